"""Parameters are declared once: YAML keys match the settings dataclasses; typos are caught."""
import dataclasses
import re
from pathlib import Path

import pytest

from turtlebot_recon.config import ConfigError, from_dict, from_params, load_yaml
from turtlebot_recon.robot import CONFIG_DIR, RobotSpec, load_robot
from turtlebot_recon.sim.simulator import SimSettings

TOP = Path(__file__).resolve().parents[2]


def test_sim_bridge_yaml_declares_every_setting_once():
    data = load_yaml(TOP / "config" / "sim_bridge.yaml")
    assert set(data) == {f.name for f in dataclasses.fields(SimSettings)}
    assert from_dict(SimSettings, data, "sim_bridge.yaml") == SimSettings()   # YAML = defaults


@pytest.mark.parametrize("path", sorted(CONFIG_DIR.glob("*.yaml")), ids=lambda p: p.stem)
def test_robot_yaml_is_complete(path):
    data = load_yaml(path)
    # everything but the box footprint (round robots) and the camera (burger) is spelled out
    optional = {"footprint_length_m", "footprint_width_m", "footprint_offset_x_m", "camera"}
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


def test_core_never_imports_rospy():
    core = TOP / "src" / "turtlebot_recon"
    offenders = [str(p.relative_to(core)) for p in core.rglob("*.py")
                 if p.parent.name != "ros" and re.search(r"^\s*(import|from)\s+rospy", p.read_text(), re.M)]
    assert offenders == []


def test_mapper_yaml_declares_every_setting_once():
    from turtlebot_recon.mapping.grid import GridSettings
    from turtlebot_recon.mapping.mapper import MapperSettings
    data = load_yaml(TOP / "config" / "mapper.yaml")
    assert set(data) == {f.name for f in dataclasses.fields(MapperSettings)}
    assert set(data["grid"]) == {f.name for f in dataclasses.fields(GridSettings)}
    assert from_dict(MapperSettings, data, "mapper.yaml") == MapperSettings()   # YAML = defaults
