"""The isolation every live test uses (guide_health/nodes/session.py): a domain reserved per run, skipped
while another run holds it or any program has a UDP port of it bound; and the shared-memory cleanup, which
removes only the Fast DDS segments no process holds a lock of."""
import fcntl
import os
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from guide_health.nodes import session
from guide_health.nodes.session import (
    PORT_BASE,
    PORT_DOMAIN_GAIN,
    clean_fastdds_shm,
    domain_in_use,
    isolated_ros_env,
    reserve_domain,
    shm_segment_of,
)

SHM = Path("/dev/shm")
linux_only = pytest.mark.skipif(not (SHM.is_dir() and Path("/proc/locks").exists()),
                                reason="needs /dev/shm and /proc/locks (Linux)")


def test_rtps_port_range_of_a_domain():
    """RTPS well-known ports: PB + DG * d (PB 7400, DG 250); domain 0's discovery multicast is 7400, its
    first participant's unicast 7410/7411; domain 1 starts at 7650."""
    assert domain_in_use(0, {7400}) and domain_in_use(0, {7411}) and domain_in_use(0, {7649})
    assert not domain_in_use(0, {7650}) and domain_in_use(1, {7650}) and not domain_in_use(1, {7399, 7900})
    assert (PORT_BASE, PORT_DOMAIN_GAIN) == (7400, 250)


def test_a_held_domain_is_never_handed_out_twice():
    first = reserve_domain()
    others = [reserve_domain() for _ in range(5)]
    try:
        ids = [first.domain_id] + [r.domain_id for r in others]
        assert len(set(ids)) == 6 and all(1 <= d <= 232 for d in ids)
        # another process (another test run) sees every one of them locked
        probe = ("import fcntl, sys, tempfile, pathlib\n"
                 "d = pathlib.Path(tempfile.gettempdir()) / 'guide_health_ros_domains'\n"
                 "held = []\n"
                 "for i in map(int, sys.argv[1:]):\n"
                 "    f = open(d / f'{i}.lock', 'a')\n"
                 "    try:\n"
                 "        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)\n"
                 "    except OSError:\n"
                 "        held.append(i)\n"
                 "print(len(held))\n")
        out = subprocess.run([sys.executable, "-c", probe, *map(str, ids)], capture_output=True, text=True)
        assert out.stdout.strip() == "6", out.stderr
    finally:
        for reservation in [first, *others]:
            reservation.release()


def test_a_domain_with_a_bound_port_is_skipped(monkeypatch):
    """A program that takes no lock (a ROS user, another project) is in domain d: its port is bound."""
    for d in range(60, 100):
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind(("0.0.0.0", PORT_BASE + PORT_DOMAIN_GAIN * d + 11))
        except OSError:
            sock.close()
            continue
        try:
            monkeypatch.setattr(session, "DOMAIN_IDS", range(d, d + 1))
            assert domain_in_use(d)
            with pytest.raises(RuntimeError, match="no free ROS domain id"):
                reserve_domain()
        finally:
            sock.close()
        monkeypatch.setattr(session, "DOMAIN_IDS", range(d, d + 1))
        reservation = reserve_domain()                 # free again once the port is closed
        assert reservation.domain_id == d
        reservation.release()
        return
    pytest.skip("no domain in 60..99 with a free port to bind")


def test_isolated_env_udp_only_is_subnet_and_inherits_the_transport(monkeypatch):
    monkeypatch.delenv("FASTDDS_BUILTIN_TRANSPORTS", raising=False)
    env = isolated_ros_env(domain_id=42)
    assert (env["ROS_DOMAIN_ID"], env["ROS_AUTOMATIC_DISCOVERY_RANGE"]) == ("42", "LOCALHOST")
    assert "FASTDDS_BUILTIN_TRANSPORTS" not in env
    env = isolated_ros_env(domain_id=42, transports="UDPv4")
    assert (env["FASTDDS_BUILTIN_TRANSPORTS"], env["ROS_AUTOMATIC_DISCOVERY_RANGE"]) == ("UDPv4", "SUBNET")
    monkeypatch.setenv("FASTDDS_BUILTIN_TRANSPORTS", "UDPv4")        # as the live tests export it
    assert isolated_ros_env(domain_id=42)["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"


def test_shm_file_names_map_to_their_segment():
    assert shm_segment_of("fastrtps_port7411") == "fastrtps_port7411"
    assert shm_segment_of("fastrtps_port7411_el") == "fastrtps_port7411"
    assert shm_segment_of("sem.fastrtps_port7411_mutex") == "fastrtps_port7411"
    assert shm_segment_of("fastrtps_16c977b90a4014bd_el") == "fastrtps_16c977b90a4014bd"
    assert shm_segment_of("fastrtps_16c977b90a4014bd_sl") == "fastrtps_16c977b90a4014bd"


def _segment(name: str, age_s: float) -> list[Path]:
    """A fake Fast DDS segment: its memory file, its semaphore and its exclusive-lock file, aged."""
    files = [SHM / name, SHM / f"sem.{name}_mutex", SHM / f"{name}_el"]
    for path in files:
        path.write_bytes(b"x" if not path.name.endswith("_el") else b"")
        os.utime(path, (time.time() - age_s, time.time() - age_s))
    return files


@linux_only
def test_cleanup_keeps_segments_in_use_and_removes_only_abandoned_ones():
    tag = uuid.uuid4().hex[:12]
    used = _segment(f"fastrtps_port{tag}a", age_s=60.0)     # its owner lives: holds the _el lock
    abandoned = _segment(f"fastrtps_port{tag}b", age_s=60.0)  # its owner was SIGKILLed: nobody holds it
    fresh = _segment(f"fastrtps_port{tag}c", age_s=0.0)      # a process is creating it right now
    orphan = SHM / f"fastrtps_{tag}d"                        # no lock file: its owner cannot be told
    orphan.write_bytes(b"x")
    os.utime(orphan, (time.time() - 60, time.time() - 60))
    owner = subprocess.Popen([sys.executable, "-c",
                              "import fcntl, sys, time\n"
                              f"f = open({str(used[2])!r}, 'r')\n"
                              "fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)\n"
                              "print('locked', flush=True)\n"
                              "time.sleep(60)\n"], stdout=subprocess.PIPE, text=True)
    try:
        assert owner.stdout.readline().strip() == "locked"
        clean_fastdds_shm()
        assert all(p.exists() for p in used), "a segment in use was removed"
        assert all(p.exists() for p in fresh), "a segment being created was removed"
        assert orphan.exists()
        assert not abandoned[0].exists() and not abandoned[1].exists(), "the abandoned segment was kept"
        assert abandoned[2].exists()                         # lock files are never removed
        # the check took no lock: the owner's lock is intact and a newcomer is still refused
        with open(used[2]) as handle, pytest.raises(OSError):
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    finally:
        owner.kill()
        owner.wait()
        for path in used + abandoned + fresh + [orphan]:
            path.unlink(missing_ok=True)
    # once the owner is gone (a SIGKILL leaves its files), the next cleanup removes its segment
    used = _segment(f"fastrtps_port{tag}a", age_s=60.0)
    try:
        clean_fastdds_shm()
        assert not used[0].exists() and not used[1].exists()
    finally:
        for path in used:
            path.unlink(missing_ok=True)
