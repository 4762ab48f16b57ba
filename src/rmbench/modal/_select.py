"""Which poles a band's data need: model-order selection for the MDOF fit.

The stabilisation diagram proposes poles; the data decide. Every candidate model is fitted by
variable projection (:mod:`._varpro`) and scored by the Bayesian information criterion of the
weighted residual, ``BIC = m ln(RSS / m) + k ln m`` (``m`` real residuals, ``k`` real parameters,
16 per pole plus the residual terms). A pole stays only when the data need it: a richer model must
beat the simpler one by ``evidence`` (10, "very strong" on Kass and Raftery's scale, since measured
noise is rarely as white as the criterion assumes), and a simpler one is kept unless it loses by
that much. The moves, repeated until none applies:

- **merge**: two poles closer than ``merge_separation`` half-power bandwidths whose φR or φL have
  a MAC above ``merge_mac`` are refitted as one mode (from their weighted mean, or from either).
  A pair the data need both of though it lies within ``unresolved_separation`` bandwidths is
  reported as unresolved (one mode split, or two no fit of this band can tell apart); further
  apart, the data have resolved it (seed 000's Table B1 has such a pair 0.14 bandwidths apart
  at 1 % noise);
- **add**: the poles on a (frequency, damping) grid whose linear residues best explain the
  remaining error (the best below, inside and above the band) and the weaker stabilisation
  clusters away from the current poles are screened with the other poles held; the best are
  refitted in turn and the first that stays physical and pays for itself is added;
- **remove**: a pole whose removal does not cost ``evidence`` is dropped (screened linearly,
  then refitted); a pole that leaves the allowed range or the physical damping range is dropped.

A band mode must be a mode as DATA.md counts them: inside the band and not straddling its edge,
``0 < ζ < zeta_max``, a half-power bandwidth of at least ``MIN_LINES`` frequency lines (narrower,
a pole fits a spike of noise as readily as a resonance; ``STRONG_LINES`` for a pole whose peak
reaches ``STRONG_PEAK`` of the band's, a resonance no spike mimics), and a peak of at least
``min_peak`` of the band's.

Modes outside the band leave tails that the lower and upper residual terms model only far from
the band: a 15 %-damped mode 25 % above the band's top bends the response across it. So the grid
also covers ``outside`` times the band's edges beyond them, and poles found there stay in the model
as **out-of-band poles** (at most ``OUTSIDE_PER_SIDE`` a side): fitted like modes (any damping,
real and unstable poles included: they shape the residual rather than describe a mode), counted
in the BIC, reported apart from the band's modes. Their positions are poorly determined, so
convergence is judged on the band modes, and an out-of-band pole that wanders out of range is
held where it was.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rmbench.modal import mdof
from rmbench.modal._candidates import (MissingScan, distinct, left_of, lsfd_scaled, scan_missing,
                                       split_left)
from rmbench.modal._varpro import Problem, Solution, pack_theta
from rmbench.modeshape import mac

# scan_missing lives in rmbench.modal._candidates; named here for the callers that import it from here
__all__ = ["Selection", "SelectionSettings", "select_modes", "scan_missing", "bic"]

SCAN_GRID = 120        # frequencies of the missing-mode scan across the band
SCAN_OUTSIDE = 12      # and beyond each edge
OUTSIDE_RANGE = 10.0   # out-of-band poles may settle within this factor of the band's edges
OUTSIDE_PER_SIDE = 2
MIN_LINES = 2.0        # a band mode's half-power bandwidth spans at least this many lines
STRONG_PEAK = 0.1      # unless its peak reaches this share of the band's: then STRONG_LINES
STRONG_LINES = 0.5
TRIAL_ITER = 15        # Levenberg-Marquardt iterations to judge a candidate model


@dataclass(frozen=True)
class SelectionSettings:
    """Settings of the model-order selection (see the module docstring)."""

    zeta_max: float = 0.3
    merge_separation: float = 0.5
    merge_mac: float = 0.9
    unresolved_separation: float = 0.1
    min_peak: float = 0.01     # a band mode's peak contribution, as a share of the band's peak
    evidence: float = 10.0     # BIC difference a pole must be worth ("very strong", Kass-Raftery)
    max_added: int = 12
    max_iter: int = 100
    outside: float = 2.0       # scan for out-of-band poles down to f_lo / outside, up to f_hi * outside;
                               # 0: no out-of-band poles


@dataclass(frozen=True)
class Selection:
    """The chosen model and how it was reached.

    Attributes
    ----------
    sol : Solution or None
        Final fit (scaled units), band modes and out-of-band poles together, by frequency.
    in_band : ndarray, shape (n,), bool
        Which poles of ``sol`` lie inside the band.
    bic : float
    merged : tuple of (float, float)
        Frequencies (Hz) of pole pairs merged into one mode.
    unresolved : tuple of (float, float)
        Close, alike pole pairs the data need both of (Hz).
    removed : tuple of float
        Frequencies (Hz) of poles dropped (not needed, or unphysical).
    added : tuple of float
        Frequencies (Hz) of the poles the add move started from.
    delta_bic : ndarray, shape (n,)
        BIC increase on removing each pole with the others held (an upper bound of the refitted
        increase): the evidence that the data need it.
    leftover : tuple
        ``(frequency Hz, ΔBIC, reason)`` of structure a pole would explain but that no physical
        pole could take, or ``()``.
    capped : bool
        The add move stopped at ``max_added`` with significant structure left.
    """

    sol: Solution | None
    in_band: np.ndarray
    bic: float
    merged: tuple = ()
    unresolved: tuple = ()
    removed: tuple = ()
    added: tuple = ()
    delta_bic: np.ndarray = field(default_factory=lambda: np.zeros(0))
    leftover: tuple = ()
    capped: bool = False


def bic(problem: Problem, cost: float, n_modes: int) -> float:
    """Bayesian information criterion of a model with ``n_modes`` poles at ``cost`` (½ RSS)."""
    m = problem.n_data
    return m * np.log(max(2 * cost, 1e-300) / m) + problem.n_params(n_modes) * np.log(m)


def select_modes(problem: Problem, freq: np.ndarray, ws: float, poles0: np.ndarray,
                 extra: np.ndarray, *, n_modes: int | None = None,
                 settings: SelectionSettings = SelectionSettings()) -> Selection:
    """Choose the poles of one band.

    Parameters
    ----------
    problem : Problem
        The band's scaled problem.
    freq : ndarray, shape (n_freq,), Hz
    ws : float
        Frequency scale of ``problem`` (rad/s).
    poles0 : ndarray, shape (n0,), complex, rad/s
        Initial poles (the stabilisation diagram's selection).
    extra : ndarray, complex, rad/s
        Weaker stabilisation clusters, tried as additions.
    n_modes : int, optional
        Fixed number of modes in the band (no out-of-band poles then): only the add and remove
        moves that reach it run.
    """
    if n_modes is not None:
        settings = SelectionSettings(**{**settings.__dict__, "outside": 0.0})
    st = _State(problem, freq, ws, settings)
    poles0 = np.asarray(poles0, complex) / ws
    extra = distinct([p / ws for p in np.asarray(extra, complex)], poles0)
    if n_modes is not None or not extra:
        cur = st.drop_unphysical(st.fit_from_poles(poles0))
    else:
        # a strong mode the diagram ranked weak distorts every other pole fitted without it, and
        # the add move may not recover from there: the start with the weak clusters competes
        # with the strong ones alone (a short trial against it)
        cur = st.drop_unphysical(st.fit_from_poles(np.concatenate([poles0, extra])))
        if len(poles0):
            limit = st.bic(cur) + settings.evidence
            alt = st.accept(st.trial(poles0, st.start_left(poles0), limit), limit)
            if alt is not None:
                cur = alt
    if n_modes is not None:
        return st.fix_count(cur, n_modes)
    for _ in range(4 * settings.max_added + 8):   # each pass changes the model or stops
        new = st.merge(cur)
        if new is None:
            new = st.add(cur, extra)
        if new is None:
            new = st.remove(cur)
        if new is None:
            break
        cur = new
    return st.result(cur)


class _State:
    """The moves of the selection on one band (scaled units inside)."""

    def __init__(self, problem, freq, ws, settings):
        self.p = problem
        self.ws = ws
        self.s = settings
        self.hz_lines = problem.omega * ws / (2 * np.pi)
        self.dw = float(problem.omega[1] - problem.omega[0])    # line spacing, scaled
        self.band_peak = float(np.abs(problem.H).max())
        # the missing-mode scan of this band (keeps what does not change between its calls)
        self.scan = MissingScan(self.hz_lines, problem.H, problem.W, problem.residuals)
        self.merged, self.unresolved, self.removed, self.added = [], [], [], []
        self.tried = set()      # keys of moves already tried on the same model size
        self.capped = False
        self.leftover = ()
        self.w_lo, self.w_hi = 2 * np.pi * freq[0] / ws, 2 * np.pi * freq[-1] / ws
        inner = np.linspace(freq[0], freq[-1], SCAN_GRID + 2)[1:-1]
        if settings.outside > 1:
            k = settings.outside
            below = np.geomspace(freq[0] / k, freq[0], SCAN_OUTSIDE + 1)[:-1]
            above = np.geomspace(freq[-1], freq[-1] * k, SCAN_OUTSIDE + 1)[1:]
            self.grid = np.concatenate([below, inner, above])
            self.w_min, self.w_max = self.w_lo / OUTSIDE_RANGE, self.w_hi * OUTSIDE_RANGE
        else:
            self.grid = inner
            self.w_min, self.w_max = self.w_lo, self.w_hi

    # -- fitting -------------------------------------------------------------------------------
    @staticmethod
    def refs_of(phi_l):
        """Normalisation element of each mode: its largest φL entry (the best-conditioned one;
        the band's fit reports in the user's normalisation afterwards)."""
        return np.argmax(np.abs(phi_l), axis=1) if len(phi_l) else np.zeros(0, int)

    def start_left(self, lam):
        """Starting φL of poles ``lam``: the rank-one split of their LSFD residues."""
        return split_left(lsfd_scaled(self.p, lam)[0])

    def fit_from_poles(self, lam):
        """LSFD residues split into φR φLᵀ as the start, then the VarPro fit."""
        if len(lam) == 0:
            return None
        return self.refit(lam, self.start_left(lam))

    def refit(self, lam, phi_l, max_iter=None, stop=None):
        """Fit from poles ``lam`` and left eigenvectors ``phi_l``; the band modes' convergence
        decides when it stops."""
        if len(lam) == 0:
            return None
        refs = self.refs_of(phi_l)
        phi_l = phi_l / phi_l[np.arange(len(refs)), refs][:, None]
        return _sorted(self.p.solve(lam, phi_l, refs, max_iter=max_iter or self.s.max_iter,
                                    watch=self.in_band(lam), stop=stop))

    def trial(self, lam, phi_l, base_bic):
        """A short fit of a candidate model: enough to see whether its BIC gets under
        ``base_bic``.

        It gives up when its cost is still above the one that beats the BIC of the current model
        and its progress per iteration is too slow to get there within five more; an accepted
        trial that stopped short is polished to convergence.
        """
        m = self.p.n_data
        target = 0.5 * m * np.exp((base_bic - self.p.n_params(len(lam)) * np.log(m)) / m)

        def run(hold=None):
            hist = []

            def stop(cost):
                hist.append(cost)
                return len(hist) >= 3 and cost - target > 5 * (hist[-2] - cost)

            if len(lam) == 0:
                return None
            refs = self.refs_of(phi_l)
            phi = phi_l / phi_l[np.arange(len(refs)), refs][:, None]
            return self.p.solve(lam, phi, refs, max_iter=min(self.s.max_iter, TRIAL_ITER),
                                watch=self.in_band(lam), stop=stop, hold=hold)

        new = run()
        if new is None:
            return None
        # an out-of-band pole that wandered off spoils a candidate only by its own wandering:
        # hold the poles that left and try again (the polish holds them likewise)
        ok = self.physical(new)
        astray = ~ok & ~self.in_band(new.lam) & ~self.in_band(lam)
        if astray.any() and ok[~astray].all():
            new = run(hold=astray)
        return _sorted(new)

    def polish(self, sol):
        """Carry an accepted trial on to convergence.

        An out-of-band pole only shapes the residual, and the data rarely pin it down: left
        free it may wander off along a flat valley (far beyond the band, where it acts as one
        more constant). If it does, the polish is redone with the out-of-band poles held where
        the trial put them.
        """
        if sol is None or sol.converged:
            return sol
        new = self.refit(sol.lam, sol.phi_l)
        if self.physical(new).all():
            return new
        hold = ~self.in_band(sol.lam)
        return _sorted(self.p.solve(sol.lam, sol.phi_l, sol.refs, max_iter=self.s.max_iter,
                                    watch=~hold, hold=hold))

    def accept(self, new, base_bic):
        """The polished candidate when it is physical and its BIC is under ``base_bic``."""
        if new is None or not self.physical(new).all() or self.bic(new) > base_bic:
            return None
        new = self.polish(new)
        return new if self.physical(new).all() and self.bic(new) <= base_bic else None

    def empty_cost(self):
        """Cost with no pole at all (residual terms only)."""
        return self.p.cost(np.zeros(0), np.zeros(0, int))

    def bic(self, sol):
        if sol is None:
            return bic(self.p, self.empty_cost(), 0)
        return bic(self.p, sol.cost, sol.n)

    def physical(self, sol):
        """Per pole: a band mode with 0 < ζ < zeta_max, or an out-of-band pole.

        Out-of-band poles are shapes of the residual, not modes: any damping (real and even
        unstable poles included: only their smooth tail across the band matters) is allowed,
        within ``OUTSIDE_RANGE`` times the band's edges.
        """
        lam = np.where(sol.lam.imag < 0, sol.lam.conj(), sol.lam)
        w, z = np.abs(lam), -lam.real / np.abs(lam)
        band = self.in_band(lam)
        # a weak mode narrower than MIN_LINES lines of half-power bandwidth is not resolved by
        # the data: such a pole fits a spike of noise as readily as a resonance. A strong one (a
        # tenth of the band's peak) is a resonance every entry shares, which no spike mimics: it
        # stays down to half a line (a lightly damped first mode on the low band's 0.125 Hz lines,
        # 1.9 lines wide and the band's largest peak, was dropped, and the modes beside it fitted
        # 1.5 % off to make up for it). And a mode is a mode when its peak reaches min_peak of the
        # band's (DATA.md, as for the exact modes)
        peak = (np.abs(sol.phi_r[:, :, None] * sol.phi_l[:, None, :]).max(axis=(1, 2))
                / np.maximum(np.abs(lam.real), 1e-300))
        lines = np.where(peak >= STRONG_PEAK * self.band_peak, STRONG_LINES, MIN_LINES)
        ok_band = (band & (z > 0) & (z < self.s.zeta_max)
                   & (2 * np.abs(lam.real) >= lines * self.dw)
                   & (peak >= self.s.min_peak * self.band_peak))
        ok_out = ~band & (w >= self.w_min) & (w <= self.w_max)
        return ok_band | ok_out

    def open_grid(self, lam):
        """The scan grid without the sides of the band that already hold ``OUTSIDE_PER_SIDE``
        out-of-band poles.

        Two poles per side shape the tails of a close pair of modes beyond the band (a tool's X
        and Y bending); more would be nearly collinear with them and stall the optimiser for no
        gain in the band.
        """
        side = self.side(lam)
        g = 2 * np.pi * self.grid / self.ws
        keep = (g >= self.w_lo) & (g <= self.w_hi)
        if np.sum(side < 0) < OUTSIDE_PER_SIDE:
            keep |= g < self.w_lo
        if np.sum(side > 0) < OUTSIDE_PER_SIDE:
            keep |= g > self.w_hi
        return self.grid[keep]

    def in_band(self, lam):
        """Which poles are modes of the band: inside it, and not straddling an edge.

        A pole within half its half-power bandwidth (``ζ ω_n / 2``) of an edge has much of its
        resonance outside the band; the band cannot characterise it as a mode, so it counts as
        an out-of-band pole (that is where the tail of a mode below or above the band settles).
        """
        return self.side(lam) == 0

    def side(self, lam):
        """−1 for poles below the band (or straddling its lower edge), +1 above, 0 for modes."""
        lam = np.asarray(lam, complex)
        w = np.abs(lam)
        half = 0.5 * np.abs(lam.real)   # ζ ω_n / 2
        out = np.zeros(len(lam), int)
        out[w < self.w_lo + half] = -1
        out[w > self.w_hi - half] = 1
        return out

    def interior(self, lam, margin=0.03):
        """Whether pole ``lam`` lies inside the band, ``margin`` of its span from each edge."""
        w, span = abs(lam), self.w_hi - self.w_lo
        return bool(self.w_lo + margin * span < w < self.w_hi - margin * span)

    def hz(self, lam):
        return np.abs(lam) * self.ws / (2 * np.pi)

    # -- moves ---------------------------------------------------------------------------------
    def drop_unphysical(self, sol):
        """Drop poles that left the allowed range or the physical damping range, one at a time."""
        while sol is not None:
            bad = np.flatnonzero(~self.physical(sol))
            if not len(bad):
                return sol
            r = bad[0]
            self.removed.append(float(self.hz(sol.lam[r])))
            keep = np.arange(sol.n) != r
            sol = self.refit(sol.lam[keep], sol.phi_l[keep])
        return sol

    def merge(self, sol):
        """Merge the closest alike pair when the data do not need both (BIC)."""
        if sol is None or sol.n < 2:
            return None
        pairs = []
        f = self.hz(sol.lam)
        z = -sol.lam.real / np.abs(sol.lam)
        modes = np.flatnonzero(self.in_band(sol.lam))  # out-of-band poles shape the residual
        for a in modes:
            for b in modes[modes > a]:
                sep = abs(f[a] - f[b]) / (z[a] * f[a] + z[b] * f[b])
                alike = np.fmax(mac(sol.phi_r[a], sol.phi_r[b]), mac(sol.phi_l[a], sol.phi_l[b]))
                if sep < self.s.merge_separation and alike > self.s.merge_mac:
                    key = ("merge", round(f[a], 6), round(f[b], 6))
                    if key not in self.tried:
                        pairs.append((sep, a, b, key))
                    elif sep < self.s.unresolved_separation:
                        self.unresolved.append((float(f[a]), float(f[b])))
        for sep, a, b, key in sorted(pairs):
            self.tried.add(key)
            base = self.bic(sol)
            keep = [r for r in range(sol.n) if r not in (a, b)]
            size = np.linalg.norm(sol.phi_r, axis=1) * np.linalg.norm(sol.phi_l, axis=1)
            starts = [(size[a] * sol.lam[a] + size[b] * sol.lam[b]) / (size[a] + size[b]),
                      sol.lam[a], sol.lam[b]]
            # one mode where two poles were: from their weighted mean, or from either of them,
            # the other poles held at their eigenvectors and the new one's from LSFD; merging
            # is rare and decisive, so each start gets the full trial without early abort
            best = None
            for lam in starts:
                phi = np.vstack([sol.phi_l[keep], left_of(self.p, sol.lam[keep], lam)])
                new = self.refit(np.append(sol.lam[keep], lam), phi,
                                 max_iter=min(self.s.max_iter, 2 * TRIAL_ITER))
                if new is not None and (best is None or self.bic(new) < self.bic(best)):
                    best = new
            new = self.accept(best, base + self.s.evidence)
            if new is not None:
                self.merged.append((float(f[a]), float(f[b])))
                return new
            if sep < self.s.unresolved_separation:
                self.unresolved.append((float(f[a]), float(f[b])))
        return None

    def add(self, sol, extra):
        """Add the candidate pole that lowers the BIC most, if any does and stays physical."""
        lam = sol.lam if sol is not None else np.zeros(0, complex)
        found = self.scan(lam * self.ws, self.open_grid(lam))
        p_val = found[0][1] if found else 1.0
        # nothing even a free residue per FRF would explain: no pole can pay for itself
        cands = [pole / self.ws for pole, p in found if p < 1e-3]
        cands += distinct(extra, lam)
        cands = [c for c in cands if ("add", round(float(abs(c)), 4), len(lam)) not in self.tried]
        if not cands:
            return None
        if len(self.added) >= self.s.max_added:
            self.capped = p_val < 1e-6
            return None
        base = self.bic(sol)
        # screen the candidates linearly (current poles held, new φL from LSFD), refit the best two
        screened = []
        for c in cands:
            self.tried.add(("add", round(float(abs(c)), 4), len(lam)))
            lam1 = np.append(lam, c)
            if sol is None:
                phi1 = split_left(lsfd_scaled(self.p, lam1)[0])
            else:
                phi1 = np.vstack([sol.phi_l, left_of(self.p, lam, c)])
            refs = self.refs_of(phi1)
            phi1 = phi1 / phi1[np.arange(len(refs)), refs][:, None]
            screened.append((self.p.cost(pack_theta(lam1, phi1, refs), refs), lam1, phi1))
        # refit the best screened candidates in turn until one is worth its 16 parameters
        target = base - self.s.evidence
        best_unphysical = None
        for _, lam1, phi1 in sorted(screened, key=lambda t: t[0])[:2]:
            new = self.trial(lam1, phi1, target)
            if new is None:
                continue
            if not self.physical(new).all():
                if self.bic(new) < target and self.interior(lam1[-1]) and (
                        best_unphysical is None or self.bic(new) < best_unphysical[0]):
                    best_unphysical = (self.bic(new), lam1[-1])
                continue
            new = self.accept(new, target)
            if new is not None:
                self.added.append(float(self.hz(lam1[-1])))
                self.leftover = ()
                return new
        # structure that only an unphysical pole would take, from a start inside the band
        if best_unphysical is not None:
            b, c = best_unphysical
            self.leftover = (float(self.hz(c)), float(b - base),
                             "a pole there lowers the BIC but takes an unphysical damping ratio, "
                             "a bandwidth under two lines or a peak under 1 % of the band's")
        return None

    def remove(self, sol):
        """Drop the pole whose removal lowers the BIC most (linear screen, then refit)."""
        if sol is None or sol.n < 2:
            return None
        base = self.bic(sol)
        screen = self.removal_bic(sol) - base
        for r in np.argsort(screen):
            if screen[r] > 2 * mdof.N_PER_MODE * np.log(self.p.n_data):
                break  # even the best case cannot pay for the refit to matter
            key = ("remove", round(float(self.hz(sol.lam[r])), 6), sol.n)
            if key in self.tried:
                continue
            self.tried.add(key)
            keep = np.arange(sol.n) != r
            limit = base + self.s.evidence
            new = self.accept(self.trial(sol.lam[keep], sol.phi_l[keep], limit), limit)
            if new is not None:
                self.removed.append(float(self.hz(sol.lam[r])))
                return new
        return None

    def removal_bic(self, sol):
        """BIC with each pole removed and the others held (linear parameters refitted)."""
        out = np.empty(sol.n)
        for r in range(sol.n):
            keep = np.arange(sol.n) != r
            refs = sol.refs[keep]
            cost = self.p.cost(pack_theta(sol.lam[keep], sol.phi_l[keep], refs), refs)
            out[r] = bic(self.p, cost, sol.n - 1)
        return out

    def fix_count(self, sol, n_modes):
        """Add or remove modes (best BIC first) until there are ``n_modes``."""
        for _ in range(2 * n_modes + 4):
            n = 0 if sol is None else sol.n
            if n == n_modes:
                break
            if n < n_modes:
                self.tried.clear()
                base = self.s
                self.s = SelectionSettings(**{**base.__dict__, "max_added": 10**6})
                new = self._add_any(sol)
                self.s = base
                if new is None:
                    break
            else:
                r = int(np.argmin(self.removal_bic(sol)))
                keep = np.arange(sol.n) != r
                new = self.refit(sol.lam[keep], sol.phi_l[keep])
            sol = new
        return self.result(sol)

    def _add_any(self, sol):
        """The best scanned pole, added whatever the BIC says (for a fixed mode count)."""
        lam = sol.lam if sol is not None else np.zeros(0, complex)
        found = self.scan(lam * self.ws, self.open_grid(lam))
        c = found[0][0] / self.ws
        if sol is None:
            return self.fit_from_poles(np.array([c]))
        return self.refit(np.append(lam, c), np.vstack([sol.phi_l, left_of(self.p, lam, c)]))

    def result(self, sol):
        if sol is None:
            return Selection(sol=None, in_band=np.zeros(0, bool), bic=self.bic(None),
                             merged=tuple(self.merged), removed=tuple(self.removed),
                             added=tuple(self.added), leftover=self.leftover, capped=self.capped)
        delta = self.removal_bic(sol) - self.bic(sol)
        f_now = self.hz(sol.lam)
        unresolved = sorted({p for p in self.unresolved if _both_present(p, f_now)})
        return Selection(sol=sol, in_band=self.in_band(sol.lam), bic=self.bic(sol),
                         merged=tuple(self.merged), unresolved=tuple(unresolved),
                         removed=tuple(self.removed), added=tuple(self.added), delta_bic=delta,
                         leftover=self.leftover, capped=self.capped)


def _sorted(sol: Solution) -> Solution:
    order = np.argsort(np.abs(sol.lam))
    return Solution(lam=sol.lam[order], phi_r=sol.phi_r[order], phi_l=sol.phi_l[order],
                    lower=sol.lower, upper=sol.upper, refs=sol.refs[order], cost=sol.cost,
                    converged=sol.converged, n_iter=sol.n_iter)


def _both_present(pair, f_now, rtol=1e-3):
    return all(np.any(np.abs(f_now - x) <= rtol * x) for x in pair)
