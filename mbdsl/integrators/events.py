"""Events: contacts and joint limits closing and opening, located within a step.

A stepper returns at each step across which a gap of the model's contacts and
limits (:class:`~mbdsl.assembly.contact.ContactState`) changed sign, the
points of a spring with a free length passed each other, or the argument u
of a table of the state passed one of the table's kinks (a point of a linear
table; :class:`~mbdsl.model.elements.StateSwitch`, its branch the number of
kinks at or below u) (:meth:`EventLocator.crosses`; the compiled loop's own
test in its kernels),
and the time loop (``loop.TimeLoop.land``) asks :class:`EventLocator` where
to end it (:meth:`EventLocator.check`): the root of the gap along the step
is estimated with Brent's method on the step's cubic Hermite interpolant of q
(from q and v at both ends, third order), or for a closing gap on the
Taylor expansion q + tau v + tau^2 a / 2 from the step's start (the motion up
to a closing is free of the contact, while the end of a step past it already
feels its force and bends the interpolant), and unless it lies within the event
tolerance of the step's start, the step is discarded and retaken with the
size that ends it just past the root (by half the tolerance). A retaken step
lands when its end is within the tolerance past the root, judged by the end's
own gap and gap rate; if it is not, the next retake corrects its size by
Newton's rule on that gap (g + dg/dt dt = 0). The
tolerance is ``EVENT_TOL`` times the nominal step size. A step is cut at most
``MAX_CUTS`` times for one event (the retaken step's own interpolant moves
the root a little each time); then it is accepted as it is.

When a step ends on an event the contact's state changes there: a closing
gap remembers its approach speed (from the interpolant's velocity at the
root), which sets the damping of its force law
(:mod:`mbdsl.model.contact`); an opening gap forgets it. Every event is
recorded in ``Solution.events``.

Functions of time that switch branch (``if``, ``min``, ``max``, ``clip``,
comparisons, ``abs``, ``sign``: :func:`time_switches`) are known in advance
(:func:`switch_times`): the time loop runs from one to the next, each stretch
ending just before its switch, and the method restarts just after it on the
new branch (:func:`restart_after_switch`).

Locating the closing matters for the law, not only for accuracy: the impact
speed is measured where the gap closes, and a step that jumps deep into a
stiff contact would also ask Newton to converge on a force that is not yet
small.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["EventLocator", "EVENT_TOL", "MAX_CUTS", "STEPS_PER_CONTACT", "SWITCH_GAP", "switch_gap",
           "restart_after_switch", "switch_times", "time_switches"]

#: Event location tolerance, as a fraction of the nominal step size h.
EVENT_TOL = 1e-6
#: At most this many retakes of a step to land on one event.
MAX_CUTS = 8
#: The landing tolerance of a kink of a table of the state, as a fraction of
#: h: a step that passes a kink by d errs by (jump of the slope) d^2, below a
#: second-order method's own error for d = 1e-4 h, while the retakes it
#: spares (steps of 1e-9 s) make an index-3 method's velocities noisy, 1e-5
#: rad/s on a crank's speed, enough to move the rate back across its kink.
KINK_TOL = 1e-4
#: A kink of a table of the state whose root, found again on a retaken step,
#: lies before this fraction of its time from the step's start (a real one
#: stays where it was, to the interpolant's accuracy) is the step's own.
RECEDES = 0.9
#: A step ends this fraction of the nominal step size h before a switch of a
#: function of time, and the next starts as far after it (:func:`switch_gap`).
SWITCH_GAP = 1e-10
#: Error-controlled steps while a gap is closed are at most its estimated
#: impact duration over this (``ContactState.duration``).
STEPS_PER_CONTACT = 50
#: A spring whose points pass each other this many times within less than the
#: run's nominal step chatters: its points stay together (two points a joint
#: holds at one place, or nearly), where its direction is not defined; the run
#: stops (E605) instead of landing pass after pass at steps of 1e-12 s
#: (measured on a generated mechanism: 1.5e6 steps, 221 passes, 100 s).
CHATTER_PASSES = 10


def switch_gap(h, t_switch) -> float:
    """How far before a switch at t_switch [s] a step ends, and after it the
    next starts [s]: ``SWITCH_GAP`` h, but never below 64 round-off units of
    t_switch, where t_switch -/+ the gap would round to t_switch itself and
    a step would end on the switch, seeing the new branch at its end (an
    error-controlled run started with h = 1e-9 s did: 6e-3 rad at t = 2 s
    on a torque switched at t = 1 s, against 4e-16 from h = 1e-6 s)."""
    return max(SWITCH_GAP * h, 64.0 * np.finfo(float).eps * max(1.0, abs(t_switch)))


def _hermite(theta, step, qa, va, qb, vb):
    """q and dq/dt at theta in [0, 1] on the cubic Hermite interpolant."""
    t2, t3 = theta * theta, theta ** 3
    h00, h10, h01, h11 = 2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + theta, -2 * t3 + 3 * t2, t3 - t2
    d00, d10, d01, d11 = 6 * t2 - 6 * theta, 3 * t2 - 4 * theta + 1, -6 * t2 + 6 * theta, \
        3 * t2 - 2 * theta
    q = h00 * qa + h10 * step * va + h01 * qb + h11 * step * vb
    v = (d00 * qa + d01 * qb) / step + d10 * va + d11 * vb
    return q, v


class EventLocator:
    """Locates a model's events in the time loop: contact gaps closing and
    opening, springs passing through zero length, switches of functions of time.

    Parameters
    ----------
    system : AssembledSystem
        With ``contact_state`` set.
    h : float [s]
        The nominal step size (the tolerance's scale).
    sol : Solution
        Receives the events (``events``) and the contact log (``contact_log``).
    """

    def __init__(self, system, h, sol):
        self.system = system
        self.group = system.contact_state
        self.springs = system.flipping_springs
        self.switches = system.state_switches
        self.tol = EVENT_TOL * h
        self.kink_tol = KINK_TOL * h
        self.sol = sol
        self.cuts = 0           # retakes for the event now being landed on
        self._kink_root = None  # (step start, time) of the last kink root a retake aimed at
        n_gaps = len(self.group.names) if self.group is not None else 0
        self.caps = np.full(n_gaps, np.inf)                  # step limits of closed gaps
        self._mass = system.mass_diag
        self.happened = False   # the step just checked ended with events
        #: ... of which one changes the law's value (a gap, a spring's direction):
        #: the restart there takes v onto the velocity constraint first. A kink of
        #: a table of the state only changes the law's slope, and that projection
        #: (an index-3 method's velocity drift, 1e-5 rad/s after a cut step) would
        #: take a rate that has just passed its kink back across it: the same
        #: kink landed on again 5e-7 s later
        self.restarts = False
        self.g = None
        self.h = h
        self._passes = {}       # spring name -> times of its recent passes
        self.chatter = None     # (spring, passes, span [s]) of a spring that chatters

    @staticmethod
    def found_by_steps(system) -> bool:
        """Whether a model has events that only the ends of a step reveal
        (contacts and limits, springs with a free length), as against the
        switches of functions of time, known before the run: a loop must
        stop at each step that crosses one (:meth:`crosses`)."""
        return (system.contact_state is not None or system.flipping_springs is not None
                or system.state_switches is not None)

    def _u(self, k, t, q, v) -> float:
        """The argument of switch k at time t [s] and (q, v) (n,)."""
        return self.switches[k].value(t, self.system._ext(q), self.system._ext(v),
                                      self.system.cmap)

    def _branches(self, t, q, v) -> np.ndarray:
        """The branch of each switch at (t, q, v), -1 where its argument is
        not a number, shape (k,): as the kernels' ``programs.switch_branches``."""
        u = [self._u(k, t, q, v) for k in range(len(self.switches))]
        return np.array([s.interval(x) if x == x else -1 for s, x in zip(self.switches, u)])

    def _accelerations(self, t, step, last, state):
        """(a at the step's start, a at its end): the start's as the time loop
        gives it (the motion's q'', ``loop.TimeLoop.land``), the end's from the
        index-1 system (a stepper's trial end carries none, and a method's own
        a need not be the motion's: HHT-ADD's); None where that system is
        singular."""
        try:
            end = self.system.index1_state(t + step, state.q, state.v)[0]
        except np.linalg.LinAlgError:
            return None
        return (last.a, end) if last.a is not None else None

    def _switched(self, t0, q0, v0, t1, q1, v1) -> dict:
        """{("switch", k): the kink passed first} of the switches whose branch
        differs between (t0, q0, v0) and (t1, q1, v1)."""
        if self.switches is None:
            return {}
        b0, b1 = self._branches(t0, q0, v0), self._branches(t1, q1, v1)
        out = {}
        for k in np.flatnonzero((b0 >= 0) & (b1 >= 0) & (b0 != b1)):
            kinks = self.switches[k].kinks
            out[("switch", int(k))] = float(kinks[b0[k]] if b1[k] > b0[k] else kinks[b0[k] - 1])
        return out

    def _spring_d(self, q):
        """d = p2 - p1 of the flipping springs, shape (k, 2)."""
        return self.system.spring_separations(q)[[i for i, _ in self.springs]]

    def hold(self, q) -> None:
        """Hold each flipping spring's direction at configuration q (n,), the
        start of the step being landed on an event: the steps tried meanwhile
        continue the old branch past a pass (``kernels.loads.spring_damper._free_length``)."""
        if self.springs is None:
            return
        d = self._spring_d(q)
        norm = np.hypot(d[:, 0], d[:, 1])
        held = np.where(norm[:, None] > 0.0, d / np.where(norm > 0.0, norm, 1.0)[:, None], 0.0)
        self.system.spring_held[[i for i, _ in self.springs]] = held

    def spring_passes(self, qa, qb) -> bool:
        """Whether a flipping spring's points pass each other between
        configurations qa and qb (n,): d_a . d_b < 0."""
        if self.springs is None:
            return False
        da, db = self._spring_d(qa), self._spring_d(qb)
        return bool(np.any(np.einsum("ka,ka->k", da, db) < 0.0))

    def release(self) -> None:
        """No direction held: the physical law (after the landing's commit)."""
        if self.springs is not None:
            self.system.spring_held[:] = 0.0

    def step_limit(self) -> float:
        """The largest error-controlled step while gaps are closed [s]: their
        estimated impact duration over ``STEPS_PER_CONTACT`` (inf when all
        are open). The error estimates of the methods see a contact's onset
        only as a change of acceleration over the step; resolving the
        contact's own time scale is what keeps its energy (measured on the
        pendulum against a stop, docs/contact.md)."""
        return min(self.caps.tolist(), default=np.inf)    # (np.min: 3 us on a few gaps)

    def start(self, t, state):
        """The run starts: every gap open, those closed at the start armed with
        their approach speed (or the floor speed at rest)."""
        g = self.group
        if g is None:
            self.g = np.zeros(0)
            return
        g.reset()
        qx, vx = self.system._ext(state.q), self.system._ext(state.v)
        self.g = g.gaps(qx)
        rates = g.gap_rates(qx, vx)
        for i in np.flatnonzero(self.g <= 0.0):
            g.arm(i, -rates[i], t)
            self.caps[i] = g.duration(i, qx, g.impact_speed[i], self._mass) / STEPS_PER_CONTACT
            self.sol.events.append((float(t), g.names[i], "closed", float(g.impact_speed[i])))
        self.sol.contact_log = g.log

    def crosses(self, t0, last, t1, new) -> bool:
        """Whether the step from ``last`` at t0 to ``new`` at t1 [s] (states
        with q, v (n,)) crosses an event: a gap changes sign, a spring's
        points pass each other (d turns against its direction at the step's
        start), or the argument of a table of the state passes a kink.
        Changes nothing: the steppers' test (the compiled loop's is
        ``integrators.compiled.loop._crossed``)."""
        q0, q1 = last.q, new.q
        g = self.group
        if g is not None and np.any((g.gaps(self.system._ext(q0)) > 0.0)
                                    != (g.gaps(self.system._ext(q1)) > 0.0)):
            return True
        if self.springs is not None:
            d0, d1 = self._spring_d(q0), self._spring_d(q1)
            if np.any(np.einsum("ka,ka->k", d0, d1) < 0.0):
                return True
        return bool(self._switched(t0, q0, last.v, t1, q1, new.v))

    def resume_at(self, q):
        """The gaps at configuration q (n,), where the next step starts: for
        a time loop that took steps without :meth:`check` and :meth:`commit`
        (a stepper returns only at a step that changes the sign of a gap:
        ``loop.TimeLoop.land``)."""
        if self.group is not None:
            self.g = self.group.gaps(self.system._ext(q))

    def _tolerance(self, i) -> float:
        """The landing tolerance of event i [s]: a kink's is ``KINK_TOL`` h."""
        return self.kink_tol if _is_kink(i) else self.tol

    def _recedes(self, i, t, root) -> bool:
        """Whether event i, a kink found at ``root`` [s] into the step from t,
        lies before ``RECEDES`` of where the retake aimed (a kink found on
        the step before it, from the same t): the crossing moved towards the
        step's start with the step, the step's own, not the motion's (u
        grazing its kink: a motor settling at the free speed where its table
        holds, at 0.66 of each retake, eight retakes for nothing); the step
        is then taken as it is."""
        kink = _is_kink(i)
        aimed, self._kink_root = self._kink_root, (t, t + root) if kink else None
        return kink and aimed is not None and aimed[0] == t and root < RECEDES * (aimed[1] - t)

    def _kink_roots(self, t, step, last, state, switched, roots):
        """Where along the step each kink in ``switched`` ({key: kink}) is
        passed, into ``roots`` (the fraction theta of the step; 0 at its
        start); returns ``kink_at(theta, k, x)``, u - x of switch k on the
        step's interpolants."""
        from scipy.optimize import brentq
        a_ends = self._accelerations(t, step, last, state) if switched else None

        def kink_at(theta, k, x):
            """u - x of switch k on the step's Hermite interpolants: of q, and
            of v from the accelerations at both ends where the index-1 system
            gives them (a rate's kink then lands in one or two retakes, not
            three to five), else v the rate of q's."""
            q, v = _hermite(theta, step, last.q, last.v, state.q, state.v)
            if a_ends is not None:
                v = _hermite(theta, step, last.v, a_ends[0], state.v, a_ends[1])[0]
            return self._u(k, t + theta * step, q, v) - x

        for key, x in switched.items():
            fa, fb = kink_at(0.0, key[1], x), kink_at(1.0, key[1], x)
            # at the start: u there within what its rate covers in the kink's
            # tolerance, or round-off, of the kink (the step before landed on it)
            rate0 = (kink_at(1e-7, key[1], x) - fa) / (1e-7 * step)
            near = abs(rate0) * self.kink_tol + 64.0 * np.finfo(float).eps * (1.0 + abs(x))
            if abs(fa) <= near or (fa > 0.0) == (fb > 0.0):
                roots[key] = 0.0                # at the start (round-off in the interpolant)
            else:
                roots[key] = brentq(kink_at, 0.0, 1.0, args=key[1:] + (x,),
                                    xtol=1e-3 * self.kink_tol / step)
        return kink_at

    def _end_value(self, i, step, state, gb, passing, kink_at, switched) -> tuple:
        """(event i's function at the step's end, its rate): a gap and its
        rate; a spring's s = d . d_start and ds/dt by difference; a kink's
        u - kink and its rate on the interpolant."""
        if _is_kink(i):
            value = kink_at(1.0, i[1], switched[i])
            return value, (value - kink_at(1.0 - 1e-7, i[1], switched[i])) / (1e-7 * step)
        if isinstance(i, tuple):
            ref, k = passing[i], i[1]
            value = self._spring_d(state.q)[k] @ ref
            eps = 1e-7 * step
            return value, (value - self._spring_d(state.q - eps * state.v)[k] @ ref) / eps
        n, ext, vext = self.system.n, np.zeros(self.system.nx), np.zeros(self.system.nx)
        ext[:n], vext[:n] = state.q, state.v
        return gb[i], self.group.gap_rate_one(i, ext, vext)

    def check(self, t, step, last, state):
        """After a step from ``last`` (at t) to ``state`` (at t + step) that
        Newton converged on: does it end on its events? Changes nothing until
        :meth:`commit` (the error control may still reject the step).

        Returns
        -------
        float or None
            The size to retake the step with, to end it on an event; None:
            the step may be kept.
        """
        g = self.group
        gb = g.gaps(self.system._ext(state.q)) if g is not None else np.zeros(0)
        crossed = list(np.flatnonzero((self.g > 0.0) != (gb > 0.0)))
        self._pending = (t, step, last, state, gb, {})
        passing = {}
        if self.springs is not None:
            # a spring's points pass each other: d turns against its direction
            # at the step's start, s = d . d_start changes sign
            d0, d1 = self._spring_d(last.q), self._spring_d(state.q)
            for k in np.flatnonzero(np.einsum("ka,ka->k", d0, d1) < 0.0):
                passing[("spring", int(k))] = d0[k]
        switched = self._switched(t, last.q, last.v, t + step, state.q, state.v)
        if not crossed and not passing and not switched:
            return None
        from scipy.optimize import brentq
        n = self.system.n
        ext = np.zeros(self.system.nx)

        def gap_at(theta, i):
            """Gap i on the step's Hermite interpolant at theta in [0, 1]."""
            ext[:n] = _hermite(theta, step, last.q, last.v, state.q, state.v)[0]
            return g.gaps_one(i, ext)

        def free_gap_at(theta, i):
            """Gap i on the Taylor expansion from the step's start."""
            tau = theta * step
            ext[:n] = last.q + tau * last.v + 0.5 * tau * tau * last.a
            return g.gaps_one(i, ext)

        roots = self._pending[5]
        for key, ref in passing.items():
            k = key[1]

            def passing_at(theta, k=k, ref=ref):
                """d . d_start of spring k on the step's Hermite interpolant."""
                q = _hermite(theta, step, last.q, last.v, state.q, state.v)[0]
                return self._spring_d(q)[k] @ ref

            roots[key] = brentq(passing_at, 0.0, 1.0, xtol=1e-3 * self.tol / step)

        kink_at = self._kink_roots(t, step, last, state, switched, roots)
        for i in crossed:
            if (gap_at(0.0, i) > 0.0) == (gb[i] > 0.0):
                roots[i] = 0.0                  # at the start (round-off in the interpolant)
            elif self.g[i] > 0.0 and free_gap_at(1.0, i) <= 0.0:
                # a closing: the motion up to it is free of the contact, and
                # its Taylor expansion from the step's start is not bent by
                # the contact force that the step's end state already feels
                roots[i] = brentq(free_gap_at, 0.0, 1.0, args=(i,),
                                  xtol=1e-3 * self.tol / step)
            else:
                roots[i] = brentq(gap_at, 0.0, 1.0, args=(i,), xtol=1e-3 * self.tol / step)
        tol = self._tolerance
        interior = {i: th for i, th in roots.items() if th * step > tol(i)}
        if not interior or self.cuts >= MAX_CUTS:
            return None
        i = min(interior, key=interior.get)
        if self._recedes(i, t, interior[i] * step):
            return None
        # where the step ends: within the tolerance past the root, by the
        # event function's own value and rate there (the retaken step's end
        # is the method's, not the interpolant's)
        value, rate = self._end_value(i, step, state, gb, passing, kink_at, switched)
        past = value / rate if rate != 0.0 else np.inf       # time since the root [s]
        if 0.0 <= past <= tol(i):
            return None
        self.cuts += 1
        if self.cuts > 1 and 0.0 < past < step:
            # a retake that did not land: Newton on the end's gap, g + rate dt = 0
            return step - past + 0.5 * tol(i)
        return interior[i] * step + 0.5 * tol(i)

    def commit(self):
        """The step last checked is kept: record its events and change the
        contacts' states (:attr:`happened` says whether it had any)."""
        t, step, last, state, gb, roots = self._pending
        g = self.group
        n = self.system.n
        self.happened = bool(roots)
        self._kink_root = None
        self.restarts = any(not _is_kink(i) for i in roots)
        self.g = gb
        #: the step limit of the gaps that changed, before an opening clears it
        gaps = [i for i in roots if not isinstance(i, tuple)]
        self.changed_limit = float(np.min(self.caps[gaps], initial=np.inf)) if gaps else np.inf
        if not roots:
            return
        self.cuts = 0
        qx, vx = np.zeros(self.system.nx), np.zeros(self.system.nx)
        for i, th in sorted(roots.items(), key=lambda x: x[1]):
            t_event = t + th * step
            if _is_kink(i):   # a table's argument passed a kink
                self.sol.events.append((t_event, self.switches[i[1]].text, "switched", 0.0))
                continue
            if isinstance(i, tuple):        # a spring's points passed each other
                name = self.springs[i[1]][1]
                self.sol.events.append((t_event, name, "passed", 0.0))
                times = self._passes.setdefault(name, [])
                times.append(t_event)
                del times[:-CHATTER_PASSES]
                if len(times) == CHATTER_PASSES and times[-1] - times[0] < self.h:
                    self.chatter = (name, CHATTER_PASSES, times[-1] - times[0])
                continue
            qx[:n], vx[:n] = _hermite(th, step, last.q, last.v, state.q, state.v)
            rate = g.gap_rate_one(i, qx, vx)
            if gb[i] <= 0.0:
                g.arm(i, -rate, t_event)
                self.caps[i] = g.duration(i, qx, g.impact_speed[i], self._mass) \
                    / STEPS_PER_CONTACT
                self.changed_limit = min(self.changed_limit, self.caps[i])
                self.sol.events.append((t_event, g.names[i], "closed",
                                        float(g.impact_speed[i])))
            else:
                g.release(i, t_event)
                self.caps[i] = np.inf
                self.sol.events.append((t_event, g.names[i], "opened", float(rate)))


def _is_kink(key) -> bool:
    """Whether an event key of :meth:`EventLocator.check` is a kink of a table
    of the state (``("switch", k)``), as against a spring's ``("spring", k)``
    or a gap's index."""
    return isinstance(key, tuple) and key[0] == "switch"


def _unparse(expr) -> str:
    """An expression as text, for the event's name."""
    from ..dsl.unparse import expr_text
    return expr_text(expr)


def _switches(expr):
    """The switching functions of a piecewise expression: a - b for every
    min(a, b), max(a, b) and comparison a < b (``if`` tests are comparisons
    or such expressions), the argument of abs and sign, and of a table whose
    slope jumps a function whose sign changes at each jump
    (``model.table.Table.switches``)."""
    from ..dsl.expressions import COMPARISONS, PAIR_FUNCTIONS, Binary, Call, Cond, TableCall, Unary
    out = []
    if isinstance(expr, Binary):
        if expr.op in PAIR_FUNCTIONS or expr.op in COMPARISONS:
            out.append(Binary("-", expr.left, expr.right))
        out += _switches(expr.left) + _switches(expr.right)
    elif isinstance(expr, Call):
        if expr.func in ("abs", "sign"):
            out.append(expr.arg)
        out += _switches(expr.arg)
    elif isinstance(expr, TableCall):
        kinks = expr.table.switches()      # a table whose sign changes at each kink
        if kinks is not None and expr.order == 0:
            out.append(TableCall(kinks, expr.arg))
        out += _switches(expr.arg)
    elif isinstance(expr, Unary):
        out += _switches(expr.operand)
    elif isinstance(expr, Cond):
        out += _switches(expr.test) + _switches(expr.then) + _switches(expr.other)
    return out


def time_switches(system):
    """Kinks and jumps of the model's functions of time (drivers, torques,
    point forces): [(text, s, expr)], the switching function s(t) (and its
    expression) changing sign where the function switches branch (``min``,
    ``max``, ``clip``, ``if``, comparisons, ``abs``, ``sign``). Known in
    advance, so a step is shortened to end on them before it is taken
    (:func:`switch_times`)."""
    from ..dsl.expressions import compile_function
    functions = list(system.driver_functions) + list(system.load_functions)
    out, seen = [], set()
    for f in functions:
        expr = getattr(f, "expr", None)
        if expr is None or getattr(f, "variables", None) or getattr(f, "constant", False):
            continue            # state functions switch with the motion: not known in advance
        text = f.text or _unparse(expr)
        for s in _switches(expr):
            key = (text, repr(s))
            if key not in seen:
                seen.add(key)
                out.append((text, compile_function(s), s))
    return out


#: At most this many steps of h in the grid :func:`switch_times` searches (16 MB of
#: nodes); a finer grid (an error-controlled run started with a tiny step) is
#: coarsened to it, which still brackets every sign change slower than the spacing.
SWITCH_GRID_LIMIT = 2_000_000


def switch_times(switches, t_start, t_end, h):
    """Every switch of :func:`time_switches` in (t_start, t_end): a sign
    change of a switching function between two nodes of the grid of steps of
    h (a zero on a node, between nodes of opposite signs, is a switch
    there), then Brent's method. For the time loop, which runs from switch
    to switch and whose steps need not fall on that grid (events, error
    control): a switch on one of its nodes is landed on too.

    Parameters
    ----------
    switches : list
        :func:`time_switches` of the model.
    t_start, t_end, h : float [s]
        h: the grid's spacing, at least (t_end - t_start) / ``SWITCH_GRID_LIMIT``.

    Returns
    -------
    list of (float, str)
        (time, text) in time order; a switch within 1e-8 h of the one before
        (or of t_start, or of t_end) is left out.
    """
    from scipy.optimize import brentq

    from ..dsl.expressions import evaluate_rows
    k = max(int(math.ceil((t_end - t_start) / h - 1e-9)), 1)
    if k > SWITCH_GRID_LIMIT:      # a tiny first step of an error-controlled run
        h = (t_end - t_start) / SWITCH_GRID_LIMIT
        k = SWITCH_GRID_LIMIT
    grid = np.minimum(t_start + h * np.arange(k + 1), t_end)
    grid[-1] = t_end
    hits = []
    for text, s, expr in switches:
        values = evaluate_rows(expr, {}, grid)
        finite = np.isfinite(values)
        nodes = np.flatnonzero(finite & (values != 0.0))       # nodes with a sign
        sign = values[nodes] > 0.0
        for k in np.flatnonzero(sign[1:] != sign[:-1]):
            i, j = nodes[k], nodes[k + 1]                      # zeros only between them
            fa, fb = s(grid[i]), s(grid[j])        # (the closure's own values, for Brent)
            if not finite[i:j + 1].all() or (fa > 0.0) == (fb > 0.0) or 0.0 in (fa, fb):
                continue
            hits.append((brentq(s, grid[i], grid[j], xtol=1e-14 * max(1.0, abs(grid[j])),
                                rtol=1e-15), text))
    out, last = [], t_start
    for time, text in sorted(hits):
        if time - last > 1e-8 * h and time < t_end - 1e-8 * h:
            out.append((time, text))
            last = time
    return out


def restart_after_switch(system, method, t, q, v, project=False):
    """The start state of ``method`` at t, just past a switch of a function of
    time, on the new branch: a and lambda from the index-1 system at (t, q, v)
    (a one-step method's carried a_n and force term would hold the old
    branch's for a whole step; a two-step method restarts from it with
    BDF1), with the least-norm multipliers where Phi_q loses rank
    (``AssembledSystem.index1_matrix``). None where the index-1 system has no
    finite solution (the state is kept).

    Parameters
    ----------
    system : AssembledSystem
    method : Method
    t : float [s]
    q, v : ndarray, shape (n,)
    project : bool
        First take v onto the velocity constraint Phi_q v + Phi_t = 0 by the
        mass-weighted least change, [[M, Phi_q^T], [Phi_q, 0]] [dv; mu] =
        [0; -(Phi_q v + Phi_t)] (Haug, sec. 6.3): an index-3 method's
        velocities drift from it by its tolerance, and a restart on tiny
        steps turns that drift into multipliers of order drift / (beta h)
        that alternate from step to step.

    Returns
    -------
    StepState or None
    """
    try:
        if project and system.m:
            import scipy.linalg
            n = system.n
            # one matrix: v, then a, lambda (least-norm multipliers where K is singular)
            K, lu, least_norm = system.index1_matrix(t, q)
            solve = least_norm or (lambda r: scipy.linalg.lu_solve(lu, r))
            drift = system.Phi_q(q, t) @ v + system.Phi_t(q, t)
            v = np.asarray(v, dtype=float) + solve(np.concatenate([np.zeros(n), -drift]))[:n]
            sol = system.index1_solve(K, t, q, v, solve=solve)
            a, lam = sol[:n], sol[n:]
        else:
            a, lam = system.index1_state(t, q, v)
    except np.linalg.LinAlgError:           # a singular configuration: keep the state
        return None
    from ..assembly.initial import InitialState
    initial = InitialState(t, np.array(q, dtype=float), np.array(v, dtype=float), a, lam,
                           0.0, 0.0, 0.0)
    return method.start(system, initial)[-1]
