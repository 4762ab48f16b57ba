"""sdypy-EMA as a peer tool for the modal-fitting bench: one band of a 4x4 receptance matrix.

sdypy-EMA (the successor of pyEMA, ``pip install sdypy-EMA``; written against 0.31.0) fits one
reference at a time: LSCF poles from the four responses of one excitation column (a common
denominator), poles picked with ``Model.select_closest_poles`` at given natural frequencies, then
LSFD modal constants with lower and upper residuals. Here the picking is handed the exact natural
frequencies, the tool's best case (no stabilisation chart to read, no GUI).

The library prints progress bars (tqdm, on stderr, even with ``show_progress=False`` in its
stabilisation step) and imports matplotlib; both are kept out of the caller's way: it is imported
when :func:`sdypy_fit` is first called, its output is swallowed and its warnings are silenced for
the duration of the call only. Nothing is pickled or written.
"""

from __future__ import annotations

import contextlib
import io
import time
import warnings

import numpy as np

__all__ = ["sdypy_fit", "COORDS"]

COORDS = ("1X", "1Y", "1aX", "1aY")
"""Order of the rows (responses) and columns (excitations) of ``H``."""


def sdypy_fit(freq, H, f_exact, *, pol_order_high: int = 60, f_window: float | None = None,
              repick: bool = True) -> dict:
    """Fit one band of a 4x4 receptance matrix with sdypy-EMA, one excitation column at a time.

    For each reference (column) k, the four FRFs ``H[:, :, k]`` go to an ``EMA.Model`` (receptance,
    band ``freq[0]``-``freq[-1]``); LSCF computes poles at model orders 2 to
    ``2 * pol_order_high``; ``select_closest_poles(f_exact)`` picks one stable pole per mode; LSFD
    (``get_constants``, lower and upper residuals) gives the modal constants.

    Parameters
    ----------
    freq : array_like, shape (n_freq,), Hz
        Evenly spaced frequency lines of the band, each a whole multiple of the spacing (the
        lines of an FFT; LSCF places the band on the grid k·df from 0 Hz).
    H : array_like, shape (n_freq, 4, 4), complex, m/N
        Receptance, ``H[:, j, k]`` response j, excitation k, both in 1X 1Y 1aX 1aY order.
    f_exact : array_like, shape (n_modes,), Hz
        Natural frequencies at which poles are picked (the exact ones: sdypy-EMA's best case).
    pol_order_high : int, default 60
        sdypy-EMA's highest polynomial order (model orders up to twice this).
    f_window : float, optional, Hz
        ``select_closest_poles``' search window. Its default of 50 Hz breaks below 25 Hz: the
        window then reaches 0 Hz, where the library's unstable poles are stored as zeros, and the
        pick collapses to 0 Hz. Default here: the smallest of 50 Hz, the lowest ``f_exact`` and the
        smallest gap between two of them (so a window never spans 0 Hz or a neighbouring mode).
    repick : bool, default True
        ``select_closest_poles`` refines each frequency over windows of at least ±2 Hz, so two
        modes closer than that can be handed the same pole. With ``repick``, a mode whose pick is
        shared with another mode, or lies nearer another mode's ``f_exact`` than its own, gets
        instead the stable pole (over all model orders) nearest its ``f_exact`` that no other mode
        holds — still the tool's own stable poles, still its best case; ``repicked`` says which.

    Returns
    -------
    dict
        ``f_n`` : ndarray, shape (4, n_modes), Hz — natural frequency per reference and mode;
        ``zeta`` : ndarray, shape (4, n_modes) — damping ratio;
        ``shapes`` : ndarray, shape (4, n_modes, 4), complex, m/(N s) = s/kg — modal constants
        ``shapes[k, r, j]`` of response j, reference k, mode r, with
        H_jk(ω) ≈ Σ_r shapes[k, r, j] / (iω − λ_r) + c.c. + residuals; in METHODS.md §2 terms
        φR_jr · φL_kr;
        ``repicked`` : ndarray, shape (4, n_modes), bool — modes picked again (see ``repick``);
        ``seconds`` : float — wall time of the four fits, import excluded.

    Raises
    ------
    ValueError
        Shapes that do not match, a frequency axis not evenly spaced or off the k·df grid, no
        ``f_exact`` or one outside the band.
    """
    freq = np.asarray(freq, dtype=float)
    H = np.asarray(H, dtype=np.complex128)
    f_exact = np.atleast_1d(np.asarray(f_exact, dtype=float))
    _check(freq, H, f_exact)
    if f_window is None:
        f_window = min(50.0, f_exact.min(), *np.diff(np.sort(f_exact)))
    with _quiet():
        from sdypy import EMA

    n_ref, n_modes = H.shape[2], f_exact.size
    f_n = np.full((n_ref, n_modes), np.nan)
    zeta = np.full((n_ref, n_modes), np.nan)
    shapes = np.full((n_ref, n_modes, H.shape[1]), np.nan + 0j)
    repicked = np.zeros((n_ref, n_modes), dtype=bool)
    start = time.perf_counter()
    for k in range(n_ref):
        with _quiet():
            model = EMA.Model(frf=H[:, :, k].T, freq=freq, lower=freq[0], upper=freq[-1],
                              pol_order_high=pol_order_high, frf_form="receptance")
            model.get_poles(method="lscf", show_progress=False)
            model.select_closest_poles(list(f_exact), f_window=f_window)
            if repick:
                repicked[k] = _repick(model, f_exact, EMA.complex_freq_to_freq_and_damp)
            _, constants = model.get_constants(method="lsfd")
        f_n[k] = model.nat_freq
        zeta[k] = model.nat_xi
        shapes[k] = np.asarray(constants).T
    return {"f_n": f_n, "zeta": zeta, "shapes": shapes, "repicked": repicked,
            "seconds": time.perf_counter() - start}


def _check(freq: np.ndarray, H: np.ndarray, f_exact: np.ndarray) -> None:
    if freq.ndim != 1 or freq.size < 8:
        raise ValueError(f"freq must be 1-D with at least 8 lines, got shape {freq.shape}")
    if H.shape != (freq.size, 4, 4):
        raise ValueError(f"H must have shape (n_freq, 4, 4) = ({freq.size}, 4, 4), got {H.shape}")
    if not np.all(np.isfinite(H)):
        raise ValueError("H holds NaN or infinite values")
    step = np.diff(freq)
    df = step.mean()
    if not (df > 0 and np.max(np.abs(step - df)) <= 1e-6 * df):
        raise ValueError(f"freq must be increasing and evenly spaced, got steps {step.min():g}-"
                         f"{step.max():g} Hz")
    if abs(freq[0] / df - round(freq[0] / df)) > 1e-6:
        raise ValueError(f"freq[0] = {freq[0]:g} Hz is not a whole multiple of the spacing {df:g} Hz; "
                         "sdypy-EMA's LSCF assumes the FFT grid k·df from 0 Hz")
    if f_exact.ndim != 1 or f_exact.size == 0 or not np.all((f_exact > freq[0]) & (f_exact < freq[-1])):
        raise ValueError(f"f_exact must lie inside the band {freq[0]:g}-{freq[-1]:g} Hz, got {f_exact}")


def _repick(model, f_exact: np.ndarray, freq_and_damp) -> np.ndarray:
    """Give modes that share a pole (or hold another mode's) the nearest free stable pole.

    Works on the model's own results: ``f_stable`` (stable pole frequencies, pole x order, 0 where
    unstable), ``all_poles`` (poles per order) and the picks ``pole_ind``, ``nat_freq``,
    ``nat_xi``, which are updated in place. Returns which modes were picked again.
    """
    picks = [tuple(ind) for ind in model.pole_ind]
    nat_freq, nat_xi = np.array(model.nat_freq, dtype=float), np.array(model.nat_xi, dtype=float)
    nearest = np.argmin(np.abs(nat_freq[:, None] - f_exact[None, :]), axis=1)
    bad = np.array([picks.count(picks[r]) > 1 or nearest[r] != r for r in range(len(picks))])
    held = {picks[r] for r in np.flatnonzero(~bad)}
    order_f = [freq_and_damp(poles) for poles in model.all_poles]
    stable = np.argwhere(model.f_stable > 0)  # (row, order) of every stable pole
    for r in np.flatnonzero(bad):
        best = None
        for row, order in stable[np.argsort(np.abs(model.f_stable[tuple(stable.T)] - f_exact[r]))]:
            index = int(np.argmin(np.abs(order_f[order][0] - model.f_stable[row, order])))
            if (order, index) not in held:
                best = (int(order), index)
                break
        if best is None:
            continue
        held.add(best)
        picks[r] = best
        fr, xi = order_f[best[0]]
        nat_freq[r], nat_xi[r] = fr[best[1]], xi[best[1]]
    model.pole_ind = np.asarray(picks, dtype=int)
    model.nat_freq, model.nat_xi = nat_freq, nat_xi
    return bad


@contextlib.contextmanager
def _quiet():
    """Swallow the library's stdout/stderr (prints, tqdm bars) and warnings for one block."""
    with (contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()),
          warnings.catch_warnings()):
        warnings.simplefilter("ignore")
        yield
