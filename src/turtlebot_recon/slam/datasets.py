"""GTSAM's pose-graph data sets, fed to ``PoseGraph`` edge by edge: the reference checks and the
city10000 benchmark of the back end.

Files (shipped in the gtsam wheel's ``Data/`` folder, ``gtsam_data_dir()``):

- ``w100.graph``: 100 poses, 300 ``EDGE2`` lines (TORO/g2o 2-D, unit information), read by
  ``gtsam.load2D``; every edge runs from the newer pose to an older one.
- ``T1_city10000_04.txt``: 20,687 lines ``EDGE2 s 1 t 0 m  x y yaw [x y yaw ...]``: an edge
  from pose s to pose t (s < t) with m hypotheses of the delta, the first the true one (the
  others are the ambiguous alternatives of GTSAM's hybrid examples; ``gtsam.load2D`` refuses the
  format). t == s + 1 is odometry, anything else a loop closure. Its noise model is not in the
  file: GTSAM's ISAM2_City10000 example uses sigmas (1/30 m, 1/30 m, 1/100 rad) for every edge.
- ``ISAM2_GT_city10000.txt``: 10,000 lines ``x y yaw``, the ground-truth trajectory.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, List, Optional, Tuple

import gtsam
import numpy as np

from .graph import GraphSettings, PoseGraph

CITY10000_EDGES = "T1_city10000_04.txt"
CITY10000_REFERENCE = "ISAM2_GT_city10000.txt"
W100 = "w100.graph"
# GTSAM's ISAM2_City10000 example's pose noise (City10000.h: kPoseNoiseModel)
CITY10000_COVARIANCE = np.diag([(1 / 30) ** 2, (1 / 30) ** 2, (1 / 100) ** 2])

Edge = Tuple[int, int, np.ndarray, np.ndarray]   # (i, j, delta pose_i⁻¹ ∘ pose_j, 3x3 covariance)


def gtsam_data_dir() -> Path:
    """The folder of GTSAM's example data in the installed wheel."""
    return Path(gtsam.findExampleDataFile(W100)).parent


def read_city10000(path) -> List[Edge]:
    """The edges of a city10000 file in file order, first hypothesis each, with
    ``CITY10000_COVARIANCE``. A malformed line raises ValueError naming its number."""
    edges = []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            p = line.split()
            if not p:
                continue
            try:
                if p[0] != "EDGE2":
                    raise ValueError(f"unknown tag {p[0]!r}")
                s, t, m = int(p[1]), int(p[3]), int(p[5])
                if m < 1 or len(p) != 6 + 3 * m:
                    raise ValueError(f"{m} hypotheses but {len(p) - 6} numbers")
                delta = np.array([float(v) for v in p[6:9]])
            except (ValueError, IndexError) as exc:
                raise ValueError(f"{path}:{n}: not a city10000 edge ({exc}): {line.strip()!r}") from None
            edges.append((s, t, delta, CITY10000_COVARIANCE))
    return edges


def read_reference(path) -> np.ndarray:
    """A trajectory file of ``x y yaw`` lines as an (n, 3) array."""
    return np.loadtxt(path, ndmin=2)[:, :3]


def read_graph_edges(path) -> List[Edge]:
    """The between-factors of a 2-D pose-graph file that ``gtsam.load2D`` reads, in file order,
    each turned to run from the older (smaller) key to the newer one. Inverting an edge is exact:
    the error of the reversed factor is -Ad(delta) times the original's, so its covariance is
    Ad Σ Adᵀ (Ad: the adjoint of the original delta)."""
    graph, _ = gtsam.load2D(str(path))
    edges = []
    for idx in range(graph.size()):
        f = graph.at(idx)
        a, b = f.keys()
        delta, cov = f.measured(), f.noiseModel().covariance()
        if a > b:
            Ad = delta.AdjointMap()
            a, b, delta, cov = b, a, delta.inverse(), Ad @ cov @ Ad.T
        edges.append((int(a), int(b), np.array([delta.x(), delta.y(), delta.theta()]), cov))
    return edges


def feed_edges(graph: PoseGraph, edges: Iterable[Edge], loops: bool = True,
               limit: Optional[int] = None) -> List[float]:
    """Feed ``edges`` (i < j, in file order) to ``graph``, starting from keyframe 0: an edge to
    the next new key creates it (guess: pose i ∘ delta). With ``loops`` every other edge is a
    loop closure (robust kernel) and each edge gets its own update; without, every edge into a
    new key joins its keyframe's factors (Gaussian, one update per keyframe) and the rest are
    loop closures. ``limit`` stops after that many updates. Returns each update's time (ms)."""
    times: List[float] = []
    pending: List[Edge] = []   # edges into the next new key, without ``loops``

    def flush():
        i, _, delta, _ = pending[0]
        guess = gtsam.Pose2(*graph.pose(i)) * gtsam.Pose2(*delta)
        graph.add_keyframe((guess.x(), guess.y(), guess.theta()), [(i, d, c) for i, _, d, c in pending])
        pending.clear()
        times.append(graph.update())

    for i, j, delta, cov in edges:
        if limit is not None and len(times) >= limit:
            break
        if pending and j != pending[0][1]:
            flush()
        if j == len(graph):
            pending.append((i, j, delta, cov))
            if loops:
                flush()
        elif j < len(graph) and i < j:
            graph.add_loop(i, j, delta, cov)
            times.append(graph.update())
        else:
            raise ValueError(f"edge {i} -> {j}: keys must be older -> newer, and {j} at most the "
                             f"next new key ({len(graph)})")
    if pending and (limit is None or len(times) < limit):
        flush()
    return times


def run_city10000(data_dir=None, steps: Optional[int] = None,
                  settings: GraphSettings = GraphSettings()) -> dict:
    """The back end over city10000 edge by edge (one iSAM2 update per line, ``steps`` lines at
    most): per-step update times and the final estimate's largest position error against the
    ground truth. Returns ``city10000_ms_median``, ``_ms_p99``, ``_ms_max``, ``_max_error_m``,
    ``keyframes``, ``steps``, the loop statistics and ``times_ms`` (every step)."""
    folder = Path(data_dir) if data_dir is not None else gtsam_data_dir()
    edges = read_city10000(folder / CITY10000_EDGES)
    truth = read_reference(folder / CITY10000_REFERENCE)
    graph = PoseGraph(settings, first_pose=tuple(truth[0]))
    times = np.array(feed_edges(graph, edges, loops=True, limit=steps))
    est = graph.poses()
    err = np.hypot(*(est[:, :2] - truth[:len(est), :2]).T)
    stats = graph.loop_stats()
    return {"city10000_ms_median": float(np.median(times)),
            "city10000_ms_p99": float(np.percentile(times, 99)),
            "city10000_ms_max": float(times.max()),
            "city10000_max_error_m": float(err.max()),
            "keyframes": len(est), "steps": len(times),
            "loops_added": stats["added"], "loops_down_weighted": stats["down_weighted"],
            "times_ms": times.tolist()}
