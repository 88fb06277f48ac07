"""Code-quality promises of the layout (README "Project tree"): ruff passes, the package is typed, the
physics in models/ is pure (no ROS, no database, no serialisation, no file I/O), and no module or function
outgrows the limits the layout set (600 lines a module, 80 lines a function)."""
import ast
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "guide_health"
MODELS = PACKAGE / "models"

#: modules whose import means ROS, a database, a serialisation format or a bag library
IMPURE_MODULES = ("rclpy", "rosbags", "sqlite3", "apsw", "json", "yaml", "pickle", "csv", "matplotlib",
                  "diagnostic_msgs", "sensor_msgs", "geometry_msgs", "std_msgs", "rcl_interfaces")
#: calls that read or write files
FILE_IO_CALLS = ("open", "read_text", "write_text", "read_bytes", "write_bytes", "savetxt", "loadtxt", "save",
                 "load", "savez", "fromfile", "tofile", "mkdir", "unlink")


def _python_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.py") if "__pycache__" not in p.parts)


def _imported_modules(tree: ast.AST) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def test_ruff_passes():
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if ruff is None:
        pytest.skip("ruff is not installed (it is in requirements.txt)")
    result = subprocess.run([ruff, "check", "--no-cache", "guide_health", "test", "bench", "launch"], cwd=ROOT,
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-1000:]


def test_package_is_typed():
    assert (PACKAGE / "py.typed").is_file()
    assert '"py.typed"' in (ROOT / "setup.py").read_text()


@pytest.mark.parametrize("path", _python_files(MODELS), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_models_import_no_ros_storage_or_serialisation_and_do_no_file_io(path):
    tree = ast.parse(path.read_text())
    impure = {m for m in _imported_modules(tree) if m.split(".")[0] in IMPURE_MODULES}
    assert not impure, f"{path.name} imports {sorted(impure)}"
    inside = {m for m in _imported_modules(tree) if m.startswith("guide_health.")}
    allowed = ("guide_health.models", "guide_health.errors", "guide_health.runs")
    assert all(m.startswith(allowed) for m in inside), sorted(inside)
    calls = {node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
             for node in ast.walk(tree) if isinstance(node, ast.Call)}
    assert not calls & set(FILE_IO_CALLS), f"{path.name} calls {sorted(calls & set(FILE_IO_CALLS))}"


def test_importing_every_model_loads_no_ros_storage_or_bag_library():
    """Transitively too: a fresh interpreter imports every models/ module and lists what it loaded."""
    modules = [".".join(p.relative_to(ROOT).with_suffix("").parts) for p in _python_files(MODELS)]
    code = ("import importlib, json, sys\n"
            f"before = set(sys.modules)\n"
            f"for m in {modules!r}: importlib.import_module(m.removesuffix('.__init__'))\n"
            "print(json.dumps(sorted(set(sys.modules) - before)))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    loaded = {name.split(".")[0] for name in json.loads(out.stdout)}
    forbidden = {"rclpy", "rosbags", "sqlite3", "apsw", "matplotlib", "diagnostic_msgs", "rcl_interfaces"}
    assert not loaded & forbidden, sorted(loaded & forbidden)


def test_no_module_over_600_lines_and_no_function_over_80():
    too_long = []
    for path in _python_files(PACKAGE):
        text = path.read_text()
        if text.count("\n") > 600:
            too_long.append(f"{path.relative_to(ROOT)}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > 80:
                    too_long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {length} lines")
    assert not too_long, too_long
