"""Exploration benchmark aggregation (turtlebot_recon.evaluation.benchmark): medians over seeds,
never-reached and failed runs, ratios against the best baseline, explore.json keys, the table."""
import json
import math

import numpy as np
import pytest

from turtlebot_recon.evaluation import benchmark as bm

INF, NAN = math.inf, math.nan


def run(strategy="recon", world="house", seed=0, status="ok", t90=100.0, t95=200.0, t99=None, cov=0.96,
        dist=50.0, coll=0, wall=60.0, rtf=10.0, series=None, dist99=None):
    """dist99 (distance to 99 %): dist - 10 m by default where 99 % is reached, else null."""
    if dist99 is None and t99 is not None:
        dist99 = dist - 10.0
    report = {"coverage_final": cov, "time_to_90_s": t90, "time_to_95_s": t95, "time_to_99_s": t99,
              "distance_m": dist, "distance_to_99_m": dist99, "collisions": coll, "wall_time_s": wall,
              "rtf": rtf}
    t = np.array([0.0, 100.0, 200.0]) if series is None else series[0]
    c = np.array([0.0, 0.9, cov]) if series is None else series[1]
    return bm.Run(strategy, world, seed, status, report, (t, c))


def test_budget_rule():
    # house: 300 + 8 * 111.27 = 1190.2 -> 1200; office: 300 + 8 * 592.1 = 5036.8 -> 5040;
    # tb3_sandbox: 300 + 8 * 19.76 = 458 < 600 -> 600
    assert bm.budget_s(111.27) == 1200.0
    assert bm.budget_s(592.1) == 5040.0
    assert bm.budget_s(19.76) == 600.0
    assert bm.budget_s(100.0, base_s=0.0, per_m2_s=1.0, min_s=0.0) == 120.0   # 100 -> next whole minute
    with pytest.raises(ValueError):
        bm.budget_s(-1.0)


def test_median_with_never():
    assert bm.median([300.0, 100.0, 200.0]) == 200.0
    assert bm.median([100.0, INF, 200.0]) == 200.0          # one never of three: still reached
    assert bm.median([100.0, INF, INF]) == INF              # most never: never
    assert bm.median([100.0, 300.0]) == 200.0
    assert bm.median([100.0, INF]) == INF                   # even count: both middles must be finite
    assert math.isnan(bm.median([]))


@pytest.mark.parametrize("a, b, expected", [
    (70.0, 100.0, 0.7), (INF, 100.0, INF), (70.0, INF, 0.0), (INF, INF, NAN),
    (5.0, 0.0, INF), (0.0, 0.0, NAN), (NAN, 1.0, NAN), (1.0, NAN, NAN)])
def test_ratio_rules(a, b, expected):
    got = bm.ratio(a, b)
    assert (math.isnan(got) and math.isnan(expected)) or got == pytest.approx(expected)


def test_failed_runs_count_as_zero_coverage_and_never():
    ok = run(seed=0, t90=100.0, cov=0.96)
    crashed = run(seed=1, status="failed", t90=50.0, cov=0.99)       # its partial report is not trusted
    timeout = run(seed=2, status="timeout", t90=60.0, cov=0.98, coll=7)
    assert crashed.time_to(90) == INF and crashed.coverage() == 0.0
    g = bm.summarise([ok, crashed, timeout])
    assert (g.runs, g.failed) == (3, 2)
    assert g.time_s[90] == INF                 # [100, inf, inf] -> inf
    assert g.coverage_median == 0.0 and g.coverage_min == 0.0
    assert g.collisions_sum == 0               # collisions, distance, wall, rtf: ok runs only
    assert g.distance_m == 50.0 and g.rtf == 10.0


def test_summarise_medians_and_collisions():
    runs = [run(seed=0, t95=200.0, t99=400.0, cov=0.99, dist=40.0, coll=0, rtf=8.0),
            run(seed=1, t95=300.0, t99=None, cov=0.97, dist=60.0, coll=2, rtf=12.0),
            run(seed=2, t95=250.0, t99=500.0, cov=0.995, dist=50.0, coll=1, rtf=10.0)]
    g = bm.summarise(runs)
    assert g.time_s == {90: 100.0, 95: 250.0, 99: 500.0}     # t99: [400, inf, 500] -> 500
    assert g.coverage_median == 0.99 and g.coverage_min == 0.97
    assert (g.distance_m, g.collisions_sum, g.collisions_max, g.rtf) == (50.0, 3, 2, 10.0)


def sweep():
    """Two worlds, recon + two baselines, one seed each.
    house: recon t99 = 300, nearest 400, density 500 -> ratio 300 / 400 = 0.75;
           distance to 99 % recon 50, nearest 30, density 40 -> 50 / 30.
    maze:  recon never reaches 99 % (t95 = 100), nearest t99 = 200, density never (t95 = 80)
           -> time99 ratio inf (null), time95 100 / 80 = 1.25; distance99 inf / 15 (null)."""
    return [run("recon", "house", t99=300.0, dist=60.0, coll=1, rtf=9.0, cov=0.995),
            run("nearest", "house", t99=400.0, dist=40.0),
            run("density", "house", t99=500.0, dist=50.0),
            run("recon", "maze", t95=100.0, t99=None, dist=20.0, coll=2, rtf=11.0, cov=0.97),
            run("nearest", "maze", t95=150.0, t99=200.0, dist=25.0),
            run("density", "maze", t95=80.0, t99=None, dist=30.0)]


def test_the_stack_speed_is_keyed_by_whether_slam_ran():
    # runs whose map is in map (SLAM, the default) give full_stack_rtf_slam, runs in odom (no
    # SLAM: the report's map_frame odom, or no such key in an older report) full_stack_rtf_lidar
    runs = sweep()
    for r, frame in zip(runs, ("map", None, None, "map", None, None)):
        if frame:
            r.report["map_frame"] = frame
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["full_stack_rtf_slam"] == 10.0 and "full_stack_rtf_lidar" not in f
    runs[0].report["map_frame"] = "odom"
    f = bm.figures(bm.aggregate(runs), runs)
    assert (f["full_stack_rtf_lidar"], f["full_stack_rtf_slam"]) == (9.0, 11.0)


def test_figures_headline_and_per_group_keys():
    runs = sweep()
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["default_min_coverage"] == 0.97
    assert f["default_collisions"] == 3
    assert f["full_stack_rtf_lidar"] == 10.0                 # median of 9 and 11
    assert f["time99_ratio_vs_best_baseline_house"] == pytest.approx(0.75)
    assert f["time99_ratio_vs_best_baseline_maze"] is None   # inf: recon never, a baseline did
    assert f["default_time99_ratio_vs_best_baseline"] is None
    assert f["default_time99_never_worlds"] == 1
    assert f["time95_ratio_vs_best_baseline_maze"] == pytest.approx(1.25)
    assert f["default_time95_ratio_vs_best_baseline"] == pytest.approx(1.25)   # worst of 1.0 (house 200/200), 1.25
    assert f["distance99_ratio_vs_best_baseline_house"] == pytest.approx(50.0 / 30.0)
    assert f["distance99_ratio_vs_best_baseline_maze"] is None       # inf: recon never got there
    assert f["default_distance99_ratio_vs_best_baseline"] is None
    assert f["distance99_m_recon_house"] == 50.0 and f["distance99_m_density_maze"] is None
    assert f["time99_s_recon_maze"] is None and f["time99_s_nearest_maze"] == 200.0
    assert f["coverage_final_recon_house"] == 0.995 and f["distance_m_density_maze"] == 30.0
    assert f["runs"] == 6 and f["failed_runs"] == 0
    json.dumps(f, allow_nan=False)                           # no inf / nan left


def test_worst_ratio_skips_undefined_worlds():
    # maze: nobody reaches 99 % (inf / inf, undefined) -> skipped; house 0.75 is the worst defined
    runs = [r for r in sweep() if r.world == "house"] + [run("recon", "maze"), run("nearest", "maze")]
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["time99_ratio_vs_best_baseline_maze"] is None
    assert f["default_time99_ratio_vs_best_baseline"] == pytest.approx(0.75)
    assert f["default_time99_never_worlds"] == 1


def test_only_default_reaches_gives_zero_ratio():
    runs = [run("recon", t99=300.0), run("nearest", t99=None)]
    assert bm.figures(bm.aggregate(runs), runs)["default_time99_ratio_vs_best_baseline"] == 0.0


def test_failed_default_run_shows_in_headline():
    runs = sweep() + [run("recon", "house", seed=1, status="timeout")]
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["default_min_coverage"] == 0.0
    assert f["default_failed_runs"] == 1 and f["failed_runs_recon_house"] == 1
    assert f["time99_s_recon_house"] is None                 # [300, inf] -> inf


def test_table_rows():
    groups = bm.aggregate(sweep())
    rows = bm.table_rows(groups)
    assert [r[:2] for r in rows] == [["house", "recon"], ["house", "nearest"], ["house", "density"],
                                     ["maze", "recon"], ["maze", "nearest"], ["maze", "density"]]
    recon_maze = dict(zip(bm.COLUMNS, rows[3]))
    assert recon_maze["ok/runs"] == "1/1" and recon_maze["cov med %"] == "97.0"
    assert (recon_maze["t95 s"], recon_maze["t99 s"]) == ("100", "never")
    assert recon_maze["coll sum/max"] == "2/2" and recon_maze["rtf"] == "11.0"
    text = bm.table(groups).splitlines()
    assert len(text) == 2 + 6 and text[0].split()[:2] == ["world", "strategy"]
    assert bm.fmt_time(INF) == "never" and bm.fmt_time(NAN) == "-" and bm.fmt_time(12.4) == "12"


def test_median_series_holds_last_value():
    grid = np.array([0.0, 5.0, 10.0, 20.0])
    a = (np.array([0.0, 10.0]), np.array([0.0, 1.0]))      # ends at 10 s, held at 1.0
    b = (np.array([0.0, 20.0]), np.array([0.0, 0.5]))
    c = (np.array([5.0, 20.0]), np.array([0.2, 0.2]))      # 0 before its first sample
    # at 5 s: a 0.5, b 0.125, c 0.2 -> 0.2; at 20 s: 1.0, 0.5, 0.2 -> 0.5
    assert bm.median_series([a, b, c], grid) == pytest.approx([0.0, 0.2, 0.25, 0.5])


def test_bar_value_falls_back_to_95():
    g = bm.summarise([run(t95=200.0, t99=None)])
    assert bm.bar_value(g) == (200.0, 95)
    assert bm.bar_value(bm.summarise([run(t95=200.0, t99=300.0)])) == (300.0, 99)
    t, pct = bm.bar_value(bm.summarise([run(t95=None, t99=None)]))
    assert math.isnan(t) and pct is None


def test_plots_are_written(tmp_path):
    runs = sweep()
    groups = bm.aggregate(runs)
    assert bm.plot_coverage_by_world(tmp_path / "cov.png", "maze", runs, ["recon", "nearest", "density"]).exists()
    assert bm.plot_time_bars(tmp_path / "bars.png", groups, ["house", "maze"], ["recon", "nearest", "density"]).exists()


def test_distance_is_compared_at_99_percent():
    """The distance driven until 99 %: a baseline that gave up early (never reached 99 %) or
    drove on after it is measured at the same point as recon, not by its whole run."""
    runs = [run("recon", "house", t99=300.0, dist=60.0, dist99=45.0),
            run("nearest", "house", t99=400.0, dist=40.0, dist99=38.0),
            run("density", "house", t99=350.0, dist=90.0, dist99=30.0),        # drove on after 99 %
            run("explore_lite", "house", t99=None, dist=10.0),                 # gave up early
            run("recon", "maze", t99=200.0, dist=20.0), run("nearest", "maze", t99=None, dist=10.0),
            run("recon", "arena", t99=200.0, dist=20.0, status="failed"), run("nearest", "arena", t99=100.0)]
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["distance99_ratio_vs_best_baseline_house"] == pytest.approx(45.0 / 30.0)
    assert f["distance99_ratio_vs_best_baseline_maze"] == 0.0       # only recon got there
    assert f["distance99_ratio_vs_best_baseline_arena"] is None     # recon's run failed: never
    assert f["distance99_m_explore_lite_house"] is None and f["distance_m_explore_lite_house"] == 10.0


def test_distance_until_a_milestone_along_the_path():
    from turtlebot_recon.evaluation import distance_until
    path = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 3.0, 4.0], [2.0, 3.0, 5.0], [3.0, 0.0, 5.0]])
    assert distance_until(path, 1.0) == pytest.approx(5.0)
    assert distance_until(path, 2.5) == pytest.approx(6.0)          # points after t are not counted
    assert distance_until(path, 10.0) == pytest.approx(9.0)
    assert distance_until(path, None) is None                        # never reached
    assert distance_until(np.zeros((0, 3)), 5.0) == 0.0


def test_the_oracle_is_a_reference_not_a_baseline():
    # house: recon 300 s, nearest 400 s, oracle 240 s. The oracle must not become "the best
    # baseline" (recon's ratio stays 300 / 400); its own figures: 240 / 400 and 300 / 240.
    runs = [run("recon", t99=300.0), run("nearest", t99=400.0), run(bm.REFERENCE, t99=240.0)]
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["time99_ratio_vs_best_baseline_house"] == pytest.approx(0.75)
    assert f["oracle_time99_ratio_vs_best_baseline_house"] == pytest.approx(0.6)
    assert f["default_time99_ratio_vs_oracle_house"] == pytest.approx(1.25)
    assert f["time99_s_oracle_house"] == 240.0
    no_oracle = [r for r in runs if r.strategy != bm.REFERENCE]
    assert not any("oracle" in k for k in bm.figures(bm.aggregate(no_oracle), no_oracle))


def held_out_sweep():
    """Tuning worlds house and arena, held-out worlds garden and doors; one seed each.
    Distance to 99 % is dist - 10 m (run()'s default) where 99 % is reached.
    house:  recon t99 300 (dist99 40), nearest 400 (30), oracle 250
    arena:  recon 360 (50), nearest 300 (35), oracle 200
    garden: recon 500 (60, coverage 0.97, 2 collisions), nearest never, density 450 (35), oracle 400
    doors:  recon 660 (70), nearest 600 (80), oracle 480"""
    return [run("recon", "house", t99=300.0, dist=50.0, cov=0.995), run("nearest", "house", t99=400.0, dist=40.0),
            run(bm.REFERENCE, "house", t99=250.0),
            run("recon", "arena", t99=360.0, dist=60.0, cov=0.992), run("nearest", "arena", t99=300.0, dist=45.0),
            run(bm.REFERENCE, "arena", t99=200.0),
            run("recon", "garden", t99=500.0, dist=70.0, cov=0.97, coll=2), run("nearest", "garden", t99=None),
            run("density", "garden", t99=450.0, dist=45.0), run(bm.REFERENCE, "garden", t99=400.0),
            run("recon", "doors", t99=660.0, dist=80.0, cov=0.993), run("nearest", "doors", t99=600.0, dist=90.0),
            run(bm.REFERENCE, "doors", t99=480.0)]


def test_held_out_worlds_are_reported_apart():
    runs = held_out_sweep()
    f = bm.figures(bm.aggregate(runs), runs, held_out=("garden", "doors", "unused"))
    assert f["tuning_worlds"] == ["house", "arena"] and f["heldout_worlds"] == ["garden", "doors"]
    assert f["runs"] == 13 and f["default_runs"] == 2 and f["heldout_default_runs"] == 2
    # tuning set: time99 house 300 / 400 = 0.75, arena 360 / 300 = 1.2 -> worst 1.2
    assert f["default_time99_ratio_vs_best_baseline"] == pytest.approx(1.2)
    # recon / oracle: house 300 / 250 = 1.2, arena 360 / 200 = 1.8 -> 1.8
    assert f["default_time99_ratio_vs_oracle_max"] == pytest.approx(1.8)
    # distance to 99 %: house 40 / 30, arena 50 / 35 = 10 / 7 -> 10 / 7
    assert f["default_distance99_ratio_vs_best_baseline_max"] == pytest.approx(10.0 / 7.0)
    assert f["default_distance99_ratio_vs_best_baseline"] == f["default_distance99_ratio_vs_best_baseline_max"]
    assert f["default_min_coverage"] == 0.992 and f["default_collisions"] == 0    # garden's 0.97 and 2 not here
    # held out: time99 garden 500 / min(never, 450) = 10 / 9, doors 660 / 600 = 1.1 -> 10 / 9
    assert f["heldout_default_time99_ratio_vs_best_baseline"] == pytest.approx(10.0 / 9.0)
    # recon / oracle: garden 500 / 400 = 1.25, doors 660 / 480 = 1.375 -> 1.375
    assert f["heldout_default_time99_ratio_vs_oracle_max"] == pytest.approx(1.375)
    # distance: garden 60 / min(never, 35) = 12 / 7, doors 70 / 80 = 0.875 -> 12 / 7
    assert f["heldout_default_distance99_ratio_vs_best_baseline_max"] == pytest.approx(12.0 / 7.0)
    assert f["heldout_default_min_coverage"] == 0.97 and f["heldout_default_collisions"] == 2
    assert f["heldout_default_time99_never_worlds"] == 0
    # per-world keys keep their names, whichever set the world is in
    assert f["time99_ratio_vs_best_baseline_garden"] == pytest.approx(10.0 / 9.0)
    assert f["default_time99_ratio_vs_oracle_doors"] == pytest.approx(1.375)
    json.dumps(f, allow_nan=False)


def test_without_held_out_worlds_every_world_is_tuning():
    runs = [r for r in held_out_sweep() if r.world in ("house", "arena")]
    for held_out in ((), ("garden", "doors")):          # none given, or none of them ran
        f = bm.figures(bm.aggregate(runs), runs, held_out=held_out)
        assert f["tuning_worlds"] == ["house", "arena"]
        assert not any(k.startswith("heldout_") for k in f)
    everything = bm.figures(bm.aggregate(held_out_sweep()), held_out_sweep())   # no held_out: one set
    assert everything["default_min_coverage"] == 0.97
    assert everything["default_time99_ratio_vs_oracle_max"] == pytest.approx(1.8)


def test_ratio_vs_oracle_max_rules():
    # house: recon 300 s, oracle never -> 0 (only recon got there); arena: recon never, oracle
    # 200 s -> inf (null): the worst world is inf; without the oracle anywhere: no key at all.
    runs = [run("recon", "house", t99=300.0), run(bm.REFERENCE, "house", t99=None)]
    assert bm.figures(bm.aggregate(runs), runs)["default_time99_ratio_vs_oracle_max"] == 0.0
    runs += [run("recon", "arena", t99=None), run(bm.REFERENCE, "arena", t99=200.0)]
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["default_time99_ratio_vs_oracle_max"] is None and f["default_time99_never_worlds"] == 1
    assert "default_time99_ratio_vs_oracle_max" not in bm.figures(bm.aggregate(runs[:1]), runs[:1])


# ---- issue 30: rows with two robots, time standing, the oracle's mean, committed sweeps, the plan

def bench_explore():
    """test/benchmarks/bench_explore.py, the sweep's planner (imported as bench-nav's test does)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import bench_explore as bx
    return bx


def timed(strategy, world, seed=0, t99=300.0, standing=None, goals=None, cov=0.995):
    r = run(strategy, world, seed, t99=t99, cov=cov)
    extra = {k: v for k, v in (("time_standing_s", standing), ("goals", goals)) if v is not None}
    return bm.Run(r.strategy, r.world, r.seed, r.status, {**r.report, **extra}, r.series)


def test_two_robots_in_one_world_are_two_rows_with_their_own_figures():
    runs = [timed("recon", "cluttered_burger", t99=1500.0, standing=90.0, goals=40, cov=0.991),
            timed("oracle", "cluttered_burger", t99=1250.0, standing=60.0),
            timed("recon", "cluttered_waffle_pi", t99=None, cov=0.70, goals=150),
            timed("oracle", "cluttered_waffle_pi", t99=1400.0, standing=50.0),
            timed("recon", "house", t99=440.0, standing=30.0, goals=20),
            timed("oracle", "house", t99=400.0, standing=30.0)]
    f = bm.figures(bm.aggregate(runs), runs, held_out=["cluttered_burger", "cluttered_waffle_pi"])
    assert f["heldout_worlds"] == ["cluttered_burger", "cluttered_waffle_pi"] and f["tuning_worlds"] == ["house"]
    assert f["time99_s_recon_cluttered_burger"] == 1500.0 and f["time99_s_recon_cluttered_waffle_pi"] is None
    assert f["default_time99_ratio_vs_oracle_cluttered_burger"] == pytest.approx(1.2)
    assert f["heldout_default_time99_ratio_vs_oracle_max"] is None           # the waffle_pi never got there
    assert f["heldout_default_min_coverage"] == 0.70 and f["default_min_coverage"] == 0.995
    assert f["heldout_default_standing_ratio_vs_oracle_max"] == pytest.approx(1.5)  # its waffle_pi runs lack the key
    assert f["goals_median_cluttered_waffle_pi"] == 150 and f["goals_median_house"] == 20
    assert f["default_time99_ratio_vs_oracle_mean"] == pytest.approx(1.1)
    json.dumps(f, allow_nan=False)


def test_oracle_mean_and_max_over_worlds():
    runs = [timed("recon", "a", t99=120.0), timed("oracle", "a", t99=100.0),
            timed("recon", "b", t99=150.0), timed("oracle", "b", t99=100.0)]
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["default_time99_ratio_vs_oracle_max"] == pytest.approx(1.5)
    assert f["default_time99_ratio_vs_oracle_mean"] == pytest.approx(1.35)


def test_a_missing_standing_key_is_missing_not_zero():
    # one recon seed from before time_standing_s: the median is over the two that have it;
    # the oracle's runs have none at all: no ratio (null), not 0 or inf
    recon = [timed("recon", "house", 0, standing=40.0), timed("recon", "house", 1),
             timed("recon", "house", 2, standing=60.0)]
    g = bm.summarise(recon)
    assert g.standing_s == 50.0
    runs = recon + [timed("oracle", "house", n) for n in range(3)]
    f = bm.figures(bm.aggregate(runs), runs)
    assert f["time_standing_s_recon_house"] == 50.0 and f["time_standing_s_oracle_house"] is None
    assert f["default_standing_ratio_vs_oracle_house"] is None
    assert f["default_standing_ratio_vs_oracle_max"] is None


def test_committed_baselines_stand_in_where_the_sweep_ran_none(tmp_path):
    bx = bench_explore()
    old = [run("recon", "house", t99=500.0), run("nearest", "house", t99=400.0), run("density", "house", t99=600.0),
           run("nearest", "maze", t99=None), run("recon", "maze", t99=900.0)]
    committed = {**bm.figures(bm.aggregate(old), old), "commit": "abc1234", "date": "2026-12-04T10:00:00Z"}
    newer_no_baselines = {"time99_s_oracle_house": 350.0, "commit": "def5678", "date": "2026-12-05T10:00:00Z"}
    (tmp_path / "explore-2026-12-04-abc1234.json").write_text(json.dumps(committed))
    (tmp_path / "explore-2026-12-05-def5678.json").write_text(json.dumps(newer_no_baselines))
    sweeps = bx.newest_first(sorted(tmp_path.glob("*.json")))
    assert [p.name for p, _ in sweeps] == ["explore-2026-12-05-def5678.json", "explore-2026-12-04-abc1234.json"]
    path, data, groups = bx.baseline_sweep(sweeps)             # the newest with baselines
    assert path.name == "explore-2026-12-04-abc1234.json" and data["commit"] == "abc1234"
    assert groups[("nearest", "house")].time_s[99] == 400.0 and groups[("nearest", "maze")].time_s[99] == INF
    assert ("recon", "house") not in groups                   # only baselines stand in
    now = [run("recon", "house", t99=360.0), run("oracle", "house", t99=300.0), run("recon", "maze", t99=800.0),
           run("recon", "office", t99=1000.0), run("nearest", "office", t99=800.0)]
    f = bm.figures(bm.aggregate(now), now, baselines=groups)
    assert f["time99_ratio_vs_best_baseline_house"] == pytest.approx(360.0 / 400.0)
    assert f["time99_ratio_vs_best_baseline_maze"] == 0.0     # only recon got there
    assert f["time99_ratio_vs_best_baseline_office"] == pytest.approx(1.25)    # the sweep's own baseline
    assert f["baseline_worlds_committed"] == ["house", "maze"]
    assert "time99_s_nearest_house" not in f                  # the per-group keys are this sweep's
    assert f["default_time99_ratio_vs_best_baseline"] == pytest.approx(1.25)


def test_default_plan_and_full_plan():
    bx = bench_explore()
    plan = bx.make_plan()
    assert plan.strategies == ["recon", "oracle"]
    assert list(plan.rows)[:6] == ["house", "maze", "office", "arena", "depot", "tb3_sandbox"]
    assert plan.rows["cluttered_burger"] == ("cluttered", "turtlebot3_burger")
    assert plan.rows["cluttered_waffle_pi"] == ("cluttered", "turtlebot3_waffle_pi")
    assert plan.rows["house"] == ("house", "turtlebot3_waffle_pi") and "warehouse" not in plan.rows
    assert plan.held_out == ["garden", "doors", "cluttered_burger", "cluttered_waffle_pi"]
    assert {r: plan.seeds[r] for r in plan.held_out} == dict.fromkeys(plan.held_out, bx.HELD_OUT_SEEDS)
    assert plan.seeds["office"] == 3 and bx.HELD_OUT_SEEDS < 3
    assert len(plan.runs()) == 2 * (6 * 3 + 4 * bx.HELD_OUT_SEEDS)
    full = bx.make_plan(full=True, baselines=True)
    assert full.rows["warehouse"] == ("warehouse", "turtlebot3_burger") and "warehouse" not in full.held_out
    assert all(full.seeds[r] == 3 for r in full.rows)
    assert full.strategies == ["recon", "nearest", "density", "gain_distance_heading", "sampled", "explore_lite",
                               "oracle"]
    one = bx.make_plan("cluttered", "oracle", 1, robot="turtlebot3_burger")     # the world keeps its row names
    assert list(one.rows) == ["cluttered_burger"] and one.runs() == [("oracle", "cluttered_burger", 0)]
    two = bx.make_plan("house", robots="house=turtlebot3_burger+turtlebot3_waffle_pi")
    assert list(two.rows) == ["house_burger", "house_waffle_pi"] and two.seeds["house_burger"] == 3
    with pytest.raises(ValueError):
        bx.make_plan(strategies="recon,bogus")


def test_budgets_follow_the_committed_oracle_times():
    bx = bench_explore()
    plan = bx.make_plan("house,tb3_sandbox,maze", "recon")
    sweeps = [("new.json", {"time99_s_oracle_house": 400.0}),
              ("old.json", {"time99_s_oracle_house": 900.0, "time99_s_oracle_tb3_sandbox": 42.0})]
    b = bx.budgets_for(plan, sweeps=sweeps)
    assert b["house"] == 1020.0                 # 2.5 x 400 = 1,000 -> whole minutes; the newest sweep's
    assert b["tb3_sandbox"] == bm.BUDGET_MIN_S  # 105 s: the floor
    assert b["maze"] == bx.WORLD_BUDGETS["maze"]    # no committed oracle time: the old rule
    assert bx.budgets_for(plan, budgets="house=700", sweeps=sweeps)["house"] == 700.0
    wall, at_budget = bx.estimate_wall_s(
        bx.make_plan("house", "recon,oracle", 1), {"house": 1020.0}, jobs=2, startup_s=20.0,
        sweeps=[("s.json", {"sim_time_s_recon_house": 500.0, "rtf_recon_house": 10.0, "full_stack_rtf_lidar": 5.0})])
    assert at_budget == 1                       # the oracle's run: no sim time, its budget at rtf 5
    assert wall == pytest.approx((500.0 / 10.0 + 20.0 + 1020.0 / 5.0 + 20.0) / 2)


def test_results_name_sittings_and_table(tmp_path):
    bx = bench_explore()
    assert bx.results_name("explore", "abc1234+dirty", "2026-12-05") == "explore-2026-12-05-abc1234-dirty.json"
    assert bx.results_name("p30", "abc1234", "2026-12-05") == "explore-2026-12-05-abc1234-p30.json"
    assert bx.sittings_wall_s(tmp_path, 100.0, resume=False) == 100.0
    assert bx.sittings_wall_s(tmp_path, 50.0, resume=True) == 150.0    # a --resume'd sweep adds its sittings
    assert bx.sittings_wall_s(tmp_path, None, resume=False) == 150.0   # --report reads them
    assert bx.sittings_wall_s(tmp_path, 70.0, resume=False) == 70.0    # a fresh sweep starts anew
    runs = [timed("recon", "house", t99=440.0, standing=30.0, goals=21),
            timed("oracle", "house", t99=400.0, standing=20.0), timed("nearest", "house", t99=500.0)]
    data = {**bm.figures(bm.aggregate(runs), runs), "robot_house": "turtlebot3_waffle_pi", "wall_s": 1234.0}
    doc = tmp_path / "benchmarks.md"
    doc.write_text(f"# B\n\n{bx.TABLE_BEGIN}\nold\n{bx.TABLE_END}\n\nafter\n")
    bx.write_table(doc, bx.markdown_table(data, "docs/results/x.json"))
    text = doc.read_text()
    assert "old" not in text and text.endswith(f"{bx.TABLE_END}\n\nafter\n")
    row = next(ln for ln in text.splitlines() if ln.startswith("| house"))
    assert row.split(" | ")[3:9] == ["440", "400", "1.10", "500 (nearest)", "0.88", "1.50"]
