"""wear_monitor's ``~/load_model`` (std_srvs/Trigger): load the parameters file named by the parameter
``model_file`` over the running model, without a restart.

Why a Trigger on a parameter rather than the parameter's change event alone: the caller gets the outcome as
the response (success, and the one-line reason of a refusal), and the same file can be loaded again after it
was rewritten (setting a parameter to its present value is no change event). The file merges over the node's
running parameters as a later ``--params-file`` would (its ``wear_monitor`` section, the node's own name),
validated by the one schema; each axis's guides are then handed over by models/wear/model_load.py (the function
``replay --model-file --model-at`` uses). A file that does not load, does not validate, changes what
the saved state is keyed by (state_schema.FINGERPRINT_PARAMS: a restart's matter) or cannot be anchored is
refused whole with one line; the model is then unchanged.

What survives a restart: the loaded model is a record in the state file beside the axis's guides (its merged
parameters, their digest, the file, the time of the load and the digest of the configured model it was loaded
over), written by the same checkpoint. A restart restores the guides (anchored at model_from_stamp_s when the
file had one) under that model, not under the parameters files' one. Precedence: the record wins while the
configured model (the parameters files) is still the one it was loaded over; a configured model with another
digest (an engineer wrote a newer model into the parameters after the load) is the newer decision and wins,
the record is dropped. A record that does not read back (not a mapping, a digest that does not match its
parameters, parameters the schema refuses) is refused in one line and counted; the node runs on the
configured model. Nothing written back to the parameters files.
"""
from __future__ import annotations

import hashlib
import json
import time

from guide_health.errors import InputError
from guide_health.models.wear.fit_watch import utc_text
from guide_health.models.wear.guide import GuideWear
from guide_health.models.wear.model_load import ModelLoadError, loaded_guides
from guide_health.models.wear.state_schema import FINGERPRINT_PARAMS
from guide_health.params import load_node_params, validate_wear_params
from guide_health.params.machine import axes_params
from guide_health.params.typed import as_dict, wear_axis_params

#: the fields of a loaded-model record (module text)
RECORD_FIELDS = ("file", "loaded_unix_s", "params", "digest", "loaded_over_digest")


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
    now = time.time()
    for channel, axis, typed, guides in models:
        channel.params = axis
        channel.model.params = typed
        channel.model.guides = guides
        channel.loaded_model = {"file": path, "loaded_unix_s": now, "params": axis, "digest": model_digest(typed),
                                "loaded_over_digest": model_digest(channel.model_params)}
    node.checkpoint()
    response.success = True
    response.message = f"loaded {path}"
    node.get_logger().info(response.message)
    return response


def model_digest(typed) -> str:
    """A digest of an axis's model: every wear parameter of its frozen parameters (canonical JSON)."""
    return hashlib.sha1(json.dumps(as_dict(typed), sort_keys=True).encode()).hexdigest()[:16]


def resumed_model(record: dict, configured: dict) -> tuple[dict | None, str]:
    """The model a restart runs on, given the saved loaded-model ``record`` and the ``configured`` axis
    parameters (the parameters files): (the record's axis parameters, "resumed with the model loaded at ...")
    when the record wins, (None, why the parameters win) else (module text: the precedence). InputError (one
    line) when the record does not read back."""
    if set(record) != set(RECORD_FIELDS) or not isinstance(record["params"], dict):
        raise InputError(f"the loaded-model record has the fields {sorted(record)}, not {list(RECORD_FIELDS)}")
    try:
        validate_wear_params(record["params"])
        typed = wear_axis_params(record["params"])
        when = utc_text(int(float(record["loaded_unix_s"]) * 1e9))
    except (InputError, ValueError, TypeError, KeyError, OverflowError) as exc:
        raise InputError(f"the loaded model's parameters are refused ({str(exc).splitlines()[0]})") from None
    if model_digest(typed) != record["digest"]:
        raise InputError("the loaded model's digest does not match its parameters (the record was altered)")
    base = wear_axis_params(configured)
    changed = [n for n in FINGERPRINT_PARAMS if n != "machine_id" and getattr(typed, n) != getattr(base, n)]
    if changed:
        raise InputError(f"the loaded model changes {', '.join(changed)}, which the saved state is keyed by")
    where = f"the model loaded at {when} from {record['file']}"
    if record["loaded_over_digest"] != model_digest(base):
        return None, (f"the parameters name another model than the one {where} was loaded over: the parameters "
                      "win (the newer decision), the loaded model is dropped")
    return record["params"], f"resumed with {where}"


def resume_loaded_model(channel, record: dict) -> str:
    """Put the model of a saved loaded-model ``record`` on ``channel`` before its guides are restored (empty
    record: none was loaded); the start-up line (resumed_model), '' when there was no record."""
    if not record:
        return ""
    axis, line = resumed_model(record, channel.params)
    channel.loaded_model = {}           # dropped: the next checkpoint overwrites the record
    if axis is not None:
        typed = wear_axis_params(axis)
        channel.params = axis
        channel.model.params = typed
        channel.model.guides = {name: GuideWear(typed) for name in channel.model.guides}
        channel.loaded_model = record
    return line
