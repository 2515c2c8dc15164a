"""The paper's experiments on any model: convergence, energy, drift, cost and
work-precision (Negrut, Jay & Khude, Sect. 4, Figs. 3-16).

A study is planned as a set of independent runs (:class:`RunSpec`), merged so
that one run serves every study that needs it (``all`` integrates each
(method, h, coefficients) once), executed by :mod:`.parallel`, and analysed
here into tables and figures. Errors are measured against a
:class:`StudyReference` whose own error is estimated; a method's error that
is not clearly above it (below ``REFERENCE_MARGIN`` times the estimate) is
flagged in the tables and left out of the fitted order.

Measures (what each table reports)
----------------------------------
convergence
    |x(T) - x_ref(T)| of each quantity; the default quantities are
    ``positions`` (max over the generalized coordinates, m or rad) and
    ``velocities`` (max over the generalized velocities). Fitted order: the
    least-squares slope of log error against log h (paper Figs. 3-6).
energy
    eps(T) = 1/T int_0^T |E(t) - E_ref(t)| dt, E = T + V the total energy,
    E_ref the reference's energy at the same t (trapezoidal rule over the
    steps). On a conservative model E_ref(t) = E(0) and this is the paper's
    eps(T) (Sect. 4, Figs. 9-10); with dampers or drivers, subtracting the
    reference's energy removes the physical dissipation or supplied work and
    leaves the numerical energy error. The HHT methods are also run at alpha
    = -0.3 and -0.05 (Figs. 7-8): the dissipation table gives eps at both and
    their ratio.
drift
    Phi_q v + Phi_t of one joint's rows at every step of one run per method
    (x against y component, Figs. 11-15). A run whose violation stays below
    ``ROUNDOFF`` (relative to the largest generalized velocity) is marked
    round-off.
cost
    Wall time of the time loop at one common h, median of ``repeat`` runs
    after a warm-up run, normalised to HHT-I3 (Fig. 16), with the engine that
    ran, Newton iterations per step, Jacobian evaluations and factorizations.
work-precision
    Error of the first quantity at T against wall time, every method and h.
"""

from __future__ import annotations

import datetime
import os
import platform
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..registry import methods_taking
from .parallel import default_jobs, run_specs
from .measures import fitted_order, quantity_error, sampled_error
from .recommend import _probe_tol, _recommend
from .reference import StudyReference, build_reference, method_order
from .runs import ModelSource, RunData, RunSpec, format_h
from .tables import Section, Table

__all__ = ["KINDS", "ALL_KINDS", "StudyOptions", "StudyResult", "Section", "run_study", "parse_h_range"]

#: The study kinds, in the order ``all`` runs them.
KINDS = ("convergence", "energy", "drift", "cost", "work-precision", "recommend")
#: The kinds ``all`` runs (``recommend`` is asked for by name, with its tolerances).
ALL_KINDS = KINDS[:5]

#: An error below this multiple of the reference's estimated error is not fitted.
REFERENCE_MARGIN = 10.0
#: Times at which a tolerance sweep's runs are compared with the reference
#: (equally spaced, the last at T): the global error is the largest over them.
RUN_SAMPLES = 20

#: A velocity violation below ROUNDOFF * max(1, max |v|) is round-off.
ROUNDOFF = 1e-10

#: The two alphas of the paper's energy figures (Figs. 7, 8).
ALPHAS = (-0.3, -0.05)

#: Methods that take HHT's alpha.
ALPHA_METHODS = methods_taking("alpha")


def parse_h_range(text: str) -> list[float]:
    """``2^-6:2^-12`` -> [2^-6, 2^-7, ..., 2^-12] (halvings from the first to the last).

    Each end is a number (``1e-3``) or a power of two (``2^-9``).

    Raises
    ------
    ValueError
        Malformed text, a non-positive end, or ends that are not a power of
        two apart.
    """
    def value(s):
        """One end of the range: ``2^k`` or a float."""
        s = s.strip()
        try:
            if "^" in s:
                base, _, exp = s.partition("^")
                return float(base) ** float(exp)
            return float(s)
        except ValueError:
            raise ValueError(f"'{s}' is not a step size (write 1e-3 or 2^-9)") from None

    first, sep, last = text.partition(":")
    if not sep:
        raise ValueError(f"--h-range expects FIRST:LAST (e.g. 2^-6:2^-12), got '{text}'")
    a, b = value(first), value(last)
    if a <= 0 or b <= 0:
        raise ValueError(f"step sizes must be positive, got '{text}'")
    k = np.log2(max(a, b) / min(a, b))
    if abs(k - round(k)) > 1e-9:
        raise ValueError(f"--h-range ends must be a power of two apart ({a:g} and {b:g} are "
                         f"{2**k:.4g} apart); list steps with --h h1,h2,... instead")
    big = max(a, b)
    return [big / 2**i for i in range(int(round(k)) + 1)]


@dataclass
class StudyOptions:
    """What a study runs.

    Attributes
    ----------
    methods : list of str
        Method names (default all: the paper's six and generalized-alpha).
    hs : list of float [s]
        Step sizes, any order (sorted decreasing).
    t_end : float [s]
    quantities : list of str
        ``positions``, ``velocities`` or coordinate/velocity column names.
    reference : str
        ``auto``, ``dop853``, a method name or a result file.
    repeat : int
        Timed repeats of the runs whose time is reported (cost, work-precision).
    joint : str or None
        Joint of the drift study (default: the first revolute joint between
        two bodies, else the first joint with two rows).
    h_single : float or None [s]
        Step of the drift and cost studies (default: the middle of ``hs``).
    jobs : int or None
        Local worker processes for the runs that are not timed (default: the
        number of cores); the timed ones run one at a time, after them
        (``parallel.run_specs``).
    scheduler : str or None
        Dask scheduler address.
    tols : tuple of float
        Target errors of ``recommend`` (in the first quantity's units).
    sweep_tols : tuple of float or None
        Tolerances (rtol = atol) of a work-precision sweep with
        error-controlled steps, each run starting from the largest h;
        None: the work-precision study sweeps the step sizes.
    """

    methods: list
    hs: list
    t_end: float
    quantities: list = field(default_factory=lambda: ["positions", "velocities"])
    reference: str = "auto"
    repeat: int = 3
    joint: str | None = None
    h_single: float | None = None
    jobs: int | None = None
    scheduler: str | None = None
    tols: tuple = (1e-3, 1e-5, 1e-7)
    sweep_tols: tuple | None = None

    def __post_init__(self):
        self.hs = sorted({float(h) for h in self.hs}, reverse=True)
        if self.h_single is None:
            self.h_single = self.hs[len(self.hs) // 2]


@dataclass
class StudyResult:
    """Every section of a study with the runs and reference behind it.

    Attributes
    ----------
    model_name : str
    options : StudyOptions
    reference : StudyReference or None
    runs : dict
        RunSpec.key -> RunData.
    sections : list of Section
    wall_time : float [s]
        Whole study, reference and all runs.
    """

    model_name: str
    options: StudyOptions
    reference: StudyReference | None
    runs: dict
    sections: list
    wall_time: float = 0.0
    command: str = ""

    def section(self, kind: str) -> Section:
        """The section of one kind.

        Raises
        ------
        KeyError
            The study did not include it.
        """
        for s in self.sections:
            if s.kind == kind:
                return s
        raise KeyError(kind)

    def text(self) -> str:
        """Every table as aligned text (what ``mbdsl study`` prints)."""
        parts = []
        if self.reference is not None:
            parts.append(f"reference: {self.reference.description}")
        for s in self.sections:
            parts += [t.text() for t in s.tables]
        return "\n\n".join(parts)

    def write(self, directory) -> list[Path]:
        """Tables (CSV, markdown), figures (PNG, SVG) and ``index.md`` into a folder.

        Returns
        -------
        list of Path
            Every file written, ``index.md`` last.
        """
        from ..graphics.plotting import write_figure
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        written = []
        for s in self.sections:
            for t in s.tables:
                t.write_csv(out / f"{t.name}.csv")
                (out / f"{t.name}.md").write_text(t.markdown() + "\n", encoding="utf-8")
                s.files += [out / f"{t.name}.csv", out / f"{t.name}.md"]
            for stem, panels, title in s.figures:
                s.files += write_figure(panels, out / stem, title)
            written += s.files
        index = out / "index.md"
        index.write_text(self._index(), encoding="utf-8")
        return written + [index]

    def _index(self) -> str:
        """The index page: context, then each section's caption, figures and tables."""
        o = self.options
        lines = [f"# Studies of model `{self.model_name}`", "",
                 f"- command: `{self.command}`" if self.command else "",
                 f"- methods: {', '.join(o.methods)}; steps h = "
                 f"{', '.join(format_h(h) for h in o.hs)} s; T = {o.t_end:g} s",
                 f"- reference: {self.reference.description}" if self.reference else "",
                 f"- {engine_line(r.engine for r in self.runs.values())}",
                 f"- machine: {platform.machine()}, {default_jobs()} cores, "
                 f"{platform.python_implementation()} {platform.python_version()}, "
                 f"{platform.platform(terse=True)}",
                 f"- written {datetime.datetime.now().isoformat(timespec='seconds')}, study wall "
                 f"time {self.wall_time:.1f} s", ""]
        lines = lines[:2] + [x for x in lines[2:] if x != ""] + [""]
        for s in self.sections:
            lines += [f"## {s.kind}", "", s.caption, ""]
            for stem, _, title in s.figures:
                lines += [f"![{title}]({stem}.png)", ""]
            for t in s.tables:
                lines += [t.markdown(), "", f"([CSV]({t.name}.csv))", ""]
        return "\n".join(lines)


# -- planning ----------------------------------------------------------------------------------

def engine_line(engines) -> str:
    """What computed a study's results, as its ``index.md`` records it:
    ``engine: mbdsl VERSION, ENGINES, kernels DIGEST`` (the engines its runs
    used, e.g. ``compiled``; the first 16 digits of
    ``kernels.cache.source_digest``). ``tests/docs/test_studies_current.py``
    compares it with the current version and kernels."""
    from ..kernels.cache import source_digest
    from ..version import __version__
    names = sorted({str(e).split("/")[0] for e in engines}) or ["none"]
    return f"engine: mbdsl {__version__}, {', '.join(names)}, kernels {source_digest()[:16]}"


def _default_joint(model) -> str | None:
    """The drift study's joint when none is named."""
    two_rows = [j for j in model.joints if j.rows == 2]
    for j in two_rows:
        if j.kind == "revolute" and j.first.body >= 0 and j.second.body >= 0:
            return j.name
    return two_rows[0].name if two_rows else (model.joints[0].name if model.joints else None)


def _effective(model, method: str) -> dict:
    """The coefficients a run of ``method`` without explicit ones uses (model file, defaults)."""
    from ..integrators import make_method, settings_coefficients
    return make_method(method, **settings_coefficients(model.settings, method)).parameters()


def _plan(kinds, o: StudyOptions, joint, model) -> list[RunSpec]:
    """The runs every requested kind needs, merged by (method, h, coefficients).

    Explicit coefficients equal to those a plain run uses are dropped, so the
    alpha = -0.05 energy run of a method whose default alpha is -0.05 is the
    plain run itself.
    """
    wanted: dict = {}

    def need(method, h, coefficients=(), repeat=0, energy=False, drift=None, tol=None,
             samples=0):
        """Add a run or widen an existing one with the same key."""
        plain = _effective(model, method)
        if all(plain.get(k) == v for k, v in coefficients):
            coefficients = ()
        spec = RunSpec(method, h, o.t_end, tuple(coefficients), repeat, energy, drift, tol,
                       samples)
        old = wanted.get(spec.key)
        if old is not None:
            spec = RunSpec(method, h, o.t_end, tuple(coefficients), max(repeat, old.repeat),
                           energy or old.energy, drift or old.drift_joint, tol,
                           max(samples, old.samples))
        wanted[spec.key] = spec

    timed = o.repeat if ("work-precision" in kinds or "recommend" in kinds) else 0
    for kind in kinds:
        for m in o.methods:
            if kind == "work-precision" and o.sweep_tols:
                for tol in o.sweep_tols:         # error-controlled, from the largest h
                    need(m, o.hs[0], repeat=o.repeat, tol=tol, samples=RUN_SAMPLES)
            elif kind in ("convergence", "work-precision", "recommend"):
                for h in o.hs:
                    need(m, h, repeat=timed)
                if kind == "recommend":          # error control at rtol = atol = each target
                    for tol in o.tols:
                        need(m, o.hs[0], repeat=timed, tol=_probe_tol(tol))
            elif kind == "energy":
                for h in o.hs:
                    need(m, h, energy=True)
                    if m in ALPHA_METHODS:
                        for a in ALPHAS:
                            need(m, h, (("alpha", a),), energy=True)
            elif kind == "drift":
                need(m, o.h_single, drift=joint)
            elif kind == "cost":
                need(m, o.h_single, repeat=o.repeat)
    return list(wanted.values())


# -- running -----------------------------------------------------------------------------------

def _build_kernels(methods, model, log):
    """Compile the kernels here, once and announced, when some method would run
    on the compiled engine and they are not built yet: local worker
    processes then load them instead of all compiling at once (a cluster's
    workers build their own on their machines)."""
    from .. import assemble, make_method
    from ..integrators.engine import numba_available, unsupported
    from ..integrators.kernel_cache import ensure_loaded, kernels_ready
    if not numba_available() or kernels_ready():
        return
    system = assemble(model)
    if any(unsupported(system, make_method(m)) is None for m in methods):
        ensure_loaded(announce=log)


def run_study(kind: str, model_path, options: StudyOptions, overrides: dict | None = None,
              progress=None, log=print, command: str = "") -> StudyResult:
    """Plan, run and analyse a study.

    Parameters
    ----------
    kind : str or sequence of str
        One of :data:`KINDS`, ``"all"``, or several kinds sharing one
        reference and one set of runs.
    model_path : str or Path
        The ``.mbd`` file.
    options : StudyOptions
    overrides : dict, optional
        Parameter overrides (``--set``).
    progress : callable, optional
        ``progress(done, total)`` after each run.
    log : callable
        One-line messages (reference, run failures).
    command : str
        The command line, recorded on the index page.

    Returns
    -------
    StudyResult

    Raises
    ------
    MbdError
        The model has errors or cannot be assembled.
    ValueError
        Unknown kind, method, quantity or joint (the message lists the valid ones).
    """
    from .. import METHODS, load_text
    kinds = ALL_KINDS if kind == "all" else ((kind,) if isinstance(kind, str) else tuple(kind))
    for k in ([] if kind == "all" else kinds):
        if k not in KINDS:
            raise ValueError(f"unknown study '{k}'; choose one of {', '.join(KINDS + ('all',))}")
    for m in options.methods:
        if m not in METHODS:
            raise ValueError(f"unknown method '{m}'; available: {', '.join(METHODS)}")
    started = time.perf_counter()
    path = Path(model_path)
    source = ModelSource(path.read_text(encoding="utf-8"), str(path),
                         tuple(sorted((overrides or {}).items())))
    model = load_text(source.text, source.file, dict(source.overrides))
    _check_quantities(model, options.quantities)
    joint = options.joint or _default_joint(model)
    if "drift" in kinds:
        names = [e.name for e in model.constraint_elements]
        if joint not in names:
            raise ValueError(f"no joint '{joint}' for the drift study; the model's joints are "
                             f"{', '.join(names) or '(none)'}")
    reference = None
    if any(k in kinds for k in ("convergence", "energy", "work-precision", "recommend")):
        t0 = time.perf_counter()
        reference = build_reference(options.reference, model, options.t_end, min(options.hs), log)
        if any(q.startswith("lambda.") for q in options.quantities):
            from .. import assemble
            reference.add_multipliers(assemble(model))
        log(f"reference ({time.perf_counter() - t0:.1f} s): {reference.description}")
        if not reference.trusted:
            log(f"warning: the reference cannot be trusted ({reference.warning}); errors "
                "against it are shown, no order is fitted from them")
    specs = _plan(kinds, options, joint, model)
    _build_kernels(options.methods, model, log)
    done = [0]

    def on_done(data: RunData):
        """Count a finished run; report a failed one."""
        done[0] += 1
        if not data.completed:
            log(f"run {data.spec.label()} stopped at t = {data.t_stop:.6g} s: "
                f"{data.message.splitlines()[0]}")
        if progress:
            progress(done[0], len(specs))

    results = run_specs(source, specs, options.jobs, options.scheduler, on_done)
    runs = {r.spec.key: r for r in results}
    system = None
    if "energy" in kinds or "recommend" in kinds:      # (recommend: the modes)
        from .. import assemble
        system = assemble(model)
    analyse = {"convergence": _convergence, "energy": _energy, "drift": _drift,
               "cost": _cost, "work-precision": _work_precision, "recommend": _recommend}
    sections = [analyse[k](options, runs, reference, model=model, system=system, joint=joint,
                           source=source) for k in kinds]
    return StudyResult(model.name, options, reference, runs, sections,
                       time.perf_counter() - started, command)


def _multiplier_names(model) -> list:
    """The model's multiplier columns, ``lambda.<joint or driver>.<k>``."""
    from .. import assemble
    return [f"lambda.{name}.{k}" for name, k in assemble(model).layout.rows]


def _check_quantities(model, quantities):
    """Quantities must be ``positions``, ``velocities``, coordinate or velocity
    names, or multiplier columns (``lambda.<joint>.<k>``)."""
    valid = ["positions", "velocities"] + model.coordinate_names() + model.velocity_names()
    if any(q.startswith("lambda.") for q in quantities):
        valid += _multiplier_names(model)
    for qn in quantities:
        if qn not in valid:
            import difflib
            close = difflib.get_close_matches(qn, valid, n=3)
            raise ValueError(f"no quantity '{qn}' (a study compares positions, velocities and "
                             f"multipliers at T)" + (f"; did you mean {', '.join(close)}?" if close else
                                      f"; choose from {', '.join(valid)}"))


def _usable(run, err, ref_err, ref=None):
    """An error that may be fitted: completed run, clearly above the
    reference's error, against a reference that passed its own cross-check."""
    return (run.completed and np.isfinite(err) and err > REFERENCE_MARGIN * ref_err
            and (ref is None or ref.trusted))


def _convergence(o, runs, ref, model, system=None, **_):
    """Error at T per method and h, fitted orders (Figs. 3-6)."""
    from ..graphics.plotting import Panel, Series
    errors = Table("convergence", f"Error at T = {o.t_end:g} s against the reference",
                   ["method", "h [s]"] + [f"error {q}" for q in o.quantities] + ["status"])
    orders = Table("convergence_orders", "Fitted order of convergence (slope of log error "
                   "against log h)", ["method", "expected"] + [f"order {q}" for q in o.quantities]
                   + ["points fitted"])
    panels = [Panel(f"error in {q} at T", "h [s]", "error", xscale="log", yscale="log")
              for q in o.quantities]
    flagged = False
    for m in o.methods:
        per_q = {q: ([], []) for q in o.quantities}
        for h in o.hs:
            run = runs[(m, h, ())]
            cells, marks = [], []
            for q in o.quantities:
                err, ref_err = quantity_error(model, run, ref, q) if run.completed else (np.nan, 0)
                cells.append(err)
                if _usable(run, err, ref_err, ref):
                    per_q[q][0].append(h)
                    per_q[q][1].append(err)
                elif run.completed and ref.trusted:
                    marks.append(f"{q} below {REFERENCE_MARGIN:g}x reference error")
                    flagged = True
            status = "completed" if run.completed else f"failed at t = {run.t_stop:.4g} s"
            errors.rows.append([m, h] + cells + ["; ".join([status] + marks)])
        exp = method_order(m, runs[(m, o.hs[0], ())].coefficients, system)
        orders.rows.append([m, exp] + [fitted_order(*per_q[q]) for q in o.quantities]
                           + [min(len(per_q[q][0]) for q in o.quantities)])
        for panel, q in zip(panels, o.quantities):
            hs_q = [h for h in o.hs if runs[(m, h, ())].completed]
            errs = [quantity_error(model, runs[(m, h, ())], ref, q)[0] for h in hs_q]
            panel.series.append(Series(m, np.array(hs_q), np.array(errs)))
    if flagged:
        errors.notes.append(f"errors below {REFERENCE_MARGIN:g} times the reference's estimated "
                            "error are shown but not fitted")
    errors.notes.append(f"reference: {ref.description}")
    if not ref.trusted:
        errors.notes.insert(0, f"the reference cannot be trusted ({ref.warning}): the errors "
                            "are shown, no order is fitted from them")
    caption = ("Global error at T of each method against the reference, on log-log axes: a "
               "method of order p draws a line of slope p (the paper's Figs. 3-6). NEWMARK "
               "(gamma = 0.6 by default) is first order; the others are second order.")
    return Section("convergence", caption, [errors, orders],
                   [("convergence", panels, "Convergence at T")])


def _eps(run, e_ref) -> float:
    """eps(T) = 1/T int |E - E_ref| dt over the run's steps."""
    t = run.t
    return float(np.trapezoid(np.abs(run.energy - e_ref), t) / (t[-1] - t[0]))


def _energy(o, runs, ref, model, system, **_):
    """eps(T) per method and h; HHT at two alphas (Figs. 7-10)."""
    from ..graphics.plotting import Panel, Series
    cache: dict = {}

    def e_ref(run):
        """Reference energy on the run's time grid (cached per grid)."""
        key = (run.spec.h, len(run.t))
        if key not in cache:
            cache[key] = ref.energy(system, run.t)
        return cache[key]

    table = Table("energy", f"Average energy error eps(T) = 1/T int |E - E_ref| dt [J], "
                  f"T = {o.t_end:g} s", ["method", "h [s]", "eps(T) [J]", "status"])
    orders = Table("energy_orders", "Fitted order of eps(T) in h", ["method", "expected",
                                                                    "order of eps"])
    eps_panel = Panel("average energy error eps(T)", "h [s]", "eps(T) [J]", xscale="log",
                      yscale="log")
    for m in o.methods:
        hs_ok, eps_ok = [], []
        for h in o.hs:
            run = runs[(m, h, ())]
            if run.completed:
                eps = _eps(run, e_ref(run))
                hs_ok.append(h)
                eps_ok.append(eps)
                table.rows.append([m, h, eps, "completed"])
            else:
                table.rows.append([m, h, float("nan"), f"failed at t = {run.t_stop:.4g} s"])
        orders.rows.append([m, method_order(m, runs[(m, o.hs[0], ())].coefficients, system),
                            fitted_order(hs_ok, eps_ok)])
        eps_panel.series.append(Series(m, np.array(hs_ok), np.array(eps_ok)))
    diss = Table("energy_dissipation", "Numerical dissipation against HHT's alpha: eps(T) at "
                 f"alpha = {ALPHAS[0]:g} and {ALPHAS[1]:g}",
                 ["method", "h [s]", f"eps alpha={ALPHAS[0]:g}", f"eps alpha={ALPHAS[1]:g}",
                  "ratio"])
    curves = []
    for m in [m for m in o.methods if m in ALPHA_METHODS]:
        for h in o.hs:
            pair = [_alpha_run(runs, model, m, h, a) for a in ALPHAS]
            if all(r.completed for r in pair):
                e = [_eps(r, e_ref(r)) for r in pair]
                diss.rows.append([m, h, e[0], e[1], e[0] / e[1]])
            else:
                diss.rows.append([m, h, float("nan"), float("nan"), float("nan")])
    alpha_methods = [m for m in ALPHA_METHODS if m in o.methods]
    if alpha_methods:
        m = alpha_methods[0]
        for a in ALPHAS:
            panel = Panel(f"{m}, alpha = {a:g}", "t [s]", "E - E_ref [J]")
            for h in o.hs:
                r = _alpha_run(runs, model, m, h, a)
                if r.completed:
                    panel.series.append(Series(f"h = {format_h(h)}", r.t, r.energy - e_ref(r)))
            curves.append(panel)
    caption = ("Energy error of each method: E - E_ref is the total energy's departure from the "
               "reference's at the same time (on a conservative model, E(t) - E(0)); eps(T) "
               "averages its magnitude over the run and falls like h^p (the paper's Figs. 9-10). "
               "The curves show the HHT energy error at two alphas (Figs. 7-8); the "
               "dissipation table compares their eps(T).")
    figures = [("energy_eps", [eps_panel], "Average energy error")]
    if curves:
        figures.insert(0, ("energy_curves", curves, "Energy error at two alphas"))
    tables = [table, orders] + ([diss] if diss.rows else [])
    return Section("energy", caption, tables, figures)


def _alpha_run(runs, model, method, h, alpha) -> RunData:
    """The run of ``method`` at ``alpha`` (the plain run when alpha is its default)."""
    if _effective(model, method).get("alpha") == alpha:
        return runs[(method, h, ())]
    return runs[(method, h, (("alpha", alpha),))]


def _drift(o, runs, ref, model, joint, **_):
    """Velocity constraint violation of one joint, x against y (Figs. 11-15)."""
    from ..graphics.plotting import Panel, Series
    table = Table("drift", f"Velocity constraint violation Phi_q v + Phi_t of joint '{joint}', "
                  f"h = {format_h(o.h_single)} s, T = {o.t_end:g} s",
                  ["method", "max |x| [m/s]", "max |y| [m/s]", "level", "status"])
    panels = []
    for m in o.methods:
        run = runs[(m, o.h_single, ())]
        d = run.drift
        vmax = max(1.0, float(np.max(np.abs(run.v_end))))
        big = np.max(np.abs(d), axis=0)
        level = "round-off" if np.max(big) <= ROUNDOFF * vmax else "O(h^p)"
        status = "completed" if run.completed else f"failed at t = {run.t_stop:.4g} s"
        table.rows.append([m, float(big[0]), float(big[1]) if d.shape[1] > 1 else float("nan"),
                           level, status])
        y = d[:, 1] if d.shape[1] > 1 else run.t
        panels.append(Panel(m, "x component [m/s]",
                            "y component [m/s]" if d.shape[1] > 1 else "t [s]",
                            [Series(m, d[:, 0], y, "scatter")]))
    table.notes.append(f"round-off: below {ROUNDOFF:g} times max(1, max |v|); index-3 methods "
                       "(newmark, hht-i3, nstiff) do not impose the velocity constraint")
    caption = (f"The velocity-level violation of joint '{joint}' at every step, its x component "
               "against its y component (the paper's Figs. 11-15): a cloud of size O(h^p) for the "
               "index-3 methods, round-off for the stabilized index-2 ones.")
    return Section("drift", caption, [table], [("drift", panels, f"Velocity drift at '{joint}'")])


def _cost(o, runs, ref, model, **_):
    """Wall time at one h normalised to HHT-I3 (Fig. 16)."""
    from ..graphics.plotting import Panel, Series
    base_m = "hht-i3" if "hht-i3" in o.methods else o.methods[0]
    base = runs[(base_m, o.h_single, ())].time
    table = Table("cost", f"Cost at h = {format_h(o.h_single)} s, T = {o.t_end:g} s (time loop, "
                  f"median of {o.repeat} runs after a warm-up run)",
                  ["method", "engine", "steps", "time [s]", "us/step", f"relative to {base_m}",
                   "iterations/step", "Jacobians", "factorizations", "residuals", "status"])
    rel = []
    for m in o.methods:
        run = runs[(m, o.h_single, ())]
        s = run.stats
        steps = max(s["steps"], 1)
        rel.append(run.time / base)
        table.rows.append([m, run.engine, s["steps"], run.time, 1e6 * run.time / steps,
                           run.time / base,
                           s["iterations"] / steps, s["jacobians"], s["factorizations"],
                           s["residuals"], "completed" if run.completed else
                           f"failed at t = {run.t_stop:.4g} s"])
    where = "a Dask cluster" if o.scheduler else "this process, one at a time"
    table.notes.append(f"{len(o.methods)} runs timed in {where}; "
                       f"machine: {platform.machine()}, {os.cpu_count()} cores")
    panel = Panel(f"CPU time relative to {base_m}", "method", "relative time",
                  [Series("relative time", np.array(o.methods), np.array(rel), "bar")])
    caption = (f"CPU time of each method at one step size, relative to {base_m} (the paper's "
               "Fig. 16), with the Newton work behind it.")
    return Section("cost", caption, [table], [("cost", [panel], "Relative cost")])


def _untrusted_note(table, ref) -> None:
    """A first note on a table of errors against a reference that failed its
    own cross-check (``StudyReference.trusted``)."""
    if not ref.trusted:
        table.notes.insert(0, f"the reference cannot be trusted ({ref.warning}): errors below "
                           "its disagreement mean nothing")


def _work_precision(o, runs, ref, model, **_):
    """Error against wall time, every method and h (or tolerance)."""
    if o.sweep_tols:
        return _work_precision_tols(o, runs, ref, model)
    from ..graphics.plotting import Panel, Series
    q = o.quantities[0]
    table = Table("work_precision", f"Error in {q} at T against wall time (median of {o.repeat} "
                  "after a warm-up run)", ["method", "engine", "h [s]", f"error {q}", "time [s]",
                                           "status"])
    panel = Panel(f"work-precision ({q})", "wall time [s]", f"error in {q} at T",
                  xscale="log", yscale="log")
    for m in o.methods:
        xs, ys = [], []
        for h in o.hs:
            run = runs[(m, h, ())]
            err = quantity_error(model, run, ref, q)[0] if run.completed else float("nan")
            table.rows.append([m, run.engine, h, err, run.time, "completed" if run.completed
                               else f"failed at t = {run.t_stop:.4g} s"])
            if run.completed:
                xs.append(run.time)
                ys.append(err)
        panel.series.append(Series(m, np.array(xs), np.array(ys)))
    _untrusted_note(table, ref)
    caption = ("What accuracy costs in time: each line is one method over the step sizes; the "
               "lower-left method gives the same error for less time.")
    return Section("work-precision", caption, [table],
                   [("work_precision", [panel], "Work-precision")])


def _work_precision_tols(o, runs, ref, model):
    """Error against wall time, every method and tolerance (error-controlled steps)."""
    from ..graphics.plotting import Panel, Series
    q = o.quantities[0]
    over = f"the largest error in {q} over {RUN_SAMPLES} times of the run"
    table = Table("work_precision", f"Error in {q} with error-controlled steps, rtol = atol = "
                  f"tol, from h = {o.hs[0]:g} s, against wall time (median of {o.repeat} after "
                  f"a warm-up run): {over} (the last at T) and the error at T",
                  ["method", "engine", "tol", "steps", "rejected", f"max error {q}",
                   f"error {q}", "time [s]", "status"])
    panel = Panel(f"work-precision by tolerance ({q})", "wall time [s]",
                  f"max error in {q} over the run", xscale="log", yscale="log")
    achieved = Panel(f"achieved error against tolerance ({q})", "tol",
                     f"max error in {q} over the run", xscale="log", yscale="log")
    slopes = Table("tolerance_proportionality", f"Tolerance proportionality: the least-squares "
                   f"slope of log(error) against log(tol) (1 when the error is proportional to "
                   f"the tolerance), of {over} and of the error at T alone (which may pass "
                   "through zero at T), and the largest error over tol at the tightest "
                   "tolerance", ["method", "slope", "slope at T", "error / tol", "runs fitted"])
    for m in o.methods:
        xs, ys, ts, ends = [], [], [], []
        for tol in o.sweep_tols:
            run = runs[(m, o.hs[0], (), tol)]
            err = quantity_error(model, run, ref, q)[0] if run.completed else float("nan")
            most = sampled_error(model, run, ref, q) if run.completed else float("nan")
            if not np.isfinite(most):      # a multiplier: at T only
                most = err
            table.rows.append([m, run.engine, tol, run.stats.get("steps", 0),
                               run.stats.get("rejected", 0), most, err, run.time,
                               "completed" if run.completed
                               else f"failed at t = {run.t_stop:.4g} s"])
            if run.completed:
                xs.append(run.time)
                ys.append(most)
                ends.append(err)
                ts.append(tol)
        slope = fitted_order(ts, ys)
        ok = [(t, e) for t, e in zip(ts, ys) if np.isfinite(e) and e > 0]
        slopes.rows.append([m, slope, fitted_order(ts, ends),
                            min(ok)[1] / min(ok)[0] if ok else float("nan"), len(ok)])
        label = f"{m} (slope {slope:.2f})" if np.isfinite(slope) else m
        panel.series.append(Series(m, np.array(xs), np.array(ys)))
        achieved.series.append(Series(label, np.array(ts), np.array(ys)))
    _untrusted_note(table, ref)
    caption = ("What accuracy costs in time when the step size follows a tolerance: each line "
               "is one method over the tolerances (rtol = atol); the lower-left method gives "
               "the same error for less time. The second panel shows the error each "
               "tolerance achieves, the largest over the run, and the second table its slope: "
               "the tolerance is an error per unit step, so that a second-order method's "
               "error falls in proportion to it (slope 1; docs/methods.md).")
    return Section("work-precision", caption, [table, slopes],
                   [("work_precision", [panel, achieved], "Work-precision by tolerance")])


__all__ += ["quantity_error", "fitted_order"]
