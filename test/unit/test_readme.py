"""README.md tells the truth about the code: the worlds, robots, controllers, strategies and
missions it names exist; its options table has the Makefile's variables, explore_sim.launch's
arguments and their defaults, read where the nodes read them (an argument that defaults to ''
leaves its parameter to the node's config/*.yaml); its relative links resolve; it stays a page
(at most 300 lines). Long tables and experiments belong in docs/."""
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import yaml

from turtlebot_recon.control import CONTROLLERS
from turtlebot_recon.exploration.explorer import MISSIONS
from turtlebot_recon.exploration.strategies import STRATEGIES

TOP = Path(__file__).resolve().parents[2]
README = (TOP / "README.md").read_text()
MAKEFILE = re.sub(r"(?m)^\s*#.*$", "", (TOP / "Makefile").read_text())   # comments are not rules
MAX_LINES = 300

WORLDS = {p.stem for p in (TOP / "worlds").glob("*.yaml")}
ROBOTS = {p.stem for p in (TOP / "config" / "robots").glob("*.yaml")}
NAMES = {  # option -> the names the code accepts
    "world": WORLDS,
    "robot": ROBOTS,
    "strategy": set(STRATEGIES) | {"oracle"},   # oracle: the driver that replaces the explorer
    "controller": set(CONTROLLERS),
    "mission": set(MISSIONS),
}
COUNTED = {"worlds": WORLDS, "robots": ROBOTS, "controllers": CONTROLLERS, "strategies": STRATEGIES}
NUMBERS = {w: i for i, w in enumerate(
    "zero one two three four five six seven eight nine ten eleven twelve".split())}


# ---- reading the README -------------------------------------------------------------------

def options_table(text: str) -> list:
    """The rows of the table whose header starts `| variable | launch argument |`, as lists of
    cells (backticks kept)."""
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if re.match(r"\|\s*variable\s*\|\s*launch argument\s*\|", ln))
    rows = []
    for ln in lines[start + 2:]:
        if not ln.startswith("|"):
            break
        rows.append([c.strip() for c in ln.strip().strip("|").split("|")])
    return rows


def ticked(cell: str) -> list:
    return re.findall(r"`([^`]+)`", cell)


def bare(cell: str) -> str:
    """A default cell's value: the first `...`, or '' for (none)."""
    names = ticked(cell)
    return names[0] if names else ""


def same_value(a, b) -> bool:
    """'0' == 0.0, 'false' == False, '' == None; else as text."""
    def norm(v):
        if v is None or v == "":
            return ""
        if isinstance(v, bool) or str(v).lower() in ("true", "false"):
            return str(v).lower()
        try:
            return float(v)
        except (TypeError, ValueError):
            return str(v)
    return norm(a) == norm(b)


# ---- reading the Makefile and the launch files as the code does ---------------------------

def makefile_passes() -> dict:
    """variable -> launch argument, for every variable a make target hands to a launch file:
    `$(call arg,VAR,name)` (passed when the user sets it) and `name:=$(VAR)` /
    `name:=$(abspath $(VAR))`."""
    passes = dict(re.findall(r"\$\(call arg,(\w+),(\w+)\)", MAKEFILE))
    for name, var in re.findall(r"\b(\w+):=\$\((?:abspath )?\$\((\w+)\)\)", MAKEFILE):
        passes.setdefault(var, name)
    return passes


def makefile_default(var: str):
    m = re.search(rf"^{var}\s*\?=\s*(.*?)\s*$", MAKEFILE, re.M)
    return m.group(1) if m else None


def launch_path(ref: str) -> Path:
    return Path(ref.replace("$(find turtlebot_recon)", str(TOP)))


def launch_arg_default(launch: Path, arg: str):
    """The `default` of <arg name=arg> in the launch file (None: no default); KeyError if absent."""
    for el in ET.parse(launch).getroot().iter("arg"):
        if el.get("name") == arg:
            return el.get("default")
    raise KeyError(f"{launch.name} has no argument '{arg}'")


def yaml_value(path: Path, key: str):
    node = yaml.safe_load(path.read_text())
    for part in key.split("/"):
        if not isinstance(node, dict) or part not in node:
            return KeyError
        node = node[part]
    return node


def yaml_defaults(launch: Path, arg: str) -> list:
    """The config/*.yaml values that apply when `arg` is left empty: every <param> set from
    $(arg arg) inside a <node>, looked up in the YAML files that node loads (each at its `ns`),
    following <include> arguments into the included launch files."""
    ref = f"$(arg {arg})"
    found = []

    def walk(el, node):
        for child in el:
            if child.tag == "node":
                walk(child, child)
            elif child.tag == "param" and child.get("value") == ref and node is not None:
                name = child.get("name")
                for rp in node.iter("rosparam"):
                    ns = rp.get("ns", "")
                    if rp.get("file") and (not ns or name.startswith(ns + "/")):
                        value = yaml_value(launch_path(rp.get("file")), name[len(ns) + 1:] if ns else name)
                        if value is not KeyError:
                            found.append(value)
            elif child.tag == "include":
                for a in child.iter("arg"):
                    if a.get("value") == ref:
                        found.extend(yaml_defaults(launch_path(child.get("file")), a.get("name")))
            else:
                walk(child, node)

    walk(ET.parse(launch).getroot(), None)
    return found


def effective_default(launch: Path, arg: str) -> list:
    """What the nodes get when the argument is not given: [the launch default] when it is a
    literal, the YAML values it falls back to when it is '', [] when it is an expression."""
    default = launch_arg_default(launch, arg)
    if default is None or "$(" in default:
        return []
    if default == "":
        return yaml_defaults(launch, arg) or [""]
    return [default]


def launch_of(cell: str) -> Path:
    """The launch file a row's argument belongs to: `name` (`other.launch`), else explore_sim."""
    named = [t for t in ticked(cell) if t.endswith(".launch")]
    return TOP / "launch" / (named[0] if named else "explore_sim.launch")


# ---- the checks ---------------------------------------------------------------------------

def check(text: str) -> list:
    """Every way README `text` disagrees with the code, one line each ([] when it agrees)."""
    problems = []
    lines = text.splitlines()
    if len(lines) > MAX_LINES:
        problems.append(f"README has {len(lines)} lines, more than {MAX_LINES}: move detail to docs/")

    # names in examples: WORLD=x, world:=x, ... (paths and placeholders are not names)
    for option, known in NAMES.items():
        pattern = rf"(?:\b{option.upper()}=|\b{option}:=)([A-Za-z0-9_]+)(?![\w./…])"
        for name in re.findall(pattern, text):
            if name not in known:
                problems.append(f"README names {option} '{name}', which the code does not have "
                                f"(known: {', '.join(sorted(known))})")

    # counts: "six worlds", "three robots", "five path controllers", "six goal strategies"
    for number, noun in re.findall(r"\b(" + "|".join(NUMBERS) + r")\s+(?:[a-z]+\s+)?(worlds|robots|controllers|strategies)\b",
                                   text, re.I):
        if NUMBERS[number.lower()] != len(COUNTED[noun]):
            problems.append(f"README says '{number} {noun}'; the code has {len(COUNTED[noun])}")

    # the options table against the Makefile and the launch files
    rows = options_table(text)
    passes = makefile_passes()
    in_table = set()
    for row in rows:
        variable, argument = bare(row[0]), bare(row[1])
        in_table.add(variable)
        default = bare(row[2])
        if passes.get(variable) != argument:
            problems.append(f"options table: the Makefile passes no {variable} as '{argument}' "
                            f"(it passes {passes.get(variable)!r})")
            continue
        launch = launch_of(row[1])
        try:
            defaults = effective_default(launch, argument)
        except KeyError as exc:
            problems.append(f"options table: {exc.args[0]}")
            continue
        make_default = makefile_default(variable)
        if make_default is not None:
            if not same_value(default, make_default):
                problems.append(f"options table: {variable} defaults to '{default}', the Makefile "
                                f"to '{make_default}'")
        elif defaults and not any(same_value(default, d) for d in defaults):
            problems.append(f"options table: {variable} defaults to '{default}', {launch.name} "
                            f"(with config/*.yaml) to {' or '.join(repr(d) for d in defaults)}")
        option = argument.lower()
        if option in NAMES:
            listed = {t for t in ticked(row[3]) if re.fullmatch(r"\w+", t)}
            if listed != NAMES[option]:
                problems.append(f"options table: {variable}'s values {sorted(listed)} are not the code's "
                                f"{sorted(NAMES[option])}")
    for variable in sorted(set(passes) - in_table):
        problems.append(f"options table: the Makefile's {variable} ({passes[variable]}) has no row")

    # make targets named, and relative links
    targets = set(re.findall(r"^([\w-]+):", MAKEFILE, re.M))
    named = re.findall(r"`make ([a-z][a-z0-9_-]*[a-z0-9])(?![\w…-])", text)   # not bench-NAME, bench-…
    for target in sorted(set(named) - targets):
        problems.append(f"README names `make {target}`, which the Makefile does not have")
    for link in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", link) or link.startswith("#"):
            continue
        if not (TOP / link.split("#")[0]).exists():
            problems.append(f"README links to {link}, which does not exist")
    return problems


def test_readme_agrees_with_the_code():
    problems = check(README)
    assert problems == [], "\n".join(problems)


def test_each_kind_of_drift_is_caught():
    """The check fails on each error README.md once had (or could have): a line per case."""
    def drifted(old: str, new: str) -> list:
        assert old in README, f"the case needs README to contain {old!r}"
        return check(README.replace(old, new, 1))

    assert any("'four worlds'" in p for p in check(README + "\nThe simulator has four worlds.\n"))
    assert any("world 'atrium'" in p for p in check(README + "\n`make run WORLD=atrium`\n"))
    assert any("robot 'turtlebot4'" in p for p in check(README + "\n`robot:=turtlebot4`\n"))
    assert any("controller 'teb'" in p for p in check(README + "\n`CONTROLLER=teb`\n"))
    assert any("strategy 'greedy'" in p for p in check(README + "\n`strategy:=greedy`\n"))
    assert any("mission 'survey'" in p for p in check(README + "\n`MISSION=survey`\n"))
    # a default that is not the code's: the controller's comes from navigator.yaml
    assert any("CONTROLLER defaults to 'pure_pursuit'" in p
               for p in drifted("| `CONTROLLER` | `controller` | `tube_mppi` |",
                                "| `CONTROLLER` | `controller` | `pure_pursuit` |"))
    # a value left out of (or added to) a row's list
    assert any("CONTROLLER's values" in p for p in drifted(", `pure_pursuit` (one YAML", " (one YAML"))
    # an argument the launch file does not have, and a Makefile variable with no row
    assert any("no BUDGET" in p for p in drifted("| `BUDGET` | `budget` |", "| `BUDGET` | `time_budget` |"))
    row = next(ln for ln in README.splitlines() if ln.startswith("| `SEED` |"))
    assert any("SEED (seed) has no row" in p for p in drifted(row + "\n", ""))
    assert any("`make bench-everything`" in p for p in check(README + "\n`make bench-everything`\n"))
    assert any("docs/nowhere.md" in p for p in check(README + "\n[x](docs/nowhere.md)\n"))
    assert any("more than 300" in p for p in check(README + "\n" * MAX_LINES))


def test_a_default_left_to_yaml_is_read_from_the_yaml(tmp_path):
    """An argument defaulting to '' is followed into the included launch file and the YAML its
    node loads, at the rosparam's namespace."""
    (tmp_path / "node.yaml").write_text("speed_mps: 0.3\n")
    (tmp_path / "inner.yaml").write_text("rate_hz: 5.0\n")
    (tmp_path / "inner.launch").write_text(f"""<launch><arg name="rate" default=""/>
      <node pkg="p" type="t" name="n"><rosparam file="{tmp_path}/inner.yaml" ns="inner"/>
        <param if="$(eval arg('rate') != '')" name="inner/rate_hz" value="$(arg rate)"/></node></launch>""")
    (tmp_path / "outer.launch").write_text(f"""<launch><arg name="rate" default=""/><arg name="speed" default=""/>
      <include file="{tmp_path}/inner.launch"><arg name="rate" value="$(arg rate)"/></include>
      <group><node pkg="p" type="t" name="m"><rosparam file="{tmp_path}/node.yaml"/>
        <param name="speed_mps" value="$(arg speed)"/></node></group></launch>""")
    assert effective_default(tmp_path / "outer.launch", "rate") == [5.0]
    assert effective_default(tmp_path / "outer.launch", "speed") == [0.3]
