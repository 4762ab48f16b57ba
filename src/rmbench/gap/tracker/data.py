"""Tracker readings as the diagnosis takes them: positions measured at joint configurations,
their noise, and the split of configurations into training and held-out ones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["TrackerData", "tracker_data", "default_covariance", "default_sigma", "check_readings",
           "split_readings", "repeat_scale"]


@dataclass(frozen=True)
class TrackerData:
    """What the diagnosis reads: joint commands, readings and their noise.

    Attributes
    ----------
    q : ndarray, shape (n, n_joint), rad
        Commanded joint angles.
    measured : ndarray, shape (n, 3), m
        Tracker readings (tracker frame).
    location : ndarray of int, shape (n,)
        Configuration label (repeats share it).
    sigma : ndarray, shape (n, 3), m
        Standard deviation of each reading per axis.
    t : ndarray, shape (n,), s, or None
        Time stamps.
    joints : tuple of str
    temperature : ndarray, shape (n,), °C, or None
        The robot's temperature at each reading.
    covariance : ndarray, shape (n, 3, 3), m², or None
        Full covariance of each reading in the robot's base frame (joint repeatability moves the
        TCP along one direction per joint: the axes are correlated); residuals are whitened with
        it, turned into the base frame by the registration, else divided by ``sigma``.
    """

    q: np.ndarray
    measured: np.ndarray
    location: np.ndarray
    sigma: np.ndarray
    t: np.ndarray | None = None
    joints: tuple = ()
    temperature: np.ndarray | None = None
    covariance: np.ndarray | None = None

    def whitening(self, rotation=np.eye(3)) -> np.ndarray:
        """Per reading, W with W Σ Wᵀ = I for the readings' (tracker-frame) errors, shape
        (n, 3, 3), 1/m; ``rotation`` turns base-frame vectors into the tracker frame."""
        if self.covariance is None:
            return np.eye(3)[None] / self.sigma[:, :, None]
        # Σ_tracker = R Σ Rᵀ = (R L)(R L)ᵀ: W = L⁻¹ Rᵀ
        return np.linalg.inv(np.linalg.cholesky(self.covariance)) @ np.asarray(rotation).T

    @property
    def drive_kind(self) -> str | None:
        """What thermal drift can follow: "temperature", "time" or None."""
        return "temperature" if self.temperature is not None else ("time" if self.t is not None else None)

    def drive(self, idx=slice(None)) -> np.ndarray | None:
        """Kelvin above the first reading's temperature, else hours since it (None without)."""
        if self.temperature is not None:
            return self.temperature[idx] - self.temperature[0]
        if self.t is not None:
            return (self.t[idx] - self.t.min()) / 3600.0
        return None


def tracker_data(readings, *, robot=None, sigma=None, repeatability: float = 0.2e-3) -> TrackerData:
    """The diagnosis's input from :class:`~rmbench.io.tracker_csv.TrackerReadings`.

    ``sigma`` (n, 3), m, overrides the readings' own; without either, the noise of a robot of
    rated RP ``repeatability`` (m) read by the default tracker is used, with its correlation
    between axes (:func:`rmbench.tracker.simulator.reading_covariance`, needs ``robot``). Time
    stamps and temperatures come with the readings when they have them.
    """
    s = sigma if sigma is not None else readings.sigma
    cov = None
    if s is None:
        if robot is None:
            raise InputError("readings carry no sigma columns: give the robot for the default noise")
        cov = default_covariance(robot, readings.q, readings.measured, repeatability=repeatability)
        s = np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1))
    return TrackerData(np.asarray(readings.q, float), np.asarray(readings.measured, float),
                       np.asarray(readings.location, int), np.asarray(s, float),
                       None if readings.t is None else np.asarray(readings.t, float),
                       tuple(readings.joints),
                       None if readings.temperature is None else np.asarray(readings.temperature, float),
                       cov)


def default_covariance(robot, q, measured, *, repeatability: float = 0.2e-3) -> np.ndarray:
    """Covariance per reading of a robot of rated RP ``repeatability`` (m) read by the default
    tracker (:func:`rmbench.tracker.simulator.reading_covariance`), shape (n, 3, 3), m²."""
    from rmbench.tracker.simulator import reading_covariance

    return reading_covariance(robot, q, measured, repeatability=repeatability)


def default_sigma(robot, q, measured, *, repeatability: float = 0.2e-3) -> np.ndarray:
    """σ per reading and axis (the diagonal of :func:`default_covariance`), shape (n, 3), m."""
    cov = default_covariance(robot, q, measured, repeatability=repeatability)
    return np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1))


def check_readings(data: TrackerData, chain) -> None:
    """Raise :class:`~rmbench.errors.InputError` where the readings do not fit the chain (joint
    count and names) or are not finite."""
    n = chain.n_joint
    if data.q.ndim != 2 or data.q.shape[1] != n:
        raise InputError(f"the readings have {data.q.shape[-1] if data.q.ndim == 2 else '?'} joint "
                         f"angles per row; the robot has {n} arm joints ({', '.join(chain.names)})")
    if data.joints and tuple(data.joints) != tuple(chain.names):
        raise InputError(f"the readings' joints ({', '.join(data.joints)}) are not the robot's "
                         f"({', '.join(chain.names)})")
    for name in ("q", "measured", "sigma"):
        arr = getattr(data, name)
        if not np.all(np.isfinite(arr)):
            raise InputError(f"readings {name} must be finite, got NaN or infinity")
    if not np.all(data.sigma > 0):
        raise InputError("readings sigma must be > 0")
    if data.covariance is not None and data.covariance.shape != (len(data.q), 3, 3):
        raise InputError(f"readings covariance must have shape ({len(data.q)}, 3, 3)")
    for name in ("t", "temperature"):
        v = getattr(data, name)
        if v is not None and (v.shape != (len(data.q),) or not np.all(np.isfinite(v))):
            raise InputError(f"readings {name} must be one finite value per reading")


def split_readings(data: TrackerData, heldout: float):
    """Configurations held out (every ``1/heldout``-th), and the readings of each part:
    ``(train, held, train_units, held_units)``, reading indices then configuration labels."""
    units = np.unique(data.location)
    if not 0 < heldout < 1:
        raise InputError(f"heldout must be between 0 and 1, got {heldout}")
    step = max(2, int(round(1 / heldout))) if heldout <= 0.5 else 2
    held_units = units[1::step] if heldout <= 0.5 else units[::step]
    train_units = np.setdiff1d(units, held_units)
    train = np.flatnonzero(np.isin(data.location, train_units))
    held = np.flatnonzero(np.isin(data.location, held_units))
    return train, held, train_units, held_units


def repeat_scale(residuals: np.ndarray, location: np.ndarray) -> tuple[float, int]:
    """The readings' noise measured on their repeats, as a factor on the assumed noise.

    A configuration read more than once (a campaign's repeats, minutes or hours apart) is the
    same pose each time: whatever a model misses that depends on the configuration alone (a link
    that bends, a mount that sags) is the same in each of its readings and cancels about their
    mean, while the noise does not. The pooled spread of the normalised residuals about each
    configuration's mean, ``Σ |r − r̄_c|² / (3 Σ (n_c − 1))``, is the noise's variance in units of
    the assumed one. What changes between a configuration's readings besides the noise (a drift
    in time, a backlash after another approach) adds to it.

    Parameters
    ----------
    residuals : ndarray, shape (n, 3)
        Normalised residuals (reading − model) / σ of every reading.
    location : ndarray of int, shape (n,)
        Each reading's configuration label.

    Returns
    -------
    scale : float
        The noise's standard deviation over the assumed one (1.0 where no configuration is read
        twice).
    dof : int
        Degrees of freedom of the estimate, ``3 Σ (n_c − 1)`` (0: none).
    """
    r = np.asarray(residuals, float).reshape(len(location), -1)
    labels, inverse, counts = np.unique(np.asarray(location), return_inverse=True, return_counts=True)
    dof = int(r.shape[1] * np.sum(counts - 1))
    if dof == 0:
        return 1.0, 0
    mean = np.zeros((len(labels), r.shape[1]))
    np.add.at(mean, inverse, r)
    mean /= counts[:, None]
    return float(np.sqrt(np.sum((r - mean[inverse]) ** 2) / dof)), dof
