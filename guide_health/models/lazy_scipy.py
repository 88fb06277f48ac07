"""The scipy functions that the nodes' and the CLI's start-up path reaches, imported on first call.

Importing scipy.optimize and scipy.special costs ~0.9 s of CPU (`python -c "import
guide_health.nodes.wear_monitor"`: 1.55 s with them at module top, 0.63 s without), and every node and CLI
process would pay it at start although most runs need none of these functions: a sliding guide without a
decaying K, a model file's forms, three K measurements or a ball contact. Each wrapper imports its function on
its first call (then a dictionary lookup); the functions are scipy's own.
"""
from __future__ import annotations


def brentq(*args, **kwargs):
    """scipy.optimize.brentq: a root bracketed by a sign change (Brent's method)."""
    from scipy.optimize import brentq as _brentq

    return _brentq(*args, **kwargs)


def stdtrit(*args, **kwargs):
    """scipy.special.stdtrit: the Student-t quantile."""
    from scipy.special import stdtrit as _stdtrit

    return _stdtrit(*args, **kwargs)


def ndtr(*args, **kwargs):
    """scipy.special.ndtr: the standard normal CDF."""
    from scipy.special import ndtr as _ndtr

    return _ndtr(*args, **kwargs)


def ellipk(*args, **kwargs):
    """scipy.special.ellipk: the complete elliptic integral of the first kind, K(m)."""
    from scipy.special import ellipk as _ellipk

    return _ellipk(*args, **kwargs)


def ellipe(*args, **kwargs):
    """scipy.special.ellipe: the complete elliptic integral of the second kind, E(m)."""
    from scipy.special import ellipe as _ellipe

    return _ellipe(*args, **kwargs)
