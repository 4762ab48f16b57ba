"""The model side of a diagnosis: a robot, changed or not, put under the test design at postures.

Each posture is *commanded*: its joint commands come from the nominal robot's rigid-body inverse
kinematics (what a real controller that only knows its nominal model sends), and the model — the
nominal one or a changed one — settles at those commands under gravity, with the test design's
sensor masses on the tool. Its modes are exact (the linearisation's complex modes); read at the
design's sensors (position, direction, cross-axis sensitivity) and excited at its hit points they
give the modal parameters a test of that model would find, so only the measurement needs a fit.

The reading is the calibration's (:func:`rmbench.calibrate.modes.as_tested`, as its
:class:`~rmbench.calibrate.model.ModalModel` reads a parametrised robot); what is the bench's own is
the changed robot a :class:`~rmbench.gap.frf.effects.Change` builds, its first-order perturbation
for screening, and the caches a search needs.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from rmbench.calibrate.modes import AsTested, ModelModes, as_tested, with_sensors
from rmbench.errors import InputError, RmbenchError
from rmbench.gap.frf.effects import Change
from rmbench.robot import Posture, Robot
from rmbench.robot.kinds import KINDS
from rmbench.robot.linear import complex_modes
from rmbench.robot.load_stiffness import REFERENCE_DEFLECTION
from rmbench.robot.parameters import ParameterSet
from rmbench.robot.spec import spec_to_xml
from rmbench.robot.variant import add_compliant_base, compile_variant

__all__ = ["ModelModes", "ModelBench"]   # ModelModes: rmbench.calibrate.modes


class ModelBench:
    """A nominal robot under a test design at a set of commanded postures.

    Parameters
    ----------
    robot : Robot
        The nominal robot (with its tool).
    design : TestDesign
    q_cmd : ndarray, shape (n_postures, n_arm), rad
        Joint commands of the postures.
    """

    def __init__(self, robot: Robot, design, q_cmd: np.ndarray, *, cache: int = 20000):
        self.robot = robot
        self.design = design
        self.q_cmd = np.asarray(q_cmd, float)
        # robots and operating points are heavy (an MjModel each): keep a few; the modes and
        # FRFs read off them are light and are what the search asks for again
        self._robots: OrderedDict = OrderedDict()
        self._ops: OrderedDict = OrderedDict()
        self._modes: OrderedDict = OrderedDict()
        self._frfs: OrderedDict = OrderedDict()
        self._cache = cache
        # the last view built: the search asks for a model's modes and then its FRF at the same
        # posture and band, with the very same change objects (one eigen-analysis for both)
        self._last_view: tuple | None = None

    @classmethod
    def commanded(cls, robot: Robot, design, postures) -> "ModelBench":
        """Joint commands from the nominal robot's inverse kinematics of each posture.

        Raises
        ------
        UnreachablePosture
            Naming the first posture the robot cannot reach.
        """
        q = np.array([robot.ik(p).q for p in postures])
        return cls(robot, design, q)

    @property
    def n_postures(self) -> int:
        """Postures: rows of ``q_cmd``."""
        return len(self.q_cmd)

    # -- robots ---------------------------------------------------------------------------------
    def robot_for(self, change: Change) -> Robot:
        """The robot with the change's robot part applied (cached)."""
        key = change.robot_part
        if key in self._robots:
            self._robots.move_to_end(key)
            return self._robots[key]
        if key.is_null():
            robot = self.robot
        else:
            if key.values or key.masses or key.base is not None or key.load_stiffness:
                xml = _variant_xml(self.robot, key)
            else:   # only the spindle speed changes
                xml = self.robot.xml
            robot = Robot(xml, name=self.robot.name, tool=self.robot.tool,
                          spindle_rpm=self.robot.spindle_rpm + key.spindle_rpm)
        _put(self._robots, key, robot, 8)
        return robot

    def operating_point(self, change: Change, band: str, p: int):
        """The changed robot, as tested in ``band`` (sensor masses on), settled at posture ``p``."""
        key = (change.robot_part, band, p)
        if key in self._ops:
            self._ops.move_to_end(key)
            return self._ops[key]
        tested_key = (change.robot_part, band)
        tested = self._robots.get(tested_key)
        if tested is None:
            tested = with_sensors(self.robot_for(change), self.design, band)
            _put(self._robots, tested_key, tested, 8)
        op = tested.at(self.q_cmd[p])
        _put(self._ops, key, op, 2 * self.n_postures + 8)
        return op

    # -- modes ----------------------------------------------------------------------------------
    def modes(self, change: Change, p: int, band: str) -> ModelModes:
        """Modes of the changed model at posture ``p`` in ``band``, as the test design sees them
        (re-settled and re-linearised: exact)."""
        key = (change, band, p)
        hit = self._modes.get(key)
        if hit is not None:
            return hit
        out = self._view(change, p, band).modes()
        _put(self._modes, key, out, self._cache)
        return out

    def frf(self, change: Change, p: int, band: str, freq: np.ndarray) -> np.ndarray:
        """Exact receptance as tested, m/N, shape (n_freq, 4, 4)."""
        freq = np.asarray(freq, float)
        key = (change, band, p, len(freq), float(freq[0]), float(freq[-1]))
        hit = self._frfs.get(key)
        if hit is not None:
            return hit
        out = self._view(change, p, band).frf(freq)
        _put(self._frfs, key, out, self._cache // 4)
        return out

    # -- first order, for screening -------------------------------------------------------------
    @staticmethod
    def fast(delta: Change) -> bool:
        """Whether ``delta`` is a matrix perturbation the fast path takes: parameters whose kind
        has one (joint stiffness and damping, servo gains, a foundation's compliance),
        load-dependent stiffness, sensor placement."""
        return (delta.base is None and not delta.masses and delta.spindle_rpm == 0
                and all(KINDS[p.kind].perturb is not None for p, _ in delta.values))

    def modes_fast(self, base: Change, delta: Change, p: int, band: str) -> ModelModes:
        """Modes of ``base + delta`` with ``delta`` applied to ``base``'s linearisation (the
        equilibrium's shift under ``delta`` neglected: first order, for screening)."""
        return self._view(base, p, band, delta).modes()

    def frf_fast(self, base: Change, delta: Change, p: int, band: str, freq) -> np.ndarray:
        """Exact receptance as tested of :meth:`modes_fast`'s model, m/N, shape (n_freq, 4, 4)."""
        return self._view(base, p, band, delta).frf(freq)

    def _view(self, change: Change, p: int, band: str, delta: Change | None = None) -> AsTested:
        """A changed model at a posture as the design, with the change's sensor offsets, tests it
        (``delta``'s parameters as a perturbation of its linearisation)."""
        last = self._last_view
        if (last is not None and last[0] is change and last[1] == p and last[2] == band
                and last[3] is delta):
            return last[4]
        view = self._new_view(change, p, band, delta)
        # the change objects are held with the view, so their identities stay theirs
        self._last_view = (change, p, band, delta, view)
        return view

    def _new_view(self, change: Change, p: int, band: str, delta: Change | None) -> AsTested:
        op = self.operating_point(change, band, p)
        offsets = change.offsets + (delta.offsets if delta is not None else ())
        design = self.design.with_offsets(offsets) if offsets else self.design
        cm = None
        if delta is not None and (delta.values or delta.load_stiffness):
            cm = complex_modes(*_perturbed(op, delta))
        return as_tested(op, design, band, cm)

    def deflection(self, p: int, joint: str) -> float:
        """Static deflection of a passive joint at posture ``p`` under gravity (rad or m)."""
        op = self.operating_point(Change(), self.design.band_names[0], p)
        m = op.robot.model
        jid = m.joint(joint).id
        return float(op.data.qpos[m.jnt_qposadr[jid]] - m.qpos_spring[m.jnt_qposadr[jid]])

    def check_postures(self, postures) -> None:
        """Raise if a posture's commands cannot be held (the nominal model cannot settle there)."""
        for p in range(self.n_postures):
            try:
                self.operating_point(Change(), self.design.band_names[0], p)
            except RmbenchError as err:
                label = postures[p].label() if isinstance(postures[p], Posture) else str(p)
                raise RmbenchError(f"posture {label}: {err}") from None


def _put(cache: OrderedDict, key, value, size: int) -> None:
    """Insert into an LRU dict, dropping the oldest entries beyond ``size``."""
    cache[key] = value
    cache.move_to_end(key)
    while len(cache) > size:
        cache.popitem(last=False)


def _variant_xml(robot: Robot, change: Change) -> str:
    """MJCF text of ``robot`` with ``change``'s robot part: its parameters written by their kinds
    (:meth:`ParameterSet.apply_spec`), then the masses, a new foundation and load-dependent
    stiffness (the order of :func:`~rmbench.robot.variant.make_variant`, so a foundation carries
    the changed masses).

    Raises
    ------
    InputError
        For a mass that leaves a body's mass non-positive, or a variant that does not compile.
    """
    spec = robot.spec
    if change.values:
        params, u = zip(*change.values)
        ParameterSet(params).apply_spec(spec, u)
    for body, mass in change.masses:
        b = spec.body(body)
        # at the centre of mass: the inertia about it is kept
        b.mass = b.mass + mass
        if not b.mass > 0:
            raise InputError(f"the mass of {body!r} must stay positive, got {b.mass:.4g} kg")
    if change.base is not None:
        add_compliant_base(spec, *change.base)
    compile_variant(spec, robot, dict(change.load_stiffness))
    return spec_to_xml(spec)


def _perturbed(op, delta: Change):
    """M, C, K of an operating point with ``delta``'s parameters and load-dependent stiffness
    applied as matrix perturbations (the kinds' :attr:`~rmbench.robot.kinds.Kind.perturb`).

    A parameter moves from the value the operating point's model has (read by its kind: a
    joint a posture's load has stiffened is stiffer than its parameter says) by its ``u`` in
    ``delta``: a log factor multiplies that value, as the re-simulated model's change does."""
    m = op.robot.model
    M, C, K = op.linear.M, op.linear.C.copy(), op.linear.K.copy()
    names = list(op.linear.dof_names)
    for p, u in delta.values:
        kind = KINDS[p.kind]
        u0 = p.to_u(kind.read_model(m, p))
        kind.perturb(m, names, p, u0, u0 + u, C, K)
    for joint, alpha in delta.load_stiffness:
        jid = m.joint(joint).id
        adr = m.jnt_qposadr[jid]
        deflection = abs(op.data.qpos[adr] - m.qpos_spring[adr])
        d = names.index(joint)
        K[d, d] += m.jnt_stiffness[jid] * alpha * deflection / REFERENCE_DEFLECTION
    return M, C, K
