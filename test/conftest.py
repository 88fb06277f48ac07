"""Shared fixtures."""
import numpy as np
import pytest


@pytest.fixture
def ros_test_env(monkeypatch):
    """make(domain_id=None, transports=None): guide_health.nodes.session.isolated_ros_env for the node and
    player processes a test starts, with its discovery range, domain and transports exported to this process
    too (monkeypatch), so that the test's own collectors and publishers join them."""
    from guide_health.nodes.session import isolated_ros_env

    def make(domain_id: int | None = None, transports: str | None = None) -> dict:
        env = isolated_ros_env(domain_id=domain_id, transports=transports)
        for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "FASTDDS_BUILTIN_TRANSPORTS"):
            if key in env:
                monkeypatch.setenv(key, env[key])
        return env
    return make


@pytest.fixture(autouse=True)
def private_ros_home(tmp_path_factory, monkeypatch):
    """state_file 'auto' (the default) lives under $ROS_HOME: each test gets its own, never ~/.ros."""
    monkeypatch.setenv("ROS_HOME", str(tmp_path_factory.mktemp("ros_home")))


@pytest.fixture
def ros_context(monkeypatch):
    """A private rclpy context on a random localhost-only domain, for nodes spun in the test process."""
    rclpy = pytest.importorskip("rclpy")
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(np.random.randint(1, 100)))
    context = rclpy.context.Context()
    rclpy.init(context=context)
    yield context
    rclpy.shutdown(context=context)
