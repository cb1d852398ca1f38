"""The contract every goal strategy class meets (the registry is the package's ``__init__``)."""
from __future__ import annotations

from typing import List, Optional, Protocol

from ..context import Context
from ..frontiers import Frontier
from ..goals import GoalBook


class Strategy(Protocol):
    """What every strategy class provides: its YAML ``name``, a frozen ``Settings`` dataclass
    (its constructor's one argument) and ``choose``, which may update the strategy's own
    memory and the book (explore_lite blacklists) but never blocks."""
    name: str

    def choose(self, frontiers: List[Frontier], ctx: Context, book: GoalBook) -> Optional[Frontier]:
        ...
