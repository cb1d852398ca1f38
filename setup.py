# Installed by catkin_python_setup(); do not run directly.
from setuptools import find_packages, setup
from catkin_pkg.python_setup import generate_distutils_setup

# Every subpackage under src/, found rather than listed: a list written by hand once left out
# perception and slam, which only the install space noticed.
setup(**generate_distutils_setup(
    packages=find_packages("src"),
    package_dir={"": "src"},
))
