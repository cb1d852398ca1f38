"""Faults during a run, the fast cases of `make bench-faults` (docs/faults.md): a stateless node
killed is restarted and the run goes on, named; a run directory on a full disk gives one clear
line; a lidar that never publishes is named in report.json's finished_reason."""
import json
import os
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest

from conftest import node_pid

TOP = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(run_dir: Path, *args: str, port: int) -> tuple:
    """tools/launch as `make run` runs it (a master of its own on ``port``); (Popen, its lines)."""
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1")
    env.pop("ROS_HOSTNAME", None)
    env.pop("TURTLEBOT_RECON_MASTER", None)
    proc = subprocess.Popen([str(TOP / "tools" / "launch"), "--tag", "run", "--done", "evaluator", "--report",
                             str(run_dir / "report.json"), "explore_sim.launch", "world:=house",
                             "robot:=turtlebot3_burger", "mission:=map", "rtf:=0", f"output:={run_dir}",
                             "end_with_evaluator:=false", *args],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    lines = []
    threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True).start()
    return proc, lines


def wait_started(proc, lines, timeout_s: float = 120.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None and not any("explorer: started" in ln for ln in lines):
        time.sleep(0.3)
    assert proc.poll() is None, "".join(lines[-20:])


def end(proc, lines, timeout_s: float = 180.0) -> str:
    try:
        proc.wait(timeout=timeout_s)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    time.sleep(0.5)                                    # the reader thread's last lines
    return "".join(lines)


def test_a_killed_navigator_is_restarted_and_the_run_goes_on(tmp_path):
    port = free_port()
    proc, lines = start(tmp_path, "budget:=60", port=port)
    wait_started(proc, lines)
    time.sleep(3.0)                                   # a goal or two under way
    pid = node_pid("navigator", port)
    assert pid is not None, "".join(lines[-20:])
    os.kill(pid, signal.SIGKILL)
    out = end(proc, lines)
    last = out.strip().splitlines()[-1]
    assert proc.returncode == 0, out[-3000:]
    assert ("[run] node navigator exited with status -9: restarting it (restart 1 of at most 3; it holds no "
            "state worth keeping)") in out, out[-3000:]
    assert last.endswith("; restarted during the run: navigator (status -9)"), last
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["node_respawns"] == ["navigator exited with status -9, restarted"]
    assert report["finished_reason"] == "time budget 60 s spent", report["finished_reason"]
    assert node_pid("navigator", port) is None        # the restarted one ended with the run
    # the new navigator drove: the robot got on after the kill (coverage of a first room)
    assert report["coverage_final"] > 0.2 and report["collisions"] == 0


@pytest.fixture
def small_disk(tmp_path):
    """A 2 MiB tmpfs (never the machine's disk); skipped where mounting is not allowed."""
    mount = tmp_path / "run"
    mount.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)],
                                           capture_output=True).returncode:
        pytest.skip("mounting a tmpfs needs root")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], capture_output=True)


def fill(directory: Path) -> None:
    try:
        with open(directory / "filler", "wb") as f:
            while True:
                f.write(b"\0" * 65536)
                f.flush()
    except OSError:
        pass


def test_a_full_run_directory_is_refused_before_any_node_starts(small_disk):
    fill(small_disk)
    proc, lines = start(small_disk, port=free_port())
    out = end(proc, lines, timeout_s=60)
    assert proc.returncode == 2 and len(out.strip().splitlines()) == 1, out
    assert out.startswith(f"[run] refused: cannot write in the run directory {small_disk}: No space left on device"), out


def test_a_disk_that_fills_during_the_run_ends_it_with_one_line_naming_it(small_disk):
    proc, lines = start(small_disk, "budget:=20", port=free_port())
    wait_started(proc, lines)
    fill(small_disk)
    out = end(proc, lines)
    last = out.strip().splitlines()[-1]
    assert proc.returncode == 1, out[-3000:]
    assert last.startswith(f"[run] failed: evaluator ended without writing {small_disk}/report.json: evaluator: "
                           f"cannot write the run output to {small_disk}: [Errno 28] No space left on device"), last


def test_a_lidar_that_never_publishes_is_named_in_the_report(tmp_path):
    """The bridge's scans go to a topic nobody relays (bench-faults' injector is not started):
    the mapper's map stands still, and the explorer's end names the lidar (before: a run with
    no scan at all ended "done" at 0 % coverage, reason "no reachable frontier")."""
    proc, lines = start(tmp_path, "budget:=120", "bridge_scan:=scan_raw", port=free_port())
    out = end(proc, lines)
    assert proc.returncode == 0, out[-3000:]
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["finished_reason"].startswith("no scan on /scan since the start (is the lidar publishing?); "), \
        report["finished_reason"]
    assert "explorer: no scan on /scan since the start (is the lidar publishing?): the exploration ended" in out
