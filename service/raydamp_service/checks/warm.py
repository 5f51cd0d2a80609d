"""The check processes' warm-up, run once by their forkserver (pool.py's preload): each check process forks with
what a check loads on first use (SciPy, LLVM, matplotlib's fonts) loaded before its memory budget: none is charged.
Every failure is logged and swallowed: the forkserver must start, and a real check reports its own errors."""

from __future__ import annotations

import gc
import logging

log = logging.getLogger("raydamp_service.checks")

SYSTEMS = (
    {"coordinates": 2, "potential": "q0^2 + q0*q1^3", "damping": {"dampers": [{"on": "q0 - q1"}]}, "eps": 0.1},
    {"kind": "chain", "n": 4, "bond": "expression", "parameters": {"potential": "r^2/2 + r^4/4"}},
    {"kind": "linear_structure", "M": {"diagonal": [1.0, 1.0]}, "alpha": 0.1, "beta": 0.01,
     "K": {"coo": {"shape": [2, 2], "rows": [0, 0, 1, 1], "cols": [0, 1, 0, 1], "values": [2.0, -1.0, -1.0, 2.0]}}},
)


def touch(settings) -> int:
    """A check of each of SYSTEMS; the number that failed (each logged). Run again in a freshly forked check process
    (compiled: about 10 ms each), it copies the pages a check writes to (reference counts) into that process before
    a user's first check, which is then not charged."""
    from raydamp.jobs import JobSpec

    from .limits import check_spec

    failed = 0
    for system in SYSTEMS:
        spec = {"system": system, "method": "3s", "h": 0.01, "n_steps": 2, "initial_state": {"rest": True}}
        try:
            check_spec(JobSpec.model_validate(spec), settings)
        except Exception:  # noqa: BLE001 - a warm-up only
            log.warning("check warm-up: %s", spec, exc_info=True)
            failed += 1
    return failed


def warm_up() -> int:
    """A plot and a check of each of SYSTEMS (their compiles); the number that failed (each logged)."""
    failed = 0
    try:
        import raydamp
        from raydamp.models import DampedPendulum

        raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, n_steps=2).plot.png("energy", width=200, height=150)
    except Exception:  # noqa: BLE001 - a warm-up only
        log.warning("check warm-up: a plot", exc_info=True)
        failed += 1
    try:
        from ..config import Settings

        settings = Settings()  # the service's environment; a warm-up's tiny runs pass any budget
    except Exception:  # noqa: BLE001 - a warm-up only
        log.warning("check warm-up: the settings", exc_info=True)
        return failed + len(SYSTEMS)
    failed += touch(settings)
    gc.freeze()  # the collector no longer walks (so writes to) what every fork shares: fewer pages copied
    return failed


FAILED = warm_up()  # read by a check process (pool._warm_up_failures)
