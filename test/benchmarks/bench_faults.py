#!/usr/bin/env python3
"""`make bench-faults`: faults injected on purpose during short explorations (issue 32, item 2),
the intended behaviour of each (docs/faults.md) against the measured one -> output/bench/faults.json.

Each case is one `tools/launch ... explore_sim.launch` run (what `make run` runs) in the house,
rtf 0, a short budget (BUDGET_S sim s; the burger with the lidar, the waffle_pi with the camera
for the tag nodes' cases), with its own ROS master port, run directory and ROS_HOME under
output/bench/faults/<case>/ (launch.log: the launcher's and the nodes' lines; inject.log: the
injector's). The faults:

- kill: SIGKILL to one node (its pid found by its ``__name:=`` and the run's master port),
  KILL_AFTER_WALL_S after the explorer said it started (the tag tracker: after its first
  confirmed tag, so that it has something to resume); for the two nodes that resume (the
  mapper, the tag tracker) ``kept`` compares what their file held at the kill with the run's
  final map (known cells) or tag list;
- stall_2s, stall_10s, drop_20pct, tf_delay_0.3s, clock_jump: test/benchmarks/fault_injector.py
  beside the run (scans or TF relayed through it: the launch's test-only ``bridge_scan`` /
  ``bridge_tf`` arguments; the clock jump is one /clock message 5 s back, as a looping bag);
- full_fs: the run directory is a 2 MiB tmpfs (mount -t tmpfs, root only; never the machine's
  disk), filled to the last byte FILL_AFTER_WALL_S after the explorer started.

Measured per case: did the run end (launcher exit status) or go on; was the cause named (the
launcher's last line and report.json's ``finished_reason``, or the restart line and
``node_respawns``); was a report written; coverage and collisions (against the fault-free run);
which node lines (WARN and above in rosout.log, sim-time stamped) came while a stream fault
lasted; processes of the run still alive afterwards. A case is *silent* (``silent_failures``)
when it ended the run without naming the cause, or when the run reported success with nothing
naming the fault while the fault cost coverage (below COVERAGE_KEPT of the fault-free run's) or
caused a collision, or when a node's death went unnoticed (a kill with neither an end nor a
restart line). Also: two launches side by side on one master port (``parallel_runs_ok``: the
second takes a port of its own, both write their reports), the bad-input catalogue
(test/unit/test_bad_input_catalogue.py run with pytest: ``bad_input_cases`` / ``_crashes``),
and with --soak N, N short explorations back to back (random worlds and seeds) counting crashes,
collisions, runs without a report and leaked processes, ports and shared memory.
"""
import argparse
import json
import os
import random
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import TOP, write  # noqa: E402
from turtlebot_recon.mapping.map_io import load_map  # noqa: E402
from turtlebot_recon.mapping.resume import decided, known_cells, resume_path  # noqa: E402
from turtlebot_recon.perception.tracker import load_tags_yaml  # noqa: E402

OUT = TOP / "output" / "bench" / "faults"
RESULTS = TOP / "docs" / "results"
BUDGET_S = 240.0            # sim s of exploration per case: the house, about two thirds seen
KILL_AFTER_WALL_S = 10.0    # wall s after "explorer: started": a few goals into the run
FILL_AFTER_WALL_S = 10.0
FAULT_AT_S = 30.0           # sim s after the explorer's start, for the injector's timed faults
COVERAGE_KEPT = 0.8         # below this share of the fault-free coverage a fault cost it (two fault-free runs at 200 s: 0.61, 0.74)
WALL_LIMIT_S = 420.0        # wall s per launch, then SIGINT (a hung run is recorded as such)
SOAK_WORLDS = ("house", "maze", "office", "arena", "doors", "garden")

# case -> (fault, node or injector arguments, launch arguments beyond the base, intended)
# intended: "restart" (respawned, the run goes on), "end" (the run ends naming the node or the
# cause), "go_on" (the stack rides it out: the run reaches its budget).
MAP = ["robot:=turtlebot3_burger", "mission:=map"]
TAGS = ["robot:=turtlebot3_waffle_pi", "mission:=tags"]
CASES = {
    "none": ("none", None, MAP, "go_on"),                     # the fault-free references
    "none_slam": ("none", None, MAP + ["slam:=true"], "go_on"),
    "none_tags": ("none", None, TAGS, "go_on"),
    "kill_sim_bridge": ("kill", "sim_bridge", MAP, "end"),
    "kill_mapper": ("kill", "mapper", MAP, "restart"),          # it resumes from its autosave
    "kill_slam": ("kill", "slam", MAP + ["slam:=true"], "end"),
    "kill_explorer": ("kill", "explorer", MAP, "end"),
    "kill_navigator": ("kill", "navigator", MAP, "restart"),
    "kill_tag_detector": ("kill", "tag_detector", TAGS, "restart"),
    "kill_tag_tracker": ("kill", "tag_tracker", TAGS, "restart"),  # it resumes from its tags.yaml
    "kill_evaluator": ("kill", "evaluator", MAP, "end"),
    "stall_2s": ("inject", ["--fault", "stall", "--duration-s", "2"], MAP + ["bridge_scan:=scan_raw"], "go_on"),
    "stall_10s": ("inject", ["--fault", "stall", "--duration-s", "10"], MAP + ["bridge_scan:=scan_raw"], "go_on"),
    "no_scan": ("inject", ["--fault", "drop", "--fraction", "1.0"], MAP + ["bridge_scan:=scan_raw"], "named_end"),
    "drop_20pct": ("inject", ["--fault", "drop", "--fraction", "0.2"], MAP + ["bridge_scan:=scan_raw"], "go_on"),
    "tf_delay_0.3s": ("inject", ["--fault", "tf_delay", "--delay-s", "0.3"], MAP + ["bridge_tf:=/tf_raw"], "go_on"),
    "clock_jump": ("inject", ["--fault", "clock_jump", "--jump-s", "5"], MAP, "go_on"),
    "full_fs": ("full_fs", None, MAP, "end"),
}
# a node's line (WARN and above) that names the injected fault: what it must mention
NOTICE = {"stall": r"scan", "drop": r"scan", "tf_delay": r"\bTF\b|transform|extrapolat",
          "clock_jump": r"jump|back in time|moved backwards|went back"}
INTENDED = {
    "restart": "the node is restarted (one line naming it, report.json node_respawns); the run goes on to its end",
    "end": "the run ends at once, exit status 1, the last line and report.json's finished_reason naming the node",
    "go_on": "the run goes on to its budget; coverage and collisions as without the fault",
    "named_end": "the run ends (its map stands still), report.json's finished_reason naming the cause",
}
LIDAR_NAMED = "no scan on /scan"         # the explorer's reason when the lidar fell silent
KILL_WHEN = {"tag_tracker": "tag_tracker: confirmed"}   # a node's kill waits for this line (default: the explorer's start)
INTENDED_FULL_FS = ("the run ends with one line saying what could not be written (no space left), "
                    "non-zero exit; no report where none fits")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run_env(port: int, ros_home: Path, auto: bool = False) -> dict:
    env = {**os.environ, "ROS_MASTER_URI": f"http://127.0.0.1:{port}", "ROS_IP": "127.0.0.1",
           "ROS_HOME": str(ros_home), "ROS_LOG_DIR": str(ros_home / "log")}
    env.pop("ROS_HOSTNAME", None)
    if auto:
        env["TURTLEBOT_RECON_MASTER"] = "auto"
    else:
        env.pop("TURTLEBOT_RECON_MASTER", None)
    return env


def processes_of(port: int) -> dict:
    """pid -> ``__name:=`` (or the command) of every process whose environment names this master."""
    found, key = {}, f"ROS_MASTER_URI=http://127.0.0.1:{port}".encode()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            env = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if key in env and int(pid) != os.getpid():
            names = [c.decode(errors="replace")[len("__name:="):] for c in cmd if c.startswith(b"__name:=")]
            found[int(pid)] = (names[0] if names else os.path.basename(cmd[0].decode(errors="replace"))) + \
                (" (zombie)" if state == "Z" else "")
    return found


def node_pid(name: str, port: int):
    for pid, who in processes_of(port).items():
        if who == name:
            return pid
    return None


def port_listening(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.5):
            return True
    except OSError:
        return False


def shm_entries() -> set:
    try:
        return set(os.listdir("/dev/shm"))
    except OSError:
        return set()


def wait_for_line(path: Path, text: str, proc: subprocess.Popen, timeout_s: float = 180.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        if path.exists() and text in path.read_text(errors="replace"):
            return True
        time.sleep(0.5)
    return False


def stop(proc: subprocess.Popen) -> int:
    """SIGINT the launch's process group, SIGKILL after 60 s."""
    try:
        os.killpg(proc.pid, signal.SIGINT)
        return proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return proc.wait()
    except ProcessLookupError:
        return proc.wait()


def fill(directory: Path) -> str:
    """Fill the file system of ``directory`` to the last byte; what stopped the writing."""
    try:
        with open(directory / "filler", "wb") as f:
            while True:
                f.write(b"\0" * 65536)
                f.flush()
    except OSError as exc:
        return exc.strerror or str(exc)
    return ""


def rosout_lines(ros_home: Path, t0: float, t1: float, launch_log=None) -> list:
    """'node: message' of the WARN/ERROR/FATAL lines on /rosout stamped within [t0, t1] sim s,
    then the screen's (``launch_log``: what a node printed but did not send to /rosout, e.g.
    tf2's "Detected jump back in time")."""
    out = []
    if launch_log is not None:
        for line in launch_log.read_text(errors="replace").splitlines():
            m = re.match(r"^\[(WARN|ERROR|FATAL)\] \[[\d.]+, ([\d.]+)\]: (.*)", line)
            if m and t0 <= float(m.group(2)) <= t1:
                out.append(f"(screen): {m.group(3)[:160]}")
    for path in sorted((ros_home / "log").glob("*/rosout.log")):
        if path.parent.is_symlink():                  # "latest": the same file again
            continue
        for line in path.read_text(errors="replace").splitlines():
            m = re.match(r"^(\d+\.\d+) (WARN|ERROR|FATAL) (\S+) \[[^\]]*\] \[topics: [^\]]*\] (.*)", line)
            if m and t0 <= float(m.group(1)) <= t1 and m.group(3) != "/fault_injector":
                out.append(f"{m.group(3).lstrip('/')}: {m.group(4)[:160]}")
    return out


def launch(case_dir: Path, run_dir: Path, args: list, port: int, tag: str, auto: bool = False,
           budget_s: float = BUDGET_S, world: str = "house", seed: int = 0) -> tuple:
    """Start one launch; (Popen, its launch.log path)."""
    ros_home = case_dir / "ros_home"
    ros_home.mkdir(parents=True, exist_ok=True)
    cmd = [str(TOP / "tools" / "launch"), "--tag", tag, "--done", "evaluator", "--report",
           str(run_dir / "report.json"), "explore_sim.launch", f"world:={world}", f"seed:={seed}", "rtf:=0",
           f"budget:={budget_s:g}", f"output:={run_dir}", "end_with_evaluator:=false", *args]
    log_path = case_dir / "launch.log"
    log = open(log_path, "wb")
    proc = subprocess.Popen(["nice", "-n", "10", *cmd], stdout=log, stderr=subprocess.STDOUT,
                            env=run_env(port, ros_home, auto), start_new_session=True)
    log.close()
    (case_dir / "command.txt").write_text(" ".join(cmd) + "\n")
    return proc, log_path


def finish(proc: subprocess.Popen, t0: float) -> tuple:
    """(exit status, hung): waited for up to WALL_LIMIT_S from ``t0``, else stopped."""
    try:
        return proc.wait(timeout=max(1.0, WALL_LIMIT_S - (time.monotonic() - t0))), False
    except subprocess.TimeoutExpired:
        return stop(proc), True


def read_report(run_dir: Path):
    try:
        return json.loads((run_dir / "report.json").read_text())
    except (OSError, ValueError):
        return None


def last_line(log_path: Path) -> str:
    lines = [ln for ln in log_path.read_text(errors="replace").splitlines() if ln.startswith("[")]
    return lines[-1] if lines else ""


def reference_of(args: list) -> str:
    """The fault-free case run with the same robot, mission and SLAM as ``args``."""
    plain = [a for a in args if not a.startswith("bridge_")]
    return next(n for n, (fault, _, a, _) in CASES.items() if fault == "none" and a == plain)


def run_case(name: str, baseline) -> dict:
    fault, what, args, intended = CASES[name]
    case_dir = OUT / name
    if case_dir.exists():
        for mount in (case_dir / "run",):
            subprocess.run(["umount", str(mount)], capture_output=True)
        shutil.rmtree(case_dir)
    run_dir = case_dir / "run"
    run_dir.mkdir(parents=True)
    mounted = False
    if fault == "full_fs":
        if os.geteuid() != 0:
            return {"case": name, "skipped": "needs root to mount a tmpfs"}
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(run_dir)], capture_output=True, text=True)
        if r.returncode:
            return {"case": name, "skipped": f"mount -t tmpfs failed: {r.stderr.strip()}"}
        mounted = True
    port = free_port()
    held = None
    shm_before = shm_entries()
    t0 = time.monotonic()
    proc, log_path = launch(case_dir, run_dir, args, port, tag=f"faults/{name}")
    injector, fault_done = None, ""
    try:
        if fault == "inject":
            inject_log = open(case_dir / "inject.log", "wb")
            injector = subprocess.Popen([sys.executable, str(Path(__file__).with_name("fault_injector.py")), *what,
                                         "--at-s", f"{FAULT_AT_S:g}"], stdout=inject_log, stderr=subprocess.STDOUT,
                                        env=run_env(port, case_dir / "ros_home"), start_new_session=True)
            inject_log.close()
        if fault in ("kill", "full_fs"):
            when = KILL_WHEN.get(what, "explorer: started") if fault == "kill" else "explorer: started"
            if wait_for_line(log_path, when, proc, timeout_s=240.0):
                time.sleep(KILL_AFTER_WALL_S if fault == "kill" and when == "explorer: started" else
                           FILL_AFTER_WALL_S if fault == "full_fs" else 3.0)     # 3 s: the tracker's autosave
                if fault == "kill":
                    pid = node_pid(what, port)
                    if pid is None:
                        fault_done = f"no {what} process found"
                    else:
                        held = held_at_kill(what, run_dir)
                        os.kill(pid, signal.SIGKILL)
                        fault_done = f"SIGKILL to {what} (pid {pid}) {time.monotonic() - t0:.0f} s (wall) into the run"
                else:
                    fault_done = f"the run directory's tmpfs filled ({fill(run_dir)})"
            else:
                fault_done = f"no '{when}' line: no fault injected"
        rc, hung = finish(proc, t0)
    finally:
        if proc.poll() is None:
            stop(proc)
        if injector is not None:
            if injector.poll() is None:
                injector.send_signal(signal.SIGINT)
                try:
                    injector.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    injector.kill()
    wall_s = time.monotonic() - t0
    time.sleep(1.0)
    leaked = processes_of(port)
    listening = port_listening(port)
    shm_new = sorted(shm_entries() - shm_before)
    report = read_report(run_dir)
    files = sorted(p.name for p in run_dir.iterdir() if not p.name.startswith(".")) if run_dir.exists() else []
    if mounted:
        subprocess.run(["umount", str(run_dir)], capture_output=True)
    last = last_line(log_path)
    log_text = log_path.read_text(errors="replace")
    fault_window = (float("nan"), float("nan"))
    if fault == "inject":
        inj = (case_dir / "inject.log").read_text(errors="replace")
        fault_done = " / ".join(ln[len("[inject] "):] for ln in inj.splitlines() if ln.startswith("[inject]"))
        times = [float(t) for t in re.findall(r"(?:t=|to )([\d.]+) s", inj)]     # a jump's both ends
        if times:
            fault_window = (min(times) - 0.5, max(times) + 15.0)
        elif "dropping" in inj or "delayed" in inj:
            fault_window = (0.0, 1e9)
    noticed = [ln for ln in rosout_lines(case_dir / "ros_home", *fault_window, launch_log=log_path)
               if re.search(NOTICE[what[1]], ln, re.I)] if fault == "inject" else []
    written_by_evaluator = bool(report) and "written_by" not in report
    reason = (report or {}).get("finished_reason") or ""
    restarted = bool(what) and fault == "kill" and f"node {what} exited with status -9: restarting it" in log_text
    ended = rc != 0
    if fault == "kill":
        named = (f"node {what} exited with status -9" in last and reason.startswith(f"node {what} exited")) if ended \
            else (restarted and any(what in r for r in (report or {}).get("node_respawns", [])))
    elif fault == "full_fs":
        named = "No space left" in last or "could not write" in last or "cannot write" in last
    elif intended == "named_end":
        named = LIDAR_NAMED in reason
    else:
        named = bool(noticed) if not ended else bool(reason) and reason != "shut down before the end"
    coverage = (report or {}).get("coverage_final")
    collisions = (report or {}).get("collisions")
    base_cov = (baseline or {}).get("coverage_final")
    base_col = (baseline or {}).get("collisions") or 0
    harmed = (coverage is not None and base_cov and coverage < COVERAGE_KEPT * base_cov) or \
        (collisions or 0) > base_col
    if hung:                  # it never ended by itself: the harness stopped it, nobody said why
        named, silent = False, True
    elif fault == "kill":
        silent = (ended and not named) or (not ended and not restarted)
    elif fault == "full_fs":
        silent = not named
    elif intended == "named_end":
        silent = not named
    else:
        silent = (ended and not named) or (not ended and bool(harmed) and not named)
    if hung:
        measured = f"hung: stopped after {WALL_LIMIT_S:.0f} s wall; last line: {last}"
    elif ended:
        measured = f"ended (exit {rc}): {last}"
    elif restarted:
        measured = f"restarted, the run went on to its end: {last}"
    else:
        measured = f"went on to its end (exit 0): {reason}"
    got = "restart" if restarted and not ended else ("end" if ended else "go_on")
    if intended == "named_end" and not ended and named:
        got = "named_end"
        harmed = False                     # no scan, no map: the coverage is the fault's, said
    row = {
        "case": name, "fault": fault_done or fault, "node": what if fault == "kill" else None,
        "intended": INTENDED_FULL_FS if fault == "full_fs" else INTENDED[intended],
        "intended_kind": intended, "measured": measured, "measured_kind": got, "harmed": bool(harmed),
        "exit_status": rc, "hung": hung, "ended": ended, "cause_named": bool(named), "silent": bool(silent),
        "report_written": report is not None, "report_by_evaluator": written_by_evaluator,
        "finished_reason": reason, "node_respawns": (report or {}).get("node_respawns", []),
        "coverage_final": coverage, "coverage_fault_free": base_cov, "collisions": collisions,
        "noticed_by": noticed[:5], "files": files, "last_line": last, "wall_s": round(wall_s, 1),
        "leaked_processes": sorted(leaked.values()), "port_still_listening": listening, "shm_new": shm_new,
        "args": args,
    }
    if held is not None:
        row["kept"] = kept_after_kill(what, held, run_dir)
    row["as_intended"] = as_intended(row)
    (case_dir / "case.json").write_text(json.dumps(row, indent=2) + "\n")
    return row


def held_at_kill(node: str, run_dir: Path):
    """What a node that resumes had saved in the run directory when killed: the mapper's known
    cells (x, y indices in a frame shared by any origin), the tag tracker's (family, id); None
    for the other nodes."""
    try:
        if node == "mapper":
            with np.load(resume_path(run_dir / "map")) as f:
                return known_cells(decided(f["logodds"]), float(f["resolution"]), f["origin"])
        if node == "tag_tracker":
            return {(t.family, t.id) for t in load_tags_yaml((run_dir / "tags.yaml").read_text())}
    except (OSError, ValueError, KeyError):
        return set()
    return None


def kept_after_kill(node: str, held: set, run_dir: Path) -> dict:
    """How much of what the node held at its kill the run's final files keep."""
    try:
        if node == "mapper":
            occ, res, origin = load_map(run_dir / "map.yaml")
            final = known_cells(occ >= 0, res, origin)
        else:
            final = {(t.family, t.id) for t in load_tags_yaml((run_dir / "tags.yaml").read_text())}
    except (OSError, ValueError):
        final = set()
    what = "known cells" if node == "mapper" else "confirmed tags"
    return {"what": what, "at_kill": len(held), "in_final": len(held & final), "final": len(final)}


def as_intended(row: dict) -> bool:
    """The measured kind is the intended one, its cause named where it ends or restarts, and
    where the run should go on (restarted, or riding a stream fault out) no coverage lost to it
    (an ended run's coverage is short by design)."""
    kind = row["intended_kind"]
    return row["measured_kind"] == kind and (row["cause_named"] or kind == "go_on") and \
        not (kind in ("go_on", "restart") and row["harmed"])


def parallel_runs(budget_s: float = 120.0) -> dict:
    """Two launches as two `make run`s in two shells: the same master URI, the port ours to
    choose (tools/env.sh's auto); the second must take a port of its own and both end with their
    own reports."""
    base = OUT / "parallel"
    shutil.rmtree(base, ignore_errors=True)
    port = free_port()
    runs = []
    for i in (1, 2):
        case_dir = base / f"run{i}"
        (case_dir / "run").mkdir(parents=True)
        t0 = time.monotonic()
        proc, log_path = launch(case_dir, case_dir / "run", MAP, port, tag=f"parallel{i}", auto=True, budget_s=budget_s)
        runs.append((proc, log_path, case_dir, t0))
        if i == 1:
            wait_for_line(log_path, "explorer: started", proc, timeout_s=120)
    ends = {}
    while len(ends) < 2 and time.monotonic() - runs[0][3] < WALL_LIMIT_S:
        for i, (proc, *_rest) in enumerate(runs):
            if i not in ends and proc.poll() is not None:
                ends[i] = time.monotonic()
        time.sleep(0.2)
    out = []
    for proc, log_path, case_dir, t0 in runs:
        rc, hung = finish(proc, t0)
        report = read_report(case_dir / "run")
        text = log_path.read_text(errors="replace")
        out.append({"exit_status": rc, "hung": hung, "last_line": last_line(log_path),
                    "own_port_line": next((ln for ln in text.splitlines() if "is taken (another run?)" in ln), ""),
                    "report_by_evaluator": bool(report) and "written_by" not in report,
                    "finished_reason": (report or {}).get("finished_reason"),
                    "coverage_final": (report or {}).get("coverage_final")})
    ok = all(r["exit_status"] == 0 and r["report_by_evaluator"] for r in out) and bool(out[1]["own_port_line"])
    # both running at once for this long (wall s): the second started before the first ended
    overlap = min(ends.get(0, time.monotonic()), ends.get(1, time.monotonic())) - runs[1][3]
    ok = ok and overlap > 0
    return {"parallel_runs_ok": int(ok), "parallel_runs": out, "parallel_master_port": port,
            "parallel_overlap_s": round(overlap, 1)}


def bad_input() -> dict:
    """test/unit/test_bad_input_catalogue.py run here: its cases (the parametrised test_bad_input)
    passed and failed."""
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rA",
                        str(TOP / "test" / "unit" / "test_bad_input_catalogue.py")], cwd=TOP,
                       capture_output=True, text=True)
    passed = len(re.findall(r"^PASSED \S+::test_bad_input\[", r.stdout, re.M))
    failed = len(re.findall(r"^(?:FAILED|ERROR) \S+::test_bad_input\[", r.stdout, re.M))
    return {"bad_input_cases": passed + failed, "bad_input_crashes": failed,
            "bad_input_pytest_exit": r.returncode,
            "bad_input_measured": "test/unit/test_bad_input_catalogue.py: each case fed through the code the node "
                                  "runs (ROS-free), checked for one line and nothing lost; crashes = failed cases"}


def soak(n: int, seed: int) -> dict:
    """N short explorations back to back, random worlds and seeds."""
    rng = random.Random(seed)
    rows = []
    for i in range(n):
        world, s = rng.choice(SOAK_WORLDS), rng.randrange(1000)
        case_dir = OUT / "soak" / f"{i:03d}-{world}-seed{s}"
        shutil.rmtree(case_dir, ignore_errors=True)
        (case_dir / "run").mkdir(parents=True)
        port, shm_before, t0 = free_port(), shm_entries(), time.monotonic()
        proc, log_path = launch(case_dir, case_dir / "run", MAP, port, tag=f"soak{i}", world=world, seed=s,
                                budget_s=120.0)
        rc, hung = finish(proc, t0)
        time.sleep(1.0)
        report = read_report(case_dir / "run")
        leaked = sorted(processes_of(port).values()) + ([f"port {port} listening"] if port_listening(port) else [])
        shm_new = sorted(shm_entries() - shm_before)
        rows.append({"world": world, "seed": s, "exit_status": rc, "hung": hung, "last_line": last_line(log_path),
                     "report": report is not None and "written_by" not in report,
                     "collisions": (report or {}).get("collisions"), "coverage_final": (report or {}).get("coverage_final"),
                     "leaked": leaked, "shm_new": shm_new, "wall_s": round(time.monotonic() - t0, 1)})
        print(f"[soak {i + 1}/{n}] {world} seed {s}: exit {rc}, coverage {rows[-1]['coverage_final']}, "
              f"collisions {rows[-1]['collisions']}, leaked {leaked or 'nothing'}", flush=True)
    return {"soak_runs": n, "soak_crashes": sum(r["exit_status"] != 0 or r["hung"] for r in rows),
            "soak_collisions": sum(r["collisions"] or 0 for r in rows),
            "soak_runs_without_report": sum(not r["report"] for r in rows),
            "leaked_processes": sum(len(r["leaked"]) for r in rows),
            # /dev/shm is the machine's: another program's files made during a run show here too
            "soak_shm_new": sorted({e for r in rows for e in r["shm_new"]}), "soak": rows}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default="", help="comma-separated subset of: " + ", ".join(CASES))
    ap.add_argument("--soak", type=int, default=0, help="N short explorations back to back (not in the default)")
    ap.add_argument("--seed", type=int, default=0, help="the soak's choice of worlds and seeds")
    ap.add_argument("--no-parallel", action="store_true")
    ap.add_argument("--no-bad-input", action="store_true")
    ap.add_argument("--copy-results", action="store_true", help="copy faults.json to docs/results/")
    ap.add_argument("--rescore", default="", help="run nothing: FILE's rows scored again (as_intended), FILE rewritten")
    a = ap.parse_args()
    if a.rescore:
        data = json.loads(Path(a.rescore).read_text())
        ran = [r for r in data["rows"] if "skipped" not in r]
        for r in ran:
            r.setdefault("harmed", r["coverage_final"] is not None and bool(r["coverage_fault_free"]) and
                         r["coverage_final"] < COVERAGE_KEPT * r["coverage_fault_free"]
                         or (r["collisions"] or 0) > 0)
            r["as_intended"] = as_intended(r)
        data["cases_as_intended"] = sum(r["as_intended"] for r in ran)
        data["cases_not_as_intended"] = [r["case"] for r in ran if not r["as_intended"]]
        Path(a.rescore).write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
        print(f"{a.rescore}: {data['cases_as_intended']} of {len(ran)} as intended; not: {data['cases_not_as_intended']}")
        return 0
    names = [c for c in a.cases.split(",") if c] if a.cases else list(CASES)
    unknown = [c for c in names if c not in CASES]
    if unknown:
        print(f"bench-faults: unknown case(s) {', '.join(unknown)}; choose from {', '.join(CASES)}")
        return 2
    # the fault-free references of the cases chosen first
    refs = sorted({reference_of(CASES[n][2]) for n in names}, key=list(CASES).index)
    names = refs + [n for n in names if n not in refs]
    OUT.mkdir(parents=True, exist_ok=True)
    t_start = time.monotonic()
    from common import commit
    started_at = commit()             # write() stamps HEAD at the end; the runs ran on this one
    rows, baselines = [], {}
    for name in names:
        row = run_case(name, baselines.get(reference_of(CASES[name][2])))
        if CASES[name][0] == "none":
            baselines[name] = {"coverage_final": row.get("coverage_final"), "collisions": row.get("collisions")}
        rows.append(row)
        print(f"[faults] {name}: {'SILENT ' if row.get('silent') else ''}{row.get('measured', row.get('skipped'))}",
              flush=True)
    ran = [r for r in rows if "skipped" not in r]
    # a full disk leaves no room for a report: there one clear line is the contract (issue 32, item 3)
    without_report = [r["case"] for r in ran if not r["report_written"] and r["case"] != "full_fs"]
    figures = {
        "cases": len(ran), "cases_skipped": [r["case"] for r in rows if "skipped" in r],
        "silent_failures": sum(r["silent"] for r in ran),
        "silent_cases": [r["case"] for r in ran if r["silent"]],
        "runs_without_report": len(without_report), "runs_without_report_cases": without_report,
        "cases_as_intended": sum(r["as_intended"] for r in ran),
        "cases_not_as_intended": [r["case"] for r in ran if not r["as_intended"]],
        "hung_runs": sum(r["hung"] for r in ran),
        "fault_leaked_processes": sum(len(r["leaked_processes"]) + r["port_still_listening"] for r in ran),
        "budget_s": BUDGET_S, "world": "house", "rows": rows, "commit_at_start": started_at,
    }
    if not a.no_parallel:
        figures.update(parallel_runs())
        print(f"[faults] parallel runs ok: {figures['parallel_runs_ok']}", flush=True)
    if not a.no_bad_input:
        figures.update(bad_input())
    figures["wall_s"] = round(time.monotonic() - t_start, 1)           # the default run's
    if a.soak:
        t_soak = time.monotonic()
        figures.update(soak(a.soak, a.seed))
        figures["soak_wall_s"] = round(time.monotonic() - t_soak, 1)
    figures["load_avg_1min_end"] = round(os.getloadavg()[0], 2)
    out = write("faults", {k: v for k, v in figures.items()})
    print("\n| case | intended | measured | named | report | coverage | collisions | silent |")
    for r in ran:
        print(f"| {r['case']} | {r['intended_kind']} | {r['measured_kind']} (exit {r['exit_status']}) | "
              f"{r['cause_named']} | {r['report_written']} | {r['coverage_final']} | {r['collisions']} | {r['silent']} |")
    if a.copy_results:
        from common import commit
        RESULTS.mkdir(parents=True, exist_ok=True)
        dest = RESULTS / f"faults-{time.strftime('%Y-%m-%d')}-{commit()}.json"
        shutil.copy(out, dest)
        print(f"-> {dest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
