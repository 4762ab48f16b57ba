"""The critical depth over the (cutter location, θ) grid: from a posture predictor, or exact.

At every pose of the grid the tool tip's modes come from a trained posture predictor
(:class:`rmbench.predict.PosturePredictor`: the tool it was trained with; a veering cluster's modes
from its learnt residues) or from the simulator's exact linearisation (the reference a plan is
judged against). Per band, the zero-order method gives the critical depth at the spindle speed,
vectorised over the poses (:func:`rmbench.stability.zoa_limit`); the pose's limit is the lowest
band's. The zero-order method is the one fast enough for thousands of poses; the bench checks it
against the full discretisation at sampled poses.

The exact reference sees, by default, the two measured bands' modes as their mode tables list them;
``exact_modes(..., bands="all")`` takes every mode of the linear model below a frequency instead,
coupled in one receptance (above about 800 rev/min at low speed the tool's modes near 2.7 kHz and
the band modes' sum between the bands set the limit there, which no band alone sees).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from rmbench.errors import InputError
from rmbench.stability.cutting import Cutting
from rmbench.stability.frame import to_cut_frame
from rmbench.stability.zoa import zoa_limit, zoa_limits
from rmbench.threads import run_concurrently

__all__ = ["DepthBand", "DepthGrid", "TipModes", "predicted_modes", "exact_modes", "predicted_depths", "exact_depths",
           "tip_modes", "depth_band", "ALL_MODES"]

_PARAMS = ("f_n", "zeta", "phiR_1X_re", "phiR_1X_im", "phiR_1Y_re", "phiR_1Y_im",
           "phiL_1X_re", "phiL_1X_im", "phiL_1Y_re", "phiL_1Y_im")


@dataclass(frozen=True)
class DepthGrid:
    """Critical depth per pose.

    Attributes
    ----------
    a_lim : ndarray, shape (n, m), m
        The lowest band's critical depth at the spindle speed (inf: stable at any depth; NaN where
        the pose is not evaluated).
    by_band : dict of str to ndarray (n, m)
    outside_hull : ndarray of bool, shape (n, m)
        Poses outside the predictor's training postures (False for exact depths).
    speed_rpm : float
    """

    a_lim: np.ndarray
    by_band: dict
    outside_hull: np.ndarray
    speed_rpm: float


def tip_modes(pred, band: str) -> tuple[np.ndarray, np.ndarray]:
    """Poles (n, n_modes) and tip residues (n, n_modes, 2, 2) of one band of a prediction (or a
    modal fit), NaN where a mode is not predicted; a veering cluster's modes from its residues."""
    modal = pred["modal"]
    sel = np.flatnonzero(pred["mode_band"].values == band)
    if not len(sel):
        raise InputError(f"the predictor has no mode in the {band!r} band")
    v = {p: modal.sel(param=p).values[:, sel] for p in _PARAMS}
    w, z = 2 * np.pi * v["f_n"], v["zeta"]
    with np.errstate(invalid="ignore"):
        poles = w * (-z + 1j * np.sqrt(1 - z ** 2))
    phi_r = np.stack([v["phiR_1X_re"] + 1j * v["phiR_1X_im"], v["phiR_1Y_re"] + 1j * v["phiR_1Y_im"]], axis=-1)
    phi_l = np.stack([v["phiL_1X_re"] + 1j * v["phiL_1X_im"], v["phiL_1Y_re"] + 1j * v["phiL_1Y_im"]], axis=-1)
    res = phi_r[..., :, None] * phi_l[..., None, :]
    if "cluster_pole" in pred:
        cp = pred["cluster_pole"].values[:, sel]
        cr = pred["cluster_residue"].transpose("posture", "mode", "out", "inp").values[:, sel, :2, :2]
        take = np.isfinite(cp)
        poles = np.where(take, cp, poles)
        res = np.where(take[..., None, None], cr, res)
    bad = ~np.isfinite(poles) | ~np.all(np.isfinite(res), axis=(-2, -1)) | ~(poles.imag > 0) | ~(poles.real < 0)
    poles = np.where(bad, np.nan, poles)
    return poles, np.where(bad[..., None, None], np.nan, res)


def _from_cluster(pred, band: str) -> np.ndarray:
    """Which modes of one band a prediction takes from a veering cluster (pole and residues),
    shape (n, n_modes) of bool."""
    sel = np.flatnonzero(pred["mode_band"].values == band)
    if "cluster_pole" not in pred:
        return np.zeros((pred.sizes["posture"], len(sel)), bool)
    return np.isfinite(pred["cluster_pole"].values[:, sel])


# lines of the log-spaced grid the chatter frequency is searched on: against 3000 lines the critical
# depths of 4440 pocket poses differ by at most 0.03 % at 18000 rev/min (0.08 % at 30000), a
# hundredth of a predictor's error, at a quarter of the time
N_FREQ = 800


def _freq(poles: np.ndarray, n_freq: int) -> np.ndarray:
    f = np.abs(poles[np.isfinite(poles)]) / (2 * np.pi)
    if not len(f):
        raise InputError("no mode to compute a critical depth from")
    return np.geomspace(0.2 * f.min(), 1.6 * f.max(), n_freq)


@dataclass(frozen=True)
class TipModes:
    """Tool-tip modes over the (location, θ) grid, per band: what the critical depth at any speed
    is computed from.

    Attributes
    ----------
    shape : (int, int)
        (n locations, m angles).
    poles : dict of str to ndarray (n_poses, n_modes), complex, rad/s
    residues : dict of str to ndarray (n_poses, n_modes, 2, 2), complex
    where : ndarray of int, shape (n_poses,)
        Flat grid index of each pose evaluated (the others are NaN in a :class:`DepthGrid`).
    outside_hull : ndarray of bool, shape (n, m)
    """

    shape: tuple
    poles: dict
    residues: dict
    where: np.ndarray
    outside_hull: np.ndarray

    def depths(self, cutting: Cutting, speed_rpm: float, *, n_freq: int = N_FREQ, heading=None,
               down=None) -> DepthGrid:
        """The critical depth of every pose at one spindle speed (rev/min).

        Parameters
        ----------
        cutting : Cutting
        speed_rpm : float
        n_freq : int
            Lines of the chatter-frequency grid.
        heading : ndarray, shape (n,), rad, optional
            Feed direction at each location in the base XY plane (:meth:`rmbench.io.ToolPath.heading`);
            the tip's modes are turned into the cut's frame there
            (:func:`rmbench.stability.frame.to_cut_frame`). None: the feed along base X everywhere,
            the numbers as before headings.
        down : ndarray of bool, shape (n,), optional
            Climb (True) or conventional (False) milling at each location; None: ``cutting.down``.
        """
        # one speed is the several speeds' first: zoa_limit is zoa_limits' one column, number for number
        return self.depths_at(cutting, [speed_rpm], n_freq=n_freq, heading=heading, down=down)[0]

    def depths_at(self, cutting: Cutting, speeds_rpm, *, n_freq: int = N_FREQ, heading=None, down=None) -> list:
        """:meth:`depths` at each of several speeds (rev/min), as a list of :class:`DepthGrid`: the
        receptance and its eigenvalues are computed once (:func:`rmbench.stability.zoa.zoa_limits`).
        ``heading`` (rad) and ``down``, shape (n,) each, as in :meth:`depths`."""
        speeds = np.atleast_1d(np.asarray(speeds_rpm, float))
        n, m = self.shape
        loc = self.where // m if m else self.where
        heading = None if heading is None else _per_location(heading, n, "heading", float)[loc]
        down = np.full(len(loc), bool(cutting.down)) if down is None else _per_location(down, n, "down", bool)[loc]

        def band(b):
            flat = np.full((n * m, len(speeds)), np.nan)
            if len(self.where):
                p = self.poles[b]
                res = self.residues[b] if heading is None else to_cut_frame(self.residues[b], heading)
                freq = _freq(p, n_freq)
                for d in (True, False):      # climb and conventional: two directional matrices
                    sel = down == d
                    cut = cutting if d == cutting.down else replace(cutting, down=d)
                    if sel.all():
                        flat[self.where] = zoa_limits(p, res, cut, speeds, freq)
                    elif sel.any():
                        flat[self.where[sel]] = zoa_limits(p[sel], res[sel], cut, speeds, freq)
            return flat

        per = dict(zip(self.poles, run_concurrently([lambda b=b: band(b) for b in self.poles])))
        out = []
        for k, sp in enumerate(speeds):
            by_band = {b: v[:, k].reshape(n, m) for b, v in per.items()}
            out.append(DepthGrid(np.minimum.reduce(list(by_band.values())), by_band, self.outside_hull, float(sp)))
        return out


def _per_location(values, n: int, name: str, kind) -> np.ndarray:
    """One value per location, shape (n,), as ``kind``; a one-line error otherwise."""
    a = np.asarray(values)
    if a.shape != (n,):
        raise InputError(f"{name} needs one value per location ({n}), got shape {a.shape}")
    a = a.astype(kind)
    if kind is float and not np.all(np.isfinite(a)):
        raise InputError(f"{name} must be finite at every location (rad)")
    return a


def predicted_modes(predictor, xy, theta, *, bands=("low", "high"), chunk: int = 4096) -> TipModes:
    """Tool-tip modes at every (location, θ) from a posture predictor.

    Parameters
    ----------
    predictor : rmbench.predict.PosturePredictor
    xy : ndarray, shape (n, 2), m
        Cutter locations (postures' x, y).
    theta : ndarray, shape (m,), rad
    bands : sequence of str
    """
    from rmbench.predict import ExtrapolationWarning

    xy, theta = np.asarray(xy, float), np.asarray(theta, float)
    n, m = len(xy), len(theta)
    poles = {b: [] for b in bands}
    res = {b: [] for b in bands}
    outside = []
    step = max(1, chunk // max(m, 1))       # locations per prediction: about ``chunk`` poses
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)   # reported through outside_hull
        for a in range(0, n, step):
            pred = predictor.predict_grid(xy[a:a + step], theta)
            outside.append(pred["outside_hull"].values)
            for b in bands:
                p, r = tip_modes(pred, b)
                poles[b].append(p)
                res[b].append(r)
    return TipModes((n, m), {b: np.concatenate(poles[b]) for b in bands},
                    {b: np.concatenate(res[b]) for b in bands}, np.arange(n * m),
                    np.concatenate(outside).reshape(n, m))


#: ``bands`` value of :func:`exact_modes` that takes every mode of the linearised robot below ``f_max``
ALL_MODES = "all"


def exact_modes(robot, xy, theta, *, reach=None, bands=("low", "high"), f_max: float = 8000.0,
                progress=None) -> TipModes:
    """The robot's exact tool-tip modes at every (location, θ) (the reference); ``reach``'s joint
    commands where given (poses it marks unusable are left out), else the robot's inverse kinematics.

    Parameters
    ----------
    bands : sequence of str or ``"all"``
        The measured bands' modes as each band sees them (its mode table: in the band and visible in
        its receptance), one :class:`TipModes` band each; or :data:`ALL_MODES`: every mode of the
        linear model below ``f_max`` as one band ``"all"`` (:func:`_all_tip_modes`): the modes
        between the bands and the tool's above them take part, and every mode adds to one
        receptance (a band's limit sees its own modes alone). On the IRB6660 with the end mill
        this lowers the limit where chatter comes at the tool's modes near 2.7 kHz or between the
        bands (40-600 Hz), above about 800 rev/min at low speed; the modes near 116-139 and 298 Hz
        barely reach the tip (residues under 1/300 of the tool modes') and change no depth.
    f_max : float
        Hz (inf: every mode); only with ``bands="all"``.
    """
    from rmbench.robot.posture import Posture

    every = isinstance(bands, str) and bands == ALL_MODES
    if every and not f_max > 0:
        raise InputError(f"f_max must be a frequency > 0 Hz, got {f_max!r}")
    keys = (ALL_MODES,) if every else tuple(bands)
    xy, theta = np.asarray(xy, float), np.asarray(theta, float)
    n, m = len(xy), len(theta)
    tables = {b: [] for b in keys}
    where = []
    for i in range(n):
        for j in range(m):
            if reach is not None and not reach.ok[i, j]:
                continue
            op = robot.at(reach.q[i, j] if reach is not None else Posture(*xy[i], theta[j]))
            if every:
                tables[ALL_MODES].append(_all_tip_modes(op, f_max))
            else:
                for b in keys:
                    t = op.modes(b)
                    tables[b].append((t.poles, t.phi_r[:, :2, None] * t.phi_l[:, None, :2]))
            where.append(i * m + j)
        if progress is not None:
            progress(i)
    poles, res = {}, {}
    for b in keys:
        k = max((len(p) for p, _ in tables[b]), default=0)
        poles[b] = np.full((len(where), k), np.nan, complex)
        res[b] = np.full((len(where), k, 2, 2), np.nan, complex)
        for row, (p, r) in enumerate(tables[b]):
            poles[b][row, :len(p)] = p
            res[b][row, :len(p)] = r
    return TipModes((n, m), poles, res, np.array(where, int), np.zeros((n, m), bool))


def _all_tip_modes(op, f_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Every complex mode of an operating point's linear model below ``f_max`` (Hz): poles (k,),
    rad/s, and residues at the tool tip in base X, Y (k, 2, 2), m/(N·s), the modes' own
    (:class:`rmbench.robot.linear.ComplexModes`: H = Σ R/(iω − λ) + conj).

    No band's visibility test (a mode table's receptance over 2,000 lines, most of a pose's time)
    and no scaling: the same modes as :meth:`rmbench.stability.Structure.from_operating_point`.
    Overdamped (real) poles are left out, as there; the IRB6660 has none.
    """
    cm = op.linear.modes()
    rows = op.coordinate_map(("1X", "1Y"))
    sel = (cm.f_n < f_max) & ~cm.real_pole
    r, lt = rows @ cm.phi_r[:, sel], rows @ cm.phi_l[:, sel]      # (2, k) each
    return cm.poles[sel], r.T[:, :, None] * lt.T[:, None, :]


def predicted_depths(predictor, xy, theta, cutting: Cutting, speed_rpm: float, *, bands=("low", "high"),
                     n_freq: int = N_FREQ, heading=None, down=None) -> DepthGrid:
    """Critical depth at every (location, θ) from a posture predictor (:func:`predicted_modes`);
    ``heading`` (rad) and ``down`` per location, shape (n,), as :meth:`TipModes.depths` takes them."""
    return predicted_modes(predictor, xy, theta, bands=bands).depths(cutting, speed_rpm, n_freq=n_freq,
                                                                     heading=heading, down=down)


def exact_depths(robot, xy, theta, cutting: Cutting, speed_rpm: float, *, reach=None, bands=("low", "high"),
                 f_max: float = 8000.0, n_freq: int = N_FREQ, progress=None, heading=None, down=None) -> DepthGrid:
    """Critical depth at every (location, θ) from the robot's exact modes (:func:`exact_modes`:
    ``bands="all"`` takes every mode below ``f_max``, Hz); ``heading`` (rad) and ``down`` per
    location, shape (n,), as :meth:`TipModes.depths` takes them."""
    return exact_modes(robot, xy, theta, reach=reach, bands=bands, f_max=f_max, progress=progress).depths(
        cutting, speed_rpm, n_freq=n_freq, heading=heading, down=down)


@dataclass(frozen=True)
class DepthBand:
    """The critical depth along a schedule with its band (:func:`depth_band`).

    Attributes
    ----------
    a_lim : ndarray, shape (n,), m
        From the predicted means.
    lower, upper : ndarray, shape (n,), m
        The band's limits.
    scale : float
        The conformal factor on the draws' robust spread of log depth (1 when not conformal): at
        the band's level, the training postures' leave-one-out depths lie within ``scale`` times
        their own spread of the depths their data give.
    n_calibration : int
        Training postures whose leave-one-out depth entered ``scale`` (0 when not conformal).
    """

    a_lim: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    scale: float
    n_calibration: int


def _sampled(pred, cutting: Cutting, speed_rpm: float, draws: int, sd_scale: float, bands, n_freq: int,
             rng, heading=None) -> tuple[np.ndarray, np.ndarray]:
    """The critical depth of a prediction's means, shape (n,), and of ``draws`` draws from its
    standard deviations, shape (draws, n); the residues turned to the feed ``heading`` (rad, shape
    (n,)) where given, as :meth:`TipModes.depths` turns them.

    Each draw perturbs every predicted parameter a tool tip's modes are built from (natural
    frequency, damping, the tip components of both eigenvectors) by an independent normal of the
    prediction's standard deviation times ``sd_scale``. A tight veering's modes, whose poles and
    residues the predictor takes from the cluster, move from there by as much as the perturbed
    parameters move each mode alone.
    """
    mean = pred["modal"].values
    sd = np.nan_to_num(pred["modal_std"].values) * sd_scale
    idx = [list(pred["param"].values).index(p) for p in _PARAMS]
    plain = pred.drop_vars(["cluster_pole", "cluster_residue"], errors="ignore")

    def modes(values):
        """Per band, the tip's poles and residues of these parameter values, every mode alone."""
        values = values.copy()
        values[..., idx[1]] = np.clip(values[..., idx[1]], 1e-4, 0.9)   # damping stays a ratio in (0, 1)
        one = plain.copy()
        one["modal"] = (("posture", "mode", "param"), values)
        return {b: tip_modes(one, b) for b in bands}

    # a draw moves each mode's pole and residues by what its perturbed parameters move them; a
    # veering cluster's modes start from the cluster's (the mean) and keep its residues, so its learnt
    # spread is sampled too. Which modes those are is the cluster's own mask, not where its pole
    # differs from the mode's: a tight veering inside a cluster keeps the mode's pole.
    centre, alone = {b: tip_modes(pred, b) for b in bands}, modes(mean)
    clustered = {b: _from_cluster(pred, b)[..., None, None] for b in bands}

    def limit(moved):
        per = []
        for b in bands:
            p = centre[b][0] + (moved[b][0] - alone[b][0])
            r = np.where(clustered[b], centre[b][1], moved[b][1])
            r = r if heading is None else to_cut_frame(r, heading)
            per.append(zoa_limit(p, r, cutting, speed_rpm, _freq(p, n_freq)))
        return np.minimum.reduce(per)

    samples = []
    for _ in range(draws):
        v = mean.copy()
        v[..., idx] += sd[..., idx] * rng.standard_normal(v[..., idx].shape)
        samples.append(limit(modes(v)))
    return limit(alone), np.array(samples)


def _depth_of(pred, cutting: Cutting, speed_rpm: float, bands, n_freq: int) -> np.ndarray:
    """The critical depth of a prediction's (or a training set's) tip modes, shape (n,), m."""
    per = []
    for b in bands:
        p, r = tip_modes(pred, b)
        per.append(zoa_limit(p, r, cutting, speed_rpm, _freq(p, n_freq)))
    return np.minimum.reduce(per)


def _log_spread(samples: np.ndarray) -> np.ndarray:
    """Robust standard deviation of the draws' log depth (interquartile range / 1.349), shape (n,):
    a few draws of a veering mode that comes near the chatter frequency drive the depth toward zero,
    which the plain standard deviation of so few draws would follow."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ls = np.log(samples)
    return (np.nanpercentile(ls, 75, axis=0) - np.nanpercentile(ls, 25, axis=0)) / 1.349


def _conformal_scale(predictor, cutting: Cutting, speed_rpm: float, *, draws: int, level: float,
                     sd_scale: float, calibrated: bool, bands, n_freq: int, rng) -> tuple[float, int]:
    """The conformal factor on the draws' log spread: at each training posture the depth predicted
    with it left out (every learner's leave-one-out means and deviations) against the depth its data
    give, in units of that prediction's own spread; the factor is their ``level`` quantile.

    Normalised split-conformal with leave-one-out residuals (the jackknife, Barber et al. 2021):
    the draws know where the predictor is unsure (far from its postures, at a veering) but not how
    the parameters' errors combine in a depth, which the one factor sets.
    """
    from rmbench.predict import ExtrapolationWarning

    X = predictor.X_train_
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)   # the training postures themselves
        data = predictor.predict(X, std=False, source="data")
        loo = predictor.predict(X, calibrated=calibrated, source="loo")
    truth = _depth_of(data, cutting, speed_rpm, bands, n_freq)
    a0, samples = _sampled(loo, cutting, speed_rpm, draws, sd_scale, bands, n_freq, rng)
    w = _log_spread(samples)
    ok = np.isfinite(truth) & np.isfinite(a0) & (truth > 0) & (a0 > 0) & np.isfinite(w)
    err = np.abs(np.log(truth[ok] / a0[ok]))
    with np.errstate(divide="ignore", invalid="ignore"):
        score = np.where(err == 0, 0.0, err / w[ok])
    n = len(score)
    k = int(np.ceil((n + 1) * level))
    if n == 0 or k > n:
        raise InputError(f"{n} training postures give a finite critical depth: too few for a conformal "
                         f"{100 * level:.0f} % band")
    return float(np.sort(score)[k - 1]), n


def depth_band(predictor, xy, theta, cutting: Cutting, speed_rpm: float, *, draws: int = 64, level: float = 0.95,
               sd_scale: float = 1.0, calibrated: bool = True, conformal: bool = False, bands=("low", "high"),
               n_freq: int = N_FREQ, seed: int = 0, heading=None) -> DepthBand:
    """The critical depth along a schedule with its band, from draws of the predictor's parameters.

    Each draw perturbs every predicted parameter a tool tip's modes are built from (natural
    frequency, damping, the tip components of both eigenvectors) by an independent normal of its
    standard deviation (:func:`_sampled`); the band is the draws' central ``level`` interval. With
    ``conformal`` it is instead ``a_lim · exp(± factor · spread)``: each location's robust spread of
    the draws' log depth times the factor that cross-validating the depth itself at the training
    postures gives (:func:`_conformal_scale`).

    Parameters
    ----------
    xy : ndarray, shape (n, 2), m
    theta : ndarray, shape (n,), rad
        One angle per location (a schedule).
    draws : int
    level : float
        Central probability of the band.
    sd_scale : float
        A further factor on the predictor's standard deviations.
    calibrated : bool
        Use the standard deviations calibrated on the training postures' leave-one-out errors
        (:meth:`rmbench.predict.PosturePredictor.std_scale`).
    conformal : bool
        Scale the band by the training postures' leave-one-out depths (a Gaussian-process
        predictor).
    heading : ndarray, shape (n,), rad, optional
        Feed direction at each location (:meth:`rmbench.io.ToolPath.heading`): the modes of the
        means and of every draw are turned into the cut's frame there, as :meth:`TipModes.depths`
        turns them. None: the feed along base X. The conformal factor is calibrated at the training
        postures, which lie on no path, with the feed along base X.
    """
    from rmbench.predict import ExtrapolationWarning

    xy, theta = np.asarray(xy, float), np.asarray(theta, float)
    X = np.column_stack([xy, theta])
    heading = None if heading is None else _per_location(heading, len(xy), "heading", float)
    rng = np.random.default_rng(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        pred = predictor.predict(X, calibrated=calibrated)
    a0, samples = _sampled(pred, cutting, speed_rpm, draws, sd_scale, bands, n_freq, rng, heading)
    if not conformal:
        tail = 100 * (1 - level) / 2
        return DepthBand(a0, np.percentile(samples, tail, axis=0), np.percentile(samples, 100 - tail, axis=0),
                         1.0, 0)
    q, n = _conformal_scale(predictor, cutting, speed_rpm, draws=draws, level=level, sd_scale=sd_scale,
                            calibrated=calibrated, bands=bands, n_freq=n_freq, rng=rng)
    half = q * _log_spread(samples)
    return DepthBand(a0, a0 * np.exp(-half), a0 * np.exp(half), q, n)
