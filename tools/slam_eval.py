#!/usr/bin/env python3
"""Score an estimated trajectory against ground truth: ATE and the relations metric.

    tools/slam_eval.py --traj FILE --gt FILE [--relations FILE] [--align] [--max-dt S] [--json OUT]

FILE are TUM trajectories (``t x y z qx qy qz qw``); ``--relations`` a Kümmerle et al. 2009
``.relations`` file (``t1 t2 x y z roll pitch yaw``). ``--align`` first aligns the estimate onto
the ground truth by SE(2) least squares (for datasets whose frames differ). Prints one line per
metric; ``--json`` also writes them. A missing or unreadable file, or nothing to compare: one
line saying why, exit status 1 (2 for bad arguments).
"""
import argparse
import json
import sys
from pathlib import Path

try:
    import turtlebot_recon  # noqa: F401  (found through the devel space: source tools/env.sh)
except ImportError:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from turtlebot_recon.evaluation.trajectory_metrics import ate, read_relations, read_tum, relations_error


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="slam_eval", description=__doc__.split("\n\n")[0])
    p.add_argument("--traj", required=True, help="estimated trajectory (TUM)")
    p.add_argument("--gt", required=True, help="ground-truth trajectory (TUM)")
    p.add_argument("--relations", help="relations file (Kümmerle et al. 2009)")
    p.add_argument("--align", action="store_true", help="align the estimate onto the ground truth (SE(2))")
    p.add_argument("--max-dt", type=float, default=0.02,
                   help="s: pairing tolerance of time stamps (default 0.02)")
    p.add_argument("--json", help="also write the figures to this JSON file")
    a = p.parse_args(argv)
    try:
        est, gt = read_tum(a.traj), read_tum(a.gt)
        result = ate(est, gt, a.max_dt, align=a.align)
        report = {"traj": a.traj, "gt": a.gt, "aligned": a.align, **result.as_dict()}
        lines = [f"ATE: rmse {result.rmse_m:.4f} m, mean {result.mean_m:.4f} m, max {result.max_m:.4f} m "
                 f"({result.matched} of {result.total} poses paired within {a.max_dt} s"
                 + (", aligned" if a.align else "") + ")"]
        if a.relations:
            rel = relations_error(est, read_relations(a.relations), a.max_dt)
            report.update(relations=a.relations, **rel.as_dict())
            lines.append(f"relations ({rel.used} used, {rel.missing} outside the estimate): translational "
                         f"{rel.trans_mean_m:.4f} ± {rel.trans_std_m:.4f} m, rotational {rel.rot_mean_deg:.3f} "
                         f"± {rel.rot_std_deg:.3f} deg; squared {rel.trans_sq_mean_m2:.5f} "
                         f"± {rel.trans_sq_std_m2:.5f} m², {rel.rot_sq_mean_deg2:.4f} "
                         f"± {rel.rot_sq_std_deg2:.4f} deg²")
        if a.json:
            Path(a.json).write_text(json.dumps(report, indent=1) + "\n")
    except (OSError, ValueError) as e:
        print(f"slam_eval: {e}", file=sys.stderr)
        return 1
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
