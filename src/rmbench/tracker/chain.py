"""A serial chain of revolute joints evaluated for many configurations at once (numpy).

Read from the robot's pinocchio model (:class:`rmbench.robot.kinematics.Kinematics`, built from the
same MJCF as MuJoCo) with every passive joint (gearbox flexibility, spindle, suppressor slides)
locked at zero: the rigid arm as its controller believes it to be. Perturbing the joint placements
gives the "true" robot of the tracker simulator and the parameters a calibration identifies.

Shapes: ``q`` is (n_joint,) or (n_config, n_joint) in rad; results carry the same leading shape.
Positions are in the robot base frame, m.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from rmbench.errors import InputError, ModelError

__all__ = ["SerialChain", "ChainState", "GRAVITY", "skew"]

GRAVITY = 9.81
"""Gravitational acceleration, m/s², along base −z."""


@dataclass(frozen=True)
class ChainState:
    """Frames of a chain at m configurations (base frame).

    Attributes
    ----------
    origins : ndarray, shape (m, n_joint, 3), m
        Joint origins.
    axes : ndarray, shape (m, n_joint, 3)
        Joint axes.
    frames : ndarray, shape (m, n_joint, 3, 3)
        Orientation of each joint's frame before its rotation (after its placement).
    bodies : ndarray, shape (m, n_joint, 3, 3)
        Orientation of each body (after its joint's rotation).
    tcp : ndarray, shape (m, 3), m
    tcp_rotation : ndarray, shape (m, 3, 3)
    """

    origins: np.ndarray
    axes: np.ndarray
    frames: np.ndarray
    bodies: np.ndarray
    tcp: np.ndarray
    tcp_rotation: np.ndarray

    def position_jacobian(self) -> np.ndarray:
        """∂tcp/∂q, shape (m, 3, n_joint), m/rad."""
        return np.swapaxes(np.cross(self.axes, self.tcp[:, None, :] - self.origins), 1, 2)

    def placement_jacobian(self) -> np.ndarray:
        """∂tcp/∂(twist of each placement) at zero twist, shape (m, 3, 6 (n_joint + 1)).

        Columns per placement: translation (3, m/m) then rotation (3, m/rad), in the
        placement's own frame; the last six belong to the TCP placement.
        """
        m, n = self.origins.shape[:2]
        out = np.empty((m, 3, 6 * (n + 1)))
        lever = self.tcp[:, None, :] - self.origins                      # (m, n, 3)
        for i in range(n):
            r = self.frames[:, i]                                         # (m, 3, 3)
            out[:, :, 6 * i: 6 * i + 3] = r
            # ω in the placement frame: d tcp = (R ω) × lever = -[lever]x R ω
            out[:, :, 6 * i + 3: 6 * i + 6] = -skew(lever[:, i]) @ r
        out[:, :, 6 * n: 6 * n + 3] = self.tcp_rotation
        out[:, :, 6 * n + 3:] = 0.0  # rotating a point about itself does not move it
        return out


@dataclass(frozen=True)
class SerialChain:
    """Kinematic and mass data of a revolute serial arm.

    Attributes
    ----------
    rotations : ndarray, shape (n_joint, 3, 3)
        Rotation of joint i's frame in joint i−1's frame (the base for i = 0) at q = 0.
    translations : ndarray, shape (n_joint, 3), m
        Origin of joint i's frame in joint i−1's frame.
    axes : ndarray, shape (n_joint, 3)
        Unit rotation axis of each joint in its own frame.
    tool_rotation : ndarray, shape (3, 3)
        Tool centre point (TCP) frame in the last joint's frame.
    tool_translation : ndarray, shape (3,), m
    masses : ndarray, shape (n_joint,), kg
        Rigid body moved by each joint (everything up to the next joint, lumped).
    centres : ndarray, shape (n_joint, 3), m
        Centre of mass of that body in its joint's frame.
    names : tuple of str
        Joint names.
    """

    rotations: np.ndarray
    translations: np.ndarray
    axes: np.ndarray
    tool_rotation: np.ndarray
    tool_translation: np.ndarray
    masses: np.ndarray
    centres: np.ndarray
    names: tuple

    def __post_init__(self):
        n = len(self.names)
        for name, shape in (("rotations", (n, 3, 3)), ("translations", (n, 3)), ("axes", (n, 3)),
                            ("tool_rotation", (3, 3)), ("tool_translation", (3,)),
                            ("masses", (n,)), ("centres", (n, 3))):
            if np.shape(getattr(self, name)) != shape:
                raise InputError(f"{name} must have shape {shape}, got {np.shape(getattr(self, name))}")

    @classmethod
    def from_kinematics(cls, kin, joints) -> "SerialChain":
        """The rigid arm of a robot's pinocchio model, passive joints locked at zero.

        Parameters
        ----------
        kin : rmbench.robot.kinematics.Kinematics
            ``robot.kinematics``.
        joints : sequence of str
            Actuated joints in chain order (``robot.arm_joints``); each must be revolute.
        """
        model = kin.model
        keep = [model.getJointId(j) for j in joints]
        lock = [i for i in range(1, model.njoints) if i not in keep]
        red = pin.buildReducedModel(model, lock, pin.neutral(model))
        if red.njoints - 1 != len(joints):
            raise ModelError(f"the arm joints {tuple(joints)} are not a serial chain")
        rot, trans, axes, masses, centres = [], [], [], [], []
        for i in range(1, red.njoints):
            jm = red.joints[i]
            data = jm.createData()
            jm.calc(data, np.zeros(jm.nq))
            s = np.asarray(data.S).reshape(6)
            if jm.nq != 1 or np.linalg.norm(s[:3]) > 1e-12:
                raise ModelError(f"joint {red.names[i]!r} is not revolute")
            if red.parents[i] != i - 1:
                raise ModelError(f"joint {red.names[i]!r} does not follow {red.names[i - 1]!r}")
            rot.append(red.jointPlacements[i].rotation)
            trans.append(red.jointPlacements[i].translation)
            axes.append(s[3:] / np.linalg.norm(s[3:]))
            masses.append(red.inertias[i].mass)
            centres.append(red.inertias[i].lever)
        frame = red.frames[red.getFrameId(kin.frame)]
        if frame.parentJoint != red.njoints - 1:
            raise ModelError(f"frame {kin.frame!r} is not carried by the last arm joint")
        return cls(np.array(rot), np.array(trans), np.array(axes),
                   frame.placement.rotation.copy(), frame.placement.translation.copy(),
                   np.array(masses), np.array(centres), tuple(joints))

    @property
    def n_joint(self) -> int:
        """Number of joints."""
        return len(self.names)

    def perturbed(self, twists) -> "SerialChain":
        """The chain with placement i replaced by placement i · exp(twist i).

        Parameters
        ----------
        twists : array_like, shape (n_joint + 1, 6)
            Per joint placement, and last the TCP placement: (translation m, rotation rad) in
            the placement's own frame. A rotation about the joint axis is a zero offset.
        """
        tw = np.asarray(twists, float)
        if tw.shape != (self.n_joint + 1, 6):
            raise InputError(f"twists must have shape ({self.n_joint + 1}, 6), got {tw.shape}")
        rot, trans = self.rotations.copy(), self.translations.copy()
        for i in range(self.n_joint):
            m = pin.SE3(rot[i], trans[i]) * pin.exp6(pin.Motion(tw[i]))
            rot[i], trans[i] = m.rotation, m.translation
        tool = pin.SE3(self.tool_rotation, self.tool_translation) * pin.exp6(pin.Motion(tw[-1]))
        return replace(self, rotations=rot, translations=trans, tool_rotation=tool.rotation,
                       tool_translation=tool.translation)

    def with_payload(self, mass: float, centre) -> "SerialChain":
        """The chain carrying an extra point mass on the last body.

        Parameters
        ----------
        mass : float
            kg (≥ 0).
        centre : array_like, shape (3,)
            Position of the mass in the last joint's frame, m.
        """
        if not (np.isfinite(mass) and mass >= 0):
            raise InputError(f"payload mass must be finite and >= 0, got {mass!r}")
        return self.with_point_mass(mass, centre)

    def with_point_mass(self, mass: float, centre) -> "SerialChain":
        """The chain with a point mass of either sign (kg) added to the last body at ``centre``
        (its frame, m): a fitted payload correction may come out negative."""
        masses, centres = self.masses.copy(), self.centres.copy()
        total = masses[-1] + mass
        if total > 0:
            centres[-1] = (masses[-1] * centres[-1] + mass * np.asarray(centre, float)) / total
        masses[-1] = total
        return replace(self, masses=masses, centres=centres)

    def with_mass_scale(self, scale) -> "SerialChain":
        """The chain with each body's mass multiplied by ``scale`` (shape (n_joint,))."""
        return replace(self, masses=self.masses * np.asarray(scale, float))

    def walk(self, q) -> "ChainState":
        """Every frame of the chain at configurations ``q``, shape (..., n_joint), rad: a
        :class:`ChainState` of the ``m`` configurations flattened in C order (positions in m)."""
        q = self._configs(q)
        m = len(q)
        rot = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
        pos = np.zeros((m, 3))
        origins = np.empty((m, self.n_joint, 3))
        axes = np.empty((m, self.n_joint, 3))
        frames = np.empty((m, self.n_joint, 3, 3))
        bodies = np.empty((m, self.n_joint, 3, 3))
        for i in range(self.n_joint):
            pos = pos + rot @ self.translations[i]
            rot = rot @ self.rotations[i]
            origins[:, i], frames[:, i], axes[:, i] = pos, rot, rot @ self.axes[i]
            rot = rot @ _axis_rotation(self.axes[i], q[:, i])
            bodies[:, i] = rot
        tcp = pos + rot @ self.tool_translation
        return ChainState(origins, axes, frames, bodies, tcp, rot @ self.tool_rotation)

    def position(self, q) -> np.ndarray:
        """TCP position, shape (..., 3), m."""
        q = np.asarray(q, float)
        return self.walk(q).tcp.reshape(q.shape[:-1] + (3,))

    def pose(self, q) -> tuple[np.ndarray, np.ndarray]:
        """TCP position (..., 3), m, and rotation (..., 3, 3)."""
        q = np.asarray(q, float)
        state = self.walk(q)
        lead = q.shape[:-1]
        return state.tcp.reshape(lead + (3,)), state.tcp_rotation.reshape(lead + (3, 3))

    def jacobian(self, q) -> np.ndarray:
        """Position Jacobian ∂p/∂q of the TCP, shape (..., 3, n_joint), m/rad."""
        q = np.asarray(q, float)
        return self.walk(q).position_jacobian().reshape(q.shape[:-1] + (3, self.n_joint))

    def gravity_torque(self, q) -> np.ndarray:
        """Torque gravity exerts about each joint axis, shape (..., n_joint), N·m.

        A link-side spring of stiffness k deflects by ``gravity_torque / k`` (sign: positive
        torque turns the joint positively).
        """
        q = np.asarray(q, float)
        st = self.walk(q)
        origins, axes = st.origins, st.axes
        com = origins + np.einsum("mnij,nj->mni", st.bodies, self.centres)
        moment = self.masses[None, :, None] * com                  # m_b c_b
        s = np.cumsum(moment[:, ::-1], axis=1)[:, ::-1]             # Σ_{b ≥ i} m_b c_b
        mass = np.cumsum(self.masses[::-1])[::-1]                   # Σ_{b ≥ i} m_b
        lever = s - mass[None, :, None] * origins
        force = np.array([0.0, 0.0, -GRAVITY])
        tau = np.einsum("mni,mni->mn", axes, _cross(lever, force))
        return tau.reshape(q.shape[:-1] + (self.n_joint,))

    def _configs(self, q) -> np.ndarray:
        q = np.asarray(q, float)
        if q.shape[-1:] != (self.n_joint,):
            raise InputError(f"q must end in {self.n_joint} joint angles, got shape {q.shape}")
        return q.reshape(-1, self.n_joint)


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices [v]x of vectors (m, 3), shape (m, 3, 3)."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of 3-vectors (a (..., 3), b (3,)), the same operations in the same
    order (the same result to the bit) without its axis handling, which cost more than the
    products on the chain's few hundred configurations."""
    cp = np.empty(np.broadcast_shapes(a.shape, b.shape), np.result_type(a, b))
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    cp0, cp1, cp2 = cp[..., 0], cp[..., 1], cp[..., 2]
    np.multiply(a1, b2, out=cp0)
    tmp = np.empty_like(cp0)
    np.multiply(a2, b1, out=tmp)
    cp0 -= tmp
    np.multiply(a2, b0, out=cp1)
    np.multiply(a0, b2, out=tmp)
    cp1 -= tmp
    np.multiply(a0, b1, out=cp2)
    np.multiply(a1, b0, out=tmp)
    cp2 -= tmp
    return cp


_AXIS_TERMS: dict = {}   # axis bytes -> (I, [axis]x, [axis]x²): a chain turns about a few fixed axes


def _axis_rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotations about a fixed unit axis by each angle (Rodrigues), shape (m, 3, 3)."""
    key = np.asarray(axis, float).tobytes()
    terms = _AXIS_TERMS.get(key)
    if terms is None:
        k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
        terms = (np.eye(3), k, k @ k)
        if len(_AXIS_TERMS) >= 64:
            _AXIS_TERMS.clear()
        _AXIS_TERMS[key] = terms
    eye, k, kk = terms
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return eye + s * k + (1.0 - c) * kk
