"""Perception (ROS-free): fiducial marker families, detection with pose and covariance, and
tracking of the markers in the map; depth images to 3-D points (``depth``)."""
