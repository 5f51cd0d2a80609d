"""The service writes no format of its own: a job's downloads are what raydamp writes for the same run
(CSV byte for byte, NPZ and NetCDF by content), across the slices a download is written in and for a
decimated selection; its plots are raydamp's sol.plot.png; its uploads are read by raydamp's Matrix Market
reader (a symmetric dense file, which the service's own header check refused, is taken)."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest
import scipy.io
import xarray as xr

import raydamp
from raydamp.jobs import job_arguments
from raydamp.results.io.writer import SLICE_BYTES

SITES, STEPS = 100, 3000  # 3001 points of (3 + 2 x 100) floats and the momentum: 4.9 MB, two slices
CHAIN = {"system": {"kind": "chain", "n": SITES, "bond": "fput"}, "method": "3s", "h": 0.05, "n_steps": STEPS,
         "initial_state": {"mode": 1, "amplitude": 0.5}}
KEPLER = {"system": {"coordinates": ["x", "y"], "potential": "-1/sqrt(x^2+y^2)", "eps": 0.01,
                     "damping": {"dampers": [{"on": "sqrt(x^2+y^2)", "c": 1}]}, "momenta": {"L": "x*p_y - y*p_x"}},
          "method": "2s", "h": 0.01, "n_steps": 2000, "save_every": 10,
          "initial_state": {"q": [1.0, 0.0], "p": [0.0, 1.2]}}
ARRAYS = ("t", "q", "p", "energy", "momentum", "work")


@pytest.fixture(scope="module")
def runs(server):
    """(job id, the same run by raydamp here) of each spec."""
    out = {}
    for name, spec in (("chain", CHAIN), ("kepler", KEPLER)):
        job_id = server.submit(spec)
        assert server.wait_finished(job_id)["status"] == "completed"
        model, q0, p0, options = job_arguments(server.job(job_id)["spec"])
        out[name] = job_id, raydamp.integrate(model, q0, p0, **options)
    return out


def _download(server, job_id: str, fmt: str, **params) -> bytes:
    response = server.client.get(f"/v1/jobs/{job_id}/trajectory", params={"format": fmt, **params}, timeout=120)
    assert response.status_code == 200, response.text
    return response.content


def _part(sol: raydamp.Solution, rows: slice) -> raydamp.Solution:
    fields = {f: getattr(sol, f) for f in sol.__dataclass_fields__}
    return raydamp.Solution(**{**fields, **{a: getattr(sol, a)[rows] for a in ARRAYS if getattr(sol, a) is not None}})


def _same_attributes(ours: dict, theirs: dict) -> None:
    """Equal but for what only the service knows (the job's id, its spec as stored) and the wall time."""
    mine, served = json.loads(ours.pop("provenance")), json.loads(theirs.pop("provenance"))
    ours.pop("wall_time"), theirs.pop("wall_time")
    assert ours == theirs
    for key in ("coordinates", "momentum_names", "method", "n_steps"):
        assert mine[key] == served[key], key


@pytest.mark.parametrize("rows", [slice(None), slice(5, 2900, 7)], ids=["whole", "decimated"])
def test_downloads_are_what_raydamp_writes(server, runs, tmp_path, rows):
    job_id, sol = runs["chain"]
    sol = _part(sol, rows)
    row_bytes = 8 * (3 + 2 * SITES + sol.momentum.shape[1])
    if rows == slice(None):
        assert sol.t.size * row_bytes > SLICE_BYTES  # the download is written in more than one slice
    params = {} if rows == slice(None) else {"start": rows.start, "stop": rows.stop, "every": rows.step}
    for fmt, suffix in (("csv", ".csv"), ("npz", ".npz"), ("netcdf", ".nc")):
        sol.save(tmp_path / f"ours{suffix}")
        (tmp_path / f"served{suffix}").write_bytes(_download(server, job_id, fmt, **params))
    assert (tmp_path / "served.csv").read_bytes() == (tmp_path / "ours.csv").read_bytes()

    with zipfile.ZipFile(tmp_path / "ours.npz") as ours, zipfile.ZipFile(tmp_path / "served.npz") as served:
        assert served.namelist() == ours.namelist()
        for member in (f"{name}.npy" for name in ARRAYS):
            assert served.read(member) == ours.read(member), member
        attrs = [json.loads(str(np.load(io.BytesIO(z.read("attrs.npy"))))) for z in (ours, served)]
    _same_attributes(*attrs)

    with xr.open_dataset(tmp_path / "ours.nc", engine="h5netcdf") as ours, \
            xr.open_dataset(tmp_path / "served.nc", engine="h5netcdf") as served:
        ours, served = ours.load(), served.load()
    _same_attributes(ours.attrs, served.attrs)
    assert served.identical(ours)  # every variable, coordinate and their attributes; the rest just compared


@pytest.mark.parametrize(("kind", "params"), [("energy", {}), ("phase", {"coordinate": "y"}),
                                              ("projection", {"x": "x", "y": "y", "width": 640, "height": 480})])
def test_plots_are_raydamps(server, runs, kind, params):
    job_id, sol = runs["kepler"]
    response = server.client.get(f"/v1/jobs/{job_id}/plots/{kind}.png", params=params)
    assert response.status_code == 200, response.text
    options = {key: value for key, value in params.items() if key not in ("width", "height")}
    assert response.content == sol.plot.png(kind, width=params.get("width", 800), height=params.get("height", 500),
                                             **options)


def test_a_symmetric_dense_matrix_market_upload_is_taken(server):
    """Stored as its lower triangle (5050 entries of 2 bytes in 10,153 bytes): the service's own check counted
    100 x 100 and refused it, 'more than a file of 10153 bytes can hold'."""
    out = io.BytesIO()
    scipy.io.mmwrite(out, np.eye(100), symmetry="symmetric")
    response = server.client.post("/v1/files", files={"file": ("M.mtx", out.getvalue(), "application/octet-stream")})
    assert response.status_code == 201, response.text
    assert response.json()["shape"] == [100, 100] and response.json()["nnz"] == 100
    lying = b"%%MatrixMarket matrix coordinate real general\n5 5 1000000000\n1 1 1.0\n"
    response = server.client.post("/v1/files", files={"file": ("K.mtx", lying, "application/octet-stream")})
    assert response.status_code == 422
    assert response.json()["detail"][0]["msg"] == ("K.mtx: the header announces 1000000000 entries, more than a file "
                                                   "of 69 bytes can hold")
