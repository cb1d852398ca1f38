# Source me: the venv first on PATH, then the catkin devel space.
_top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="$_top/.venv/bin:$PATH"
export ROS_HOME="${ROS_HOME:-$_top/build/ros_home}"
export PYTHONDONTWRITEBYTECODE=1
# shellcheck disable=SC1091
source "$("$_top/tools/ws-path")/devel/setup.bash"
unset _top
