"""mbdsl: dynamics of planar multibody systems from a small declarative language.

Public API
----------
load(path, overrides)        parse and check a ``.mbd`` file -> Model
load_text(text, ...)         the same from a string
from_spec(spec, overrides)   check a ModelSpec built in Python -> Model
Component(name, params, items)  a part defined once; component("upper", L=0.4) -> instance
check(path)                  every diagnostic of a file (no exception)
assemble(model)              -> AssembledSystem (M, Q, Phi and derivatives)
simulate(model, method=..., h=..., t_end=..., **coefficients) -> Solution
METHODS                      the paper's integration methods by name
write_solution(sol, path)    CSV, or HDF5 for .h5/.hdf5
load_solution(path)          a result file back into a Solution
plot(sol, ...)               time histories as one matplotlib figure
animate(sol, path, ...)      the mechanism's motion as GIF/MP4
mbdsl.studies.run_study      the paper's experiments (convergence, energy, drift,
                             cost, work-precision) on a model, in parallel
"""

from __future__ import annotations

from pathlib import Path

from .assembly.initial import InitialState, consistent_initial_state
from .assembly.system import AssembledSystem, assemble
from .dsl.check import check_spec
from .dsl.parser import parse_file, parse_text
from .dsl.spec import (ArgSpec, BeamSpec, BodySpec, DriverSpec, ForceSpec, InitialSpec, JointSpec,
                       ModelSpec, ParameterSpec, PointSpec, SettingSpec, StateSpec, TableSpec,
                       ComponentSpec, ImportSpec, InstanceSpec, OutputSpec)
from .errors import (AssemblyError, ConvergenceError, Diagnostic, MbdError, MbdModelError,
                     MbdSyntaxError, render)
from .integrators import (METHODS, JacobianUpdate, NewtonOptions, integrate, make_method,
                          method_parameters, settings_coefficients)
from .integrators.dense import output_times as dense_times
from .model.elements import Model
from .io import load_solution, write_solution
from .io.solution import Solution
from .registry import DEFAULT_METHOD

__version__ = "0.1.0"

#: A component (a part with parameters) built in Python:
#: ``Component("Link", {"L": "1 m"}, [BodySpec(...)])``; calling it makes an
#: instance, ``link("upper", L=0.4)`` (see :class:`~mbdsl.dsl.spec.ComponentSpec`).
Component = ComponentSpec

__all__ = [
    "load", "load_text", "from_spec", "check", "redundant_policy", "assemble", "simulate", "METHODS",
    "Model", "Solution", "AssembledSystem", "InitialState", "NewtonOptions", "JacobianUpdate",
    "ModelSpec", "BodySpec", "BeamSpec", "JointSpec", "ForceSpec", "DriverSpec", "InitialSpec",
    "ParameterSpec", "PointSpec", "SettingSpec", "ArgSpec", "StateSpec", "TableSpec",
    "Component", "ComponentSpec", "ImportSpec", "InstanceSpec", "OutputSpec",
    "MbdError", "MbdSyntaxError", "MbdModelError", "AssemblyError", "ConvergenceError",
    "Diagnostic", "render", "__version__", "load_solution", "write_solution", "plot", "animate",
]


def plot(solution, y=None, x: str = "t", path=None):
    """Time histories of a Solution as one figure; see :func:`mbdsl.graphics.plotting.plot_solution`."""
    from .graphics.plotting import plot_solution
    return plot_solution(solution, y=y, x=x, path=path)


def animate(solution, path, fps: float = 25.0, speed: float = 1.0):
    """Write the mechanism's motion; see :func:`mbdsl.graphics.plotting.animate_solution`."""
    from .graphics.plotting import animate_solution
    return animate_solution(solution, path, fps=fps, speed=speed)


def load(path, overrides: dict | None = None) -> Model:
    """Parse and check a model file.

    Parameters
    ----------
    path : str or Path
    overrides : dict of str -> float or str, optional
        Parameter values replacing the declared ones (the CLI's ``--set``).

    Returns
    -------
    Model

    Raises
    ------
    MbdSyntaxError, MbdModelError
        With diagnostics (file, line, column, hint).
    """
    return check_spec(parse_file(path), overrides)


def load_text(text: str, file: str = "<string>", overrides: dict | None = None) -> Model:
    """Like :func:`load`, from model text."""
    return check_spec(parse_text(text, file), overrides)


def from_spec(spec: ModelSpec, overrides: dict | None = None) -> Model:
    """Check a :class:`ModelSpec` built in Python (see :mod:`mbdsl.dsl.spec`).

    The model's source is the specification written in the language
    (:func:`mbdsl.dsl.unparse.spec_text`), so that its result files can be
    read back, plotted and animated like those of a model file.
    """
    if spec.source is None:
        import dataclasses

        from .dsl.unparse import spec_text
        spec = dataclasses.replace(spec, source=spec_text(spec))
    return check_spec(spec, overrides)


def redundant_policy(model: Model, method: str | None = None,
                     formulation: str | None = None) -> str:
    """How the initial state treats redundant joints for a run: ``"accept"``
    (W405, the run goes on with the augmented formulation) when the
    formulation is augmented, or not chosen and the method takes it;
    ``"error"`` (E401) otherwise."""
    method = method or model.settings.get("method", DEFAULT_METHOD)
    formulation = formulation or model.settings.get("formulation")
    if formulation is not None:
        return "accept" if formulation == "augmented" else "error"
    return "accept" if METHODS[method].accepts_augmented else "error"


def check(path, overrides: dict | None = None) -> list[Diagnostic]:
    """All diagnostics of a model file (errors and warnings); empty if clean.

    Beyond the language checks, assembles the initial configuration and
    analyses it (redundant joints: W405 when the run would go on with the
    augmented formulation, else E401; loops that cannot close E503, a
    mechanism that cannot move W402), as ``mbdsl check`` does.
    """
    try:
        model = load(path, overrides)
    except MbdError as err:
        return err.diagnostics
    try:
        init = consistent_initial_state(assemble(model), float(model.settings.get("t_start", 0.0)),
                                        redundant=redundant_policy(model))
    except MbdError as err:
        return list(model.warnings) + err.diagnostics
    return list(model.warnings) + list(init.warnings)


def step_control(settings: dict, rtol: float | None = None, atol: float | None = None):
    """The run's :class:`~mbdsl.integrators.adaptive.StepControl`, or None for
    fixed steps: rtol/atol given here first, then the ``simulate`` section's
    ``rtol``, ``atol`` and ``tol`` (which sets both); one of the pair alone
    sets the other to the same value.

    Raises
    ------
    ValueError
        A non-positive tolerance.
    """
    from .integrators.adaptive import StepControl
    tol = settings.get("tol")
    r = rtol if rtol is not None else settings.get("rtol", tol)
    a = atol if atol is not None else settings.get("atol", tol)
    if r is None and a is None:
        return None
    return StepControl(float(r if r is not None else a), float(a if a is not None else r))


def simulate(model: Model, method: str | None = None, h: float | None = None,
             t_end: float | None = None, *, newton: NewtonOptions | None = None,
             on_failure: str = "raise", progress=None, observers=(), engine: str = "auto",
             output_every: int = 1, announce=None, compile_policy: str = "wait",
             formulation: str | None = None, rtol: float | None = None,
             atol: float | None = None, setup_time: float = 0.0, fixed: bool = False,
             output_dt: float | None = None, output_times=None,
             **coefficients) -> Solution:
    """Simulate a model.

    Parameters
    ----------
    model : Model
        From :func:`load` or :func:`from_spec`.
    method : str, optional
        A key of :data:`METHODS`; default: the model's ``simulate`` section,
        else ``"hht-i3"``.
    h : float [s], optional
        Step size; default from the ``simulate`` section.
    t_end : float [s], optional
        End time; default from the ``simulate`` section.
    newton : NewtonOptions, optional
    on_failure : {"raise", "return"}
        See :func:`mbdsl.integrators.integrate`.
    progress : callable, optional
        ``progress(t, h, iterations)`` as the run goes; see
        :func:`mbdsl.integrators.integrate`.
    observers : sequence of mbdsl.io.observers.RunObserver, optional
        Told of the run as it goes (its start, the rows recorded, events, its
        end), e.g. ``mbdsl.io.CsvStream(path)``, which writes the rows to a
        file as the run goes.
    engine : {"auto", "numpy", "compiled", "uncompiled"}
        See :func:`mbdsl.integrators.integrate`.
    output_every : int
        Record every K-th step and the last one.
    announce : callable (str) -> None, optional
        Told when the compiled kernels are compiled for this machine (once).
    compile_policy : {"wait", "background"}
        See :func:`mbdsl.integrators.integrate`.
    formulation : {"lagrange", "augmented"}, optional
        The constraint formulation (``Method.formulated``); default: the
        ``simulate`` section's, else ``"lagrange"``. ``"augmented"`` runs
        through singular positions and redundant joints (newmark, hht-i3,
        nstiff, genalpha). Not given: a model with redundant
        joints runs augmented (with W405) when the method takes it.
    rtol, atol : float, optional
        Error-controlled step sizes (``integrators.adaptive``): each step's
        estimated local position error within atol + rtol |q| (atol in m
        and rad), h the first step's size. Either one alone sets both;
        default: the ``simulate`` section's ``rtol``, ``atol`` or ``tol``
        (both), else fixed steps of h.
    setup_time : float [s]
        Time spent before this call on the run (reading the model), counted
        in the run's ``timings["setup"]`` with the assembly's.
    fixed : bool
        Fixed steps of h, whatever tolerance the ``simulate`` section gives
        (a study's sweep over h); with ``rtol``/``atol`` a ValueError.
    output_dt : float [s], optional
        Rows every output_dt from the start (and at t_end) instead of one
        per step, interpolated within the steps by the method's dense
        output (:mod:`mbdsl.integrators.dense`); events keep their rows.
        Default: the ``simulate`` section's ``output_dt``, else a row per
        (``output_every``-th) step.
    output_times : sequence of float [s], optional
        Rows at exactly these times (and t_end), as scipy's ``t_eval``;
        excludes ``output_dt``.
    **coefficients
        Method coefficients, e.g. ``alpha=-0.1``; default from the
        ``simulate`` section.

    Returns
    -------
    Solution

    Raises
    ------
    ValueError
        Missing h or t_end, unknown method, coefficient out of range, an
        unknown formulation or one the method does not take; both
        output_dt and output_times, an output time outside the run, or
        either with output_every > 1.
    AssemblyError
        No consistent initial state.
    ConvergenceError
        The run could not go on (``on_failure="raise"``); carries the
        partial solution.
    """
    s = model.settings
    method = method or s.get("method", DEFAULT_METHOD)
    h = h if h is not None else s.get("h")
    t_end = t_end if t_end is not None else s.get("t_end")
    if h is None or t_end is None:
        raise ValueError("give h and t_end, as arguments or in the model's simulate section")
    # coefficients from the model's simulate section apply to the methods that
    # take them (a file written for hht-i3 still runs with --method nstiff);
    # coefficients given here are checked strictly
    params = settings_coefficients(s, method)
    params.update({k: v for k, v in coefficients.items() if v is not None})
    m = make_method(method, **params)
    import time
    t0 = time.perf_counter()
    system = assemble(model)
    if engine == "uncompiled":       # nothing compiled is imported, not even outside the loop
        system.kernels = "uncompiled"
    t_start = float(s.get("t_start", 0.0))
    chosen = formulation or s.get("formulation")
    formulated = m.formulated(chosen or "lagrange", system)   # an unknown or refused one: now
    initial = consistent_initial_state(system, t_start,
                                       redundant=redundant_policy(model, method, chosen))
    if chosen is None and any(d.code == "W405" for d in initial.warnings):
        formulated = m.formulated("augmented", system)   # redundant joints: what runs them
    m = formulated
    from .modes import step_warning           # a mode the step neither follows nor damps
    found = step_warning(system, initial, m, float(h), float(t_end) - t_start)
    if found is not None:
        initial.warnings.append(found)
    assembly_time = time.perf_counter() - t0
    if fixed and (rtol is not None or atol is not None):
        raise ValueError("fixed steps and a tolerance (rtol/atol) exclude each other")
    control = None if fixed else step_control(s, rtol, atol)
    if output_times is None and output_dt is None and output_every == 1:
        output_dt = s.get("output_dt")
    times = None
    if output_dt is not None or output_times is not None:
        times = dense_times(t_start, float(t_end), dt=output_dt, times=output_times)
    return integrate(system, m, float(t_end), float(h), t_start=t_start, initial=initial,
                     newton=newton, on_failure=on_failure, progress=progress,
                     observers=observers, engine=engine, output_every=output_every,
                     announce=announce, compile_policy=compile_policy, control=control,
                     setup_time=setup_time + assembly_time, output_times=times)
