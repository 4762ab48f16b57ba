"""Posture scheduling: H∞ controllers designed at a grid of postures and blended between them.

The robot's modes move with its posture (the MH180 stand-in's tangential mode from 4.7 to 7.4 Hz
over a 30° × 40° J2-J3 window), and a controller designed at one posture loses its reduction, then
its stability, away from it. A :class:`Schedule` holds one controller per posture of a rectangular
grid over some arm joints (the scheduling variables ``s``, rad); the rest of the posture is a
reference posture, with one joint (``hold``) turned by minus the scheduled joints' moves so that
the tool keeps its orientation (J5 against J2 and J3: parallel axes).

Blending: every controller of the grid sees the same measurements and their outputs are mixed,
``u = Σ_i w_i(s) K_i y``, with the multilinear interpolation weights of ``s`` on the grid. Unlike
interpolating state-space matrices, this needs no common coordinates between the controllers'
realisations, and at a grid posture it is exactly that posture's design. At a frozen posture the
blend is an LTI controller (:meth:`Schedule.at`); whether it stabilises the plants between the grid
postures is not implied by the designs: :func:`certify` checks it densely.
"""

from __future__ import annotations

import bisect
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rmbench.control.analysis import closed_loop_matrix
from rmbench.control.controller import CONTROLLER_VERSION, Controller, write_npz
from rmbench.control.design import controller_order, design
from rmbench.control.plant import Plant, first_strong_mode
from rmbench.control.sampled import sampled_radius
from rmbench.control.weights import Weights
from rmbench.errors import InputError
from rmbench.plotting import axes_or_new

__all__ = ["Schedule", "grid_posture", "design_schedule", "Certificate", "certify", "blend_plants", "loop_margin"]

SCHEDULE_VERSION = 1
F_BAND = (2.0, 40.0)  # Hz: where a design looks for the mode it targets (the suppressor's band)
ANGLE_TOL = 1e-4  # rad: a posture's rounding (a trajectory file's 0.001°, a reference posture's IK) is no departure


def grid_posture(q_ref, joints, s, hold: int | None = None) -> np.ndarray:
    """Arm joint commands (rad, shape (n_arm,)) at scheduling variables ``s`` (rad, shape (n_s,)).

    ``q_ref`` with ``q[joints] = s``; the joint ``hold`` turns by minus the scheduled joints' total
    move (it keeps the tool's orientation where their axes are parallel).
    """
    q = np.array(q_ref, float)
    s = np.asarray(s, float)
    joints = list(joints)
    moved = s - q[joints]
    q[joints] = s
    if hold is not None:
        q[hold] -= moved.sum()
    return q


@dataclass(frozen=True)
class Schedule:
    """Controllers at the postures of a rectangular grid, blended on the posture.

    Attributes
    ----------
    axes : tuple of str
        Suppressor axes every controller reads and drives.
    joints : tuple of int
        Arm joints (indices into the arm's joint vector) the schedule runs on.
    grid : tuple of ndarray
        Each scheduled joint's grid angles, rad, strictly increasing, at least two.
    controllers : tuple of Controller
        One per grid posture, in C order over ``grid`` (the last joint varies fastest).
    q_ref : ndarray, shape (n_arm,)
        Reference posture, rad: the unscheduled joints' angles.
    hold : int or None
        Joint turned against the scheduled ones (see :func:`grid_posture`).
    meta : dict
        Design record, JSON-serialisable.
    reach : tuple of float or None
        Per scheduled joint, rad: how far beyond its grid's edges the schedule still vouches for its
        loop (it holds the edge's controllers there: the extrapolation ring). ``None``: no limit.
    span : tuple of float or None
        Per arm joint, rad: how far an unscheduled joint may depart from the schedule's posture
        (:meth:`posture` of the scheduling variables) and still be covered; scheduled joints'
        entries are not used. ``None``: not checked.

    A posture outside the reach or the span is refused (:meth:`refusal`, :meth:`check`) with a
    message naming the joint: the schedule's designs say nothing there.
    """

    axes: tuple[str, ...]
    joints: tuple[int, ...]
    grid: tuple[np.ndarray, ...]
    controllers: tuple[Controller, ...]
    q_ref: np.ndarray
    hold: int | None = None
    meta: dict = field(default_factory=dict, compare=False)
    reach: tuple[float, ...] | None = None
    span: tuple[float, ...] | None = None

    def __post_init__(self):
        if len(self.grid) != len(self.joints) or not self.joints:
            raise InputError(f"a schedule needs one grid per scheduled joint; got {len(self.grid)} grids "
                             f"for {len(self.joints)} joints")
        for j, g in zip(self.joints, self.grid):
            if g.ndim != 1 or len(g) < 2 or np.any(np.diff(g) <= 0):
                raise InputError(f"joint {j + 1}'s grid must be at least two increasing angles, got {g}")
        if len(self.controllers) != self.n_postures:
            raise InputError(f"a {'x'.join(str(len(g)) for g in self.grid)} grid needs {self.n_postures} "
                             f"controllers, got {len(self.controllers)}")
        if any(c.axes != self.axes for c in self.controllers):
            raise InputError(f"every controller of the schedule must drive the axes {self.axes}")
        if self.reach is not None and (len(self.reach) != len(self.joints) or min(self.reach) < 0):
            raise InputError(f"reach needs one non-negative angle per scheduled joint ({len(self.joints)}), "
                             f"got {self.reach}")
        if self.span is not None and (len(self.span) != len(self.q_ref) or min(self.span) < 0):
            raise InputError(f"span needs one non-negative angle per arm joint ({len(self.q_ref)}), got {self.span}")

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(g) for g in self.grid)

    @property
    def n_postures(self) -> int:
        return int(np.prod(self.shape))

    def mode_range(self) -> tuple[tuple[float, float], ...]:
        """Per axis, the lowest and highest mode (Hz) the grid's controllers were designed for
        (their ``meta["mode_hz"]``)."""
        modes = [c.meta["mode_hz"] for c in self.controllers]
        return tuple((float(lo), float(hi)) for lo, hi in zip(np.min(modes, axis=0), np.max(modes, axis=0)))

    def grid_variables(self) -> np.ndarray:
        """Scheduling variables of the grid postures, rad, shape (n_postures, n_s), C order."""
        mesh = np.meshgrid(*self.grid, indexing="ij")
        return np.stack([m.ravel() for m in mesh], axis=1)

    def posture(self, s) -> np.ndarray:
        """Arm joint commands at scheduling variables ``s``, rad (:func:`grid_posture`)."""
        return grid_posture(self.q_ref, self.joints, s, self.hold)

    def variables(self, q) -> np.ndarray:
        """Scheduling variables of an arm posture ``q`` (rad): its scheduled joints' angles."""
        return np.asarray(q, float)[list(self.joints)]

    def refusal(self, q) -> str | None:
        """Why the schedule does not cover arm posture(s) ``q`` (rad, shape (n_arm,) or (n, n_arm)):
        a one-line message naming the first joint out of :attr:`reach` or :attr:`span`, or None
        where every posture is covered."""
        Q = np.atleast_2d(np.asarray(q, float))
        S = Q[:, list(self.joints)]
        if self.reach is not None:
            for k, (j, g, r) in enumerate(zip(self.joints, self.grid, self.reach)):
                out = np.maximum(g[0] - S[:, k], S[:, k] - g[-1])
                i = int(np.argmax(out))
                if out[i] > r + ANGLE_TOL:
                    return (f"J{j + 1} at {np.degrees(S[i, k]):.1f} deg lies {np.degrees(out[i]):.1f} deg beyond the "
                            f"schedule's grid ({np.degrees(g[0]):.1f} to {np.degrees(g[-1]):.1f} deg), past its reach "
                            f"of {np.degrees(r):.1f} deg: no controller was designed or certified there "
                            "(extend the grid)")
        if self.span is not None:
            moved = S - self.q_ref[list(self.joints)]
            nominal = np.repeat(self.q_ref[None], len(Q), axis=0)
            if self.hold is not None:
                nominal[:, self.hold] -= moved.sum(axis=1)
            dev = Q - nominal
            for j, lim in enumerate(self.span):
                if j in self.joints:
                    continue
                i = int(np.argmax(np.abs(dev[:, j])))
                if abs(dev[i, j]) > lim + ANGLE_TOL:
                    return (f"J{j + 1} departs {np.degrees(dev[i, j]):+.1f} deg from the schedule's posture, more "
                            f"than the {np.degrees(lim):.1f} deg its designs cover (schedule that joint, or "
                            "measure and design there)")
        return None

    def check(self, q) -> None:
        """Raise :class:`~rmbench.errors.InputError` with :meth:`refusal`'s message where the
        schedule does not cover ``q`` (rad, shape (n_arm,) or (n, n_arm))."""
        why = self.refusal(q)
        if why is not None:
            raise InputError(f"the schedule refuses this posture: {why}")

    def inside(self, s) -> bool:
        """Whether ``s`` lies in the grid's box (outside it the schedule holds its edge)."""
        s = np.asarray(s, float)
        return bool(all(g[0] - 1e-12 <= v <= g[-1] + 1e-12 for g, v in zip(self.grid, s)))

    def weights(self, s) -> np.ndarray:
        """Multilinear interpolation weights of ``s`` over the grid postures, shape (n_postures,).

        Non-negative, summing to one, at most ``2**n_s`` of them non-zero; ``s`` outside the grid's
        box is clipped to it.
        """
        s = np.asarray(s, float)
        if s.shape != (len(self.joints),):
            raise InputError(f"scheduling variables must have shape ({len(self.joints)},), got {s.shape}")
        # plain floats and bisect: a running loop calls this hundreds of times a second
        w = np.ones(1)
        for g, v in zip(self.grid, s.tolist()):
            g = g.tolist()
            v = min(max(v, g[0]), g[-1])
            i = min(max(bisect.bisect_right(g, v) - 1, 0), len(g) - 2)
            t = (v - g[i]) / (g[i + 1] - g[i])
            axis_w = np.zeros(len(g))
            axis_w[i], axis_w[i + 1] = 1.0 - t, t
            w = np.outer(w, axis_w).ravel()
        return w

    def at(self, s, *, tol: float = 1e-9) -> Controller:
        """The blended controller at a frozen posture: its neighbours in parallel, outputs weighted.

        Returns
        -------
        Controller
            Order the sum of the neighbours' orders (one neighbour's own design at a grid posture).
        """
        w = self.weights(s)
        idx = np.flatnonzero(w > tol)
        parts = [self.controllers[i] for i in idx]
        A = _block_diag([p.A for p in parts])
        B = np.vstack([p.B for p in parts])
        C = np.hstack([wi * p.C for wi, p in zip(w[idx], parts)])
        D = sum(wi * p.D for wi, p in zip(w[idx], parts))
        return Controller(self.axes, A, B, C, D, {"blend": {"postures": idx.tolist(), "weights": w[idx].tolist()}})

    # file format -------------------------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Write an ``.npz`` (arrays ``A_i, B_i, C_i, D_i`` per grid posture, ``grid_k``, ``q_ref``,
        and ``meta`` as JSON) atomically; read with :meth:`load`, never unpickled."""
        arrays = {"q_ref": self.q_ref}
        for k, g in enumerate(self.grid):
            arrays[f"grid_{k}"] = g
        for i, c in enumerate(self.controllers):
            arrays.update({f"{x}_{i}": getattr(c, x) for x in "ABCD"})
        meta = dict(self.meta, axes=list(self.axes), joints=list(self.joints), hold=self.hold,
                    reach=None if self.reach is None else [float(v) for v in self.reach],
                    span=None if self.span is None else [float(v) for v in self.span],
                    controllers=[c.meta for c in self.controllers], rmbench_schedule_version=SCHEDULE_VERSION,
                    rmbench_controller_version=CONTROLLER_VERSION)
        return write_npz(path, arrays, meta)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Schedule":
        """Read a schedule file (one-line errors for a missing, foreign or damaged file)."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                if meta.get("rmbench_schedule_version") != SCHEDULE_VERSION:
                    raise InputError(f"{path} is not an rmbench schedule file of version {SCHEDULE_VERSION}")
                joints = tuple(int(j) for j in meta["joints"])
                grid = tuple(np.asarray(z[f"grid_{k}"], float) for k in range(len(joints)))
                n = int(np.prod([len(g) for g in grid]))
                axes = tuple(meta["axes"])
                ctrls = tuple(Controller(axes, *(np.asarray(z[f"{x}_{i}"], float) for x in "ABCD"),
                                         meta=meta["controllers"][i]) for i in range(n))
                q_ref = np.asarray(z["q_ref"], float)
        except FileNotFoundError:
            raise InputError(f"no schedule file {path}") from None
        except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
            raise InputError(f"{path} is not an rmbench schedule file ({exc})") from None
        hold, reach, span = meta.get("hold"), meta.get("reach"), meta.get("span")
        rest = {k: v for k, v in meta.items() if k not in ("axes", "joints", "hold", "controllers", "reach", "span")}
        return cls(axes, joints, grid, ctrls, q_ref, None if hold is None else int(hold), rest,
                   None if reach is None else tuple(float(v) for v in reach),
                   None if span is None else tuple(float(v) for v in span))


def _block_diag(blocks) -> np.ndarray:
    n = sum(b.shape[0] for b in blocks)
    out = np.zeros((n, n))
    r = 0
    for b in blocks:
        k = b.shape[0]
        out[r:r + k, r:r + k] = b
        r += k
    return out


def design_schedule(plants, grid, joints, q_ref, *, hold: int | None = None, weights: Weights | None = None,
                    order: int | None = None, mimo: bool = True, progress=None, reach=None,
                    span=None) -> Schedule:
    """Design one controller per grid posture.

    Parameters
    ----------
    plants : sequence of Plant
        The plant at each grid posture, C order over ``grid`` (measured, or from a calibrated model:
        whatever the user holds, never the robot's truth).
    grid : sequence of array_like
        Each scheduled joint's angles, rad.
    joints, q_ref, hold
        See :class:`Schedule`.
    weights : Weights, optional
    order : int, optional
        Controller states (default 12, plus 8 per further axis of a MIMO design).
    mimo : bool
        One design over all the plant's axes; else one SISO loop per axis, side by side.
    progress : callable, optional
        Called with each posture's index once designed.
    reach, span : sequence of float, optional
        Where the schedule vouches for its loop beyond its grid, rad (see :class:`Schedule`).

    Each design targets, on each axis, the plant's lowest strong resonance
    (:func:`~rmbench.control.plant.first_strong_mode`), so that one mode is followed over the grid.
    """
    grid = tuple(np.asarray(g, float) for g in grid)
    plants = list(plants)
    axes = plants[0].axes if plants else ()
    ctrls = []
    for i, p in enumerate(plants):
        if p.axes != axes:
            raise InputError(f"plant {i} has axes {p.axes}, the first {axes}")
        target = [first_strong_mode(p, k, f_min=F_BAND[0], f_max=F_BAND[1]) for k in range(p.n_axes)]
        for k, f in enumerate(target):
            if not F_BAND[0] * 1.02 < f < F_BAND[1] * 0.98:
                raise InputError(f"grid posture {i}: the {axes[k]} response shows no resonance within "
                                 f"{F_BAND[0]:g}-{F_BAND[1]:g} Hz (its largest value sits at the band's edge, "
                                 f"{f:.3g} Hz): no mode for the controller to damp")
        if mimo or p.n_axes == 1:
            d = design(p, weights, order=order or controller_order(p.n_axes), mode_hz=target)
            c, gammas = d.controller, [d.gamma]
        else:
            ds = [design(p.select((a,)), weights, order=order or controller_order(1), mode_hz=[target[k]])
                  for k, a in enumerate(axes)]
            c, gammas = Controller.block_diagonal([d.controller for d in ds]), [d.gamma for d in ds]
        meta = {"gamma": gammas, "mode_hz": target, "plant_source": p.source,
                "structure": "MIMO" if mimo and p.n_axes > 1 else "SISO"}
        ctrls.append(Controller(c.axes, c.A, c.B, c.C, c.D, meta))
        if progress is not None:
            progress(i)
    meta = {"structure": "MIMO" if mimo and len(axes) > 1 else "SISO",
            "weights": (weights or Weights()).as_dict()}
    return Schedule(tuple(axes), tuple(int(j) for j in joints), grid, tuple(ctrls), np.asarray(q_ref, float),
                    hold, meta, None if reach is None else tuple(float(v) for v in reach),
                    None if span is None else tuple(float(v) for v in span))


def blend_plants(plants, weights, *, tol: float = 1e-9) -> Plant:
    """The plants with non-zero weight side by side, outputs summed with the weights: a plant whose
    response is the weighted mean of theirs (shape (n_x, ...) the sum of theirs)."""
    idx = np.flatnonzero(np.asarray(weights) > tol)
    parts = [plants[i] for i in idx]
    w = np.asarray(weights)[idx]
    A = _block_diag([p.A for p in parts])
    B = np.vstack([p.B for p in parts])
    C = np.hstack([wi * p.C for wi, p in zip(w, parts)])
    D = sum(wi * p.D for wi, p in zip(w, parts))
    modes = tuple(float(v) for v in np.average([p.mode_hz for p in parts], axis=0, weights=w))
    return Plant(parts[0].axes, A, B, C, D, "interpolated", modes, {"blend": idx.tolist()})


def loop_margin(plant: Plant, controller: Controller, freq) -> float:
    """Smallest singular value of the return difference ``I − K G_u`` over ``freq`` (Hz).

    The loop broken at the voice-coil forces; a margin ``m`` guarantees stability for any
    simultaneous gain in ``[1/(1+m), 1/(1−m)]`` or phase up to ``2 asin(m/2)`` in every channel.
    """
    n = plant.n_axes
    G = plant.frf(freq)[:, :, n:]
    K = controller.frf(freq)
    rd = np.eye(n) - K @ G
    return float(np.min(np.linalg.svd(rd, compute_uv=False)))


@dataclass(frozen=True)
class Certificate:
    """Closed-loop stability of a schedule over its grid and between its postures.

    Attributes
    ----------
    variables : ndarray, shape (n, n_s)
        Scheduling variables checked, rad.
    on_grid : ndarray, shape (n,), bool
    max_real : ndarray, shape (n,)
        Largest real part of the closed-loop poles at each point, 1/s.
    margin : ndarray, shape (n,)
        :func:`loop_margin` at each point.
    plants : str
        What the plants between the grid postures were: ``"model"`` (a plant at every point) or
        ``"interpolated"`` (:func:`blend_plants` of the grid plants).
    loop : str
        The loop whose stability is certified: ``"continuous"`` (plant and controller in continuous
        feedback, ``max_real < 0``) or ``"sampled"`` (the hardware's sampled-data loop,
        :mod:`rmbench.control.sampled`: ``spectral_radius < 1``; ``max_real`` kept for comparison).
    spectral_radius : ndarray, shape (n,), or None
        Of the sampled-data loop at each point (``loop == "sampled"`` only).
    """

    variables: np.ndarray
    on_grid: np.ndarray
    max_real: np.ndarray
    margin: np.ndarray
    plants: str
    loop: str = "continuous"
    spectral_radius: np.ndarray | None = None

    @property
    def unstable_points(self) -> np.ndarray:
        """Whether each point's certified loop is unstable, shape (n,), bool."""
        if self.loop == "sampled":
            return self.spectral_radius >= 1.0
        return self.max_real >= 0

    @property
    def stable(self) -> bool:
        return not bool(np.any(self.unstable_points))

    @property
    def worst(self) -> int:
        """Index of the point with the smallest margin."""
        return int(np.argmin(self.margin))

    def headline(self) -> dict:
        """``{"stable", "min_margin", "points"}``: what a schedule file's ``meta`` keeps of it."""
        head = {"stable": self.stable, "min_margin": float(self.margin.min()), "points": len(self.margin)}
        if self.loop == "sampled":  # a continuous certificate's headline stays as it was
            head.update(loop="sampled", max_spectral_radius=float(self.spectral_radius.max()))
        return head

    def to_dict(self) -> dict:
        """:meth:`headline`, the worst point and every point checked (scheduling variables in rad,
        largest closed-loop real part in 1/s, loop margin) as strict JSON values."""
        from rmbench.io.strict_json import jsonable

        w = self.worst
        points = [{"variables": v, "on_grid": g, "max_real": r, "margin": m}
                  for v, g, r, m in zip(self.variables, self.on_grid, self.max_real, self.margin)]
        worst = {"variables": self.variables[w], "on_grid": self.on_grid[w], "max_real": self.max_real[w],
                 "margin": self.margin[w]}
        if self.loop == "sampled":
            for pt, rho in zip(points, self.spectral_radius):
                pt["spectral_radius"] = rho
            worst["spectral_radius"] = self.spectral_radius[w]
        return jsonable({**self.headline(), "plants": self.plants, "worst": worst, "points_checked": points})

    def summary(self) -> str:
        """Stable or not over how many points (on and between the grid postures), and where the
        loop margin is smallest (scheduling variables in degrees)."""
        w, n_grid = self.worst, int(self.on_grid.sum())
        where = ", ".join(f"{np.degrees(v):.1f}" for v in self.variables[w])
        sampled = self.loop == "sampled"
        lines = [
            f"certificate over {len(self.margin)} points ({n_grid} grid postures, {len(self.margin) - n_grid} "
            f"between; plants {self.plants}): {'stable' if self.stable else 'UNSTABLE'}"
            + (" on the sampled-data loop" if sampled else ""),
            f"smallest loop margin {self.margin[w]:.3f} at ({where}) deg "
            f"({'a grid posture' if self.on_grid[w] else 'between grid postures'})",
            f"largest closed-loop pole real part {self.max_real.max():.3g} 1/s"
            + (" (continuous loop)" if sampled else "")]
        if sampled:
            lines.append(f"sampled-data loop: largest spectral radius {self.spectral_radius.max():.6f}, "
                         f"{int(self.unstable_points.sum())} point(s) unstable")
        return "\n".join(lines)

    def plot(self, ax=None):
        """Loop margin at every point checked: over the scheduled joint's angle (deg) for a
        one-joint schedule, else over the first two joints' angles (colour); grid postures as
        circles, unstable points as red crosses.

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        ax = axes_or_new(ax, (6, 4))
        deg = np.degrees(self.variables)
        bad = self.unstable_points
        if deg.shape[1] == 1:
            order = np.argsort(deg[:, 0])
            ax.plot(deg[order, 0], self.margin[order], "-", color="C0", label="loop margin")
            ax.plot(deg[self.on_grid, 0], self.margin[self.on_grid], "o", color="C0", label="grid postures")
            ax.plot(deg[bad, 0], self.margin[bad], "x", color="red", label="unstable")
            ax.set_xlabel("scheduled joint, deg")
            ax.set_ylabel("loop margin")
        else:
            sc = ax.scatter(deg[:, 0], deg[:, 1], c=self.margin, s=np.where(self.on_grid, 60, 25), cmap="viridis")
            ax.figure.colorbar(sc, ax=ax, label="loop margin")
            ax.plot(deg[bad, 0], deg[bad, 1], "x", color="red", label="unstable")
            ax.set_xlabel("first scheduled joint, deg")
            ax.set_ylabel("second scheduled joint, deg")
        ax.set_title(f"schedule certificate: {'stable' if self.stable else 'UNSTABLE'}")
        ax.legend(fontsize=8)
        return ax


def certify(schedule: Schedule, grid_plants, *, dense: int = 3, plant_at=None, freq=None,
            hardware=None) -> Certificate:
    """Check the scheduled loop's stability at the grid postures and densely between them.

    Parameters
    ----------
    schedule : Schedule
    grid_plants : sequence of Plant
        The plants at the grid postures (C order); at each the loop of its own controller is checked.
    dense : int
        Each grid interval is split into ``dense`` parts; at every interior point of this finer grid
        the blended controller (:meth:`Schedule.at`) is checked.
    plant_at : callable, optional
        ``s -> Plant`` (e.g. a calibrated robot's linearisation): the plant at an interior point.
        Without it, the plant there is the grid plants blended with the same weights as the
        controllers (:func:`blend_plants`: their responses interpolated, realised in parallel).
    freq : array_like, optional
        Lines of the margin, Hz (default 0.5-200 Hz, 600 lines, log-spaced).
    hardware : Hardware, optional
        :class:`~rmbench.control.closed_loop.Hardware`: certify the sampled-data loop it runs
        (:func:`~rmbench.control.sampled.sampled_radius`: sample rate, delay, hold, amplifier) at
        every point, the continuous loop's poles kept beside it. Without it: the continuous loop.
        The blended controller at a frozen posture is what the hardware runs there (its parts
        stepped in Tustin form side by side, outputs weighted).
    """
    freq = np.geomspace(0.5, 200.0, 600) if freq is None else np.asarray(freq, float)
    grid_plants = list(grid_plants)
    if len(grid_plants) != schedule.n_postures:
        raise InputError(f"certify needs {schedule.n_postures} grid plants, got {len(grid_plants)}")
    fine = [np.concatenate([np.linspace(g[i], g[i + 1], dense + 1)[:-1] for i in range(len(g) - 1)] + [g[-1:]])
            for g in schedule.grid]
    mesh = np.meshgrid(*fine, indexing="ij")
    points = np.stack([m.ravel() for m in mesh], axis=1)
    on_grid = np.array([all(np.any(np.isclose(v, g, rtol=0, atol=1e-12)) for v, g in zip(p, schedule.grid))
                        for p in points])
    max_real, margin, radius = [], [], []
    for p, grid_point in zip(points, on_grid):
        w = schedule.weights(p)
        if grid_point:
            i = int(np.argmax(w))
            pl, k = grid_plants[i], schedule.controllers[i]  # exactly that posture's design
        else:
            k = schedule.at(p)
            pl = plant_at(p) if plant_at is not None else blend_plants(grid_plants, w)
        max_real.append(float(np.max(np.linalg.eigvals(closed_loop_matrix(pl, k)).real)))
        margin.append(loop_margin(pl, k, freq))
        if hardware is not None:
            radius.append(sampled_radius(pl, k, hardware))
    return Certificate(points, on_grid, np.array(max_real), np.array(margin),
                       "model" if plant_at is not None else "interpolated",
                       *(("sampled", np.array(radius)) if hardware is not None else ()))
