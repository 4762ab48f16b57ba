"""Controller tuning runs: a grid of weights × postures, designed and scored in parallel.

A TOML file (validated before anything runs; unknown keys are errors)::

    robot = "mh180"                 # bundled name or MJCF path
    axes = ["tangential"]           # one axis: SISO; several: one MIMO design
    modified = false
    evaluate = "mujoco"             # "mujoco": stepped sines in closed loop; "linear": analysis only
    mode_ratios = [0.8, 1.0, 1.2]   # evaluation postures: the first axis's mode moved by these ratios
    amplitude = 20.0                # N, disturbance sine
    [weights]                       # each key a list: the grid is their product
    k_a = [20.0, 40.0]
    zeta_w = [0.25, 0.4]

Every case is designed at the robot's reference posture and scored at each evaluation posture:
reduction of the acceleration sensitivity peak at the mode (MuJoCo stepped sines at 7 frequencies
across ±15 % of the mode, or the linear analysis), stability, and from the linear analysis over
1-100 Hz the largest amplification above twice the mode (dB), the stroke used (fraction of
±stroke at ``amplitude``) and the peak force (N at ``amplitude``).
"""

from __future__ import annotations

import itertools
import tomllib
from pathlib import Path
from typing import Literal

import numpy as np
import xarray as xr
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from rmbench.control.analysis import is_stable, reduction, sensitivity
from rmbench.control.design import DesignError, design
from rmbench.control.plant import AXES, reaction_mass, robot_plant
from rmbench.control.weights import Weights
from rmbench.errors import InputError

__all__ = ["TuneConfig", "load_tune_config", "tune", "tune_table"]


class TuneConfig(BaseModel):
    """A tuning run (see the module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    robot: str = "mh180"
    axes: tuple[str, ...] = ("tangential",)
    modified: bool = False
    evaluate: Literal["mujoco", "linear"] = "mujoco"
    mode_ratios: tuple[float, ...] = (0.8, 1.0, 1.2)
    amplitude: float = Field(20.0, gt=0)
    plant_order: int = Field(14, ge=4)
    controller_order: int = Field(12, ge=2)
    weights: dict[str, list[float]] = Field(default_factory=dict)

    @field_validator("axes")
    @classmethod
    def _axes(cls, v):
        bad = [a for a in v if a not in AXES]
        if bad or not v:
            raise ValueError(f"axes must be names from {', '.join(AXES)}")
        return v

    @field_validator("mode_ratios")
    @classmethod
    def _ratios(cls, v):
        if not v or any(r <= 0 for r in v):
            raise ValueError("mode_ratios must be positive numbers")
        return v

    @field_validator("weights")
    @classmethod
    def _weights(cls, v):
        known = set(Weights.__dataclass_fields__)
        for k, vals in v.items():
            if k not in known:
                raise ValueError(f"unknown weight {k!r}; known: {', '.join(sorted(known))}")
            if not vals:
                raise ValueError(f"weight {k!r} has an empty list")
        return v

    def cases(self) -> list[Weights]:
        names = sorted(self.weights)
        return [Weights().with_(**dict(zip(names, combo)))
                for combo in itertools.product(*(self.weights[n] for n in names))]


def load_toml_model(path, model: type[BaseModel], what: str):
    """A TOML file (or a bundled one in ``control/configs`` by name) parsed into ``model``, with
    one-line errors naming the file and the offending key."""
    bundled = Path(__file__).parent / "configs" / f"{path}.toml"
    path = bundled if not str(path).endswith(".toml") and bundled.exists() else Path(path)
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"no {what} {path}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: not valid TOML ({err})") from None
    try:
        return model(**raw)
    except ValidationError as err:
        e = err.errors()[0]
        where = ".".join(str(x) for x in e["loc"]) or what
        raise InputError(f"{path}: {where}: {e['msg']}") from None


def load_tune_config(path) -> TuneConfig:
    """Parse and validate a tuning TOML file, or a bundled one by name (one-line errors naming the key)."""
    cfg = load_toml_model(path, TuneConfig, "tuning config")
    cfg.cases()
    return cfg


def _case(robot_xml, name, q_ref, q_eval, axes, weights, cfg_json):
    """Design one weight set at the reference posture; score it at every evaluation posture."""
    from rmbench.control.experiments import reduction_at, sine_sweep
    from rmbench.robot import Robot

    cfg = TuneConfig.model_validate_json(cfg_json)
    robot = Robot(robot_xml, name=name, tool=None)
    op0 = robot.at(np.asarray(q_ref))
    out = {"gamma": np.nan, "reason": "", "rows": []}
    try:
        d = design(robot_plant(op0, axes, order=cfg.plant_order), weights, order=cfg.controller_order,
                   modified=cfg.modified)
    except DesignError as err:
        out["reason"] = str(err)
        return out
    out["gamma"] = d.gamma
    K = d.controller
    for q in q_eval:
        op = robot.at(np.asarray(q))
        P = robot_plant(op, axes)
        f = np.geomspace(1.0, 100.0, 1500)
        o, c = sensitivity(P, None, f), sensitivity(P, K, f)
        row = {"stable": is_stable(P, K), "mode_hz": P.mode_hz[0]}
        reds, amps = [], []
        for i in range(len(axes)):
            om, cm = np.abs(o["acc"][:, i, i]), np.abs(c["acc"][:, i, i])
            reds.append(reduction(f, om, cm, P.mode_hz[i]))
            amps.append(float(20 * np.log10(np.max((cm / om)[f > 2 * P.mode_hz[i]]))))
        row["reduction_linear"] = reds
        row["amplification_db"] = amps
        row["stroke_used"] = float(cfg.amplitude * np.abs(c["pos"]).max() / reaction_mass(op.robot.model, axes[0]).stroke)
        row["force_max"] = float(cfg.amplitude * np.abs(c["force"]).max())
        row["reduction"] = list(reds)
        if cfg.evaluate == "mujoco" and row["stable"]:
            # stepped sines on the first axis around its mode, uncontrolled and controlled
            f0 = P.mode_hz[0]
            fs = f0 * np.linspace(0.85, 1.15, 7)
            base = sine_sweep(op, None, axes[0], fs, amplitude=cfg.amplitude, workers=0)
            ctl = sine_sweep(op, K, axes[0], fs, amplitude=cfg.amplitude, workers=0)
            row["stable"] = bool(ctl.ok.all())
            if row["stable"]:
                row["reduction"][0] = reduction_at(base, ctl, axes[0], f0)
        out["rows"].append(row)
    return out


def tune(cfg: TuneConfig, *, workers: int | None = None, scheduler=None, progress: bool = False) -> xr.Dataset:
    """Run a tuning grid; returns a Dataset over (case, ratio) with the scores and the weights."""
    from rmbench.control.experiments import _run
    from rmbench.control.postures import posture_for_mode_ratio
    from rmbench.robot import Robot
    from rmbench.robot.suppressor import reference_q

    robot = Robot.load(cfg.robot)
    q_ref = reference_q(robot)
    q_eval = [q_ref if r == 1.0 else posture_for_mode_ratio(robot, q_ref, r, axis=cfg.axes[0])
              for r in cfg.mode_ratios]
    cases = cfg.cases()
    tasks = [(_case, (robot.xml, robot.name, q_ref, q_eval, cfg.axes, w, cfg.model_dump_json()))
             for w in cases]
    res = _run(tasks, workers, scheduler, progress, "tune")
    n_c, n_r, n_a = len(cases), len(cfg.mode_ratios), len(cfg.axes)
    red = np.full((n_c, n_r, n_a), np.nan)
    red_lin = np.full((n_c, n_r, n_a), np.nan)
    amp = np.full((n_c, n_r, n_a), np.nan)
    stable = np.zeros((n_c, n_r), bool)
    stroke = np.full((n_c, n_r), np.nan)
    force = np.full((n_c, n_r), np.nan)
    mode = np.full((n_c, n_r), np.nan)
    for i, r in enumerate(res):
        for j, row in enumerate(r["rows"]):
            red[i, j], red_lin[i, j], amp[i, j] = row["reduction"], row["reduction_linear"], row["amplification_db"]
            stable[i, j], stroke[i, j], force[i, j] = row["stable"], row["stroke_used"], row["force_max"]
            mode[i, j] = row["mode_hz"]
    ds = xr.Dataset({"reduction": (("case", "ratio", "axis"), red),
                     "reduction_linear": (("case", "ratio", "axis"), red_lin),
                     "amplification_db": (("case", "ratio", "axis"), amp),
                     "stable": (("case", "ratio"), stable), "stroke_used": (("case", "ratio"), stroke),
                     "force_max": (("case", "ratio"), force), "mode_hz": (("case", "ratio"), mode),
                     "gamma": ("case", np.array([r["gamma"] for r in res])),
                     "reason": ("case", np.array([r["reason"] for r in res], dtype=object))},
                    coords={"case": np.arange(n_c), "ratio": list(cfg.mode_ratios), "axis": list(cfg.axes)})
    for name in sorted(cfg.weights):
        ds[name] = ("case", np.array([getattr(w, name) for w in cases]))
    ds.attrs.update(config=cfg.model_dump_json(), evaluate=cfg.evaluate)
    return ds


def tune_table(ds: xr.Dataset, cfg: TuneConfig) -> list[dict]:
    """One row per case of a :func:`tune` result: its ``weights``, ``gamma``, ``reason`` (why the
    design failed, else ""), and over the postures the smallest ``reduction_min`` (None unless
    stable at all), ``stable_all``, the largest ``stroke_used_max`` (fraction of ±stroke),
    ``force_max`` (N) and ``amplification_db_max``."""
    rows = []
    for c in ds.case.values:
        w = {k: float(ds[k].sel(case=c)) for k in sorted(cfg.weights)}
        r = ds.sel(case=c)
        rows.append({"weights": w, "gamma": float(r.gamma), "reason": str(r.reason.values),
                     "reduction_min": float(np.nanmin(r.reduction.values)) if r.stable.all() else None,
                     "stable_all": bool(r.stable.all()), "stroke_used_max": float(np.nanmax(r.stroke_used)),
                     "force_max": float(np.nanmax(r.force_max)),
                     "amplification_db_max": float(np.nanmax(r.amplification_db))})
    return rows
