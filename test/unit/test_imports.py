"""What the package's modules may import.

- Nothing under src/turtlebot_recon but ros/ (the thin rospy layer) imports ROS: no rospy,
  rosbag, genpy, roslib, rospkg, tf / tf2_ros, actionlib, no message or service package
  (``*_msgs``, ``*_srvs``, turtlebot_recon.msg / .srv) and not the ros/ layer itself: ROS
  supplies time, waiting and I/O in the nodes and in ros/.
- The robot's core, every module there except sim/ and evaluation/ (simulation and scoring only:
  they may use the simulator) and ros/, never imports the simulator (turtlebot_recon.sim,
  pybullet): the same code runs on a real robot. A map_server map is mapping's; sim builds on it.
- The package's modules import each other without a cycle.

Imports are read with ``ast`` and relative ones resolved, so ``from ..sim import x``,
``from .. import sim``, an import inside a function and one under ``if TYPE_CHECKING:`` all
count: a cycle hidden from the interpreter by a function-level or TYPE_CHECKING import is still
two modules that cannot be read, tested or moved apart.
"""
import ast
import re
from pathlib import Path
from typing import Dict, List, Set

CORE = Path(__file__).resolve().parents[2] / "src" / "turtlebot_recon"
SIM_ONLY = ("sim", "evaluation")
SIM_MODULES = ("turtlebot_recon.sim", "pybullet", "pybullet_data", "pybullet_utils")
ROS_MODULES = ("rospy", "rosbag", "genpy", "roslib", "rospkg", "rosgraph", "tf", "tf2_ros", "tf2_py",
               "tf_conversions", "actionlib", "message_filters", "cv_bridge",
               "turtlebot_recon.msg", "turtlebot_recon.srv", "turtlebot_recon.ros")
MESSAGE_PACKAGE = re.compile(r"[A-Za-z0-9_]+_(msgs|srvs)$")    # sensor_msgs, std_srvs, kobuki_msgs...


def import_statements(source: str, package: str) -> List[tuple]:
    """(module, names) of every import in ``source`` (a module of ``package``), relative ones
    made absolute: ``import a.b`` gives ("a.b", ()), ``from a import b, c`` ("a", ("b", "c"))."""
    parts = package.split(".")
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(alias.name, ()) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = parts[:len(parts) - node.level + 1] if node.level else []
            found.append((".".join(base + ([node.module] if node.module else [])),
                          tuple(alias.name for alias in node.names)))
    return found


def imports_of(source: str, package: str) -> set:
    """Absolute names of the modules ``source`` (a module of ``package``) imports;
    ``from a import b`` gives both a and a.b (b may be a module)."""
    names = set()
    for module, members in import_statements(source, package):
        names.add(module)
        names.update(f"{module}.{name}" for name in members)
    return names


def package_of(path: Path) -> str:
    """The package a file under src/turtlebot_recon belongs to (an __init__.py: its own)."""
    return ".".join(("turtlebot_recon",) + path.relative_to(CORE).parent.parts)


def files_outside(*tops):
    """The package's .py files, but those under the top-level folders ``tops``."""
    return [p for p in sorted(CORE.rglob("*.py")) if p.relative_to(CORE).parts[0] not in tops]


def core_files():
    return files_outside(*SIM_ONLY, "ros")


def offenders(files, banned) -> dict:
    """{file: the modules it imports that ``banned(module)`` is true of} for the files that import any."""
    found = {}
    for p in files:
        names = sorted(m for m in imports_of(p.read_text(), package_of(p)) if banned(m))
        if names:
            found[str(p.relative_to(CORE))] = names
    return found


def under(module: str, roots) -> bool:
    return any(module == r or module.startswith(r + ".") for r in roots)


def is_sim(module: str) -> bool:
    return under(module, SIM_MODULES)


def is_ros(module: str) -> bool:
    return under(module, ROS_MODULES) or bool(MESSAGE_PACKAGE.match(module.split(".")[0]))


def module_of(path: Path) -> str:
    """The module a file under src/turtlebot_recon is (an __init__.py: its package)."""
    return package_of(path) if path.name == "__init__.py" else f"{package_of(path)}.{path.stem}"


def import_graph(sources: Dict[str, str]) -> Dict[str, Set[str]]:
    """{module: the modules of ``sources`` it imports} for sources {module name: text} (a
    package under its own name). ``from a import b`` is an edge to a.b where that is one of
    the modules, else to a (b is a name defined in a's __init__); any other name is cut back to
    the longest prefix that is one of the modules; modules outside ``sources`` are left out."""
    packages = {m for m in sources if any(o.startswith(m + ".") for o in sources)}
    graph = {}
    for module, text in sources.items():
        package = module if module in packages else module.rpartition(".")[0]
        targets = []
        for imported, members in import_statements(text, package):
            targets += [f"{imported}.{m}" if f"{imported}.{m}" in sources else imported for m in members] \
                or [imported]
        edges = set()
        for name in targets:
            while name and name not in sources:
                name = name.rpartition(".")[0]
            if name and name != module:
                edges.add(name)
        graph[module] = edges
    return graph


def cycles(graph: Dict[str, Set[str]]) -> List[List[str]]:
    """One cycle (a list of modules, the first repeated at the end) through every strongly
    connected set of two or more modules (Tarjan's algorithm, iterative)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                members = set()
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    members.add(w)
                    if w == v:
                        break
                if len(members) > 1:
                    found.append(_cycle_through(v, members, graph))
    return found


def _cycle_through(start: str, members: Set[str], graph) -> List[str]:
    """The shortest path start -> ... -> start inside ``members`` (breadth first)."""
    came_from = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & members):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(came_from[path[-1]])
                    return [start] + path[::-1][1:] + [start] if v != start else [start, start]
                if w not in came_from:
                    came_from[w] = v
                    nxt.append(w)
        frontier = nxt
    raise AssertionError(f"{start} is in no cycle of {sorted(members)}")


def package_sources() -> Dict[str, str]:
    return {module_of(p): p.read_text() for p in sorted(CORE.rglob("*.py"))}


def test_relative_imports_resolve_to_absolute_names():
    source = ("from ..sim.world import World\nfrom .. import sim\nfrom . import grid\n"
              "import turtlebot_recon.sim\n"
              "def f():\n    import pybullet as pb\n")
    names = imports_of(source, "turtlebot_recon.mapping")     # as mapping/map_io.py
    assert {"turtlebot_recon.sim.world", "turtlebot_recon.sim", "turtlebot_recon.mapping.grid",
            "pybullet"} <= names
    assert sorted(m for m in names if is_sim(m)) == [
        "pybullet", "turtlebot_recon.sim", "turtlebot_recon.sim.world",
        "turtlebot_recon.sim.world.World"]
    assert package_of(CORE / "mapping" / "map_io.py") == "turtlebot_recon.mapping"
    assert package_of(CORE / "geometry.py") == "turtlebot_recon"


def test_core_is_what_it_should_be():
    tops = {p.relative_to(CORE).parts[0] for p in core_files()}
    assert {"mapping", "planning", "exploration", "control", "behavior", "geometry.py"} <= tops
    assert not tops & {"sim", "evaluation", "ros"}


def test_core_never_imports_the_simulator():
    assert offenders(core_files(), is_sim) == {}


def test_nothing_but_ros_imports_ros():
    assert offenders(files_outside("ros"), is_ros) == {}


def test_the_ros_ban_catches_each_way_in():
    source = ("import rosbag\nfrom genpy import Time\nfrom sensor_msgs.msg import LaserScan\n"
              "from ..msg import TagDetectionArray\nfrom ..ros.bags import BagReader\n"
              "from std_srvs.srv import Trigger\nimport tf2_ros\n"
              "def f():\n    from kobuki_msgs.msg import BumperEvent\n"
              "import numpy\nfrom ..geometry import wrap_angle\nimport tf_free_module\n")
    names = imports_of(source, "turtlebot_recon.slam")       # as slam/logs.py
    banned = {m for m in names if is_ros(m)}
    assert {"rosbag", "genpy", "sensor_msgs.msg", "turtlebot_recon.msg", "turtlebot_recon.ros.bags",
            "std_srvs.srv", "tf2_ros", "kobuki_msgs.msg"} <= banned
    assert not banned & {"numpy", "turtlebot_recon.geometry", "turtlebot_recon.geometry.wrap_angle",
                         "tf_free_module"}


def test_import_graph_resolves_modules_and_packages():
    sources = {
        "p": "from .s import REGISTRY\n",
        "p.s": "from .a import A\nfrom .. import t\n",                 # a package
        "p.s.a": "from . import Context\nimport p.t\ndef f():\n    from p.u import g\n",
        "p.t": "import numpy as np\nfrom p import u\n",
        "p.u": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .s.a import A\n",
    }
    graph = import_graph(sources)
    assert graph == {"p": {"p.s"}, "p.s": {"p.s.a", "p.t"}, "p.s.a": {"p.s", "p.t", "p.u"},
                     "p.t": {"p.u"}, "p.u": {"p.s.a"}}
    found = cycles(graph)
    assert len(found) == 1                     # one strongly connected set: p.s, p.s.a, p.t, p.u
    cycle = found[0]
    assert cycle[0] == cycle[-1] and set(cycle) <= {"p.s", "p.s.a", "p.t", "p.u"}
    assert all(b in graph[a] for a, b in zip(cycle, cycle[1:]))
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_no_import_cycles():
    graph = import_graph(package_sources())
    assert "turtlebot_recon.exploration.context" in graph["turtlebot_recon.exploration.goals"]
    found = cycles(graph)
    assert found == [], "import cycles:\n" + "\n".join(" -> ".join(c) for c in found)
