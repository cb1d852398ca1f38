"""Parameters are declared once: YAML keys match the settings dataclasses; typos are caught."""
import dataclasses
import typing
from pathlib import Path

import pytest

from turtlebot_recon.behavior.supervisor import SupervisorSettings
from turtlebot_recon.control import (CONTROLLERS, DEFAULT_CONTROLLER, DwaSettings, MppiSettings, PdSettings,
                                     TubeMppiSettings)
from turtlebot_recon.config import ConfigError, from_dict, from_params, load_yaml
from turtlebot_recon.evaluation.evaluator import EvaluatorSettings
from turtlebot_recon.evaluation.oracle import OracleDriverSettings
from turtlebot_recon.exploration.explorer import ExplorerSettings
from turtlebot_recon.exploration.frontiers import FrontierSettings
from turtlebot_recon.exploration.goals import GoalBookSettings
from turtlebot_recon.exploration.tag_search import TagSearchSettings
from turtlebot_recon.exploration.strategies import DEFAULT_STRATEGY, STRATEGIES
from turtlebot_recon.mapping.mapper import MapperSettings
from turtlebot_recon.mapping.octomap_layer import OctomapSettings
from turtlebot_recon.perception.detector import DetectorNodeSettings
from turtlebot_recon.perception.tracker import TrackerNodeSettings
from turtlebot_recon.planning.lattice import LatticeSettings
from turtlebot_recon.planning.navigation import NavigationSettings
from turtlebot_recon.robot import CONFIG_DIR, RobotSpec, load_robot
from turtlebot_recon.sim.simulator import SimSettings
from turtlebot_recon.sim.wander import WanderSettings
from turtlebot_recon.slam.node_settings import SlamNodeSettings
from turtlebot_recon.trajectory import TrajectorySettings

TOP = Path(__file__).resolve().parents[2]
CONFIG = TOP / "config"

# Every block of every config/*.yaml: (file, key path of the block) -> its settings class. The
# path () is the file's top level, less the keys that lead to a block or selector of their own.
# Nested dataclass fields (mapper.yaml's grid, navigator.yaml's follower, oracle.yaml's route)
# are part of their class's block, except those with a file of their own (OWN_FILE), which the
# launch files load into the node's namespace under the field's name.

BLOCKS = {
    ("sim_bridge.yaml", ()): SimSettings,
    ("mapper.yaml", ()): MapperSettings,
    ("octomap.yaml", ()): OctomapSettings,
    ("navigator.yaml", ()): NavigationSettings,
    ("lattice.yaml", ()): LatticeSettings,
    ("dwa.yaml", ()): DwaSettings,
    ("pd.yaml", ()): PdSettings,
    ("mppi.yaml", ()): MppiSettings,
    ("tube_mppi.yaml", ()): TubeMppiSettings,
    ("supervisor.yaml", ()): SupervisorSettings,
    ("trajectory.yaml", ()): TrajectorySettings,
    ("evaluator.yaml", ()): EvaluatorSettings,
    ("oracle.yaml", ()): OracleDriverSettings,
    ("scripted_drive.yaml", ()): WanderSettings,
    ("explorer.yaml", ()): ExplorerSettings,
    ("explorer.yaml", ("frontiers",)): FrontierSettings,
    ("explorer.yaml", ("goals",)): GoalBookSettings,
    ("explorer.yaml", ("tag_search",)): TagSearchSettings,
    ("tag_detector.yaml", ()): DetectorNodeSettings,
    ("tag_tracker.yaml", ()): TrackerNodeSettings,
    ("slam.yaml", ()): SlamNodeSettings,
    **{("explorer.yaml", ("strategies", name)): cls.Settings for name, cls in STRATEGIES.items()},
}
OWN_FILE = {LatticeSettings: "lattice.yaml", DwaSettings: "dwa.yaml", PdSettings: "pd.yaml",
            MppiSettings: "mppi.yaml", TubeMppiSettings: "tube_mppi.yaml", OctomapSettings: "octomap.yaml"}
# Chosen per run, so never defaulted by a node: the launch files set them, and the top-level
# launch files hold their one default (test_defaults.py checks those).
SET_BY_LAUNCH = {"robot", "world"}
# Keys that choose rather than set: (file, key path) -> (the choices, the default).
SELECTORS = {("explorer.yaml", ("strategy",)): (set(STRATEGIES), DEFAULT_STRATEGY)}


ROWS = {*BLOCKS, *SELECTORS}


def _block(name: str, path: tuple):
    data = load_yaml(CONFIG / name)
    for key in path:
        data = data[key]
    return data


def _is_or_holds_a_row(name: str, path: tuple) -> bool:
    """Whether the key path ``path`` of file ``name`` is a row of BLOCKS or SELECTORS or lies above one."""
    return any(f == name and p[:len(path)] == path for f, p in ROWS)


def _assert_keys_are_fields(cls, block: dict, where: str) -> None:
    """The block's keys are exactly the class's fields, and likewise in nested dataclass fields."""
    hints = typing.get_type_hints(cls)
    assert set(block) == {f.name for f in dataclasses.fields(cls)
                          if hints[f.name] not in OWN_FILE and f.name not in SET_BY_LAUNCH}, where
    for f in dataclasses.fields(cls):
        if dataclasses.is_dataclass(hints[f.name]) and hints[f.name] not in OWN_FILE:
            _assert_keys_are_fields(hints[f.name], block[f.name], f"{where}/{f.name}")


def _params(table: dict) -> list:
    return [pytest.param(name, path, id="/".join((name, *path))) for name, path in table]


@pytest.mark.parametrize("name, path", _params(BLOCKS))
def test_yaml_block_declares_every_setting_once_with_its_default(name, path):
    cls, where = BLOCKS[name, path], "/".join((name, *path))
    own = {k: v for k, v in _block(name, path).items() if not _is_or_holds_a_row(name, (*path, k))}
    _assert_keys_are_fields(cls, own, where)
    assert from_dict(cls, own, where) == cls()      # YAML = defaults


@pytest.mark.parametrize("name, path", _params(BLOCKS))
def test_robot_and_world_have_no_default_in_a_node(name, path):
    # "" is no robot: load_robot("") fails loudly, so a node started without ~robot stops
    cls = BLOCKS[name, path]
    for field in dataclasses.fields(cls):
        if field.name in SET_BY_LAUNCH:
            assert field.default == "", f"{cls.__name__}.{field.name}"
            assert field.name not in _block(name, path), f"{name}: {field.name}"


@pytest.mark.parametrize("name, path", _params(SELECTORS))
def test_yaml_selector_names_a_choice_and_the_default(name, path):
    choices, default = SELECTORS[name, path]
    assert _block(name, path) == default and default in choices


def test_every_config_file_and_key_has_a_settings_class():
    # Every config/*.yaml (robots/ and rviz/ hold no node's settings) has a row ...
    assert sorted(p.name for p in CONFIG.glob("*.yaml")) == sorted({f for f, _ in BLOCKS})
    # ... and every key in it is a row, lies above one, or is a key of the block it sits in.
    uncovered = []

    def walk(name: str, path: tuple, node: dict) -> None:
        for key, value in node.items():
            sub = (*path, key)
            if _is_or_holds_a_row(name, sub):
                if (name, sub) not in ROWS:
                    walk(name, sub, value)
            elif (name, path) not in BLOCKS:
                uncovered.append("/".join((name, *sub)))

    for name in sorted({f for f, _ in BLOCKS}):
        walk(name, (), load_yaml(CONFIG / name))
    assert uncovered == []


@pytest.mark.parametrize("path", sorted(CONFIG_DIR.glob("*.yaml")), ids=lambda p: p.stem)
def test_robot_yaml_is_complete(path):
    data = load_yaml(path)
    # everything but the box footprint (round robots), the camera (burger) and the depth camera
    # (the TurtleBot 3s) is spelled out
    optional = {"footprint_length_m", "footprint_width_m", "footprint_offset_x_m", "camera", "depth_camera"}
    required = {f.name for f in dataclasses.fields(RobotSpec)} - optional
    assert required <= set(data), required - set(data)
    robot = load_robot(path.stem)
    assert robot.name == path.stem


def test_robot_specs_match_design():
    burger, waffle, tb2 = (load_robot(n) for n in ("turtlebot3_burger", "turtlebot3_waffle_pi", "turtlebot2"))
    assert (burger.max_linear_mps, burger.max_angular_radps, burger.camera) == (0.22, 2.84, None)
    assert (waffle.max_linear_mps, waffle.max_angular_radps) == (0.26, 1.82)
    assert (waffle.footprint_length_m, waffle.footprint_width_m) == (0.281, 0.306)
    assert (tb2.max_linear_mps, tb2.lidar.beams, tb2.lidar.range_max_m, tb2.bumpers) == (0.7, 640, 4.0, True)
    assert burger.lidar.beams == 360 and burger.lidar.range_max_m == 3.5 and burger.lidar.rate_hz == 5.0


def test_unknown_and_bad_parameters():
    with pytest.raises(ConfigError, match=r"src: unknown parameter\(s\) \['rtff'\]"):
        from_dict(SimSettings, {"rtff": 2.0}, "src")
    with pytest.raises(ConfigError, match="src/rtf: expected a number"):
        from_dict(SimSettings, {"rtf": "fast"}, "src")
    with pytest.raises(ConfigError, match="src/physics_hz: must be >= 100"):
        from_dict(SimSettings, {"physics_hz": 50.0}, "src")
    with pytest.raises(ConfigError, match="src/clock_rate_hz: must be <= physics_hz"):
        from_dict(SimSettings, {"clock_rate_hz": 200.0}, "src")
    warnings = []
    s = from_params(SimSettings, {"rtf": 3, "colour": "red"}, "/sim_bridge", warnings.append)
    assert s.rtf == 3.0 and len(warnings) == 1 and "colour" in warnings[0]
    with pytest.raises(ConfigError, match="no file"):
        load_robot("turtlebot9")


def test_every_controller_has_a_settings_block_and_the_default_is_one():
    # navigator.yaml names the default controller; every controller's settings class is a
    # NavigationSettings field (the pure pursuit's is ``follower``), loaded from its own file
    # (OWN_FILE) or navigator.yaml's block, and the launch file loads each own file.
    assert load_yaml(CONFIG / "navigator.yaml")["controller"] == DEFAULT_CONTROLLER in CONTROLLERS
    hints = typing.get_type_hints(NavigationSettings)
    for name, (settings_cls, _) in CONTROLLERS.items():
        assert settings_cls in hints.values(), name
        assert NavigationSettings(controller=name).controller_settings() == settings_cls()
    launch = (TOP / "launch" / "navigator.launch").read_text()
    for cls, file in OWN_FILE.items():
        if cls is not LatticeSettings and cls in hints.values():
            assert f"config/{file}" in launch, file
    assert 'config/octomap.yaml" command="load" ns="octomap"' in (TOP / "launch" / "mapper.launch").read_text()
    with pytest.raises(ConfigError, match="navigator/controller: unknown controller 'mpc'; choose one of"):
        from_dict(NavigationSettings, {"controller": "mpc"}, "navigator")
