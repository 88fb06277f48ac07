from glob import glob

from setuptools import find_packages, setup

package_name = "guide_health"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "bench"]),
    package_data={package_name: ["fastdds/*.xml", "py.typed"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", sorted(glob("config/*.yaml") + glob("config/*.csv"))),
        ("share/" + package_name + "/config/systemd", sorted(glob("config/systemd/*"))),
        ("share/" + package_name + "/launch", sorted(glob("launch/*.launch.py"))),
    ],
    # every module guide_health/ imports (test/test_dependencies.py checks it against package.xml); rclpy
    # and the message packages come from ROS 2 (apt, or ros-jazzy-* from PyPI: requirements.txt)
    install_requires=["setuptools", "numpy", "scipy", "pyyaml", "matplotlib", "tqdm", "rosbags",
                      "apsw", "lz4", "backports.zstd; python_version < '3.14'", "dask[distributed]"],
    zip_safe=True,
    maintainer="guide_health developers",
    maintainer_email="guide-health@example.com",
    description="Guideway and slewing-bearing condition monitoring for ROS 2",
    license="Apache-2.0",
    extras_require={"test": ["pytest", "pytest-xdist", "hypothesis", "zstandard", "mcap", "contactmechanics",
                             "SurfaceTopography", "ruff", "icalendar"]},
    entry_points={
        "console_scripts": [
            "guide-health = guide_health.cli:main",
            "wear_monitor = guide_health.nodes.wear_monitor:main",
            "slewing_monitor = guide_health.nodes.slewing_monitor:main",
            "fleet_monitor = guide_health.nodes.fleet_monitor:main",
            "vibration_monitor = guide_health.nodes.vibration_monitor:main",
            "bag_player = guide_health.nodes.bag_player:main",
        ],
    },
)
