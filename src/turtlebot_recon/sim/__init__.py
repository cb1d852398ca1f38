"""PyBullet simulator core: worlds, robots, sensors (ROS-free)."""
from .world import Tag, World, WorldError, load_world, world_path  # noqa: F401
