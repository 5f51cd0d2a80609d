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
