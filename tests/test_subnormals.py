"""A damped run that outlives its decay ends near zero, not cycling among subnormal doubles.

The damping flow scales p by e^{-eps h} < 1; on the smallest subnormals that product rounds back to
the same value, so without flushing the state cycled among values below 2.2e-308 for the rest of the
run, each step 25x slower (cpp/include/raydamp/math/flush_subnormals.hpp). With subnormals flushed to zero
a kick's h sin q underflows to 0 once q is within a few thousand times 2.2e-308 of rest, so the state stops there.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum

TINY = sys.float_info.min  # the smallest normal double


def _decayed(method: str) -> raydamp.Solution:
    # From 1e-290 the amplitude e^{-eps t / 2} falls below 1e-308 by t = 830; the run goes on to 2,000.
    return raydamp.integrate(DampedPendulum(0.1), [1e-290], [0.0], method=method, h=0.1, n_steps=20_000,
                             save_every=1)


@pytest.mark.parametrize("method", ["3s", "2s", "rks", "baoab"])
def test_a_decayed_state_never_saves_a_subnormal(method):
    sol = _decayed(method)
    assert sol.status == "completed"
    values = np.abs(np.concatenate([sol.q.ravel(), sol.p.ravel()]))
    assert not np.any((values > 0) & (values < TINY)), "a subnormal value was saved"
    assert abs(sol.q[-1, 0]) < 1e-300 and abs(sol.p[-1, 0]) < 1e-300  # rks stops at 1.7e-306


def test_values_above_the_subnormal_range_follow_the_damped_law():
    # Flushing touches only values below 2.2e-308. At 1e-290 sin q = q, and for q'' + eps q' + q = 0 the
    # quadratic form q^2 + p^2 + eps q p decays exactly as e^{-eps t}; 3s follows it to its O(h^2) error
    # down to 1e-300.
    sol = _decayed("3s")
    t, q, p = sol.t, sol.q[:, 0] / 1e-290, sol.p[:, 0] / 1e-290  # scaled first, so no square underflows
    live = np.abs(sol.q[:, 0]) > 1e-300
    assert live.sum() > 1_000
    form = q**2 + p**2 + 0.1 * q * p
    assert np.max(np.abs(form[live] * np.exp(0.1 * t[live]) - 1.0)) < 1e-2


def test_the_interpreter_keeps_gradual_underflow_after_a_run():
    _decayed("3s")
    assert np.float64(TINY) / 4 > 0  # MXCSR restored: NumPy still makes subnormals
    assert TINY / 4 > 0
