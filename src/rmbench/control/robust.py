"""The sampled-data loop certified over an identified plant's parameter uncertainty (issue 83, item 1).

:func:`~rmbench.control.sampled.certify_sampled` checks the plants it is given and nothing between
them. A measured plant (:func:`~rmbench.control.identify.fit_modes_matrix`) is known only to the
fit's precision; this module draws plants from the fit's parameter distribution and checks the
hardware's sampled loop (:func:`~rmbench.control.sampled.sampled_radius`) for each, with the
probabilistic guarantee of the scenario approach.

The distribution: Gaussian, centred on the fit, with the fit's covariance ``σ² (JᵀJ)⁺``
(:attr:`MatrixModes.cov`) times ``spread²``, over the fitted modes' log-frequencies, log-damping
ratios and shapes (:attr:`MatrixModes.params`). Why a Gaussian and not the 95 % box of the
standard errors: the fit correlates its parameters (a mode's frequency with its shape, overlapping
modes with each other), which a box ignores; a box of ``p`` per-parameter 95 % intervals covers the
joint distribution with only about ``0.95^p`` (36 % for 20 parameters) and its corners are points
the fit makes unlikely; and the scenario bound is a statement about a probability distribution,
which the Gaussian (the fit's own linearised uncertainty) is. Logarithms keep every drawn
frequency and damping positive. Not drawn: the pseudo-modes of the modes above the band keep their
fitted shapes. They enter the model squared, so where they are small (little of those modes in the
band) the linearised covariance of their shapes is meaningless (standard errors far above their
values); the fitted modes are drawn from their marginal distribution (the covariance's block),
which is wider than the conditional one given the pseudo-modes, so this errs on the safe side.

The guarantee (scenario approach; Calafiore & Campi 2006, Tempo, Calafiore & Dabbene 2013,
*Randomized Algorithms for Analysis and Control of Uncertain Systems*): if ``N`` independent draws
all give a stable loop, then with confidence ``1 − β`` the probability that a plant drawn from the
distribution gives an unstable loop is at most ``ε = 1 − β^(1/N)`` (:func:`scenario_epsilon`): were
it above ``ε``, ``N`` stable draws would have had probability below ``(1 − ε)^N = β``. At β = 0.05,
N = 59 gives ε = 5 % and N = 299 gives 1 %. For a schedule the statement holds per grid posture
(each has its own draws), and for all ``n`` postures at once with confidence ``1 − n β``.
Nothing here is a worst case over an interval (a structured singular value would be); a plant
outside the distribution (a fit with a wrong model order, a robot that drifted since the
measurement) is not covered.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rmbench.control.controller import Controller
from rmbench.control.identify import MatrixModes
from rmbench.control.plant import Plant, ReactionMass, modal_plant, parse_axes
from rmbench.control.sampled import sampled_radius
from rmbench.errors import InputError
from rmbench.plotting import axes_or_new

__all__ = ["scenario_epsilon", "scenario_draws", "draw_modes", "draw_plants", "measured_modes",
           "RobustCertificate", "certify_robust", "certify_schedule_robust"]

DISTRIBUTION = ("Gaussian N(fit, spread² cov) over the fitted modes' ln f_n, ln zeta and shapes "
                "(the fit's least-squares covariance); residual pseudo-modes held at the fit")
"""What the draws are drawn from (module docstring), as the certificate reports it."""


def scenario_epsilon(n_draws: int, beta: float = 0.05) -> float:
    """``ε = 1 − β^(1/N)``: with ``N`` independent draws all stable, P(unstable) ≤ ε with
    confidence ``1 − β`` (module docstring)."""
    if n_draws < 1 or not 0.0 < beta < 1.0:
        raise InputError(f"the scenario bound needs at least one draw and 0 < beta < 1; got {n_draws}, {beta}")
    return float(1.0 - beta ** (1.0 / n_draws))


def scenario_draws(epsilon: float, beta: float = 0.05) -> int:
    """The fewest draws ``N = ⌈ln β / ln(1 − ε)⌉`` whose all being stable bounds P(unstable) by
    ``epsilon`` with confidence ``1 − beta`` (59 for 5 %, 299 for 1 %, at β = 0.05)."""
    if not (0.0 < epsilon < 1.0 and 0.0 < beta < 1.0):
        raise InputError(f"scenario_draws needs 0 < epsilon < 1 and 0 < beta < 1; got {epsilon}, {beta}")
    return int(math.ceil(math.log(beta) / math.log(1.0 - epsilon) - 1e-12))


def draw_modes(fit: MatrixModes, n_draws: int, *, seed: int | np.random.SeedSequence | None = 0,
               spread: float = 1.0) -> list[MatrixModes]:
    """``n_draws`` independent sets of modes from the fit's distribution (module docstring).

    Parameters
    ----------
    fit : MatrixModes
        With a covariance (:func:`~rmbench.control.identify.fit_modes_matrix` gives one).
    n_draws : int
    seed : int, SeedSequence or None
        Of :func:`numpy.random.default_rng`.
    spread : float
        Multiplies every standard error (1: the fit's own; larger: a more cautious distribution).
    """
    if fit.cov is None:
        raise InputError("these modes carry no covariance: draw from a fit (fit_modes_matrix)")
    if n_draws < 1 or not spread >= 0:
        raise InputError(f"draw_modes needs at least one draw and spread >= 0; got {n_draws}, {spread}")
    theta = fit.params
    n, N = fit.shapes.shape
    nf = 2 * (N - fit.n_residual) + n * (N - fit.n_residual)  # the fitted modes' parameters
    lam, U = np.linalg.eigh(0.5 * (fit.cov[:nf, :nf] + fit.cov[:nf, :nf].T))
    root = U * np.sqrt(np.clip(lam, 0.0, None))            # root @ rootᵀ = cov (positive semi-definite)
    z = np.random.default_rng(seed).standard_normal((n_draws, nf))
    # a parameter the data leave undetermined may draw far out (exp of a huge log-frequency):
    # kept as drawn, non-finite included; :func:`certify_robust` counts such a draw as failed
    with np.errstate(over="ignore", invalid="ignore"):
        return [fit.with_params(np.concatenate([theta[:nf] + spread * root @ zi, theta[nf:]])) for zi in z]


def draw_plants(fit: MatrixModes, masses, axes, n_draws: int, *, seed=0, spread: float = 1.0) -> list[Plant]:
    """:func:`draw_modes`, each built into a plant by :func:`~rmbench.control.plant.modal_plant`
    with the reaction masses ``masses`` (one :class:`ReactionMass` per axis) along ``axes``."""
    return [modal_plant(m.f_n, m.zeta, m.shapes, list(masses), axes, source="drawn")
            for m in draw_modes(fit, n_draws, seed=seed, spread=spread)]


def measured_modes(plant: Plant) -> tuple[MatrixModes, list[ReactionMass]]:
    """The fit and the reaction masses a :func:`~rmbench.control.identify.plant_from_frf_matrix`
    plant was built from, read back from its ``info`` (the masses' stroke and peak force are not
    kept there, nor in the dynamics: infinite)."""
    info = plant.info
    if "fit" not in info or "cov" not in info["fit"] or "shapes" not in info:
        raise InputError("the plant carries no fit covariance: build it with plant_from_frf_matrix")
    fit = info["fit"]
    modes = MatrixModes(np.asarray(info["f_n"], float), np.asarray(info["zeta"], float),
                        np.asarray(info["shapes"], float), int(fit["n_residual"]), float(fit["rel_error"]),
                        cov=np.asarray(fit["cov"], float))
    masses = [ReactionMass(r["m"], r["k"], r["b"], np.inf, np.inf) for r in info["reaction_masses"]]
    return modes, masses


@dataclass(frozen=True)
class RobustCertificate:
    """Sampled-data stability over draws of identified plants, with the scenario guarantee.

    Attributes
    ----------
    spectral_radius : ndarray, shape (n_postures, n_draws)
        Of the sampled loop with each drawn plant (< 1 stable); one row for a single controller,
        one per grid posture (C order) for a schedule.
    nominal_radius : ndarray, shape (n_postures,)
        Of the loop with the fitted (nominal) plant.
    beta : float
        One minus the confidence of the scenario bound.
    spread : float
        Factor on the fit's standard errors the draws used.
    seed : int
    hardware : dict
        ``fs`` (Hz), ``substeps``, ``delay_samples``, ``amp_bandwidth`` (Hz) of the loop checked.
    distribution : str
        What the draws were drawn from.
    """

    spectral_radius: np.ndarray
    nominal_radius: np.ndarray
    beta: float
    spread: float
    seed: int
    hardware: dict
    distribution: str = DISTRIBUTION

    @property
    def draws(self) -> int:
        """Draws per posture, ``N``."""
        return int(self.spectral_radius.shape[1])

    @property
    def unstable(self) -> int:
        """Drawn plants whose sampled loop is unstable, over all postures."""
        return int(np.sum(self.spectral_radius >= 1.0))

    @property
    def unbuildable(self) -> int:
        """Drawn parameter sets that make no plant (counted in :attr:`unstable`): the fit leaves a
        parameter so undetermined that its draws leave the physical range."""
        return int(np.sum(~np.isfinite(self.spectral_radius)))

    @property
    def nominal_unstable(self) -> int:
        """Postures whose nominal (fitted) plant's loop is unstable."""
        return int(np.sum(self.nominal_radius >= 1.0))

    @property
    def stable(self) -> bool:
        """Whether every drawn and every nominal loop is stable: the certificate passes."""
        return self.unstable == 0 and self.nominal_unstable == 0

    @property
    def epsilon(self) -> float:
        """Scenario bound on P(unstable) per posture at confidence ``1 − beta`` (valid when
        :attr:`stable`)."""
        return scenario_epsilon(self.draws, self.beta)

    @property
    def worst(self) -> tuple[int, int]:
        """(posture, draw) of the largest spectral radius."""
        i, j = np.unravel_index(int(np.argmax(self.spectral_radius)), self.spectral_radius.shape)
        return int(i), int(j)

    def headline(self) -> dict:
        """``{"stable", "draws", "unstable", "unbuildable", "epsilon", "beta", "max_spectral_radius"}``:
        what a schedule file's ``meta`` keeps of it (plain floats and ints; the radius None where a
        draw made no plant)."""
        i, j = self.worst
        return {"stable": self.stable, "draws": self.draws, "unstable": self.unstable, "unbuildable": self.unbuildable,
                "epsilon": float(self.epsilon), "beta": float(self.beta),
                "max_spectral_radius": (float(self.spectral_radius[i, j]) if np.isfinite(self.spectral_radius[i, j])
                                        else None)}

    def to_dict(self) -> dict:
        """Verdict, scenario bound, counts, the worst draw and every spectral radius, as strict
        JSON values."""
        from rmbench.io.strict_json import jsonable

        i, j = self.worst
        return jsonable({
            "loop": "sampled", "stable": self.stable, "postures": len(self.nominal_radius), "draws": self.draws,
            "unstable": self.unstable, "unbuildable": self.unbuildable, "nominal_unstable": self.nominal_unstable,
            "scenario": {"epsilon": self.epsilon, "beta": self.beta, "confidence": 1.0 - self.beta,
                         "valid": self.stable},
            "worst": {"posture": i, "draw": j, "spectral_radius": self.spectral_radius[i, j]},
            "spread": self.spread, "seed": self.seed, "distribution": self.distribution, "hardware": self.hardware,
            "nominal_radius": self.nominal_radius, "spectral_radius": self.spectral_radius})

    def summary(self) -> str:
        """Verdict; the guarantee (ε, confidence) or how many draws failed; the worst spectral
        radius (dimensionless, per sample)."""
        hw, (i, j) = self.hardware, self.worst
        n_p = len(self.nominal_radius)
        where = f" (posture {i})" if n_p > 1 else ""
        lines = [f"robust sampled-data certificate at {hw['fs']:g} Hz ({hw['delay_samples']} sample(s) delay, "
                 f"amplifier {hw['amp_bandwidth']:g} Hz): {'PASSES' if self.stable else 'FAILS'}",
                 f"{self.draws} plants drawn per posture over {n_p} posture(s), spread x{self.spread:g} of the "
                 f"fit's standard errors: {self.unstable} unstable"
                 + (f" ({self.unbuildable} drew no plant: a parameter the fit leaves undetermined)"
                    if self.unbuildable else "") + f"; nominal {self.nominal_unstable} unstable"]
        if self.stable:
            per = "per posture, " if n_p > 1 else ""
            lines.append(f"guarantee: P(unstable) <= {100 * self.epsilon:.2f} % {per}with confidence "
                         f"{100 * (1 - self.beta):g} % (scenario bound 1 - beta^(1/N))")
        else:
            lines.append("no guarantee: a drawn or nominal loop is unstable")
        lines.append(f"largest spectral radius {self.spectral_radius[i, j]:.6g}{where}, nominal largest "
                     f"{self.nominal_radius.max():.6f}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """Spectral radius of every draw per posture (dots), the nominal (black diamond) and the
        stability limit 1; unstable draws as red crosses.

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        ax = axes_or_new(ax, (6, 3.5))
        n_p, n = self.spectral_radius.shape
        x = np.arange(n_p)[:, None] + np.linspace(-0.3, 0.3, n)[None]  # a strip per posture
        # a draw that made no plant is drawn as a cross at the limit
        rho = np.where(np.isfinite(self.spectral_radius), self.spectral_radius, 1.0)
        bad = self.spectral_radius >= 1.0
        ax.plot(x.ravel(), rho.ravel(), ".", color="C0", ms=3, label="drawn plants")
        ax.plot(x[bad], rho[bad], "x", color="red", label="unstable or no plant")
        ax.plot(np.arange(n_p), self.nominal_radius, "D", color="k", ms=5, label="nominal")
        ax.axhline(1.0, color="k", lw=0.8, ls="--", label="stability limit")
        ax.set_xlabel("grid posture" if n_p > 1 else "")
        ax.set_xticks(np.arange(n_p))
        ax.set_ylabel("spectral radius")
        verdict = f"P(unstable) <= {100 * self.epsilon:.1f} %" if self.stable else f"{self.unstable} unstable"
        ax.set_title(f"robust sampled-data loop, {n} draws: {verdict}")
        ax.legend(fontsize=8)
        return ax


def _hardware_dict(hardware) -> dict:
    return {"fs": float(hardware.fs), "substeps": int(hardware.substeps),
            "delay_samples": int(hardware.delay_samples), "amp_bandwidth": float(hardware.amp_bandwidth)}


def _radius(modes: MatrixModes, masses, axes, controller, hardware) -> float:
    """The sampled loop's spectral radius with the plant of ``modes``; infinite where they make no
    plant (a non-finite or non-positive frequency or damping drawn for a parameter the data leave
    undetermined): a loop on such a plant cannot be vouched for."""
    if not all(np.all(np.isfinite(v)) for v in (modes.f_n, modes.zeta, modes.shapes)):
        return np.inf
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            plant = modal_plant(modes.f_n, modes.zeta, modes.shapes, list(masses), axes, source="drawn")
            return sampled_radius(plant, controller, hardware)
    except (InputError, np.linalg.LinAlgError):  # a frequency so far out that the matrices overflow
        return np.inf


def _radii(fit, masses, axes, controller, hardware, draws, seed, spread) -> tuple[np.ndarray, float]:
    nominal = modal_plant(fit.f_n, fit.zeta, fit.shapes, list(masses), axes, source="measured")
    rho = [_radius(m, masses, axes, controller, hardware)
           for m in draw_modes(fit, draws, seed=seed, spread=spread)]
    return np.array(rho), sampled_radius(nominal, controller, hardware)


def certify_robust(fit: MatrixModes, masses, axes, controller: Controller, hardware, *, draws: int = 59,
                   beta: float = 0.05, spread: float = 1.0, seed: int = 0) -> RobustCertificate:
    """The sampled loop of ``controller`` with ``draws`` plants drawn from ``fit`` (and the nominal).

    Parameters
    ----------
    fit : MatrixModes
        Identified modes with their covariance (:func:`~rmbench.control.identify.fit_modes_matrix`;
        :func:`measured_modes` reads them back from a measured plant).
    masses : sequence of ReactionMass, one per axis
    axes : sequence of str
        The controller's axes.
    controller : Controller
    hardware : Hardware
        :class:`~rmbench.control.closed_loop.Hardware` of the sampled loop.
    draws : int
        ``N``: 59 bounds P(unstable) by 5 %, 299 by 1 %, at β = 0.05 (:func:`scenario_draws`).
    beta : float
        One minus the bound's confidence.
    spread : float
        Factor on the fit's standard errors.
    seed : int
    """
    axes = parse_axes(axes)
    scenario_epsilon(draws, beta)  # validates draws and beta
    rho, nom = _radii(fit, masses, axes, controller, hardware, draws, seed, spread)
    return RobustCertificate(rho[None], np.array([nom]), float(beta), float(spread), int(seed),
                             _hardware_dict(hardware))


def certify_schedule_robust(schedule, fits, masses, hardware, *, draws: int = 59, beta: float = 0.05,
                            spread: float = 1.0, seed: int = 0) -> RobustCertificate:
    """:func:`certify_robust` at every grid posture of a schedule, each with its own controller.

    ``fits`` holds the identified modes at the grid postures (C order over ``schedule.grid``,
    :class:`~rmbench.control.schedule.Schedule`); posture ``i`` draws from its own fit with the seed
    ``[seed, i]``. Between the grid postures is :func:`~rmbench.control.schedule.certify`'s job.
    """
    fits = list(fits)
    if len(fits) != schedule.n_postures:
        raise InputError(f"certify_schedule_robust needs {schedule.n_postures} fits, got {len(fits)}")
    scenario_epsilon(draws, beta)
    axes = parse_axes(schedule.axes)
    rows, nominal = [], []
    for i, (fit, k) in enumerate(zip(fits, schedule.controllers)):
        rho, nom = _radii(fit, masses, axes, k, hardware, draws, np.random.SeedSequence([seed, i]), spread)
        rows.append(rho)
        nominal.append(nom)
    return RobustCertificate(np.array(rows), np.array(nominal), float(beta), float(spread), int(seed),
                             _hardware_dict(hardware))
