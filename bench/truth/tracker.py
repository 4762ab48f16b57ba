"""Real MH180s read by a laser tracker, built apart from the diagnosis that reads them (issue 79).

The positions are the real robot's own physics: its MJCF (the ordinary spread of
:func:`spread_xml`, model-form errors, a payload) settled under gravity by MuJoCo at
each commanded configuration, the TCP read where it comes to rest, then moved into the tracker's
frame. Nothing here goes through the diagnosis's pose model, its sources or its noise model.

Model-form errors (:data:`FORM_KINDS`), each with probability ``p_form``:

* ``bending_link``, ``bearing_tilt``: the link bends, a main bearing tilts
  (:func:`truth.form.apply_form`; at the FRF bench's sizes), so the TCP sags by the gravity load;
* ``reflector_sag``: the reflector's mount gives under its own weight: the TCP read 20-80 µm along
  the part of gravity normal to the tool axis;
* ``thermal_gradient``: one link (upper arm or forearm) warms along its length, 10-40 µm per metre
  and hour (not the whole arm about its base, as the library's thermal drift).

Structural sources (:data:`IN_LIBRARY`, :data:`OUT_OF_LIBRARY`), at the sizes of the tracker
bench's draws: a 10-25 kg payload at the TCP, a gear's first harmonic of 80-150 µrad, a reflector
offset of 1.5-3 mm, the whole arm expanding 20-60 µm per metre and hour; outside the library a
backlash of 100-200 µrad against the direction of the last move, or a joint 1.6-2.2 times
stiffer when its gravity torque is positive.

Noise the diagnosis is not told (:func:`draw_noise`): the joints' scatter (25 µrad per joint at
the rated level) and the tracker's (its data sheet's 5 µm/m and 12.5 µm as 2σ bounds), both
scaled by a factor log-uniform 0.5-2, and in half the robots correlated from one reading to the
next (AR(1), ρ 0.3-0.8).

The ordinary spread (:func:`spread_xml`): the nominal MJCF edited as text, every flexible joint's
stiffness × U(0.7, 1.3), every body placement ± 0.5 mm along it, every link mass ± 10 %. The
campaigns (:func:`campaign`): quasi-random configurations of the joint ranges :data:`BOXES`, each
read twice in random order. Both are shared with the spread robots of ``bench/gap_tracker.py``
(:mod:`truth.tracker_spread`).

:func:`visibility` (and :func:`readings_visibility`, for any pair of readers) decides whether a
source shows in the readings beyond their noise, without the diagnosis; sizes are never enlarged.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import mujoco
import numpy as np

from rmbench.tracker import MH180_CALIBRATION_BOX, MH180_JOINT_BOX, sobol_points
from truth.form import apply_form, draw_form

__all__ = ["FORM_KINDS", "IN_LIBRARY", "OUT_OF_LIBRARY", "BOXES", "TrackerRobot", "spread_xml", "campaign",
           "draw_tracker_robot", "draw_noise", "Reader", "visibility", "readings_visibility"]

FORM_KINDS = ("bending_link", "bearing_tilt", "reflector_sag", "thermal_gradient")
IN_LIBRARY = ("payload", "gear_periodic_error", "frame_error", "thermal_drift")
OUT_OF_LIBRARY = ("backlash", "directional_stiffness")
JOINT_SCATTER = 25e-6           # rad per joint, at the rated repeatability
_PPM, _PROBE = 5e-6, 12.5e-6    # the tracker's data sheet, each a 2σ bound
_GROWING = {"upper_arm": "motor4", "forearm": "motor5"}     # a warming link and the body it carries


@dataclass(frozen=True)
class TrackerRobot:
    """A real MH180 and how it is read.

    Attributes
    ----------
    xml : str
        Its MJCF: the spread, the MJCF form errors and a payload.
    ordinary : dict
        The spread's true factors and placements (:func:`spread_xml`).
    form : tuple of dict
        ``{"kind", "location", "size"}`` of each form error.
    source : dict or None
        The structural source: ``{"kind", "location", ...}`` in the diagnosis's naming.
    noise : dict
        ``{"scale", "rho"}`` of the readings' noise.
    frame : dict
        The tracker's place: ``{"yaw", "position"}`` (rad; m, in the base frame).
    """

    xml: str
    ordinary: dict
    form: tuple
    source: dict | None
    noise: dict
    frame: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"ordinary": self.ordinary, "form": list(self.form), "source": self.source, "noise": self.noise,
                "frame": self.frame}


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


def _logu(rng, lo, hi) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def draw_source(rng: np.random.Generator, *, in_library: bool) -> dict:
    """One structural source (see the module), located in the diagnosis's naming."""
    j = int(rng.integers(1, 6))         # j2 ... j6
    if not in_library:
        if rng.random() < 0.5:
            return {"kind": "backlash", "location": f"j{j + 1}", "joint": j, "angle": float(rng.uniform(100e-6, 200e-6))}
        return {"kind": "directional_stiffness", "location": f"j{j + 1}", "joint": j,
                "ratio": float(rng.uniform(1.6, 2.2))}
    kind = IN_LIBRARY[int(rng.integers(len(IN_LIBRARY)))]
    if kind == "payload":
        return {"kind": kind, "location": "tool", "mass": float(rng.uniform(10, 25))}
    if kind == "gear_periodic_error":
        return {"kind": kind, "location": f"j{j + 1}:h1", "joint": j, "amplitude": float(rng.uniform(80e-6, 150e-6)),
                "phase": float(rng.uniform(0, 2 * np.pi))}
    if kind == "thermal_drift":
        return {"kind": kind, "location": "time", "per_hour": float(rng.uniform(2e-5, 6e-5))}
    v = rng.normal(size=3)
    return {"kind": kind, "location": "tool", "offset": (float(rng.uniform(1.5e-3, 3e-3)) * v / np.linalg.norm(v)).tolist()}


def draw_noise(rng: np.random.Generator) -> dict:
    """The readings' noise: a scale log-uniform 0.5-2 of the rated level, correlated from one
    reading to the next in half the robots."""
    scale = _logu(rng, 0.5, 2.0)
    rho = float(rng.uniform(0.3, 0.8)) if rng.random() < 0.5 else 0.0
    return {"scale": scale, "rho": rho}


def draw_tracker_robot(nominal_xml: str, rng: np.random.Generator, *, p_form: float = 0.5,
                       source: str = "none") -> TrackerRobot:
    """A real MH180 from the nominal MJCF; ``source``: ``"none"``, ``"in_library"`` or
    ``"out_of_library"``."""
    xml, ordinary = spread_xml(nominal_xml, rng)
    root = ET.fromstring(xml)
    form = []
    for kind in FORM_KINDS:
        if rng.random() >= p_form:
            continue
        if kind in ("bending_link", "bearing_tilt"):
            e = draw_form(rng, kind)
            apply_form(root, e)
            form.append(e.to_dict())
        elif kind == "reflector_sag":
            form.append({"kind": kind, "location": "tool", "size": {"per_g": float(rng.uniform(20e-6, 80e-6))}})
        else:
            link = ("upper_arm", "forearm")[int(rng.integers(2))]
            form.append({"kind": kind, "location": link, "size": {"per_hour": float(rng.uniform(1e-5, 4e-5))}})
    src = None if source == "none" else draw_source(rng, in_library=source == "in_library")
    if src is not None and src["kind"] == "payload":
        _payload(root, src["mass"])
    frame = {"yaw": float(np.radians(rng.uniform(120, 180))),
             "position": [float(rng.uniform(3.0, 4.0)), float(rng.uniform(-2.0, -1.0)), float(rng.uniform(0.5, 1.0))]}
    return TrackerRobot(ET.tostring(root, encoding="unicode"), ordinary, tuple(form), src, draw_noise(rng), frame)


def _payload(root: ET.Element, mass: float) -> None:
    """A point-like mass at the TCP site, fixed to the flange."""
    flange = next(b for b in root.iter("body") if b.get("name") == "flange")
    tcp = next(s for s in root.iter("site") if s.get("name") == "tcp")
    body = ET.SubElement(flange, "body", {"name": "payload", "pos": tcp.get("pos", "0 0 0")})
    ET.SubElement(body, "inertial", {"pos": "0 0 0", "mass": f"{mass:.9g}", "diaginertia": "0.01 0.01 0.01"})


class Reader:
    """The real robot read by the tracker: :meth:`positions` of commanded configurations."""

    def __init__(self, robot: TrackerRobot, *, with_source: bool = True):
        from rmbench.robot import Robot

        self.truth = robot
        self.source = robot.source if with_source else None
        xml = robot.xml if with_source or robot.source is None or robot.source["kind"] != "payload" else \
            _without_payload(robot.xml)
        self.robot = Robot(xml, name="real", tool=None)
        m = self.robot.model
        self.data = mujoco.MjData(m)
        self.tcp = m.site("tcp").id
        self.form = {f["kind"]: f for f in robot.form}
        grow = self.form.get("thermal_gradient")
        self.grow = None if grow is None else (m.body(_GROWING[grow["location"]]).id, m.body_pos[
            m.body(_GROWING[grow["location"]]).id].copy(), grow["size"]["per_hour"])
        yaw = robot.frame["yaw"]
        self.rot = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
        self.origin = -self.rot @ np.asarray(robot.frame["position"], float)
        self.stiff = None
        if self.source is not None and self.source["kind"] == "directional_stiffness":
            jid = m.joint(f"j{self.source['joint'] + 1}_flex").id
            self.stiff = (jid, float(m.jnt_stiffness[jid]))

    def _settled(self, q, hours: float) -> tuple[np.ndarray, np.ndarray]:
        """TCP position (3,) and tool axis (3,), base frame, at the commands ``q`` (6,) rad."""
        m, d = self.robot.model, self.data
        if self.grow is not None:
            body, pos, rate = self.grow
            m.body_pos[body] = pos * (1.0 + rate * hours)
        if self.stiff is not None:
            jid, k = self.stiff
            m.jnt_stiffness[jid] = k
        self.robot.settle(q, d)
        if self.stiff is not None:
            jid, k = self.stiff
            # a positive gravity torque on the joint deflects its spring positively: the stiffer
            # side, settled again
            if d.qpos[m.jnt_qposadr[jid]] > 0:
                m.jnt_stiffness[jid] = k * self.source["ratio"]
                self.robot.settle(q, d)
        return d.site_xpos[self.tcp].copy(), d.site_xmat[self.tcp].reshape(3, 3)[:, 2].copy()

    def positions(self, q, previous, t, rng: np.random.Generator | None = None) -> np.ndarray:
        """Tracker-frame TCP positions (n, 3), m, of the commands ``q`` (n, 6) read at ``t`` (s
        since the first reading), each after the commands ``previous`` (n, 6); noise-free, or
        read with the robot's noise drawn from ``rng``."""
        commanded = np.asarray(q, float)
        q = commanded.copy()
        n = len(q)
        s = self.source
        scale, rho = self.truth.noise["scale"], self.truth.noise["rho"]
        if rng is not None:
            q = q + scale * JOINT_SCATTER * _ar1(rng, (n, q.shape[1]), rho)
        if s is not None and s["kind"] == "gear_periodic_error":
            j = s["joint"]
            q[:, j] += s["amplitude"] * np.sin(q[:, j] + s["phase"])
        if s is not None and s["kind"] == "backlash":
            j = s["joint"]
            q[:, j] -= s["angle"] * np.sign(commanded[:, j] - np.asarray(previous, float)[:, j])
        hours = np.asarray(t, float) / 3600.0
        out = np.empty((n, 3))
        sag = self.form.get("reflector_sag")
        for k in range(n):
            p, axis = self._settled(q[k], hours[k])
            if sag is not None:
                g = np.array([0.0, 0.0, -1.0])
                p = p + sag["size"]["per_g"] * (g - (g @ axis) * axis)
            if s is not None and s["kind"] == "frame_error":
                rot = self.data.site_xmat[self.tcp].reshape(3, 3)
                p = p + rot @ np.asarray(s["offset"])
            out[k] = p
        if s is not None and s["kind"] == "thermal_drift":
            out = out * (1.0 + s["per_hour"] * hours)[:, None]
        out = out @ self.rot.T + self.origin
        if rng is not None:
            d = np.linalg.norm(out, axis=1)       # the range: the tracker at its frame's origin
            sigma = scale * np.sqrt((0.5 * _PPM * d) ** 2 + (0.5 * _PROBE) ** 2)
            out = out + sigma[:, None] * _ar1(rng, (n, 3), rho)
        return out


def _ar1(rng: np.random.Generator, shape, rho: float) -> np.ndarray:
    """Standard normal draws of ``shape`` correlated ``rho`` from one row to the next (unit variance)."""
    e = rng.standard_normal(shape)
    if rho == 0:
        return e
    out = np.empty(shape)
    out[0] = e[0]
    c = np.sqrt(1 - rho * rho)
    for i in range(1, shape[0]):
        out[i] = rho * out[i - 1] + c * e[i]
    return out


def _without_payload(xml: str) -> str:
    root = ET.fromstring(xml)
    for parent in root.iter("body"):
        for child in list(parent.findall("body")):
            if child.get("name") == "payload":
                parent.remove(child)
    return ET.tostring(root, encoding="unicode")


def visibility(robot: TrackerRobot, q, previous, t, seed: int, *, p: float = 1e-3) -> dict:
    """Whether ``robot``'s structural source shows in its readings beyond their noise, decided
    without the diagnosis (:func:`readings_visibility` of its :class:`Reader` with and without it)."""
    return readings_visibility(Reader(robot), Reader(robot, with_source=False), q, previous, t, seed,
                               rho=robot.noise["rho"], p=p)


def readings_visibility(with_, without, q, previous, t, seed: int, *, rho: float = 0.0, p: float = 1e-3) -> dict:
    """Whether a change shows in the readings beyond their noise: the noise-free readings of
    ``with_`` and ``without`` (readers: ``positions(q, previous, t, rng=None)``), their difference
    judged against the campaign's own noise on an independent draw, as
    :func:`truth.visibility.visibility` judges an FRF's (χ²_with − χ²_null beyond z·√(2n), σ̂² per
    axis from a third draw); ``rho``: the readings' correlation from one to the next."""
    from scipy.stats import norm

    p1, p0 = with_.positions(q, previous, t), without.positions(q, previous, t)
    draws = [without.positions(q, previous, t, np.random.default_rng([seed, k])) - p0 for k in (1, 2, 3)]
    var = np.mean(draws[0] ** 2, axis=0)[None, :]       # per axis
    chi2_with = float(np.sum((p1 - p0 + draws[1]) ** 2 / var))
    chi2_null = float(np.sum(draws[2] ** 2 / var))
    n = p1.size
    # readings correlated ρ from one to the next: a sum of their squares scatters
    # √((1 + ρ²)/(1 − ρ²)) times as much as of independent ones
    threshold = float(norm.ppf(1 - p) * np.sqrt(2 * n * (1 + rho * rho) / (1 - rho * rho)))
    return {"chi2_with": chi2_with, "chi2_null": chi2_null, "n": n, "threshold": threshold,
            "visible": bool(chi2_with - chi2_null > threshold),
            "effect_chi2": float(np.sum((p1 - p0) ** 2 / var))}
