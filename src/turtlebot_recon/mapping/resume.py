"""The mapper's resume file: its grid saved as it grows, so that a mapper restarted mid-run
(roslaunch's respawn, docs/faults.md) goes on from the map it had instead of an empty one.

One file, ``<map_file>.resume.npz`` beside the map: the grid's log-odds (NaN unknown), its
resolution and origin, the sim time it was saved at and the launch's key. It is written whole
through a temporary file and a rename (``files.write_atomic``): a SIGKILL in the middle of a
save leaves the previous file, never a broken one. A file written under another key is an
earlier run's in the same directory and is not taken.
"""
from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from ..files import write_atomic
from .map_io import FREE_THRESH, OCCUPIED_THRESH, save_map

RESUME_SUFFIX = ".resume.npz"


def resume_path(map_file: str | Path) -> Path:
    """The resume file beside the map whose base path (``.../map``) is ``map_file``."""
    return Path(str(map_file) + RESUME_SUFFIX)


def save_resume(path: str | Path, logodds: np.ndarray, resolution: float, origin_xy: tuple,
                key: str, stamp_s: float) -> Path:
    """Write the grid (log-odds float32 (rows, cols), NaN unknown; ``resolution`` m per cell;
    ``origin_xy`` m) saved at sim time ``stamp_s`` under the launch's ``key``, atomically.
    OSError (a full disk) leaves the previous file as it was."""
    buf = io.BytesIO()
    np.savez_compressed(buf, logodds=np.asarray(logodds, np.float32), resolution=float(resolution),
                        origin=np.asarray(origin_xy, float)[:2], key=str(key), stamp_s=float(stamp_s))
    return write_atomic(path, buf.getvalue())


def load_resume(path: str | Path, key: str | None):
    """(log-odds, resolution m, (origin x, y), saved at sim s) of the resume file at ``path``
    when it was written under ``key`` (None: whichever run's); None when there is none or it is
    another run's. ValueError naming the file when it cannot be read (a file that is not ours)."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as f:
            if key is not None and str(f["key"]) != key:
                return None
            logodds, resolution, origin = f["logodds"], float(f["resolution"]), f["origin"]
            stamp_s = float(f["stamp_s"])
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as exc:
        raise ValueError(f"{path}: not a mapper resume file: {exc}") from None
    if logodds.ndim != 2 or logodds.dtype != np.float32 or origin.shape != (2,):
        raise ValueError(f"{path}: not a mapper resume file: log-odds {logodds.dtype} {logodds.shape}, "
                         f"origin {origin.shape}")
    return logodds, resolution, (float(origin[0]), float(origin[1])), stamp_s


def map_from_resume(resume_file: str | Path, base: str | Path) -> Path | None:
    """map_server files ``base``.pgm/.yaml from the resume file (the last grid a mapper saved,
    whichever run's: the caller knows the file is its run's), where a mapper that died for good
    wrote no map; None when there is no resume file. The map saver's thresholds, as the
    mapper's own save. ValueError for a file that is not a resume file, OSError when the map
    cannot be written."""
    got = load_resume(resume_file, None)
    if got is None:
        return None
    logodds, resolution, origin, _ = got
    occupancy = np.where(np.isnan(logodds), -1, np.rint(percent(logodds))).astype(np.int8)
    return save_map(base, occupancy, resolution, origin)


def known_cells(known: np.ndarray, resolution: float, origin_xy) -> set:
    """The cells where ``known`` (bool (rows, cols)) is true, as (x, y) cell indices from the
    frame's origin: comparable between two grids of one resolution and different origins (a
    resumed map against the final one)."""
    rows, cols = np.nonzero(known)
    ox, oy = round(float(origin_xy[0]) / resolution), round(float(origin_xy[1]) / resolution)
    return set(zip((cols + ox).tolist(), (rows + oy).tolist()))


def percent(logodds: np.ndarray) -> np.ndarray:
    """Occupancy probability in percent (0-100, float) from log-odds; NaN (unknown) stays NaN."""
    with np.errstate(invalid="ignore", over="ignore"):
        return 100.0 / (1.0 + np.exp(-np.asarray(logodds, np.float64)))


def decided(logodds: np.ndarray) -> np.ndarray:
    """The cells a saved map_server map keeps as free or occupied (map_saver's thresholds; the
    ones in between it writes as unknown), from log-odds (NaN unknown)."""
    p = percent(logodds)
    with np.errstate(invalid="ignore"):
        return (p <= FREE_THRESH) | (p >= OCCUPIED_THRESH)
