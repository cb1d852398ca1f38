"""The latest message of a topic, converted to core data once, when asked for."""
from __future__ import annotations

from typing import Callable


class Latest:
    """Subscribe with it as the callback (``rospy.Subscriber(topic, T, latest)``): ``msg`` is the
    newest message; ``get()`` its conversion by ``convert_fn``, made once per message (a map's
    conversion costs milliseconds; the node may ask for it at every tick)."""

    def __init__(self, convert_fn: Callable):
        self.msg, self._convert, self._converted = None, convert_fn, (None, None)

    def __call__(self, m) -> None:
        self.msg = m

    def get(self):
        m = self.msg
        if m is not None and self._converted[0] is not m:
            self._converted = (m, self._convert(m))
        return None if m is None else self._converted[1]
