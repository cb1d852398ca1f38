"""Goal selection strategies: one contract, one module, one class and one YAML block each.

A strategy looks at the current frontiers (``frontiers.Frontier``), a ``Context`` (robot
pose, time, grids, seeded RNG) and the shared ``GoalBook``, and returns the frontier to go
to (its ``goal`` / ``goal_cell`` being the point to send), or None when nothing is left.
Strategies never block, hold no clock (``ctx.now_s``) and draw randomness only from
``ctx.rng``. Every returned goal is a cell the robot can stand on (costmap <= ctx.max_cost)
and reach (finite ``ctx.cost_to_come``), and is not blacklisted.

| name                  | source    | rule                                                       |
|-----------------------|-----------|------------------------------------------------------------|
| nearest               | seed 001  | nearest accessible point of the nearest frontier           |
| density               | seed 003  | min (5 dist - frontier neighbours) / attempt weight        |
| gain_distance_heading | seed 004  | max 2.3 unknowns near - 2 dist + 5 cos(heading error)      |
| sampled               | seed 000  | 5 % random frontier cells, nearest or median; tags first   |
| explore_lite          | m-explore | min 3.0 d_min res - 1.0 size res, goal at the centroid     |
| recon (default)       | ours      | first goal of a tour over all clusters on path distances   |

Where a seed sent a point that is not a reachable cell (seed 003's unknown frontier cell,
explore_lite's centroid), the point is snapped to the nearest reachable cell within
``snap_radius_m`` (what the seeds' planners did implicitly: RRT to the nearest tree node,
move_base to the nearest plannable cell); a point with none is skipped. Such goals are
returned as a copy of their frontier with ``goal``, ``goal_cell`` and ``path_cost_m``
replaced (``gain`` stays the cluster's).

The contracts live apart: ``exploration.context.Context`` (what a strategy sees) and
``base.Strategy`` (what a strategy class provides). This module is the registry
(``STRATEGIES``, ``make_strategy``, ``load_strategy``); each strategy lives in the module named
after it, with helpers used by several of them in ``common``. To add one: a module with a frozen
``Settings`` dataclass (``validate``) and a class with ``name``, ``Settings`` and ``choose``,
an entry in ``STRATEGIES``, a block in config/explorer.yaml and a test.
"""
from __future__ import annotations

from typing import Dict, Optional, Tuple

from ...config import ConfigError, from_dict
from ..goals import GoalBookSettings
from .base import Strategy
from .density import Density
from .explore_lite import ExploreLite
from .gain_distance_heading import GainDistanceHeading
from .nearest import Nearest
from .recon import Recon
from .sampled import Sampled

__all__ = ["Strategy", "STRATEGIES", "DEFAULT_STRATEGY", "make_strategy", "load_strategy", "Nearest",
           "Density", "GainDistanceHeading", "Sampled", "ExploreLite", "Recon"]


STRATEGIES: Dict[str, type] = {cls.name: cls for cls in
                               (Nearest, Density, GainDistanceHeading, Sampled, ExploreLite, Recon)}
DEFAULT_STRATEGY = "recon"


def make_strategy(name: str, params: Optional[dict] = None, source: str = "explorer") -> Strategy:
    """Strategy ``name`` with ``params`` (its YAML block); ConfigError names any bad key."""
    if name not in STRATEGIES:
        raise ConfigError(f"{source}/strategy: unknown strategy {name!r}; "
                          f"known: {sorted(STRATEGIES)}")
    cls = STRATEGIES[name]
    if params is not None and not isinstance(params, dict):
        raise ConfigError(f"{source}/strategies/{name}: expected a mapping, got {params!r}")
    return cls(from_dict(cls.Settings, params or {}, f"{source}/strategies/{name}"))


def load_strategy(config: dict, source: str = "explorer") -> Tuple[Strategy, GoalBookSettings]:
    """The strategy named by ``config['strategy']`` (default recon) with its block from
    ``config['strategies']``, and the GoalBook settings from ``config['goals']``. Every
    strategy block is validated, not only the chosen one, so a typo anywhere fails loudly."""
    blocks = config.get("strategies") or {}
    if not isinstance(blocks, dict):
        raise ConfigError(f"{source}/strategies: expected a mapping, got {blocks!r}")
    unknown = sorted(set(blocks) - set(STRATEGIES))
    if unknown:
        raise ConfigError(f"{source}/strategies: unknown strategy block(s) {unknown}; known: "
                          f"{sorted(STRATEGIES)}")
    built = {name: make_strategy(name, block, source) for name, block in blocks.items()}
    name = config.get("strategy", DEFAULT_STRATEGY)
    strategy = built.get(name) or make_strategy(name, None, source)
    goals = from_dict(GoalBookSettings, config.get("goals") or {}, f"{source}/goals")
    return strategy, goals
