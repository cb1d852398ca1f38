# Installed by catkin_python_setup(); do not run directly.
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(
    packages=["turtlebot_recon", "turtlebot_recon.sim", "turtlebot_recon.ros", "turtlebot_recon.mapping",
              "turtlebot_recon.planning", "turtlebot_recon.evaluation", "turtlebot_recon.exploration",
              "turtlebot_recon.exploration.strategies",
              "turtlebot_recon.behavior", "turtlebot_recon.control"],
    package_dir={"": "src"},
))
