"""`guide-health maintenance NAMESPACE AXIS KIND`: a maintenance event entered on a running wear_monitor.

The node's maintenance calls (docs/machine.md) are std_srvs/Trigger services ``maintenance/<axis>/<kind>``
whose values are the node's ``maintenance_*`` parameters. This command does with rclpy what ``ros2 param
set`` and ``ros2 service call`` do, so no ``ros2`` CLI is needed: it sets every ``maintenance_*`` value of
the call through the node's ``set_parameters`` service (rcl_interfaces; all of them, so a value left by an
earlier ``ros2 param set`` never rides along), calls the Trigger and prints the node's answer.

Exit status: 0 applied, 1 refused by the node (its reason, e.g. "already applied at ..."), 2 bad input or
no such node or service within ``--timeout`` (one line).
"""
from __future__ import annotations

import argparse
import os
import time

from guide_health.cli.command import Command
from guide_health.errors import InputError
from guide_health.models.wear.maintenance import KINDS, straightness_from_text

#: the wear_monitor parameters a call sets (params/machine.py MAINTENANCE_PARAMS)
CALL_PARAMS = ("maintenance_guide", "maintenance_straightness_m", "maintenance_time_s", "maintenance_note")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("namespace", help="the node's namespace, e.g. /m1 ('/' for none)")
    p.add_argument("axis", help="the axis (its maintenance/<axis>/<kind> service), e.g. y")
    p.add_argument("kind", choices=KINDS, help="what was done")
    p.add_argument("--value", default=None,
                   help="straightness measured after a regrind/rail replacement, or the manual reading, with its "
                        "unit: 4um, '4 um', 4e-6m, 0.004mm (none: the configured A0; measure needs one)")
    p.add_argument("--guide", default="", help="the guide (rail/way) it concerns ('' = every guide of the axis)")
    p.add_argument("--note", default="", help="free text recorded with the event (who, what)")
    p.add_argument("--node", default="wear_monitor", help="the node's name (default wear_monitor)")
    p.add_argument("--timeout", type=float, default=20.0, help="seconds to wait for the node and each reply")


def node_name(namespace: str, name: str) -> str:
    """'/m1/wear_monitor' from ('/m1' or 'm1', 'wear_monitor'); '/wear_monitor' for the root namespace."""
    ns = "/" + namespace.strip("/") if namespace.strip("/") else ""
    return f"{ns}/{name}"


def call_values(args: argparse.Namespace) -> dict:
    """The maintenance_* parameter values of the call (InputError, one line, for a bad --value)."""
    value_m = 0.0
    if args.value is not None:
        value_m = straightness_from_text(args.value)
        if value_m == 0.0:
            raise InputError("--value 0: a straightness of 0 reads as 'not measured'; omit --value for A0")
    if args.kind == "measure" and args.value is None:
        raise InputError("measure needs --value (the straightness read, e.g. --value 7.2um)")
    return {"maintenance_guide": args.guide, "maintenance_straightness_m": value_m, "maintenance_time_s": 0.0,
            "maintenance_note": args.note}


def run(args: argparse.Namespace) -> dict:
    if not (args.timeout > 0):
        raise InputError(f"--timeout must be > 0 s, got {args.timeout}")
    values = call_values(args)
    target = node_name(args.namespace, args.node)
    service = f"{target.rsplit('/', 1)[0]}/maintenance/{args.axis}/{args.kind}"
    try:
        import rclpy
    except ImportError:
        raise InputError("guide-health maintenance needs rclpy (source the ROS 2 setup first)") from None
    context = rclpy.Context()
    rclpy.init(args=[], context=context)
    try:
        success, message = _call(context, target, service, values, args.timeout)
    finally:
        rclpy.shutdown(context=context)
    return {"node": target, "service": service, "axis": args.axis, "kind": args.kind, "guide": args.guide,
            "straightness_entered_um": values["maintenance_straightness_m"] * 1e6 if args.value else None,
            "note": args.note, "success": success, "message": message, "exit_status": 0 if success else 1}


def _call(context, target: str, service: str, values: dict, timeout_s: float) -> tuple[bool, str]:
    """Set the values through ``<target>/set_parameters``, then call the Trigger ``service``."""
    from rcl_interfaces.srv import SetParameters
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from std_srvs.srv import Trigger

    node = context_node(context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        setter = node.create_client(SetParameters, f"{target}/set_parameters")
        if not setter.wait_for_service(timeout_sec=timeout_s):
            raise InputError(f"no node {target} found within {timeout_s:g} s (ROS_DOMAIN_ID "
                             f"{os.environ.get('ROS_DOMAIN_ID', '0')}); is it running under that namespace?")
        trigger = node.create_client(Trigger, service)
        if not trigger.wait_for_service(timeout_sec=timeout_s):
            raise InputError(f"{target} has no service {service}{_axes_hint(node, target)}")
        request = SetParameters.Request(parameters=[Parameter(k, value=v).to_parameter_msg()
                                                    for k, v in values.items()])
        reply = _result(executor, setter.call_async(request), timeout_s, f"{target}/set_parameters")
        for name, result in zip(values, reply.results):
            if not result.successful:
                raise InputError(f"{target} refused {name} = {values[name]!r}: {result.reason}")
        answer = _result(executor, trigger.call_async(Trigger.Request()), timeout_s, service)
        return bool(answer.success), str(answer.message)
    finally:
        executor.shutdown()
        node.destroy_node()


def context_node(context):
    """This command's own short-lived node (no parameter services of its own)."""
    import rclpy

    return rclpy.create_node(f"guide_health_maintenance_{os.getpid()}", context=context,
                             start_parameter_services=False)


def _result(executor, future, timeout_s: float, what: str):
    end = time.monotonic() + timeout_s
    while not future.done() and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    if not future.done() or future.result() is None:
        raise InputError(f"no reply from {what} within {timeout_s:g} s")
    return future.result()


def _axes_hint(node, target: str) -> str:
    """' (axes: x, y, z)': the maintenance services the node offers."""
    prefix = f"{target.rsplit('/', 1)[0]}/maintenance/"
    axes = sorted({name[len(prefix):].split("/")[0] for name, _ in node.get_service_names_and_types()
                   if name.startswith(prefix)})
    return f" (axes: {', '.join(axes)})" if axes else ""


def format_text(result: dict) -> str:
    return f"{'applied' if result['success'] else 'refused'}: {result['message']}"


MAINTENANCE = Command(add_arguments, run, format_text)
