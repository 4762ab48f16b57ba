"""Mixed-sensitivity H∞ design of proof-mass controllers (METHODS.md §8, seed 004 Paper II).

The generalised plant, per axis i (exogenous inputs w, controls u; exogenous outputs z,
measurements y)::

    w = [d_i, n_a,i, n_p,i]        disturbance force (N), accelerometer and encoder noise (unit)
    z = [W_a a_i, W_p p_i, W_u u_i (, W_o u_i)]
    y = [a_i + noise_acc n_a,i, p_i + noise_pos n_p,i]

``W_o`` (the out-of-band force weight above ``r_o f0``, issue 83) is there only with ``k_o > 0``;
why it weights the force and not the acceleration is in :mod:`rmbench.control.weights`.

The seed's Fig. 2 also has references for the acceleration and the mass position. Both are zero in
every test here (hold the robot still, keep the mass centred); what they contribute to the
synthesis — an exogenous input on each measured channel, which gives D21 full row rank — the
sensor-noise inputs provide. The design is
synthesised with SLICOT's SB10AD (through slycot, as python-control's ``hinfsyn``) at a bounded
bisection over γ; the controller is then reduced by balanced truncation. With several axes the
design is joint (MIMO): the plant's coupling between the axes is in the minimisation.

The seed's "modified" controller (the resonance / anti-resonance pair at the modelled mode taken
out, for robustness to the mode moving with posture) is :func:`modify`.
"""

from __future__ import annotations

from dataclasses import dataclass

import control as ct
import numpy as np
from scipy import linalg

from rmbench.control.controller import Controller
from rmbench.control.plant import Plant
from rmbench.control.weights import Weights
from rmbench.errors import InputError, RmbenchError

__all__ = ["DesignError", "Design", "generalized_plant", "design", "achieves_gamma", "modify", "robust_design",
           "plant_order", "controller_order"]


class DesignError(RmbenchError):
    """The synthesis failed: a rank condition, infeasible weights, a γ bound too low."""


@dataclass(frozen=True)
class Design:
    """A synthesised controller and what it was designed for.

    Attributes
    ----------
    controller : Controller
        Reduced (and, with ``modified``, modified) controller.
    full : Controller
        The controller as synthesised (order of the generalised plant).
    gamma : float
        Achieved H∞ norm of the weighted closed loop.
    plant : Plant
    weights : Weights
    """

    controller: Controller
    full: Controller
    gamma: float
    plant: Plant
    weights: Weights


def plant_order(n_axes: int) -> int:
    """States of the reduced robot plant of a design over ``n_axes`` proof-mass axes."""
    return 14 + 10 * (n_axes - 1)


def controller_order(n_axes: int) -> int:
    """States of the controller of a design over ``n_axes`` proof-mass axes."""
    return 12 + 8 * (n_axes - 1)


def generalized_plant(plant: Plant, weights: Weights, mode_hz=None) -> ct.StateSpace:
    """The weighted generalised plant; inputs ``[w; u]``, outputs ``[z; y]`` (module docstring).

    ``mode_hz`` (one per axis) centres the acceleration weights; default the plant's modes.
    """
    n = plant.n_axes
    f0 = plant.mode_hz if mode_hz is None else tuple(mode_hz)
    if len(f0) != n:
        raise InputError(f"mode_hz needs one frequency per axis ({n}), got {len(f0)}")
    G = plant.ss()
    ax = plant.axes
    blocks = [G]
    for i, a in enumerate(ax):
        blocks.append(ct.tf2ss(weights.acceleration(f0[i]), inputs=f"acc_{a}", outputs=f"z_acc_{a}",
                               name=f"Wa_{a}"))
        blocks.append(ct.tf2ss(weights.position(), inputs=f"pos_{a}", outputs=f"z_pos_{a}", name=f"Wp_{a}"))
        blocks.append(ct.tf2ss(weights.force(), inputs=f"u_{a}", outputs=f"z_u_{a}", name=f"Wu_{a}"))
        if weights.out_of_band:
            blocks.append(ct.tf2ss(weights.out_of_band_force(f0[i]), inputs=f"u_{a}", outputs=f"z_out_{a}",
                                   name=f"Wo_{a}"))
        blocks.append(ct.summing_junction([f"acc_{a}", f"na_{a}"], f"y_acc_{a}", name=f"sa_{a}"))
        blocks.append(ct.summing_junction([f"pos_{a}", f"np_{a}"], f"y_pos_{a}", name=f"sp_{a}"))
        blocks.append(ct.ss([], [], [], [[weights.noise_acc]], inputs=f"n_acc_{a}", outputs=f"na_{a}",
                            name=f"Wna_{a}"))
        blocks.append(ct.ss([], [], [], [[weights.noise_pos]], inputs=f"n_pos_{a}", outputs=f"np_{a}",
                            name=f"Wnp_{a}"))
    inputs = ([f"d_{a}" for a in ax] + [f"n_acc_{a}" for a in ax] + [f"n_pos_{a}" for a in ax]
              + [f"u_{a}" for a in ax])
    z_out = [f"z_out_{a}" for a in ax] if weights.out_of_band else []
    outputs = ([f"z_acc_{a}" for a in ax] + [f"z_pos_{a}" for a in ax] + [f"z_u_{a}" for a in ax] + z_out
               + [f"y_acc_{a}" for a in ax] + [f"y_pos_{a}" for a in ax])
    return ct.interconnect(blocks, inplist=inputs, outlist=outputs, inputs=inputs, outputs=outputs,
                           check_unused=False)


def design(plant: Plant, weights: Weights | None = None, *, order: int | None = 12,
           modified: bool = False, mode_hz=None, gamma_max: float = 1e4, gamma_tol: float = 0.01,
           gamma_margin: float = 1.05) -> Design:
    """Synthesise an H∞ controller for a proof-mass plant.

    Parameters
    ----------
    plant : Plant
    weights : Weights, optional
        Default :class:`Weights()`.
    order : int or None
        Reduce the controller to this many states by balanced truncation (None: keep the
        synthesised order). Where the reduced controller no longer stabilises the design plant,
        the order is raised by two until it does (up to the synthesised one).
    modified : bool
        Take out the controller's resonance / anti-resonance pair at each axis's mode (seed).
    mode_hz : sequence of float, optional
        Modes the acceleration weights centre on (default: the plant's).
    gamma_max : float
        Upper bound of the γ bisection; no controller below it is a :class:`DesignError`.
    gamma_tol : float
        Relative accuracy of the bisection (at most 40 synthesis calls).
    gamma_margin : float
        The controller is computed at ``gamma_margin × γ_opt``: the central controller at the
        optimum itself has needlessly fast poles.

    Returns
    -------
    Design
    """
    weights = weights if weights is not None else Weights()
    _check_weights(weights)
    P = generalized_plant(plant, weights, mode_hz)
    n = plant.n_axes
    nmeas, ncon = 2 * n, n
    gamma, k = _bisect(P, nmeas, ncon, gamma_max, gamma_tol, gamma_margin, weights)
    meta = {"gamma": gamma, "weights": weights.as_dict(), "modified": False,
            "plant": {"source": plant.source, "mode_hz": list(plant.mode_hz), "order": plant.order},
            "mode_hz": list(plant.mode_hz if mode_hz is None else mode_hz)}
    full = Controller(plant.axes, *k, meta=meta)
    base = modify(full, meta["mode_hz"]) if modified else full
    red = base
    if order is not None:
        from rmbench.control.analysis import is_stable

        # the smallest order from ``order`` up whose controller still stabilises the design plant
        for n_k in range(order, base.order, 2):
            cand = reduce(base, n_k)
            if is_stable(plant, cand):
                red = cand
                break
    return Design(red, full, gamma, plant, weights)


def reduce(controller: Controller, order: int) -> Controller:
    """Balanced truncation of the controller's stable part to ``order`` states (unstable part kept)."""
    if order >= controller.order:
        return controller
    sys = ct.ss(controller.A, controller.B, controller.C, controller.D)
    try:
        red = ct.balred(sys, order, method="matchdc")
    except ValueError:
        red = ct.balred(sys, order, method="truncate")
    meta = dict(controller.meta, reduced_from=controller.order)
    return Controller(controller.axes, *(np.asarray(x, float) for x in (red.A, red.B, red.C, red.D)),
                      meta=meta)


def modify(controller: Controller, mode_hz, *, band: float = 0.3, zeta_max: float = 0.5) -> Controller:
    """Take out the pole pair nearest each mode and the zero pair it forms (seed's "modified").

    In the controller's modal form the pole pair within ``±band`` of the mode (the resonance) is
    dropped; with it goes the anti-resonance it formed with the rest. The gain far above the mode
    is kept exactly; well below it the pair's static share is lost (the seed's trade-off: less gain
    right at the modelled mode, more robustness when the real mode sits elsewhere).
    """
    A, B, C, D = controller.A, controller.B, controller.C, controller.D
    w, V = linalg.eig(A)
    Vi = linalg.inv(V)
    keep = np.ones(len(w), bool)
    for f0 in np.atleast_1d(mode_hz):
        w0 = 2 * np.pi * f0
        zeta = -w.real / np.maximum(np.abs(w), 1e-12)
        near = (np.abs(np.abs(w) - w0) < band * w0) & (np.abs(w.imag) > 0) & (zeta < zeta_max) & (zeta > 0)
        if not np.any(near):
            continue
        cand = np.flatnonzero(near)
        best = cand[np.argmin(np.abs(np.abs(w[cand]) - w0))]  # the resonance at the mode
        pair = np.flatnonzero(np.isclose(w, w[best]) | np.isclose(w, np.conj(w[best])))
        keep[pair] = False
    if np.all(keep):
        return Controller(controller.axes, A, B, C, D, dict(controller.meta, modified=True))
    # modal truncation: the pair's term R/(s − λ) + c.c. goes; nothing is added back, so the gain far
    # above the mode is kept and the resonance and the anti-resonance it formed with the rest vanish
    Ck, Bk = C @ V[:, keep], Vi[keep] @ B
    Ak = np.diag(w[keep])
    Ar, Br2, Cr2 = _real_form(Ak, Bk, Ck)
    return Controller(controller.axes, Ar, Br2, Cr2, D.copy(),
                      dict(controller.meta, modified=True,
                           removed_poles_hz=(np.abs(w[~keep]) / 2 / np.pi).tolist()))


def robust_design(plants, weights: Weights | None = None, *, nominal: int | None = None, **kwargs) -> Design:
    """One controller for a family of plants (e.g. the suppressor over the workspace).

    The design plant is the family member whose mode is the median; the acceleration weight's
    band-pass is widened (``zeta_w``) to cover the family's range of mode frequencies, so that the
    minimisation spends its effort wherever the mode may be.
    """
    plants = list(plants)
    if not plants:
        raise InputError("robust_design needs at least one plant")
    weights = weights if weights is not None else Weights()
    f = np.array([p.mode_hz for p in plants])  # (n_plants, n_axes)
    if nominal is None:
        nominal = int(np.argsort(f[:, 0])[len(plants) // 2])
    f0 = np.sqrt(f.min(0) * f.max(0))  # geometric centre of each axis's range
    spread = float(np.max(f.max(0) / f.min(0)))
    zeta_w = max(weights.zeta_w, 0.5 * (spread - 1 / spread) + 0.1)
    d = design(plants[nominal], weights.with_(zeta_w=zeta_w), mode_hz=tuple(f0), **kwargs)
    return d


# -- synthesis -----------------------------------------------------------------------------------
_MESSAGES = {
    1: "the plant and force weight lose column rank on the imaginary axis (A3): a pole of the plant "
       "or of a weight on the jω axis, or the force weight W_u is zero at some frequency — move "
       "weight poles off the axis (f_pl, f_ul > 0)",
    2: "the plant and noise weights lose row rank on the imaginary axis (A4): a measured signal is "
       "not reached by noise — raise noise_acc / noise_pos above zero",
    3: "D12 has not full column rank: the force weight W_u must be nonzero at high frequency (k_u > 0)",
    4: "D21 has not full row rank: the sensor-noise weights noise_acc and noise_pos must be nonzero",
    5: "the SVD in the synthesis did not converge (badly scaled weights?)",
}


_INADMISSIBLE = {
    6: "SLICOT: controller not admissible, gamma too small",
    7: "SLICOT: the X-Riccati equation has no stabilising solution",
    8: "SLICOT: the Y-Riccati equation has no stabilising solution",
    9: "SLICOT: singular loop transformation",
    10: "SLICOT: singular values of D11 could not be estimated",
    11: "SLICOT: the feedthrough loop is singular",
    12: "SLICOT: no stabilising controller",
    "unverified": "the synthesis returned controllers whose closed loop does not reach gamma",
}
_MIN_POLE_HZ = 1e-5  # weight poles nearer the jω axis break hinfsyn's rank conditions (A3, A4)


_MIN_FEEDTHROUGH = 1e-12  # relative to 1: D12 and D21 below this are rank-deficient for SB10AD


def _check_weights(weights: Weights) -> None:
    """Conditions SB10AD needs, checked up front so the message can name the weight."""
    for name in ("f_pl", "f_ul"):
        if getattr(weights, name) < _MIN_POLE_HZ:
            raise DesignError(f"weight pole {name} = {getattr(weights, name):g} Hz lies on the imaginary axis "
                              f"for hinfsyn (rank conditions A3/A4): use {name} >= {_MIN_POLE_HZ:g} Hz")
    if weights.k_u < _MIN_FEEDTHROUGH:
        raise DesignError(f"force weight k_u = {weights.k_u:g} leaves D12 without full column rank: raise k_u")
    for name in ("noise_acc", "noise_pos"):
        if getattr(weights, name) < _MIN_FEEDTHROUGH:
            raise DesignError(f"noise weight {name} = {getattr(weights, name):g} leaves D21 without full row "
                              f"rank: every measurement needs some noise, raise {name}")


def _bisect(P, nmeas, ncon, gamma_max, gamma_tol, margin, weights):
    """Smallest γ (to ``gamma_tol``) with an admissible controller; the controller at margin × γ."""
    from slycot import sb10ad
    from slycot.exceptions import SlycotArithmeticError, SlycotParameterError

    A, B, C, D = (np.asarray(x, float) for x in (P.A, P.B, P.C, P.D))
    n, m, p = A.shape[0], B.shape[1], C.shape[0]

    last = {}

    def attempt(g):
        try:
            out = sb10ad(n, m, p, ncon, nmeas, g, A, B, C, D, job=4)
        except SlycotArithmeticError as err:
            if err.info in _MESSAGES:
                raise DesignError(f"H-infinity synthesis failed: {_MESSAGES[err.info]}") from None
            last["info"] = err.info
            return None  # 6-12: no admissible controller at this γ
        except SlycotParameterError as err:
            raise DesignError(f"H-infinity synthesis rejected its input: {err}") from None
        k = out[1:5]
        # SB10AD can report success on an ill-conditioned Riccati solution whose controller does not
        # reach γ at all (seen as a controller amplifying the mode it should damp): such a γ counts
        # as inadmissible
        if not _achieves(A, B, C, D, k, ncon, nmeas, g):
            last["info"] = "unverified"
            return None
        return k

    if attempt(gamma_max) is None:
        why = _INADMISSIBLE.get(last.get("info"), "no admissible controller")
        raise DesignError(f"no stabilising H-infinity controller with gamma <= {gamma_max:g} ({why}): "
                          f"the weights ask for more than the plant allows (k_a = {weights.k_a:g} against "
                          f"k_u = {weights.k_u:g}, k_p = {weights.k_p:g}); lower k_a, or raise gamma_max")
    lo, hi = 0.0, gamma_max
    for _ in range(40):
        if hi - lo <= gamma_tol * hi:
            break
        mid = 0.5 * (lo + hi) if lo > 0 and hi / lo < 4 else (np.sqrt(lo * hi) if lo > 0 else hi / 4)
        if attempt(mid) is None:
            lo = mid
        else:
            hi = mid
    g = hi * margin
    k = attempt(g)
    if k is None:
        g, k = hi, attempt(hi)
    return float(g), tuple(np.asarray(x, float) for x in k)


_CHECK_HZ = np.geomspace(0.05, 500.0, 400)


def achieves_gamma(plant: Plant, controller: Controller, gamma: float, *, weights: Weights | None = None,
                   mode_hz=None, slack: float = 1.05) -> bool:
    """Whether ``controller`` stabilises the weighted generalised plant of ``plant``
    (:func:`generalized_plant` with ``weights`` and ``mode_hz``) and keeps its closed-loop gain
    from the disturbances and noises to the weighted outputs below ``slack × gamma`` over
    0.05-500 Hz: the check every synthesis result has to pass (SB10AD can report success on an
    ill-conditioned solution whose controller does not reach γ)."""
    P = generalized_plant(plant, weights if weights is not None else Weights(), mode_hz)
    A, B, C, D = (np.asarray(x, float) for x in (P.A, P.B, P.C, P.D))
    k = (controller.A, controller.B, controller.C, controller.D)
    return _achieves(A, B, C, D, k, plant.n_axes, 2 * plant.n_axes, gamma, slack=slack)


def _achieves(A, B, C, D, k, ncon, nmeas, gamma, *, slack: float = 1.05) -> bool:
    """Whether the controller ``k = (Ak, Bk, Ck, Dk)`` stabilises the generalised plant and keeps
    its closed-loop gain from ``w`` to ``z`` below ``slack × γ`` on :data:`_CHECK_HZ`."""
    Ak, Bk, Ck, Dk = (np.asarray(x, float) for x in k)
    m1, p1 = B.shape[1] - ncon, C.shape[0] - nmeas
    B1, B2 = B[:, :m1], B[:, m1:]
    C1, C2 = C[:p1], C[p1:]
    D11, D12, D21, D22 = D[:p1, :m1], D[:p1, m1:], D[p1:, :m1], D[p1:, m1:]
    try:
        E = np.linalg.inv(np.eye(ncon) - Dk @ D22)  # u = E (Ck xk + Dk (C2 x + D21 w))
    except np.linalg.LinAlgError:
        return False
    F = np.linalg.inv(np.eye(nmeas) - D22 @ Dk)
    Acl = np.block([[A + B2 @ E @ Dk @ C2, B2 @ E @ Ck],
                    [Bk @ F @ C2, Ak + Bk @ F @ D22 @ Ck]])
    Bcl = np.vstack([B1 + B2 @ E @ Dk @ D21, Bk @ F @ D21])
    Ccl = np.hstack([C1 + D12 @ E @ Dk @ C2, D12 @ E @ Ck])
    Dcl = D11 + D12 @ E @ Dk @ D21
    if not np.all(np.isfinite(Acl)):
        return False
    lam, V = np.linalg.eig(Acl)
    if np.max(lam.real) >= 0:
        return False
    # all lines at once in the closed loop's modal coordinates
    CV, ViB = Ccl @ V, np.linalg.solve(V, Bcl)
    T = np.einsum("pn,fn,nm->fpm", CV, 1.0 / (2j * np.pi * _CHECK_HZ[:, None] - lam[None]), ViB) + Dcl
    return bool(np.max(np.linalg.svd(T, compute_uv=False)) <= slack * gamma)


def _real_form(A, B, C):
    """Real block-diagonal realisation of a diagonal complex modal form."""
    w = np.diag(A)
    used = np.zeros(len(w), bool)
    blocks_A, rows_B, cols_C = [], [], []
    for i, wi in enumerate(w):
        if used[i]:
            continue
        used[i] = True
        if abs(wi.imag) < 1e-12 * max(abs(wi), 1):
            blocks_A.append(np.array([[wi.real]]))
            rows_B.append(B[i:i + 1].real)
            cols_C.append(C[:, i:i + 1].real)
            continue
        j = next(j for j in range(len(w)) if not used[j] and np.isclose(w[j], np.conj(wi)))
        used[j] = True
        # x_i = a + ib; states [Re x_i, Im x_i]
        blocks_A.append(np.array([[wi.real, -wi.imag], [wi.imag, wi.real]]))
        rows_B.append(np.vstack([B[i].real, B[i].imag]))
        cols_C.append(np.column_stack([2 * C[:, i].real, -2 * C[:, i].imag]))
    return linalg.block_diag(*blocks_A), np.vstack(rows_B), np.hstack(cols_C)
