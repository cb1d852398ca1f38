"""What the robot's core may import: the same code runs in the simulator and on a real robot.

The core is every module under src/turtlebot_recon except sim/ and evaluation/ (simulation and
scoring only: they may use the simulator) and ros/ (the rospy layer). It never imports the
simulator (turtlebot_recon.sim, pybullet); a map_server map is mapping's, and sim builds on it.
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


def core_files():
    return [p for p in sorted(CORE.rglob("*.py"))
            if p.relative_to(CORE).parts[0] not in SIM_ONLY + ("ros",)]


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
    offenders = {}
    for p in core_files():
        sim = sorted(m for m in imports_of(p.read_text(), package_of(p)) if under(m, SIM_MODULES))
        if sim:
            offenders[str(p.relative_to(CORE))] = sim
    assert offenders == {}
