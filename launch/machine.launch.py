"""One machine: wear_monitor (and optionally slewing_monitor) in the machine's namespace.

    ros2 launch guide_health machine.launch.py namespace:=m1 params_file:=/path/to/machine.yaml \
        [slewing_params_file:=/path/to/slewing.yaml]

The params files are passed to rcl as they are: their sections must apply in the namespace
(``/**/wear_monitor:``, ``/**/slewing_monitor:`` as in every shipped config; a ``wear_monitor:`` section is
the root namespace's only, and the node exits 2 naming the file, its sections and its full name).
Topics resolve in the namespace (/m1/joint_states, /m1/guide/load, ...); /diagnostics is absolute, so a
fleet_monitor sees every machine. The state file is the params file's state_file (shipped configs: auto =
$ROS_HOME/guide_health/<machine_id>/wear_monitor.db). Needs a ROS 2 installation with `launch_ros` (not on
PyPI: without it, start the console scripts directly, e.g. `wear_monitor --ros-args -r __ns:=/m1 --params-file FILE`).
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PythonExpression
from launch_ros.actions import Node

from launch import LaunchDescription


def generate_launch_description():
    share = get_package_share_directory("guide_health")
    namespace = LaunchConfiguration("namespace")
    params_file = LaunchConfiguration("params_file")
    slewing_params = LaunchConfiguration("slewing_params_file")
    return LaunchDescription([
        DeclareLaunchArgument("namespace", default_value="m1", description="machine namespace"),
        DeclareLaunchArgument("params_file", default_value=os.path.join(share, "config", "bench_000.yaml"),
                              description="wear_monitor parameters (ROS 2 parameters YAML)"),
        DeclareLaunchArgument("slewing_params_file", default_value="",
                              description="slewing_monitor parameters; empty: no slewing_monitor"),
        Node(package="guide_health", executable="wear_monitor", name="wear_monitor", namespace=namespace,
             parameters=[params_file], output="screen"),
        Node(package="guide_health", executable="slewing_monitor", name="slewing_monitor",
             namespace=namespace, parameters=[slewing_params], output="screen",
             condition=IfCondition(PythonExpression(["'", slewing_params, "' != ''"]))),
    ])
