"""Messages of the OctoMap layer (the mapper's 3-D obstacles): /octomap/occupied markers."""
from __future__ import annotations

import numpy as np
import rospy
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..mapping.octomap_layer import height_colours


def occupied_markers(centres: np.ndarray, sizes: np.ndarray, floor_band_m: float, robot_height_m: float,
                     frame: str, stamp: rospy.Time) -> MarkerArray:
    """The occupied voxels above the floor band as cubes, one CUBE_LIST per voxel size (pruned
    leaves are larger; octomap_server's occupied_cells_vis_array does the same), coloured by
    height: blue at the floor band, red at the robot's top and above. Voxels at or below the
    floor band (the floor itself) are left out. Every size's list is sent, empty ones with
    DELETE, so a size that has gone leaves rviz."""
    centres = np.asarray(centres, np.float64).reshape(-1, 3)
    sizes = np.asarray(sizes, np.float64).ravel()
    keep = centres[:, 2] > floor_band_m
    centres, sizes = centres[keep], sizes[keep]
    rgb = height_colours(centres[:, 2], floor_band_m, robot_height_m)
    out = MarkerArray()
    levels = np.unique(sizes)
    for i, size in enumerate(levels):
        m = Marker()
        m.header.stamp, m.header.frame_id = stamp, frame
        m.ns, m.id, m.type, m.action = "occupied", i, Marker.CUBE_LIST, Marker.ADD
        m.pose.orientation.w = 1.0
        m.scale.x = m.scale.y = m.scale.z = float(size)
        m.color = ColorRGBA(1.0, 1.0, 1.0, 1.0)
        sel = sizes == size
        m.points = [Point(*p) for p in centres[sel].tolist()]
        m.colors = [ColorRGBA(r, g, b, 1.0) for r, g, b in rgb[sel].tolist()]
        out.markers.append(m)
    if not out.markers:   # nothing occupied (yet): clear what an earlier message drew
        m = Marker()
        m.header.stamp, m.header.frame_id = stamp, frame
        m.ns, m.action = "occupied", Marker.DELETEALL
        out.markers.append(m)
    return out
