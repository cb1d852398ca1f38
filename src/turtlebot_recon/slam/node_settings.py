"""scripts/slam's parameters (config/slam.yaml): the node's own, SLAM's and localisation's."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..config import positive, require
from .localization import LocalizationSettings
from .slam import SlamSettings


@dataclass(frozen=True)
class SlamNodeSettings:
    """scripts/slam's parameters (config/slam.yaml)."""
    map_frame: str = "map"
    odom_frame: str = "odom"
    base_frame: str = "base_footprint"
    robot: str = ""                  # wheel separation for the odometry noise model; no default: the launch
                                         # files set it (their top-level files hold its one default)
    tf_rate_hz: float = 20.0              # map -> odom, from its own timer
    transform_tolerance_s: float = 0.1    # map -> odom stamped this far ahead (slam_gmapping's)
    tf_timeout_s: float = 1.0             # wait this long for odometry at a scan's stamp
    output_dir: str = ""                  # ~save writes here ('' = $ROS_HOME/slam)
    tag_landmarks: bool = True            # mapping: tags seen (tags/detections) are landmarks in the
                                          # graph, published on slam/landmarks; false: ignored
    mode: str = "mapping"                 # mapping (SLAM) | localization (track in map_file)
    map_file: str = ""                    # localization: a map_server YAML (e.g. a run's map.yaml)
    initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)  # localization: the start pose in
                                          # the map (m, m, rad); rviz's 2D Pose Estimate resets it
    slam: SlamSettings = field(default_factory=SlamSettings)
    localization: LocalizationSettings = field(default_factory=LocalizationSettings)

    def validate(self, src: str) -> None:
        positive(src, self, "tf_rate_hz", "tf_timeout_s")
        require(self.mode in ("mapping", "localization"), src, "mode",
                f"must be mapping or localization, got {self.mode!r}")
        require(self.mode != "localization" or bool(self.map_file), src, "map_file",
                "mode localization needs a map_file (a map_server YAML)")
        require(len(self.initial_pose) == 3 and all(math.isfinite(float(v)) for v in self.initial_pose), src,
                "initial_pose", f"must be three finite numbers (x m, y m, yaw rad), got {self.initial_pose!r}")
        require(self.transform_tolerance_s >= 0.0, src, "transform_tolerance_s", "must be >= 0")
        require(len({self.map_frame, self.odom_frame, self.base_frame}) == 3, src, "map_frame",
                "map_frame, odom_frame and base_frame must differ")
