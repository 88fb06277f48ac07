"""Pure physics: numpy/scipy only, SI units, no ROS, no I/O."""
