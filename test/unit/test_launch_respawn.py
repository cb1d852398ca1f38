"""tools/launch's Watcher with respawnable nodes (docs/faults.md): roslaunch reports a dead
respawnable process every 0.1 s until it restarts it; each death is one restart, said once,
and the death after MAX_RESPAWNS restarts ends the run like any other failure."""
import importlib.machinery
import importlib.util
import io
from pathlib import Path

TOP = Path(__file__).resolve().parents[2]


def tools_launch():
    loader = importlib.machinery.SourceFileLoader("tools_launch", str(TOP / "tools" / "launch"))
    spec = importlib.util.spec_from_loader("tools_launch", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


class Proc:
    """The process monitor's process: its spawn count grows with each restart."""

    def __init__(self):
        self.spawn_count = 1


def watcher_with(launch, proc):
    w = launch.Watcher("evaluator", "run")
    w.watch_respawns(["navigator"], lambda name: proc if name == "navigator-5" else None)
    return w


def test_one_death_is_one_restart_however_often_roslaunch_reports_it():
    launch = tools_launch()
    launch.TERMINAL = out = io.StringIO()
    proc = Proc()
    w = watcher_with(launch, proc)
    for _ in range(10):                       # 1 s of respawn_delay: reported every 0.1 s
        w.process_died("navigator-5", -9)
    assert w.respawns == [("navigator", -9)]
    assert w.verdict() is None                # the run goes on
    assert out.getvalue().splitlines() == [
        "[run] node navigator exited with status -9: restarting it (restart 1 of at most 3; "
        "it holds no state worth keeping)"]


def test_a_node_that_keeps_dying_ends_the_run():
    launch = tools_launch()
    launch.TERMINAL = io.StringIO()
    proc = Proc()
    w = watcher_with(launch, proc)
    for death in range(launch.MAX_RESPAWNS):
        w.process_died("navigator-5", 1)
        proc.spawn_count += 1                 # roslaunch restarted it
        assert w.verdict() is None, death
    w.process_died("navigator-5", 1)          # one death too many
    assert len(w.respawns) == launch.MAX_RESPAWNS
    assert w.verdict() == ("failed", "navigator-5", 1)


def test_a_node_not_marked_respawn_still_ends_the_run():
    launch = tools_launch()
    launch.TERMINAL = io.StringIO()
    w = watcher_with(launch, Proc())
    w.process_died("mapper-3", -9)
    assert w.respawns == [] and w.verdict() == ("failed", "mapper-3", -9)


def test_a_node_that_resumes_says_so_when_restarted():
    launch = tools_launch()
    launch.TERMINAL = out = io.StringIO()
    w = launch.Watcher("evaluator", "run")
    w.watch_respawns(["mapper", "tag_tracker"], lambda name: Proc())
    w.process_died("mapper-2", -9)
    w.process_died("tag_tracker-7", -9)
    assert w.verdict() is None
    assert out.getvalue().splitlines() == [
        "[run] node mapper exited with status -9: restarting it (restart 1 of at most 3; "
        "it resumes from the map it saved)",
        "[run] node tag_tracker exited with status -9: restarting it (restart 1 of at most 3; "
        "it resumes from the tags it saved)"]


def test_the_launch_files_respawn_the_nodes_that_can_resume_only():
    """docs/faults.md's decisions: the tag detector and the navigator (no state worth keeping),
    the mapper and the tag tracker (they resume from the files they save as they go, under the
    launch's resume_key) are respawned; every other node of the stack ends the run when it dies."""
    import xml.etree.ElementTree as ET
    respawned, keyed = {}, set()
    for path in sorted((TOP / "launch").glob("*.launch")):
        for node in ET.parse(path).getroot().iter("node"):
            if node.get("respawn") == "true":
                respawned[node.get("name")] = float(node.get("respawn_delay", "0"))
                if any(p.get("name") == "resume_key" and p.get("value") == "$(anon run)" for p in node.iter("param")):
                    keyed.add(node.get("name"))
    assert respawned == {"tag_detector": 1.0, "navigator": 1.0, "mapper": 1.0, "tag_tracker": 1.0}
    assert keyed == {"mapper", "tag_tracker"}      # a restart finds its own launch's files only
    launch = tools_launch()
    assert set(launch.RESUMES) == keyed


def test_the_last_error_is_the_nodes_own_not_a_traceback_rospy_logs_after_it(tmp_path):
    """A fresh machine's full-disk run: the evaluator said why (rospy.logerr, logger rosout), then
    rospy's connection teardown logged a traceback (logger rospy.internal) at shutdown; the
    line tools/launch ends the run with must be the node's reason."""
    launch = tools_launch()
    (tmp_path / "evaluator-7.log").write_text(
        "[rosout][INFO] 2026-12-07 04:10:01,000: evaluator: finishing at t=20.0 s sim\n"
        "[rosout][ERROR] 2026-12-07 04:10:03,732: evaluator: cannot write the run output to /r: "
        "[Errno 28] No space left on device\n"
        "[rospy.internal][ERROR] 2026-12-07 04:10:03,900: Traceback (most recent call last):\n"
        "  File \"/usr/lib/python3/dist-packages/rospy/impl/tcpros_base.py\", line 750, in close\n"
        "OSError: [Errno 9] Bad file descriptor\n"
        "[rosout][ERROR] 2026-12-07 04:10:04,000: Traceback (most recent call last):\n"   # registration's
        "  File \"/usr/lib/python3/dist-packages/rospy/impl/registration.py\", line 154, in notify_added\n")
    assert launch.last_error("evaluator-7", str(tmp_path)) == \
        "evaluator: cannot write the run output to /r: [Errno 28] No space left on device"
    # a node that said nothing itself: rospy's own error is still better than nothing
    (tmp_path / "mapper-4.log").write_text(
        "[rospy.internal][ERROR] 2026-12-07 04:10:03,900: Unable to report rosout\n")
    assert launch.last_error("mapper-4", str(tmp_path)) == "Unable to report rosout"
