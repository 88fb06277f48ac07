"""guide_health: guideway and slewing-bearing condition monitoring (ROS 2)."""
__version__ = "0.1.0"
