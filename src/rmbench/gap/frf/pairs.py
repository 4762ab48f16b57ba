"""Pairs of effects, for a gap no single effect explains: the bases they are built on, the second
effect screened on top of each, the best refined, and the singles improved where a pair's effect
alone, refitted from its value in the pair, beats them (:func:`pairs`)."""

from __future__ import annotations

from rmbench.gap.frf.evidence import equivalent
from rmbench.gap.frf.search import GRID_PAIR

__all__ = ["pairs", "pair_bases", "better_singles"]


def pairs(refiner, obj_train, effects, singles, screens, pairs_of: int) -> tuple[list, list]:
    """Pairs on the best singles: the second effect screened on top of each base, the best
    ``pairs_of`` refined with it. Returns the singles (improved where a pair's effect alone,
    refitted from its value in the pair, beats them) and the pairs."""
    jobs = []
    # the second effect is screened on every other training posture (the pairs are refined on
    # all): half the cost, and the screening only has to rank
    coarse = obj_train.subset(obj_train.postures[::2])
    for first in pair_bases(singles, equivalent(screens)):
        base = first.change()
        e1 = coarse.vector(base)
        others = refiner.screen([e for e in effects if e.name != first.effects[0].name],
                                e1, base, grid=GRID_PAIR, postures=coarse.postures)
        jobs += [(first.effects + (sc.effect,), first.values + (sc.values,))
                 for sc in sorted(others, key=lambda s_: s_.chi2)[:pairs_of]]
    pairs = refiner.run(jobs)
    if pairs:
        # each effect of the best pair alone, refitted from its value in the pair: a single's
        # refinement can stall (at a bound, in a local minimum) where the pair's found the way,
        # and a pair whose second effect does nothing must lose to its first
        best_pair = min(pairs, key=lambda f: f.score)
        again = refiner.run([((e,), (v,)) for e, v in zip(best_pair.effects, best_pair.values)])
        singles = better_singles(singles, again)
    return singles, pairs


def pair_bases(singles, equivalent=(), *, within: float = 2.0) -> list:
    """The singles that pairs are built on: the best, and the next best that is not
    indistinguishable from it, if its training χ² is within a factor ``within`` of the best's (a
    look-alike repeats the best's pairs; a far worse second adds pairs the best's screening
    already offers: its partner would have to do the best's work).

    ``singles``: fitted single-effect models (:class:`~rmbench.gap.frf.search.Fitted`), ranked by
    their score; ``equivalent``: groups of effect names the data cannot tell apart
    (:func:`~rmbench.gap.frf.evidence.equivalent`). Returns one or two of ``singles``, best first."""
    ranked = sorted(singles, key=lambda f: f.score)
    if not ranked:
        return []
    first = ranked[0]
    twins = {n for g in equivalent if first.effects[0].name in g for n in g}
    for f in ranked[1:]:
        if f.effects[0].name not in twins:
            return [first, f] if f.chi2_train <= within * first.chi2_train else [first]
    return [first]


def better_singles(singles, refits) -> list:
    """``singles`` with each refit in place of the same effect's fit if it scores better (or added).

    Both are single-effect :class:`~rmbench.gap.frf.search.Fitted` models, matched by their
    effect's name; the order of ``singles`` is kept, new effects follow."""
    out = {f.effects[0].name: f for f in singles}
    for f in refits:
        name = f.effects[0].name
        if name not in out or f.score < out[name].score:
            out[name] = f
    return list(out.values())
