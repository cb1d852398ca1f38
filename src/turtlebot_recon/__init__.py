"""turtlebot_recon: autonomous exploration for TurtleBot 2/3 (ROS-free core)."""
