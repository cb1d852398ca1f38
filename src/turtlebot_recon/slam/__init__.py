"""SLAM (ROS-free): scan matching (C++ front end), the GTSAM iSAM2 pose graph (back end),
keyframes and loop closures that tie them together, and the logs a run can be replayed from."""
