"""A thin-walled part supported by a robot (seed 001, METHODS.md §6): the plate and the scene.

The part is a steel plate clamped at both ends and bending out of its plane (its most flexible
direction, base X in the scene). It enters MuJoCo as a modal model: one body per mode on a slide
joint with unit modal mass, joint stiffness ω_r² and damping 2ζω_r, so that the plate's
displacement at a point s along the span is ``u(s) = Σ_r φ_r(s) q_r`` with the mass-normalised
shapes φ_r of a clamped-clamped Timoshenko beam (:func:`rmbench.robot.beam.section_matrices`).
The plate's in-plane modes (above 3 kHz for 100 mm width) are left out.

The robot's support end effector (a ball caster; here the tool tip's position stands in for the
ball's centre) presses the plate at one point through a normal contact spring K_x (the Hertz
contact linearised at the preload). The spring is a MuJoCo fixed tendon whose length is the
ball's X displacement (the robot's X Jacobian at its equilibrium, as joint coefficients) minus
the plate's displacement at the contact point (the modal shapes there), and whose spring length
carries the preload. Linear in the joint coordinates, it is exactly the spring of RCSA's Eq. 6 in
the linearised dynamics; the preload then settles the assembly at its own equilibrium.

Dimensions: plate 450 x 100 x 6 mm, C45 steel (E 210 GPa, ρ 7850 kg/m³, ν 0.3), 31 mm of each end
in the clamps, so the free span is 388 mm: first modes 212 and 584 Hz (seed: 212 and 567 Hz, its
clamps less than rigid; a clamped-clamped beam has the ratio 2.76).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import mujoco
import numpy as np
from scipy.linalg import eigh

from rmbench.errors import InputError
from rmbench.robot.beam import section_matrices
from rmbench.robot.spec import spec_to_xml

__all__ = ["Plate", "SupportScene", "support_scene", "PART_JOINT"]

#: Prefix of the plate's modal joints in a scene (``part_mode_0``, ``part_mode_1``, ...).
PART_JOINT = "part_mode_"


@dataclass(frozen=True)
class Plate:
    """A plate clamped at both ends, bending through its thickness; SI units.

    Attributes
    ----------
    length, width, thickness : float
        Plate dimensions, m.
    clamp : float
        Length held in each clamp, m; the free span is ``length − 2 clamp``.
    youngs_modulus, density, poisson : float
    zeta : float
        Modal damping ratio of every mode.
    n_modes : int
        Modes kept in the modal model.
    n_el : int
        Timoshenko elements over the span.
    """

    length: float = 0.450
    width: float = 0.100
    thickness: float = 0.006
    clamp: float = 0.031
    youngs_modulus: float = 210e9
    density: float = 7850.0
    poisson: float = 0.3
    zeta: float = 0.002
    n_modes: int = 6
    n_el: int = 80

    def __post_init__(self):
        if not self.span > 0:
            raise InputError(f"plate span must be positive: length {self.length} m, clamps {self.clamp} m")
        if self.n_modes < 1 or self.n_el < 2 * self.n_modes:
            raise InputError("plate needs n_modes ≥ 1 and n_el ≥ 2 n_modes")

    @property
    def span(self) -> float:
        return self.length - 2 * self.clamp

    def _fe(self):
        t, w, e = self.thickness, self.width, self.youngs_modulus
        g = e / (2 * (1 + self.poisson))
        k, m = section_matrices(self.span, self.n_el, ei=e * w * t**3 / 12, kappa_ga=5 / 6 * g * w * t,
                                rho_a=self.density * w * t, rho_i=self.density * w * t**3 / 12)
        free = np.arange(2, k.shape[0] - 2)  # both ends clamped: w = θ = 0
        return k[np.ix_(free, free)], m[np.ix_(free, free)], free

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Natural frequencies (Hz, shape (n_modes,)) and mass-normalised shapes at the FE nodes.

        Returns
        -------
        f_n : ndarray, shape (n_modes,)
        shapes : ndarray, shape (n_el + 1, n_modes)
            Displacement (m per √kg) at the nodes, clamps included (zero there).
        """
        k, m, free = self._fe()
        w2, vec = eigh(k, m, subset_by_index=[0, self.n_modes - 1])
        full = np.zeros((2 * (self.n_el + 1), self.n_modes))
        full[free] = vec
        return np.sqrt(w2) / (2 * np.pi), full[0::2]

    def shapes_at(self, s) -> np.ndarray:
        """Mass-normalised mode shapes at points ``s`` (m from the left clamp), shape (n_points, n_modes)."""
        s = np.atleast_1d(np.asarray(s, float))
        if np.any((s < 0) | (s > self.span)):
            raise InputError(f"plate points must lie on the free span 0..{1e3 * self.span:g} mm")
        _, nodes = self.modes()
        x = np.linspace(0, self.span, self.n_el + 1)
        # nodes every span/80 (4.9 mm): linear interpolation errs < 0.1 % of a mode's peak
        return np.stack([np.interp(s, x, nodes[:, r]) for r in range(self.n_modes)], axis=1)

    def receptance(self, freq: np.ndarray, out, inp) -> np.ndarray:
        """Receptance of the plate alone between points (m from the left clamp), m/N, (n_freq, n_out, n_in)."""
        f_n, _ = self.modes()
        wr = 2 * np.pi * f_n
        w = 2 * np.pi * np.asarray(freq, float)[:, None]
        den = wr**2 - w**2 + 2j * self.zeta * wr * w  # (n_freq, n_modes)
        a, b = self.shapes_at(out), self.shapes_at(inp)
        return np.einsum("or,fr,ir->foi", a, 1 / den, b)


@dataclass(frozen=True)
class SupportScene:
    """A robot pressing a plate: the scene's MJCF and what locates the part in it.

    Attributes
    ----------
    xml : str
        The assembled MJCF (robot, tool, plate modes, contact tendon).
    plate : Plate
    contact : float
        Contact point, m from the left clamp.
    k_x : float
        Contact stiffness, N/m.
    preload : float
        Normal force of the ball on the plate at rest, N.
    q_cmd : ndarray, shape (n_arm,)
        The robot's arm commands (rad).
    spring_length : float
        The contact tendon's rest length, m (kept at full precision: the MJCF writer rounds it to
        6 digits, which at k_x = 2e7 N/m would move the preload by up to 10 N).
    robot_name, tool : str
    """

    xml: str
    plate: Plate
    contact: float
    k_x: float
    preload: float
    q_cmd: np.ndarray
    spring_length: float
    robot_name: str
    tool: str | None

    def robot(self):
        """The scene as a :class:`~rmbench.robot.Robot` (pose it with ``.at(scene.q_cmd)``)."""
        from rmbench.robot.model import Robot

        r = Robot(self.xml, name=f"{self.robot_name}+plate", tool=self.tool)
        t = mujoco.mj_name2id(r.model, mujoco.mjtObj.mjOBJ_TENDON, "part_contact")
        r.model.tendon_lengthspring[t] = [self.spring_length, self.spring_length]
        return r

    def contact_force(self, op=None) -> float:
        """Normal force of the ball on the plate at the scene's equilibrium, N (> 0: pressing)."""
        op = op or self.robot().at(self.q_cmd)
        t = mujoco.mj_name2id(op.robot.model, mujoco.mjtObj.mjOBJ_TENDON, "part_contact")
        return float(self.k_x * (op.data.ten_length[t] - self.spring_length))

    def part_rows(self, op, points) -> np.ndarray:
        """Rows mapping the scene's generalised coordinates to plate displacements at ``points``.

        Parameters
        ----------
        op : OperatingPoint
            The scene robot at its operating point.
        points : sequence of float
            m from the left clamp.

        Returns
        -------
        ndarray, shape (n_points, n_dof)
        """
        phi = self.plate.shapes_at(points)
        rows = np.zeros((phi.shape[0], op.robot.model.nv))
        for r in range(phi.shape[1]):
            j = op.robot.model.joint(f"{PART_JOINT}{r}")
            rows[:, op.robot.model.jnt_dofadr[j.id]] = phi[:, r]
        return rows


def support_scene(robot, q_cmd: np.ndarray, plate: Plate = Plate(), *, contact: float | None = None,
                  k_x: float = 2e7, preload: float = 100.0) -> SupportScene:
    """Build the scene of ``robot`` at arm commands ``q_cmd`` pressing ``plate`` in base X.

    Parameters
    ----------
    robot : Robot
    q_cmd : ndarray, shape (n_arm,), rad
    plate : Plate
    contact : float, optional
        Contact point, m from the left clamp (default 0.4 of the span: no node of the first modes).
    k_x : float
        Normal contact stiffness, N/m (a ball caster's Hertz contact at ~100 N is of order 1e7).
    preload : float
        Normal force at rest, N (≥ 0).
    """
    contact = 0.4 * plate.span if contact is None else float(contact)
    if not 0 < contact < plate.span:
        raise InputError(f"contact point must lie inside the span (0, {1e3 * plate.span:g}) mm")
    if not (np.isfinite(k_x) and k_x > 0):
        raise InputError(f"contact stiffness k_x must be positive, got {k_x}")
    if not (np.isfinite(preload) and preload >= 0):
        raise InputError(f"preload must be zero or positive, got {preload}")
    op = robot.at(np.asarray(q_cmd, float))
    jx = op.coordinate_map(("1X",))[0]  # the ball centre's X per joint, at the robot's equilibrium
    f_n, _ = plate.modes()
    phi = plate.shapes_at(contact)[0]
    spec = mujoco.MjSpec.from_string(robot.xml)
    tip = op.data.site_xpos[mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_SITE, robot.tcp)]
    # the plate's body (visual only), normal along X, just beyond the ball, centred so that the
    # contact point lies at the tip
    ball_r = 0.010
    centre_y = tip[1] + (plate.span / 2 - contact)
    slab = spec.worldbody.add_body(name="part_plate", pos=[tip[0] + ball_r + plate.thickness / 2, centre_y, tip[2]])
    slab.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[plate.thickness / 2, plate.length / 2, plate.width / 2],
                  contype=0, conaffinity=0, rgba=[0.55, 0.6, 0.7, 0.6], mass=0)
    for r, f in enumerate(f_n):
        wr = 2 * math.pi * f
        body = spec.worldbody.add_body(name=f"part_modal_{r}", pos=[tip[0] + 0.1, centre_y, tip[2] - 0.3 - 0.01 * r])
        body.add_joint(name=f"{PART_JOINT}{r}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0],
                       stiffness=[wr**2, 0, 0], damping=2 * plate.zeta * wr)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.004, 0, 0], mass=1.0, contype=0,
                      conaffinity=0, rgba=[0.55, 0.6, 0.7, 0.3])  # unit modal mass
    tendon = spec.add_tendon(name="part_contact", stiffness=[k_x, 0, 0])
    length0 = 0.0
    for i, coef in enumerate(jx):
        if abs(coef) > 1e-12:
            jname = robot.model.joint(robot.model.dof_jntid[i]).name
            tendon.wrap_joint(jname, float(coef))
            length0 += coef * op.data.qpos[robot.model.jnt_qposadr[robot.model.dof_jntid[i]]]
    for r in range(len(f_n)):
        tendon.wrap_joint(f"{PART_JOINT}{r}", float(-phi[r]))
    # compressed by preload/k_x at the robot's own equilibrium: the ball pushes the plate along +X
    tendon.springlength = [length0, length0]
    xml = spec_to_xml(spec)
    # The preload is the contact force once robot and plate have settled against each other; the
    # force is affine in the spring length, so two settles find it exactly.
    trial = SupportScene(xml, plate, contact, float(k_x), float(preload), np.asarray(q_cmd, float),
                         float(length0), robot.name, robot.tool)
    f0 = trial.contact_force()
    trial = replace(trial, spring_length=length0 - 1e-5)
    f1 = trial.contact_force()
    spring_length = length0 - 1e-5 * (preload - f0) / (f1 - f0)
    # the MJCF writer keeps 6 digits; the rest length needs all of them (see SupportScene)
    xml = re.sub(r'(<fixed name="part_contact"[^>]*springlength=")[^"]*"',
                 lambda m: f'{m.group(1)}{float(spring_length):.17g} {float(spring_length):.17g}"', xml)
    header = (f"<!-- rmbench robot-supported part scene (rmbench.robot.part.support_scene): "
              f"{robot.name} with tool {robot.tool} at q_cmd = {np.round(np.degrees(q_cmd), 4).tolist()} deg; "
              f"plate {1e3 * plate.length:g} x {1e3 * plate.width:g} x {1e3 * plate.thickness:g} mm, "
              f"span {1e3 * plate.span:g} mm, modes {np.round(f_n, 1).tolist()} Hz as unit-mass slide "
              f"joints part_mode_*; contact {1e3 * contact:g} mm from the left clamp, "
              f"k_x {k_x:g} N/m, preload {preload:g} N (tendon part_contact) -->\n")
    return SupportScene(header + xml, plate, contact, float(k_x), float(preload), np.asarray(q_cmd, float),
                        float(spring_length), robot.name, robot.tool)
