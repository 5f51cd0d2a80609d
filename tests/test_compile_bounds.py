"""A System's compiled size is bounded after differentiation, not only its text (issue 27, F1): a
790-byte potential coupling 128 coordinates all to all has some 17,000 distinct operations in its
Hessian product and took LLVM half a minute; it is refused before compiling, naming the field."""

from __future__ import annotations

import pytest

import raydamp
from raydamp.jobs import JobError, job_arguments
from raydamp.systems.system.compile import MAX_OPERATIONS


def _quartic(n: int) -> str:
    return "(" + "+".join(f"q{i}^2" for i in range(n)) + ")^2"


def test_an_all_to_all_quartic_of_128_coordinates_is_refused_naming_the_potential():
    spec = {"system": {"coordinates": 128, "potential": _quartic(128)}, "method": "3s", "h": 0.1, "n_steps": 1,
            "initial_state": {"q": [0.1] * 128, "p": [0.0] * 128}}
    assert len(spec["system"]["potential"]) < 1000
    with pytest.raises(JobError) as caught:
        job_arguments(spec)
    assert caught.value.loc == ("system", "potential")
    assert f"more than {MAX_OPERATIONS} distinct operations" in str(caught.value)


def test_the_bound_leaves_room_for_real_systems():
    coupled = raydamp.System.from_dict({"coordinates": 48, "potential": _quartic(48)})  # about 2,500 operations
    assert coupled.dim == 48
    chain = "+".join(f"(1-cos(q{i}-q{i + 1}))" for i in range(255))  # 256 coordinates, nearest neighbours
    assert raydamp.System.from_dict({"coordinates": 256, "potential": chain}).dim == 256


def test_a_product_of_many_coordinates_counts_each_factor():
    # The Hessian product of q0*q1*...*q69 is 5,040 distinct nodes of SymEngine's tree, within the bound on
    # nodes (it compiled, in 14 s), but some 333,000 factors; of 50 coordinates (120,000) it still compiles.
    n = 70
    spec = {"system": {"coordinates": n, "potential": "*".join(f"q{i}" for i in range(n))}, "method": "3s",
            "h": 0.1, "n_steps": 1, "initial_state": {"q": [1.0] * n, "p": [0.0] * n}}
    with pytest.raises(JobError) as caught:
        job_arguments(spec)
    assert caught.value.loc == ("system", "potential")
    assert f"more than {MAX_OPERATIONS} distinct operations" in str(caught.value)
    assert raydamp.System.from_dict({"coordinates": 50, "potential": "*".join(f"q{i}" for i in range(50))}).dim == 50
