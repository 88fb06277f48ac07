"""docs/ros.md's colcon path: the package copied into a fresh workspace's src/, `colcon build --base-paths src`
(the documented command) installs every parameter file, launch file, the resource marker, package.xml, the
Fast DDS profile and every console script, and an installed script starts from the install (not from this
checkout). Skipped where colcon is not installed (`make test` installs it from requirements.txt)."""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "guide_health"
#: what the workspace needs of this checkout to build the package
SOURCES = ("setup.py", "setup.cfg", "package.xml", "resource", "config", "launch", PACKAGE)


def colcon_executable() -> str | None:
    return shutil.which("colcon", path=str(Path(sys.executable).parent)) or shutil.which("colcon")


def console_scripts() -> set[str]:
    return set(re.findall(r'"([\w-]+) = [\w.]+:\w+"', (ROOT / "setup.py").read_text()))


def clean_env() -> dict[str, str]:
    """This process's environment without a sourced workspace or this checkout on the Python path, and with
    the interpreter's bin first (the venv colcon runs in)."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH", "CMAKE_PREFIX_PATH")}
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    return env


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    colcon = colcon_executable()
    if colcon is None:
        pytest.skip("colcon is not installed (requirements.txt installs colcon-common-extensions)")
    ws = tmp_path_factory.mktemp("ws")
    src = ws / "src" / PACKAGE
    src.mkdir(parents=True)
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(ROOT / name, src / name)
    built = subprocess.run([colcon, "build", "--base-paths", "src"], cwd=ws, env=clean_env(),
                           capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    return ws, built.stdout + built.stderr


def test_build_installs_every_file_a_ros_user_needs(workspace):
    ws, output = workspace
    prefix = ws / "install" / PACKAGE
    share = prefix / "share" / PACKAGE
    # colcon-ros adds a missing marker or manifest itself, with this warning: setup.py must install them
    assert "doesn't explicitly install" not in output, output
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE).is_file()
    assert (share / "package.xml").read_text() == (ROOT / "package.xml").read_text()
    configs = sorted(p.name for p in (ROOT / "config").iterdir() if p.is_file())
    assert "pin_on_disc_seed000.csv" in configs and len(configs) >= 8
    assert sorted(p.name for p in (share / "config").iterdir() if p.is_file()) == configs
    assert sorted(p.name for p in (share / "config" / "systemd").iterdir()) == sorted(
        p.name for p in (ROOT / "config" / "systemd").iterdir())
    assert sorted(p.name for p in (share / "launch").iterdir()) == sorted(
        p.name for p in (ROOT / "launch").glob("*.launch.py"))
    site = next(prefix.glob(f"lib/python3*/site-packages/{PACKAGE}"))
    assert (site / "fastdds" / "bag_player.xml").is_file() and (site / "py.typed").is_file()
    scripts = prefix / "lib" / PACKAGE                 # where `ros2 run guide_health <script>` looks
    assert len(console_scripts()) == 6
    assert sorted(p.name for p in scripts.iterdir()) == sorted(console_scripts())
    for script in scripts.iterdir():
        assert os.access(script, os.X_OK), script
    assert (ws / "install" / "setup.bash").is_file()   # colcon-bash: `source install/setup.bash` works


def test_installed_scripts_run_from_the_install(workspace):
    ws, _ = workspace
    scripts = ws / "install" / PACKAGE / "lib" / PACKAGE
    probe = (f". install/setup.sh && export PATH={scripts}:$PATH && "
             "python3 -c 'import guide_health; print(guide_health.__file__)' && "
             "guide-health --help && bag_player --help")
    run = subprocess.run(["sh", "-c", probe], cwd=ws, env=clean_env(), capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    imported_from = Path(run.stdout.splitlines()[0])
    assert imported_from.is_relative_to(ws / "install"), imported_from
    assert "usage: guide-health" in run.stdout and "usage: bag_player" in run.stdout
