"""What every guide_health node's main() does: init, build the node, spin, shut down cleanly."""
from __future__ import annotations

import sys
from collections.abc import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from guide_health.errors import InputError


def run_node(name: str, factory: Callable[[], object], argv: list[str] | None = None,
             events_executor: bool | Callable[[object], bool] = False) -> int:
    """rclpy.init, node = factory(), spin until SIGINT/SIGTERM, then node.close() (if it has one: final
    checkpoint) and shutdown. Bad parameters (InputError/ValueError from the factory) exit 2 with one line.

    events_executor (or a predicate on the node): spin rclpy's EventsExecutor instead of the
    SingleThreadedExecutor. Either way the loop is spin_once: EventsExecutor.spin() in rclpy 7.1.6 does
    not return on SIGINT.
    """
    rclpy.init(args=argv)
    node = None
    try:
        node = factory()
        use_events = events_executor(node) if callable(events_executor) else events_executor
        if use_events:
            from rclpy.experimental import EventsExecutor

            executor = EventsExecutor()
        else:
            executor = SingleThreadedExecutor()
        executor.add_node(node)
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (InputError, ValueError) as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            close = getattr(node, "close", None)
            if close is not None:
                close()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
