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

from rmbench._version import __version__
from rmbench.errors import InputError
from rmbench.robot.modes import PARAMS
from rmbench.impact.sensors import COORDS
from rmbench.modeshape import pair_modes

__all__ = ["DATASET_VERSION", "PartStore", "save", "open_campaign", "track_modes", "posture_positions",
           "exact_modes_dataset", "find_posture"]

#: Version of the campaign dataset format, written as the ``rmbench_dataset_version`` attribute;
#: :func:`open_campaign` reads this version and older.
DATASET_VERSION = 1


def posture_positions(x, y, theta) -> np.ndarray:
    """Posture coordinates for neighbour search: 0.1 m of travel weighs as much as 10° of θ.

    Parameters
    ----------
    x, y : array_like, shape (n_postures,), m
    theta : array_like, shape (n_postures,), rad

    Returns
    -------
    ndarray, shape (n_postures, 3)
    """
    return np.column_stack([np.asarray(x) / 0.1, np.asarray(y) / 0.1, np.asarray(theta) / np.radians(10)])


def find_posture(ds: xr.Dataset, posture) -> int | None:
    """Position of ``posture`` (x, y in m, theta in rad) among a dataset's postures, or None where
    none lies within 1e-6 of it (|Δx| + |Δy| + |Δθ|, m and rad)."""
    d = np.abs(ds.x.values - posture.x) + np.abs(ds.y.values - posture.y) + np.abs(ds.theta.values - posture.theta)
    index = int(np.nanargmin(d))
    return index if d[index] < 1e-6 else None


def track_modes(tables: list, positions: np.ndarray | None = None, *, freq_tol: float = 0.05,
                max_cost: float = 3.0) -> np.ndarray:
    """Consistent mode numbers over the postures of a campaign.

    Modes are numbered by frequency at the first posture that has any (the root; DATA.md). The
    other postures are visited along the minimum spanning tree of their ``positions`` from the
    root (in the order given without positions), and each posture's modes are paired with the
    tracked modes of its parent — its nearest already-tracked neighbour, so that a mode never
    jumps across the workspace between two comparisons — by minimum cost
    ``(1 − MAC([φR, φL])) + |Δf| / (f · freq_tol)`` (Hungarian assignment); a mode missing at
    the parent is compared with its value further up the tree. A mode whose best pairing costs
    more than ``max_cost`` starts a new track, numbered after the existing ones. Comparing φR and φL together (8 complex entries) separates close modes
    better than φR alone; the frequency term dominates once two modes are more than
    ``freq_tol`` apart, because base-frame eigenvector components rotate with the wrist (two
    perpendicular spindle bending modes swap their X/Y shapes as θ turns) while a mode's
    frequency moves little between neighbouring postures.

    Parameters
    ----------
    tables : list of ModeTable or None
        One per posture (None for a failed posture).
    positions : ndarray, shape (n_postures, d), optional
        Posture coordinates scaled to comparable units (see :func:`posture_positions`).

    Returns
    -------
    ndarray, shape (n_postures, n_tracked, 16)
        Parameters in DATA.md order, NaN where a mode was not found.
    """
    valid = [p for p, t in enumerate(tables) if t is not None and len(t)]
    if not valid:
        return np.full((len(tables), 0, 16), np.nan)
    root = valid[0]
    n = len(tables[root])
    order, parent = _visit_order(valid, root, positions)
    t0 = tables[root]
    rank = np.argsort(t0.f_n)
    columns = [np.full((len(tables), 16), np.nan) for _ in range(n)]
    for i, j in enumerate(rank):
        columns[i][root] = t0.params()[j]
    origin = [(t0.f_n[j], _shapes(t0)[j]) for j in rank]  # where each track was first seen
    state = {root: {i: origin[i] for i in range(n)}}
    for p in order:
        if p == root:
            continue
        # the parent's view of every track; tracks it never saw, as first seen
        known = {i: state[parent[p]].get(i, origin[i]) for i in range(len(columns))}
        t = tables[p]
        shapes = _shapes(t)
        tracks = [known[i] for i in range(len(columns))]  # (f, shape) of each track
        pairs = pair_modes(t.f_n, [f for f, _ in tracks], shapes, np.array([s for _, s in tracks]),
                           freq_scale=freq_tol, freq="relative", max_cost=max_cost)
        params = t.params()
        paired = set()
        for j, i in zip(*pairs):
            columns[i][p] = params[j]
            known[i] = (t.f_n[j], shapes[j])
            paired.add(j)
        for j in np.argsort(t.f_n):
            if j not in paired:  # a mode unlike every tracked one starts a track of its own
                columns.append(np.full((len(tables), 16), np.nan))
                columns[-1][p] = params[j]
                origin.append((t.f_n[j], shapes[j]))
                known[len(columns) - 1] = origin[-1]
        state[p] = known
    return np.stack(columns, axis=1)


def _shapes(table) -> np.ndarray:
    """[φR / |φR|, φL / |φL|] of each mode, shape (n_modes, 8): both sides weigh alike in the MAC."""
    r = table.phi_r / np.linalg.norm(table.phi_r, axis=1, keepdims=True)
    lft = table.phi_l / np.linalg.norm(table.phi_l, axis=1, keepdims=True)
    return np.concatenate([r, lft], axis=1)


def _visit_order(valid: list, root: int, positions) -> tuple[list, dict]:
    """Postures in tree order from the root and each one's parent (the previous one without positions)."""
    if positions is None:
        order = [root] + [p for p in valid if p != root]
        return order, {p: q for q, p in zip(order[:-1], order[1:])}
    from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree
    from scipy.spatial.distance import cdist

    pos = np.asarray(positions, float)[valid]
    # ties in distance are broken by index; a tiny offset keeps zero distances as edges
    tree = minimum_spanning_tree(cdist(pos, pos) + 1e-9)
    idx, pred = breadth_first_order(tree, valid.index(root), directed=False)
    order = [valid[i] for i in idx]
    return order, {valid[i]: valid[pred[i]] for i in idx if pred[i] >= 0}


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

    def assemble(self, toml: str, postures, robot) -> xr.Dataset:
        """One dataset from all parts, modes tracked over the postures; ``robot`` (the campaign's
        :class:`rmbench.robot.Robot`) names the joints of ``q_cmd`` and gives the table height."""
        from rmbench.robot.modes import ModeTable

        cfg = self.cfg
        parts = [self.read(i) for i in range(self.n)]
        bands = list(cfg.bands)
        from rmbench.impact.measure import band_lines

        freq_b = {b: band_lines(cfg.bands[b]) for b in bands}
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
        modal, mode_band = _tracked_modes(tables, postures, bands, self.n)
        n_modes = modal["modes"].shape[1]
        joints = list(robot.arm_joints) if n_joint else []
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
        _annotate(ds, cfg, toml, robot)
        return ds

    def remove(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


def _tracked_modes(tables: dict, postures, bands, n: int) -> tuple[dict, np.ndarray]:
    """The exact modes as tested and bare, each tracked over the postures per band
    (``{"modes" | "modes_bare": (n, n_modes, 16)}``, padded to a common mode count), and each
    mode's band."""
    modal, mode_band = {}, []
    pos = posture_positions([p.x for p in postures], [p.y for p in postures], [p.theta for p in postures])
    for k in ("modes", "modes_bare"):
        blocks = [track_modes(tables[(b, k)], pos) for b in bands]
        modal[k] = np.concatenate(blocks, axis=1) if blocks else np.zeros((n, 0, 16))
        if k == "modes":
            mode_band = np.concatenate([[b] * blk.shape[1] for b, blk in zip(bands, blocks)])
    # the bare and as-tested sets may differ in count; pad to a common mode axis
    n_modes = max(modal["modes"].shape[1], modal["modes_bare"].shape[1])
    for k in modal:
        pad = n_modes - modal[k].shape[1]
        if pad:
            modal[k] = np.concatenate([modal[k], np.full((n, pad, 16), np.nan)], axis=1)
    if len(mode_band) < n_modes:
        mode_band = np.concatenate([mode_band, ["?"] * (n_modes - len(mode_band))])
    return modal, np.asarray(mode_band)


def _annotate(ds: xr.Dataset, cfg, toml: str, robot) -> None:
    """Units of the variables and coordinates, and the campaign's provenance in the attributes."""
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
        config=toml or cfg.model_dump_json(), config_digest=cfg.digest, seed=cfg.seed, method=cfg.method,
        robot=robot_name, commands_from=cfg.robot.commands_from or robot_name,
        tool=str(cfg.robot.tool), table_z=float(robot.table_z),
        sensor_spacing_low=1e-3 * cfg.bands["low"].s_1a_mm if "low" in cfg.bands else np.nan,
        sensor_spacing_high=1e-3 * cfg.bands["high"].s_1a_mm if "high" in cfg.bands else np.nan,
        receptance_from="accelerance (high band), displacement (low band)", upstream="",
        software=_versions())


def exact_modes_dataset(robot, postures, bands=("low", "high")) -> xr.Dataset:
    """The robot's exact modes at postures, tracked over them, as a modal dataset (DATA.md's
    ``modal`` layout, as :func:`rmbench.modal.fit_campaign` writes): what a posture predictor
    trains on when the simulator's truth is wanted without a campaign (the modes of the bare tool,
    no sensor on it; :meth:`rmbench.robot.model.OperatingPoint.modes`).

    Parameters
    ----------
    robot : rmbench.robot.Robot
    postures : sequence of Posture
    bands : sequence of str

    Returns
    -------
    xarray.Dataset
        ``modal`` (posture, mode, param) with ``mode_band``; coordinates x, y (m), theta (rad).
    """
    postures = list(postures)
    tables = {(b, "modes"): [] for b in bands}
    for p in postures:
        op = robot.at(p)
        for b in bands:
            tables[(b, "modes")].append(op.modes(b))
    for b in bands:                   # _tracked_modes tracks both sets; the bare one is this one
        tables[(b, "modes_bare")] = tables[(b, "modes")]
    modal, mode_band = _tracked_modes(tables, postures, list(bands), len(postures))
    return xr.Dataset(
        {"modal": (("posture", "mode", "param"), modal["modes"])},
        coords={"posture": np.arange(len(postures)), "x": ("posture", np.array([p.x for p in postures])),
                "y": ("posture", np.array([p.y for p in postures])),
                "theta": ("posture", np.array([p.theta for p in postures])),
                "mode": np.arange(modal["modes"].shape[1]), "mode_band": ("mode", np.asarray(mode_band, str)),
                "param": list(PARAMS)},
        attrs={"kind": "exact_modes", "robot": robot.name, "tool": str(robot.tool)})

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
