"""What the package's modules may import.

- Nothing under src/turtlebot_recon but ros/ (the thin rospy layer) imports rospy: ROS supplies
  time, waiting and I/O in the nodes.
- The robot's core, every module there except sim/ and evaluation/ (simulation and scoring only:
  they may use the simulator) and ros/, never imports the simulator (turtlebot_recon.sim,
  pybullet): the same code runs on a real robot. A map_server map is mapping's; sim builds on it.

Imports are read with ``ast`` and relative ones resolved, so ``from ..sim import x``,
``from .. import sim`` and an import inside a function all count.
"""
import ast
from pathlib import Path

CORE = Path(__file__).resolve().parents[2] / "src" / "turtlebot_recon"
SIM_ONLY = ("sim", "evaluation")
SIM_MODULES = ("turtlebot_recon.sim", "pybullet", "pybullet_data", "pybullet_utils")


def imports_of(source: str, package: str) -> set:
    """Absolute names of the modules ``source`` (a module of ``package``) imports;
    ``from a import b`` gives both a and a.b (b may be a module)."""
    parts = package.split(".")
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = parts[:len(parts) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            names.add(module)
            names.update(f"{module}.{alias.name}" for alias in node.names)
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
    """{file: the banned modules it imports} for the files that import any."""
    found = {}
    for p in files:
        names = sorted(m for m in imports_of(p.read_text(), package_of(p)) if under(m, banned))
        if names:
            found[str(p.relative_to(CORE))] = names
    return found


def under(module: str, roots) -> bool:
    return any(module == r or module.startswith(r + ".") for r in roots)


def test_relative_imports_resolve_to_absolute_names():
    source = ("from ..sim.world import World\nfrom .. import sim\nfrom . import grid\n"
              "import turtlebot_recon.sim\n"
              "def f():\n    import pybullet as pb\n")
    names = imports_of(source, "turtlebot_recon.mapping")     # as mapping/map_io.py
    assert {"turtlebot_recon.sim.world", "turtlebot_recon.sim", "turtlebot_recon.mapping.grid",
            "pybullet"} <= names
    assert sorted(m for m in names if under(m, SIM_MODULES)) == [
        "pybullet", "turtlebot_recon.sim", "turtlebot_recon.sim.world",
        "turtlebot_recon.sim.world.World"]
    assert package_of(CORE / "mapping" / "map_io.py") == "turtlebot_recon.mapping"
    assert package_of(CORE / "geometry.py") == "turtlebot_recon"


def test_core_is_what_it_should_be():
    tops = {p.relative_to(CORE).parts[0] for p in core_files()}
    assert {"mapping", "planning", "exploration", "control", "behavior", "geometry.py"} <= tops
    assert not tops & {"sim", "evaluation", "ros"}


def test_core_never_imports_the_simulator():
    assert offenders(core_files(), SIM_MODULES) == {}


def test_nothing_but_ros_imports_rospy():
    assert offenders(files_outside("ros"), ("rospy",)) == {}
