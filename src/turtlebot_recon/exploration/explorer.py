"""The exploration loop's settings (the explorer node's own keys of config/explorer.yaml)."""
from dataclasses import dataclass

from turtlebot_recon.config import positive, require


@dataclass(frozen=True)
class ExplorerSettings:
    """The node's own keys of config/explorer.yaml."""
    robot: str = "turtlebot3_waffle_pi"  # footprint -> costmap (the navigator's inflation)
    map_frame: str = "odom"              # odom until SLAM provides map -> odom
    base_frame: str = "base_footprint"
    cycle_period_s: float = 1.0          # explorer cycle (sim time); also right after a goal ends
    supervisor_rate_hz: float = 10.0     # supervisor ticks (sim time)
    seed: int = 0                        # the strategies' RNG (sampled)
    same_goal_m: float = 0.3             # a choice this close to the goal being pursued keeps it
    use_visits: bool = True              # give the strategy /visit_map's counts (recon's term)
    abort_retries: int = 30              # an aborted goal that is still reachable is re-sent this
                                         # often in a row before it counts as a failure
    scan_margin_m: float = 0.03          # scan clearance: the body's half width plus this
    scan_max_age_s: float = 1.0          # older scans are not used for recoveries
    status_period_wall_s: float = 5.0    # terminal progress line (wall time: readable at any rtf)
    shutdown_when_done: bool = False     # end the node once the supervisor says DONE

    def validate(self, src: str) -> None:
        positive(src, self, "cycle_period_s", "supervisor_rate_hz", "same_goal_m", "scan_max_age_s",
                 "status_period_wall_s")
        require(isinstance(self.abort_retries, int) and self.abort_retries >= 0, src, "abort_retries",
                "must be an integer >= 0")
        require(self.scan_margin_m >= 0, src, "scan_margin_m", "must be >= 0")
