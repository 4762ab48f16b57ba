"""Model updating: the ordinary parameters of a nominal robot fitted to measured modes.

The residual is the gap diagnosis's (:mod:`rmbench.calibrate.residual`): measured modes paired with
the model's by an assignment on MAC and frequency, each pair giving its frequency error
``ln(f_model/f_meas)``, damping error ``ln(ζ_model/ζ_meas)``, residue scale and shape ``√(1 − MAC)``,
each divided by the measurement's standard error and a floor. Unpaired modes are counted and
weigh a constant (no gradient), so the vector keeps its layout while the pairing changes from one
iteration to the next.

The fit is a maximum a posteriori estimate in the parameters' ``u`` (log factors, or offsets), with
each parameter's prior range read as ±2 standard deviations about the nominal: Tikhonov
regularisation toward the nominal of unit weight on that scale. It is solved by a bounded trust-region
Gauss-Newton (:func:`rmbench.calibrate.solver.solve`) with forward-difference sensitivities of the
exact linearisation (:class:`~rmbench.calibrate.model.ModalModel`); the pairing is held fixed while
a Jacobian is taken and renewed at every step (:class:`~rmbench.calibrate.problem.Problem`).

A fit from the nominal starts from the best of a few gross starts and, when the model is still far
from the data there, a coarse stage on the frequencies alone (:mod:`rmbench.calibrate.start`). With
the FRFs it runs in two stages: the modes alone from the nominal, then modes and FRFs together from
there. What the data determined, and what they leave at the prior, is read from the posterior
(:mod:`rmbench.calibrate.account`) into a :class:`~rmbench.calibrate.result.Calibration`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from rmbench.calibrate.account import account
from rmbench.calibrate.design import sensor_parameter
from rmbench.calibrate.model import ModalModel, spindle_parameter
from rmbench.calibrate.problem import Problem
from rmbench.calibrate.residual import pair
from rmbench.calibrate.result import Calibration, ParameterEstimate, error_summary, mode_errors
from rmbench.calibrate.solver import IDENTIFIABLE, WEAK, Bounds, SolverOptions, solve
from rmbench.calibrate.start import coarse_start, free_start, given_start
from rmbench.errors import InputError, RmbenchError, UnreachablePosture
from rmbench.robot.parameters import DEFAULT_GROUPS, OPTIONAL_GROUPS, ParameterSet, parameter_set
from rmbench.threads import one_blas_thread

# Calibration, ParameterEstimate, mode_errors, error_summary (rmbench.calibrate.result) and the
# identifiability thresholds are re-exported: callers import them from here
__all__ = ["CalibrationSettings", "ParameterEstimate", "Calibration", "calibrate", "linearisation", "model_of",
           "mode_errors", "error_summary", "IDENTIFIABLE", "WEAK"]


@dataclass(frozen=True)
class CalibrationSettings:
    """How a calibration runs.

    Attributes
    ----------
    groups : tuple of str
        Parameter groups (:data:`rmbench.robot.parameters.GROUPS`).
    prior_weight : float
        Multiplies the prior term (1: the prior ranges as stated).
    max_iter : int
        Most evaluations of the fine stage, four more per parameter of a model-form group
        (:func:`fine_limit`; the coarse stage, when the start is far, takes at most 10).
    step : float
        Forward-difference step, as a share of each parameter's prior standard deviation.
    workers : int or None
        Worker processes for the sensitivities (None: the process's share of the cores).
    frf : bool
        Add the FRF residuals (mean log-magnitude gap per entry and quarter band,
        :func:`~rmbench.calibrate.residual.frf_residuals`) to the modal ones, where the data
        carry FRFs (:attr:`ModalData.frf`): they see what lies between and beyond the modes (a
        tool contact's residual flexibility, a sensor's gain). A fit from the nominal (no
        ``start``) fits the modes alone first and adds the FRFs from there.
    extra : tuple of str
        Parameters in no group (:data:`rmbench.robot.parameters.STRUCTURAL`, ``BODY.mass``, a
        sensor's placement ``sensor.BAND:COORD.along`` or ``.angle``,
        :func:`~rmbench.calibrate.design.sensor_parameter`; the spindle's speed ``spindle.speed``,
        :func:`~rmbench.calibrate.model.spindle_parameter`) fitted beside the groups'.
    free : tuple of str
        Parameters fitted without their prior and with wide bounds
        (:meth:`~rmbench.robot.parameters.ParameterSet.freed`): a structural effect's size, which
        no ordinary spread describes.
    start_rank : int
        Which of the gross starts (:func:`~rmbench.calibrate.start.gross_start`), ranked by their
        coarse residual, a fit from the nominal begins at: 0 the best. The coarse residual does not
        rank the basins the fit ends in; a diagnosis tries the next ones for a candidate that closed
        most of the gap but not all of it (:func:`rmbench.gap.frf.confirm.confirm`).
    robust : float or None
        Huber's threshold on the fine stage's residuals, in standard errors
        (:class:`~rmbench.calibrate.solver.SolverOptions`); None: least squares.
    """

    groups: tuple = DEFAULT_GROUPS
    prior_weight: float = 1.0
    max_iter: int = 16
    step: float = 0.02
    workers: int | None = None
    frf: bool = False
    extra: tuple = ()
    free: tuple = ()
    start_rank: int = 0
    robust: float | None = 3.0


@one_blas_thread
def calibrate(robot, data, *, held=(), settings: CalibrationSettings = CalibrationSettings(),
              start: dict | None = None, progress=None) -> Calibration:
    """Calibrate a nominal robot's ordinary parameters to measured modes.

    Parameters
    ----------
    robot : Robot
        The nominal robot (with its tool).
    data : ModalData
        Measured modes at measured postures (:func:`~rmbench.calibrate.data.load_modal_data`).
    held : sequence of int
        Posture indices held out of the fit and scored after it.
    settings : CalibrationSettings
    start : dict, optional
        ``{parameter name: u}`` to start from (a previous calibration; absent names at the
        nominal, absent freed ones at the best of their gross sizes) instead of the gross starts
        and the coarse stage.
    progress : callable, optional
        ``progress(message)`` after each step.

    Raises
    ------
    InputError
        A posture the nominal robot cannot reach or hold, a nominal whose modes do not pair
        with the data's, fewer data than parameters (naming the undetermined ones).
    """
    say = progress or (lambda msg: None)
    if not (settings.frf and start is None):
        return _fit(robot, data, held, settings, start, say)
    # From the nominal, the modes alone first. The FRF residuals' landscape is rugged far from
    # the data: between heavily damped modes that overlap, a model whose modes sit in the wrong
    # order fits the magnitudes locally as well as one nearer the truth, and the fit stays there
    # (a foundation sliding 94 µm/kN, calibrated with the FRFs from the nominal: training χ²
    # 3533 on 2120 residuals, the links' centres of mass 0.2 m off; the modes first: 203,
    # where the truth gives 203)
    modes = _fit(robot, data, held, replace(settings, frf=False), None, say)
    say("the modes fitted: the FRFs joined")
    start = dict(zip([p.name for p in modes.params], np.asarray(modes.u, float)))
    out = _fit(robot, data, held, settings, start, say)
    return replace(out, iterations=modes.iterations + out.iterations, seconds=round(modes.seconds + out.seconds, 3))


def linearisation(robot, data, u, postures, settings: CalibrationSettings = CalibrationSettings()) -> tuple:
    """The residuals and their sensitivity to the calibrated parameters, per posture and band.

    What a search on top of a calibration needs to let the ordinary parameters follow it to first
    order (:mod:`rmbench.gap.frf.joint`). The parameters are those of ``settings.groups``, on the modal
    residuals: ``settings.extra``, ``free`` and ``frf`` do not apply here.

    Parameters
    ----------
    robot : Robot
        The nominal robot the calibration started from.
    data : ModalData
    u : ndarray, shape (n_params,)
        Calibrated parameters (:attr:`Calibration.u`) of ``settings.groups``.
    postures : sequence of int
        Posture indices into ``data``.

    Returns
    -------
    blocks : dict
        ``{(posture, band): (e, J)}``: the residual at ``u`` (layout of
        :func:`~rmbench.calibrate.residual.mode_residuals`) and its sensitivity per prior
        standard deviation, shape (size, n_params).
    z : ndarray, shape (n_params,)
        ``u`` in prior standard deviations (the prior pulls it toward 0).
    names : tuple of str
    """
    q = [robot.ik(post).q for post in data.postures]
    rob, params = parameter_set(robot, settings.groups)
    mm = ModalModel(rob, params, data.design, np.array(q), data.bands)
    problem = Problem(mm, data, postures, settings)
    try:
        r, j = problem.jacobian(np.asarray(u, float))
    finally:
        problem.close()
    sigma = problem.sigma
    j = j * sigma[None, :]
    blocks, at = {}, 0
    for key, size in zip(problem.keys, problem.sizes):
        blocks[key] = (r[at:at + size], j[at:at + size])
        at += size
    return blocks, np.asarray(u, float) / sigma, tuple(params.names)


def model_of(robot, data, settings: CalibrationSettings = CalibrationSettings()) -> ModalModel:
    """The model a calibration of the nominal ``robot`` to ``data`` with ``settings`` fits (its
    groups' and extra parameters, freed ones widened), at every posture of ``data``."""
    rob, params = _parameters(robot, settings)
    if settings.free:
        params = params.freed(settings.free)
    return ModalModel(rob, params, data.design, np.array([robot.ik(p).q for p in data.postures]), data.bands)


def _fit(robot, data, held, settings, start, say) -> Calibration:
    """One fit of :func:`calibrate`: from ``start`` (``{name: u}``) or, where that is None, from the
    gross starts and the coarse stage."""
    t0 = time.perf_counter()
    held, train, q = _postures(robot, data, held)
    rob, params = _parameters(robot, settings)
    if settings.free:
        params = params.freed(settings.free)
    mm = ModalModel(rob, params, data.design, np.array(q), data.bands)
    u0 = np.zeros(len(params))
    _check_pairing(mm, u0, data, train)
    problem = Problem(mm, data, train, settings)
    sigma = problem.sigma
    # the prior's weight per parameter: none on a freed one
    w = np.sqrt(settings.prior_weight) * np.array([0.0 if n in settings.free else 1.0 for n in params.names])
    lo, hi = params.lower() / sigma, params.upper() / sigma
    try:
        chi2_before, sol = _solve(problem, settings, w, lo, hi, start, say)
        z = sol.x
        r1, j1 = problem.scaled(z)
    finally:
        problem.close()
    chi2_after = float(r1 @ r1)
    say(f"calibrated: χ²/residual {chi2_after / problem.n:.3g} after {sol.nfev} evaluations")
    chi2_held, n_held = _held_chi2(mm, data, held, settings, z * sigma)
    estimates, cov_u, combos, notes, widening = account(params, z, j1, chi2_after, problem.n, Bounds(lo, hi),
                                                        prior=(w > 0).astype(float), held=(chi2_held, n_held))
    if sol.at_limit:
        notes.append(f"the fit stopped at its limit of {fine_limit(params, settings)} evaluations")
    u = z * sigma
    rows_train = {"before": mode_errors(mm, u0, data, train), "after": mode_errors(mm, u, data, train)}
    rows_held = ({"before": mode_errors(mm, u0, data, held), "after": mode_errors(mm, u, data, held)}
                 if held else {})
    xml = _calibrated_xml(rob, params, u, data, settings, train)
    return Calibration(params=tuple(estimates), u=u, cov_u=cov_u, combinations=tuple(combos),
                       chi2_before=chi2_before, chi2_after=chi2_after, n_residuals=problem.n,
                       train=tuple(train), held=tuple(held), modes_train=rows_train,
                       modes_held=rows_held, xml=xml, iterations=sol.nfev,
                       seconds=round(time.perf_counter() - t0, 3), notes=tuple(notes),
                       chi2_prior=sol.chi2_prior, at_limit=bool(sol.at_limit), chi2_held=chi2_held,
                       n_held=n_held, widening=widening)


def _parameters(robot, settings) -> tuple:
    """The robot to calibrate and the parameters of ``settings``: its groups', then its ``extra``
    ones (the spindle's speed ``spindle.speed`` and a sensor's placement,
    ``sensor.BAND:COORD.along``/``.angle``, after the MJCF's)."""
    sensors = [n for n in settings.extra if n.startswith("sensor.")]
    speed = "spindle.speed" in settings.extra
    rob, params = parameter_set(robot, settings.groups,
                                [n for n in settings.extra if n not in sensors and n != "spindle.speed"])
    added = (spindle_parameter(rob),) if speed else ()
    added += tuple(sensor_parameter(n) for n in dict.fromkeys(sensors))
    return rob, ParameterSet(tuple(params) + added) if added else params


def _solve(problem: Problem, settings, w, lo, hi, start, say) -> tuple:
    """``(χ² of the nominal, the solution)`` of a fit: the nominal checked for enough data, the
    start (given, or the gross starts and the coarse stage) and the fine stage, in prior σ within
    ``lo``, ``hi``, the prior's weight ``w`` per parameter."""
    params, sigma = problem.mm.params, problem.sigma

    def fun(z):
        # the data and the prior: the coarse stage and the gross starts score with both
        return np.concatenate([problem.residuals(z * sigma), w * z])

    r0, j0 = problem.scaled(np.zeros(len(params)))
    chi2_before = float(r0 @ r0)
    _check_enough(j0, params, problem.n, problem.data, problem.postures)
    say(f"nominal: χ²/residual {chi2_before / problem.n:.3g} over {problem.n} residuals, "
        f"{len(params)} parameters")
    if start is not None:
        z0 = given_start(start, params, sigma, lo, hi)
        absent = [n for n in settings.free if n not in start]
        if absent:
            # a freed parameter the start does not hold (a foundation's sliding, added to a
            # calibration without it) starts at the best of its gross sizes, as from the nominal
            z0 = free_start(params, absent, fun, z0, lo, hi, say)
    else:
        z0 = coarse_start(problem, settings, w, lo, hi, say)
    prior_sd = np.where(w > 0, 1.0 / np.where(w > 0, w, 1.0), np.inf)
    sol = solve(lambda z: problem.residuals(z * sigma), lambda z: problem.scaled(z)[1], z0, prior_sd=prior_sd,
                bounds=Bounds(lo, hi), options=SolverOptions(max_nfev=fine_limit(params, settings), robust=settings.robust))
    return chi2_before, sol


_FORM_EVALUATIONS = 4       # more evaluations of the fine stage per parameter of a model-form group


def fine_limit(params, settings) -> int:
    """Most evaluations of the fine stage: ``settings.max_iter``, and four more for each parameter
    of a model-form group (:data:`~rmbench.robot.parameters.OPTIONAL_GROUPS`). A form parameter
    trades off with the ordinary ones along shallow valleys (a bearing's tilt against the link
    masses' centres), where the trust region needs more steps: six tilt compliances stopped at 16
    evaluations with a held-out p95 of 2.3 %, and reach 0.9 % with more."""
    form = sum(p.group in OPTIONAL_GROUPS for p in params)
    return settings.max_iter + _FORM_EVALUATIONS * form


def _held_chi2(mm, data, held, settings, u) -> tuple[float, int]:
    """The data χ² at ``u`` on the held-out postures, with the training residual (modes, and the
    FRFs where fitted), and its number of residuals; ``(0, 0)`` with none held out."""
    if not held:
        return 0.0, 0
    problem = Problem(mm, data, held, settings)
    if not problem.n:
        return 0.0, 0
    r = problem.residuals(u)
    return float(r @ r), problem.n


def _postures(robot, data, held) -> tuple[list, list, np.ndarray]:
    """``(held, train, q)``: the held-out and training posture indices (sorted) and the robot's
    joint angles at every posture of the data, (n_postures, n_joints) rad."""
    held = sorted({int(h) for h in held})
    train = [p for p in range(len(data)) if p not in held]
    if not train:
        raise InputError("every posture is held out: nothing is left to calibrate on")
    if any(not 0 <= h < len(data) for h in held):
        raise InputError(f"held-out posture index out of range (the data have {len(data)} postures)")
    q = []
    for post in data.postures:
        try:
            q.append(robot.ik(post).q)
        except UnreachablePosture as err:
            raise InputError(f"the data's postures are not this robot's: {err}") from None
    return held, train, np.array(q)


def _check_pairing(mm, u0, data, train, *, least: float = 0.3) -> None:
    total = paired = 0
    for p in train:
        for b in data.bands:
            meas = data.modes[p].get(b)
            if meas is None or not len(meas):
                continue
            try:
                pr = pair(meas, mm.modes(u0, p, b))
            except RmbenchError as err:
                raise InputError(f"the nominal robot cannot hold posture {data.postures[p].label()}: {err}") from None
            total += len(meas)
            paired += len(pr.meas)
    if total == 0:
        raise InputError("the data hold no measured modes at the training postures")
    if paired < least * total:
        raise InputError(f"the nominal's modes do not pair with the data's: only {paired} of {total} measured "
                         "modes have a model mode within 15 % in frequency and alike in shape "
                         "(another robot, tool or test design?)")


def _check_enough(j, params, n_res, data, train) -> None:
    """Fewer informative data than parameters: name the ones the data cannot touch."""
    n_modes = sum(len(data.modes[p][b]) for p in train for b in data.bands if b in data.modes[p])
    informative = 2 * n_modes       # frequency and damping of each measured mode at the least
    if informative >= len(params):
        return
    s = np.linalg.norm(j, axis=0)
    order = np.argsort(s)
    weakest = [params.names[i] for i in order[:len(params) - informative]]
    raise InputError(f"{n_modes} measured modes ({informative} frequencies and dampings) cannot determine "
                     f"{len(params)} parameters: at least {', '.join(weakest)} would be undetermined; "
                     "measure more postures or calibrate fewer groups (--params)")


def _calibrated_xml(robot, params, u, data, settings, train) -> str:
    from rmbench.robot.spec import set_custom_text, spec_to_xml

    spec = robot.spec
    params.apply_spec(spec, u)
    note = (f"calibrated by rmbench to {data.source or 'measured modes'} ({len(train)} postures, bands "
            f"{', '.join(data.bands)}; groups {', '.join(settings.groups)})")
    set_custom_text(spec, "rmbench_calibration", note)
    xml = spec_to_xml(spec)
    return f"<!-- {note.replace('--', '-')} -->\n{xml}"
