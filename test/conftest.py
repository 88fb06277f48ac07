"""Shared fixtures."""
import numpy as np
import pytest


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
