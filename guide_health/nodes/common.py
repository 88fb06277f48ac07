"""What every guide_health node's main() does: init, build the node, spin, shut down cleanly."""
from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from guide_health.errors import InputError
from guide_health.params import SCHEMAS
from guide_health.params.ros_args import check_ros_args


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename and exc.strerror:
        return f"{exc.strerror}: {exc.filename}"
    return " ".join(str(exc).split()) or type(exc).__name__


def _check_params(name: str, argv: list[str]) -> None:
    """The node's --params-file/-p arguments through the strict loader of the CLI (InputError, one line)."""
    if name in SCHEMAS:
        check_ros_args(SCHEMAS[name], list(argv))


def _init(argv: list[str] | None) -> None:
    """rclpy.init; rcl's RCLError (a params file rcl cannot parse, a bad --ros-args) as InputError."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    # rcl logs its own "[ERROR] [rcl]: Failed to parse global arguments" on fd 2: held back, shown on success
    with tempfile.TemporaryFile() as held:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(held.fileno(), 2)
        try:
            rclpy.init(args=argv)
        except _rclpy.RCLError as exc:
            raise InputError(f"rcl refused the arguments: {exc}".split(", at ")[0]) from None
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        held.seek(0)
        sys.stderr.write(held.read().decode(errors="replace"))


def run_node(name: str, factory: Callable[[], object], argv: list[str] | None = None,
             events_executor: bool | Callable[[object], bool] = False) -> int:
    """rclpy.init, node = factory(), spin until SIGINT/SIGTERM, then node.close() (if it has one: final
    checkpoint) and shutdown. Bad parameters exit 2 with one line, never a traceback: the --params-file/-p
    arguments are first checked by the strict loader of the CLI (unknown keys, missing node section, ranges,
    cross-checks; guide_health.params.ros_args), an RCLError of rclpy.init and an InputError/ValueError/
    OSError of the factory (parameters, state file) end the same way.

    events_executor (or a predicate on the node): spin rclpy's EventsExecutor instead of the
    SingleThreadedExecutor. Either way the loop is spin_once: EventsExecutor.spin() in rclpy 7.1.6 does
    not return on SIGINT.
    """
    node = None
    try:
        _check_params(name, sys.argv if argv is None else argv)
        _init(argv)
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
    except (InputError, ValueError, OSError) as exc:
        print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
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
