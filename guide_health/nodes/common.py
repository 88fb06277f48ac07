"""What every guide_health node's main() does: --help, check the parameters, init, build the node, log the
start-up line, spin, shut down cleanly."""
from __future__ import annotations

import os
import sys
import tempfile
import time
from collections.abc import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from guide_health.errors import InputError
from guide_health.io.state_store import resolve_state_path
from guide_health.nodes.usage import help_requested, usage
from guide_health.params import SCHEMAS
from guide_health.params.ros_args import read_ros_args


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename and exc.strerror:
        return f"{exc.strerror}: {exc.filename}"
    return " ".join(str(exc).split()) or type(exc).__name__


def _check_params(name: str, argv: list[str]):
    """The node's --params-file/-p arguments through the strict loader of the CLI (InputError, one line):
    the RosArgs (full name, merged parameters, sections applied), None for a node without a schema."""
    return read_ros_args(SCHEMAS[name], list(argv)) if name in SCHEMAS else None


def _state_before(name: str, ros_args) -> tuple | None:
    """(state file, it existed) of a node with a ``state_file`` parameter, looked at before the node opens it."""
    if ros_args is None or "state_file" not in SCHEMAS[name].by_name:
        return None
    params = ros_args.params or SCHEMAS[name].defaults()
    try:
        path = resolve_state_path(params["state_file"], params["machine_id"], ros_args.fqn.rsplit("/", 1)[-1])
    except (InputError, ValueError, OSError):
        return None
    return (path, path is not None and path.exists())


def _parameter(node, name: str, default=None):
    return node.get_parameter(name).value if node.has_parameter(name) else default


def startup_line(node, ros_args, state: tuple | None) -> str:
    """One line at start: machine_id, full name, axes, parameters files and the sections applied, state file."""
    axes = getattr(node, "axes", None)
    if isinstance(axes, dict) and axes:
        where = "axes " + ", ".join(axes)
    elif _parameter(node, "joint_name"):
        where = f"axes {_parameter(node, 'joint_name')}"
    elif _parameter(node, "bearing"):
        where = f"axes none (bearing {_parameter(node, 'bearing')})"
    else:
        where = "axes none"
    files: dict[str, list[str]] = {}
    for path, section in (ros_args.applied if ros_args is not None else []):
        files.setdefault(path, []).append(section)
    params = "; ".join(f"{path} [{', '.join(sections)}]" for path, sections in files.items())
    if ros_args is not None and ros_args.overrides:
        params += ("; " if params else "") + "-p " + " ".join(ros_args.overrides)
    line = (f"start: machine_id {_parameter(node, 'machine_id', '-')}, node {node.get_fully_qualified_name()}, "
            f"{where}, params {params or 'none (defaults)'}")
    path = getattr(node, "state_path", None)
    if state is not None or path is not None:
        before, existed = state if state is not None else (None, False)
        resumed = existed and path is not None and str(path) == str(before)
        line += f", state {path} ({'resumed' if resumed else 'new'})" if path is not None else ", state none"
    elif _parameter(node, "history_file") is not None:
        history = _parameter(node, "history_file")
        line += f", history {history or 'none'}"
    return line


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


#: how often the spin loop asks rclpy.ok() [s]
OK_CHECK_PERIOD_S = 0.05


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
    if help_requested(sys.argv if argv is None else [name, *argv]):
        sys.stdout.write(usage(name))
        return 0
    node = None
    try:
        ros_args = _check_params(name, sys.argv if argv is None else argv)
        state = _state_before(name, ros_args)
        _init(argv)
        node = factory()
        node.get_logger().info(startup_line(node, ros_args, state))
        use_events = events_executor(node) if callable(events_executor) else events_executor
        if use_events:
            from rclpy.experimental import EventsExecutor

            executor = EventsExecutor()
        else:
            executor = SingleThreadedExecutor()
        executor.add_node(node)
        # rclpy.ok() takes the context's lock (1.0 us a call against 0.04 us for time.monotonic()), and the
        # events executor returns from spin_once after every message: asked at most every OK_CHECK_PERIOD_S
        # (it was ~4 % of a 5-axis wear_monitor's samples at 6 kHz, py-spy), a shutdown is still seen within
        # that period plus one spin (<= 0.1 s)
        check_at = 0.0
        while True:
            now = time.monotonic()
            if now >= check_at:
                if not rclpy.ok():
                    break
                check_at = now + OK_CHECK_PERIOD_S
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
