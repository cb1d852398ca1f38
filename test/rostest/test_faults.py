"""Faults during a run, the fast cases of `make bench-faults` (docs/faults.md): a stateless node
killed is restarted and the run goes on, named; the mapper and the tag tracker killed are
restarted and go on from what they saved, which the run's final map and tags keep; a run
directory on a full disk gives one clear line; a lidar that never publishes is named in
report.json's finished_reason."""
import json
import os
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest

import numpy as np

from conftest import node_pid
from turtlebot_recon.mapping.map_io import load_map
from turtlebot_recon.mapping.resume import decided, known_cells, load_resume
from turtlebot_recon.perception.tracker import load_tags_yaml

TOP = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(run_dir: Path, *args: str, port: int) -> tuple:
    """tools/launch as `make run` runs it (a master of its own on ``port``), the burger mapping
    unless ``args`` say otherwise; (Popen, its lines)."""
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


def wait_started(proc, lines, timeout_s: float = 120.0, text: str = "explorer: started") -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None and not any(text in ln for ln in lines):
        time.sleep(0.3)
    assert proc.poll() is None and any(text in ln for ln in lines), "".join(lines[-20:])


def wait_for_file(path: Path, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not path.exists():
        time.sleep(0.3)
    assert path.exists(), path


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


def killed_and_resumed(proc, lines, node: str, port: int, what: str, run_dir: Path, timeout_s: float = 180.0) -> tuple:
    """SIGKILL ``node``; the run must go on to its budget with the node restarted, resuming
    from ``what`` it saved. (the run's lines, its report.json)."""
    pid = node_pid(node, port)
    assert pid is not None, "".join(lines[-20:])
    os.kill(pid, signal.SIGKILL)
    out = end(proc, lines, timeout_s=timeout_s)
    assert proc.returncode == 0, out[-3000:]
    assert (f"[run] node {node} exited with status -9: restarting it (restart 1 of at most 3; it resumes from "
            f"{what})") in out, out[-3000:]
    report = json.loads((run_dir / "report.json").read_text())
    assert report["node_respawns"] == [f"{node} exited with status -9, restarted"]
    return out, report


def test_a_killed_mapper_resumes_from_its_autosave_and_the_final_map_keeps_it(tmp_path):
    port = free_port()
    proc, lines = start(tmp_path, "budget:=60", port=port)
    wait_started(proc, lines)
    resume = tmp_path / "map.resume.npz"
    wait_for_file(resume)                             # the first autosave (10 s sim)
    time.sleep(2.0)
    with np.load(resume) as f:
        key = str(f["key"])                           # this launch's resume_key
    before_logodds, res, before_origin, _ = load_resume(resume, key)
    out, report = killed_and_resumed(proc, lines, "mapper", port, "the map it saved", tmp_path)
    assert f"mapper: resuming from {resume}, saved at " in out, out[-3000:]
    assert report["finished_reason"] == "time budget 60 s spent", report["finished_reason"]
    # the map the run ends with (the evaluator's ~save_map of the resumed mapper) holds every
    # cell the dead mapper had saved
    occ, res_final, origin = load_map(tmp_path / "map.yaml")
    before = known_cells(decided(before_logodds), res, before_origin)   # the cells a saved map keeps
    after = known_cells(occ >= 0, res_final, origin)
    assert len(before) > 2000 and len(before - after) <= 0.01 * len(before), (len(before), len(before - after))
    assert len(after) > len(before)                   # and the resumed mapper went on mapping
    assert report["collisions"] == 0


def test_a_killed_tag_tracker_resumes_from_its_tags_and_the_final_list_keeps_them(tmp_path):
    port = free_port()
    proc, lines = start(tmp_path, "budget:=150", "robot:=turtlebot3_waffle_pi", "mission:=tags", port=port)
    wait_started(proc, lines, timeout_s=240.0, text="tag_tracker: confirmed")
    tags_yaml = tmp_path / "tags.yaml"
    wait_for_file(tags_yaml)                          # the autosave (at most 2 s sim after)
    time.sleep(1.0)
    before = {(t.family, t.id) for t in load_tags_yaml(tags_yaml.read_text())}
    assert before
    out, _ = killed_and_resumed(proc, lines, "tag_tracker", port, "the tags it saved", tmp_path,
                                timeout_s=300.0)
    assert f"tag_tracker: resuming from {tags_yaml}, saved by a tracker of this run" in out, out[-3000:]
    after = {(t.family, t.id) for t in load_tags_yaml(tags_yaml.read_text())}
    assert before <= after, (before, after)           # the tags found before the kill are in the final list


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
    # the nodes' saves on the full disk (the mapper's autosave and its last save, the tracker's)
    # are one line each, no traceback
    assert "Traceback" not in out, out[-3000:]
    assert out.count("mapper: cannot autosave the map") <= 1, out[-3000:]


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
