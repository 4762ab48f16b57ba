"""Milling stability (METHODS.md §10; issue 17).

Stability lobes of 2-DOF milling with multi-mode, cross-coupled tool-tip dynamics: the
full-discretisation method (Ding et al. 2010), the semi-discretisation method (Insperger & Stépán)
as its independent check, and the zero-order approximation (Altintas & Budak) with the full
oriented FRF matrix::

    from rmbench.stability import BENCHMARK, Structure, lobes
    d = lobes(Structure.sdof(0.03993, 922, 0.011), BENCHMARK, speeds_rpm, depths_m, method="fdm")
    d.speed_rpm, d.a_lim                     # critical depth of the lowest lobe per speed, m

The model works in the cut's frame (x along the feed); :func:`to_cut_frame` turns a tool tip's
base-axes receptance or residues to a feed heading. Cuts: the solver benchmark, aluminium at high
speed (:data:`ALUMINIUM_6061`), steel and titanium at low speed (:data:`STEEL_C45`, :data:`TI6AL4V`;
``SPEED_RANGES["low"]``). :func:`cutting_force` gives the force history of a rigid tool (with a
tooth's runout), e.g. as a disturbance on a moving robot.
"""

from rmbench.stability.cutting import ALUMINIUM_6061, BENCHMARK, STEEL_C45, TI6AL4V, Cutting
from rmbench.stability.fdm import fdm_spectral_radius
from rmbench.stability.forces import cutting_force, tooth_force
from rmbench.stability.frame import feed_rotation, to_cut_frame
from rmbench.stability.grids import DEPTH_MAX, SPEED_RANGES, benchmark_structure, depth_grid, speed_grid
from rmbench.stability.lobes import METHODS, Lobes, compare_lobes, lobes, lowest_envelope
from rmbench.stability.sdm import sdm_spectral_radius
from rmbench.stability.structure import Structure
from rmbench.stability.zoa import zoa_limit, zoa_limits, zoa_lobes

__all__ = ["Cutting", "BENCHMARK", "ALUMINIUM_6061", "STEEL_C45", "TI6AL4V", "Structure", "Lobes", "lobes",
           "lowest_envelope", "compare_lobes", "METHODS", "fdm_spectral_radius", "sdm_spectral_radius", "zoa_lobes",
           "zoa_limit", "zoa_limits", "feed_rotation", "to_cut_frame", "speed_grid", "depth_grid",
           "benchmark_structure", "SPEED_RANGES", "DEPTH_MAX", "cutting_force", "tooth_force"]
