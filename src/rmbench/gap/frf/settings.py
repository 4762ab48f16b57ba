"""How hard the FRF gap diagnosis searches (:class:`DiagnosisSettings`), and which of the effect
library's kinds are left to search once ordinary parameter groups are calibrated
(:func:`structural_kinds`)."""

from __future__ import annotations

from dataclasses import dataclass

from rmbench.gap.selection import SearchSettings

__all__ = ["DiagnosisSettings", "structural_kinds"]


@dataclass(frozen=True)
class DiagnosisSettings(SearchSettings):
    """How hard the diagnosis searches: :class:`~rmbench.gap.selection.SearchSettings` (held-out
    share of the postures, every other one in (θ, x, y) order at 0.5; refinement by
    re-simulation; noise test; bootstrap; kinds) and

    Attributes
    ----------
    pairs_of : int
        When no single effect explains the gap, this many second effects (the best of a screening
        on top of each of the two best singles) are paired with each and refined; none with
        ``calibrate`` (a verdict there rests on a recalibration with one effect freed).
    max_train : int
        Most training postures used by the screening and the refinement (spread evenly).
    max_held : int
        Most held-out postures the candidates are scored on (spread evenly); postures beyond
        ``max_train + max_held`` enter the gap map and the significance test only.
    calibrate : tuple of str or None
        Parameter groups (:mod:`rmbench.robot.parameters`) calibrated on the training postures
        before the search (:mod:`rmbench.calibrate`); the search then runs on the calibrated
        model, for the structural effects only (the library's kinds other than the gearboxes',
        their damping's and the servos': a foundation or tool holder far outside its ordinary
        spread stays a candidate), each fitted jointly with the ordinary parameters
        (:mod:`rmbench.gap.frf.joint`).
    min_shrink : float
        Least held-out shrink of the rms normalised gap for an effect to be called the
        explanation: one that brings the gap to the noise only because the gap was small
        explains little.
    confirm : int
        With ``calibrate``, when the joint search explains nothing: how many of the kinds that
        map onto model parameters (tool holder, spindle bearings, foundation, a body's mass) are
        confirmed by a full recalibration with their best candidate in place, against a null
        recalibration (:mod:`rmbench.gap.frf.confirm`); 0 for none.
    """

    pairs_of: int = 3
    max_train: int = 16
    max_held: int = 32
    calibrate: tuple | None = None
    min_shrink: float = 0.5
    confirm: int = 4


# library kinds an ordinary-parameter group already fits (a foundation and a tool holder can be
# far outside their ordinary spread, a structural fault: their kinds stay in the search, fitted
# jointly with the calibrated parameters)
_COVERED = {"joints": "joint_stiffness", "damping": "joint_damping", "servo": "servo_stiffness"}


def structural_kinds(groups) -> tuple:
    """The library's kinds left to search once ``groups`` are calibrated."""
    from rmbench.gap.frf.effects import KINDS

    covered = {_COVERED[g] for g in groups if g in _COVERED}
    return tuple(k for k in KINDS if k not in covered)
