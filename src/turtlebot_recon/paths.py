"""Where the package's data files (config/, worlds/, urdf/) lie, wherever the code runs from.

In a checkout and in a catkin devel space (whose Python path points into src/) they are in the
package root, two levels above this file. In an install space (``catkin_make install``, a Debian
package) this file is ``<prefix>/lib/python3/dist-packages/turtlebot_recon/paths.py`` and
CMakeLists.txt installs them to ``<prefix>/share/turtlebot_recon``.
"""
from pathlib import Path

_HERE = Path(__file__).resolve().parent
_SOURCE_ROOT = _HERE.parents[1]
_INSTALLED_SHARE = _HERE.parents[3] / "share" / "turtlebot_recon"

SHARE_DIR = _SOURCE_ROOT if (_SOURCE_ROOT / "package.xml").is_file() else _INSTALLED_SHARE


def launch_defaults(launch_file: str) -> dict:
    """A launch file's literal argument defaults (those without substitutions), by name. The
    top-level launch files hold the one default of the robot and the world; a tool outside
    roslaunch (tools/launch's checks, tools/slam_log.py) reads them here rather than repeating them."""
    import xml.etree.ElementTree as ET
    path = SHARE_DIR / "launch" / Path(launch_file).name
    if not path.is_file():
        return {}
    return {a.get("name"): a.get("default") for a in ET.parse(path).getroot().iter("arg")
            if a.get("default") and "$(" not in a.get("default")}
