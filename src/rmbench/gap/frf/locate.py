"""Where a gap lies when no effect of the library names it: generic local augmentations of the
calibrated model, each fitted with the ordinary parameters following, ranked by how much of the
held-out gap it removes.

The augmentations are the physics every robot of this class has somewhere and no data sheet
states, one compliance at a time (:mod:`rmbench.robot.kinds`):

- a **tilt** at each gearbox joint: a compliance about the two axes normal to the joint's (its
  bearing, or whatever bends across the joint);
- a **bending** of each long link: its distal half on a compliance about the two axes normal to
  the link;
- a **resonator** on each link: a package on springs at its centre of mass (a hose, a cable
  chain), tuned to a frequency at which the calibrated model leaves measured modes without a
  partner at the training postures (a package rings at much the same frequency in every posture,
  the robot's own modes do not), a few masses tried on whole solutions.

Each candidate ``c`` enters the calibrated model at zero (rigid) and is fitted to first order on
the training postures together with the ordinary parameters (as :mod:`rmbench.gap.frf.joint`
fits a library effect: ``δz`` eliminated in closed form, the prior on it kept), its size at least
zero. It is scored on the held-out postures with that fit, never refitted: the share of the
held-out rms gap it removes against the same fit without it (``shrink``), and a weight ``exp(−χ²_held / 2)``
over the candidates (Akaike-like: each adds one parameter). The result says where and what, not
a name: "a compliance across j2", "lower_arm bending", "a resonance at 18 Hz on upper_arm". A gap
no candidate reduces (a sensor, a distributed error) stays where it is: the localisation then
says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FOUND", "Place", "Localisation", "candidates", "locate", "locate_calibration"]


@dataclass(frozen=True)
class Place:
    """One generic augmentation, fitted.

    Attributes
    ----------
    name : str
        Its parameter (``j2_flex.tilt_compliance``, ``lower_arm.bending_compliance``).
    where : str
        The joint or link it acts at.
    acts_like : str
        What it is, in words.
    size : float
        Fitted compliance, rad/(N·m) (first order, from rigid); a resonator's package mass, kg.
    shrink : float
        Share of the calibrated model's held-out rms gap it removes (may be negative).
    weight : float
        Its evidence weight over the candidates (sums to 1).
    at : tuple of tuple of float
        Where it is drawn, (x, z) in m at the zero posture: the joint's axis point, or the link's
        two ends.
    frequency : float
        A resonator's tuning against its link held still, Hz (0 for a compliance).
    form : str
        What it is where neither a compliance nor a resonance (a tracker's ``"lost motion"``,
        rad); empty otherwise.
    """

    name: str
    where: str
    acts_like: str
    size: float
    shrink: float
    weight: float
    at: tuple = ()
    frequency: float = 0.0
    form: str = ""

    @property
    def what(self) -> str:
        """``"compliance"``, ``"resonance"`` or the place's own :attr:`form`."""
        return self.form or ("resonance" if self.frequency > 0 else "compliance")

    def to_dict(self) -> dict:
        return {"name": self.name, "where": self.where, "acts_like": self.acts_like, "size": self.size,
                "frequency": self.frequency, "shrink": self.shrink, "weight": self.weight,
                "at": [list(a) for a in self.at], "what": self.what}


@dataclass(frozen=True)
class Localisation:
    """The ranked places of a gap.

    Attributes
    ----------
    places : tuple of Place
        Best first (lowest held-out χ²).
    chi2_held : float
        The held-out χ² of the calibrated model's residual with the ordinary parameters refitted
        to first order and no candidate: the baseline each place's shrink is taken against.
    links : tuple of tuple of float
        The robot's links at the zero posture seen from the side, ``(x0, z0, x1, z1)`` in m: what
        a figure draws the places on.
    """

    places: tuple
    chi2_held: float
    links: tuple = ()

    @property
    def found(self) -> bool:
        """Whether the best place removes at least a quarter of the held-out rms gap."""
        return bool(self.places) and self.places[0].shrink >= FOUND

    def summary(self) -> str:
        """One line: where, what, how much, how sure."""
        if not self.places:
            return "no place to test"
        p = self.places[0]
        if not self.found:
            return (f"no single augmentation of a joint or link explains it (the best, {p.acts_like}, "
                    f"removes {100 * p.shrink:.0f} % of the held-out gap): a sensor or a distributed error")
        size = {"resonance": f"{p.size:.1f} kg", "compliance": f"{p.size / 1e-9:.0f} µrad/(kN·m)",
                "growth": f"{p.size * 1e6:.1f} µm per hour or kelvin"}.get(p.what, f"{abs(p.size) * 1e6:.0f} µrad")
        return (f"localised at {p.where}: acts like {p.acts_like} of {size}, removing "
                f"{100 * p.shrink:.0f} % of the held-out gap (confidence {p.weight:.2f})")

    def to_dict(self) -> dict:
        return {"found": self.found, "summary": self.summary(), "chi2_held": self.chi2_held,
                "places": [p.to_dict() for p in self.places], "links": [list(x) for x in self.links]}


FOUND = 0.25       # a place that removes less of the held-out rms gap localises nothing
_STEP = 20.0        # finite-difference step of a candidate compliance, µrad/(kN·m)
_REFINE = 3         # candidates evaluated again on whole solutions
_TRIAL = (50.0, 200.0, 800.0)     # their sizes where the first order says none, µrad/(kN·m)
_PACKAGES = (2.0, 5.0, 12.0)      # kg: a resonator's masses tried (a hose or cable chain: 3-20 kg)
_TUNINGS = 2                      # at most this many frequencies tried
_SAME_RING = 0.1                  # unpartnered modes within 10 % of each other ring at one frequency


def candidates(robot) -> tuple:
    """The augmentations' parameter names for ``robot``: a tilt at each gearbox joint, a bending
    of each long link (:mod:`rmbench.robot.parameters`' ``tilt`` and ``bending`` groups)."""
    from rmbench.robot.parameters import parameter_set

    _, params = parameter_set(robot, ("tilt", "bending"))
    return tuple(params.names)


def resonators(robot) -> tuple:
    """The links a resonator is tried on (those the ``masses`` group calibrates), and their
    parameter names ``LINK.resonator_mass``, ``LINK.resonance`` in that order."""
    from rmbench.robot.parameters import parameter_set

    _, params = parameter_set(robot, ("masses",))
    links = tuple(n.rsplit(".", 1)[0] for n in params.names)
    return links, tuple(f"{b}.{f}" for b in links for f in ("resonator_mass", "resonance"))


def _words(name: str) -> tuple[str, str]:
    target, field = name.split(".", 1)
    if field == "tilt_compliance":
        joint = target.removesuffix("_flex")
        return joint, f"a compliance across {joint} (about the two axes normal to its own)"
    return target, f"{target} bending (its distal half turning about the two axes normal to it)"


def locate(calibrated, data, train, held, ordinary, settings) -> Localisation:
    """Rank the generic augmentations of a calibrated model by the held-out gap each removes.

    Parameters
    ----------
    calibrated : Robot
        The calibrated model (the ordinary parameters at their fitted values).
    data : ModalData
        The measured modes, every posture the calibration saw or held out.
    train, held : sequence of int
        Posture indices into ``data``.
    ordinary : Ordinary
        The ordinary parameters linearised at the calibration (:class:`~rmbench.gap.frf.joint.Ordinary`),
        keyed by posture index into ``data``.
    settings : CalibrationSettings
        The calibration's (its residual's step and workers).
    """
    from rmbench.calibrate.model import ModalModel
    from rmbench.calibrate.problem import Problem
    from rmbench.robot.parameters import ParameterSet, parameter_set

    names = candidates(calibrated)
    rob, params = parameter_set(calibrated, ("tilt", "bending"))
    cands = ParameterSet([p for p in params if p.name in names])
    q = np.array([calibrated.ik(p).q for p in data.postures])
    mm = ModalModel(rob, cands, data.design, q, data.bands)
    problem = Problem(mm, data, list(train) + list(held), settings)
    # forward differences of whole solutions: at rigid, a compliance's hinge does not move in any
    # mode, so the first-order (matrix) sensitivity the calibration uses reads zero there
    steps = _STEP * np.ones(len(cands))
    try:
        base = np.zeros(len(cands))
        stepped = [base + h * np.eye(len(cands))[i] for i, h in enumerate(steps)]
        e, *rest = problem.residuals_many([base] + stepped)
        g = np.column_stack([(r - e) / h for r, h in zip(rest, steps)])
        lin = _Following.of(problem, ordinary, train)
        tunings = _tunings(problem, e, data, train)
        fits = _fitted(problem, e, g, cands, lin)
    finally:
        problem.close()
    # resonators on a model of their own (their packages' slides would slow every evaluation
    # above), only where some measured modes lack a partner
    rings = _ringing(calibrated, data, list(train) + list(held), settings, lin, tunings) if tunings else []
    return _ranked(fits, names, cands, rings, calibrated)


def _tunings(problem, e, data, train) -> list:
    """Frequencies (Hz) at which measured modes of the training postures have no partner in the
    calibrated model (a residual's slot at :data:`~rmbench.calibrate.residual.UNPAIRED`),
    grouped within :data:`_SAME_RING`, those found at the most postures first (at least two):
    where a package rings."""
    from rmbench.calibrate.residual import UNPAIRED

    found, at = [], 0
    for (p, b), size in zip(problem.keys, problem.sizes):
        meas = data.modes[p][b]
        if p in set(train):
            first = e[at:at + 4 * len(meas)].reshape(len(meas), 4)[:, 0]
            found += [(float(f), p) for f in np.asarray(meas.f_n)[np.isclose(first, UNPAIRED)]]
        at += size
    found.sort()
    groups = []
    for f, p in found:
        if groups and f <= groups[-1][0][0] * (1 + _SAME_RING):
            groups[-1].append((f, p))
        else:
            groups.append([(f, p)])
    groups = [g for g in groups if len({p for _, p in g}) >= 2]
    groups.sort(key=lambda g: -len({p for _, p in g}))
    return [float(np.median([f for f, _ in g])) for g in groups[:_TUNINGS]]


def _ringing(calibrated, data, postures, settings, lin, tunings) -> list:
    """``(link, f, mass, held-out χ²)`` of a resonator on each link at each tuning, the mass of
    :data:`_PACKAGES` with the lowest training objective, on whole solutions with the ordinary
    parameters following to first order."""
    from rmbench.calibrate.model import ModalModel
    from rmbench.calibrate.problem import Problem
    from rmbench.robot.parameters import ParameterSet, parameter_set

    links, rings = resonators(calibrated)
    rob, params = parameter_set(calibrated, ("masses",), extra=rings)
    cands = ParameterSet([p for p in params if p.name in rings])
    q = np.array([calibrated.ik(p).q for p in data.postures])
    trials, us = [], []
    for k, b in enumerate(links):
        for f in tunings:
            for m in _PACKAGES:
                u = np.zeros(len(cands))
                u[2 * k], u[2 * k + 1] = cands.params[2 * k].to_u(m), cands.params[2 * k + 1].to_u(f)
                trials.append((b, f, m))
                us.append(u)
    problem = Problem(ModalModel(rob, cands, data.design, q, data.bands), data, postures, settings)
    try:
        residuals = problem.residuals_many(us)
    finally:
        problem.close()
    best = {}
    for (b, f, m), r in zip(trials, residuals):
        objective, chi2 = _followed(r, lin)
        if (b, f) not in best or objective < best[(b, f)][0]:
            best[(b, f)] = (objective, m, chi2)
    return [(b, f, m, chi2) for (b, f), (_, m, chi2) in best.items()]


@dataclass(frozen=True)
class _Following:
    """The ordinary parameters following a candidate to first order: their sensitivity ``J``
    (rows of the residual, per prior σ), calibrated values ``z`` (prior σ), the normal matrix of
    the training rows ``gram`` (``JᵀJ + I``) and the training and held-out rows ``tr``, ``he``."""

    J: np.ndarray
    z: np.ndarray
    gram: np.ndarray
    tr: np.ndarray
    he: np.ndarray

    @classmethod
    def of(cls, problem, ordinary, train) -> "_Following":
        k = len(ordinary.z)
        rows_train, rows_held, J = [], [], []
        at = 0
        for (p, b), size in zip(problem.keys, problem.sizes):
            block = ordinary.blocks.get((p, b))
            J.append(block if block is not None and block.shape[0] == size else np.zeros((size, k)))
            (rows_train if p in set(train) else rows_held).extend(range(at, at + size))
            at += size
        J = np.vstack(J)
        tr = np.array(rows_train, int)
        return cls(J, np.asarray(ordinary.z, float), J[tr].T @ J[tr] + np.eye(k), tr, np.array(rows_held, int))

    def step(self, e: np.ndarray) -> np.ndarray:
        """``δz`` minimising the training rows' ``‖e + J δz‖² + ‖z + δz‖²``."""
        return -np.linalg.solve(self.gram, self.J[self.tr].T @ e[self.tr] + self.z)



def _fitted(problem, e, g, cands, lin) -> tuple:
    """The held-out χ² with no candidate (the ordinary parameters alone following) and
    ``[(size, held-out χ²)]`` of each compliance candidate: fitted to first order, the best
    :data:`_REFINE` again on whole solutions along their first-order direction."""
    # the baseline: the same first-order fit with no candidate, so that each candidate is judged
    # by what it adds, not by the linearisation's drift
    _, chi2_before = _fit_one(e, np.zeros(len(e)), lin)
    fits = [_fit_one(e, g[:, c], lin) for c in range(len(cands))]
    for c in np.argsort([chi2 for _, chi2 in fits])[:_REFINE]:
        fits[c] = _refined(problem, c, fits[c][0], len(cands), lin)
    return chi2_before, fits


def _ranked(fitted, names, cands, rings, calibrated) -> Localisation:
    """The places of the compliance candidates ``fitted`` (:func:`_fitted`) and the resonators
    ``rings`` (:func:`_ringing`), ranked by held-out χ²."""
    chi2_before, fits = fitted

    def shrink(chi2_after):
        return float(1 - np.sqrt(chi2_after / chi2_before)) if chi2_before > 0 else 0.0

    places = []
    for c, (size, chi2_after) in enumerate(fits):
        where, words = _words(names[c])
        places.append((chi2_after, Place(names[c], where, words, size * cands.params[c].unit, shrink(chi2_after), 0.0)))
    for b, f, m, chi2_after in rings:
        places.append((chi2_after, Place(f"{b}.resonator", b, f"a resonance at {f:.1f} Hz (a package on springs)",
                                         m, shrink(chi2_after), 0.0, frequency=f)))
    places.sort(key=lambda x: x[0])
    chi2 = np.array([x[0] for x in places])
    w = np.exp(-(chi2 - chi2.min()) / 2)
    w /= w.sum()
    links, at = _side_view(calibrated.model)
    ranked = tuple(Place(p.name, p.where, p.acts_like, p.size, p.shrink, float(wi), at.get(p.where, ()),
                         p.frequency) for (_, p), wi in zip(places, w))
    return Localisation(ranked, chi2_before, links)


def _side_view(model) -> tuple[tuple, dict]:
    """The links of ``model`` at its zero posture seen from the side, ``(x0, z0, x1, z1)`` each
    (m), and where each joint (``jN``: its axis point) and body (its origin and its first child's)
    lies, ``{name: ((x, z), ...)}``."""
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    links, at = [], {}
    for b in range(1, model.nbody):
        parent = int(model.body_parentid[b])
        if parent > 0:
            links.append((float(data.xpos[parent, 0]), float(data.xpos[parent, 2]),
                          float(data.xpos[b, 0]), float(data.xpos[b, 2])))
        children = [c for c in range(model.nbody) if model.body_parentid[c] == b]
        if children:
            at[model.body(b).name] = ((float(data.xpos[b, 0]), float(data.xpos[b, 2])),
                                      (float(data.xpos[children[0], 0]), float(data.xpos[children[0], 2])))
    for j in range(model.njnt):
        name = model.joint(j).name
        if name.endswith("_flex"):
            at[name.removesuffix("_flex")] = ((float(data.xanchor[j, 0]), float(data.xanchor[j, 2])),)
    return tuple(links), at


def locate_calibration(robot, data, cal, settings) -> Localisation:
    """:func:`locate` for a :class:`~rmbench.calibrate.result.Calibration` ``cal`` of the nominal
    ``robot`` to ``data`` with ``settings``, on its training and held-out postures (a diagnosis
    that has its calibration's linearisation already passes it to :func:`locate` itself)."""
    from rmbench.calibrate import linearisation
    from rmbench.gap.frf.joint import Ordinary
    from rmbench.robot import Robot

    if not cal.held:
        raise ValueError("a localisation needs held-out postures to score on")
    blocks, z, names = linearisation(robot, data, cal.u, range(len(data.postures)), settings)
    ordinary = Ordinary({key: J for key, (_, J) in blocks.items()}, z, names)
    calibrated = Robot(cal.xml, name=robot.name, tool=robot.tool, spindle_rpm=robot.spindle_rpm)
    return locate(calibrated, data, cal.train, cal.held, ordinary, settings)


def _refined(problem, c: int, theta: float, k: int, lin: _Following) -> tuple[float, float]:
    """``(θ, held-out χ²)`` of candidate ``c`` evaluated on whole solutions at a few sizes about its
    first-order one (a compliance's effect is far from linear at the sizes a form error reaches),
    the ordinary parameters following each to first order; the size with the lowest training
    objective (data and prior) kept, never the held-out one."""
    sizes = [theta * f for f in (0.5, 1.0, 2.0, 4.0)] if theta > 0 else list(_TRIAL)
    us = [np.eye(k)[c] * t for t in sizes]
    best = None
    for t, e in zip(sizes, problem.residuals_many(us)):
        objective, chi2 = _followed(e, lin)
        if best is None or objective < best[0]:
            best = (objective, t, chi2)
    return best[1], best[2]


def _followed(e, lin: _Following) -> tuple[float, float]:
    """``(training objective, held-out χ²)`` of a whole solution's residual ``e`` with the ordinary
    parameters following to first order (data and prior on the training rows)."""
    dz = lin.step(e)
    train = e[lin.tr] + lin.J[lin.tr] @ dz
    res = e[lin.he] + lin.J[lin.he] @ dz
    return float(train @ train + (lin.z + dz) @ (lin.z + dz)), float(res @ res)


def _fit_one(e, g, lin: _Following) -> tuple[float, float]:
    """``(θ, held-out χ²)`` of one candidate column ``g`` (per unit of its ``u``) fitted with the
    ordinary parameters following to first order, ``θ ≥ 0``: the training residual
    ``[e + J δz + g θ ; z + δz]`` is linear in ``(δz, θ)``, so ``δz`` is eliminated in closed form
    and ``θ`` is a one-dimensional least squares."""
    tr, he, Jt = lin.tr, lin.he, lin.J[lin.tr]
    # δz(θ) = a + b θ
    a = lin.step(e)
    b = -np.linalg.solve(lin.gram, Jt.T @ g[tr])
    r0 = np.concatenate([e[tr] + Jt @ a, lin.z + a])
    r1 = np.concatenate([g[tr] + Jt @ b, b])
    theta = max(0.0, -float(r0 @ r1) / float(r1 @ r1)) if r1 @ r1 > 0 else 0.0
    res = e[he] + lin.J[he] @ (a + b * theta) + g[he] * theta
    return theta, float(res @ res)
