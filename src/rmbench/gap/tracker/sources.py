"""Kinematic error sources of a serial arm, and the pose model they edit (tracker data).

A :class:`Source` is one candidate cause of pose error: a frozen record of a few parameters,
each the project's one parameter record (:class:`~rmbench.robot.parameters.Parameter`) of a pose
kind (:data:`SOURCE_KINDS`, no MJCF edit), in SI units, zero for the nominal arm.
:class:`PoseModel` predicts TCP positions in the robot base frame for any set of source values:
the nominal rigid chain (:class:`~rmbench.tracker.chain.SerialChain`) with its nominal gravity
compliance (the MJCF ``<joint>_flex`` stiffness), edited by the sources. The conventions are the
tracker simulator's (:mod:`rmbench.tracker.simulator`), so a source drawn there is the same source
here.

Kinds (:func:`source_library`):

* ``joint_offset@jN`` — zero offset, rad;
* ``link_geometry@jN`` — placement of joint N: length (m, along the placement's translation) and
  twist (rad, about the axis normal to the joint axis and the link);
* ``gravity_compliance@jN`` — fraction added to the joint's nominal compliance (joints with a
  ``_flex`` spring only);
* ``link_mass@jN`` — fraction added to the mass of the body joint N carries (an ordinary parameter
  a calibration fits, :func:`source_library` ``masses``; it moves the gravity torque's share
  between the joints, which no compliance fraction does);
* ``payload@tool`` — unmodelled mass at the TCP, kg (deflects the compliant joints);
* ``gear_periodic_error@jN:hH`` — harmonic H of the joint's output revolution, ``a sin(H q) +
  b cos(H q)``, rad;
* ``frame_error@tool`` — reflector (TCP) offset in the tool frame, m, 3 components;
* ``thermal_drift@time`` (or ``@temperature``) — uniform expansion of the arm about its base, per
  hour since the first reading (or per kelvin above its temperature); needs time stamps (or
  temperatures).

The robot base's place in the tracker frame is registered by a best fit in every model, so a base
frame error is the registration's and no source of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.robot.parameters import Parameter
from rmbench.tracker.chain import SerialChain

__all__ = ["Source", "PoseModel", "source_library", "SOURCE_KINDS", "ORDINARY"]

# the pose model's kinds: the registry its parameters' kinds are checked against
# (:attr:`rmbench.robot.parameters.Parameter.registry`); none has an MJCF edit
SOURCE_KINDS = ("joint_offset", "link_geometry", "gravity_compliance", "link_mass", "payload",
                "gear_periodic_error", "frame_error", "thermal_drift")
ORDINARY = ("joint_offset", "link_geometry", "gravity_compliance", "link_mass")   # what a robot calibration fits

# per kind, each parameter's (name, typical magnitude in SI, SI unit). The magnitude is the
# parameter's unit of u (value = unit · u, nominal 0): the solver and the finite differences
# (steps of 1e-3 u) then see a 1 mrad offset, a 10 % compliance and a 10 kg payload alike
_PARAMETERS = {
    "joint_offset": (("offset", 1e-3, "rad"),),
    "link_geometry": (("length", 1e-3, "m"), ("twist", 1e-3, "rad")),
    "gravity_compliance": (("fraction", 0.1, "1"),),
    "link_mass": (("fraction", 0.05, "1"),),
    "payload": (("mass", 10.0, "kg"),),
    "gear_periodic_error": (("a_sin", 1e-4, "rad"), ("b_cos", 1e-4, "rad")),
    "frame_error": (("dx", 1e-3, "m"), ("dy", 1e-3, "m"), ("dz", 1e-3, "m")),
    "thermal_drift@time": (("per_hour", 1e-5, "1/h"),),
    "thermal_drift@temperature": (("per_kelvin", 1e-5, "1/K"),),
}


@dataclass(frozen=True)
class Source:
    """One candidate error source: a frozen record of its parameters.

    Build one with :meth:`of`.

    Attributes
    ----------
    kind : str
        One of :data:`SOURCE_KINDS`.
    location : str
        ``jN`` (joint), ``jN:hH`` (joint and harmonic), ``tool``, ``time`` or ``temperature``.
    parameters : tuple of Parameter
        One :class:`~rmbench.robot.parameters.Parameter` per value, in the order of the source's
        value array: named ``KIND@LOCATION.FIELD`` (``joint_offset@j2.offset``), of group
        ``ordinary`` (:data:`ORDINARY`) or ``structural``, targets ``(where,)`` (the joint's
        name, ``tool``, ``time`` or ``temperature``), index its place in the array, nominal 0,
        linear with :attr:`~rmbench.robot.parameters.Parameter.unit` the typical magnitude (SI),
        unbounded (the engine's priors are the diagnosis's settings), label the SI unit.
    joint : int
        Index of the joint (-1: none).
    harmonic : int
        Harmonic order (gear errors), else 0.
    """

    kind: str
    location: str
    parameters: tuple
    joint: int = -1
    harmonic: int = 0

    @classmethod
    def of(cls, kind: str, location: str, *, joint: int = -1, harmonic: int = 0) -> "Source":
        """The source of ``kind`` at ``location`` with its parameters (:data:`_PARAMETERS`).

        Raises
        ------
        ValueError
            An unknown kind.
        """
        if kind not in SOURCE_KINDS:
            raise ValueError(f"unknown source kind {kind!r}; one of {', '.join(SOURCE_KINDS)}")
        name = f"{kind}@{location}"
        spec = _PARAMETERS[name if kind == "thermal_drift" else kind]
        group = "ordinary" if kind in ORDINARY else "structural"
        where = location.split(":")[0]
        params = tuple(Parameter(f"{name}.{field}", group, kind, (where,), i, 0.0, False, unit,
                                 -np.inf, np.inf, label, registry=SOURCE_KINDS)
                       for i, (field, unit, label) in enumerate(spec))
        return cls(kind, location, params, joint, harmonic)

    @property
    def params(self) -> tuple:
        """The parameters' short names (``offset``, ``a_sin``): the keys of :meth:`params_dict`."""
        return tuple(p.name[len(self.name) + 1:] for p in self.parameters)

    @property
    def name(self) -> str:
        """``kind@location``."""
        return f"{self.kind}@{self.location}"

    @property
    def n_params(self) -> int:
        """Parameters the source fits (:attr:`parameters`)."""
        return len(self.parameters)

    def params_dict(self, values) -> dict:
        """``{short name: SI value}`` of one value array (shape (n_params,))."""
        return {p: float(v) for p, v in zip(self.params, np.atleast_1d(values))}

    def describe(self, values) -> str:
        """One line in user units (mm, degrees, kg, per cent)."""
        v = np.atleast_1d(np.asarray(values, float))
        if self.kind == "joint_offset":
            return f"{self.location} zero offset {np.degrees(v[0]):+.4f}°"
        if self.kind == "link_geometry":
            return (f"{self.location} placement: length {1e3 * v[0]:+.3f} mm, "
                    f"twist {np.degrees(v[1]):+.4f}°")
        if self.kind == "gravity_compliance":
            return f"{self.location} gravity compliance {100 * v[0]:+.1f} %"
        if self.kind == "link_mass":
            return f"mass carried by {self.location} {100 * v[0]:+.1f} %"
        if self.kind == "payload":
            return f"payload {v[0]:+.2f} kg at the TCP"
        if self.kind == "gear_periodic_error":
            amp = np.hypot(v[0], v[1])
            phase = np.degrees(np.arctan2(v[1], v[0]))
            return (f"{self.location.split(':')[0]} gear error, harmonic {self.harmonic}: "
                    f"{1e6 * amp:.1f} µrad, phase {phase:.0f}°")
        if self.kind == "frame_error":
            return "TCP offset (" + ", ".join(f"{1e3 * x:+.3f}" for x in v) + ") mm"
        unit = "hour" if self.location == "time" else "kelvin"
        return f"thermal expansion {1e6 * v[0]:+.1f} µm/m per {unit}"


def source_library(chain: SerialChain, compliance, *, harmonics: int = 2,
                   drive: str | None = None, masses: bool = False) -> list[Source]:
    """Every candidate source of a chain.

    Parameters
    ----------
    compliance : array_like, shape (n_joint,), rad/(N·m)
        Nominal gravity compliance per joint (0: rigid; such joints get no compliance source).
    harmonics : int
        Gear-error harmonics per joint.
    drive : {"time", "temperature"} or None
        What the readings carry that thermal drift can follow (None: no thermal source).
    masses : bool
        Each compliant chain's body masses too (``link_mass``; bodies beyond the first joint).
    """
    c = np.asarray(compliance, float)
    out = []
    for j, name in enumerate(chain.names):
        out.append(Source.of("joint_offset", name, joint=j))
    for j, name in enumerate(chain.names):
        out.append(Source.of("link_geometry", name, joint=j))
    for j, name in enumerate(chain.names):
        if c[j] > 0:
            out.append(Source.of("gravity_compliance", name, joint=j))
    if masses and np.any(c > 0):
        for j, name in enumerate(chain.names):
            if j > 0 and chain.masses[j] > 0:
                out.append(Source.of("link_mass", name, joint=j))
    out.append(Source.of("payload", "tool"))
    for j, name in enumerate(chain.names):
        for h in range(1, harmonics + 1):
            out.append(Source.of("gear_periodic_error", f"{name}:h{h}", joint=j, harmonic=h))
    out.append(Source.of("frame_error", "tool"))
    if drive == "time":
        out.append(Source.of("thermal_drift", "time"))
    elif drive == "temperature":
        out.append(Source.of("thermal_drift", "temperature"))
    return out


class PoseModel:
    """TCP positions of the nominal arm edited by error sources.

    Parameters
    ----------
    chain : SerialChain
        The nominal rigid arm.
    compliance : array_like, shape (n_joint,), rad/(N·m)
        Nominal gravity compliance per joint (0: rigid).
    """

    def __init__(self, chain: SerialChain, compliance):
        self.chain = chain
        self.compliance = np.asarray(compliance, float)
        n = chain.n_joint
        # per placement, in the joint's own frame: the length direction (the placement's
        # translation) and the twist axis, the common normal of the previous joint's axis (the
        # base z for the first) and this one's, as in Denavit-Hartenberg's link twist; for
        # parallel axes, the link's direction across them
        self._length_dir = np.empty((n, 3))
        self._twist_dir = np.empty((n, 3))
        prev = np.array([0.0, 0.0, 1.0])      # in the frame before placement 0 (the base)
        for i in range(n):
            r = chain.rotations[i]
            d = r.T @ chain.translations[i]
            axis = chain.axes[i]
            prev_here = r.T @ prev
            tw = np.cross(prev_here, axis)
            if np.linalg.norm(tw) < 1e-6:
                tw = d - (d @ axis) * axis
            if np.linalg.norm(tw) < 1e-6:
                tw = _normal(axis)
            if np.linalg.norm(d) < 1e-6:
                d = _normal(axis)
            self._length_dir[i] = d / np.linalg.norm(d)
            self._twist_dir[i] = tw / np.linalg.norm(tw)
            prev = axis                        # next placement's "before" frame is this joint's
        self._distinct_cache = {}
        self._recent = {}

    def _kept(self, key, compute):
        """``compute()``, or what it gave when last asked with ``key`` (the last few kept)."""
        out = self._recent.get(key)
        if out is None:
            out = remember(self._recent, key, compute(), 8)
        return out

    def _distinct(self, q: np.ndarray):
        """``(rows, inverse)``: the first reading of each distinct configuration in ``q`` and,
        per reading, its place among them (``q[rows][inverse]`` is ``q``); ``(None, None)`` where
        every configuration is read once. The last few answers are kept: the diagnosis asks for
        the same training or held-out readings thousands of times."""
        key = (q.shape, q.tobytes())
        hit = self._distinct_cache.get(key)
        if hit is None:
            if q.ndim != 2 or len(q) < 2:
                hit = (None, None)
            else:
                # rows compared by their bytes: equal to the bit (-0.0 is not 0.0 here)
                raw = np.ascontiguousarray(q).view(np.dtype((np.void, q.itemsize * q.shape[1])))
                _, first, inverse = np.unique(raw.ravel(), return_index=True, return_inverse=True)
                if len(first) == len(q):
                    hit = (None, None)
                else:
                    order = np.argsort(first)             # distinct rows in order of first reading
                    place = np.empty_like(order)
                    place[order] = np.arange(len(order))
                    hit = (first[order], place[np.ravel(inverse)])
            remember(self._distinct_cache, key, hit, 8)
        return hit

    def twists(self, sources, values) -> np.ndarray:
        """Placement twists (n_joint + 1, 6) of the sources (simulator convention)."""
        tw = np.zeros((self.chain.n_joint + 1, 6))
        for s, v in zip(sources, values):
            v = np.atleast_1d(v)
            if s.kind == "link_geometry":
                tw[s.joint, :3] += v[0] * self._length_dir[s.joint]
                tw[s.joint, 3:] += v[1] * self._twist_dir[s.joint]
            elif s.kind == "frame_error":
                tw[-1, :3] += v
        return tw

    def positions(self, q, sources=(), values=(), drive=None) -> np.ndarray:
        """TCP positions in the base frame, shape (n, 3), m.

        Parameters
        ----------
        q : ndarray, shape (n, n_joint), rad
            Commanded (motor-side) joint angles.
        sources, values : sequences
            Sources and one parameter array each.
        drive : ndarray, shape (n,), optional
            What thermal drift follows: hours since the first reading, or kelvin above its
            temperature.
        """
        q = np.asarray(q, float)
        # a configuration read more than once (a campaign reads each several times) is computed
        # once: every step below is row by row, so the positions are the same to the bit
        rows, inverse = self._distinct(q)
        if rows is not None:
            q = q[rows]
        chain = self.chain
        tw = self.twists(sources, values)
        if np.any(tw):
            chain = self._kept(("chain", tw.tobytes()), lambda: self.chain.perturbed(tw))
        angles = q.copy()
        comp = self.compliance.copy()
        expansion = 0.0
        scale = np.ones(chain.n_joint)
        for s, v in zip(sources, values):
            if s.kind == "link_mass":
                scale[s.joint] += np.atleast_1d(v)[0]
        if np.any(scale != 1.0):
            chain = chain.with_mass_scale(scale)
        for s, v in zip(sources, values):
            v = np.atleast_1d(v)
            if s.kind == "joint_offset":
                angles[:, s.joint] += v[0]
            elif s.kind == "gear_periodic_error":
                h = s.harmonic
                angles[:, s.joint] += v[0] * np.sin(h * q[:, s.joint]) + v[1] * np.cos(h * q[:, s.joint])
            elif s.kind == "gravity_compliance":
                comp[s.joint] *= 1.0 + v[0]
            elif s.kind == "payload":
                chain = chain.with_point_mass(float(v[0]), self.chain.tool_translation)
            elif s.kind == "thermal_drift":
                if drive is None:
                    raise ValueError("thermal drift needs time stamps or temperatures")
                expansion = v[0] * np.asarray(drive, float)
        deflection = np.zeros_like(angles)
        if np.any(comp):
            # as the simulator: two fixed-point steps. The first step's torque, at the undeflected
            # angles, is kept: the finite differences of a compliance fraction (or of a drift)
            # move neither the angles nor the chain
            first = angles + deflection
            key = ("torque", first.tobytes(), chain.rotations.tobytes(), chain.translations.tobytes(),
                   chain.axes.tobytes(), chain.masses.tobytes(), chain.centres.tobytes())
            deflection = comp * self._kept(key, lambda: chain.gravity_torque(first))
            deflection = comp * chain.gravity_torque(angles + deflection)
        p = chain.position(angles + deflection)
        if inverse is not None:
            p = p[inverse]
        if np.any(expansion):
            p = p * (1.0 + np.asarray(expansion))[:, None]
        return p



def remember(cache: dict, key, value, size: int):
    """``value``, kept under ``key`` in ``cache``, whose oldest entry goes beyond ``size``."""
    if len(cache) >= size:
        try:
            cache.pop(next(iter(cache)))
        except (RuntimeError, KeyError, StopIteration):    # changed meanwhile by another thread
            cache.clear()
    cache[key] = value
    return value


def _normal(axis: np.ndarray) -> np.ndarray:
    """A unit vector normal to ``axis``."""
    e = np.eye(3)[int(np.argmin(np.abs(axis)))]
    v = np.cross(axis, e)
    return v / np.linalg.norm(v)
