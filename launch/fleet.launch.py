"""A fleet: one wear_monitor per machine namespace plus fleet_monitor aggregating /diagnostics.

    ros2 launch guide_health fleet.launch.py machines:=m1,m2,m3 params_file:=/path/to/machine.yaml \
        history_file:=/var/lib/guide_health/fleet.db

The params file goes to every machine's node as it is: its section must apply in any namespace
(``/**/wear_monitor:``, as in every shipped config); machine_id and state_file are set per machine on top.
Each machine's state file is $ROS_HOME/guide_health/<machine>/wear_monitor.db (state_file auto, machine_id =
the namespace), or <state_dir>/<machine>.db with state_dir:=DIR, so the monitors never share a checkpoint (a
second process on one state file is refused by its lock).
Needs a ROS 2 installation with `launch_ros` (see machine.launch.py).
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from launch import LaunchDescription


def machine_nodes(context):
    machines = [m.strip() for m in LaunchConfiguration("machines").perform(context).split(",") if m.strip()]
    params_file = LaunchConfiguration("params_file").perform(context)
    state_dir = LaunchConfiguration("state_dir").perform(context)
    def state_file(m: str) -> str:
        return os.path.join(state_dir, f"{m}.db") if state_dir else "auto"

    return [Node(package="guide_health", executable="wear_monitor", name="wear_monitor", namespace=m,
                 parameters=[params_file, {"machine_id": m, "state_file": state_file(m)}],
                 output="screen") for m in machines]


def generate_launch_description():
    share = get_package_share_directory("guide_health")
    return LaunchDescription([
        DeclareLaunchArgument("machines", default_value="m1,m2", description="comma-separated namespaces"),
        DeclareLaunchArgument("params_file", default_value=os.path.join(share, "config", "bench_000.yaml")),
        DeclareLaunchArgument("state_dir", default_value="",
                              description="folder of the state files; empty: $ROS_HOME/guide_health/<machine>/"),
        DeclareLaunchArgument("history_file", default_value=""),
        OpaqueFunction(function=machine_nodes),
        Node(package="guide_health", executable="fleet_monitor", name="fleet_monitor",
             parameters=[{"history_file": LaunchConfiguration("history_file")}], output="screen"),
    ])
