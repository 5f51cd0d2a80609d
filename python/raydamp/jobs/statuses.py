"""Why a run stopped: the one list of run statuses.

The core defines the list (cpp/include/raydamp/status.hpp) in the order files store a status as a
number; this module names and documents each one. A run that did not complete keeps every row it
computed up to where it stopped, and its message says why.
"""

from __future__ import annotations

from .. import _core

__all__ = ["STATUSES", "MEANINGS", "FAILED", "FINISHED"]

STATUSES: tuple[str, ...] = tuple(_core.STATUSES)

MEANINGS: dict[str, str] = {
    "completed": "every step was taken.",
    "non_finite": "the state stopped being finite (an overflow, or a user function that failed) at "
                  "failed_step; the rows up to the last finite state are kept.",
    "cancelled": "a CancelToken (or Ctrl-C) stopped the run between blocks of steps; the rows so far are kept.",
    "out_of_memory": "the saved rows outgrew memory; those that fit are kept (raise save_every).",
    "diverged": "the run blew up while its state was still finite: its energy gained more than `divergence` "
                "times what its start, its load and its temperature can give it (see raydamp.integrate); it "
                "stopped at failed_step, keeping its rows.",
    "event": "a terminal event (raydamp.Event(..., terminal=True)) ended the run at its crossing time, the last "
             "step shortened to land there; the message names the event.",
    "not_converged": "an implicit step's iteration did not converge (method=\"newmark\": Newton's iteration on a "
                     "Structure's springs, step halving included) at failed_step; the message names the step, and "
                     "the rows before it are kept.",
    "collapsed": "a spring's drift passed its collapse limit (integrate's collapse, raydamp.ida's collapse_drift): "
                 "the run stopped at that step's end, keeping its rows and its envelope; the message names the "
                 "spring.",
    "constraint_failed": "a constrained System's position constraint could not be solved at failed_step (its "
                         "Newton iteration did not reach constraint_tol, or the constraints' gradients became "
                         "dependent); the message names the constraint, and the rows before that step are kept.",
}

# The statuses of a run that failed (a blow-up or a lack of memory), as against one that completed
# or was stopped on purpose.
FAILED = frozenset({"non_finite", "out_of_memory", "diverged", "not_converged", "constraint_failed"})
# The statuses of a run that did what it was asked: every step, or up to its terminal event or collapse.
FINISHED = frozenset({"completed", "event", "collapsed"})

if set(MEANINGS) != set(STATUSES):  # the core's list and these names must be the same list
    raise ImportError(f"raydamp.jobs.statuses: core statuses {STATUSES} differ from the documented "
                      f"{tuple(MEANINGS)}")
