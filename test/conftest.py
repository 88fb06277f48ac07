"""Shared fixtures."""
import numpy as np
import pytest


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
