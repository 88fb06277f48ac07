"""A fleet: one wear_monitor per machine namespace plus fleet_monitor aggregating /diagnostics.

    ros2 launch guide_health fleet.launch.py machines:=m1,m2,m3 params_file:=/path/to/machine.yaml \
        history_file:=/var/lib/guide_health/fleet.db

Each machine's state file is <state_dir>/<machine>.db so the monitors never share a checkpoint.
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
    return [Node(package="guide_health", executable="wear_monitor", name="wear_monitor", namespace=m,
                 parameters=[params_file, {"machine_id": m, "state_file": os.path.join(state_dir, f"{m}.db")}],
                 output="screen") for m in machines]


def generate_launch_description():
    share = get_package_share_directory("guide_health")
    return LaunchDescription([
        DeclareLaunchArgument("machines", default_value="m1,m2", description="comma-separated namespaces"),
        DeclareLaunchArgument("params_file", default_value=os.path.join(share, "config", "bench_000.yaml")),
        DeclareLaunchArgument("state_dir", default_value=os.path.expanduser("~/.guide_health")),
        DeclareLaunchArgument("history_file", default_value=""),
        OpaqueFunction(function=machine_nodes),
        Node(package="guide_health", executable="fleet_monitor", name="fleet_monitor",
             parameters=[{"history_file": LaunchConfiguration("history_file")}], output="screen"),
    ])
