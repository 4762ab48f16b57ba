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
compliance) change C and K directly; masses and centres of mass move the equilibrium and the
gravity stiffness, so the robot is settled again (from the settled state) and linearised for each.
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np

from rmbench.calibrate.modes import ModelModes, as_tested, with_sensors
from rmbench.errors import RmbenchError
from rmbench.robot.kinds import KINDS
from rmbench.robot.linear import equilibrium, linearize, perturbed_modes_many
from rmbench.robot.model import OperatingPoint

__all__ = ["ModalModel", "FAST_KINDS"]

# kinds whose change enters the linearisation through C and K alone (a matrix perturbation)
FAST_KINDS = tuple(name for name, kind in KINDS.items() if kind.perturb is not None)


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

    @property
    def n_postures(self) -> int:
        return len(self.q_cmd)

    def _model(self, u, band):
        """The band's compiled model with the values at ``u`` (the last few kept)."""
        key = (band, np.asarray(u, float).tobytes())
        hit = self._built.get(key)
        if hit is not None:
            return hit
        base = self._tested[band]
        model = copy.copy(base.model)
        self.params.apply_model(model, u)
        shell = copy.copy(base)     # the same robot with this model: what an OperatingPoint reads
        shell.model = model
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

    def _work(self, band: str, which: int) -> mujoco.MjData:
        """A reusable ``MjData`` of the band's models (``which``: 0 the settled state, 1 a step)."""
        key = (band, which)
        if key not in self._scratch:
            self._scratch[key] = mujoco.MjData(self._tested[band].model)
        return self._scratch[key]

    def _settled_from(self, op: OperatingPoint, v, band: str, inertial: bool = False):
        """The linearisation with the values at ``v``, settled from the equilibrium of ``op`` (the
        same posture at nearby values) by chord steps on its stiffness; ``inertial``: ``v``
        differs from ``op``'s values in masses and centres of mass alone."""
        shell = self._model(v, band)
        data = self._work(band, 1)
        data.qpos[:] = op.data.qpos
        data.qvel[:] = op.data.qvel
        data.ctrl[:] = op.data.ctrl
        equilibrium(shell.model, data, shell._held, stiffness=op.linear.K)
        # at rest (no spinning rotor) C is the joints' and servos' damping, which a mass or a
        # centre of mass leaves as it is
        rest = inertial and not np.any(data.qvel)
        return linearize(shell.model, data, op.linear.C if rest else None)

    def modes(self, u, p: int, band: str) -> ModelModes:
        """Modes at posture ``p`` in ``band`` with the values at ``u`` (settled, linearised: exact)."""
        return self.response(u, p, band)[0]

    def response(self, u, p: int, band: str, freq=None) -> tuple:
        """Modes at posture ``p`` in ``band`` with the values at ``u``, and the exact receptance as
        tested at ``freq`` (Hz; m/N, shape (n_freq, 4, 4); None without ``freq``)."""
        op = self._settle(u, p, band, self._work(band, 0))
        return as_tested(op, self.design, band).response(freq)

    def sensitivity(self, u, p: int, band: str, steps, freq=None) -> tuple:
        """Modes at ``u`` and with each parameter stepped by ``steps[i]`` (in ``u``), and with
        ``freq`` the receptances too.

        One eigen-analysis at ``u``; each step's modes follow from it to first order
        (:func:`~rmbench.robot.linear.perturbed_modes`) and the step's change of M, C and K.
        Parameters that enter only C and K (:data:`FAST_KINDS`) change them directly; masses
        and centres of mass move the equilibrium and the gravity stiffness, so the robot is
        settled again (from the equilibrium at ``u``) and linearised for each.

        Returns
        -------
        base : (ModelModes, ndarray or None)
        stepped : list of (ModelModes, ndarray or None), one per parameter
        """
        u = np.asarray(u, float)
        op = self._settle(u, p, band, self._work(band, 0))
        seen = as_tested(op, self.design, band)
        lin, cm = op.linear, seen.cm
        base = seen.response(freq)
        model = op.robot.model
        names = list(lin.dof_names)
        k = len(self.params)
        dm, dc, dk = (np.zeros((k,) + lin.M.shape) for _ in range(3))
        for i, prm in enumerate(self.params):
            v = u.copy()
            v[i] += steps[i]
            if prm.kind in FAST_KINDS:
                C, K = lin.C.copy(), lin.K.copy()
                _perturb(model, names, prm, u[i], v[i], C, K, self.params)
                dc[i], dk[i] = C - lin.C, K - lin.K
            else:
                step = self._settled_from(op, v, band, inertial=prm.kind in ("mass", "com"))
                dm[i], dc[i], dk[i] = step.M - lin.M, step.C - lin.C, step.K - lin.K
        stepped = [seen.with_modes(m).response(freq, base[0].band_peak)
                   for m in perturbed_modes_many(cm, dm, dc, dk)]
        return base, stepped


def _perturb(model, names, prm, u_old, u_new, C, K, params) -> None:
    """Add to C and K, in place, what moving ``prm`` from ``u_old`` to ``u_new`` changes: its
    kind's matrix perturbation (:attr:`~rmbench.robot.kinds.Kind.perturb`)."""
    perturb = KINDS[prm.kind].perturb
    if perturb is None:  # pragma: no cover - FAST_KINDS only
        raise RmbenchError(f"no matrix perturbation for {prm.kind}")
    perturb(model, names, prm, u_old, u_new, C, K)
