"""Thin rclpy adapters around guide_health.models."""
import sys as _sys

from guide_health.nodes.usage import exit_on_help as _exit_on_help

# `wear_monitor --help` (a console script: argv[0] names the node) answers here, before the node module
# imports rclpy, numpy and scipy; `python -m guide_health.nodes.<node> --help` is answered by run_node
_exit_on_help(_sys.argv)
