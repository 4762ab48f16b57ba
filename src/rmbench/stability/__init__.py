"""Milling stability (METHODS.md §10; issue 17).

Stability lobes of 2-DOF milling with multi-mode, cross-coupled tool-tip dynamics: the
full-discretisation method (Ding et al. 2010), the semi-discretisation method (Insperger & Stépán)
as its independent check, and the zero-order approximation (Altintas & Budak) with the full
oriented FRF matrix::

    from rmbench.stability import BENCHMARK, Structure, lobes
    d = lobes(Structure.sdof(0.03993, 922, 0.011), BENCHMARK, speeds_rpm, depths_m, method="fdm")
    d.speed_rpm, d.a_lim                     # critical depth of the lowest lobe per speed, m
"""

from rmbench.stability.cutting import ALUMINIUM_6061, BENCHMARK, Cutting
from rmbench.stability.fdm import fdm_spectral_radius
from rmbench.stability.grids import DEPTH_MAX, SPEED_RANGES, benchmark_structure, depth_grid, speed_grid
from rmbench.stability.lobes import METHODS, Lobes, compare_lobes, lobes, lowest_envelope
from rmbench.stability.sdm import sdm_spectral_radius
from rmbench.stability.structure import Structure
from rmbench.stability.zoa import zoa_limit, zoa_limits, zoa_lobes

__all__ = ["Cutting", "BENCHMARK", "ALUMINIUM_6061", "Structure", "Lobes", "lobes", "lowest_envelope", "compare_lobes",
           "METHODS", "fdm_spectral_radius", "sdm_spectral_radius", "zoa_lobes", "zoa_limit", "zoa_limits", "speed_grid", "depth_grid",
           "benchmark_structure", "SPEED_RANGES", "DEPTH_MAX"]
