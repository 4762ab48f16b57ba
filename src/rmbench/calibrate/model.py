"""A parametrised robot under a test design at commanded postures: its modes for any parameters.

For a parameter vector ``u`` (:mod:`rmbench.robot.parameters`) the values are written into a copy of
the compiled model (no recompilation), the robot settles at each posture's joint commands under
gravity and is linearised exactly (METHODS.md §11), and its complex modes are read at the test
design's sensors and hit points (:func:`~rmbench.calibrate.modes.as_tested`, the reading the gap
diagnosis's model bench shares). Each band has its own model: the band's sensors sit on the tool
with their masses (:func:`~rmbench.calibrate.modes.with_sensors`).

Sensitivities (:meth:`ModalModel.sensitivity`) are analytic eigen-sensitivities (Fox-Kapoor,
Nelson; :func:`~rmbench.robot.linear.perturbed_modes`) of the exact linearisation: one
eigen-analysis per posture and band, whatever the number of parameters. Parameters that enter the
linear model only through its matrices (joint stiffness and damping, servo gains, the base's
compliance) change C and K directly; masses and centres of mass change M and the gravity
stiffness, so the stepped model is linearised at the settled state (at rest; a spinning rotor
settles again, since its gyroscopic terms hold the state).
A sensor's placement (:data:`~rmbench.calibrate.design.SENSOR_KINDS`) changes no mode, only how
the design reads them: its step re-reads the unstepped modes at the moved sensor. The spindle's
speed (:func:`spindle_parameter`) is the robot's state, not its MJCF: the robot settles with its
rotor spinning at that speed, whose gyroscopic coupling enters C.
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np

from rmbench.calibrate.design import SENSOR_KINDS, sensor_offsets
from rmbench.calibrate.modes import ModelModes, as_tested, with_sensors
from rmbench.errors import InputError, RmbenchError
from rmbench.robot.kinds import KINDS, Kind
from rmbench.robot.linear import equilibrium, linearize, perturbed_modes_many
from rmbench.robot.model import OperatingPoint
from rmbench.robot.parameters import Parameter

__all__ = ["ModalModel", "FAST_KINDS", "SPEED_KIND", "spindle_parameter"]

# kinds whose change enters the linearisation through C and K alone (a matrix perturbation)
FAST_KINDS = tuple(name for name, kind in KINDS.items() if kind.perturb is not None)
_SENSOR = tuple(k.name for k in SENSOR_KINDS)
_RPM = 2 * np.pi / 60          # rad/s per rev/min


def _nothing(target, p, x) -> None:
    """The spindle's speed writes nothing into the MJCF (:class:`ModalModel` spins the rotor)."""


# fitted in thousands of rev/min, from the robot's own speed; a freed one from rest to 30,000
SPEED_KIND = Kind("spindle_speed", _nothing, _nothing, display=lambda v: v / _RPM, resolution=100 * _RPM,
                  wide=lambda p: (p.lower, p.upper), gross=lambda p: [0.0, 5.0, 10.0, 20.0])


def spindle_parameter(robot) -> Parameter:
    """The spindle's speed as a parameter, ``spindle.speed``: rad/s, fitted in thousands of rev/min
    added to the robot's own (:attr:`Robot.spindle_rpm`), from rest to 30,000 rev/min.

    Raises
    ------
    InputError
        A robot without a spinning spindle (no ``spindle_spin`` joint).
    """
    if mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_JOINT, "spindle_spin") < 0:
        raise InputError(f"{robot.name} has no spindle that spins (no spindle_spin joint)")
    u0 = robot.spindle_rpm / 1000.0
    return Parameter("spindle.speed", "state", "spindle_speed", ("spindle_spin",), 0, robot.spindle_rpm * _RPM,
                     False, 1000 * _RPM, -u0, 30.0 - u0, "rev/min", registry=(SPEED_KIND,))


class ModalModel:
    """The modes of a parametrised robot as a test design sees them, at commanded postures.

    Parameters
    ----------
    robot : Robot
        The robot the parameters describe (from :func:`~rmbench.robot.parameters.parameter_set`).
    params : ParameterSet
    design : TestDesign
    q_cmd : ndarray, shape (n_postures, n_arm), rad
        Joint commands of the postures (the nominal robot's inverse kinematics).
    bands : sequence of str
    """

    def __init__(self, robot, params, design, q_cmd, bands):
        self.robot = robot
        self.params = params
        self.design = design
        self.q_cmd = np.asarray(q_cmd, float)
        self.bands = tuple(bands)
        self._tested = {b: with_sensors(robot, design, b) for b in self.bands}
        self._built = {}
        self._scratch = {}      # reusable MjData to settle in (:meth:`_work`)
        self._at = {}           # the settled postures at the last values asked (:meth:`_tested_at`)
        # the test design's parameters: read through the design, not written into the model
        self._sensor = np.array([p.kind in _SENSOR for p in params], bool)
        self._speed = next((i for i, p in enumerate(params) if p.kind == "spindle_speed"), None)

    @property
    def n_postures(self) -> int:
        """Postures: rows of ``q_cmd``."""
        return len(self.q_cmd)

    def _model(self, u, band):
        """The band's compiled model with the values at ``u`` (the last few kept)."""
        u = np.where(self._sensor, 0.0, np.asarray(u, float))    # a sensor's step: the same model
        key = (band, u.tobytes())
        hit = self._built.get(key)
        if hit is not None:
            return hit
        base = self._tested[band]
        model = copy.copy(base.model)
        self.params.apply_model(model, u)
        shell = copy.copy(base)     # the same robot with this model: what an OperatingPoint reads
        shell.model = model
        if self._speed is not None:
            shell.spindle_rpm = self.params.params[self._speed].value(u[self._speed]) / _RPM
        # room for a Jacobian's worth (each stepped parameter's model, reused across postures)
        if len(self._built) > (len(self.params) + 4) * len(self.bands):
            self._built.pop(next(iter(self._built)))
        self._built[key] = shell
        return shell

    def operating_point(self, u, p: int, band: str) -> OperatingPoint:
        """The robot with the values at ``u``, as tested in ``band``, settled at posture ``p``.

        Raises
        ------
        RmbenchError
            If the robot cannot hold the posture with these values.
        """
        return self._settle(u, p, band, mujoco.MjData(self._model(u, band).model))

    def _settle(self, u, p: int, band: str, data) -> OperatingPoint:
        """:meth:`operating_point` in a given ``MjData`` (any of the band's: they share the sizes)."""
        shell = self._model(u, band)
        shell.settle(self.q_cmd[p], data)
        return OperatingPoint(shell, None, self.q_cmd[p], None, data, linearize(shell.model, data))

    def _work(self, band: str, which) -> mujoco.MjData:
        """A reusable ``MjData`` of the band's models (``which``: ``("at", p)`` posture ``p``'s
        settled state, 1 a step)."""
        key = (band, which)
        if key not in self._scratch:
            self._scratch[key] = mujoco.MjData(self._tested[band].model)
        return self._scratch[key]

    def _tested_at(self, u, p: int, band: str) -> tuple:
        """``(op, seen, responses)``: the operating point with the values at ``u`` settled at
        posture ``p`` in ``band``, its modes as tested, and the responses read of them so far
        (``{freq key: response}``). Those of the last ``u`` are kept: a solver asks for the
        Jacobian where it has just had the residuals, and a sensitivity's base is that residual's
        model (settled from a reset state, so the same bit for bit)."""
        key = u.tobytes()
        if self._at.get("u") != key:
            self._at = {"u": key}
        hit = self._at.get((p, band))
        if hit is None:
            op = self._settle(u, p, band, self._work(band, ("at", p)))
            hit = self._at[(p, band)] = (op, as_tested(op, self._design(u), band), {})
        return hit

    def _settled_from(self, op: OperatingPoint, v, band: str, inertial: bool = False):
        """The linearisation with the values at ``v``, settled from the equilibrium of ``op`` (the
        same posture at nearby values) by chord steps on its stiffness; ``inertial``: ``v``
        differs from ``op``'s values in masses and centres of mass alone."""
        shell = self._model(v, band)
        data = self._work(band, 1)
        data.qpos[:] = op.data.qpos
        data.qvel[:] = op.data.qvel
        data.ctrl[:] = op.data.ctrl
        if self._speed is not None:     # the rotor at the stepped speed
            data.qvel[shell.model.jnt_dofadr[shell.model.joint("spindle_spin").id]] = shell.spindle_rpm * _RPM
        equilibrium(shell.model, data, shell._held, stiffness=op.linear.K)
        # at rest (no spinning rotor) C is the joints' and servos' damping, which a mass or a
        # centre of mass leaves as it is
        rest = inertial and not np.any(data.qvel)
        return linearize(shell.model, data, op.linear.C if rest else None)

    def _inertial_step(self, op: OperatingPoint, v, band: str):
        """The linearisation with masses and centres of mass at ``v``, at ``op``'s state (at
        rest), K by forward differences (:func:`~rmbench.robot.linear.linearize`).

        Not settled again: the step moves the equilibrium by its change of load over the joints'
        stiffness, a second-order change of M and K. On the IRB6660 (3 postures, both bands, the
        45 parameters of the gap diagnosis) it moves each step's frequency shifts by under 1 %;
        settling again took about 40 % of a diagnosis's time.
        """
        data = self._work(band, 1)
        data.qpos[:] = op.data.qpos
        data.qvel[:] = op.data.qvel
        data.ctrl[:] = op.data.ctrl
        return linearize(self._model(v, band).model, data, op.linear.C, differences="forward")

    def _design(self, u):
        """The test design with the sensors placed as ``u`` says."""
        if not self._sensor.any():
            return self.design
        return self.design.with_offsets(sensor_offsets(self.params, u))

    def modes(self, u, p: int, band: str) -> ModelModes:
        """Modes at posture ``p`` in ``band`` with the values at ``u`` (settled, linearised: exact)."""
        return self.response(u, p, band)[0]

    def response(self, u, p: int, band: str, freq=None) -> tuple:
        """Modes at posture ``p`` in ``band`` with the values at ``u``, and the exact receptance as
        tested at ``freq`` (Hz; m/N, shape (n_freq, 4, 4); None without ``freq``)."""
        _, seen, responses = self._tested_at(np.asarray(u, float), p, band)
        key = None if freq is None else np.asarray(freq, float).tobytes()
        if key not in responses:
            responses[key] = seen.response(freq)
        return responses[key]

    def sensitivity(self, u, p: int, band: str, steps, freq=None) -> tuple:
        """Modes at ``u`` and with each parameter stepped by ``steps[i]`` (in ``u``), and with
        ``freq`` the receptances too.

        One eigen-analysis at ``u``; each step's modes follow from it to first order
        (:func:`~rmbench.robot.linear.perturbed_modes`) and the step's change of M, C and K.
        Parameters that enter only C and K (:data:`FAST_KINDS`) change them directly; masses
        and centres of mass change M and the gravity stiffness, read from the stepped model
        linearised at the settled state of ``u`` (:meth:`_inertial_step`); other kinds, and
        any step with the rotor spinning, settle again from that state and are linearised.

        Parameters
        ----------
        u : ndarray, shape (n_params,)
            Parameter values in ``u`` (:mod:`rmbench.robot.parameters`: log factors or steps of
            the parameter's unit).
        p : int
            Posture index.
        band : str
        steps : ndarray, shape (n_params,)
            Each parameter's step, in ``u``.
        freq : ndarray, shape (n_freq,), Hz, optional
            Lines to compute the receptances at.

        Returns
        -------
        base : (ModelModes, ndarray or None)
            The modes at ``u`` and the receptance as tested, m/N, shape (n_freq, 4, 4) (None
            without ``freq``).
        stepped : list of (ModelModes, ndarray or None), one per parameter
            The same with that parameter stepped.
        """
        u = np.asarray(u, float)
        op, seen, _ = self._tested_at(u, p, band)
        lin, cm = op.linear, seen.cm
        base = self.response(u, p, band, freq)
        model = op.robot.model
        names = list(lin.dof_names)
        k = len(self.params)
        dm, dc, dk = (np.zeros((k,) + lin.M.shape) for _ in range(3))
        read = {}       # a sensor stepped: the modes at ``u`` read where it moved
        rest = self._speed is None and not np.any(op.data.qvel)
        k_forward = None    # K at ``u`` by forward differences: the inertial steps' baseline
        for i, prm in enumerate(self.params):
            v = u.copy()
            v[i] += steps[i]
            if self._sensor[i]:
                read[i] = as_tested(op, self._design(v), band, cm).response(freq, base[0].band_peak)
            elif prm.kind in FAST_KINDS:
                C, K = lin.C.copy(), lin.K.copy()
                _perturb(model, names, prm, u[i], v[i], C, K, self.params)
                dc[i], dk[i] = C - lin.C, K - lin.K
            elif rest and prm.kind in ("mass", "com"):
                if k_forward is None:
                    k_forward = self._inertial_step(op, u, band).K
                step = self._inertial_step(op, v, band)
                dm[i], dk[i] = step.M - lin.M, step.K - k_forward
            else:
                step = self._settled_from(op, v, band, inertial=prm.kind in ("mass", "com"))
                dm[i], dc[i], dk[i] = step.M - lin.M, step.C - lin.C, step.K - lin.K
        moved = [i for i in range(k) if not self._sensor[i]]
        stepped = dict(zip(moved, (seen.with_modes(m).response(freq, base[0].band_peak)
                                   for m in perturbed_modes_many(cm, dm[moved], dc[moved], dk[moved]))))
        return base, [read[i] if i in read else stepped[i] for i in range(k)]


def _perturb(model, names, prm, u_old, u_new, C, K, params) -> None:
    """Add to C and K, in place, what moving ``prm`` from ``u_old`` to ``u_new`` changes: its
    kind's matrix perturbation (:attr:`~rmbench.robot.kinds.Kind.perturb`)."""
    perturb = KINDS[prm.kind].perturb
    if perturb is None:  # pragma: no cover - FAST_KINDS only
        raise RmbenchError(f"no matrix perturbation for {prm.kind}")
    perturb(model, names, prm, u_old, u_new, C, K)
