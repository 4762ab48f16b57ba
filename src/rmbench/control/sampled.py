"""Stability of the sampled-data loop the hardware runs (issue 83), not of the continuous one.

:func:`~rmbench.control.analysis.is_stable` checks plant and controller in continuous feedback.
The real-time loop (:mod:`rmbench.control.closed_loop`) differs: the controller runs in Tustin form
at ``Hardware.fs``, its force reaches the amplifier ``delay_samples`` samples later and is held
between samples, the amplifier lags (first order, ``amp_bandwidth``), and the accelerometer
reading a sample uses is the one MuJoCo computed at the start of the last physics step (``mj_step``
evaluates the sensors before it integrates: the acceleration is one physics step old, the encoder
positions are not). Each of these costs phase; a controller the continuous check passes can be
unstable on the hardware. :func:`sampled_loop` builds that loop as one discrete-time state matrix;
its spectral radius below 1 is the loop's stability.

What is modelled, per controller sample of ``T = 1/fs`` split into ``substeps`` physics steps of
``h = T / substeps``:

- the plant, continuous, discretised exactly by zero-order hold over ``h`` (``expm``): its input is
  the coil force held through each physics step, as MuJoCo holds ``ctrl``;
- the amplifier as the simulation runs it: before each physics step the force moves
  ``α = 1 − exp(−2π f_amp h)`` of the way to its target (a first-order lag, exact for a held target)
  and is then held through the step;
- the controller in Tustin form at ``fs`` (:meth:`Controller.discretize`, the function the
  simulation uses);
- the delay: a shift register of ``delay_samples`` force vectors;
- the measurements: ``y = [a, p]`` with ``a`` the acceleration at the start of the last physics
  step (the force then applied included) and ``p`` the reaction-mass positions now.

What is not: the accelerometer's AC coupling is no filter here: the simulation subtracts the static
reading at equilibrium, a constant that does not enter the loop's dynamics; the sensor noise, bias
and encoder quantisation are inputs or a nonlinearity of amplitude 1 µm, not in a stability test;
the coils' force limit, the end stops and the stroke guard are nonlinear and idle while the loop is
small (the guard's gain is 1). The plant is the linear one given, not MuJoCo's semi-implicit Euler
integration of the nonlinear robot.

Robustness: :func:`certify_sampled` checks a list of plants (parameter draws of a calibrated plant,
the plants of a grid, …) against one controller. It certifies those plants and nothing between
them: no guarantee is claimed for a parameter interval beyond the points given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from rmbench.control.analysis import closed_loop_matrix
from rmbench.control.controller import Controller
from rmbench.control.plant import Plant
from rmbench.errors import InputError
from rmbench.plotting import axes_or_new

__all__ = ["sampled_loop", "sampled_radius", "sampled_stable", "SampledCertificate", "certify_sampled"]


def _substep(plant: Plant, h: float, amp_bandwidth: float) -> tuple[np.ndarray, np.ndarray]:
    """One physics step of plant, amplifier and accelerometer reading: ``w' = P w + Q t`` over
    ``w = [x, f, r]`` (plant state, applied force N, acceleration read m/s²) for a held target
    force ``t`` (N)."""
    n, nx = plant.n_axes, plant.order
    Bu, C_acc, D_acc = plant.B[:, n:], plant.C[:n], plant.D[:n, n:]
    aug = np.zeros((nx + n, nx + n))
    aug[:nx, :nx], aug[:nx, nx:] = plant.A, Bu
    E = expm(aug * h)                      # exact zero-order hold: [[Φ, Γ], [0, I]]
    Phi, Gam = E[:nx, :nx], E[:nx, nx:]
    a = 1.0 - np.exp(-2 * np.pi * amp_bandwidth * h)
    x, f, r = slice(0, nx), slice(nx, nx + n), slice(nx + n, nx + 2 * n)
    P = np.zeros((nx + 2 * n, nx + 2 * n))
    Q = np.zeros((nx + 2 * n, n))
    # f' = (1 − α) f + α t, applied through the step; x and the reading see f'
    P[f, f], Q[f] = (1 - a) * np.eye(n), a * np.eye(n)
    P[x, x], P[x, f], Q[x] = Phi, (1 - a) * Gam, a * Gam
    P[r, x], P[r, f], Q[r] = C_acc, (1 - a) * D_acc, a * D_acc
    return P, Q


def sampled_loop(plant: Plant, controller: Controller, hardware) -> tuple[np.ndarray, dict]:
    """The discrete-time closed loop at ``hardware.fs``: ``S[k+1] = Phi @ S[k]`` (module docstring).

    Parameters
    ----------
    plant : Plant
        Continuous-time plant (inputs ``[d, u]``, outputs ``[a, p]``; only ``u`` is driven).
    controller : Controller
        Continuous-time controller on the plant's axes (``u = K y``).
    hardware : Hardware
        :class:`~rmbench.control.closed_loop.Hardware` (``fs``, ``substeps``, ``delay_samples``,
        ``amp_bandwidth`` are read).

    Returns
    -------
    Phi : ndarray, shape (N, N)
        ``N = n_x + 2n + n_k + delay·n``; the state at sample ``k``, taken just before the
        controller steps, is ordered ``[x, f, r, x_k, u_(k−1), …, u_(k−delay)]``: plant state
        (its own units), force the amplifier applied in the last physics step (N, n), acceleration
        read (m/s², n), Tustin controller state, the forces computed and not yet sent (N, n each).
    layout : dict
        ``{name: slice}`` of those blocks (``"plant"``, ``"force"``, ``"acc_read"``,
        ``"controller"``, ``"delay"``).
    """
    if controller.axes != plant.axes:
        raise InputError(f"controller drives {controller.axes}, the plant has axes {plant.axes}")
    n, nx = plant.n_axes, plant.order
    T, s, dly = 1.0 / hardware.fs, int(hardware.substeps), int(hardware.delay_samples)
    Ad, Bd, Cd, Dd = controller.discretize(hardware.fs)
    nk = Ad.shape[0]
    nw = nx + 2 * n
    N = nw + nk + dly * n
    lay = {"plant": slice(0, nx), "force": slice(nx, nx + n), "acc_read": slice(nx + n, nw),
           "controller": slice(nw, nw + nk), "delay": slice(nw + nk, N)}
    Y = np.zeros((2 * n, N))                  # y = [a read; p now] = Y S
    Y[:n, lay["acc_read"]] = np.eye(n)
    Y[n:, lay["plant"]] = plant.C[n:]
    Y[n:, lay["force"]] = plant.D[n:, n:]     # zero for a position output; kept for generality
    U = Dd @ Y                                # u_k = U S
    U[:, lay["controller"]] += Cd
    if dly:                                   # the target sent now: u_(k−delay)
        Tgt = np.zeros((n, N))
        Tgt[:, N - n:] = np.eye(n)
    else:
        Tgt = U
    P, Q = _substep(plant, T / s, hardware.amp_bandwidth)
    Ps, Qs = np.eye(nw), np.zeros((nw, n))
    for _ in range(s):
        Ps, Qs = P @ Ps, P @ Qs + Q
    Phi = np.zeros((N, N))
    Phi[:nw] = Qs @ Tgt
    Phi[:nw, :nw] += Ps
    Phi[lay["controller"]] = Bd @ Y
    Phi[lay["controller"], lay["controller"]] += Ad
    if dly:
        d0 = nw + nk
        Phi[d0:d0 + n] = U
        Phi[d0 + n:N, d0:N - n] = np.eye((dly - 1) * n)
    return Phi, lay


def sampled_radius(plant: Plant, controller: Controller, hardware) -> float:
    """Spectral radius of :func:`sampled_loop`'s matrix: below 1 the loop is stable, and
    ``−fs·ln ρ`` (1/s) is the slowest decay rate, the sampled counterpart of −max Re(pole)."""
    return float(np.max(np.abs(np.linalg.eigvals(sampled_loop(plant, controller, hardware)[0]))))


def sampled_stable(plant: Plant, controller: Controller, hardware) -> bool:
    """Whether the sampled-data loop is stable (spectral radius < 1)."""
    return sampled_radius(plant, controller, hardware) < 1.0


@dataclass(frozen=True)
class SampledCertificate:
    """Sampled-data stability of one controller against a list of plants.

    Attributes
    ----------
    spectral_radius : ndarray, shape (n_plants,)
        Of each plant's sampled loop (< 1 stable).
    continuous_max_real : ndarray, shape (n_plants,)
        Largest real part of the continuous loop's poles, 1/s (< 0 stable): the check the sampled
        one replaces, kept for comparison.
    hardware : dict
        ``fs`` (Hz), ``substeps``, ``delay_samples``, ``amp_bandwidth`` (Hz) of the loop checked.
    """

    spectral_radius: np.ndarray
    continuous_max_real: np.ndarray
    hardware: dict

    @property
    def unstable(self) -> int:
        """Plants whose sampled loop is unstable."""
        return int(np.sum(self.spectral_radius >= 1.0))

    @property
    def stable(self) -> bool:
        """Whether every plant's sampled loop is stable (spectral radius below 1)."""
        return self.unstable == 0

    @property
    def continuous_unstable(self) -> int:
        """Plants whose continuous loop is unstable (the check the sampled one replaces)."""
        return int(np.sum(self.continuous_max_real >= 0.0))

    @property
    def worst(self) -> int:
        """Index of the plant with the largest spectral radius."""
        return int(np.argmax(self.spectral_radius))

    def to_dict(self) -> dict:
        """Counts, the worst plant and every plant's spectral radius and continuous largest real
        part (1/s), with the hardware checked, as strict JSON values."""
        from rmbench.io.strict_json import jsonable

        w = self.worst
        return jsonable({"loop": "sampled", "plants": len(self.spectral_radius), "stable": self.stable,
                         "unstable": self.unstable, "continuous_unstable": self.continuous_unstable,
                         "worst": {"index": w, "spectral_radius": self.spectral_radius[w],
                                   "continuous_max_real": self.continuous_max_real[w]},
                         "hardware": self.hardware, "spectral_radius": self.spectral_radius,
                         "continuous_max_real": self.continuous_max_real})

    def summary(self) -> str:
        """Unstable plants on the sampled and on the continuous loop, and the worst plant's
        spectral radius (dimensionless, per sample) and decay time constant (s)."""
        w, hw = self.worst, self.hardware
        rho = float(self.spectral_radius[w])
        decay = f"slowest decay {-1.0 / (hw['fs'] * np.log(rho)):.3g} s" if 0 < rho < 1 else "no decay"
        return "\n".join([
            f"sampled-data loop at {hw['fs']:g} Hz ({hw['delay_samples']} sample(s) delay, amplifier "
            f"{hw['amp_bandwidth']:g} Hz): {self.unstable} of {len(self.spectral_radius)} plants unstable "
            f"(continuous check: {self.continuous_unstable})",
            f"worst plant {w}: spectral radius {rho:.6f} ({decay})"])

    def plot(self, ax=None):
        """Spectral radius per plant against the stability limit 1; unstable plants as red crosses.

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        ax = axes_or_new(ax, (6, 3.5))
        i = np.arange(len(self.spectral_radius))
        bad = self.spectral_radius >= 1.0
        ax.plot(i, self.spectral_radius, "o", color="C0", ms=4, label="spectral radius")
        ax.plot(i[bad], self.spectral_radius[bad], "x", color="red", label="unstable")
        ax.axhline(1.0, color="k", lw=0.8, ls="--", label="stability limit")
        ax.set_xlabel("plant")
        ax.set_ylabel("spectral radius")
        ax.set_title(f"sampled-data loop: {self.unstable} of {len(i)} unstable")
        ax.legend(fontsize=8)
        return ax


def certify_sampled(plants, controller: Controller, hardware) -> SampledCertificate:
    """The sampled-data loop of ``controller`` with each of ``plants`` (and the continuous loop's
    verdict beside it). Only the plants given are checked (module docstring)."""
    plants = list(plants)
    if not plants:
        raise InputError("certify_sampled needs at least one plant")
    rho = [sampled_radius(p, controller, hardware) for p in plants]
    cont = [float(np.max(np.linalg.eigvals(closed_loop_matrix(p, controller)).real)) for p in plants]
    hw = {"fs": float(hardware.fs), "substeps": int(hardware.substeps),
          "delay_samples": int(hardware.delay_samples), "amp_bandwidth": float(hardware.amp_bandwidth)}
    return SampledCertificate(np.array(rho), np.array(cont), hw)
