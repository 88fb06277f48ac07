"""``--help`` / ``-h`` of the node scripts: usage text, printed without importing rclpy or starting ROS.

Imported by ``guide_health/nodes/__init__.py`` before a node module's heavy imports (rclpy, numpy, scipy:
over a second), so that ``wear_monitor --help`` answers at once, creates no file and joins no DDS domain.
Only the standard library here.
"""
from __future__ import annotations

import os
import sys

DOCS = "docs/interfaces.md"
#: node script -> (what it does, topics in, topics out, an example command)
NODES = {
    "wear_monitor": (
        "live precision monitor of a guideway, or of every axis of a machine (axes: [x, y, z])",
        "joint_states (sensor_msgs/JointState), guide/load (geometry_msgs/WrenchStamped), guide/straightness "
        "(std_msgs/Float64), guide/temperature (sensor_msgs/Temperature, optional); per axis <axis>/guide/... "
        "with `axes`; maintenance/events (diagnostic_msgs/DiagnosticArray)",
        "/diagnostics, guide/straightness_predicted, guide/remaining_life (std_msgs/Float64), maintenance/events",
        "wear_monitor --ros-args -r __ns:=/m1 --params-file config/bench_000.yaml"),
    "slewing_monitor": (
        "roller contact stress of a three-row slewing bearing from its load",
        "slewing/load (geometry_msgs/WrenchStamped)",
        "/diagnostics",
        "slewing_monitor --ros-args -r __ns:=/crane --params-file config/slewing_131.32.2000.00Z.yaml"),
    "vibration_monitor": (
        "failure signs of a rolling guide from accelerometer blocks and sound pressure",
        "guide/acceleration (sensor_msgs/LaserScan), guide/sound_pressure (sensor_msgs/FluidPressure)",
        "/diagnostics",
        "vibration_monitor --ros-args -r __ns:=/bench --params-file config/life_test_seed004.yaml"),
    "fleet_monitor": (
        "one status for a fleet of machines from every machine's /diagnostics, and a SQLite history",
        "/diagnostics (diagnostic_msgs/DiagnosticArray)",
        "/diagnostics",
        "fleet_monitor --ros-args -p history_file:=/var/lib/guide_health/fleet.db"),
}


def help_requested(argv: list[str]) -> bool:
    """``-h`` or ``--help`` among the program's own arguments (before ``--ros-args``: after it they are rcl's)."""
    own = argv[1:argv.index("--ros-args")] if "--ros-args" in argv else argv[1:]
    return "-h" in own or "--help" in own


def usage(name: str) -> str:
    what, inputs, outputs, example = NODES[name]
    return (f"usage: {name} [-h] [--ros-args [-r __ns:=/NAMESPACE] [--params-file FILE ...] "
            f"[-p NAME:=VALUE ...]]\n\n"
            f"{name}: {what}.\n\n"
            f"subscribes: {inputs}\n"
            f"publishes:  {outputs}\n\n"
            f"parameters: the table in {DOCS} (section Parameters), names, units and ranges in the schema "
            f"(guide_health/params/); a parameters file's section '/**/{name}:' applies in any namespace.\n"
            f"example:    {example}\n"
            f"On start the node logs one line: machine_id, full name, axes, the parameters files and sections "
            f"applied, the state file (resumed or new).\n")


def exit_on_help(argv: list[str]) -> None:
    """Print the usage and exit 0 when ``argv`` is a node script's asking for help; else return."""
    name = os.path.basename(argv[0]) if argv else ""
    name = name.removesuffix(".py")
    if name in NODES and help_requested(argv):
        sys.stdout.write(usage(name))
        sys.stdout.flush()
        raise SystemExit(0)
