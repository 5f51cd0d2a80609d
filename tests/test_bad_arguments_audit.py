"""Bad arguments to public functions are ValueErrors that start with the argument's name (API audit:
each case below raised another exception, or gave a meaningless answer, before; the comment says which)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse

import raydamp
from raydamp.analysis import (
    cartesian_state,
    convergence,
    distance_from,
    energy_error,
    kinetic_temperature,
    modified_energy,
    modified_relative_equilibrium,
    momentum_drift,
    piecewise_linear_response,
    reduced_coordinates,
    reduced_hessian,
    reference_solution,
    relative_equilibrium,
)
from raydamp.models import DampedPendulum, ElasticPendulum


def refused(name: str, call, *args, **kwargs) -> str:
    """The ValueError's message, checked to start with ``name``."""
    with pytest.raises(ValueError) as info:
        call(*args, **kwargs)
    message = str(info.value)
    assert message.startswith(name), message
    return message


def pendulum_solution(n_steps: int = 3):
    return raydamp.integrate(DampedPendulum(), [1.0], [0.0], h=0.1, n_steps=n_steps)


def test_convergence_checks_hs_and_reference():
    model = DampedPendulum(0.5)
    args = dict(q0=[1.0], p0=[0.0], t_end=1.0)
    # A (q, p) of the wrong length was broadcast: errors and an order that meant nothing.
    refused("reference[0]", convergence, model, "3s", [0.1, 0.05], **args, reference=([1, 2], [3, 4]))
    refused("reference[1]", convergence, model, "3s", [0.1, 0.05], **args, reference=([1.0], [3, 4]))
    refused("reference", convergence, model, "3s", [0.1, 0.05], **args, reference=3)  # TypeError (unpacking)
    refused("reference", convergence, model, "3s", [0.1, 0.05], **args, reference=([1.0],))  # ValueError, unnamed
    # A generator of step sizes was float()'s TypeError: any iterable of numbers is taken.
    listed = convergence(model, "3s", [0.1, 0.05], **args)
    generated = convergence(model, "3s", (h for h in [0.1, 0.05]), **args)
    np.testing.assert_array_equal(generated.errors, listed.errors)
    refused("hs", convergence, model, "3s", 0.1, **args)  # (was named already: kept so by the iterable check)
    refused("hs[1]", convergence, model, "3s", [0.1, "x"], **args)  # NumPy's "could not convert string"
    refused("hs[0]", convergence, model, "3s", [math.nan, 0.1], **args)  # integrate's "h must be finite"
    # (integrate named it before; the reference check now reads model.dim first: kept a ValueError)
    refused("model", convergence, None, "3s", [0.1, 0.05], **args, reference=([1.0], [0.0]))


def test_analysis_functions_refuse_wrong_objects():
    ep = ElasticPendulum()
    eq = relative_equilibrium(ep, 1.0)
    sol = pendulum_solution()
    refused("solution_or_q", distance_from, eq, [1, 2], [1, 2])  # IndexError
    refused("solution", distance_from, eq, sol)  # IndexError: a DampedPendulum's solution has one column
    refused("equilibrium", distance_from, 3, [1, 2, 3], [0, 0, 0])  # AttributeError (reduced)
    refused("q", reduced_coordinates, [1, 2], [1, 2])  # IndexError
    refused("p", reduced_coordinates, [1, 2, 3], [[1, 2, 3], [1, 2, 3]])  # broadcast: two rows from one state
    refused("solution", energy_error, DampedPendulum(), None)  # AttributeError
    refused("reference", energy_error, DampedPendulum(), sol, reference=3)  # AttributeError
    refused("model", energy_error, None, sol)  # AttributeError
    refused("model", reference_solution, None, [0], [0], [0, 1])  # AttributeError
    refused("burn_in", kinetic_temperature, sol, "x")  # UFuncTypeError
    refused("solution", momentum_drift, None)  # AttributeError
    refused("decay_rate", momentum_drift, sol, decay_rate=math.nan)  # NaNs back
    refused("start", modified_relative_equilibrium, ep, "3s", 0.1, 1.0, start=3)  # AttributeError
    refused("mu", modified_relative_equilibrium, ep, "3s", 0.1, "x", start=eq)  # TypeError (mu / rho)
    refused("equilibrium", reduced_hessian, ep, 3)  # AttributeError
    refused("h", modified_energy, DampedPendulum(), [1.0], [0.0], math.nan)  # NaNs back
    refused("q", modified_energy, DampedPendulum(), "x", [0.0], 0.1)  # NumPy's "could not convert string"
    refused("rho", cartesian_state, 0, 0, 0, 0, 1)  # ZeroDivisionError
    refused("rho", cartesian_state, math.nan, 0, 0, 0, 1)  # a state of NaNs
    refused("mu", cartesian_state, 1, 0, 0, 0, math.inf)  # a state with an inf
    # mu^2 overflowed (OverflowError) or underflowed to 0 (ZeroDivisionError); the range is in the message.
    assert "1e-150 <= |mu| <= 1e+20" in refused("mu", relative_equilibrium, ep, 1e300)
    refused("mu", relative_equilibrium, ep, 1e-300)
    # Inside the range a small mu comes out right (brentq's absolute xtol left rho ~ 1e-15 far off: z = -2.31).
    small = relative_equilibrium(ep, 1e-30)
    assert small.z == pytest.approx(-2.0, rel=1e-12)
    # scipy.sparse matrices are taken, as the rest of raydamp takes them (float()'s TypeError), strings named.
    dense = piecewise_linear_response(np.eye(2), 0.1 * np.eye(2), np.eye(2), [1, 1], [0, 1, 2], [0, 1, 0])
    sparse = piecewise_linear_response(scipy.sparse.eye(2), scipy.sparse.csr_matrix(0.1 * np.eye(2)),
                                       scipy.sparse.eye(2), [1, 1], [0, 1, 2], [0, 1, 0])
    np.testing.assert_array_equal(sparse[0], dense[0])
    for position, name in enumerate(["M", "C", "K", "direction", "t", "values"]):
        args = [np.eye(2), 0.1 * np.eye(2), np.eye(2), [1, 1], [0, 1, 2], [0, 1, 0]]
        args[position] = "ab"  # NumPy's "could not convert string to float", naming nothing
        refused(name, piecewise_linear_response, *args)
    # A blow-up of the reference is the solver failing, not a bad argument: it stays a RuntimeError.
    with pytest.raises(RuntimeError, match="reference solver failed"):
        reference_solution(raydamp.System(1, "-q0^4"), [10.0], [0.0], [0, 100])


def test_rayleigh_refuses_non_finite_coefficients():
    refused("omega1", raydamp.rayleigh_coefficients, 1e200, 2e200, 0.05, 0.05)  # OverflowError
    refused("omega1", raydamp.rayleigh_coefficients, 1e-200, 2e-200, 0.05, 0.05)  # ZeroDivisionError
    refused("omega1", raydamp.rayleigh_coefficients, 1e150, 1.1e150, 0.05, 0.05)  # (inf, ...)
    refused("omega1", raydamp.rayleigh_coefficients, 1e-200, 2e-200, 0, 0)  # ZeroDivisionError (0 / 0)
    refused("zeta1", raydamp.rayleigh_coefficients, 1, 2, 1e308, 1e308)  # (inf, inf)
    refused("omega", raydamp.modal_damping_ratio, 1e-320, 1, 0)  # inf
    refused("omega", raydamp.modal_damping_ratio, 1e300, 0, 1e300)  # inf
    assert raydamp.rayleigh_coefficients(1.0, 3.0, 0.02, 0.05) == pytest.approx((0.0075, 0.0325), rel=1e-14)


def test_load_refuses_what_is_not_a_result_file(tmp_path):
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, a=np.ones(3))
    refused("path: not a raydamp result file", raydamp.load, foreign)  # KeyError 'attrs is not a file ...'
    (tmp_path / "garbage.nc").write_bytes(b"not a netcdf file")
    refused("path: not a raydamp result file", raydamp.load, tmp_path / "garbage.nc")  # OSError
    (tmp_path / "garbage.npz").write_bytes(b"not a zip file")
    refused("path: not a raydamp result file", raydamp.load, tmp_path / "garbage.npz")  # NumPy's pickle message
    import xarray as xr

    other = xr.Dataset({"a": ("x", np.ones(3))})
    other.to_netcdf(tmp_path / "other.nc", engine="h5netcdf")
    refused("path: not a raydamp result file", raydamp.load, tmp_path / "other.nc")  # KeyError 'provenance'
    other.to_zarr(tmp_path / "other.zarr", mode="w", zarr_format=2)
    refused("path: not a raydamp result file", raydamp.load, tmp_path / "other.zarr")  # KeyError 'provenance'
    (tmp_path / "empty.zarr").mkdir()
    refused("path: not a raydamp result file", raydamp.load, tmp_path / "empty.zarr")  # GroupNotFoundError
    refused("path", raydamp.load, None)  # TypeError
    ens = raydamp.integrate_ensemble(DampedPendulum(), [[1.0], [0.5]], [[0.0], [0.0]], h=0.1, n_steps=3)
    ds = ens.to_xarray()
    ds["status"].values[0] = 99
    ds.to_netcdf(tmp_path / "status.nc", engine="h5netcdf")
    assert "status" in refused("path: not a raydamp result file", raydamp.load, tmp_path / "status.nc")  # IndexError
    # A missing file stays what open() raises; a good one still loads.
    with pytest.raises(FileNotFoundError):
        raydamp.load(tmp_path / "missing.nc")
    ens.save(tmp_path / "ens.nc")
    assert raydamp.load(tmp_path / "ens.nc").members == 2


def test_loads_and_make_model_check_their_arguments():
    refused("terms[0]", raydamp.Load, [1, 2])  # AttributeError ('int' has no 'direction') when integrated
    refused("terms", raydamp.Load, "ab")  # the same, one character a term
    refused("terms", raydamp.Load, None)  # TypeError (not iterable)
    assert raydamp.Load([]).terms == ()
    refused("path", raydamp.Load.from_file, None, [1.0])  # TypeError (Path(None))
    refused("load.expression.parameters", raydamp.Load.from_dict,
            {"expression": {"expression": "t", "parameters": [1]}})  # TypeError (dict([1]))
    refused("parameters must be a dict", raydamp.Load.expression, "a*t", ["a"])  # "dictionary update sequence..."
    refused("parameters must be a dict", raydamp.models.make_model, "damped_pendulum", "eps")  # the same
    refused("model", raydamp.models.make_model, ["x"])  # TypeError (unhashable)
    assert raydamp.models.make_model("damped_pendulum", {"eps": 0.2}).eps == 0.2


def test_linear_structure_plain_form_names_a_huge_integer():
    def plain(diagonal, rows=(0,)):
        return {"kind": "linear_structure", "M": {"diagonal": diagonal},
                "K": {"coo": {"shape": [2, 2], "rows": list(rows), "cols": [0], "values": [1.0]}}}

    refused("M.diagonal[0]", raydamp.LinearStructure.from_dict, plain([10**400, 1]))  # OverflowError
    refused("M.diagonal[1]", raydamp.LinearStructure.from_dict, plain([1, -10**5000]))  # OverflowError
    refused("K.coo.rows[0]", raydamp.LinearStructure.from_dict, plain([1, 1], rows=[2**70]))  # OverflowError


def test_model_methods_check_their_arguments():
    ep = ElasticPendulum()
    refused("q", ep.vector_field, [0, 1], [0, 0])  # the binding's TypeError
    refused("p", ep.vector_field, [0, 1, 0], None)  # the binding's TypeError
    refused("name", ep.flow, 3, [0, 1, 0], [0, 0, 0], 0.1)  # the binding's TypeError
    chain = raydamp.Chain(4)
    refused("q", chain.mode_energies, None, None)  # IndexError
    refused("q", chain.mode_energies, "abcd", [0, 0, 0, 0])  # NumPy's "could not convert string to float"
    refused("r", chain.mass_product, [1, 2, 3])  # broadcast silently
    structure = raydamp.LinearStructure(np.eye(2), np.eye(2))
    refused("r", structure.mass_product, [1, 2, 3])  # scipy's "dimension mismatch"
    np.testing.assert_array_equal(structure.mass_product([1, 2]), [1.0, 2.0])


def test_sweep_names_item_and_client():
    refused("text", raydamp.parse_grid_item, None)  # AttributeError (no partition)
    job = {"model": "damped_pendulum", "q0": [1.0], "p0": [0.0], "h": 0.1, "n_steps": 5}
    message = refused("client", raydamp.sweep, job, {"eps": [0.1]}, client="tcp://x")  # 'str' has no 'map'
    assert "dask.distributed.Client" in message


def test_strings_and_bools_are_not_read_as_numbers_or_flags():
    # Each ran (API audit): q0 [True, 0.5, 1.0] as [1.0, 0.5, 1.0]; allow_indefinite_stiffness="no" and
    # measure="no" as True (a non-empty string is truthy); a sweep axis of strings as numbers, None as NaN.
    refused("q0", raydamp.integrate, ElasticPendulum(), [True, 0.5, 1.0], [1.0, 0.0, 0.0], h=0.1, n_steps=1)
    refused("allow_indefinite_stiffness", raydamp.LinearStructure, np.eye(2), -np.eye(2),
            allow_indefinite_stiffness="no")
    structure = raydamp.LinearStructure(np.eye(2), np.diag([1.0, 4.0]), alpha=0.1)
    refused("measure", raydamp.advise, structure, t_end=10.0, tolerance=1e-3, measure="no")
    job = {"model": "damped_pendulum", "q0": [1.0], "p0": [0.0], "h": 0.1, "n_steps": 5}
    for axis, shown in ((["0.1"], "'0.1'"), ([0.1, None], "None")):
        message = refused("grid.eps[", raydamp.check_sweep, job, {"eps": axis})
        assert message.endswith(f"expected a real number, got {shown}"), message
    refused("grid.h", raydamp.check_sweep, job, {"h": np.array(["0.1"])})
    assert raydamp.check_sweep(job, {"eps": np.array([0.1, 0.2])}).grid == {"eps": [0.1, 0.2]}


def test_a_zarr_path_that_is_a_file_is_refused_naming_it(tmp_path):
    # FileExistsError from Zarr (API audit); a store that is already a directory is replaced, as documented.
    (tmp_path / "taken.zarr").write_text("not a store")
    ens = raydamp.integrate_ensemble(DampedPendulum(), [[1.0], [2.0]], [0.0], h=0.1, n_steps=3)
    refused("path: ", ens.save, tmp_path / "taken.zarr")
    job = {"model": "damped_pendulum", "q0": [1.0], "p0": [0.0], "h": 0.1, "n_steps": 3}
    refused("store: ", raydamp.sweep, job, {"eps": [0.1]}, store=str(tmp_path / "taken.zarr"))
    ens.save(tmp_path / "ok.zarr")
    ens.save(tmp_path / "ok.zarr")
    np.testing.assert_array_equal(raydamp.load(tmp_path / "ok.zarr").q, ens.q)
