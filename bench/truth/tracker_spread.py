"""The spread MH180s of ``bench/gap_tracker.py`` (issue 43): the ordinary spread of
:func:`truth.tracker.spread_xml` (the nominal MJCF edited as text), measured by the tracker
simulator (:class:`rmbench.tracker.simulator.TrackerSimulator`, its own chain and error draws) with
its random error sources switched off. Half also carry one structural source, injected through
the simulator's own error model: a payload at the TCP, a gear harmonic on one joint, a reflector
(TCP) offset, or thermal drift (the arm expands about its base in proportion to the hours since
the first reading); some carry one outside the diagnosis's library: backlash (the link lags the
motor by a fixed angle against the direction the joint last moved in) or a link whose stiffness
depends on the direction it is loaded in.

Unlike :mod:`truth.tracker`'s real robots (their own MuJoCo physics), these read through the
simulator's serial chain, the pose model the tracker diagnosis also builds on: an in-model bench.
Whether a source shows is decided by :func:`truth.tracker.readings_visibility`; sizes are never
enlarged.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmbench.robot import Robot
from rmbench.tracker.simulator import ErrorDistribution, TrackerSimulator

__all__ = ["STRUCTURAL", "OUT_OF_LIBRARY", "draw_structural", "SpreadRobot"]

STRUCTURAL = ("payload", "gear_periodic_error", "frame_error", "thermal_drift")
OUT_OF_LIBRARY = ("backlash", "directional_stiffness")
_ZERO = ErrorDistribution(offset_sd=0.0, length_sd=0.0, twist_sd=0.0, tool_sd=0.0, stiffness_sd=0.0,
                          mass_sd=0.0, payload=(0.0, 0.0), gear_amplitude=(0.0, 0.0))


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
