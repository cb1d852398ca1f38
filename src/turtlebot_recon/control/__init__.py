"""Control: the path controllers behind one contract (ROS-free, never blocking).

- ``base``:      the contract every controller implements (``Controller``: ``reset()``,
                 ``compute(ControlInput) -> ControlOutput``), the statuses, ``PeriodClock``;
- ``tracking``:  what the controllers share: the path (progress along it, the goal latch) and
                 the turn-in-place law, with one parameter block (navigator.yaml's ``tracking``);
- ``footprint``: the robot's body against the occupancy grid (``BodyCheck``);
- the controllers: ``follower`` (pure pursuit), ``dwa``, ``pd``, ``mppi``, ``tube_mppi``;
  ``CONTROLLERS`` names them for the navigator's ``controller`` parameter.
"""
from __future__ import annotations

from typing import Optional

from ..config import ConfigError, from_dict
from .base import (ARRIVED, BLOCKED, FOLLOWING, NO_PATH, ROTATING, STATUSES, ControlInput,
                   ControlMarkers, ControlOutput, Controller, PeriodClock)
from .dwa import DwaController, DwaSettings
from .follower import FollowerSettings, PurePursuit
from .footprint import BodyCheck
from .mppi import MppiController, MppiSettings
from .pd import PdController, PdSettings
from .tracking import TrackingSettings
from .tube_mppi import TubeMppiController, TubeMppiSettings

# The controllers the navigator can drive with (``controller:=`` NAME): NAME -> (its settings
# class, its class); every class is built as cls(settings, robot, tracking). One line adds one.
CONTROLLERS = {
    "pure_pursuit": (FollowerSettings, PurePursuit),
    "dwa": (DwaSettings, DwaController),
    "pd": (PdSettings, PdController),
    "mppi": (MppiSettings, MppiController),
    "tube_mppi": (TubeMppiSettings, TubeMppiController),
}
DEFAULT_CONTROLLER = "tube_mppi"   # make bench-nav's pick, and sooner to 99 % in make bench-explore: docs/benchmarks.md


def make_controller(name: str, settings, robot, tracking: Optional[TrackingSettings] = None) -> Controller:
    """The controller ``name`` of CONTROLLERS for ``robot``; ``settings``: its settings object,
    a dict of its parameters (checked as a config block), or None for the defaults;
    ``tracking``: the shared path-tracking parameters (None: their defaults). An unknown name
    raises ConfigError (a ValueError) in one line listing the choices."""
    if name not in CONTROLLERS:
        raise ConfigError(f"controller '{name}' is unknown; choose one of {', '.join(CONTROLLERS)}")
    settings_cls, cls = CONTROLLERS[name]
    if settings is None:
        settings = settings_cls()
    elif isinstance(settings, dict):
        settings = from_dict(settings_cls, settings, name)
    elif not isinstance(settings, settings_cls):
        raise ConfigError(f"controller '{name}' takes {settings_cls.__name__}, got "
                          f"{type(settings).__name__}")
    return cls(settings, robot, tracking)


__all__ = [
    "FOLLOWING", "ROTATING", "ARRIVED", "BLOCKED", "NO_PATH", "STATUSES",
    "ControlInput", "ControlOutput", "ControlMarkers", "Controller", "PeriodClock", "BodyCheck",
    "CONTROLLERS", "DEFAULT_CONTROLLER", "make_controller",
    "TrackingSettings", "FollowerSettings", "PurePursuit", "DwaSettings", "DwaController", "PdSettings", "PdController",
    "MppiSettings", "MppiController", "TubeMppiSettings", "TubeMppiController",
]
