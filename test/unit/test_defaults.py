"""Each default once: config/*.yaml declares every node parameter's default, and nothing that
feeds a node repeats or contradicts it unless a comment says why.

What is read: every launch/*.launch, the Makefile and src/native/*.cpp (the pybind11 bindings).

The comment convention, checked here:
- launch files: an ``<arg>`` whose value reaches a parameter that a node's loaded YAML declares
  defaults to ``''`` (the launch file then sets the parameter only when given:
  ``<param if="$(eval arg('x') != '')" ...>``), or has no default, or has the XML comment right
  before it starting with ``on purpose:`` and saying why it differs from the YAML. The same holds
  for a literal ``<param value>`` and for the value an ``<include>`` passes down.
- ``robot`` and ``world`` are chosen per run: no node's YAML declares them, launch pieces that
  others include take them without a default, and the top-level launch files that default them
  all give the same value, under a comment starting with ``one default:``.
- an argument of the same name in explore_sim.launch and explore_robot.launch sets the same
  parameters of the nodes both start (``budget`` once set different ones).
- Makefile: a variable passed to a launch argument has no default of its own unless the line
  above it is a ``# on purpose:`` comment; no ``name:=literal`` reaches a YAML parameter; the
  help text does not print such a variable's value.
- bindings: no ``py::arg(...) = value``; only ``= py::none()`` (an input that may be absent)
  stays. The values come from the Python settings, which come from the YAML.
- C++: a default in a parameter struct of include/ that a YAML key also declares equals it
  (the bindings pass every value; the struct's defaults serve C++ callers), and every
  ``occupied_threshold`` is map_server's (mapping.map_io.OCCUPIED_THRESH).
- Python: no ``occupied_threshold`` defaults to a number (mapping.map_io.OCCUPIED_THRESH is the
  one value).
"""
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

TOP = Path(__file__).resolve().parents[2]
LAUNCH, CONFIG = TOP / "launch", TOP / "config"
# the launch files a user starts; every other one is a piece that these include
TOP_LEVEL = ("sim.launch", "run_sim.launch", "explore_sim.launch", "explore_robot.launch")
CHOSEN_PER_RUN = ("robot", "world")
ON_PURPOSE, ONE_DEFAULT = "on purpose:", "one default:"


# ---------------------------------------------------------------------------- launch files

def parse(path: Path) -> ET.Element:
    return ET.parse(path, ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))).getroot()


def comment_before(parent: ET.Element, child: ET.Element) -> str:
    """The text of the XML comment right before ``child`` among ``parent``'s children, else ''."""
    kids = list(parent)
    i = kids.index(child)
    if i > 0 and kids[i - 1].tag is ET.Comment:
        return (kids[i - 1].text or "").strip()
    return ""


def args_in(text: str, names) -> set:
    """The argument names of ``names`` that the substitution text refers to: $(arg x), arg('x')
    and, inside $(eval ...), a bare name."""
    found = set()
    for m in re.finditer(r"\$\(arg (\w+)\)|arg\('(\w+)'\)", text or ""):
        found.add(m.group(1) or m.group(2))
    for expr in re.findall(r"\$\(eval (.*)\)", text or ""):
        found |= {w for w in re.findall(r"\b[a-z_]\w*\b", re.sub(r"'[^']*'", "", expr)) if w in names}
    return found


def yaml_key(loads: list, name: str):
    """(file, key path, value) of parameter ``name`` (relative to the node) in the YAML files the
    node loads ([(file, ns)]), or None."""
    for file, ns in loads:
        parts = name.split("/")
        if ns:
            prefix = ns.split("/")
            if parts[:len(prefix)] != prefix:
                continue
            parts = parts[len(prefix):]
        data = yaml.safe_load((CONFIG / file).read_text())
        for key in parts:
            if not isinstance(data, dict) or key not in data:
                break
            data = data[key]
        else:
            return file, "/".join(parts), data
    return None


def is_literal(value: str) -> bool:
    return "$(" not in value


class Launch:
    """One launch file: its arguments and, for each, the YAML parameters its value reaches
    (node name, parameter, YAML file, key), through <param>, <rosparam> and <include>."""

    cache: dict = {}

    @classmethod
    def get(cls, name: str) -> "Launch":
        if name not in cls.cache:
            cls.cache[name] = Launch(name)
        return cls.cache[name]

    def __init__(self, name: str):
        self.name, self.root = name, parse(LAUNCH / name)
        self.args = {a.get("name"): a for a in self.root.iter("arg") if a.get("value") is None}
        self.parent = {c: p for p in self.root.iter() for c in p}
        self.sets = {a: set() for a in self.args}
        self.literals = []     # (where, comment, literal text, YAML value) of literal params
        self.nodes = set()
        for node in self.root.iter("node"):
            self._node(node)
        for inc in self.root.iter("include"):
            self._include(inc)
        # an argument whose default is another's value (map_file: $(arg output)/map) passes it on
        for arg, el in self.args.items():
            m = re.fullmatch(r"\$\(arg (\w+)\)[^$]*", el.get("default", ""))
            if m and m.group(1) in self.sets:
                self.sets[m.group(1)] |= self.sets[arg]

    def _node(self, node: ET.Element) -> None:
        name = node.get("name")
        self.nodes.add(name)
        loads = [(Path(r.get("file")).name, r.get("ns", "")) for r in node.findall("rosparam")
                 if r.get("command") == "load"]
        for el in node:
            if el.tag == "param":
                param, value = el.get("name"), el.get("value", "")
            elif el.tag == "rosparam" and el.get("param"):
                param, value = el.get("param"), el.text or ""
            else:
                continue
            found = yaml_key(loads, param)
            if found is None:
                continue
            for a in args_in(value, self.args):
                self.sets[a].add((name, param) + found[:2])
            if is_literal(value):
                self.literals.append((f"{self.name}: {name}/{param}", comment_before(node, el), value, found[2]))

    def _include(self, inc: ET.Element) -> None:
        piece = Launch.get(Path(inc.get("file")).name)
        for a in inc.findall("arg"):
            reached = piece.sets.get(a.get("name"), set())
            for mine in args_in(a.get("value", ""), self.args):
                self.sets[mine] |= reached
            value = a.get("value", "")
            if reached and value and is_literal(value):
                self.literals.append((f"{self.name}: include {piece.name} {a.get('name')}",
                                      comment_before(inc, a), value, sorted(reached)))
        self.nodes |= piece.nodes

    def comment(self, arg: str) -> str:
        el = self.args[arg]
        return comment_before(self.parent[el], el)


LAUNCH_FILES = sorted(p.name for p in LAUNCH.glob("*.launch"))


def test_the_top_level_list_names_launch_files():
    assert set(TOP_LEVEL) <= set(LAUNCH_FILES)


@pytest.mark.parametrize("name", LAUNCH_FILES)
def test_launch_arguments_leave_yaml_parameters_to_the_yaml(name):
    launch, bad = Launch.get(name), []
    for arg, reached in launch.sets.items():
        default = launch.args[arg].get("default")
        if arg in CHOSEN_PER_RUN or not reached or default in (None, ""):
            continue
        if not launch.comment(arg).startswith(ON_PURPOSE):
            params = ", ".join(sorted({f"{f}: {k}" for _, _, f, k in reached}))
            bad.append(f"{arg} default {default!r} (YAML: {params}): default to '' or say why "
                       f"in an '<!-- {ON_PURPOSE} ... -->' line above it")
    assert bad == [], f"{name}:\n" + "\n".join(bad)


@pytest.mark.parametrize("name", LAUNCH_FILES)
def test_literal_parameter_values_are_commented(name):
    bad = [f"{where} = {value!r} (YAML: {yaml_value!r})" for where, comment, value, yaml_value
           in Launch.get(name).literals if not comment.startswith(ON_PURPOSE)]
    assert bad == []


def test_robot_and_world_have_one_default_in_the_top_level_launch_files():
    defaults = {}
    for name in LAUNCH_FILES:
        launch = Launch.get(name)
        for arg in CHOSEN_PER_RUN:
            if arg not in launch.args or launch.args[arg].get("default") is None:
                continue
            assert name in TOP_LEVEL, f"{name} is included by others: {arg} must come without a default"
            first = min((a for a in CHOSEN_PER_RUN if a in launch.args),
                        key=lambda a: list(launch.root).index(launch.args[a]))
            assert launch.comment(first).startswith(ONE_DEFAULT), \
                f"{name}: say where {arg}'s one default lives ('<!-- {ONE_DEFAULT} ... -->' above it)"
            defaults.setdefault(arg, {})[name] = launch.args[arg].get("default")
    for arg, where in defaults.items():
        assert len(set(where.values())) == 1, f"{arg} defaults differ: {where}"
    for path in CONFIG.glob("*.yaml"):
        data = yaml.safe_load(path.read_text())
        assert not set(CHOSEN_PER_RUN) & set(data), f"{path.name} defaults {set(CHOSEN_PER_RUN) & set(data)}"


def test_explore_sim_and_explore_robot_arguments_mean_one_thing():
    sim, robot = Launch.get("explore_sim.launch"), Launch.get("explore_robot.launch")
    both = sim.nodes & robot.nodes
    for arg in set(sim.args) & set(robot.args):
        on_sim = {(n, p) for n, p, _, _ in sim.sets[arg] if n in both}
        on_robot = {(n, p) for n, p, _, _ in robot.sets[arg] if n in both}
        assert on_sim == on_robot, f"{arg}: explore_sim.launch sets {on_sim}, explore_robot.launch {on_robot}"


# ---------------------------------------------------------------------------- Makefile

MAKEFILE = (TOP / "Makefile").read_text()


def makefile_launch_vars() -> dict:
    """Makefile variable -> the launch argument it is passed to (name:=$(VAR), $(call arg,VAR,name))."""
    found = {v: n for n, value in re.findall(r"\b(\w+):=(\S+)", MAKEFILE)
             for v in re.findall(r"\$\(([A-Z_]+)\)", value)}
    found.update({v: n for v, n in re.findall(r"\$\(call arg,(\w+),(\w+)\)", MAKEFILE)})
    return found


def yaml_args() -> dict:
    """Launch argument -> the YAML parameters it reaches in some top-level launch file."""
    out = {}
    for name in TOP_LEVEL:
        for arg, reached in Launch.get(name).sets.items():
            if reached or arg in CHOSEN_PER_RUN:
                out.setdefault(arg, set()).update(reached)
    return out


def makefile_defaults() -> dict:
    """Makefile variable -> (its definition line, the line above it)."""
    lines = MAKEFILE.splitlines()
    return {m.group(1): (line, lines[i - 1] if i else "") for i, line in enumerate(lines)
            for m in [re.match(r"^(\w+)\s*(\?=|:=|=)", line)] if m}


def test_makefile_variables_passed_to_launch_files_have_no_default():
    defined = makefile_defaults()
    bad = [f"{defined[v][0].strip()}: pass it only when the user sets it, or '# {ON_PURPOSE} ...' above"
           for v in makefile_launch_vars() if v in defined
           and not defined[v][1].lstrip("# ").startswith(ON_PURPOSE)]
    assert bad == []


def test_makefile_passes_no_literal_to_a_yaml_parameter():
    reached = yaml_args()
    commands = "\n".join(line for line in MAKEFILE.splitlines() if "@echo" not in line)   # help: examples
    bad = [f"{n}:={v}" for n, v in re.findall(r"\b(\w+):=([^\s$()]+)", commands) if n in reached]
    assert bad == []


def test_makefile_help_prints_no_launch_default():
    help_text = MAKEFILE.split("\nhelp:", 1)[1].split("\n\n", 1)[0]
    shown = [v for v in makefile_launch_vars() if f"$({v})" in help_text and v not in makefile_defaults()]
    assert shown == [], f"help prints {shown}: their defaults live in the launch files and config/"


# ---------------------------------------------------------------------------- bindings, core

def test_bindings_take_no_defaults():
    bad = []
    for path in sorted((TOP / "src" / "native").glob("*.cpp")):
        text = re.sub(r"\s+", " ", path.read_text())
        bad += [f"{path.name}: py::arg(\"{m.group(1)}\") = {m.group(2)}"
                for m in re.finditer(r'py::arg\("(\w+)"\) ?= ?([^,)]+\)?)', text)
                if not m.group(2).startswith("py::none()")]
    assert bad == [], "pass these from the Python settings:\n" + "\n".join(bad)


@pytest.mark.parametrize("name, constant", [("occupied_threshold", "OCCUPIED_THRESH"),
                                            ("free_threshold", "FREE_THRESH")])
def test_map_thresholds_are_one_named_value(name, constant):
    # map_server's thresholds: one named value each, in code and in no YAML
    pattern = re.compile(name + r"\s*(?::\s*int)?\s*[=:]\s*\d")
    files = sorted((TOP / "src" / "turtlebot_recon").rglob("*.py")) + sorted((TOP / "config").glob("*.yaml"))
    bad = [f"{p.relative_to(TOP)}:{i + 1}" for p in files
           for i, line in enumerate(p.read_text().splitlines()) if pattern.search(line)]
    assert bad == [], f"use mapping.map_io.{constant}: " + ", ".join(bad)


OCCUPIED_THRESH = int(re.search(r"^OCCUPIED_THRESH, FREE_THRESH = (\d+), \d+",
                                (TOP / "src" / "turtlebot_recon" / "mapping" / "map_io.py").read_text(),
                                re.M).group(1))
# header, struct -> (YAML file, key path of its block, {C++ field: YAML key} where they differ)
HEADER_STRUCTS = {
    ("occupancy_grid.hpp", "GridSettings"): ("mapper.yaml", ("grid",), {}),
    ("visibility.hpp", "VisibilityParams"): ("explorer.yaml", ("frontiers",), {"beams": "gain_beams"}),
    ("lattice_grid.hpp", "LatticeParams"): ("lattice.yaml", (), {}),
    ("scan_matcher.hpp", "MatcherParams"): ("slam.yaml", ("slam", "matcher"), {}),
    ("camera_coverage.hpp", "CoverageParams"): ("explorer.yaml", ("tag_search", "coverage"), {}),
    ("costmap.hpp", "InflationParams"): (None, (), {}),
    ("mppi/optimizer.hpp", "OptimizerSettings"): ("mppi.yaml", (), {}),
    ("octomap_layer.hpp", "OctomapParams"): ("octomap.yaml", (), {"resolution": "resolution_m"}),
}


def struct_defaults(header: str, struct: str) -> dict:
    text = (TOP / "include" / "turtlebot_recon" / header).read_text()
    body = re.search(r"struct %s \{(.*?)\n\};" % struct, text, re.S).group(1)
    return {m.group(1): float(m.group(2)) if re.search(r"[.e]", m.group(2)) else int(m.group(2))
            for m in re.finditer(r"^\s*(?:double|int|bool)\s+(\w+)\s*=\s*([-+0-9.e]+);", body, re.M)}


@pytest.mark.parametrize("header, struct", sorted(HEADER_STRUCTS))
def test_cpp_struct_defaults_match_the_yaml(header, struct):
    file, path, rename = HEADER_STRUCTS[header, struct]
    block = yaml.safe_load((CONFIG / file).read_text()) if file else {}
    for key in path:
        block = block[key]
    defaults = struct_defaults(header, struct)
    assert defaults, f"{header}: no defaults parsed in {struct}"
    for field, value in defaults.items():
        if field == "occupied_threshold":
            assert value == OCCUPIED_THRESH, f"{header} {struct}.{field}"
        elif rename.get(field, field) in block:
            assert value == pytest.approx(block[rename.get(field, field)]), f"{header} {struct}.{field} vs {file}"
