"""Where a tracker gap lies when no source of the library explains it (issue 80, item 3).

Three generic augmentations of each joint, the common ways a real joint departs from a linear
spring at a fixed zero:

* **lost motion** (``jN.lost_motion``, rad): the joint stops short by the same angle on the side
  it was driven from, ``Δθ = b · sign(q_N − q_N,previous)`` (backlash, hysteresis, a loose
  coupling); the previous command is the reading before it in time;
* **a compliance that depends on the torque's side** (``jN.directional_compliance``,
  rad/(N·m)): ``Δθ = c · |τ_N|`` with ``τ_N`` the gravity torque about the joint; beside the
  calibrated (symmetric) compliance it makes the joint softer on one side than on the other
  (a preloaded or worn gear, a counterbalance acting one way);
* **a link that grows** (``jN.growth``, m per hour or kelvin), where the readings carry time
  stamps or temperatures: the placement of joint N lengthens with the drive (a thermal gradient
  along one link, where a thermal drift scales the whole robot).

Each is fitted to first order on top of the calibrated pose model, with the ordinary parameters
(under their priors) and the base registration following, on the training readings; the places
are ranked by the held-out χ² they leave. A place's ``shrink`` is the share of the held-out rms
gap it removes against the same first-order fit without it, and its weight is ``exp(−χ²_held /
2)`` over the candidates, as the FRF localisation (:mod:`rmbench.gap.frf.locate`) reports them.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular

from rmbench.gap.frf.locate import Localisation, Place
from rmbench.gap.tracker.engine import Engine, Fit
from rmbench.gap.tracker.sources import Source

__all__ = ["locate", "approach", "augmentations"]


def approach(data) -> np.ndarray:
    """The sign each joint was last driven with before each reading, shape (n, n_joint): the
    command minus the one read before it in time (by the time stamps where given, else in the
    readings' order); 0 for the first reading and for a joint that did not move."""
    q = np.asarray(data.q, float)
    order = np.argsort(data.t, kind="stable") if data.t is not None else np.arange(len(q))
    out = np.zeros_like(q)
    out[order[1:]] = np.sign(q[order[1:]] - q[order[:-1]])
    return out


def augmentations(model, data) -> dict:
    """Each joint's augmentations as a change per reading and per unit of their parameter:
    ``{(name, words): (joint, (n,) array)}``. ``jN.lost_motion`` and
    ``jN.directional_compliance`` change the joint's angle (rad per unit); ``jN.growth`` the
    length of the joint's placement (m per unit), where the readings carry a drive (hours or
    kelvin)."""
    steps = approach(data)
    torque = np.abs(model.chain.gravity_torque(np.asarray(data.q, float)))
    drive = data.drive()
    out = {}
    for j, name in enumerate(model.chain.names):
        if np.any(steps[:, j]):
            out[(f"{name}.lost_motion", "a lost motion with the direction of approach")] = (j, steps[:, j])
        # a joint gravity never loads (the first, about the vertical) has no side to differ on
        if model.compliance[j] * np.max(torque[:, j], initial=0.0) > 1e-9:
            out[(f"{name}.directional_compliance", "a compliance that differs with the torque's side")] = \
                (j, torque[:, j])
        if drive is not None and j > 0 and np.ptp(drive) > 0:
            out[(f"{name}.growth", f"a link that grows with the {data.drive_kind} (a thermal gradient)")] = \
                (j, np.asarray(drive, float))
    return out


_FORMS = {"lost_motion": "lost motion", "growth": "growth"}     # else a compliance


def _per_reading(column: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """A joint-angle column (3 n,) scaled reading by reading: the whitening acts per reading."""
    return (column.reshape(-1, 3) * factor[:, None]).ravel()


def locate(eng: Engine, start: Fit) -> Localisation:
    """The joints' augmentations (module docstring) ranked on the calibrated model ``start``.

    Returns
    -------
    rmbench.gap.frf.locate.Localisation
        Places best first; ``chi2_held`` is the baseline (the ordinary parameters refitted to
        first order, no candidate).
    """
    train, held = eng.train, eng.held
    args = (start.sources, start.values, start.rotation)
    base_t = np.hstack([eng.columns(*args, train), eng.registration_columns(*args, train)])
    base_h = np.hstack([eng.columns(*args, held), eng.registration_columns(*args, held)])
    sd = eng.prior_sd(start.sources)
    precision = np.concatenate([np.where(np.isfinite(sd), 1.0 / np.where(np.isfinite(sd), sd, 1.0) ** 2, 0.0),
                                np.zeros(6)])
    value = np.concatenate([np.atleast_1d(v) for v in start.values] or [np.zeros(0)])
    r_t = eng.residual(*args, start.translation, train).ravel()
    r_h = eng.residual(*args, start.translation, held).ravel()
    if eng.held_chol is not None:
        # the held-out residuals as the search scores them: whitened by the calibration's own
        # uncertainty carried there too (Engine.carry), so a place's χ² compares with a model's
        r_h, base_h = (solve_triangular(eng.held_chol, x, lower=True, check_finite=False) for x in (r_h, base_h))

    def held_white(g):
        return g if eng.held_chol is None else solve_triangular(eng.held_chol, g, lower=True, check_finite=False)

    def offset_column(j, idx):
        # the joint's zero offset moves the TCP as any small turn of the joint does
        s = Source.of("joint_offset", eng.model.chain.names[j], joint=j)
        return eng.columns(*args, idx, of=(s,))[:, 0]

    def growth_column(j, idx):
        # the placement's length, as a link that grows does
        s = Source.of("link_geometry", eng.model.chain.names[j], joint=j)
        return eng.columns(*args, idx, of=(s,))[:, 0]

    def chi2_held(g_t=None, g_h=None):
        a, b = (base_t, base_h) if g_t is None else (np.column_stack([base_t, g_t]), np.column_stack([base_h, g_h]))
        prec = precision if g_t is None else np.append(precision, 0.0)
        x0 = value if g_t is None else np.append(value, 0.0)
        # one Gauss-Newton step of the regularised fit: the prior pulls the ordinary values to 0
        x0 = np.concatenate([x0, np.zeros(a.shape[1] - len(x0))])
        info = a.T @ a + np.diag(prec)
        rhs = a.T @ r_t - prec * x0
        step = np.linalg.lstsq(info, rhs, rcond=None)[0]
        return float(np.sum((r_h - b @ step) ** 2)), float(step[-1])

    chi2_before, _ = chi2_held()
    fitted = []
    for (name, words), (j, factor) in augmentations(eng.model, eng.data).items():
        column = growth_column if name.endswith("growth") else offset_column
        g_t = _per_reading(column(j, train), factor[train])
        g_h = held_white(_per_reading(column(j, held), factor[held]))
        chi2, size = chi2_held(g_t, g_h)
        fitted.append((chi2, name, words, size))
    if not fitted:
        return Localisation((), chi2_before)
    fitted.sort(key=lambda x: x[0])
    chi2 = np.array([x[0] for x in fitted])
    w = np.exp(-(chi2 - chi2.min()) / 2)
    w /= w.sum()
    places = tuple(Place(name, name.split(".")[0], words, size,
                         float(1 - np.sqrt(c / chi2_before)) if chi2_before > 0 else 0.0, float(wi),
                         form=_FORMS.get(name.rpartition(".")[2], ""))
                   for (c, name, words, size), wi in zip(fitted, w))
    return Localisation(places, chi2_before)
