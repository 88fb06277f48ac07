"""The scipy functions that the nodes' and the CLI's start-up path reaches, imported on first call.

Importing scipy.optimize and scipy.special costs ~0.9 s of CPU (`python -c "import
guide_health.nodes.wear_monitor"`: 1.55 s with them at module top, 0.63 s without), and every node and CLI
process would pay it at start although most runs need none of these functions: a sliding guide without a
decaying K, a model file's forms, three K measurements or a ball contact. Each wrapper imports its function on
its first call (then a dictionary lookup); the functions are scipy's own.
"""
from __future__ import annotations

import importlib


def _imported_on_first_call(module: str, name: str, what: str):
    """A function that calls ``module.name`` (imported on its first call; later calls find it in sys.modules)."""
    def call(*args, **kwargs):
        return getattr(importlib.import_module(module), name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = f"{module}.{name}: {what}"
    return call


brentq = _imported_on_first_call("scipy.optimize", "brentq", "a root bracketed by a sign change (Brent's method)")
stdtrit = _imported_on_first_call("scipy.special", "stdtrit", "the Student-t quantile")
ndtr = _imported_on_first_call("scipy.special", "ndtr", "the standard normal CDF")
ellipk = _imported_on_first_call("scipy.special", "ellipk", "the complete elliptic integral of the first kind, K(m)")
ellipe = _imported_on_first_call("scipy.special", "ellipe", "the complete elliptic integral of the second kind, E(m)")
