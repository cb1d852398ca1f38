"""The ROS layer: message <-> core conversions and rosbag I/O; the only package under
src/turtlebot_recon that imports ROS (rospy, rosbag, message classes)."""
