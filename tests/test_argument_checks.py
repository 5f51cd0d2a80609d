"""raydamp.integrate refuses what is not a number, and says so briefly (issue 9's Python API audit)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum

Q0, P0 = [0.9 * math.pi], [0.0]


def run(q0=Q0, p0=P0, **options):
    return raydamp.integrate(DampedPendulum(eps=0.01), q0, p0, **{"method": "3s", "h": 0.1, "n_steps": 10,
                                                                 **options})


@pytest.mark.parametrize(("q0", "message"), [
    (None, "q0 must be an array of 1 real numbers, got None"),
    (True, "q0 must be an array of 1 real numbers, got True"),
    ([True], "q0 must be an array of 1 real numbers, got [True]"),
    ("1.0", "q0 must be an array of 1 real numbers, got '1.0'"),
    (["1.0"], "q0 must be an array of 1 real numbers, got ['1.0']"),
    ([None], "q0 must be an array of 1 real numbers, got [None]"),
    ([math.nan], "q0 must be finite, got q0[0] = nan"),
])
def test_q0_must_be_real_numbers(q0, message):
    with pytest.raises(ValueError) as error:
        run(q0=q0)
    assert str(error.value) == message


@pytest.mark.parametrize("name", ["n_steps", "save_every"])
@pytest.mark.parametrize("value", [10.0, True, "10", np.float64(10.0)])
def test_counts_must_be_integers(name, value):
    with pytest.raises(ValueError, match=f"^{name} must be an integer, got "):
        run(**{name: value})


def test_integer_types_of_numpy_are_counts():
    assert run(n_steps=np.int64(10), save_every=np.int32(5)).summary()["steps"] == 10


def test_a_huge_bad_list_gives_a_short_message():
    with pytest.raises(ValueError) as error:
        run(q0=["x"] * 10**6)
    assert len(str(error.value)) < 300 and "1000000 items" in str(error.value)
    with pytest.raises(ValueError) as error:
        run(p0=[0.0] * 10**6 + [math.inf])
    assert len(str(error.value)) < 300  # the shape, not the list
    with pytest.raises(ValueError) as error:
        raydamp.integrate(raydamp.models.ElasticPendulum(), [0.0, 1.0, math.nan], [0.0] * 3, h=0.1, n_steps=1)
    assert str(error.value) == "q0 must be finite, got q0[2] = nan"


def test_float_arrays_and_integer_lists_are_accepted():
    base = run()
    for q0 in (np.array(Q0), np.array(Q0, dtype=np.float32).astype(float), [2], np.array([2])):
        sol = run(q0=q0)
        assert sol.q.shape == base.q.shape
    assert run(q0=[2]).q[0, 0] == 2.0
