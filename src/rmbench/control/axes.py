"""A suppressor design for one or several proof-mass axes, with the plant and controller orders
each takes: one MIMO loop over all axes, or one SISO loop per axis side by side.

The orders: a single axis's plant keeps 14 states after balanced truncation and its controller
12; each further axis of a MIMO design adds 10 plant and 8 controller states.
"""

from __future__ import annotations

from dataclasses import dataclass

from rmbench.control.controller import Controller
from rmbench.control.design import controller_order, design, plant_order
from rmbench.control.experiments import measured_plant
from rmbench.control.plant import parse_axes, robot_plant
from rmbench.control.weights import Weights
from rmbench.errors import InputError

__all__ = ["AxesDesign", "design_axes"]


@dataclass(frozen=True)
class AxesDesign:
    """A controller for some proof-mass axes and what its design reached.

    Attributes
    ----------
    controller : Controller
        Its ``meta`` holds ``structure``, ``mode_hz``, ``gamma`` and ``plant_source`` besides the
        design's own entries.
    gammas : tuple of float
        Achieved H∞ norm of each loop (one for a MIMO design).
    mode_hz : tuple of float
        Frequencies of the modes each loop targets, Hz.
    structure : str
        ``"MIMO"`` or ``"SISO"``.
    """

    controller: Controller
    gammas: tuple
    mode_hz: tuple
    structure: str


def design_axes(op, axes, weights: Weights | None = None, *, mimo: bool = False, plant: str = "exact",
                order: int | None = None, modified: bool = False) -> AxesDesign:
    """Design the suppressor for ``axes`` at the operating point ``op``.

    Parameters
    ----------
    op : rmbench.robot.OperatingPoint
    axes : str or sequence of str
        Proof-mass axes (:data:`rmbench.control.AXES`), e.g. ``"tangential,axial"``.
    weights : Weights, optional
    mimo : bool
        One loop over all axes; else one SISO loop per axis (the same for a single axis).
    plant : {"exact", "measured"}
        The exact linearised robot, or the plant identified from a simulated FRF measurement
        (one mode per axis: SISO designs only).
    order : int, optional
        Controller states of each loop (default :func:`controller_order`).
    modified : bool
        The seed's modified design (:func:`rmbench.control.design`).

    Raises
    ------
    rmbench.errors.InputError
        Unknown axes or plant, or a measured plant asked for a MIMO design.
    """
    axes = parse_axes(axes)
    if plant not in ("exact", "measured"):
        raise InputError(f"plant must be 'exact' or 'measured', got {plant!r}")
    if plant == "measured" and mimo and len(axes) > 1:
        raise InputError("--plant measured identifies one mode per axis; it gives SISO designs only")

    def plant_of(ax):
        if plant == "measured":
            return measured_plant(op, ax[0])
        return robot_plant(op, ax, order=plant_order(len(ax)))

    if mimo or len(axes) == 1:
        d = design(plant_of(axes), weights, order=order or controller_order(len(axes)), modified=modified)
        ctrl, gammas, modes = d.controller, (d.gamma,), tuple(d.plant.mode_hz)
    else:
        parts = [design(plant_of((a,)), weights, order=order or controller_order(1), modified=modified)
                 for a in axes]
        ctrl = Controller.block_diagonal([p.controller for p in parts])
        gammas, modes = tuple(p.gamma for p in parts), tuple(p.plant.mode_hz[0] for p in parts)
    structure = "MIMO" if mimo else "SISO"
    gammas, modes = tuple(float(g) for g in gammas), tuple(float(f) for f in modes)
    meta = dict(ctrl.meta, q_cmd=op.q_cmd.tolist(), structure=structure, mode_hz=list(modes),
                gamma=list(gammas) if len(gammas) > 1 else gammas[0], plant_source=plant)
    ctrl = Controller(ctrl.axes, ctrl.A, ctrl.B, ctrl.C, ctrl.D, meta)
    return AxesDesign(ctrl, gammas, modes, structure)
