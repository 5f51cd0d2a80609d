"""A LinearStructure is what its docstring says: M symmetric positive definite (both triangles
compared), K positive semi-definite unless an indefinite K is asked for (issue 27, F5)."""

from __future__ import annotations

import numpy as np
import pytest

import raydamp

sparse = pytest.importorskip("scipy.sparse")
N = 300


def bar():
    """A free-free bar of linear elements: K singular (a rigid mode), consistent M, K not diagonally dominant
    once the mass shift is added to it."""
    K = sparse.diags([-np.ones(N - 1), 2 * np.ones(N), -np.ones(N - 1)], [-1, 0, 1]).tolil()
    K[0, 0] = K[-1, -1] = 1.0
    M = sparse.diags([np.ones(N - 1) / 6, 4 * np.ones(N) / 6, np.ones(N - 1) / 6], [-1, 0, 1])
    return M.tocsc(), K.tocsc()


def test_a_mass_with_one_triangle_changed_is_refused():
    M, K = bar()
    M = M.tolil()
    M[0, 1] = 0.5  # the lower triangle keeps 1/6: a Cholesky factorisation would read only one of them
    with pytest.raises(ValueError, match=r"^M: must be symmetric \(max \|M - M\^T\| = 0\.333\)"):
        raydamp.LinearStructure(M.tocsc(), K)


def test_an_indefinite_stiffness_is_refused_unless_asked_for():
    M, K = bar()
    raydamp.LinearStructure(M, K)  # singular but semi-definite: accepted
    indefinite = K - 0.001 * M  # lowest eigenvalue of M^{-1} K: -0.001
    with pytest.raises(ValueError, match=r"^K: must be positive semi-definite"):
        raydamp.LinearStructure(M, indefinite)
    with pytest.raises(ValueError, match=r"^K: must be positive semi-definite"):
        raydamp.LinearStructure(sparse.identity(N, format="csc"), -sparse.identity(N, format="csc"))
    grown = raydamp.LinearStructure(M, indefinite, allow_indefinite_stiffness=True)
    assert grown.to_dict()["allow_indefinite_stiffness"] is True
    again = raydamp.LinearStructure.from_dict(grown.to_dict())
    assert again.allow_indefinite_stiffness and "allow_indefinite_stiffness" not in raydamp.LinearStructure(
        M, K).to_dict()


def test_the_job_schema_refuses_both_by_json_path():
    from raydamp.jobs import JobError, job_arguments

    M, K = bar()
    coo = K.tocoo()
    job = {"system": {"kind": "linear_structure", "M": {"diagonal": [1.0] * N},
                      "K": {"coo": {"shape": [N, N], "rows": coo.row.tolist(), "cols": coo.col.tolist(),
                                    "values": (-coo.data).tolist()}}},
           "method": "3s", "h": 0.1, "n_steps": 10, "initial_state": {"rest": True}}
    with pytest.raises(JobError) as caught:
        job_arguments(job)
    assert caught.value.loc == ("system", "K") and "positive semi-definite" in str(caught.value)
    job["system"]["allow_indefinite_stiffness"] = True
    model = job_arguments(job)[0]
    assert model.allow_indefinite_stiffness
