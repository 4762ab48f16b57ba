"""Interchangeable cutting tools as lumped Timoshenko beams in MJCF.

A tool is clamped in the holder through a compliant contact (translational stiffness ``k_t`` and
rotational stiffness ``k_r`` per lateral direction, with dampers, METHODS.md §4) and bends along
its overhang. As in RCSA (METHODS.md §4), the shank in the holder moves with the holder, and the
overhang (tool substructure A) couples to it at the holder face through the contact. Two rigid
bodies per tool: the overhang's root segment, on contact slides ``k_t`` and on hinges at the holder
face whose compliance is the contact's ``1/k_r`` in series with the root share ``c1`` of the
bending (no mass lies between them), and the tip segment, hinged ``d2`` from the tip with
compliance ``c2``. The three values ``c1, c2, d2`` are those that
reproduce the Timoshenko cantilever's static flexibility exactly for a tip force and a tip moment:
deflection ``L³/3EI + L/κGA``, rotation ``L/EI`` and the cross term ``L²/2EI``. With the first
hinge at the root the tip segment is long (≈ L/3 less a shear correction), so the chain's fastest
mode stays near 35 kHz on the robot, against 58 kHz for hinges at the Gauss points: it sets the
stable time step of every simulation that keeps the tool flexible. The first bending mode of the clamped overhang lies
within 10 % of Timoshenko theory (6.3 kHz for the Ø20 x 50 mm carbide reference rod;
Euler-Bernoulli says 6.8 kHz).

Names in the tool's MJCF are short (``root`` (the shank), ``overhang``, ``contact_x``, ``contact_rx``, ``bend_y``, ``tip``, ``p1a``);
the robot attaches the tool with the prefix ``tool_``, so in the assembled robot they read
``tool_root``, ``tool_contact_x``, ``tool_contact_rx``, ``tool_bend_y``, ``tool_tip`` and
``tool_p1a``.

Frames: the tool's root body sits at the holder face with its z axis along the tool axis,
pointing from the tip into the spindle; the tool extends along -z. Site ``tip`` is the tool tip
(point 1 of METHODS.md §1), site ``p1a`` the point ``s_1a`` up the tool from the tip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rmbench.errors import ModelError
from rmbench.robot.beam import section_matrices

__all__ = ["ToolGeometry", "TOOLS", "tool_xml"]


@dataclass(frozen=True)
class ToolGeometry:
    """A cylindrical tool, SI units throughout.

    Parameters
    ----------
    name : str
        Bundled name of the tool.
    diameter : float
        Shank diameter, m.
    length : float
        Total length, m (shank in the holder plus overhang).
    overhang : float
        Free length out of the holder face, m.
    flute_length : float
        Length of the fluted part at the tip, m (0 for a plain rod).
    flute_core_ratio : float
        Equivalent bending diameter of the fluted part over the shank diameter.
    youngs_modulus, density, poisson : float
        E in Pa, ρ in kg/m³, ν.
    loss_factor : float
        Structural damping η of the tool material.
    k_t, k_r : float
        Contact stiffness per lateral direction: N/m and N·m/rad.
    c_t, c_r : float
        Contact damping per lateral direction: N·s/m and N·m·s/rad.
    s_1a : float
        Default distance of point 1a up the tool from the tip, m.
    """

    name: str
    diameter: float
    length: float
    overhang: float
    flute_length: float
    flute_core_ratio: float
    youngs_modulus: float
    density: float
    poisson: float
    loss_factor: float
    k_t: float
    k_r: float
    c_t: float
    c_r: float
    s_1a: float = 0.020

    def __post_init__(self):
        for field in ("diameter", "length", "overhang", "youngs_modulus", "density", "k_t", "k_r"):
            if not getattr(self, field) > 0:
                raise ModelError(f"tool {self.name!r}: {field} must be positive, got {getattr(self, field)}")
        if not 0 < self.overhang < self.length:
            raise ModelError(f"tool {self.name!r}: overhang must lie in (0, length)")
        if not 0 <= self.flute_length <= self.overhang:
            raise ModelError(f"tool {self.name!r}: flute_length must lie in [0, overhang]")

    # Section properties of the overhang, with the fluted part folded into one equivalent beam.
    @property
    def bending_diameter(self) -> float:
        """Equivalent diameter of the overhang for bending, m (length-weighted compliance)."""
        f = self.flute_length / self.overhang
        d_f = self.flute_core_ratio * self.diameter
        inv_i = (1 - f) / self.diameter**4 + f / d_f**4
        return inv_i ** -0.25

    @property
    def mass_per_length(self) -> float:
        """Mass per metre of the overhang, kg/m (flutes remove about a third of the section)."""
        area = math.pi * self.diameter**2 / 4
        f = self.flute_length / self.overhang
        return self.density * area * (1 - 0.35 * f)

    @property
    def ei(self) -> float:
        """Bending stiffness EI of the overhang, N·m²."""
        return self.youngs_modulus * math.pi * self.bending_diameter**4 / 64

    @property
    def kappa_ga(self) -> float:
        """Shear stiffness κGA of the overhang, N (κ for a solid circle)."""
        nu = self.poisson
        kappa = 6 * (1 + nu) / (7 + 6 * nu)
        g = self.youngs_modulus / (2 * (1 + nu))
        return kappa * g * math.pi * self.bending_diameter**2 / 4

    def hinge_layout(self) -> tuple[float, float, float]:
        """Bending layout: compliances ``c1`` (root share), ``c2`` (rad/N·m) and ``d2`` (m from the tip).

        Solves c1 + c2 = L/EI, c1 L + c2 d2 = L²/2EI, c1 L² + c2 d2² = L³/3EI + L/κGA.
        """
        big_l, ei = self.overhang, self.ei
        deflection = big_l**3 / (3 * ei) + big_l / self.kappa_ga
        d2 = big_l - 2 * ei * deflection / big_l**2
        c2 = big_l**2 / (2 * ei * (big_l - d2))
        return big_l / ei - c2, c2, d2

    def overhang_matrices(self, n_el: int = 20) -> tuple[np.ndarray, np.ndarray]:
        """Free-free Timoshenko finite-element matrices of the overhang in one lateral plane.

        The overhang is RCSA's tool substructure A (METHODS.md §4): node 0 at the holder face
        (point 2), node ``n_el`` at the tip (point 1); rotations are slopes dw/dx with x running
        from the holder face to the tip, the convention of METHODS.md §3. Section values are those
        of the simulated tool: the equivalent bending section, the fluted mass per length and
        the shank's rotary inertia per length (ρA D²/16).

        Returns
        -------
        K, M : ndarray, shape (2(n_el+1), 2(n_el+1))
            Stiffness (N/m, N, N·m) and mass (kg, kg·m, kg·m²) matrices, DOFs ``[w_0, θ_0, ...]``.
            Structural damping is the loss factor: K(1 + iη).
        """
        return self.overhang_segment(self.overhang, n_el)

    def overhang_segment(self, length: float, n_el: int) -> tuple[np.ndarray, np.ndarray]:
        """Like :meth:`overhang_matrices` for a piece of the overhang of the given length, m."""
        return section_matrices(length, n_el, ei=self.ei, kappa_ga=self.kappa_ga,
                                rho_a=self.mass_per_length,
                                rho_i=self.mass_per_length * self.diameter**2 / 16)

    def shank_mass(self) -> tuple[float, float]:
        """Mass (kg) and rotary inertia about its centre (kg·m²) of the shank held in the holder."""
        shank = self.length - self.overhang
        mass = self.density * math.pi * self.diameter**2 / 4 * shank
        return mass, mass * (self.diameter**2 / 16 + shank**2 / 12)

    def static_tip_compliance(self) -> float:
        """Tip deflection per tip force of the overhang clamped rigidly, m/N (Timoshenko)."""
        return self.overhang**3 / (3 * self.ei) + self.overhang / self.kappa_ga


#: The bundled tools by name: ``dummy`` (the reference carbide rod) and ``endmill`` (a 2-flute
#: PCD end mill), each with its tool-holder contact (SI, :class:`ToolGeometry`).
TOOLS: dict[str, ToolGeometry] = {
    # METHODS.md §4: carbide rod, seed contact values of the reference tool.
    "dummy": ToolGeometry(
        name="dummy", diameter=0.020, length=0.100, overhang=0.050, flute_length=0.0,
        flute_core_ratio=1.0, youngs_modulus=540e9, density=14500.0, poisson=0.25,
        loss_factor=0.001, k_t=6.25e7, k_r=3.86e6, c_t=175.0, c_r=0.14),
    # 2-flute PCD end mill on a carbide shank; flutes reduce the bending core to ~80 % of D.
    "endmill": ToolGeometry(
        name="endmill", diameter=0.018, length=0.095, overhang=0.045, flute_length=0.015,
        flute_core_ratio=0.8, youngs_modulus=540e9, density=14500.0, poisson=0.25,
        loss_factor=0.001, k_t=4.5e7, k_r=4.19e6, c_t=210.0, c_r=1.5),
}


def _cyl_inertia(mass: float, radius: float, length: float) -> tuple[float, float, float]:
    """Diagonal inertia of a solid cylinder about its centre, axis z, kg·m²."""
    ixx = mass * (3 * radius**2 + length**2) / 12
    return ixx, ixx, mass * radius**2 / 2


def _segment(tool: ToolGeometry, z_top: float, z_bot: float, extra_mass: float = 0.0,
             extra_top: float = 0.0) -> str:
    """``<inertial>`` of the overhang between z_top and z_bot (< z_top) plus a shank above."""
    mu = tool.mass_per_length
    r = tool.diameter / 2
    pieces = [(mu * (z_top - z_bot), (z_top + z_bot) / 2, z_top - z_bot)]
    if extra_mass > 0:
        pieces.append((extra_mass, z_top + extra_top / 2, extra_top))
    mass = sum(p[0] for p in pieces)
    zc = sum(p[0] * p[1] for p in pieces) / mass
    ixx = izz = 0.0
    for m, z, ln in pieces:
        a, _, c = _cyl_inertia(m, r, ln)
        ixx += a + m * (z - zc) ** 2
        izz += c
    return (f'<inertial pos="0 0 {zc:.9g}" mass="{mass:.9g}" '
            f'diaginertia="{ixx:.9g} {ixx:.9g} {izz:.9g}"/>')


def tool_xml(tool: ToolGeometry) -> str:
    """MJCF text of a tool, to be attached at a robot's ``tool_mount`` site.

    Returns
    -------
    str
        A complete ``<mujoco>`` document whose worldbody holds the body ``root`` (the shank).
    """
    big_l = tool.overhang
    c1, c2, d2 = tool.hinge_layout()
    z2 = -(big_l - d2)  # bending hinge below the holder face
    k_root = 1 / (1 / tool.k_r + c1)  # contact rotation in series with the root bending
    k_b = 1 / c2
    shank = tool.length - tool.overhang
    shank_mass = tool.density * math.pi * tool.diameter**2 / 4 * shank
    r = tool.diameter / 2
    ixx, _, izz = _cyl_inertia(shank_mass, r, shank)
    # Structural damping as an equivalent viscous damper at the clamped first bending mode; in the
    # root hinge each damper acts on its spring's share of the rotation.
    omega_1 = 1.875**2 * math.sqrt(tool.ei / (tool.mass_per_length * big_l**4))
    c_b = tool.loss_factor * k_b / omega_1
    c_root = (tool.c_r * (k_root / tool.k_r) ** 2
              + tool.loss_factor / (c1 * omega_1) * (k_root * c1) ** 2)
    s = tool.s_1a
    if s < d2:
        p1a_body, p1a_z = "tip_segment", -(d2 - s)
    else:
        p1a_body, p1a_z = "overhang", -(big_l - s)
    p1a = f'<site name="p1a" pos="0 0 {p1a_z:.9g}" size="0.002" rgba="0 0.6 1 1"/>'

    def maybe(body):
        return p1a if body == p1a_body else ""

    return f"""<mujoco model="tool_{tool.name}">
  <!-- Generated by rmbench.robot.tool from ToolGeometry {tool.name!r}; do not edit by hand.
       D={tool.diameter} m, length={tool.length} m, overhang={tool.overhang} m,
       EI={tool.ei:.6g} N m^2, kappaGA={tool.kappa_ga:.6g} N; contact k_t={tool.k_t:.6g} N/m,
       k_r={tool.k_r:.6g} N m/rad in series with the root bending {1 / c1:.6g} N m/rad;
       bending hinge {1000 * d2:.4g} mm from the tip, {k_b:.6g} N m/rad. -->
  <default>
    <geom contype="0" conaffinity="0" group="1" density="0"/>
  </default>
  <worldbody>
    <body name="root">
      <inertial pos="0 0 {shank / 2:.9g}" mass="{shank_mass:.9g}" diaginertia="{ixx:.9g} {ixx:.9g} {izz:.9g}"/>
      <geom type="cylinder" fromto="0 0 {shank:.9g} 0 0 0" size="{r:.9g}" rgba="0.5 0.5 0.55 1"/>
      <body name="overhang">
        <joint name="contact_x" type="slide" axis="1 0 0" stiffness="{tool.k_t:.9g}" damping="{tool.c_t:.9g}"/>
        <joint name="contact_y" type="slide" axis="0 1 0" stiffness="{tool.k_t:.9g}" damping="{tool.c_t:.9g}"/>
        <joint name="contact_rx" type="hinge" axis="1 0 0" stiffness="{k_root:.9g}" damping="{c_root:.9g}"/>
        <joint name="contact_ry" type="hinge" axis="0 1 0" stiffness="{k_root:.9g}" damping="{c_root:.9g}"/>
        {_segment(tool, 0.0, z2)}
        <geom type="cylinder" fromto="0 0 0 0 0 {z2:.9g}" size="{r:.9g}" rgba="0.6 0.6 0.65 1"/>
        {maybe("overhang")}
        <body name="tip_segment" pos="0 0 {z2:.9g}">
          <joint name="bend_x" type="hinge" axis="1 0 0" stiffness="{k_b:.9g}" damping="{c_b:.9g}"/>
          <joint name="bend_y" type="hinge" axis="0 1 0" stiffness="{k_b:.9g}" damping="{c_b:.9g}"/>
          {_segment(tool, 0.0, -d2)}
          <geom type="cylinder" fromto="0 0 0 0 0 {-d2:.9g}" size="{r:.9g}" rgba="0.8 0.5 0.2 1"/>
          <site name="tip" pos="0 0 {-d2:.9g}" size="0.002" rgba="1 0 0 1"/>
          {maybe("tip_segment")}
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
