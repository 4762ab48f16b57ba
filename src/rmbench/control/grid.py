"""Schedule grids and the shaker campaigns over them: the TOML a user writes, the measurements a
scheduled design reads (METHODS.md §8, one design per grid posture).

A grid file (validated before anything runs; unknown keys are errors)::

    robot = "mh180"            # the nominal robot: postures, reaction masses
    axes = ["tangential", "axial"]
    mimo = true                # one design over the axes; false: one SISO loop per axis
    hold = "j5"                # joint turned against the scheduled ones ("" for none)
    duration = 64.0            # s of random force per shaker test
    reach = 5.0                # degrees beyond the grid's edges the schedule still holds (optional)
    [joints]                   # scheduled joints and their grid angles, degrees (>= 2, increasing)
    j2 = [-10, 0, 10, 20]
    j3 = [-10, 3.333, 16.667, 30]
    [span]                     # optional: how far each unscheduled joint may depart, degrees
    j1 = 180                   # (a joint not named here must stay at the schedule's posture)
    j4 = 15

Unscheduled joints sit at the robot's reference posture. ``reach`` and ``span`` say where the
designed schedule vouches for its loop (:class:`~rmbench.control.schedule.Schedule`); outside them
it refuses the posture with a message. Without them it holds its edge anywhere. A campaign
(:func:`measure_campaign`) is a dataset of 2 × 2 (or n × n) accelerance matrices, one per grid
posture, saved like an impact campaign (netCDF, complex ``H``); :func:`plants_from_campaign` fits
each (:func:`~rmbench.control.identify.plant_from_frf_matrix`) with the reaction masses the
campaign recorded, so a design needs the measurements and nothing of the robot's truth.
"""

from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import xarray as xr
from pydantic import BaseModel, ConfigDict, Field, field_validator

from rmbench.control.design import plant_order
from rmbench.control.experiments import measure_accelerance_matrix
from rmbench.control.identify import plant_from_frf_matrix
from rmbench.control.plant import AXES, Plant, ReactionMass, reaction_mass, robot_plant
from rmbench.control.schedule import grid_posture
from rmbench.errors import InputError

__all__ = ["ScheduleGrid", "load_schedule_grid", "measure_campaign", "plants_from_campaign", "plants_from_model"]

CAMPAIGN_KIND = "shaker_campaign"


class ScheduleGrid(BaseModel):
    """A schedule's grid (see the module docstring). Angles in degrees, as the file gives them."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    robot: str = "mh180"
    axes: tuple[str, ...] = ("tangential",)
    mimo: bool = True
    hold: str = ""
    duration: float = Field(64.0, ge=24.0)  # s: three 8 s segments at least (the first is dropped)
    joints: dict[str, list[float]]
    reach: float | None = Field(None, ge=0.0)
    span: dict[str, float] | None = None

    @field_validator("axes")
    @classmethod
    def _axes(cls, v):
        if not v or any(a not in AXES for a in v) or len(set(v)) != len(v):
            raise ValueError(f"axes must be distinct names from {', '.join(AXES)}")
        return v

    @field_validator("joints")
    @classmethod
    def _joints(cls, v):
        if not v:
            raise ValueError("name at least one scheduled joint, e.g. j2 = [-10, 0, 10]")
        for name, angles in v.items():
            if len(angles) < 2 or np.any(np.diff(angles) <= 0):
                raise ValueError(f"{name}: at least two increasing angles (degrees)")
        return v

    @field_validator("span")
    @classmethod
    def _span(cls, v):
        if v is not None and any(not np.isfinite(a) or a < 0 for a in v.values()):
            raise ValueError("span: one non-negative angle (degrees) per named joint")
        return v

    def limits(self, robot) -> tuple[tuple[float, ...] | None, tuple[float, ...] | None]:
        """The schedule's ``reach`` (per scheduled joint) and ``span`` (per arm joint), rad, on
        ``robot`` (None where the file gives none); a joint of ``span`` the arm lacks, or a
        scheduled joint in it, is an error."""
        arm = list(robot.arm_joints)
        reach = None if self.reach is None else (float(np.radians(self.reach)),) * len(self.joints)
        if self.span is None:
            return reach, None
        for name in self.span:
            if name not in arm:
                raise InputError(f"span names joint {name!r}; the robot's arm joints are {', '.join(arm)}")
            if name in self.joints:
                raise InputError(f"span names {name}, a scheduled joint: its range is the grid and the reach")
        return reach, tuple(float(np.radians(self.span.get(name, 0.0))) for name in arm)

    def resolve(self, robot) -> tuple[tuple[int, ...], tuple[np.ndarray, ...], int | None, np.ndarray]:
        """Joint indices, grid angles (rad), hold joint index and reference posture (rad) on ``robot``.

        Raises
        ------
        InputError
            A joint the robot's arm does not have, or a grid posture outside its joint limits.
        """
        from rmbench.robot.suppressor import reference_q

        arm = list(robot.arm_joints)
        for name in list(self.joints) + ([self.hold] if self.hold else []):
            if name not in arm:
                raise InputError(f"the schedule names joint {name!r}; the robot's arm joints are {', '.join(arm)}")
        idx = tuple(arm.index(n) for n in self.joints)
        grid = tuple(np.radians(np.asarray(a, float)) for a in self.joints.values())
        hold = arm.index(self.hold) if self.hold else None
        q_ref = reference_q(robot)
        lo, hi = robot.limits[:, 0], robot.limits[:, 1]
        mesh = np.meshgrid(*grid, indexing="ij")
        for s in np.stack([m.ravel() for m in mesh], axis=1):
            q = grid_posture(q_ref, idx, s, hold)
            bad = np.flatnonzero((q < lo - 1e-9) | (q > hi + 1e-9))
            if len(bad):
                j = int(bad[0])
                raise InputError(f"grid posture {np.round(np.degrees(s), 3).tolist()} deg puts {arm[j]} at "
                                 f"{np.degrees(q[j]):.1f} deg, outside its limits "
                                 f"[{np.degrees(lo[j]):.1f}, {np.degrees(hi[j]):.1f}]")
        return idx, grid, hold, q_ref

    def postures(self, robot) -> tuple[np.ndarray, np.ndarray]:
        """Scheduling variables (n, n_s) and arm postures (n, n_arm) of the grid, rad, C order."""
        idx, grid, hold, q_ref = self.resolve(robot)
        mesh = np.meshgrid(*grid, indexing="ij")
        S = np.stack([m.ravel() for m in mesh], axis=1)
        return S, np.array([grid_posture(q_ref, idx, s, hold) for s in S])


def load_schedule_grid(path) -> ScheduleGrid:
    """Parse and validate a grid TOML file, or a bundled one by name (one-line errors naming the key)."""
    from rmbench.control.tune import load_toml_model

    return load_toml_model(path, ScheduleGrid, "schedule grid")


def measure_campaign(robot, grid: ScheduleGrid, *, seed: int = 0, progress=None) -> xr.Dataset:
    """Shaker tests (:func:`~rmbench.control.experiments.measure_accelerance_matrix`) at every grid posture.

    Returns
    -------
    xarray.Dataset
        ``H`` (posture, freq, out, in), complex, m/s²/N; ``s_deg`` (posture, joint) and ``q_deg``
        (posture, arm_joint); attributes: the grid (JSON), the reaction masses, the robot's name.
    """
    from rmbench.impact.dataset import DATASET_VERSION

    S, Q = grid.postures(robot)
    H = []
    for k, q in enumerate(Q):
        freq, h, _ = measure_accelerance_matrix(robot.at(q), grid.axes, duration=grid.duration, seed=seed + k)
        H.append(h)
        if progress is not None:
            progress(k)
    masses = [reaction_mass(robot.model, a) for a in grid.axes]
    return xr.Dataset(
        {"H": (("posture", "freq", "out", "in"), np.array(H))},
        coords={"posture": np.arange(len(Q)), "freq": freq, "out": list(grid.axes), "in": list(grid.axes),
                "joint": list(grid.joints), "arm_joint": list(robot.arm_joints),
                "s_deg": (("posture", "joint"), np.degrees(S)), "q_deg": (("posture", "arm_joint"), np.degrees(Q))},
        attrs={"kind": CAMPAIGN_KIND, "robot": robot.name, "grid": grid.model_dump_json(),
               "reaction_masses": json.dumps([asdict(m) for m in masses]),
               "rmbench_dataset_version": DATASET_VERSION})


def plants_from_campaign(ds: xr.Dataset) -> tuple[ScheduleGrid, list[Plant]]:
    """The grid and one fitted plant per grid posture of a shaker campaign (:func:`measure_campaign`)."""
    if ds.attrs.get("kind") != CAMPAIGN_KIND:
        raise InputError(f"not a shaker campaign (kind {ds.attrs.get('kind')!r}); make one with "
                         "'rmbench control measure'")
    grid = ScheduleGrid(**json.loads(ds.attrs["grid"]))
    masses = [ReactionMass(**m) for m in json.loads(ds.attrs["reaction_masses"])]
    freq = ds.freq.values
    return grid, [plant_from_frf_matrix(freq, ds.H.values[k], masses, grid.axes) for k in range(ds.sizes["posture"])]


def plants_from_model(robot, grid: ScheduleGrid) -> list[Plant]:
    """One plant per grid posture from a model's exact linearisation (a calibrated robot's MJCF),
    reduced by balanced truncation as the single-posture designs are."""
    _, Q = grid.postures(robot)
    return [robot_plant(robot.at(q), grid.axes, order=plant_order(len(grid.axes))) for q in Q]
