"""ROS 2 side of the schema: parameter descriptors and declaring a node's parameters.

rcl_interfaces is imported inside the functions, so ``import guide_health.params`` needs no ROS.
"""
from __future__ import annotations

import math
from typing import Any

from guide_health.errors import InputError
from guide_health.params.machine import AXIS_SCHEMA, axes_params, axis_names, coerce_axis_value
from guide_health.params.schema import NodeSchema, Param, coerce_value
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA, validate_wear_params

INT64_MIN, INT64_MAX = -(2 ** 63), 2 ** 63 - 1


def descriptor_for(param: Param):
    """rcl_interfaces ParameterDescriptor of ``param``: description with the unit, the range (ROS ranges are
    inclusive: an open end is declared at its closure, the exact interval is in ``additional_constraints``),
    ``read_only`` unless dynamic, and ``dynamic_typing`` so that an integer value may set a float parameter."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

    unit = f" [{param.unit}]" if param.unit else ""
    descriptor = ParameterDescriptor(description=f"{param.description}{unit}", read_only=not param.dynamic,
                                     dynamic_typing=True)
    if param.choices:
        descriptor.additional_constraints = "one of: " + ", ".join(param.choices)
    elif param.bounds is not None:
        descriptor.additional_constraints = f"in {param.interval}{param.unit_suffix}"
        low, high, _, _ = param.bounds
        if isinstance(param.default, int) and not isinstance(param.default, bool):
            descriptor.integer_range = [IntegerRange(
                from_value=int(low) if math.isfinite(low) else INT64_MIN,
                to_value=int(high) if math.isfinite(high) else INT64_MAX, step=0)]
        elif isinstance(param.default, float):
            descriptor.floating_point_range = [FloatingPointRange(from_value=low, to_value=high, step=0.0)]
    return descriptor


def _node_value(value: Any, default: Any) -> Any:
    """A list parameter comes back from rclpy as an array/tuple: make it a list again."""
    if isinstance(default, list) and (isinstance(value, (tuple, list)) or hasattr(value, "tolist")):
        return list(value)
    return value


def declare_parameters(node, schema: NodeSchema, on_applied=None) -> dict[str, Any]:
    """Declare ``schema`` on an rclpy node and return the values coerced and validated like the offline
    loader does (same numbers live and offline; InputError with the offline message on a bad value).

    Declared first with ``dynamic_typing`` only (so ``6000`` may set a float parameter and a bad value gets
    the schema's message, not rclpy's), then given the full descriptor (range, read_only) once validated.

    Run-time changes (``ros2 param set``, the ``set_parameters`` service): rclpy refuses a read-only
    parameter itself; the on-set callback refuses a value the loader would refuse (type, range,
    cross-checks) with the loader's one-line reason; an accepted one updates the returned dict, and
    ``on_applied({name: coerced value})`` (a post-set callback) applies it to the running model.
    """
    from rcl_interfaces.msg import ParameterDescriptor

    values = {}
    for param in schema.params:
        node.declare_parameter(param.name, param.default, ParameterDescriptor(dynamic_typing=True))
        value = _node_value(node.get_parameter(param.name).value, param.default)
        values[param.name] = coerce_value(param.name, value, param.default)
    schema.validate(values)
    for param in schema.params:
        node.set_descriptor(param.name, descriptor_for(param))
    node.add_on_set_parameters_callback(lambda changed: _check_set(schema, values, changed))
    if on_applied is not None:
        node.add_post_set_parameters_callback(
            lambda changed: on_applied({p.name: values[p.name] for p in changed if p.name in schema.by_name}))
    return values


def _check_set(schema: NodeSchema, values: dict[str, Any], changed) -> Any:
    """``ros2 param set`` of a dynamic parameter: the same ranges and cross-checks as at start (an inverted
    threshold pair is refused with the schema's message); ``values`` follows the accepted changes."""
    from rcl_interfaces.msg import SetParametersResult


    new = dict(values)
    try:
        for parameter in changed:
            if parameter.name in schema.by_name:
                default = schema.by_name[parameter.name].default
                new[parameter.name] = coerce_value(parameter.name, _node_value(parameter.value, default), default)
        schema.validate(new)
    except InputError as exc:
        return SetParametersResult(successful=False, reason=str(exc))
    values.update(new)
    return SetParametersResult(successful=True)


def declare_axis_parameters(node, params: dict) -> dict[str, dict]:
    """Declare ``<axis>.<name>`` of every axis on an rclpy node (read-only: an axis's geometry and topics
    are fixed while it runs; default: the section's top-level value) and return :func:`axes_params` of
    the values, validated like the offline loader does."""
    from rcl_interfaces.msg import ParameterDescriptor

    values = dict(params)
    for axis in params["axes"]:
        for name in axis_names(WEAR_MONITOR_SCHEMA):
            param = AXIS_SCHEMA[name] if name in AXIS_SCHEMA.by_name else WEAR_MONITOR_SCHEMA[name]
            default = param.default if name in AXIS_SCHEMA.by_name else params[name]
            full = f"{axis}.{name}"
            node.declare_parameter(full, default, ParameterDescriptor(dynamic_typing=True))
            value = node.get_parameter(full).value
            if isinstance(default, list):
                value = list(value)
            values[full] = coerce_axis_value(full, value, default)
            descriptor = descriptor_for(param)
            descriptor.read_only = True
            node.set_descriptor(full, descriptor)
    return axes_params(values, validate_wear_params)
