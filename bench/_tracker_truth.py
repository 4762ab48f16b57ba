"""Blind "real" MH180s for the tracker calibration bench (issue 43), built by code other than the
diagnosis's pose model: the nominal MJCF edited as text (every flexible joint's stiffness × U(0.7,
1.3), every body placement ± 0.5 mm along it, every link mass ± 10 %), then measured by the tracker
simulator (:class:`rmbench.tracker.simulator.TrackerSimulator`, its own chain and error draws) with
its random error sources switched off. Half also carry one structural source, injected through
the simulator's own error model: a payload at the TCP, a gear harmonic on one joint, a reflector
(TCP) offset, or thermal drift (the arm expands about its base in proportion to the hours since
the first reading); some carry one outside the diagnosis's library: backlash (the link lags the
motor by a fixed angle against the direction the joint last moved in) or a link whose stiffness
depends on the direction it is loaded in. :func:`scaled` enlarges a source that the readings
cannot tell from the spread (the bench's visibility rule, ``bench/gap_tracker.py``).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

from rmbench.robot import Robot
from rmbench.tracker import MH180_CALIBRATION_BOX, MH180_JOINT_BOX, sobol_points
from rmbench.tracker.simulator import ErrorDistribution, TrackerSimulator

STRUCTURAL = ("payload", "gear_periodic_error", "frame_error", "thermal_drift")
OUT_OF_LIBRARY = ("backlash", "directional_stiffness")
_ZERO = ErrorDistribution(offset_sd=0.0, length_sd=0.0, twist_sd=0.0, tool_sd=0.0, stiffness_sd=0.0,
                          mass_sd=0.0, payload=(0.0, 0.0), gear_amplitude=(0.0, 0.0))


def spread_xml(xml: str, rng: np.random.Generator) -> tuple[str, dict]:
    """The MJCF with every flexible joint's stiffness, body placement and link mass drawn."""
    truth = {}

    def stiffness(m):
        f = float(rng.uniform(0.7, 1.3))
        truth[f"{m.group(1)}.stiffness"] = f
        return f'{m.group(0)[:m.start(3) - m.start(0)]}{float(m.group(3)) * f:.9g}"'

    xml = re.sub(r'<joint name="(j\d_flex)"([^>]*?)stiffness="([0-9.eE+-]+)"', stiffness, xml)

    def placement(m):
        v = np.array([float(x) for x in m.group(2).split()])
        n = np.linalg.norm(v)
        if n < 1e-9:
            return m.group(0)
        d = float(rng.uniform(-0.5e-3, 0.5e-3))
        truth[f"{m.group(1)}.length"] = d
        v = v * (1 + d / n)
        return f'<body name="{m.group(1)}" pos="{" ".join(f"{x:.9g}" for x in v)}"'

    xml = re.sub(r'<body name="(motor\d)" pos="([^"]+)"', placement, xml)

    def mass(m):
        f = float(rng.uniform(0.9, 1.1))
        return f'{m.group(1)}mass="{float(m.group(2)) * f:.9g}"'

    xml = re.sub(r'(<inertial pos="[^"]*" )mass="([0-9.eE+-]+)"', lambda m: mass(m) if float(m.group(2)) > 5 else m.group(0), xml)
    return xml, truth


def draw_structural(rng: np.random.Generator, in_library: bool, n_joint: int) -> dict:
    """One structural source: kind, location (the diagnosis's naming) and size."""
    if in_library:
        kind = STRUCTURAL[int(rng.integers(len(STRUCTURAL)))]
        if kind == "payload":
            return {"kind": kind, "location": "tool", "mass": float(rng.uniform(10, 25))}
        if kind == "gear_periodic_error":
            j = int(rng.integers(1, n_joint))
            return {"kind": kind, "location": f"j{j + 1}:h1", "joint": j,
                    "amplitude": float(rng.uniform(80e-6, 150e-6)), "phase": float(rng.uniform(0, 2 * np.pi))}
        if kind == "thermal_drift":     # a warming arm: 20-60 µm per metre and hour
            return {"kind": kind, "location": "time", "per_hour": float(rng.uniform(2e-5, 6e-5))}
        v = rng.normal(size=3)
        return {"kind": kind, "location": "tool", "offset": (float(rng.uniform(1.5e-3, 3e-3)) * v / np.linalg.norm(v)).tolist()}
    kind = OUT_OF_LIBRARY[int(rng.integers(len(OUT_OF_LIBRARY)))]
    j = int(rng.integers(1, n_joint))
    if kind == "backlash":
        return {"kind": kind, "location": f"j{j + 1}", "joint": j, "angle": float(rng.uniform(100e-6, 200e-6))}
    # the joint is stiffer (×1.6-2.2) when the gravity torque on it is positive than when negative;
    # seen only where that torque changes sign over the campaign (the wrist, mostly)
    return {"kind": kind, "location": f"j{j + 1}", "joint": j, "ratio": float(rng.uniform(1.6, 2.2))}


def scaled(source: dict, factor: float) -> dict:
    """``source`` with its size times ``factor``: the mass, amplitude, offset, expansion rate or
    backlash angle; a directional stiffness's excess ratio ``ratio - 1``."""
    out = dict(source)
    if source["kind"] == "directional_stiffness":
        out["ratio"] = 1.0 + (source["ratio"] - 1.0) * factor
        return out
    key = {"payload": "mass", "gear_periodic_error": "amplitude", "frame_error": "offset",
           "thermal_drift": "per_hour", "backlash": "angle"}[source["kind"]]
    out[key] = (np.asarray(source[key]) * factor).tolist() if key == "offset" else source[key] * factor
    return out


class SpreadRobot:
    """A drawn MH180 measured by the tracker simulator (structural source included)."""

    def __init__(self, xml: str, source: dict | None, rng: np.random.Generator, tool=None):
        self.robot = Robot(xml, name="truth", tool=tool)
        sim = TrackerSimulator.from_robot(self.robot, rng, distribution=_ZERO)
        hidden, chain = sim.hidden, sim.true_chain
        if source is not None and source["kind"] == "payload":
            chain = chain.with_payload(source["mass"], sim.nominal.tool_translation)
            hidden = dataclasses.replace(hidden, payload_mass=source["mass"])
        elif source is not None and source["kind"] == "frame_error":
            tw = hidden.twists.copy()
            tw[-1, :3] = source["offset"]
            chain = sim.nominal.perturbed(tw).with_mass_scale(hidden.mass_scale)
            hidden = dataclasses.replace(hidden, twists=tw)
        elif source is not None and source["kind"] == "gear_periodic_error":
            amp, phase = np.zeros_like(hidden.gear_amplitude), np.zeros_like(hidden.gear_phase)
            amp[source["joint"], 0], phase[source["joint"], 0] = source["amplitude"], source["phase"]
            hidden = dataclasses.replace(hidden, gear_amplitude=amp, gear_phase=phase)
        self.sim = dataclasses.replace(sim, hidden=hidden, true_chain=chain)
        self.source = source

    def _angles(self, q, previous, joint_noise=None):
        sim, s = self.sim, self.source
        ql = np.asarray(q, float) + (0 if joint_noise is None else joint_noise)
        ql = ql + sim.hidden.offsets + sim.hidden.gear_error(ql)
        if s is not None and s["kind"] == "backlash":
            j = s["joint"]
            ql[:, j] -= s["angle"] * np.sign(np.asarray(q)[:, j] - np.asarray(previous)[:, j])
        k = np.broadcast_to(sim.hidden.stiffness, ql.shape).copy()
        defl = np.zeros_like(ql)
        for _ in range(2):
            tau = sim.true_chain.gravity_torque(ql + defl)
            if s is not None and s["kind"] == "directional_stiffness":
                j = s["joint"]
                k[:, j] = np.where(tau[:, j] > 0, sim.hidden.stiffness[j] * s["ratio"], sim.hidden.stiffness[j])
            defl = tau / k
        return ql + defl

    def positions(self, q, previous, t, rng=None) -> np.ndarray:
        """Tracker-frame TCP positions (n, 3), m, of commands ``q`` read at ``t`` (s since the
        first reading): noise-free, or measured with ``rng``."""
        sim, s = self.sim, self.source
        noise = None if rng is None else rng.normal(size=np.shape(q)) * sim.joint_sigma
        rot, trans = sim.base_in_tracker
        p_base = sim.true_chain.position(self._angles(q, previous, noise))
        if s is not None and s["kind"] == "thermal_drift":
            p_base = p_base * (1.0 + s["per_hour"] * np.asarray(t, float) / 3600.0)[:, None]
        p = p_base @ rot.T + trans
        if rng is not None:
            p = p + rng.normal(size=p.shape) * sim.tracker.sigma(np.linalg.norm(p, axis=-1))[..., None]
        return p


BOXES = {"calibration": MH180_CALIBRATION_BOX, "machining": MH180_JOINT_BOX}
"""The campaigns' joint ranges: every joint swept as far as the cell allows (kinematic
calibration's practice), or the machining region in front of the robot."""


def campaign(rng: np.random.Generator, n_config: int = 250, repeats: int = 2, box: str = "calibration"):
    """Commands, their order (configuration labels) and the configuration each reading came from,
    ``n_config`` quasi-random configurations of the joint ranges ``BOXES[box]``."""
    lo, hi = BOXES[box]
    q_conf = sobol_points(n_config, lo, hi, rng)
    order = np.concatenate([rng.permutation(n_config) for _ in range(repeats)])
    q = q_conf[order]
    return q, order, np.vstack([q[:1], q[:-1]])
