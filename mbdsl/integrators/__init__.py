"""Integration methods of Negrut, Jay & Khude, the Newton engine and the time loop.

``METHODS`` maps the paper's method names to their classes; every entry
runs in one time loop (:mod:`.loop`, started by :func:`integrate`,
:mod:`.driver`), its steps taken by the compiled loop (:mod:`.engine`,
:mod:`.compiled`) or the Python Newton iteration (:mod:`.newton`).
"""

from .base import Block, Method, StepContext, StepState
from .driver import integrate
from .hht_add import HHTADD
from .hht_i3 import HHTI3
from .genalpha import GenAlpha, GenAlphaSI2
from .hht_si2 import HHTSI2
from .newmark import Newmark
from .nstiff import NStiff
from .nstiff_si2 import NStiffSI2
from .newton import JacobianUpdate, Newton, NewtonOptions, NewtonResult, NewtonStatus
from . import kernel_cache, warm_up
from ..registry import COEFFICIENTS, METHOD_NAMES

# the kernel cache loads the kernels by a run through the driver, which it does not import
kernel_cache.register_warm_up(warm_up.run)

_CLASSES = (Newmark, HHTI3, NStiff, NStiffSI2, HHTADD, HHTSI2, GenAlpha, GenAlphaSI2)

#: The method names (``mbdsl.registry``, in its order) -> method classes.
METHODS = {name: next(c for c in _CLASSES if c.name == name) for name in METHOD_NAMES}

__all__ = ["METHODS", "Method", "Block", "StepState", "StepContext", "integrate",
           "HHTI3", "Newmark", "NStiff", "NStiffSI2", "HHTADD", "HHTSI2", "GenAlpha", "GenAlphaSI2", "Newton", "NewtonOptions", "NewtonResult", "NewtonStatus",
           "JacobianUpdate", "make_method", "method_parameters", "settings_coefficients"]


def method_parameters(name: str) -> set[str]:
    """Names of the coefficients the method ``name`` accepts.

    Raises
    ------
    ValueError
        Unknown method.
    """
    if name not in METHODS:
        raise ValueError(f"unknown method '{name}'; available: {', '.join(METHODS)}")
    import inspect
    params = inspect.signature(METHODS[name].__init__).parameters.values()
    return {p.name for p in params if p.name != "self"
            and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}


def make_method(name: str, **parameters) -> Method:
    """Construct a method by its paper name with validated coefficients.

    Parameters
    ----------
    name : str
        One of ``METHODS``.
    **parameters
        The method's coefficients (e.g. ``alpha``); None values are ignored.

    Raises
    ------
    ValueError
        Unknown method, a coefficient the method does not take, or one out
        of its range (the message says why).
    """
    accepted = method_parameters(name)
    cls = METHODS[name]
    params = {k: v for k, v in parameters.items() if v is not None}
    extra = set(params) - accepted
    if extra:
        raise ValueError(f"method '{name}' takes no parameter {', '.join(sorted(extra))}; "
                         f"its parameters are {', '.join(sorted(accepted)) or '(none)'}")
    return cls(**params)


def settings_coefficients(settings: dict, name: str) -> dict:
    """The coefficients a model's ``simulate`` section sets that method ``name`` takes.

    A file written for hht-i3 (``alpha -0.1``) still runs with nstiff: the
    coefficients the method does not take are left out, not refused.

    Raises
    ------
    ValueError
        Unknown method.
    """
    accepted = method_parameters(name)
    return {k: settings[k] for k in COEFFICIENTS if k in settings and k in accepted}
