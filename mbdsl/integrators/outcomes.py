"""How the time loop asks a stepper for steps, and what a stepper's call returns.

One driver (``engine.TimeLoop``) runs every engine's steps through a stepper
with one contract: the compiled loop (``integrators.compiled.run``, through
``engine.KernelStepper``) and the Python Newton iteration on a method's own
residual or on the kernels' (``stepper.PythonStepper``). A call is asked in a
mode and ends with one status; both are plain integers, so that the
compiled kernels read them as constants (this module imports nothing).

Modes
-----
RUN
    Step on until the end of the stretch, a step limit, full output
    buffers, an event, or a step that fails.
ATTEMPT
    One attempt at a step of the given size; return at an event.
LAND
    One attempt at a step of the given size, taken whatever its gaps do
    (the step the event locator placed on an event).

Statuses
--------
CONVERGED
    The steps asked for were taken.
MAX_ITER, DIVERGING, SINGULAR, NONFINITE
    Newton did not converge on a step (``newton.NewtonStatus.code``);
    its size is in the loop state's next h.
TOLERANCE
    With error control, the local error above the tolerance at h_min.
EVENT
    A converged step changed the sign of a gap or passed a spring's points
    through each other; it is not taken, its end is in ``trial``.
REJECTED
    (ATTEMPT, LAND) its error estimate rejected the step; the next size is
    in the loop state's next h.
"""

CONVERGED, MAX_ITER, DIVERGING, SINGULAR, NONFINITE, TOLERANCE = 0, 1, 2, 3, 4, 5
EVENT, REJECTED = 6, 7
RUN, ATTEMPT, LAND = 0, 1, 2
