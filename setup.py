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
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/launch", glob("launch/*.py")),
    ],
    install_requires=["setuptools", "numpy", "scipy", "rosbags", "pyyaml", "matplotlib", "tqdm"],
    zip_safe=True,
    maintainer="guide_health developers",
    maintainer_email="guide-health@example.com",
    description="Guideway and slewing-bearing condition monitoring for ROS 2",
    license="Apache-2.0",
    tests_require=["pytest"],
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
