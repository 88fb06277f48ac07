"""config/systemd/guide-health-wear@.service: one wear_monitor per machine at boot. systemd checks the unit
(`systemd-analyze verify`, skipped where it is absent); its ExecStart, expanded for an instance as systemd
expands it (systemd.service(5) "Command lines": the line split into words with quotes, then "%i" the
instance, "${VAR}" a variable's value as one word, "$VAR" alone as a word split at whitespace; the
program itself a literal absolute path), runs as written in systemd's clean environment plus the
machine's EnvironmentFile, under its namespace on the test's own domain, and the node reports the params
file's machine_id on /diagnostics and writes its start-up line to its output (the journal) while running."""
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
UNIT = ROOT / "config" / "systemd" / "guide-health-wear@.service"
ENV_EXAMPLE = ROOT / "config" / "systemd" / "machine.env.example"
#: what the system manager gives a service besides its Environment=/EnvironmentFile= (systemd.exec(5))
SYSTEMD_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"


def unit_settings(text: str) -> dict[str, list[str]]:
    """Key -> values of the unit's [Service] section (a key may repeat)."""
    settings: dict[str, list[str]] = {}
    section = ""
    for line in text.splitlines():
        line = line.strip()
        if not line or line[0] in "#;":
            continue
        if line.startswith("["):
            section = line.strip("[]")
            continue
        key, _, value = line.partition("=")
        settings.setdefault(f"{section}.{key}", []).append(value)
    return settings


def environment_file(text: str) -> dict[str, str]:
    """VAR=value lines (systemd.exec(5) EnvironmentFile=; '#' lines are comments)."""
    return dict(line.split("=", 1) for line in text.splitlines() if line.strip() and not line.startswith("#"))


def expand_exec(line: str, instance: str, env: dict[str, str]) -> list[str]:
    """The argv systemd runs for ExecStart ``line`` of instance ``instance`` with environment ``env``."""
    argv = []
    for word in shlex.split(line.replace("%i", instance).replace("%%", "%")):
        alone = re.fullmatch(r"\$([A-Za-z_][A-Za-z0-9_]*)", word)
        if alone:
            argv += env.get(alone.group(1), "").split()
        else:
            argv.append(re.sub(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}", lambda m: env.get(m.group(1), ""), word))
    return argv


def test_unit_and_environment_file_say_what_a_machine_needs():
    settings = unit_settings(UNIT.read_text())
    assert settings["Service.EnvironmentFile"] == ["/etc/guide_health/%i.env"]
    assert settings["Service.Restart"] == ["on-failure"]
    assert settings["Service.RestartPreventExitStatus"] == ["2"]            # bad parameters: no restart loop
    assert settings["Install.WantedBy"] == ["multi-user.target"]
    exec_start = settings["Service.ExecStart"][0]
    assert exec_start.split()[0] == "/usr/bin/env"                        # a literal program (systemd's rule)
    example = environment_file(ENV_EXAMPLE.read_text())
    assert set(example) == {"GUIDE_HEALTH_VENV", "MACHINE_NAMESPACE", "PARAMS_FILE", "ROS_DOMAIN_ID"}
    argv = expand_exec(exec_start, "m1", example)
    assert argv == ["/usr/bin/env", "/opt/guide_health/venv/bin/wear_monitor", "--ros-args", "-r", "__ns:=/m1",
                    "--params-file", "/etc/guide_health/m1.yaml"]


def test_systemd_analyze_verifies_the_unit(tmp_path):
    tool = shutil.which("systemd-analyze")
    if tool is None:
        pytest.skip("systemd-analyze is not installed")
    for name in ("guide-health-wear@.service", "guide-health-wear@m1.service"):   # template and an instance
        shutil.copy(UNIT, tmp_path / name)
        proc = subprocess.run([tool, "verify", str(tmp_path / name)], capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0 and proc.stderr.strip() == "", proc.stderr        # no warning either


@pytest.mark.ros
def test_the_expanded_exec_start_runs_the_machine_under_its_namespace(tmp_path, ros_test_env):
    from guide_health.nodes.session import PLAYER_WAIT_TIMEOUT_S, DiagnosticsCollector

    test_env = ros_test_env()
    machine_env = dict(environment_file(ENV_EXAMPLE.read_text()),
                       GUIDE_HEALTH_VENV=str(Path(sys.executable).parent.parent),    # this venv
                       PARAMS_FILE=str(ROOT / "config" / "bench_000.yaml"),           # machine_id bench_000
                       ROS_DOMAIN_ID=test_env["ROS_DOMAIN_ID"])
    settings = unit_settings(UNIT.read_text())
    assert settings["Service.Environment"] == ["ROS_HOME=%S ROS_LOG_DIR=%L/guide_health"]
    state, logs = tmp_path / "var-lib", tmp_path / "var-log"                          # %S, %L
    env = {"PATH": SYSTEMD_PATH, "LANG": "C.UTF-8", **machine_env, "ROS_HOME": str(state),
           "ROS_LOG_DIR": str(logs / "guide_health"),
           **{k: test_env[k] for k in ("FASTDDS_BUILTIN_TRANSPORTS", "ROS_AUTOMATIC_DISCOVERY_RANGE")}}
    if os.environ.get("PYTHONPATH"):
        env["PYTHONPATH"] = os.environ["PYTHONPATH"]          # the code under test (a worktree) over the venv's
    argv = expand_exec(settings["Service.ExecStart"][0], "m1", machine_env)
    collector = DiagnosticsCollector("collector_systemd")
    journal = tmp_path / "journal.log"
    with open(journal, "w") as out:
        proc = subprocess.Popen(argv, env=env, stdout=out, stderr=subprocess.STDOUT, cwd=tmp_path)
    try:
        end, seen = time.monotonic() + PLAYER_WAIT_TIMEOUT_S, None
        while time.monotonic() < end and seen is None and proc.poll() is None:
            seen = next((name for name, s in list(collector.latest.items()) if s["hardware_id"] == "bench_000"),
                        None)
            time.sleep(0.1)
        assert seen is not None, journal.read_text()
        assert seen.startswith("bench_000/wear_monitor: ")
        start = [line for line in journal.read_text().splitlines() if "start: " in line]   # already written
        assert len(start) == 1, journal.read_text()
        assert "machine_id bench_000, node /m1/wear_monitor" in start[0]
        assert f"{machine_env['PARAMS_FILE']} [/**/wear_monitor]" in start[0]
        assert str(state / "guide_health" / "bench_000" / "wear_monitor.db") in start[0]
    finally:
        proc.send_signal(signal.SIGTERM)                     # systemctl stop
        try:
            code = proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = proc.wait()
        collector.close()
    assert code == 0, journal.read_text()                    # a clean stop is no failure to restart on
    assert (state / "guide_health" / "bench_000" / "wear_monitor.db").is_file()
