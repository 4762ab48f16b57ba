"""A saved posture predictor: one ``.npz`` of plain arrays with its metadata as JSON text in it.

:func:`save_predictor` and :func:`load_predictor` write and read a whole
:class:`~rmbench.predict.PosturePredictor` (its ``save`` and ``load``); :func:`state` and
:func:`from_state` one :class:`~rmbench.predict.gp.MTGP`; :func:`grouped_state` and
:func:`grouped_from_state` a :class:`~rmbench.predict.mtgp.GroupedMTGP` under a key prefix. Only
numbers and strings: the file loads with ``allow_pickle=False``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rmbench._version import __version__
from rmbench.errors import InputError
from rmbench.io.npz_file import read_npz, write_npz
from rmbench.predict.baselines import MULTI_TASK
from rmbench.predict.cluster import ModeCluster
from rmbench.predict.gp import MTGP
from rmbench.predict.mtgp import GroupedMTGP

__all__ = ["save_predictor", "load_predictor", "state", "from_state", "grouped_state", "grouped_from_state"]

FORMAT = 1


def save_predictor(pred, path) -> Path:
    """Write a fitted :class:`~rmbench.predict.PosturePredictor` to one ``.npz`` (arrays + JSON
    metadata; no pickle), atomically."""
    path = Path(path)
    if pred.model not in MULTI_TASK:
        raise InputError(f"only the Gaussian-process learners ({', '.join(MULTI_TASK)}) are saved "
                         f"as plain arrays; {pred.model!r} would need pickle")
    learner = pred.learner_
    models = learner.models_ if isinstance(learner, GroupedMTGP) else [learner]
    groups = learner.groups if isinstance(learner, GroupedMTGP) else [list(range(len(pred.live_)))]
    arrays = {"X_train": pred.X_train_, "live": pred.live_, "constant": pred.constant_}
    for i, m in enumerate(models):
        arrays.update({f"m{i}/{k}": v for k, v in state(m).items()})
    if pred.residual_learner_ is not None:
        arrays.update(grouped_state("residual", pred.residual_learner_))
    for i, learner in enumerate(pred.cluster_learners_):
        arrays.update(grouped_state(f"cluster{i}", learner))
    for i, learner in enumerate(pred.pole_learners_):
        arrays.update(grouped_state(f"poles{i}", learner))
    meta = {"format": FORMAT, "rmbench_version": __version__, "model": pred.model,
            "order": pred.order, "vectors": pred.vectors,
            "tasks": list(pred.tasks_), "modes": pred.modes_.tolist(), "params": list(pred.params_),
            "mode_band": pred.mode_band_.tolist(), "phiL_ref": pred.phiL_ref_.tolist(),
            "groups": [list(map(int, g)) for g in groups], "train_seconds": pred.train_seconds_,
            "source": pred.source_, "residual_bands": list(pred.residual_bands_),
            "residual_f_max": list(pred.residual_f_max_),
            "residual_seconds": pred.residual_seconds_, "clusters_option": pred.clusters,
            "entry_learners": "per column",
            "clusters": [{"modes": list(map(int, c.modes)), "center": [c.center.real, c.center.imag],
                          "radius": c.radius} for c in pred.clusters_],
            "cluster_seconds": pred.cluster_seconds_,
            "pole_clusters": [{"modes": list(map(int, c.modes)), "center": [c.center.real, c.center.imag],
                               "radius": c.radius} for c in pred.pole_clusters_]}
    return write_npz(path, meta, arrays)


def load_predictor(cls, path):
    """A ``cls`` (:class:`~rmbench.predict.PosturePredictor`) with the learnt attributes of a file
    written by :func:`save_predictor` (arrays only; nothing is unpickled); its hull is left to
    the caller."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"predictor not found: {path}")
    try:
        meta, a = read_npz(path, FORMAT)
        # files written before the gauge learnt the dataset's normalisation
        order = meta.get("order", "frequency")
        pred = cls(meta["model"], order, meta.get("vectors", "dataset"),
                   meta.get("clusters_option", "auto" if order == "frequency" else "none"))
        pred.tasks_ = tuple(meta["tasks"])
        pred.modes_ = np.asarray(meta["modes"], int)
        pred.params_ = tuple(meta["params"])
        pred.mode_band_ = np.asarray(meta["mode_band"], str)
        pred.phiL_ref_ = np.asarray(meta["phiL_ref"], str)
        pred.train_seconds_ = float(meta["train_seconds"])
        pred.source_ = str(meta.get("source", ""))
        pred.X_train_ = np.asarray(a["X_train"], float)
        pred.live_ = np.asarray(a["live"], int)
        pred.constant_ = np.asarray(a["constant"], float)
        groups = _children(a, "")
        models = [from_state(groups.get(f"m{i}", {})) for i in range(len(meta["groups"]))]
        # files written before the residual terms were learnt have none
        pred.residual_bands_ = tuple(meta.get("residual_bands", ()))
        pred.residual_f_max_ = tuple(float(v) for v in meta.get("residual_f_max", ()))
        pred.residual_seconds_ = float(meta.get("residual_seconds", 0.0))
        # files written before the terms were learnt per column hold one Kronecker MTGP
        per_column = meta.get("entry_learners") == "per column"
        pred.residual_learner_ = (grouped_from_state("residual", a, per_column)
                                  if pred.residual_bands_ else None)
        # files written before veering clusters were learnt have none
        pred.clusters_ = tuple(ModeCluster(tuple(c["modes"]), complex(*c["center"]), float(c["radius"]))
                               for c in meta.get("clusters", ()))
        pred.cluster_learners_ = [grouped_from_state(f"cluster{i}", a, True)
                                  for i in range(len(pred.clusters_))]
        pred.cluster_seconds_ = float(meta.get("cluster_seconds", 0.0))
        # files written before tight veerings took their frequencies from poles have none
        pred.pole_clusters_ = tuple(ModeCluster(tuple(c["modes"]), complex(*c["center"]), float(c["radius"]))
                                    for c in meta.get("pole_clusters", ()))
        pred.pole_learners_ = [grouped_from_state(f"poles{i}", a, True) for i in range(len(pred.pole_clusters_))]
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise InputError(f"{path}: not an rmbench predictor ({type(err).__name__}: {err})") from None
    if meta["model"] in ("mtgp", "mtgp-lowrank"):
        pred.learner_ = models[0]
    else:
        g = GroupedMTGP(meta["groups"])
        g.models_, g.n_tasks_ = models, len(pred.live_)
        pred.learner_ = g
    return pred


_STATE_SCALARS = ("n_tasks_", "dropped_")
_STATE_ARRAYS = ("varying_", "constant_", "x_mean_", "x_scale_", "y_mean_", "y_scale_", "loo_scale_", "y_fit_",
                 "loo_mu_", "loo_sd_")


def state(m: MTGP) -> dict:
    """Plain arrays of a fitted MTGP (see :func:`from_state`)."""
    out = {k: np.asarray(getattr(m, k)) for k in _STATE_SCALARS + _STATE_ARRAYS if hasattr(m, k)}
    if m.posterior_ is not None:
        out.update({f"post/{k}": v for k, v in m.posterior_.arrays().items()})
    return out


def from_state(a: dict) -> MTGP:
    """The MTGP of :func:`state`'s arrays (files of older versions lack some: defaults noted)."""
    from rmbench.predict.posterior import KronPosterior

    m = MTGP()
    for k in _STATE_SCALARS:
        setattr(m, k, int(a[k]))
    for k in _STATE_ARRAYS:
        if k in a:
            setattr(m, k, np.asarray(a[k]))
    # a group left unlearnt (its mode found at too few postures) has no varying tasks
    m.varying_ = np.asarray(getattr(m, "varying_", ()), int)
    if not hasattr(m, "loo_scale_"):       # a file saved before the scales were kept: uncalibrated
        m.loo_scale_ = np.ones(m.n_tasks_)
    post = {k[5:]: v for k, v in a.items() if k.startswith("post/")}
    m.posterior_ = KronPosterior.from_arrays(post) if post else None
    return m


def grouped_state(prefix: str, learner) -> dict:
    """Plain arrays of a GroupedMTGP of single columns (``{prefix}/m{j}/...``)."""
    if not isinstance(learner, GroupedMTGP):
        raise InputError("only Gaussian-process learners are saved as plain arrays")
    out = {f"{prefix}/groups": np.array([len(g) for g in learner.groups])}
    for j, m in enumerate(learner.models_):
        out.update({f"{prefix}/m{j}/{k}": v for k, v in state(m).items()})
    return out


def grouped_from_state(prefix: str, a: dict, per_column: bool):
    """The learner of :func:`grouped_state`'s arrays under ``prefix``; ``per_column`` False reads
    the one Kronecker MTGP that files of older versions held there."""
    if not per_column:                 # one Kronecker MTGP under ``{prefix}/``
        return from_state({k.split("/", 1)[1]: v for k, v in a.items() if k.startswith(f"{prefix}/")})
    sizes = np.asarray(a[f"{prefix}/groups"], int)
    start = np.concatenate([[0], np.cumsum(sizes)])
    g = GroupedMTGP([list(range(start[j], start[j + 1])) for j in range(len(sizes))])
    models = _children(a, f"{prefix}/")
    g.models_ = [from_state(models.get(f"m{j}", {})) for j in range(len(sizes))]
    g.n_tasks_ = int(start[-1])
    return g


def _children(a: dict, prefix: str) -> dict:
    """``{child: {rest: array}}`` of the keys ``f"{prefix}{child}/{rest}"`` of ``a``: each saved
    learner's arrays, found in one pass over the file's keys (a predictor holds thousands)."""
    out: dict = {}
    for k, v in a.items():
        if k.startswith(prefix):
            child, sep, rest = k[len(prefix):].partition("/")
            if sep:
                out.setdefault(child, {})[rest] = v
    return out
