"""Loads and ground motion over HTTP (issue 26, point 3): records uploaded to POST /v1/files (PEER .AT2,
CSV, .npy), read and checked at upload by raydamp's own reader, named by a job's load, ground motion or
initial state, run by a real server process and compared with raydamp in this process; bad uploads and
bad references refused with a 422 naming the problem and the JSON path; a file in use kept (409)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sparse

import raydamp

SERVER_ENV = {"RAYDAMP_MAX_STEPS": str(10**10)}
G = 9.81
RECORD_DT, RECORD_POINTS = 0.01, 1000
PERIOD, ZETA = 0.5, 0.05


def ground_acceleration() -> np.ndarray:
    """A deterministic 'earthquake' in g: a few sines under an envelope, 10 s sampled at 0.01 s."""
    t = np.arange(RECORD_POINTS) * RECORD_DT
    envelope = np.minimum(t / 1.0, 1.0) * np.exp(-np.maximum(t - 3.0, 0.0) / 2.0)
    return 0.3 * envelope * (np.sin(2 * np.pi * 1.7 * t) + 0.6 * np.sin(2 * np.pi * 3.1 * t + 0.4)
                             + 0.3 * np.sin(2 * np.pi * 0.8 * t + 1.1))


def at2_text(values: np.ndarray, dt: float = RECORD_DT, npts: int | None = None) -> str:
    """The PEER NGA layout: four header lines (NPTS and DT on the fourth), then five values a line."""
    lines = ["PEER NGA STRONG MOTION DATABASE RECORD", "RAYDAMP TEST, 1 JAN 2000, SYNTHETIC, 0",
             "ACCELERATION TIME SERIES IN UNITS OF G",
             f"NPTS= {npts if npts is not None else values.size:6d}, DT= {dt:.4f} SEC"]
    for start in range(0, values.size, 5):
        lines.append("".join(f"{v:15.7E}" for v in values[start:start + 5]))
    return "\n".join(lines) + "\n"


def npy_bytes(array) -> bytes:
    out = io.BytesIO()
    np.save(out, np.asarray(array))
    return out.getvalue()


def upload(server, name: str, content: bytes | str):
    if isinstance(content, str):
        content = content.encode()
    return server.client.post("/v1/files", files={"file": (name, content, "application/octet-stream")})


def uploaded(server, name: str, content: bytes | str) -> str:
    response = upload(server, name, content)
    assert response.status_code == 201, response.text
    return response.json()["id"]


def oscillator() -> dict:
    """One storey: m = 1, T = 0.5 s, 5 % mass-proportional damping (C = alpha M, alpha = 2 zeta omega)."""
    omega = 2 * np.pi / PERIOD
    return {"kind": "linear_structure", "M": {"diagonal": [1.0]},
            "K": {"coo": {"shape": [1, 1], "rows": [0], "cols": [0], "values": [omega**2]}},
            "alpha": 2 * ZETA * omega}


def job(**changes) -> dict:
    return {"system": oscillator(), "method": "3s", "h": 1e-3, "t_end": 12.0, "save_every": 10,
            "initial_state": {"rest": True}, **changes}


def trajectory(server, job_id: str) -> dict:
    response = server.client.get(f"/v1/jobs/{job_id}/trajectory")
    assert response.status_code == 200, response.text
    return {key: (np.array(value, dtype=float) if value is not None else None)
            for key, value in response.json().items()}


def locs(response) -> list[list]:
    assert response.status_code == 422, response.text
    return [list(d["loc"]) for d in response.json()["detail"]]


@pytest.fixture(scope="module")
def record(module_server, tmp_path_factory) -> tuple[str, Path]:
    """The synthetic record as an .AT2 file here and as an upload there: (its id, its path)."""
    path = tmp_path_factory.mktemp("records") / "SYNTH.AT2"
    path.write_text(at2_text(ground_acceleration()))
    return uploaded(module_server, "SYNTH.AT2", path.read_bytes()), path


def test_an_at2_upload_is_a_record_with_its_samples_and_times(module_server, record):
    file_id, _ = record
    info = module_server.client.get(f"/v1/files/{file_id}").json()
    assert info["kind"] == "record" and info["format"] == "at2" and info["name"] == "SYNTH.AT2"
    assert info["samples"] == RECORD_POINTS and info["shape"] is None and info["nnz"] is None
    assert info["t_start"] == 0.0
    assert info["t_end"] == pytest.approx((RECORD_POINTS - 1) * RECORD_DT, rel=1e-12)
    assert info["dt"] == pytest.approx(RECORD_DT, rel=1e-12)
    listed = {f["id"]: f for f in module_server.client.get("/v1/files").json()["files"]}
    assert listed[file_id]["kind"] == "record"
    # A matrix beside it keeps its own listing.
    mtx = io.BytesIO()
    scipy.io.mmwrite(mtx, sparse.eye(3).tocoo())
    matrix = upload(module_server, "I.mtx", mtx.getvalue()).json()
    assert matrix["kind"] == "matrix" and matrix["format"] == "mtx" and matrix["shape"] == [3, 3]
    assert matrix["samples"] is None


def test_a_ground_motion_job_equals_raydamp_in_this_process(module_server, record):
    """The record as ground motion on a 1-DOF oscillator (T = 0.5 s, 5 %): the service's run equals
    raydamp.integrate on the same .AT2 file here, and the energy budget H - H0 + W - W_f closes to O(h^2)."""
    file_id, path = record
    spec = job(ground_motion={"acceleration": {"file": {"id": file_id, "factor": G}}, "direction": [1.0]})
    done = module_server.wait_finished(module_server.submit(spec))
    assert done["status"] == "completed", done
    got = trajectory(module_server, done["id"])

    structure = raydamp.LinearStructure.from_dict(oscillator())
    motion = raydamp.GroundMotion(raydamp.Load.from_file(path, factor=G), direction=[1.0])
    local = raydamp.integrate(structure, [0.0], [0.0], method="3s", h=1e-3, t_end=12.0, save_every=10,
                              load=motion, work=True)
    scale = np.abs(local.q).max()
    assert scale > 1e-3  # the record moved the storey: about a centimetre
    np.testing.assert_allclose(got["t"], local.t, rtol=1e-15, atol=0)
    np.testing.assert_allclose(got["q"], local.q, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(got["p"], local.p, rtol=0, atol=1e-12 * np.abs(local.p).max())
    for name in ("energy", "work", "load_work"):
        expected = getattr(local, name)
        np.testing.assert_allclose(got[name], expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    print(f"\nmax |q_service - q_local| / max|q| = {np.abs(got['q'] - local.q).max() / scale:.1e}")

    # The energy budget from the service's own columns: small against the energy the load put in.
    balance = got["energy"] - got["energy"][0] + got["work"] - got["load_work"]
    np.testing.assert_allclose(balance, local.energy_balance, rtol=0, atol=1e-12 * np.abs(local.load_work).max())
    assert np.abs(balance).max() < 1e-3 * np.abs(got["load_work"]).max()
    summary = done["summary"]
    assert summary["load_work_final"] == pytest.approx(float(local.load_work[-1]), rel=1e-12)
    assert summary["energy_balance_max"] == pytest.approx(float(np.abs(local.energy_balance).max()), rel=1e-9)
    # The downloads carry W_f as well, and the energy plot draws the budget.
    npz = module_server.client.get(f"/v1/jobs/{done['id']}/trajectory", params={"format": "npz"})
    with np.load(io.BytesIO(npz.content)) as data:
        np.testing.assert_array_equal(data["load_work"], got["load_work"])
    csv = module_server.client.get(f"/v1/jobs/{done['id']}/trajectory", params={"format": "csv"}).text
    assert csv.splitlines()[0].endswith(",work,load_work")
    png = module_server.client.get(f"/v1/jobs/{done['id']}/plots/energy.png")
    assert png.status_code == 200 and png.content.startswith(b"\x89PNG")


def test_csv_and_one_column_npy_records_as_loads(module_server):
    """Two columns t, value (CSV) with a direction and a factor, plus one column of values (.npy) with
    the job's dt: the service's run equals raydamp's with the same series."""
    t = np.linspace(0.0, 2.0, 41)
    force = np.sin(3.0 * t) * np.exp(-t)
    csv = "time,force\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, force))
    pulses = np.cos(np.arange(300) * 0.05)
    csv_id, npy_id = uploaded(module_server, "force.csv", csv), uploaded(module_server, "pulses.npy", npy_bytes(pulses))
    info = module_server.client.get(f"/v1/files/{npy_id}").json()
    assert info["kind"] == "record" and info["samples"] == 300 and info["t_start"] is None and info["dt"] is None
    load = {"terms": [{"file": {"id": csv_id, "direction": [1.0], "factor": 2.5}},
                      {"file": {"id": npy_id, "direction": [0.5], "dt": 0.01}}]}
    done = module_server.wait_finished(module_server.submit(job(load=load, t_end=4.0)))
    assert done["status"] == "completed", done
    got = trajectory(module_server, done["id"])

    local_load = (2.5 * raydamp.Load.series(t, force, [1.0])
                  + raydamp.Load.series(np.arange(300) * 0.01, pulses, [0.5]))
    structure = raydamp.LinearStructure.from_dict(oscillator())
    local = raydamp.integrate(structure, [0.0], [0.0], method="3s", h=1e-3, t_end=4.0, save_every=10,
                              load=local_load, work=True)
    scale = np.abs(local.q).max()
    assert scale > 1e-3
    np.testing.assert_allclose(got["q"], local.q, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(got["load_work"], local.load_work, rtol=0, atol=1e-12 * np.abs(local.load_work).max())


def test_malformed_uploads_are_422_naming_the_problem(module_server):
    good = ground_acceleration()[:20]
    text = at2_text(good)
    cases = {
        "npts.AT2": (at2_text(good, npts=21), "NPTS=21 but the record has 20 values"),
        "word.AT2": (text.replace(text.splitlines()[5][:15], "      abc      ", 1), "is not a number"),
        "dt.AT2": (at2_text(good, dt=0.0), "DT must be > 0"),
        "header.AT2": (text.replace("NPTS=", "POINTS="), "line 4 must give NPTS and DT"),
        "back.csv": ("t,a\n0,1\n0.5,2\n0.4,3\n", "times must increase"),
        "nan.csv": ("0,1\n0.5,nan\n1,3\n", "values[1] is not finite"),
        "words.csv": ("0,1\n0.5,two\n", "line 2: not numbers"),
        "three.npy": (npy_bytes(np.ones((4, 3))), "got shape (4, 3)"),
        "strings.npy": (npy_bytes(np.array(["a", "b"])), "expected numbers"),
        # A header announcing 10^12 floats in a 128-byte file: refused before NumPy allocates them.
        "lying.npy": (_lying_npy(), "more than a file of"),
        "inf.npy": (npy_bytes(np.array([[0.0, 1.0], [1.0, np.inf]])), "not finite"),
    }
    for name, (content, message) in cases.items():
        response = upload(module_server, name, content)
        assert response.status_code == 422, (name, response.text)
        detail = response.json()["detail"][0]
        assert detail["loc"] == ["body", "file"], name
        assert message in detail["msg"] and name in detail["msg"], (name, detail["msg"])
    listed = {f["name"] for f in module_server.client.get("/v1/files", params={"limit": 1000}).json()["files"]}
    assert not listed & set(cases)


def _lying_npy() -> bytes:
    """A valid .npy header (version 1.0) claiming shape (10^12,) of float64, and 8 bytes of data."""
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000,), }"
    header += " " * (64 - 10 - len(header) - 1) + "\n"
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode() + b"\x00" * 8


def test_bad_references_are_422_naming_the_path(module_server, record):
    file_id, _ = record
    one_column = uploaded(module_server, "values.csv", "1\n2\n3\n")
    mtx = io.BytesIO()
    scipy.io.mmwrite(mtx, sparse.eye(1).tocoo())
    matrix = uploaded(module_server, "one.mtx", mtx.getvalue())
    cases = [
        ({"load": {"file": {"path": "/etc/passwd", "direction": [1.0]}}}, ["body", "load", "file", "path"],
         "reads no paths"),
        ({"ground_motion": {"acceleration": {"file": {"path": "RSN953.AT2"}}, "direction": [1.0]}},
         ["body", "ground_motion", "acceleration", "file", "path"], "reads no paths"),
        ({"load": {"file": {"id": "0" * 32, "direction": [1.0]}}}, ["body", "load", "file", "id"],
         "no uploaded file with id"),
        ({"load": {"file": {"id": matrix, "direction": [1.0]}}}, ["body", "load", "file", "id"], "is a matrix"),
        ({"load": {"file": {"id": one_column, "direction": [1.0]}}}, ["body", "load", "file", "dt"],
         "one column of values"),
        ({"load": {"file": {"id": file_id, "direction": [1.0], "dt": 0.01}}}, ["body", "load", "file", "dt"],
         "has a time column"),
        ({"load": {"file": {"id": file_id, "direction": [1.0, 0.0]}}}, ["body", "load", "direction"],
         "length 2, the model has 1"),
        ({"system": {**oscillator(), "K": {"file": file_id}}}, ["body", "system", "K", "file"], "is a record"),
        ({"initial_state": {"q": {"file": file_id}, "p": [0.0]}}, ["body", "initial_state", "q", "file"],
         "two columns"),
        ({"initial_state": {"q": {"file": one_column}, "p": [0.0]}}, ["body", "initial_state", "q"],
         "has length 3, but the model has 1"),
        ({"initial_state": {"q": [0.0], "p": {"file": "../etc/passwd"}}}, ["body", "initial_state", "p", "file"],
         "pattern"),
    ]
    for changes, loc, message in cases:
        response = module_server.client.post("/v1/jobs", json=job(**changes))
        found = locs(response)
        assert loc in found, (changes, found)
        assert message in response.json()["detail"][0]["msg"], (changes, response.json())


def test_a_record_in_use_cannot_be_deleted(module_server, record, tmp_path):
    """A queued or running job naming a record (in its ground motion) or a vector (in its initial state)
    keeps them: 409 naming the job, until it is cancelled."""
    at2 = uploaded(module_server, "KEEP.AT2", at2_text(ground_acceleration()))
    start = uploaded(module_server, "q0.npy", npy_bytes(np.array([0.01])))
    spec = job(ground_motion={"acceleration": {"file": {"id": at2, "factor": G}}, "direction": [1.0]},
               initial_state={"q": {"file": start}, "p": [0.0]}, t_end=None, n_steps=10**9, save_every=10**6)
    long_job = module_server.submit(spec)
    module_server.wait_for(long_job, lambda j: j["status"] in ("queued", "running"), timeout=10)
    for file_id in (at2, start):
        response = module_server.client.delete(f"/v1/files/{file_id}")
        assert response.status_code == 409, response.text
        assert long_job in response.json()["detail"]
    assert module_server.client.post(f"/v1/jobs/{long_job}/cancel").status_code == 202
    assert module_server.wait_finished(long_job)["status"] == "cancelled"
    for file_id in (at2, start):
        assert module_server.client.delete(f"/v1/files/{file_id}").status_code == 204
    response = module_server.client.post("/v1/jobs", json=spec)
    assert ["body", "ground_motion", "acceleration", "file", "id"] in locs(response)


def test_a_10_000_dof_chain_started_from_uploaded_files(module_server):
    """A 10^4-DOF chain of springs (K uploaded as Matrix Market, M lumped inline) started from a
    displacement uploaded as .npy and a velocity as a one-column CSV: past max_dim = 1000, which bounds
    what a job carries inline. The run equals raydamp's from the same vectors."""
    n = 10_000
    K = sparse.diags([2.0 * np.ones(n), -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1]).tocsc() * 1e4
    x = np.arange(1, n + 1) / (n + 1)
    q0 = 1e-3 * np.sin(np.pi * x) + 1e-4 * np.sin(7 * np.pi * x)
    p0 = 1e-2 * x * (1 - x)
    mtx = io.BytesIO()
    scipy.io.mmwrite(mtx, K, symmetry="symmetric")
    ids = {"K": uploaded(module_server, "K.mtx", mtx.getvalue()),
           "q": uploaded(module_server, "q0.npy", npy_bytes(q0)),
           "p": uploaded(module_server, "p0.csv", "".join(f"{float(v)!r}\n" for v in p0))}
    assert module_server.client.get(f"/v1/files/{ids['q']}").json()["samples"] == n
    system = {"kind": "linear_structure", "M": {"diagonal": [1.0] * n}, "K": {"file": ids["K"]}, "alpha": 0.05}
    spec = {"system": system, "method": "3s", "h": 2e-3, "n_steps": 500, "save_every": 50,
            "save_dofs": [0, n // 2, n - 1], "initial_state": {"q": {"file": ids["q"]}, "p": {"file": ids["p"]}}}
    # Inline, the same start is refused (and as a 2 x 10^4-number body, it is close to the body limit).
    inline = module_server.client.post("/v1/jobs", json={**spec, "initial_state": {"q": q0.tolist(), "p": p0.tolist()}})
    assert ["body", "initial_state", "q"] in locs(inline) and "max_dim" in inline.json()["detail"][0]["msg"]
    done = module_server.wait_finished(module_server.submit(spec), timeout=300)
    assert done["status"] == "completed", done
    got = trajectory(module_server, done["id"])
    structure = raydamp.LinearStructure(sparse.identity(n, format="csc"), K, alpha=0.05)
    local = raydamp.integrate(structure, q0, p0, method="3s", h=2e-3, n_steps=500, save_every=50,
                              save_dofs=[0, n // 2, n - 1], work=True)
    np.testing.assert_allclose(got["q"][0], q0[[0, n // 2, n - 1]], rtol=1e-15)  # the files' numbers, exactly
    np.testing.assert_allclose(got["energy"], local.energy, rtol=1e-12, atol=0)
    np.testing.assert_allclose(got["q"], local.q, rtol=0, atol=1e-12 * np.abs(local.q).max())
    assert got["energy"][-1] < got["energy"][0]  # damped


def test_records_are_parsed_once_by_their_content():
    """The resolver (files.ParsedFiles) reads a stored record by its content alone, as the check processes
    do: an .AT2 gives its (t, values), a one-column file (None, values); each parsed once per id."""
    from raydamp_service.checks.uploads import ParsedFiles

    class Store:
        def __init__(self, files):
            self.files, self.reads = files, 0

        def file_content(self, file_id):
            self.reads += 1
            return self.files.get(file_id)

        def file_exists(self, file_id):
            return file_id in self.files

    values = ground_acceleration()[:50]
    store = Store({"a" * 32: at2_text(values).encode(), "b" * 32: npy_bytes(values)})
    parsed = ParsedFiles(store, max_entries=10**6)
    t, a = parsed("a" * 32)
    np.testing.assert_allclose(t, np.arange(50) * RECORD_DT, rtol=1e-15)
    np.testing.assert_allclose(a, values, rtol=1e-7)  # the .AT2 holds 8 digits
    assert parsed("a" * 32)[1] is a and store.reads == 1
    t, b = parsed("b" * 32)
    assert t is None and np.array_equal(b, values) and store.reads == 2


def test_a_files_table_from_before_records_gains_its_columns(tmp_path):
    import sqlite3

    from raydamp_service.kinds.jobs import JobStore

    db = tmp_path / "old.sqlite3"
    with sqlite3.connect(db) as connection:  # the files table as matrices-only services wrote it
        connection.execute("CREATE TABLE files (seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, "
                           "name TEXT NOT NULL, bytes INTEGER NOT NULL, rows INTEGER NOT NULL, cols INTEGER NOT NULL, "
                           "nnz INTEGER NOT NULL, created_at TEXT NOT NULL, content BLOB NOT NULL)")
        connection.execute("INSERT INTO files (id, name, bytes, rows, cols, nnz, created_at, content) VALUES "
                           "('f', 'K.mtx', 3, 2, 2, 2, '2024-01-01T00:00:00+00:00', x'2525')")
    connection.close()
    store = JobStore(db)
    store.open()
    try:
        old = store.file("f")
        assert old.kind == "matrix" and old.format == "mtx" and old.shape == (2, 2) and old.dt is None
    finally:
        store.close()


def test_a_sweep_reads_no_paths_either(module_server, tmp_path):
    """A sweep's job runs without the file resolver: a "path" there must still be refused, before the
    service (or its workers) opens the file (found in review: it would have read any file)."""
    secret = tmp_path / "secret.csv"
    secret.write_text("0,1\n1,2\n")
    for body in ({"load": {"file": {"path": str(secret), "direction": [1.0]}}},
                 {"ground_motion": {"acceleration": {"terms": [{"file": {"path": str(secret)}}]}, "direction": [1.0]}}):
        response = module_server.client.post("/v1/sweeps", json={"job": job(**body, work=False),
                                                                  "grid": {"h": [1e-3, 2e-3]}})
        assert response.status_code == 422, response.text
        detail = response.json()["detail"][0]
        assert detail["loc"][:3] == ["body", "job", next(iter(body))] and detail["loc"][-1] == "path", detail
        assert "reads no paths" in detail["msg"]


def test_a_temperature_without_a_seed_gets_one_stored_with_the_job(module_server):
    spec = {"model": "damped_pendulum", "parameters": {"eps": 0.3}, "method": "baoab", "h": 0.05, "n_steps": 40,
            "initial_state": {"q": [0.5], "p": [0.0]}, "temperature": 0.5}
    response = module_server.client.post("/v1/jobs", json=spec)
    assert response.status_code == 202, response.text
    stored = module_server.client.get(response.headers["location"]).json()["spec"]
    assert isinstance(stored["seed"], int) and stored["temperature"] == 0.5


def _rss_kib(pid: int, field: str = "VmRSS") -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise LookupError(field)


def test_a_record_upload_is_parsed_outside_the_server(module_server):
    """Issue 44, N1: a record was parsed in the server's thread pool, a Python float per value: the server grew by
    about 86 bytes per byte uploaded (a 4 MiB column: +345 MB) and kept it. Now a check process parses it, under
    its budgets; the server holds the bytes received (and a copy for the pipe), not their values as objects."""
    import threading

    content = b"0.25\n" * (2 * 2**20 // 5)  # 2 MiB, 419,430 samples: +180 MB in the server before
    pid = module_server.process.pid
    assert upload(module_server, "warm.csv", "0.5\n0.25\n").status_code == 201
    baseline = _rss_kib(pid)
    peak, done = [baseline], threading.Event()

    def sample() -> None:
        while not done.is_set():
            peak.append(_rss_kib(pid))
            done.wait(0.005)

    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        response = upload(module_server, "column.csv", content)
    finally:
        done.set()
        sampler.join()
    assert response.status_code == 201, response.text
    assert response.json()["samples"] == 2 * 2**20 // 5
    grown = (max(peak) - baseline) / 1024
    assert grown <= 3 * len(content) / 2**20 + 24, f"the server grew by {grown:.0f} MiB for a 2 MiB upload"


def test_an_upload_is_never_held_whole_by_the_server(module_server):
    """Issue 44, N1 measured (benchmarks/bench_upload_memory.py): a 64 MiB upload grew the server by 4 copies of it
    (the bytes read, their pickle to the check process, SQLite's bound copy and its row). Now it is copied to a
    file a piece at a time, read there by the check process, and stored from the file into a zeroblob: a refused
    upload costs the server a few MiB, a stored one the row SQLite builds (the content is not its last column)."""
    pid = module_server.process.pid
    size = 16 * 2**20
    stored = npy_bytes(np.full(size // 8 - 16, 0.01))  # 2.1e6 samples: within the 10^7 limit
    refused = b"0\n" * 10_500_000  # 1.05e7 samples: past it
    assert upload(module_server, "warm.npy", npy_bytes(np.ones(4))).status_code == 201
    for name, content, status, bound in (("big.npy", stored, 201, 2.5 * len(stored) / 2**20 + 12),
                                         ("big.csv", refused, 422, 12)):
        before = _rss_kib(pid)
        Path(f"/proc/{pid}/clear_refs").write_text("5")  # the peak (VmHWM) from here
        response = upload(module_server, name, content)
        assert response.status_code == status, response.text[:300]
        grown = (_rss_kib(pid, "VmHWM") - before) / 1024
        assert grown <= bound, f"{name}: the server grew by {grown:.0f} MiB for {len(content) / 2**20:.0f} MiB"
    assert "10000000 samples" in response.json()["detail"][0]["msg"]

