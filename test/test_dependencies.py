"""Every module guide_health/, launch/ and test/ import is declared, where a ROS user and a pip user look:
package.xml (<exec_depend> for what the package and its launch files import, <test_depend> for what only the
tests import), setup.py (install_requires, the "test" extra) and requirements.txt (what `make test`
installs). The imports are found in the source (AST); the table below names each one's rosdep key and pip
requirement. A new import without a row, a row no import uses, and a declaration missing anywhere all fail."""
import ast
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
COMMON_INTERFACES = "ros-jazzy-common-interfaces"

#: import name -> (package.xml key, pip requirement that brings it; None: not on PyPI).
#: rclpy's own dependencies (rosgraph_msgs, rcl_interfaces, ament_index_python) come with ros-jazzy-rclpy.
IMPORTS: dict[str, tuple[str, str | None]] = {
    "rclpy": ("rclpy", "ros-jazzy-rclpy"),
    "rosgraph_msgs": ("rosgraph_msgs", "ros-jazzy-rclpy"),
    "rcl_interfaces": ("rcl_interfaces", "ros-jazzy-rclpy"),
    "ament_index_python": ("ament_index_python", "ros-jazzy-rclpy"),
    "sensor_msgs": ("sensor_msgs", COMMON_INTERFACES),
    "geometry_msgs": ("geometry_msgs", COMMON_INTERFACES),
    "std_msgs": ("std_msgs", COMMON_INTERFACES),
    "diagnostic_msgs": ("diagnostic_msgs", COMMON_INTERFACES),
    "std_srvs": ("std_srvs", COMMON_INTERFACES),
    "launch": ("launch", None),                  # ros2 launch: apt ROS only (launch files)
    "launch_ros": ("launch_ros", None),
    "numpy": ("python3-numpy", "numpy"),
    "scipy": ("python3-scipy", "scipy"),
    "yaml": ("python3-yaml", "pyyaml"),
    "matplotlib": ("python3-matplotlib", "matplotlib"),
    "tqdm": ("python3-tqdm", "tqdm"),
    "rosbags": ("python3-rosbags-pip", "rosbags"),
    "apsw": ("python3-apsw", "apsw"),
    "lz4": ("python3-lz4", "lz4"),
    "backports.zstd": ("python3-backports-zstd-pip", "backports-zstd"),
    "dask": ("python3-dask", "dask[distributed]"),
    "distributed": ("python3-distributed", "dask[distributed]"),
    "pytest": ("python3-pytest", "pytest"),
    "hypothesis": ("python3-hypothesis", "hypothesis"),
    "zstandard": ("python3-zstandard", "zstandard"),
    "mcap": ("python3-mcap-pip", "mcap"),
    "ContactMechanics": ("python3-contactmechanics-pip", "contactmechanics"),
    "SurfaceTopography": ("python3-surfacetopography-pip", "surfacetopography"),
    "icalendar": ("python3-icalendar", "icalendar"),
}
#: tools the tests run as programs (no import): package.xml key, pip requirement, the test that runs it
TOOLS = {"ruff": ("ruff", "ruff", "test_code_quality.py")}
#: pytest plugins a command line loads (no import): package.xml key, pip requirement, the file and the option
#: that load it (`make test` runs the suite on three xdist workers)
PLUGINS = {"xdist": ("python3-pytest-xdist", "pytest-xdist", "Makefile", "-n 3")}
#: standard library from Python 3.14 on (guide_health/io/bag/mcap_records.py falls back to backports.zstd)
STDLIB_LATER = {"compression"}
#: namespace packages, named by their first two components
NAMESPACES = {"backports"}


def imported_modules(folder: Path) -> dict[str, set[str]]:
    """Third-party module -> files importing it (absolute imports; relative ones and the project's own
    modules excluded)."""
    # the project's own modules: the package, test helpers and the bench scripts some tests import
    local = {"guide_health"} | {p.stem for d in ("test", "bench") for p in (ROOT / d).glob("*.py")}
    found: dict[str, set[str]] = {}
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module] if node.module.split(".")[0] not in NAMESPACES else \
                    [f"{node.module}.{alias.name}" if node.module.count(".") == 0 else node.module
                     for alias in node.names]
            else:
                continue
            for name in names:
                parts = name.split(".")
                top = ".".join(parts[:2]) if parts[0] in NAMESPACES else parts[0]
                if parts[0] in sys.stdlib_module_names or parts[0] in STDLIB_LATER or parts[0] in local:
                    continue
                found.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return found


def package_xml_keys() -> dict[str, set[str]]:
    """{'exec': {...}, 'test': {...}} from package.xml (comments ignored; <depend> counts as both)."""
    xml = re.sub(r"<!--.*?-->", "", (ROOT / "package.xml").read_text(), flags=re.S)
    keys = {kind: set(re.findall(rf"<{kind}>\s*([^<\s]+)\s*</{kind}>", xml))
            for kind in ("exec_depend", "test_depend", "depend")}
    return {"exec": keys["exec_depend"] | keys["depend"], "test": keys["test_depend"] | keys["depend"]}


def requirement_name(line: str) -> str:
    """'dask[distributed]>=2024.1' -> 'dask[distributed]', 'backports.zstd; python_version...' ->
    'backports-zstd' (PEP 503 normalised, extras kept)."""
    match = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(\[[^\]]*\])?", line)
    assert match, line
    return re.sub(r"[-_.]+", "-", match.group(1)).lower() + (match.group(2) or "")


def setup_py_requirements() -> tuple[set[str], set[str]]:
    """(install_requires, extras_require['test']) of setup.py, read from its source."""
    call = next(node for node in ast.walk(ast.parse((ROOT / "setup.py").read_text()))
                if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "setup")
    keywords = {kw.arg: kw.value for kw in call.keywords}
    install = {requirement_name(r) for r in ast.literal_eval(keywords["install_requires"])}
    test = {requirement_name(r) for r in ast.literal_eval(keywords["extras_require"])["test"]}
    return install, test


def requirements_txt() -> set[str]:
    lines = [line.split("#")[0].strip() for line in (ROOT / "requirements.txt").read_text().splitlines()]
    return {requirement_name(line) for line in lines if line}


def pip_name(requirement: str | None) -> str | None:
    return None if requirement is None else requirement_name(requirement)


RUNTIME = {name: files for folder in ("guide_health", "launch")
           for name, files in imported_modules(ROOT / folder).items()}
TESTS = imported_modules(ROOT / "test")


def test_the_scan_finds_the_imports_it_must():
    """The AST scan itself: known imports in known files (a scan that found nothing would pass the rest)."""
    assert "guide_health/analysis/fleet.py" in RUNTIME["distributed"]
    assert "guide_health/io/bag/mcap_records.py" in RUNTIME["backports.zstd"]
    assert "guide_health/io/bag/mcap_records.py" in RUNTIME["lz4"]
    assert "test/test_mcap_layouts.py" in TESTS["mcap"]
    assert {"launch/machine.launch.py", "launch/fleet.launch.py"} <= RUNTIME["launch_ros"]
    assert "test/test_bulk_read.py" in TESTS["zstandard"]
    assert "test/test_roller_numerical.py" in TESTS["ContactMechanics"]
    assert not {"os", "compression", "guide_health", "reference_wear", "live_feed"} & (set(RUNTIME) | set(TESTS))


def test_every_import_has_a_row_and_every_row_an_import():
    imported = set(RUNTIME) | set(TESTS)
    assert not imported - set(IMPORTS), f"imports without a row in IMPORTS: {sorted(imported - set(IMPORTS))}"
    assert not set(IMPORTS) - imported, f"rows no file imports: {sorted(set(IMPORTS) - imported)}"


def test_package_xml_declares_every_import():
    keys = package_xml_keys()
    missing_exec = {name: (IMPORTS[name][0], sorted(files)[:2]) for name, files in RUNTIME.items()
                    if IMPORTS[name][0] not in keys["exec"]}
    assert not missing_exec, f"imported by the package or its launch files, no <exec_depend>: {missing_exec}"
    missing_test = {name: (IMPORTS[name][0], sorted(files)[:2]) for name, files in TESTS.items()
                    if IMPORTS[name][0] not in keys["exec"] | keys["test"]}
    assert not missing_test, f"imported by the tests, no <exec_depend> or <test_depend>: {missing_test}"
    for tool, (key, _, test_file) in TOOLS.items():
        assert tool in (ROOT / "test" / test_file).read_text()
        assert key in keys["test"], f"{tool} (run by {test_file}) has no <test_depend>"
    for plugin, (key, _, user, option) in PLUGINS.items():
        assert option in (ROOT / user).read_text(), f"{user} no longer loads {plugin} ({option})"
        assert key in keys["test"], f"{plugin} (loaded by {user}) has no <test_depend>"


def test_package_xml_declares_nothing_unused():
    keys = package_xml_keys()
    test_only = {IMPORTS[name][0] for name in set(TESTS) - set(RUNTIME)} | {k for k, _, _ in TOOLS.values()} | {
        k for k, _, _, _ in PLUGINS.values()}
    assert keys["exec"] == {IMPORTS[name][0] for name in RUNTIME}, "exec_depend keys no import needs (or missing)"
    assert keys["test"] == test_only, "test_depend keys: only what the tests alone import or run"


def test_setup_py_and_requirements_txt_install_every_import():
    install, test_extra = setup_py_requirements()
    wanted = requirements_txt()
    for name in RUNTIME:
        requirement = pip_name(IMPORTS[name][1])
        if requirement is None:
            assert all(f.startswith("launch/") for f in RUNTIME[name]), f"{name}: not on PyPI, only for launch files"
        elif requirement.startswith("ros-jazzy-"):       # ROS 2 itself: apt, or PyPI wheels for `make`
            assert requirement in {r.split("[")[0] for r in wanted}, (name, requirement)
        else:
            assert requirement in install, f"{name}: {requirement} not in setup.py install_requires"
            assert requirement in wanted, f"{name}: {requirement} not in requirements.txt"
    for name in set(TESTS) - set(RUNTIME):
        requirement = pip_name(IMPORTS[name][1])
        if requirement.startswith("ros-jazzy-"):
            assert requirement in {r.split("[")[0] for r in wanted}, (name, requirement)
            continue
        assert requirement in install | test_extra, f"{name}: {requirement} not in setup.py's 'test' extra"
        assert requirement in wanted, f"{name}: {requirement} not in requirements.txt"
    for tool, (_, requirement, _) in TOOLS.items():
        assert requirement in test_extra and requirement in wanted, tool
    for plugin, (_, requirement, _, _) in PLUGINS.items():
        assert requirement in test_extra and requirement in wanted, plugin
    # the colcon install test (test_colcon_install.py) runs where `make test` installed colcon
    assert "colcon-common-extensions" in wanted


def test_fleet_on_dask_without_dask_is_one_line_naming_the_package(monkeypatch):
    """Dask is declared; a hand-made environment without it gets one line naming the package, not a
    ModuleNotFoundError traceback (and --workers 0 still runs in-process)."""
    from guide_health.analysis.fleet import run_fleet
    from guide_health.errors import InputError

    monkeypatch.setitem(sys.modules, "distributed", None)      # find_spec -> None, import -> ImportError
    with pytest.raises(InputError) as info:
        run_fleet("replay", lambda *args: {}, [Path("/nonexistent/m1"), Path("/nonexistent/m2")], ["p.yaml"],
                  Path("/nonexistent/out"), (), workers=2)
    message = str(info.value)
    assert "\n" not in message and "'distributed'" in message and "pip install 'dask[distributed]'" in message
