"""Exploration benchmark (issue 5 item 8, `make bench-explore`): ROS-free aggregation of runs.

A run is one exploration (strategy, world, seed) with its report.json (DESIGN §6 keys) and its
coverage samples (coverage.csv). ``aggregate`` groups runs per (strategy, world); ``figures``
turns the groups into the flat ``output/bench/explore.json`` object; ``table`` prints them;
``plot_coverage_by_world`` and ``plot_time_bars`` draw the figures' pictures.

Conventions (the docstring of each function repeats the one it uses):
- **Never reached** a milestone (time_to_99_s null) counts as +inf, not as the budget: a
  median over seeds is finite only if more than half the seeds reached it (with an even count,
  both middle seeds), and "the best baseline" is the smallest finite median. JSON has no inf:
  a never-reached median is written null.
- **Failed runs** (crashed, wall-clock timeout, or no report) are never dropped silently:
  they count as coverage 0 and as never reaching any milestone (in time or in distance driven
  to it), and are counted per group; the whole run's distance, collisions, wall time and RTF
  are taken from the runs that finished (``ok``).
- **Ratios** a / b of two medians (e.g. recon's time to 99 % over the best baseline's):
  finite / finite is the number; inf / finite = inf (recon never got there, a baseline did:
  the target fails); finite / inf = 0 (only recon got there); inf / inf and 0 / 0 are
  undefined (nan). inf and nan are written null, with the ``*_never_worlds`` counts saying why.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..exploration.strategies import DEFAULT_STRATEGY
from ..exploration.strategies import STRATEGIES as _REGISTRY

STRATEGIES = tuple(_REGISTRY)   # the explorer's, in its order
REFERENCE = "oracle"    # the omniscient route (evaluation.oracle): never a baseline
MILESTONES_PCT = (90, 95, 99)

# Default budget rule (sim seconds): base + per-m² of the world's free area, at least min,
# rounded up to a whole minute. The house (111 m², finished in ~590 s with the burger) gets
# 1,200 s, the office (592 m²) 5,100 s, tb3_sandbox (20 m²) the 600 s minimum.
BUDGET_BASE_S = 300.0
BUDGET_PER_M2_S = 8.0
BUDGET_MIN_S = 600.0


def budget_s(free_area_m2: float, base_s: float = BUDGET_BASE_S, per_m2_s: float = BUDGET_PER_M2_S,
             min_s: float = BUDGET_MIN_S) -> float:
    """Sim seconds for a world of ``free_area_m2`` (m²): max(min_s, base_s + per_m2_s · area),
    rounded up to a multiple of 60 s."""
    if not (math.isfinite(free_area_m2) and free_area_m2 >= 0):
        raise ValueError(f"free_area_m2 must be a finite number >= 0, got {free_area_m2}")
    return 60.0 * math.ceil(max(min_s, base_s + per_m2_s * free_area_m2) / 60.0)


@dataclass(frozen=True)
class Run:
    """One run. ``status``: "ok" (the evaluator ended the run and wrote report.json), "failed"
    (crashed or no report) or "timeout" (killed after its wall-clock limit). ``report``: its
    report.json (possibly partial or empty when not ok); ``series``: (t_s, coverage) arrays."""
    strategy: str
    world: str
    seed: int
    status: str
    report: dict = field(default_factory=dict)
    series: tuple = (np.zeros(0), np.zeros(0))
    reason: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def time_to(self, pct: int) -> float:
        """Sim seconds to ``pct`` % coverage; +inf if never reached or the run failed."""
        t = self.report.get(f"time_to_{pct}_s") if self.ok else None
        return math.inf if t is None else float(t)

    def distance_to(self, pct: int) -> float:
        """Metres driven until ``pct`` % coverage (report key distance_to_<pct>_m); +inf if never
        reached, the run failed or the report has no such key."""
        d = self.report.get(f"distance_to_{pct}_m") if self.ok else None
        return math.inf if d is None else float(d)

    def coverage(self) -> float:
        """Final coverage (fraction); 0 for a failed run."""
        c = self.report.get("coverage_final") if self.ok else None
        return 0.0 if c is None else float(c)

    def value(self, key: str) -> float:
        """The report's number ``key`` (e.g. time_standing_s, goals); nan when the run failed or
        its report has no such key (a run from before the key is missing, not 0)."""
        v = self.report.get(key) if self.ok else None
        return math.nan if v is None else float(v)


def median(values) -> float:
    """Median of numbers that may be +inf (never reached); nan for none."""
    v = np.asarray(list(values), float)
    return float(np.median(v)) if v.size else math.nan


def ratio(a: float, b: float) -> float:
    """a / b of two medians with the module's never-reached rules: inf / finite = inf,
    finite / inf = 0, inf / inf = nan, x / 0 = inf for x > 0 and nan for x = 0, nan in = nan."""
    if math.isnan(a) or math.isnan(b) or (math.isinf(a) and math.isinf(b)):
        return math.nan
    if math.isinf(b):
        return 0.0
    if b == 0:
        return math.inf if a > 0 else math.nan
    return a / b


@dataclass(frozen=True)
class Group:
    """The runs of one (strategy, world), summarised over seeds (see the module docstring)."""
    strategy: str
    world: str
    runs: int
    failed: int
    time_s: dict                  # milestone % -> median sim seconds over seeds (inf: never)
    coverage_median: float        # fraction, failed runs as 0
    coverage_min: float
    distance_m: float             # whole run, median over ok runs (nan if none)
    distance99_m: float           # driven until 99 % coverage, median over seeds (inf: never)
    collisions_sum: int           # over ok runs
    collisions_max: int
    wall_s: float                 # median over ok runs
    rtf: float                    # median over ok runs
    standing_s: float = math.nan  # time standing (speed under 0.05 m/s), median over ok runs with the key
    goals: float = math.nan       # goals sent, median over ok runs with the key
    sim_s: float = math.nan       # sim seconds the run lasted, median over ok runs


def summarise(runs: list) -> Group:
    """One Group from the runs of a single (strategy, world)."""
    ok = [r for r in runs if r.ok]

    def ok_median(key):
        return median(v for v in (r.value(key) for r in ok) if not math.isnan(v))

    collisions = [int(r.report.get("collisions") or 0) for r in ok]
    cov = [r.coverage() for r in runs]
    return Group(strategy=runs[0].strategy, world=runs[0].world, runs=len(runs), failed=len(runs) - len(ok),
                 time_s={p: median(r.time_to(p) for r in runs) for p in MILESTONES_PCT},
                 coverage_median=median(cov), coverage_min=min(cov),
                 distance_m=ok_median("distance_m"), distance99_m=median(r.distance_to(99) for r in runs),
                 collisions_sum=sum(collisions),
                 collisions_max=max(collisions, default=0), wall_s=ok_median("wall_time_s"), rtf=ok_median("rtf"),
                 standing_s=ok_median("time_standing_s"), goals=ok_median("goals"), sim_s=ok_median("sim_time_s"))


def aggregate(runs: list) -> dict:
    """{(strategy, world): Group}, in the order the pairs first appear in ``runs``."""
    by_key: dict = {}
    for r in runs:
        by_key.setdefault((r.strategy, r.world), []).append(r)
    return {k: summarise(v) for k, v in by_key.items()}


def versus_best_baseline(groups: dict, world: str, value, default: str = DEFAULT_STRATEGY) -> float:
    """ratio(value(default's group), min of value(g) over the baselines' groups in ``world``
    (every strategy but ``default``, DEFAULT_STRATEGY and REFERENCE) — smaller is better for
    the default. nan when either side has no group."""
    mine = groups.get((default, world))
    others = [value(g) for (s, w), g in groups.items()
              if w == world and s not in (default, DEFAULT_STRATEGY, REFERENCE)]
    others = [v for v in others if not math.isnan(v)]
    if mine is None or not others:
        return math.nan
    return ratio(value(mine), min(others))


def has_baseline(groups: dict, world: str, default: str = DEFAULT_STRATEGY) -> bool:
    """Whether a baseline (any strategy but ``default``, DEFAULT_STRATEGY and REFERENCE) ran in ``world``."""
    return any(w == world and s not in (default, DEFAULT_STRATEGY, REFERENCE) for s, w in groups)


def with_baselines(groups: dict, baselines: dict, default: str = DEFAULT_STRATEGY) -> dict:
    """``groups`` plus, for each of its worlds where no baseline ran, the groups of ``baselines``
    ({(strategy, world): Group}, e.g. a committed sweep's: ``sweep_groups``) in that world."""
    worlds = {w for _, w in groups}
    missing = {w for w in worlds if not has_baseline(groups, w, default)}
    return {**groups, **{k: g for k, g in baselines.items() if k[1] in missing and k not in groups}}


def sweep_groups(data: dict, strategies=STRATEGIES, default: str = DEFAULT_STRATEGY) -> dict:
    """{(strategy, world): Group} of the baselines in a sweep's explore.json object ``data``
    (``figures``' per-group keys; a null time or distance is "never"), for comparing with them."""
    def number(key, never=math.inf):
        v = data.get(key)
        return never if v is None else float(v)

    out = {}
    for s in strategies:
        if s in (default, DEFAULT_STRATEGY, REFERENCE):
            continue
        head = f"time99_s_{s}_"
        for key in data:
            if not key.startswith(head):
                continue
            w = key[len(head):]
            out[(s, w)] = Group(
                strategy=s, world=w, runs=int(number(f"runs_{s}_{w}", 0)),
                failed=int(number(f"failed_runs_{s}_{w}", 0)),
                time_s={p: number(f"time{p}_s_{s}_{w}") for p in MILESTONES_PCT},
                coverage_median=number(f"coverage_final_{s}_{w}", math.nan),
                coverage_min=number(f"coverage_min_{s}_{w}", math.nan),
                distance_m=number(f"distance_m_{s}_{w}", math.nan), distance99_m=number(f"distance99_m_{s}_{w}"),
                collisions_sum=int(number(f"collisions_{s}_{w}", 0)), collisions_max=0,
                wall_s=math.nan, rtf=number(f"rtf_{s}_{w}", math.nan))
    return out


def worst(ratios) -> float:
    """The worst (largest) of per-world ratios: inf if any is inf, nan if none is defined
    (undefined worlds are skipped; the *_never_worlds counts report them)."""
    v = [r for r in ratios if not math.isnan(r)]
    return max(v) if v else math.nan


def _json(v):
    """A JSON figure: inf and nan -> None (null)."""
    return None if isinstance(v, float) and not math.isfinite(v) else v


def headline(groups: dict, runs: list, worlds: list, default: str = DEFAULT_STRATEGY, prefix: str = "") -> dict:
    """The figures that hold targets, over the runs and groups of ``worlds`` only, each key
    with ``prefix`` (``figures`` uses "" for the tuning worlds, "heldout_" for the held-out ones).

    default_runs, default_failed_runs; default_min_coverage (min final coverage of the
    default's runs, failed = 0); default_collisions (total over its ok runs);
    full_stack_rtf_lidar (median RTF of its ok runs with the map in odom: no SLAM) and
    full_stack_rtf_slam (the same over its runs with SLAM, the map in map; each key only where
    such runs are); default_time{99,95}_ratio_vs_best_baseline
    (per world: the default's median time to the milestone / the best other strategy's, then the
    worst world) with default_time{99,95}_never_worlds (worlds where the default's median never
    got there); default_distance99_ratio_vs_best_baseline (the same for the distance driven
    until 99 %: a strategy that stops early or drives on after 99 % is measured at the same
    point as the others) and default_distance99_ratio_vs_best_baseline_max (the same figure
    under the issue's name); default_time99_ratio_vs_oracle_max (per world where both the
    default and the REFERENCE ran: the default's median time to 99 % / the oracle's, then the
    worst world; absent when the oracle ran in none) and default_time99_ratio_vs_oracle_mean
    (their mean over the worlds where it is defined; inf if any is);
    default_standing_ratio_vs_oracle_max (the same for the median time standing,
    time_standing_s; worlds where either side's runs lack the key are skipped).
    """
    chosen = set(worlds)
    mine = [r for r in runs if r.strategy == default and r.world in chosen]
    out = {"default_runs": len(mine), "default_failed_runs": sum(not r.ok for r in mine),
           "default_min_coverage": min((r.coverage() for r in mine), default=math.nan),
           "default_collisions": sum(int(r.report.get("collisions") or 0) for r in mine if r.ok)}
    for key, slam in (("full_stack_rtf_lidar", False), ("full_stack_rtf_slam", True)):
        rtf = [float(r.report["rtf"]) for r in mine
               if r.ok and r.report.get("rtf") and (r.report.get("map_frame") == "map") == slam]
        if rtf:
            out[key] = median(rtf)
    for pct in (99, 95):
        out[f"default_time{pct}_ratio_vs_best_baseline"] = worst(
            versus_best_baseline(groups, w, lambda g: g.time_s[pct], default) for w in worlds)
        out[f"default_time{pct}_never_worlds"] = sum(
            math.isinf(groups[(default, w)].time_s[pct]) for w in worlds if (default, w) in groups)
    distance = worst(versus_best_baseline(groups, w, lambda g: g.distance99_m, default) for w in worlds)
    out["default_distance99_ratio_vs_best_baseline"] = distance
    out["default_distance99_ratio_vs_best_baseline_max"] = distance
    versus_oracle = [ratio(groups[(default, w)].time_s[99], groups[(REFERENCE, w)].time_s[99])
                     for w in worlds if (default, w) in groups and (REFERENCE, w) in groups]
    if versus_oracle:
        out[f"default_time99_ratio_vs_{REFERENCE}_max"] = worst(versus_oracle)
        defined = [v for v in versus_oracle if not math.isnan(v)]
        out[f"default_time99_ratio_vs_{REFERENCE}_mean"] = float(np.mean(defined)) if defined else math.nan
        out[f"default_standing_ratio_vs_{REFERENCE}_max"] = worst(
            ratio(groups[(default, w)].standing_s, groups[(REFERENCE, w)].standing_s)
            for w in worlds if (default, w) in groups and (REFERENCE, w) in groups)
    return {prefix + k: v for k, v in out.items()}


def figures(groups: dict, runs: list, default: str = DEFAULT_STRATEGY, held_out=(), baselines=None) -> dict:
    """The flat explore.json object (without machine and commit); see the module docstring.

    The worlds of ``held_out`` are the check that the tuning did not overfit: the ``headline``
    figures are computed over the other worlds (the tuning set, listed in tuning_worlds) and
    again over the held-out ones with the prefix "heldout_" (listed in heldout_worlds; those
    keys only when a held-out world ran). runs and failed_runs count every run.

    ``baselines`` ({(strategy, world): Group}, a committed sweep's ``sweep_groups``) stand in for
    the baselines of the worlds where none ran in this sweep, in every *_vs_best_baseline figure
    (listed in baseline_worlds_committed); the per-group keys are this sweep's own.

    Per world: time{99,95}_ratio_vs_best_baseline_<w>, distance99_ratio_vs_best_baseline_<w>;
    where the REFERENCE (oracle) ran, oracle_time99_ratio_vs_best_baseline_<w> (what the
    omniscient route reaches against the baselines), default_time99_ratio_vs_oracle_<w> and
    default_standing_ratio_vs_oracle_<w>; goals_median_<w> (the default's goals sent, median).
    Per strategy and world: time90_s_, time95_s_, time99_s_ (median; null = never),
    coverage_final_ (median), coverage_min_, distance_m_ (whole run), distance99_m_ (null =
    never), collisions_, time_standing_s_, goals_, sim_time_s_, rtf_ (medians over ok runs;
    null where no run has the key), runs_, failed_runs_<strategy>_<world>.
    """
    own = groups
    groups = with_baselines(own, baselines or {}, default)
    worlds = list(dict.fromkeys(w for _, w in own))
    held = [w for w in worlds if w in set(held_out)]
    tuning = [w for w in worlds if w not in set(held_out)]
    out = {"runs": len(runs), "failed_runs": sum(not r.ok for r in runs), "tuning_worlds": tuning,
           "baseline_worlds_committed": [w for w in worlds if not has_baseline(own, w, default)
                                         and has_baseline(groups, w, default)]}
    out.update(headline(groups, runs, tuning, default))
    if held:
        out["heldout_worlds"] = held
        out.update(headline(groups, runs, held, default, "heldout_"))
    for pct in (99, 95):
        out.update({f"time{pct}_ratio_vs_best_baseline_{w}":
                    versus_best_baseline(groups, w, lambda g: g.time_s[pct], default) for w in worlds})
    out.update({f"distance99_ratio_vs_best_baseline_{w}":
                versus_best_baseline(groups, w, lambda g: g.distance99_m, default) for w in worlds})
    for w in worlds:            # the omniscient reference: the headroom of any goal selection
        if (REFERENCE, w) in groups:
            out[f"{REFERENCE}_time99_ratio_vs_best_baseline_{w}"] = versus_best_baseline(
                groups, w, lambda g: g.time_s[99], REFERENCE)
            if (default, w) in groups:
                out[f"default_time99_ratio_vs_{REFERENCE}_{w}"] = ratio(
                    groups[(default, w)].time_s[99], groups[(REFERENCE, w)].time_s[99])
                out[f"default_standing_ratio_vs_{REFERENCE}_{w}"] = ratio(
                    groups[(default, w)].standing_s, groups[(REFERENCE, w)].standing_s)
        if (default, w) in groups:
            out[f"goals_median_{w}"] = groups[(default, w)].goals
    for (s, w), g in own.items():
        for pct in MILESTONES_PCT:
            out[f"time{pct}_s_{s}_{w}"] = g.time_s[pct]
        out.update({f"coverage_final_{s}_{w}": g.coverage_median, f"coverage_min_{s}_{w}": g.coverage_min,
                    f"distance_m_{s}_{w}": g.distance_m, f"distance99_m_{s}_{w}": g.distance99_m,
                    f"collisions_{s}_{w}": g.collisions_sum, f"time_standing_s_{s}_{w}": g.standing_s,
                    f"goals_{s}_{w}": g.goals, f"sim_time_s_{s}_{w}": g.sim_s, f"rtf_{s}_{w}": g.rtf,
                    f"runs_{s}_{w}": g.runs, f"failed_runs_{s}_{w}": g.failed})
    return {k: _json(v) for k, v in out.items()}


# ---------------------------------------------------------------------------------- table
COLUMNS = ("world", "strategy", "ok/runs", "cov med %", "cov min %", "t90 s", "t95 s", "t99 s",
           "dist m", "dist99 m", "coll sum/max", "wall s", "rtf")


def fmt_time(t: float) -> str:
    """Seconds as a table cell: 'never' for inf, '-' for nan (no runs)."""
    return "never" if math.isinf(t) else "-" if math.isnan(t) else f"{t:.0f}"


def _num(v: float, spec: str) -> str:
    return "-" if math.isnan(v) else format(v, spec)


def table_rows(groups: dict) -> list:
    """One list of cells (str) per group, sorted by world then strategy as given."""
    order = {w: k for k, w in enumerate(dict.fromkeys(w for _, w in groups))}
    rows = []
    for g in sorted(groups.values(), key=lambda g: order[g.world]):     # stable: strategies keep their order
        rows.append([g.world, g.strategy, f"{g.runs - g.failed}/{g.runs}", _num(100 * g.coverage_median, ".1f"),
                     _num(100 * g.coverage_min, ".1f"), *(fmt_time(g.time_s[p]) for p in MILESTONES_PCT),
                     _num(g.distance_m, ".1f"), "never" if math.isinf(g.distance99_m) else _num(g.distance99_m, ".1f"),
                     f"{g.collisions_sum}/{g.collisions_max}", _num(g.wall_s, ".0f"),
                     _num(g.rtf, ".1f")])
    return rows


def table(groups: dict) -> str:
    """A fixed-width text table of the groups (medians over seeds; 'never' = not reached)."""
    rows = [list(COLUMNS)] + table_rows(groups)
    widths = [max(len(r[i]) for r in rows) for i in range(len(COLUMNS))]
    lines = ["  ".join(c.ljust(w) if i < 2 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths)))
             for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


# ---------------------------------------------------------------------------------- plots
def median_series(series: list, grid: np.ndarray) -> np.ndarray:
    """Median coverage over runs on ``grid`` (s): each run's samples held at their last value
    after its end (a run that finished early keeps its final coverage), 0 before its first."""
    if not series:
        return np.full(grid.shape, np.nan)
    held = [np.interp(grid, t, c, left=0.0, right=c[-1]) if len(t) else np.zeros(grid.shape) for t, c in series]
    return np.median(np.vstack(held), axis=0)


def plot_coverage_by_world(path_png, world: str, runs: list, strategies: list):
    """Coverage (%) vs sim time (s) in ``world``: one colour per strategy, each seed a thin
    line, the median over seeds thick."""
    from .report import _figure, _save
    fig = _figure(900, 500)
    ax = fig.add_subplot()
    colours = dict(zip(strategies, [f"C{k}" for k in range(len(strategies))]))
    for s in strategies:
        mine = [r.series for r in runs if r.world == world and r.strategy == s and len(r.series[0])]
        if not mine:
            continue
        for t, c in mine:
            ax.plot(t, 100 * np.asarray(c), color=colours[s], lw=0.6, alpha=0.35)
        grid = np.linspace(0.0, max(float(t[-1]) for t, _ in mine), 400)
        ax.plot(grid, 100 * median_series(mine, grid), color=colours[s], lw=2.0, label=s)
    for m in MILESTONES_PCT:
        ax.axhline(m, color="grey", lw=0.6, ls="--")
    ax.set_xlabel("sim time (s)")
    ax.set_ylabel("coverage of reachable free space (%)")
    ax.set_ylim(0, 101)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower right", fontsize=8)
    ax.set_title(f"{world}: coverage vs sim time (thin: seeds, thick: median)")
    fig.tight_layout()
    return _save(fig, path_png)


def bar_value(g: Group) -> tuple:
    """(seconds, milestone %) drawn for a group: median time to 99 %, else to 95 % (marked),
    else (nan, None) for never."""
    for pct in (99, 95):
        if math.isfinite(g.time_s[pct]):
            return g.time_s[pct], pct
    return math.nan, None


def plot_time_bars(path_png, groups: dict, worlds: list, strategies: list):
    """Grouped bars per world, one per strategy: median time to 99 %; hatched and labelled
    '95' where 99 % was never reached (time to 95 % instead); 'never' where neither was."""
    from .report import _figure, _save
    fig = _figure(max(900, 160 * len(worlds)), 500)
    ax = fig.add_subplot()
    width = 0.8 / max(1, len(strategies))
    labelled = set()
    for k, s in enumerate(strategies):
        for i, w in enumerate(worlds):
            g = groups.get((s, w))
            if g is None:
                continue
            x = i - 0.4 + (k + 0.5) * width
            t, pct = bar_value(g)
            ax.bar(x, 0.0 if pct is None else t, width, color=f"C{k}", hatch="//" if pct == 95 else None,
                   edgecolor="black", lw=0.4, label=None if s in labelled else s)
            labelled.add(s)
            if pct is None:
                ax.text(x, 0, "never", rotation=90, ha="center", va="bottom", fontsize=7, color=f"C{k}")
            elif pct == 95:
                ax.text(x, t, "95", ha="center", va="bottom", fontsize=7)
    if labelled:
        ax.legend(fontsize=8)
    ax.set_xlim(-0.5, len(worlds) - 0.5)
    ax.set_xticks(range(len(worlds)))
    ax.set_xticklabels(worlds)
    ax.set_ylabel("median sim time to 99 % (s)")
    ax.set_title("time to 99 % coverage (hatched '95': 99 % never reached, time to 95 % shown)")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return _save(fig, path_png)
