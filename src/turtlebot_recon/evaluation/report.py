"""Run output (DESIGN §6, issue 5 item 6): report.json / report.md and the coverage and map
plots. Plots are drawn on matplotlib's Agg canvas (headless).

report.json is written last and atomically (``write_report``), so a run directory is complete
once report.json exists: whoever watches for it never reads a part of it, nor misses a file
written with it."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..files import write_atomic
from ..mapping.map_io import FREE_THRESH, OCCUPIED_THRESH

# DESIGN §6 keys of report.json, in order: key -> (what report.md calls it, unit shown there).
# Fractions (unit "%") stay fractions in report.json; report.md shows them in per cent.
REPORT_KEYS = {
    "world": ("world", ""),
    "robot": ("robot", ""),
    "strategy": ("goal strategy", ""),
    "seed": ("seed", ""),
    "coverage_final": ("coverage of reachable free space, final", "%"),
    "time_to_90_s": ("sim time to 90 % coverage", "s"),
    "time_to_95_s": ("sim time to 95 % coverage", "s"),
    "time_to_99_s": ("sim time to 99 % coverage", "s"),
    "map_precision_occupied": ("map precision, occupied cells", "%"),
    "map_precision_free": ("map precision, free cells", "%"),
    "ate_m": ("absolute trajectory error (RMSE)", "m"),
    "tags_placed": ("tags placed in the world", ""),
    "tags_confirmed": ("tags confirmed", ""),
    "tag_recall": ("tag recall", "%"),
    "tag_error_median_m": ("tag position error, median", "m"),
    "tag_error_max_m": ("tag position error, max", "m"),
    "false_tags": ("false tags", ""),
    "distance_m": ("distance driven", "m"),
    "collisions": ("collisions", ""),
    "sim_time_s": ("sim time", "s"),
    "wall_time_s": ("wall-clock time", "s"),
    "rtf": ("real-time factor", "×"),
    "finished_reason": ("finished because", ""),
}
PERCENT_KEYS = {k for k, (_, unit) in REPORT_KEYS.items() if unit == "%"}
MILESTONES_PCT = (90, 95, 99)
DPI = 100


def _plain(value):
    """A JSON-safe value: numpy scalars and arrays to Python, non-finite floats to None."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def full_report(report: dict) -> dict:
    """Every DESIGN §6 key in order (missing ones None), then the extra keys as given."""
    out = {k: _plain(report.get(k)) for k in REPORT_KEYS}
    out.update({str(k): _plain(v) for k, v in report.items() if k not in REPORT_KEYS})
    return out


def _cell(key: str, value) -> str:
    return _format(key, value).replace("|", "\\|")   # a "|" would end the table cell


def _format(key: str, value) -> str:
    if value is None:
        return "—"
    if key in PERCENT_KEYS and isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"{100.0 * value:.2f}"
    if isinstance(value, float):
        return f"{value:.1f}" if key.endswith("_s") or abs(value) >= 1000 else f"{value:.3f}"
    if isinstance(value, (list, dict)):
        return json.dumps(value)
    return str(value)


def markdown(report: dict) -> str:
    """report.md's text: a table of the DESIGN §6 metrics with units, then any extra keys."""
    r = full_report(report)
    title = " · ".join(str(r[k]) for k in ("world", "robot", "strategy") if r[k] is not None)
    lines = [f"# Run report{': ' + title if title else ''}", "",
             "| metric | value | unit | report.json key |", "|---|---:|---|---|"]
    lines += [f"| {label} | {_cell(k, r[k])} | {unit} | `{k}` |"
              for k, (label, unit) in REPORT_KEYS.items()]
    extra = [k for k in r if k not in REPORT_KEYS]
    if extra:
        lines += ["", "## Other", "", "| key | value |", "|---|---:|"]
        lines += [f"| {k} | {_cell(k, r[k])} |" for k in extra]
    lines += ["", "Fractions are shown in %; — = not measured (null in report.json).", ""]
    return "\n".join(lines)


def write_report(out_dir: str | Path, report: dict) -> tuple:
    """Write ``out_dir``/report.md, then ``out_dir``/report.json (DESIGN §6 keys, missing ones
    null, extra keys kept) atomically (``write_atomic``), so report.json appears whole and after
    report.md; return their paths. Write every other file of the run before calling this."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    json_path, md_path = out_dir / "report.json", out_dir / "report.md"
    text = json.dumps(full_report(report), indent=2, allow_nan=False) + "\n"   # fails before any write
    md_path.write_text(markdown(report))
    write_atomic(json_path, text)
    return json_path, md_path


def _figure(width_px: int, height_px: int):
    # A bare Figure on an Agg canvas, not pyplot: no global backend switch, no figure registry,
    # nothing left open after saving (and matplotlib is imported only when plotting).
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(width_px / DPI, height_px / DPI), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path_png) -> Path:
    path = Path(path_png)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)      # no bbox_inches="tight": the size stays as made
    return path


COVERAGE_SIZE_PX = (800, 450)


def plot_coverage(path_png: str | Path, series, title: str = "") -> Path:
    """Coverage (%) vs sim time (s), with 90 / 95 / 99 % guides and the time each was reached.
    ``series``: a CoverageTracker or a (t_s, fraction) pair of arrays. 800 x 450 px PNG."""
    t, frac = series.series if hasattr(series, "series") else series
    t, pct = np.asarray(t, float), 100.0 * np.asarray(frac, float)
    fig = _figure(*COVERAGE_SIZE_PX)
    ax = fig.add_subplot()
    ax.plot(t, pct, color="tab:blue", lw=1.8, label="coverage")
    for m, colour in zip(MILESTONES_PCT, ("tab:orange", "tab:red", "tab:purple")):
        hit = np.flatnonzero(pct >= m)
        label = f"{m} % at {t[hit[0]]:.1f} s" if hit.size else f"{m} % not reached"
        ax.axhline(m, color=colour, lw=0.8, ls="--", label=label)
        if hit.size:
            ax.axvline(t[hit[0]], color=colour, lw=0.8, ls=":")
    ax.set_xlabel("sim time (s)")
    ax.set_ylabel("coverage of reachable free space (%)")
    ax.set_ylim(0, 101)
    ax.set_xlim(0, max(float(t.max()) if t.size else 1.0, 1e-9))
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8, framealpha=0.9)
    ax.set_title(title)
    fig.tight_layout()
    return _save(fig, path_png)


MAP_LONG_SIDE_PX = 900            # the map's longer side
MAP_MARGIN_PX = (150, 120)        # room for axes, labels and the title (width, height)


def map_figure_size_px(shape: tuple) -> tuple:
    """(width, height) of plot_map's PNG for a (rows, cols) map: the longer side of the map
    900 px, the other in proportion (rounded), plus 150 x 120 px of margins."""
    rows, cols = shape
    scale = MAP_LONG_SIDE_PX / max(rows, cols, 1)
    return (int(round(cols * scale)) + MAP_MARGIN_PX[0], int(round(rows * scale)) + MAP_MARGIN_PX[1])


def map_image(occupancy: np.ndarray) -> np.ndarray:
    """RGB floats of a ROS occupancy grid: free (0..25) white, occupied (>= 65) black, unknown
    grey, values in between shaded by their probability."""
    v = occupancy.astype(float)
    grey = np.clip(1.0 - v / 100.0, 0.0, 1.0)
    grey[(occupancy >= 0) & (occupancy <= FREE_THRESH)] = 1.0
    grey[occupancy >= OCCUPIED_THRESH] = 0.0
    grey[occupancy < 0] = 0.62
    return np.repeat(grey[..., None], 3, axis=2)


def _tag_fields(tag) -> tuple:
    """(family, id, x, y, z) of a tag given as a mapping or an object with family/id/x/y/z
    (family and z optional), or a tuple: (family, id, x, y, z), (family, id, x, y) or
    (id, x, y). A missing family or z is None."""
    if isinstance(tag, dict):
        z = tag.get("z")
        return (tag.get("family"), tag.get("id"), float(tag["x"]), float(tag["y"]),
                None if z is None else float(z))
    if hasattr(tag, "x"):
        z = getattr(tag, "z", None)
        return (getattr(tag, "family", None), getattr(tag, "id", None), float(tag.x), float(tag.y),
                None if z is None else float(z))
    if len(tag) == 3:
        return None, tag[0], float(tag[1]), float(tag[2]), None
    z = tag[4] if len(tag) > 4 else None
    return tag[0], tag[1], float(tag[2]), float(tag[3]), None if z is None else float(z)


def match_tags(true_tags, estimated) -> list:
    """For each estimate (in order) the index in ``true_tags`` of the true tag it matches, or
    None for a false tag (``metrics.match_tags``, as ``tag_metrics`` counts them). Tags as
    plot_map takes them; a tag without a family matches only one without."""
    from .metrics import match_tags as match
    return [k for k, _ in match([_tag_fields(t) for t in true_tags], [_tag_fields(t) for t in estimated])]


# plot_map's tags: true tags hollow, estimates filled, false tags red; the legend's labels
# (each followed by its count, but the error lines'); how far the axes reach beyond a tag that
# lies off the robot's map (m).
TRUE_TAG_COLOUR, ESTIMATE_COLOUR, FALSE_TAG_COLOUR = "tab:purple", "tab:cyan", "red"
TAG_LABELS = {"true": "true tags", "estimated": "estimated tags", "error": "tag error (estimate to true)",
              "false": "false tags"}
TAG_MARGIN_M = 0.4


def _annotate(ax, fields, colour, offset) -> None:
    for _, tag_id, x, y, _ in fields:
        ax.annotate(f"tag {tag_id}", (x, y), xytext=offset, textcoords="offset points", fontsize=7,
                    color=colour)


def _plot_tags(ax, tags, true_tags) -> None:
    """Tags on plot_map's axes: the true tags as hollow diamonds with their ids, the estimates
    as filled circles, each joined by a thin line to the true tag it matches; with ``true_tags``
    given (even empty), an estimate that matches none (a false tag) is a red cross with its id;
    without, the estimates are not judged and carry their ids."""
    est = [_tag_fields(t) for t in tags or ()]
    if true_tags is None:
        match = None
    else:
        truth = [_tag_fields(t) for t in true_tags]
        match = match_tags(true_tags, tags or ())
        if truth:
            ax.plot([t[2] for t in truth], [t[3] for t in truth], marker="D", ms=9, mfc="none",
                    mec=TRUE_TAG_COLOUR, mew=1.6, ls="", zorder=4,
                    label=f"{TAG_LABELS['true']} ({len(truth)})")
            _annotate(ax, truth, TRUE_TAG_COLOUR, (5, -10))
        pairs = [(e, truth[k]) for e, k in zip(est, match) if k is not None]
        if pairs:   # one artist, the segments separated by NaN
            seg = np.array([[e[2:4], t[2:4], (np.nan, np.nan)] for e, t in pairs], float).reshape(-1, 2)
            ax.plot(seg[:, 0], seg[:, 1], color=ESTIMATE_COLOUR, lw=0.8, zorder=5, label=TAG_LABELS["error"])
    good = est if match is None else [e for e, k in zip(est, match) if k is not None]
    false = [] if match is None else [e for e, k in zip(est, match) if k is None]
    if good:
        ax.plot([e[2] for e in good], [e[3] for e in good], marker="o", ms=5, color=ESTIMATE_COLOUR,
                mec="black", mew=0.5, ls="", zorder=6,
                label=f"{TAG_LABELS['estimated']} ({len(good)}{'' if match is None else ' matched'})")
        if match is None:
            _annotate(ax, good, ESTIMATE_COLOUR, (4, -9))
    if false:
        ax.plot([e[2] for e in false], [e[3] for e in false], marker="X", ms=8, color=FALSE_TAG_COLOUR,
                mec="black", mew=0.5, ls="", zorder=6, label=f"{TAG_LABELS['false']} ({len(false)})")
        _annotate(ax, false, FALSE_TAG_COLOUR, (5, 4))


def plot_map(path_png: str | Path, occupancy: np.ndarray, resolution: float, origin_xy: tuple,
             path_xy=None, goals_xy=None, tags=None, title: str = "", true_tags=None) -> Path:
    """The robot's map (free white, occupied black, unknown grey; row 0 at ``origin_xy``) with
    the driven path (line, start and end marked), the visited goals (numbered markers) and the
    tags drawn on it. ``tags``: the estimated (confirmed) tags, filled circles; ``true_tags``:
    the world's tags, hollow diamonds; with both, each estimate is joined to the true tag it
    matches (``match_tags``: marker set, id and within metrics.FALSE_TAG_M) and the false ones
    are red crosses. Tags as ``_tag_fields`` reads them, e.g. (family, id, x, y, z) or (id, x, y);
    the axes grow to show those off the map (unknown grey there). Everything in the map frame,
    axes in metres, equal aspect. PNG of ``map_figure_size_px(occupancy.shape)``."""
    rows, cols = occupancy.shape
    x0, y0 = float(origin_xy[0]), float(origin_xy[1])
    extent = (x0, x0 + cols * resolution, y0, y0 + rows * resolution)
    fig = _figure(*map_figure_size_px(occupancy.shape))
    ax = fig.add_subplot()
    ax.imshow(map_image(occupancy), origin="lower", extent=extent, interpolation="nearest")
    if path_xy is not None and len(path_xy):
        p = np.asarray(path_xy, float).reshape(-1, 2)
        ax.plot(p[:, 0], p[:, 1], color="tab:blue", lw=1.2, label="driven path")
        ax.plot(*p[0], marker="o", color="tab:green", ms=7, ls="", label="start")
        ax.plot(*p[-1], marker="s", color="tab:red", ms=6, ls="", label="end")
    if goals_xy is not None and len(goals_xy):
        g = np.asarray(goals_xy, float).reshape(-1, 2)
        ax.plot(g[:, 0], g[:, 1], marker="x", color="tab:orange", ms=7, mew=2, ls="",
                label="goals")
        for k, (gx, gy) in enumerate(g, 1):
            ax.annotate(str(k), (gx, gy), xytext=(3, 3), textcoords="offset points",
                        fontsize=7, color="tab:orange")
    if tags or true_tags is not None:
        _plot_tags(ax, tags, true_tags)
        # Tags off the robot's map (not explored yet, or false) stay in view, on unknown grey.
        xy = [_tag_fields(t)[2:4] for t in [*(tags or ()), *(true_tags or ())]]
        if xy:
            (lo_x, lo_y), (hi_x, hi_y) = np.min(xy, axis=0) - TAG_MARGIN_M, np.max(xy, axis=0) + TAG_MARGIN_M
            extent = (min(extent[0], lo_x), max(extent[1], hi_x), min(extent[2], lo_y), max(extent[3], hi_y))
            ax.set_facecolor((0.62, 0.62, 0.62))
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, map frame)")
    ax.set_ylabel("y (m, map frame)")
    ax.set_title(title)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8, framealpha=0.8)
    fig.tight_layout()
    return _save(fig, path_png)
