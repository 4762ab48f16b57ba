"""Virtual impact campaigns: many postures, run in parallel, written as they finish, resumable.

Each posture is an independent task (local worker processes by default, or the workers of an
existing dask.distributed scheduler). Its random numbers come from ``(seed, posture index)``, so results do not depend on the
number of workers or on the order of completion. Each finished posture is written at once to
``OUT.parts/``; a rerun skips the postures already there; when all are done they are assembled into
one dataset (``OUT``) and the parts are removed.
"""

from __future__ import annotations

import contextlib
import functools
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rmbench.errors import InputError, RmbenchError
from rmbench.impact.config import CampaignConfig
from rmbench.impact.measure import band_lines, exact_band, measure_band
from rmbench.impact.sensors import COORDS, sensor_set
from rmbench.parallel import map_cases
from rmbench.robot import OperatingPoint, Posture, Robot, seed_grid
from rmbench.robot.model import Band
from rmbench.robot.variant import condensed, with_tool_masses

__all__ = ["Campaign", "postures_of", "run_posture", "run_campaign", "dry_run"]


def postures_of(cfg: CampaignConfig, robot: Robot | None = None) -> list[Posture]:
    """The campaign's postures in order.

    ``robot`` and ``validation`` are the robot's own grid and validation postures (a robot built by
    ``rmbench model build`` carries them; for the stand-ins they are the seed's).
    """
    g = cfg.grid
    if g.kind == "seed":
        return seed_grid()
    if g.kind in ("robot", "validation"):
        if robot is None:
            robot = Robot.load(cfg.robot.name, tool=cfg.robot.tool)
        return robot.grid() if g.kind == "robot" else robot.validation()
    if g.kind == "product":
        return [Posture.from_mm_deg(x, y, t) for x in g.x_mm for y in g.y_mm for t in g.theta_deg]
    return [Posture.from_mm_deg(*p) for p in g.postures]


@dataclass(frozen=True)
class Campaign:
    """A validated configuration with its robot models, ready to measure postures.

    Attributes
    ----------
    config : CampaignConfig
    toml : str
        The configuration text (kept in the dataset).
    robot : Robot
        The bare robot.
    nominal : Robot or None
        The robot whose rigid-body inverse kinematics commands the postures
        (``[robot] commands_from``); None when the robot commands itself.
    """

    config: CampaignConfig
    toml: str
    robot: Robot
    nominal: Robot | None = None

    @classmethod
    def build(cls, config: CampaignConfig, toml: str = "") -> "Campaign":
        """Load the robot (and the nominal robot that commands it, if any).

        Raises
        ------
        ModelError
            For an unknown robot or tool, or a malformed MJCF.
        InputError
            If the nominal robot does not command the same arm joints as the robot under test.
        """
        r = config.robot
        robot = Robot.load(r.name, tool=r.tool, spindle_rpm=r.spindle_rpm)
        nominal = None
        if r.commands_from is not None:
            nominal = Robot.load(r.commands_from, tool=r.tool if r.tool is not None else robot.tool)
            if nominal.arm_joints != robot.arm_joints:
                raise InputError(f"commands_from robot {nominal.name!r} commands joints "
                                 f"{' '.join(nominal.arm_joints)}, the robot under test {' '.join(robot.arm_joints)}")
        return cls(config, toml, robot, nominal)

    def operating_point(self, posture: Posture) -> OperatingPoint:
        """The bare robot commanded to a posture and settled there under gravity.

        The joint commands come from the rigid-body inverse kinematics of :attr:`nominal` when
        set (what a real controller that only knows its nominal model sends; the robot under
        test may then miss the posture by its kinematic errors), else of the robot itself.

        Raises
        ------
        UnreachablePosture
            If the commanding robot cannot reach the posture.
        """
        if self.nominal is None:
            return self.robot.at(posture)
        return self.robot.at(self.nominal.ik(posture).q)

    @functools.cached_property
    def bands(self) -> dict[str, Band]:
        """Per band name, its :class:`~rmbench.robot.model.Band` (f_min, f_max in Hz, s_1a in m)."""
        return {name: Band(name, b.f_min, b.f_max, 1e-3 * b.s_1a_mm) for name, b in self.config.bands.items()}

    @functools.cached_property
    def sensors(self) -> dict:
        """Per band name, its :class:`~rmbench.impact.sensors.SensorSet`, with calibration errors
        drawn once per campaign (from the seed)."""
        rng = np.random.default_rng([self.config.seed, 1_000_003])  # calibration: once per campaign
        return {name: sensor_set(b, self.config, rng) for name, b in self.config.bands.items()}

    @functools.cached_property
    def hammer_gain(self) -> dict[str, float]:
        """Per band name, the load cell's actual over nominal sensitivity (dimensionless; 1 plus
        the band's relative calibration error times a normal draw, once per campaign)."""
        rng = np.random.default_rng([self.config.seed, 1_000_033])
        return {name: 1 + b.hammer.calibration_error * rng.standard_normal()
                for name, b in self.config.bands.items()}

    @functools.cached_property
    def tested_robots(self) -> dict[str, Robot]:
        """Per band: the robot as tested (sensor masses on the tool)."""
        out = {}
        for name, s in self.sensors.items():
            out[name] = with_tool_masses(self.robot, s.tool_masses()) if s.mass > 0 else self.robot
        return out

    @functools.cached_property
    def sim_robots(self) -> dict[str, Robot]:
        """Per band: the model that is integrated in the time domain.

        For the low band the spindle, holder and tool freedoms (0.8-28 kHz, far above the band)
        are welded and their static compliance added back to the readings; a spinning rotor
        keeps its joint, whose gyroscopic coupling moves the arm's modes (X-Y cross entries by
        2-13 % at 10 400 rev/min). The high band integrates the full robot as tested.
        """
        keep = ("spindle_spin",) if self.robot.spindle_rpm else ()
        return {name: condensed(self.tested_robots[name], ("spindle_", "tool_"), keep=keep)
                if b.sensor == "laser" else self.tested_robots[name]
                for name, b in self.config.bands.items()}

    @property
    def freq(self) -> np.ndarray:
        """Every band's frequency lines, band after band, Hz, shape (n_freq,)."""
        return np.concatenate([band_lines(b) for b in self.config.bands.values()])

    @property
    def band_of_line(self) -> np.ndarray:
        """The band name of each line of :attr:`freq`, shape (n_freq,)."""
        return np.concatenate([[name] * len(band_lines(b)) for name, b in self.config.bands.items()])


def run_posture(campaign: Campaign, index: int, posture: Posture) -> dict:
    """Measure one posture; never raises for a posture that fails (it is recorded with its reason).

    Returns
    -------
    dict
        Arrays of the posture (see :func:`rmbench.impact.dataset.posture_part`).
    """
    cfg = campaign.config
    rng = np.random.default_rng([cfg.seed, index])
    coords = tuple(cfg.hits.points)
    out = {"index": index, "posture": posture, "ok": True, "reason": "", "bands": {}, "q_cmd": None,
           "steps": 0, "overloads": 0, "seconds": 0.0}
    t0 = time.perf_counter()
    try:
        op_bare = campaign.operating_point(posture)
        out["q_cmd"] = op_bare.q_cmd
        for name, bcfg in cfg.bands.items():
            band = campaign.bands[name]
            sensors = campaign.sensors[name]
            tested = campaign.tested_robots[name]
            op_t = tested.at(op_bare.q_cmd) if tested is not campaign.robot else op_bare
            freq = band_lines(bcfg)
            h_ex, h_bare, modes, modes_bare = exact_band(op_t, op_bare, sensors, band, freq, COORDS)
            sim = campaign.sim_robots[name]
            op_sim = sim.at(op_bare.q_cmd) if cfg.method == "time" and sim is not tested else op_t
            h_ex_in = h_ex[:, :, [COORDS.index(c) for c in coords]]
            (h, coh), steps, over = measure_band(
                op_sim, op_t, sensors, bcfg, band, campaign.hammer_gain[name], cfg.hits.averages,
                coords, rng, method=cfg.method, h_exact=h_ex_in, noise_scale=cfg.noise_scale)
            if not np.all(np.isfinite(h)):
                raise RmbenchError(f"{name} band: the simulation diverged")
            out["bands"][name] = {"freq": freq, "H": _full(h, coords), "coherence": _full(coh, coords),
                                  "H_exact": h_ex, "H_exact_bare": h_bare, "modes": modes,
                                  "modes_bare": modes_bare}
            out["steps"] += steps
            out["overloads"] += over
    except RmbenchError as err:
        out.update(ok=False, reason=str(err), bands={})
    except Exception as err:  # a crash in one posture must not stop the campaign
        out.update(ok=False, reason=f"{type(err).__name__}: {err}", bands={},
                   trace=traceback.format_exc(limit=3))
    out["seconds"] = time.perf_counter() - t0
    return out


def _full(h: np.ndarray, coords) -> np.ndarray:
    """Place measured columns (hit coordinates) into the 4x4 matrix; columns not hit stay NaN."""
    full = np.full(h.shape[:2] + (4,), np.nan, dtype=h.dtype)
    for k, c in enumerate(coords):
        full[:, :, COORDS.index(c)] = h[:, :, k]
    return full


@functools.lru_cache(maxsize=4)
def _campaign_from_json(config_json: str, toml: str) -> Campaign:
    """Per-process cache: a worker builds the robot models once per campaign."""
    return Campaign.build(CampaignConfig.model_validate_json(config_json), toml)


def _task(config_json: str, toml: str, index: int, posture: tuple) -> dict:
    return run_posture(_campaign_from_json(config_json, toml), index, Posture(*posture))


def _posture_case(config_json: str, toml: str, single_threaded: bool, item: tuple) -> dict:
    """One posture ``item = (index, (x, y, theta))`` as a case of :func:`rmbench.parallel.map_cases`.

    ``single_threaded``: one thread in every pool while it runs, as in a worker process, so that
    a posture run here (one worker, or one posture left) equals one run on a worker bit for bit.
    """
    if not single_threaded:
        return _task(config_json, toml, *item)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        return _task(config_json, toml, *item)


def run_campaign(cfg: CampaignConfig, out: str | Path, *, toml: str = "", workers: int | None = None,
                 scheduler: str | None = None, progress: bool = True, force: bool = False) -> Path:
    """Run a campaign into the dataset file ``out`` (netCDF), resuming from ``out.parts/``.

    A finished dataset of the same configuration at ``out`` (:func:`is_complete`) is kept and
    nothing runs, unless ``force``.

    Parameters
    ----------
    workers : int, optional
        Local worker processes, each single-threaded (default: this command's share of the cores,
        :func:`rmbench.threads.default_workers`); 1, or a single posture left, runs single-threaded
        in this process; 0 runs in this process with its own threads.
    scheduler : str, optional
        Address of an existing dask scheduler (then ``workers`` is ignored); the postures run
        through :func:`rmbench.parallel.map_cases`.
    force : bool
        Simulate every posture again even if ``out`` is complete.
    """
    from rmbench.impact import dataset

    out = Path(out)
    built = Campaign.build(cfg, toml)  # fail fast on a bad robot or tool, before anything runs
    postures = postures_of(cfg, built.robot)
    if not postures:
        raise InputError("the posture grid is empty")
    if not force and is_complete(cfg, out, n_postures=len(postures)):
        return out
    parts = dataset.PartStore(out, cfg, n_postures=len(postures))
    todo = [i for i in range(len(postures)) if not parts.has(i)]
    config_json = cfg.model_dump_json()
    bar = _progress(len(postures), len(postures) - len(todo), progress)
    # workers=0: here, with this process's threads (the cases in order); else each posture
    # single-threaded, on local worker processes or the scheduler's cluster, written as it finishes
    case = functools.partial(_posture_case, config_json, toml, scheduler is not None or workers != 0)
    items = [(i, _tuple(postures[i])) for i in todo]
    # closing: an interrupt while a part is written cancels the postures not started at once
    with contextlib.closing(map_cases(case, items, workers=workers, scheduler=scheduler)) as done:
        for _, result in done:
            parts.write(result)
            bar.update(1)
    bar.close()
    ds = parts.assemble(toml, postures, built.robot)
    dataset.save(ds, out)
    parts.remove()
    return out


def is_complete(cfg: CampaignConfig, out: str | Path, *, n_postures: int | None = None) -> bool:
    """Whether ``out`` is a finished dataset of this configuration: the digest it was written with
    (attribute ``config_digest``) is ``cfg``'s, it has every posture, and no partial results of a
    later run lie beside it. A file that cannot be read, or of another configuration, is not."""
    import xarray as xr

    out = Path(out)
    if not out.is_file() or Path(str(out) + ".parts").exists():
        return False
    try:
        with xr.open_dataset(out, engine="h5netcdf") as ds:
            digest, n = ds.attrs.get("config_digest"), ds.sizes.get("posture")
    except Exception:  # noqa: BLE001 - any unreadable file is simply not a finished run
        return False
    if n_postures is None:
        n_postures = len(postures_of(cfg, Campaign.build(cfg).robot))
    return digest == cfg.digest and n == n_postures


def _tuple(p: Posture) -> tuple:
    return (p.x, p.y, p.theta)


def _progress(total, done, enabled):
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit="posture", disable=not enabled, desc="campaign",
                dynamic_ncols=True)


def dry_run(cfg: CampaignConfig) -> dict:
    """Validate, list the postures and estimate the work: steps to simulate and time.

    The time is extrapolated from the steps and a short timing of each band's simulator at the
    first posture.
    """
    from rmbench.robot.simulate import simulate

    campaign = Campaign.build(cfg)
    postures = postures_of(cfg, campaign.robot)
    est = {"postures": [p.label() for p in postures], "n_postures": len(postures), "bands": {}}
    op = campaign.operating_point(postures[0])
    total_s = 0.0
    for name, b in cfg.bands.items():
        tested = campaign.tested_robots[name]
        op_t = tested.at(op.q_cmd)
        if cfg.method == "linear":
            est["bands"][name] = {"steps_per_posture": 0}
            continue
        op_sim = campaign.sim_robots[name].at(op.q_cmd)
        from rmbench.impact.measure import _decay_time, integrator_of, substeps

        sub = substeps(op_sim, b)
        n_samp = min(int(round(b.sample_rate / b.line_spacing)),
                     int(np.ceil(_decay_time(op_t, campaign.bands[name], b.decay) * b.sample_rate)))
        steps = n_samp * sub * len(cfg.hits.points) * cfg.hits.averages
        t0 = time.perf_counter()
        simulate(op_sim, np.zeros((2000, op_sim.robot.model.nv)), dt=1.0 / (b.sample_rate * sub),
                 integrator=integrator_of(b))
        rate = 2000 / (time.perf_counter() - t0)
        est["bands"][name] = {"steps_per_posture": steps, "dt": 1.0 / (b.sample_rate * sub),
                              "steps_per_s": rate}
        total_s += steps / rate
    est["steps_total"] = sum(v["steps_per_posture"] for v in est["bands"].values()) * len(postures)
    est["estimated_core_seconds"] = total_s * len(postures)
    return est
