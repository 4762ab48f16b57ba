"""Campaign datasets (DATA.md layout): per-posture parts, assembly with mode tracking, file IO.

A dataset is one netCDF-4 file written with h5netcdf (complex variables as HDF5 complex
compounds). Its attribute ``rmbench_dataset_version`` names the layout; older layouts are upgraded
on open where possible, newer or unknown ones rejected with both versions named.
"""

from __future__ import annotations

import datetime as _dt
import json
import shutil
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.optimize import linear_sum_assignment

from rmbench._version import __version__
from rmbench.errors import InputError
from rmbench.robot.modes import PARAMS
from rmbench.impact.sensors import COORDS

__all__ = ["DATASET_VERSION", "PartStore", "save", "open_campaign", "track_modes", "mac"]

DATASET_VERSION = 1


def mac(a: np.ndarray, b: np.ndarray) -> float:
    """Modal assurance criterion of two complex vectors."""
    return float(np.abs(np.vdot(a, b)) ** 2 / (np.vdot(a, a).real * np.vdot(b, b).real))


def track_modes(tables: list, max_cost: float = 0.6) -> np.ndarray:
    """Consistent mode numbers over a sequence of postures.

    Modes are numbered by frequency at the first posture that has any; each later posture's modes
    are paired with the last known value of each tracked mode by minimum cost
    ``(1 − MAC(φR)) + |Δf|/f`` (Hungarian assignment); a pairing above ``max_cost`` is left out.

    Parameters
    ----------
    tables : list of ModeTable or None
        One per posture (None for a failed posture).

    Returns
    -------
    ndarray, shape (n_postures, n_tracked, 16)
        Parameters in DATA.md order, NaN where a mode was not found.
    """
    ref = next((t for t in tables if t is not None and len(t)), None)
    n = len(ref) if ref is not None else 0
    out = np.full((len(tables), n, 16), np.nan)
    if n == 0:
        return out
    last_f = ref.f_n.copy()
    last_phi = ref.phi_r.copy()
    for p, t in enumerate(tables):
        if t is None or len(t) == 0:
            continue
        cost = np.empty((n, len(t)))
        for i in range(n):
            for j in range(len(t)):
                cost[i, j] = (1 - mac(last_phi[i], t.phi_r[j])) + abs(t.f_n[j] - last_f[i]) / last_f[i]
        rows, cols = linear_sum_assignment(cost)
        params = t.params()
        for i, j in zip(rows, cols):
            if cost[i, j] <= max_cost:
                out[p, i] = params[j]
                last_f[i], last_phi[i] = t.f_n[j], t.phi_r[j]
    return out


class PartStore:
    """The per-posture results of a running campaign, beside its output file.

    Raises
    ------
    InputError
        If the directory holds parts of a different configuration.
    """

    def __init__(self, out: Path, cfg, n_postures: int):
        self.dir = Path(str(out) + ".parts")
        self.cfg = cfg
        self.digest = cfg.digest
        self.n = n_postures
        meta = self.dir / "campaign.json"
        if meta.is_file():
            saved = json.loads(meta.read_text())
            if saved.get("digest") != self.digest:
                raise InputError(f"{self.dir} holds partial results of another configuration; "
                                 "remove it or use another --out")
        else:
            self.dir.mkdir(parents=True, exist_ok=True)
            _atomic_write_text(meta, json.dumps({"digest": self.digest, "n_postures": n_postures}))

    def path(self, index: int) -> Path:
        return self.dir / f"posture_{index:05d}.npz"

    def has(self, index: int) -> bool:
        return self.path(index).is_file()

    def write(self, result: dict) -> None:
        """Store one posture's result atomically (plain arrays, no pickle)."""
        arrays = {"ok": np.array(result["ok"]), "reason": np.array(result["reason"]),
                  "seconds": np.array(result["seconds"]), "steps": np.array(result["steps"]),
                  "overloads": np.array(result["overloads"]),
                  "q_cmd": np.array(result["q_cmd"] if result["q_cmd"] is not None else [], float)}
        for name, b in result["bands"].items():
            for key in ("freq", "H", "coherence", "H_exact", "H_exact_bare"):
                arrays[f"{name}__{key}"] = b[key]
            for key in ("modes", "modes_bare"):
                t = b[key]
                arrays[f"{name}__{key}__params"] = t.params()
                arrays[f"{name}__{key}__phi_r"] = t.phi_r
                arrays[f"{name}__{key}__phi_l"] = t.phi_l
        path = self.path(result["index"])
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, **arrays)
        tmp.replace(path)

    def read(self, index: int) -> dict:
        with np.load(self.path(index), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}

    def assemble(self, toml: str, postures) -> xr.Dataset:
        """One dataset from all parts, modes tracked over the postures."""
        from rmbench.robot.modes import ModeTable

        cfg = self.cfg
        parts = [self.read(i) for i in range(self.n)]
        bands = list(cfg.bands)
        freq_b = {}
        for b in bands:
            from rmbench.impact.measure import band_lines

            freq_b[b] = band_lines(cfg.bands[b])
        freq = np.concatenate([freq_b[b] for b in bands])
        band_coord = np.concatenate([[b] * len(freq_b[b]) for b in bands])
        shape = (self.n, len(freq), 4, 4)
        data = {k: np.full(shape, np.nan + 0j if k != "coherence" else np.nan)
                for k in ("H", "coherence", "H_exact", "H_exact_bare")}
        ok = np.array([bool(p["ok"]) for p in parts])
        n_joint = max((len(p["q_cmd"]) for p in parts), default=0)
        q_cmd = np.full((self.n, n_joint), np.nan)
        tables = {(b, k): [] for b in bands for k in ("modes", "modes_bare")}
        for i, p in enumerate(parts):
            if len(p["q_cmd"]):
                q_cmd[i] = p["q_cmd"]
            start = 0
            for b in bands:
                n_b = len(freq_b[b])
                if ok[i]:
                    for k in data:
                        data[k][i, start:start + n_b] = p[f"{b}__{k}"]
                for k in ("modes", "modes_bare"):
                    if ok[i]:
                        prm = p[f"{b}__{k}__params"]
                        tables[(b, k)].append(ModeTable(
                            band=b, f_n=prm[:, 0], zeta=prm[:, 1], phi_r=p[f"{b}__{k}__phi_r"],
                            phi_l=p[f"{b}__{k}__phi_l"], peak=np.zeros(len(prm))))
                    else:
                        tables[(b, k)].append(None)
                start += n_b
        modal, mode_band = {}, []
        for k in ("modes", "modes_bare"):
            blocks = [track_modes(tables[(b, k)]) for b in bands]
            modal[k] = np.concatenate(blocks, axis=1) if blocks else np.zeros((self.n, 0, 16))
            if k == "modes":
                mode_band = np.concatenate([[b] * blk.shape[1] for b, blk in zip(bands, blocks)])
        # the bare and as-tested sets may differ in count; pad to a common mode axis
        n_modes = max(modal["modes"].shape[1], modal["modes_bare"].shape[1])
        for k in modal:
            pad = n_modes - modal[k].shape[1]
            if pad:
                modal[k] = np.concatenate([modal[k], np.full((self.n, pad, 16), np.nan)], axis=1)
        if len(mode_band) < n_modes:
            mode_band = np.concatenate([mode_band, ["?"] * (n_modes - len(mode_band))])
        from rmbench.impact.campaign import Campaign

        joints = list(Campaign.build(cfg).robot.arm_joints) if n_joint else []
        ds = xr.Dataset(
            {
                "H": (("posture", "freq", "out", "inp"), data["H"]),
                "coherence": (("posture", "freq", "out", "inp"), data["coherence"].real),
                "H_exact": (("posture", "freq", "out", "inp"), data["H_exact"]),
                "H_exact_bare": (("posture", "freq", "out", "inp"), data["H_exact_bare"]),
                "modal_exact": (("posture", "mode", "param"), modal["modes"]),
                "modal_exact_bare": (("posture", "mode", "param"), modal["modes_bare"]),
                "q_cmd": (("posture", "joint"), q_cmd),
                "seconds": ("posture", np.array([float(p["seconds"]) for p in parts])),
                "steps": ("posture", np.array([int(p["steps"]) for p in parts])),
                "overloads": ("posture", np.array([int(p["overloads"]) for p in parts])),
            },
            coords={
                "posture": np.arange(self.n),
                "x": ("posture", np.array([p.x for p in postures])),
                "y": ("posture", np.array([p.y for p in postures])),
                "theta": ("posture", np.array([p.theta for p in postures])),
                "ok": ("posture", ok),
                "reason": ("posture", np.array([str(p["reason"]) for p in parts])),
                "freq": freq,
                "band": ("freq", band_coord),
                "out": list(COORDS),
                "inp": list(COORDS),
                "joint": joints,
                "mode": np.arange(n_modes),
                "mode_band": ("mode", np.asarray(mode_band, dtype=str)),
                "param": list(PARAMS),
            },
        )
        ds["H"].attrs.update(units="m/N", long_name="measured receptance (H1)")
        ds["H_exact"].attrs.update(units="m/N", long_name="exact receptance as tested")
        ds["H_exact_bare"].attrs.update(units="m/N", long_name="exact receptance without sensors")
        ds["x"].attrs["units"] = "m"
        ds["y"].attrs["units"] = "m"
        ds["theta"].attrs["units"] = "rad"
        ds["freq"].attrs["units"] = "Hz"
        ds["q_cmd"].attrs["units"] = "rad"
        robot_name = cfg.robot.name
        ds.attrs.update(
            rmbench_version=__version__, rmbench_dataset_version=DATASET_VERSION,
            created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            config=toml or cfg.model_dump_json(), seed=cfg.seed, method=cfg.method,
            robot=robot_name, tool=str(cfg.robot.tool), table_z=float(Campaign.build(cfg).robot.table_z),
            sensor_spacing_low=1e-3 * cfg.bands["low"].s_1a_mm if "low" in cfg.bands else np.nan,
            sensor_spacing_high=1e-3 * cfg.bands["high"].s_1a_mm if "high" in cfg.bands else np.nan,
            receptance_from="accelerance (high band), displacement (low band)", upstream="",
            software=_versions())
        return ds

    def remove(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


def save(ds: xr.Dataset, path: str | Path) -> Path:
    """Write a dataset atomically (a temporary file renamed into place)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    ds.to_netcdf(tmp, engine="h5netcdf", invalid_netcdf=True)
    tmp.replace(path)
    return path


def open_campaign(path: str | Path) -> xr.Dataset:
    """Open a campaign dataset, checking its layout version.

    Raises
    ------
    InputError
        If the file is missing, unreadable, or of a layout this version cannot read.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"dataset not found: {path}")
    try:
        ds = xr.load_dataset(path, engine="h5netcdf")
    except Exception as err:  # h5py/h5netcdf raise many types for a bad file
        raise InputError(f"cannot read dataset {path}: {type(err).__name__}: {err}") from None
    version = ds.attrs.get("rmbench_dataset_version")
    if version is None:
        raise InputError(f"{path} is not an rmbench campaign dataset (no rmbench_dataset_version)")
    version = int(version)
    if version > DATASET_VERSION or version < 1:
        raise InputError(f"{path} has dataset version {version}; this rmbench "
                         f"({__version__}) reads version {DATASET_VERSION} and older")
    for name in ("H",):
        if name not in ds:
            raise InputError(f"{path} has no variable {name!r}")
    return ds


def _versions() -> str:
    import mujoco
    import pinocchio

    return json.dumps({"rmbench": __version__, "mujoco": mujoco.__version__,
                       "pinocchio": pinocchio.__version__, "numpy": np.__version__,
                       "xarray": xr.__version__})


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)
