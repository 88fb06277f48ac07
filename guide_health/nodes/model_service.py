"""wear_monitor's ``~/load_model`` (std_srvs/Trigger): load the parameters file named by the parameter
``model_file`` over the running model, without a restart.

Why a Trigger on a parameter rather than the parameter's change event alone: the caller gets the outcome as
the response (success, and the one-line reason of a refusal), and the same file can be loaded again after it
was rewritten (setting a parameter to its present value is no change event). The file merges over the node's
running parameters as a later ``--params-file`` would (its ``wear_monitor`` section, the node's own name),
validated by the one schema; each axis's guides are then handed over by models/wear/model_load.py (the function
``replay --model-file --model-at`` uses). A file that does not load, does not validate, changes what
the saved state is keyed by (state_schema.FINGERPRINT_PARAMS: a restart's matter) or cannot be anchored is
refused whole with one line; the model is then unchanged. A loaded file is not written back to the
parameters files: a restart with the old files restores the state under the old model.
"""
from __future__ import annotations

from guide_health.errors import InputError
from guide_health.models.wear.model_load import ModelLoadError, loaded_guides
from guide_health.models.wear.state_schema import FINGERPRINT_PARAMS
from guide_health.params import load_node_params, validate_wear_params
from guide_health.params.machine import axes_params
from guide_health.params.typed import wear_axis_params


def loaded_models(node, path: str) -> list:
    """[(channel, axis params dict, typed params, guides)] of the file over the node's running parameters;
    ValueError / InputError (one line) when it cannot be loaded."""
    if not path:
        raise InputError("the parameter model_file is empty: set it to the model file to load")
    merged = load_node_params(path, node.get_name(), dict(node.params))
    axes = axes_params(merged, validate_wear_params)
    out = []
    for channel in node.channels:
        axis = axes[channel.name]
        typed = wear_axis_params(axis)
        changed = [n for n in FINGERPRINT_PARAMS if n != "machine_id" and getattr(typed, n) !=
                   getattr(channel.model.params, n)]
        if changed:
            raise InputError(f"{path} changes {', '.join(changed)} of axis {channel.name}: that needs a restart")
        out.append((channel, axis, typed, loaded_guides(channel.model, typed)))
    return out


def on_load_model(node, response):
    """The service: every axis loads the file or none does (module text)."""
    node.process_inputs()
    path = str(node.get_parameter("model_file").value)
    try:
        models = loaded_models(node, path)
    except (InputError, ModelLoadError, ValueError) as exc:
        response.success = False
        response.message = f"load_model refused: {str(exc).splitlines()[0]}"
        node.get_logger().warning(response.message)
        return response
    for channel, axis, typed, guides in models:
        channel.params = axis
        channel.model.params = typed
        channel.model.guides = guides
    node.checkpoint()
    response.success = True
    response.message = f"loaded {path}"
    node.get_logger().info(response.message)
    return response
