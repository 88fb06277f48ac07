"""Shared fixtures."""
import pytest

#: the transports of every live test: UDP only, so that no test depends on /dev/shm (a SIGKILLed process's
#: locked ports, or another run's cleanup, cannot strand it); see guide_health.nodes.session.isolated_ros_env
LIVE_TEST_TRANSPORTS = "UDPv4"
ROS_ENV_KEYS = ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "FASTDDS_BUILTIN_TRANSPORTS")


@pytest.fixture
def ros_domain():
    """A DDS domain id of this test's own, held until it ends (session.reserve_domain: locked against other
    runs of this package, and no participant of any other program bound to it)."""
    from guide_health.nodes.session import reserve_domain

    reservation = reserve_domain()
    yield reservation.domain_id
    reservation.release()


@pytest.fixture
def ros_test_env(monkeypatch, ros_domain):
    """make(): the environment of the node and player processes a test starts (the test's own domain, UDP
    only), exported to this process too (monkeypatch), so that the test's own collectors and publishers
    join them. Every live test uses this isolation, and ros_context the same."""
    from guide_health.nodes.session import isolated_ros_env

    def make() -> dict:
        env = isolated_ros_env(domain_id=ros_domain, transports=LIVE_TEST_TRANSPORTS)
        for key in ROS_ENV_KEYS:
            monkeypatch.setenv(key, env[key])
        return env
    return make


@pytest.fixture(autouse=True)
def private_ros_home(tmp_path_factory, monkeypatch):
    """state_file 'auto' (the default) lives under $ROS_HOME: each test gets its own, never ~/.ros."""
    monkeypatch.setenv("ROS_HOME", str(tmp_path_factory.mktemp("ros_home")))


@pytest.fixture
def ros_context(ros_test_env):
    """A private rclpy context in the isolation of ros_test_env, for nodes spun in the test process."""
    rclpy = pytest.importorskip("rclpy")
    ros_test_env()
    context = rclpy.context.Context()
    rclpy.init(context=context)
    yield context
    rclpy.shutdown(context=context)


@pytest.fixture
def live_wear_node(ros_test_env, tmp_path):
    """live_node.LiveWearNode in this test's isolation (ros_test_env), stopped at the test's end."""
    pytest.importorskip("rclpy")
    from live_node import LiveWearNode

    live = LiveWearNode(ros_test_env(), tmp_path)
    yield live
    live.close()
