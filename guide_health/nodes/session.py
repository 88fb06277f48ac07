"""Run the live pipeline (bag_player -> topics -> node -> /diagnostics) from Python: used by the demo and
the replay tests. Processes are real ROS 2 processes on a DDS domain of their own (isolated_ros_env)."""
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

#: the domain ids a run may take (0 is every ROS user's default; 232 is the last Fast DDS accepts)
DOMAIN_IDS = range(1, 233)
#: RTPS well-known ports (PB + DG * domain + ...): every participant of a domain binds UDP ports in
#: [PORT_BASE + PORT_DOMAIN_GAIN * d, PORT_BASE + PORT_DOMAIN_GAIN * (d + 1))
PORT_BASE, PORT_DOMAIN_GAIN = 7400, 250
_held_domains: list[DomainReservation] = []     # reservations of isolated_ros_env(), kept for the process


class DomainReservation:
    """A DDS domain id held by this process: an exclusive flock on ``<tmp>/guide_health_ros_domains/<id>.lock``
    (every run of this package on the host skips a locked id) taken only while no UDP port of the domain is
    bound on the host (/proc/net/udp: no participant of any other program is in it). Released by
    :meth:`release` or when the process ends."""

    def __init__(self, domain_id: int, handle):
        self.domain_id, self._handle = domain_id, handle

    def release(self) -> None:
        if self._handle is not None:
            self._handle.close()                 # closing the file drops the flock
            self._handle = None


def bound_udp_ports() -> set[int]:
    """Local UDP ports bound on this host (IPv4 and IPv6); empty where /proc is not readable."""
    ports: set[int] = set()
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 1 and ":" in fields[1]:
                ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


def domain_in_use(domain_id: int, ports: set[int] | None = None) -> bool:
    """True when a UDP port of ``domain_id`` is bound on this host (some DDS participant is in it)."""
    low = PORT_BASE + PORT_DOMAIN_GAIN * domain_id
    return any(low <= port < low + PORT_DOMAIN_GAIN for port in (bound_udp_ports() if ports is None else ports))


def reserve_domain(rng: random.Random | None = None) -> DomainReservation:
    """A free domain id, held until released (:class:`DomainReservation`). RuntimeError when every id is
    locked or in use."""
    import fcntl
    import tempfile

    lock_dir = Path(tempfile.gettempdir()) / "guide_health_ros_domains"
    lock_dir.mkdir(mode=0o777, exist_ok=True)
    candidates = list(DOMAIN_IDS)
    (rng or random.SystemRandom()).shuffle(candidates)
    for domain_id in candidates:
        handle = open(lock_dir / f"{domain_id}.lock", "a")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:                          # another run holds it
            handle.close()
            continue
        if domain_in_use(domain_id):             # a program that takes no lock (another ROS user) is in it
            handle.close()
            continue
        return DomainReservation(domain_id, handle)
    raise RuntimeError(f"no free ROS domain id in {DOMAIN_IDS.start}..{DOMAIN_IDS.stop - 1} on this host")


def isolated_ros_env(domain_id: int | None = None, transports: str | None = None) -> dict[str, str]:
    """Environment for ROS 2 processes that never cross-talk with other runs: a domain id of their own
    (``domain_id``, else one reserved for this process's lifetime: :func:`reserve_domain`) and either
    localhost-only discovery (shared memory + UDP on 127.0.0.1) or, with ``transports="UDPv4"`` (default:
    the caller's FASTDDS_BUILTIN_TRANSPORTS, as the live tests set it), UDP only. UDP only makes a run
    independent of /dev/shm: a SIGKILLed process leaves its shared-memory ports locked, and a process
    started after it may then fail to open them ("open_and_lock_file failed") and stay undiscovered.
    rmw_fastrtps replaces the built-in transports by its own (UDP on 127.0.0.1 + shared memory) when the
    discovery range is LOCALHOST, so with ``transports`` the range is SUBNET and the reserved domain id is
    what keeps runs apart."""
    if domain_id is None:
        _held_domains.append(reserve_domain())
        domain_id = _held_domains[-1].domain_id
    env = dict(os.environ)
    transports = transports or env.get("FASTDDS_BUILTIN_TRANSPORTS")
    if transports:
        env["FASTDDS_BUILTIN_TRANSPORTS"] = transports
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"
    else:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    env["PYTHONUNBUFFERED"] = "1"
    return env


#: Fast DDS shared-memory files: segments ``fastrtps_<id>``, ports ``fastrtps_port<N>``, their semaphores
#: ``sem.fastrtps_port<N>_mutex``, and the lock files ``<segment>_el`` (exclusive) / ``<segment>_sl``
#: (shared) that the processes using a segment hold (flock) while they live
SHM_PATTERNS = ("/dev/shm/fastrtps_*", "/dev/shm/fastdds_*", "/dev/shm/sem.fastrtps_*", "/dev/shm/sem.fastdds_*")
SHM_LOCK_SUFFIXES = ("_el", "_sl")


def held_flocks() -> set[tuple[int, int, int]]:
    """(device major, minor, inode) of every file some process holds a flock or POSIX lock on
    (/proc/locks), read without taking any lock."""
    held = set()
    try:
        lines = Path("/proc/locks").read_text().splitlines()
    except OSError:
        return held
    for line in lines:
        fields = line.split()
        if "->" in fields:                       # a waiter, not a holder
            continue
        for field in fields:
            parts = field.split(":")
            if len(parts) == 3:
                try:
                    held.add((int(parts[0], 16), int(parts[1], 16), int(parts[2])))
                except ValueError:
                    continue
                break
    return held


def shm_segment_of(name: str) -> str:
    """The segment a /dev/shm file belongs to: ``fastrtps_port7411`` for itself, its ``_el``/``_sl`` lock
    files and ``sem.fastrtps_port7411_mutex``."""
    if name.startswith("sem."):
        name = name[len("sem."):].removesuffix("_mutex")
    for suffix in SHM_LOCK_SUFFIXES:
        name = name.removesuffix(suffix)
    return name


def clean_fastdds_shm(min_age_s: float = 10.0) -> int:
    """Remove the Fast DDS shared-memory segments (and their semaphores) that no process uses any more
    (left by a SIGKILL); the number removed. A segment is in use while a process holds one of its lock
    files (/proc/locks; checked without locking, so a process opening it meanwhile is never refused). Kept:
    a segment with a held lock file, a segment without any lock file (its owner cannot be told), a segment
    touched in the last ``min_age_s`` (a process may be creating it) and the lock files themselves (0 bytes,
    reused by Fast DDS; deleting one between a process's open and flock would give two owners)."""
    files = [path for pattern in SHM_PATTERNS for path in glob.glob(pattern)]
    held = held_flocks()
    if not held and not Path("/proc/locks").exists():
        return 0                                 # no way to tell the segments in use
    in_use, has_lock_file, recent = set(), set(), set()
    now = time.time()
    for path in files:
        name = os.path.basename(path)
        segment = shm_segment_of(name)
        try:
            info = os.stat(path)
        except OSError:
            continue
        if name.endswith(SHM_LOCK_SUFFIXES):
            has_lock_file.add(segment)
            if (os.major(info.st_dev), os.minor(info.st_dev), info.st_ino) in held:
                in_use.add(segment)
        if now - info.st_mtime < min_age_s:
            recent.add(segment)
    removed = 0
    for path in files:
        name = os.path.basename(path)
        segment = shm_segment_of(name)
        if name.endswith(SHM_LOCK_SUFFIXES) or segment in in_use or segment in recent \
                or segment not in has_lock_file:
            continue
        try:
            os.unlink(path)
            removed += 1
        except OSError:
            pass
    return removed


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


#: bag_player's waits when a caller does not choose: for the node's subscriptions to match its writers
#: (``--wait-subscribers``, a DDS match count), and for a reader that takes no data; generous because they
#: end as soon as the condition holds (a loaded machine starts a node in tens of seconds)
PLAYER_WAIT_TIMEOUT_S = 120.0


def play_bag(bag: str | Path, env: dict[str, str], extra: list[str] | None = None,
             timeout: float = 600.0) -> subprocess.CompletedProcess:
    """Run bag_player on ``bag`` (``extra``: its options) to its end; ``--wait-timeout`` and
    ``--ack-timeout`` default to PLAYER_WAIT_TIMEOUT_S."""
    extra = list(extra or [])
    for option in ("--wait-timeout", "--ack-timeout"):
        if option not in extra:
            extra += [option, f"{PLAYER_WAIT_TIMEOUT_S:g}"]
    cmd = [sys.executable, "-m", "guide_health.nodes.bag_player", str(bag)] + extra
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

    def wait_counts(self, name: str, counts: dict[str, float], timeout: float = 300.0) -> dict | None:
        """Latest status once every key of ``counts`` has reached its value (the node has taken every message
        it was sent: a condition, not a quiet time, which a CPU-starved node also shows); after ``timeout``
        the latest status, for the caller's assertion to show what was missing."""
        def reached(status: dict) -> bool:
            return all(float(status["values"].get(key, "nan")) >= value for key, value in counts.items())
        return self.wait_for(name, reached, timeout=timeout) or self.get(name)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self._rclpy.shutdown(context=self.context)
        self._thread.join(timeout=5)


#: the counts of a wear_monitor status that reach their offline values once the node has taken a whole bag
BAG_COUNT_KEYS = ("samples", "load_samples", "measurements")


def bag_counts(offline: dict) -> dict[str, float]:
    """The counts (BAG_COUNT_KEYS) of an offline replay result: what a live status reaches after the bag."""
    return {key: float(offline[key]) for key in BAG_COUNT_KEYS if key in offline}


def settled_status_after_bag(executable_module: str, params_file: str | Path | list, overrides: dict | None,
                             env: dict[str, str], bag: str | Path, status_name: str, log_path: str | Path,
                             settle_key: str = "sliding_distance_m", collector_name: str = "bag_collector",
                             timeout: float = 300.0, counts: dict[str, float] | None = None) -> dict:
    """Start a node, wait for its status ``status_name``, play ``bag`` into it at full rate (once its
    subscriptions have matched the player's writers), and return the status once it reports ``counts``
    (:meth:`DiagnosticsCollector.wait_counts`, e.g. :func:`bag_counts` of the offline replay), or without
    ``counts`` once ``settle_key`` has stopped changing for 2 s; the node is stopped and the collector
    closed whatever happens. RuntimeError (with the node's log or bag_player's stderr) when the node does
    not come up or the player fails."""
    collector = DiagnosticsCollector(collector_name)
    node = start_node(executable_module, params_file, overrides, env, log_path=log_path)
    try:
        if collector.wait_for(status_name, timeout=PLAYER_WAIT_TIMEOUT_S) is None:
            raise RuntimeError(f"{status_name!r} never published:\n{Path(log_path).read_text()}")
        played = play_bag(bag, env, ["--wait-subscribers", "1", "--max-rate", "0"])
        if played.returncode != 0:
            raise RuntimeError(f"bag_player failed:\n{played.stderr}")
        if counts:
            return collector.wait_counts(status_name, counts, timeout=timeout)
        return collector.wait_settled(status_name, settle_key, settle_s=2.0, timeout=timeout)
    finally:
        stop_node(node)
        collector.close()
        clean_fastdds_shm()
