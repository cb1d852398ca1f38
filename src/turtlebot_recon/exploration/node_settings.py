"""scripts/explorer's parameters: its private namespace read into the core's settings.

The node's own keys (config/explorer.yaml) make ``ExplorerSettings``; its blocks are
``frontiers``, the strategy's (``strategy``, ``goals``, ``strategies``: ``load_strategy``),
``tag_search``, and config/supervisor.yaml and config/lattice.yaml (the navigator's lattice:
where a frontier counts as reachable), which the launch file loads into ``supervisor`` and
``lattice``. ROS-free: the node hands in ``rospy.get_param("~")`` and a warning function.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..behavior import SupervisorSettings
from ..config import from_dict, from_params
from ..planning.lattice import LatticeSettings
from .explorer import ExplorerSettings
from .frontiers import FrontierSettings
from .goals import GoalBookSettings
from .strategies import load_strategy
from .tag_search import TagSearchSettings

STRATEGY_KEYS = ("strategy", "goals", "strategies")   # load_strategy's part of the parameters
BLOCK_KEYS = STRATEGY_KEYS + ("frontiers", "supervisor", "lattice", "tag_search")


@dataclass(frozen=True)
class ExplorerParams:
    node: ExplorerSettings
    frontiers: FrontierSettings
    strategy: object                      # a Strategy (exploration/strategies)
    goals: GoalBookSettings
    supervisor: SupervisorSettings
    lattice: LatticeSettings
    tag_search: TagSearchSettings


def explorer_params(params: dict, name: str, warn: Callable[[str], None]) -> ExplorerParams:
    """The explorer's settings from its parameters (``name``: the node's, for messages); an
    unknown node key or a missing supervisor / lattice block gets a line through ``warn``; a
    bad value raises ConfigError."""
    node = from_params(ExplorerSettings, {k: v for k, v in params.items() if k not in BLOCK_KEYS}, name, warn)
    frontiers = from_dict(FrontierSettings, params.get("frontiers") or {}, f"{name}/frontiers")
    strategy, goals = load_strategy({k: params[k] for k in STRATEGY_KEYS if k in params}, name)
    if "supervisor" not in params:
        warn("explorer: no ~supervisor parameters (config/supervisor.yaml): defaults used")
    supervisor = from_dict(SupervisorSettings, params.get("supervisor") or {}, f"{name}/supervisor")
    if "lattice" not in params:
        warn("explorer: no ~lattice parameters (config/lattice.yaml, the navigator's lattice): defaults used")
    lattice = from_dict(LatticeSettings, params.get("lattice") or {}, f"{name}/lattice")
    tag_search = from_dict(TagSearchSettings, params.get("tag_search") or {}, f"{name}/tag_search")
    return ExplorerParams(node, frontiers, strategy, goals, supervisor, lattice, tag_search)
