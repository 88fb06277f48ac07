"""Package wiring a ROS user relies on: console scripts resolve, launch files name real executables and
files, package.xml and setup.py agree. (launch_ros is not on PyPI, so launch files are checked statically.)"""
import ast
import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def console_scripts() -> dict[str, str]:
    text = (ROOT / "setup.py").read_text()
    return dict(re.findall(r'"([\w-]+) = ([\w.]+:\w+)"', text))


def test_every_console_script_imports_and_has_its_main():
    scripts = console_scripts()
    assert set(scripts) == {"guide-health", "wear_monitor", "slewing_monitor", "fleet_monitor", "vibration_monitor",
                            "bag_player"}
    for name, target in scripts.items():
        module, func = target.split(":")
        assert callable(getattr(importlib.import_module(module), func)), name


@pytest.mark.parametrize("launch_file", sorted((ROOT / "launch").glob("*.launch.py")), ids=lambda p: p.name)
def test_launch_files_name_installed_executables(launch_file):
    tree = ast.parse(launch_file.read_text())
    executables = {kw.value.value for node in ast.walk(tree) if isinstance(node, ast.Call)
                   for kw in node.keywords if kw.arg == "executable" and isinstance(kw.value, ast.Constant)}
    packages = {kw.value.value for node in ast.walk(tree) if isinstance(node, ast.Call)
                for kw in node.keywords if kw.arg == "package" and isinstance(kw.value, ast.Constant)}
    assert executables and executables <= set(console_scripts())
    assert packages == {"guide_health"}
    for call in ast.walk(tree):   # default config files exist in the package
        if isinstance(call, ast.Call) and getattr(call.func, "attr", "") == "join":
            parts = [a.value for a in call.args if isinstance(a, ast.Constant)]
            if parts[:1] == ["config"]:
                assert (ROOT / Path(*parts)).exists(), parts


def test_package_xml_declares_the_runtime_dependencies():
    xml = (ROOT / "package.xml").read_text()
    assert 'format="3"' in xml
    for dep in ("rclpy", "sensor_msgs", "geometry_msgs", "std_msgs", "diagnostic_msgs", "python3-numpy",
                "python3-scipy"):
        assert f">{dep}<" in xml, dep
    assert "<build_type>ament_python</build_type>" in xml


def test_the_docs_name_every_console_script():
    """docs/ros.md's table and the README's list of console scripts name all of setup.py's."""
    table = (ROOT / "docs" / "ros.md").read_text().split("## Console scripts")[1].split("\n## ")[0]
    readme = (ROOT / "README.md").read_text()
    listed = re.search(r"six console\s+scripts\s+are(.{0,200})", readme, re.S).group(1)
    for name in console_scripts():
        assert f"| `{name}` |" in table, name
        assert f"`{name}`" in listed, name
