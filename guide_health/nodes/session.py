"""Run the live pipeline (bag_player -> topics -> node -> /diagnostics) from Python: used by the demo and
the replay tests. Processes are real ROS 2 processes on an isolated, localhost-only DDS domain."""
from __future__ import annotations

import glob
import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from guide_health.models.levels import Level


def isolated_ros_env(domain_id: int | None = None, transports: str | None = None) -> dict[str, str]:
    """Environment for ROS 2 processes that never cross-talk with other runs: localhost discovery only and
    a per-run domain id. ``transports="UDPv4"`` switches Fast DDS off shared memory
    (FASTDDS_BUILTIN_TRANSPORTS): a SIGKILLed process leaves its shared-memory ports locked, and a process
    started after it may then fail to open them ("open_and_lock_file failed") and stay undiscovered.
    rmw_fastrtps replaces the built-in transports by its own (UDP on 127.0.0.1 + shared memory) when the
    discovery range is LOCALHOST, so with ``transports`` the range is SUBNET and the random domain id is
    what keeps runs apart."""
    env = dict(os.environ)
    if transports:
        env["FASTDDS_BUILTIN_TRANSPORTS"] = transports
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"
    else:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_DOMAIN_ID"] = str(domain_id if domain_id is not None else random.randint(1, 100))
    env.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    env["PYTHONUNBUFFERED"] = "1"
    return env


def clean_fastdds_shm() -> int:
    """Remove Fast DDS shared-memory files whose owner process is gone (left by a SIGKILL)."""
    removed = 0
    patterns = ("/dev/shm/fastrtps_*", "/dev/shm/fastdds_*", "/dev/shm/sem.fastrtps_*")
    for lock in [path for pattern in patterns for path in glob.glob(pattern)]:
        name = os.path.basename(lock)
        if "port" in name and name.endswith("_el"):
            continue
        try:
            # segments in use are locked by their owner; an unlocked, old segment is a leftover
            if time.time() - os.path.getmtime(lock) > 1.0 and _not_in_use(lock):
                os.unlink(lock)
                removed += 1
        except OSError:
            pass
    return removed


def _not_in_use(path: str) -> bool:
    import fcntl

    try:
        with open(path, "rb") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            fcntl.flock(handle, fcntl.LOCK_UN)
        return True
    except OSError:
        return False


def start_node(executable_module: str, params_file: str | Path | list | None, overrides: dict | None,
               env: dict[str, str], log_path: str | Path | None = None) -> subprocess.Popen:
    """Start a node (``python -m guide_health.nodes.<name>``) with a params file (or several, the later
    overriding, as rcl merges them) and ``-p`` overrides."""
    cmd = [sys.executable, "-m", executable_module, "--ros-args"]
    for path in params_file if isinstance(params_file, (list, tuple)) else [params_file] if params_file else []:
        cmd += ["--params-file", str(path)]
    for key, value in (overrides or {}).items():
        cmd += ["-p", f"{key}:={value}"]
    out = open(log_path, "w") if log_path else subprocess.DEVNULL
    return subprocess.Popen(cmd, env=env, stdout=out, stderr=subprocess.STDOUT)


def stop_node(proc: subprocess.Popen, timeout: float = 15.0) -> int:
    """SIGINT (clean shutdown: the node writes its last checkpoint), then SIGKILL if it hangs."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


def play_bag(bag: str | Path, env: dict[str, str], extra: list[str] | None = None,
             timeout: float = 600.0) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "guide_health.nodes.bag_player", str(bag)] + list(extra or [])
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)


class DiagnosticsCollector:
    """Subscribes /diagnostics in this process (in a background executor thread) and keeps the latest
    status per name. Call inside an environment set up with :func:`isolated_ros_env` (os.environ)."""

    def __init__(self, node_name: str = "diagnostics_collector"):
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.executors import SingleThreadedExecutor

        self._rclpy = rclpy
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(node_name, context=self.context)
        self.latest: dict[str, dict] = {}
        self.history: dict[str, list[dict]] = {}       # every status received, per name
        self.count = 0
        self._lock = threading.Lock()
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_array, 100)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # shutdown races
            pass

    def _on_array(self, msg) -> None:
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec   # the node's clock
        with self._lock:
            for status in msg.status:
                self.latest[status.name] = entry = {
                    "level": int(Level.parse(status.level)),
                    "message": status.message,
                    "hardware_id": status.hardware_id,
                    "values": {kv.key: kv.value for kv in status.values},
                    "received": time.monotonic(),
                    "stamp_ns": stamp_ns,
                }
                self.history.setdefault(status.name, []).append(entry)
                self.count += 1

    def get(self, name: str) -> dict | None:
        with self._lock:
            entry = self.latest.get(name)
            return None if entry is None else dict(entry)

    def wait_for(self, name: str, predicate=lambda status: True, timeout: float = 30.0) -> dict | None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            status = self.get(name)
            if status is not None and predicate(status):
                return status
            time.sleep(0.05)
        return None

    def wait_settled(self, name: str, key: str, settle_s: float = 2.0, timeout: float = 60.0) -> dict | None:
        """Latest status once ``key`` has not changed for ``settle_s`` (the node has drained its queue)."""
        end = time.monotonic() + timeout
        last_value, since = None, time.monotonic()
        while time.monotonic() < end:
            status = self.get(name)
            value = None if status is None else status["values"].get(key)
            if value != last_value:
                last_value, since = value, time.monotonic()
            elif value is not None and time.monotonic() - since >= settle_s:
                return status
            time.sleep(0.05)
        return self.get(name)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self._rclpy.shutdown(context=self.context)
        self._thread.join(timeout=5)


def settled_status_after_bag(executable_module: str, params_file: str | Path | list, overrides: dict | None,
                             env: dict[str, str], bag: str | Path, status_name: str, log_path: str | Path,
                             settle_key: str = "sliding_distance_m", collector_name: str = "bag_collector",
                             timeout: float = 120.0) -> dict:
    """Start a node, wait for its status ``status_name``, play ``bag`` into it at full rate (waiting for a
    subscriber), and return the status once ``settle_key`` has stopped changing; the node is stopped and the
    collector closed whatever happens. RuntimeError (with the node's log or bag_player's stderr) when the
    node does not come up or the player fails."""
    collector = DiagnosticsCollector(collector_name)
    node = start_node(executable_module, params_file, overrides, env, log_path=log_path)
    try:
        if collector.wait_for(status_name, timeout=30.0) is None:
            raise RuntimeError(f"{status_name!r} never published:\n{Path(log_path).read_text()}")
        played = play_bag(bag, env, ["--wait-subscribers", "1", "--max-rate", "0"])
        if played.returncode != 0:
            raise RuntimeError(f"bag_player failed:\n{played.stderr}")
        return collector.wait_settled(status_name, settle_key, settle_s=2.0, timeout=timeout)
    finally:
        stop_node(node)
        collector.close()
        clean_fastdds_shm()
