# Source me: the venv first on PATH, then the catkin devel space.
_top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# The user's ROS network settings, read before the devel space's hooks set their defaults
# (roslaunch's hook sets ROS_MASTER_URI=http://localhost:11311 when unset).
_ros_net="${ROS_MASTER_URI:-}${ROS_HOSTNAME:-}${ROS_IP:-}"
export PATH="$_top/.venv/bin:$PATH"
export ROS_HOME="${ROS_HOME:-$_top/build/ros_home}"
export PYTHONDONTWRITEBYTECODE=1
# shellcheck disable=SC1091
source "$("$_top/tools/ws-path")/devel/setup.bash"
# None of ROS_MASTER_URI, ROS_HOSTNAME, ROS_IP set by the user: a local master on the loopback
# address, so that nothing depends on this machine's host name resolving (in many containers it
# does not). Any one of them set leaves all three as the user has them (a real robot's master).
# TURTLEBOT_RECON_MASTER=auto tells tools/launch that the port is ours to choose (11311 when free),
# while the URI is the one set here (a shell that sourced this file before keeps it).
if [[ -z $_ros_net ]]; then
  export ROS_MASTER_URI=http://127.0.0.1:11311 ROS_IP=127.0.0.1 TURTLEBOT_RECON_MASTER=auto
elif [[ $ROS_MASTER_URI != http://127.0.0.1:11311 ]]; then
  unset TURTLEBOT_RECON_MASTER
fi
unset _top _ros_net
