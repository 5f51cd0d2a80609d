"""Linear structures over HTTP: {"system": {"kind": "linear_structure", ...}} with matrices as COO
triplets or uploaded Matrix Market files (POST /v1/files), run by a real server process and compared
with raydamp in this process; bad structures and uploads refused with a 422 naming the JSON path, or
413 past the upload limit."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sparse

import raydamp

# Small limits, so that the limit tests need small bodies: 200 entries per COO matrix, 16 KiB files.
MAX_NNZ = 200
MAX_FILE = 16 * 1024
SERVER_ENV = {"RAYDAMP_MAX_STRUCTURE_NNZ": str(MAX_NNZ), "RAYDAMP_MAX_FILE_BYTES": str(MAX_FILE),
              "RAYDAMP_MAX_STEPS": str(10**10)}
N = 50
H = 0.002
STEPS = 500


def bar(n: int = N) -> tuple[sparse.csc_matrix, sparse.csc_matrix]:
    """A 1-D elastic bar of unit length, E = A = rho = 1, fixed at x = 0 and free at x = 1, in n linear
    elements: consistent mass M and stiffness K (both n x n, tridiagonal, SPD)."""
    le = 1.0 / n
    k_e = np.array([[1.0, -1.0], [-1.0, 1.0]]) / le
    m_e = np.array([[2.0, 1.0], [1.0, 2.0]]) * le / 6.0
    rows, cols, k_vals, m_vals = [], [], [], []
    for element in range(n):
        nodes = (element - 1, element)  # node i is the dof of x = (i + 1) le; node -1 is the fixed end
        for a in range(2):
            for b in range(2):
                if nodes[a] >= 0 and nodes[b] >= 0:
                    rows.append(nodes[a])
                    cols.append(nodes[b])
                    k_vals.append(k_e[a, b])
                    m_vals.append(m_e[a, b])
    K = sparse.csc_matrix((k_vals, (rows, cols)), shape=(n, n))
    M = sparse.csc_matrix((m_vals, (rows, cols)), shape=(n, n))
    return M, K


def coo(matrix) -> dict:
    m = matrix.tocoo()
    return {"coo": {"shape": list(m.shape), "rows": m.row.tolist(), "cols": m.col.tolist(),
                    "values": m.data.tolist()}}


def initial_state(n: int = N) -> tuple[list[float], list[float]]:
    x = np.arange(1, n + 1) / n
    return (0.01 * np.sin(np.pi * x / 2)).tolist(), (0.002 * x).tolist()  # the first mode's shape, and a push


def job(system: dict, **changes) -> dict:
    q0, p0 = initial_state()
    return {"system": system, "method": "3s", "step_size": H, "n_steps": STEPS, "save_every": 100,
            "initial_state": {"q": q0, "p": p0}, **changes}


def structure_system(M, K) -> dict:
    f = np.zeros(N)
    f[-1] = 1e-3  # a pull at the free end
    return {"kind": "linear_structure", "M": M, "K": K, "alpha": 0.2, "beta": 1e-4, "f": f.tolist()}


def local_run(M, K) -> raydamp.Solution:
    f = np.zeros(N)
    f[-1] = 1e-3
    s = raydamp.LinearStructure(M, K, alpha=0.2, beta=1e-4, f=f)
    q0, p0 = initial_state()
    return raydamp.integrate(s, q0, p0, method="3s", h=H, n_steps=STEPS, save_every=100, work=True)


def _peak_rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise AssertionError("no VmHWM in /proc status")


def upload(server, name: str, content: bytes):
    return server.client.post("/v1/files", files={"file": (name, content, "application/octet-stream")})


def mtx_bytes(matrix, **options) -> bytes:
    out = io.BytesIO()
    scipy.io.mmwrite(out, matrix, **options)
    return out.getvalue()


def locs(response) -> list[list]:
    assert response.status_code == 422, response.text
    return [list(d["loc"]) for d in response.json()["detail"]]


def test_bar_as_coo_triplets_matches_python(module_server):
    M, K = bar()
    done = module_server.wait_finished(module_server.submit(job(structure_system(coo(M), coo(K)))))
    assert done["status"] == "completed", done
    trajectory = module_server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    local = local_run(M, K)
    energy = np.array(trajectory["energy"])
    assert energy.shape == local.energy.shape
    np.testing.assert_allclose(energy, local.energy, rtol=1e-12, atol=0)
    np.testing.assert_allclose(np.array(trajectory["q"]), local.q, rtol=1e-12, atol=1e-15)
    # The damping took energy: the balance H - H0 + W stays small (O(h^2)) while H falls.
    assert energy[-1] < energy[0]
    balance = energy - energy[0] + np.array(trajectory["work"])
    assert np.abs(balance).max() < 1e-3 * abs(energy[0])
    assert module_server.client.get("/v1/jobs", params={"limit": 5}).json()["jobs"][0]["model"] == "linear_structure"
    # Its files and plots, whose coordinate names come from the structure's size (not from "coordinates").
    for fmt in ("csv", "npz"):
        response = module_server.client.get(f"/v1/jobs/{done['id']}/trajectory", params={"format": fmt})
        assert response.status_code == 200, response.text
    npz = np.load(io.BytesIO(response.content))
    np.testing.assert_allclose(npz["energy"], local.energy, rtol=1e-12, atol=0)
    for kind in ("energy", "phase"):
        response = module_server.client.get(f"/v1/jobs/{done['id']}/plots/{kind}.png")
        assert response.status_code == 200 and response.content[:4] == b"\x89PNG", response.text


def test_lumped_mass_as_a_diagonal_and_save_dofs(module_server):
    M, K = bar()
    lumped = np.asarray(M.sum(axis=1)).ravel()  # row sums: the lumped mass
    system = structure_system({"diagonal": lumped.tolist()}, coo(K))
    done = module_server.wait_finished(module_server.submit(job(system, save_dofs=[0, N - 1])))
    assert done["status"] == "completed", done
    trajectory = module_server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    local = local_run(sparse.diags(lumped), K)
    assert np.array(trajectory["q"]).shape == (local.t.size, 2)
    np.testing.assert_allclose(np.array(trajectory["q"]), local.q[:, [0, N - 1]], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trajectory["energy"], local.energy, rtol=1e-12, atol=0)


def test_bar_from_uploaded_matrix_market_files(module_server, tmp_path):
    M, K = bar()
    paths = {}
    for name, matrix in (("M", M), ("K", K)):
        paths[name] = tmp_path / f"{name}.mtx"
        scipy.io.mmwrite(paths[name], matrix, symmetry="symmetric")
    ids = {}
    for name, path in paths.items():
        response = upload(module_server, path.name, path.read_bytes())
        assert response.status_code == 201, response.text
        info = response.json()
        assert info["name"] == path.name and info["bytes"] == path.stat().st_size
        assert info["shape"] == [N, N] and info["nnz"] == 3 * N - 2  # the symmetric file's mirror counted
        assert response.headers["location"] == f"/v1/files/{info['id']}"
        ids[name] = info["id"]
    listed = {f["id"] for f in module_server.client.get("/v1/files").json()["files"]}
    assert set(ids.values()) <= listed
    assert module_server.client.get(f"/v1/files/{ids['K']}").json()["shape"] == [N, N]

    system = structure_system({"file": ids["M"]}, {"file": ids["K"]})
    done = module_server.wait_finished(module_server.submit(job(system)))
    assert done["status"] == "completed", done
    trajectory = module_server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    local = local_run(str(paths["M"]), str(paths["K"]))  # raydamp reads the same files itself
    np.testing.assert_allclose(trajectory["energy"], local.energy, rtol=1e-12, atol=0)
    # The files as written hold M and K to 16 digits: the run equals the COO one closely too.
    coo_run = local_run(M, K)
    np.testing.assert_allclose(trajectory["energy"], coo_run.energy, rtol=1e-9, atol=0)


def test_a_matrix_file_with_a_blank_before_its_banner_serves_a_job(module_server):
    """The upload read it as a matrix (by its .mtx name; scipy skips the blank), but a stored file is read again by
    its content alone, which took it for text columns: the job got 422 "expected columns t, value" on its file."""
    M, K = bar()
    content = b" " + mtx_bytes(K, symmetry="symmetric")
    response = upload(module_server, "K.mtx", content)
    assert response.status_code == 201 and response.json()["kind"] == "matrix", response.text
    system = structure_system(coo(M), {"file": response.json()["id"]})
    done = module_server.wait_finished(module_server.submit(job(system)))
    assert done["status"] == "completed", done
    np.testing.assert_allclose(module_server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()["energy"],
                               local_run(M, K).energy, rtol=1e-9, atol=0)


def test_a_file_in_use_cannot_be_deleted(module_server):
    M, K = bar()
    ids = [upload(module_server, f"{name}.mtx", mtx_bytes(matrix)).json()["id"]
           for name, matrix in (("M", M), ("K", K))]
    system = structure_system({"file": ids[0]}, {"file": ids[1]})
    long_job = module_server.submit(job(system, n_steps=10**9, save_every=10**6))
    module_server.wait_for(long_job, lambda j: j["status"] in ("queued", "running"), timeout=10)
    response = module_server.client.delete(f"/v1/files/{ids[1]}")
    assert response.status_code == 409, response.text
    assert long_job in response.json()["detail"]
    assert module_server.client.post(f"/v1/jobs/{long_job}/cancel").status_code == 202
    assert module_server.wait_finished(long_job)["status"] == "cancelled"
    assert module_server.client.delete(f"/v1/files/{ids[1]}").status_code == 204
    assert module_server.client.get(f"/v1/files/{ids[1]}").status_code == 404
    assert module_server.client.delete(f"/v1/files/{ids[1]}").status_code == 404
    # The job that named it is finished and keeps its results; a new job naming it is refused.
    response = module_server.client.post("/v1/jobs", json=job(system))
    assert ["body", "system", "K", "file"] in locs(response)
    assert ids[1] in response.json()["detail"][0]["msg"]


def _bad_structures():
    M, K = bar()
    system = structure_system(coo(M), coo(K))

    def changed(key, **coo_changes):
        form = coo(K if key == "K" else M)
        form["coo"].update(coo_changes)
        return {**system, key: form}

    K_rows = coo(K)["coo"]["rows"]
    out_of_range = list(K_rows)
    out_of_range[3] = N
    lower = sparse.tril(K).tocoo()  # only the lower triangle: not symmetric
    over = MAX_NNZ + 1
    return [
        ("non-square shape", job(changed("K", shape=[N, N + 1])), ["body", "system", "K", "coo", "shape"]),
        ("index out of range", job(changed("K", rows=out_of_range)), ["body", "system", "K", "coo", "rows", 3]),
        ("negative index", job(changed("M", cols=[-1] + coo(M)["coo"]["cols"][1:])),
         ["body", "system", "M", "coo", "cols", 0]),
        ("lengths differ", job(changed("K", values=coo(K)["coo"]["values"][:-1])), ["body", "system", "K", "coo"]),
        ("nnz over the limit", job(changed("K", rows=[0] * over, cols=[0] * over, values=[1.0] * over)),
         ["body", "system", "K", "coo", "rows"]),
        ("K not symmetric", job({**system, "K": coo(lower)}), ["body", "system", "K"]),
        ("M not positive definite", job({**system, "M": {"diagonal": [1.0] * (N - 1) + [-1.0]}}),
         ["body", "system", "M"]),
        ("missing file id", job({**system, "K": {"file": "0" * 32}}), ["body", "system", "K", "file"]),
        ("malformed file id", job({**system, "K": {"file": "../etc/passwd"}}), ["body", "system", "K", "file"]),
        ("a path, which raydamp run reads", job({**system, "K": {"file": "K.mtx"}}), ["body", "system", "K", "file"]),
        ("unknown matrix form", job({**system, "K": {"dense": [[1.0]]}}), ["body", "system", "K"]),
        ("matrix not an object", job({**system, "M": [1.0, 2.0]}), ["body", "system", "M"]),
        ("extra key in coo", job({**system, "K": {"coo": {**coo(K)["coo"], "dense": 1}}}),
         ["body", "system", "K", "coo", "dense"]),
        ("q of wrong length", job(system, initial_state={"q": [0.0] * (N - 1), "p": [0.0] * N}),
         ["body", "initial_state", "q"]),
        ("f of wrong length", job({**system, "f": [0.0] * 3}), ["body", "system", "f"]),
        ("negative beta", job({**system, "beta": -1.0}), ["body", "system", "beta"]),
        ("mode start", job(system, initial_state={"mode": 1}), ["body", "initial_state"]),
        ("save_dofs out of range", job(system, save_dofs=[N]), ["body", "save_dofs"]),
    ]


@pytest.mark.parametrize("spec, loc", [case[1:] for case in _bad_structures()],
                         ids=[case[0] for case in _bad_structures()])
def test_bad_structures_are_422_naming_the_path(module_server, spec, loc):
    found = locs(module_server.client.post("/v1/jobs", json=spec))
    assert any(where[:len(loc)] == loc for where in found), found


def test_bad_uploads_are_422(module_server):
    M, K = bar()
    cases = {
        "not.mtx": b"just some text\n",
        "truncated.mtx": mtx_bytes(K)[:-40],
        "complex.mtx": mtx_bytes(sparse.csc_matrix(np.eye(3) * (1 + 1j))),
        "rectangular.mtx": mtx_bytes(sparse.csc_matrix(np.ones((3, 4)))),
        # A header announcing 10^9 entries in a 60-byte file: refused before the reader allocates them.
        "lying.mtx": b"%%MatrixMarket matrix coordinate real general\n5 5 1000000000\n1 1 1.0\n",
        "nan.mtx": b"%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 nan\n2 2 1.0\n",
    }
    for name, content in cases.items():
        response = upload(module_server, name, content)
        assert response.status_code == 422, (name, response.text)
        assert response.json()["detail"][0]["loc"] == ["body", "file"], name
    # No file part at all.
    response = module_server.client.post("/v1/files", data={"other": "x"})
    assert ["body", "file"] in locs(response)
    listed = {f["name"] for f in module_server.client.get("/v1/files", params={"limit": 1000}).json()["files"]}
    assert not listed & set(cases)


def test_uploads_past_max_file_bytes_are_413(module_server):
    # Far past: refused from Content-Length, before the body is read.
    response = upload(module_server, "big.mtx", b"%" * (10 * MAX_FILE))
    assert response.status_code == 413, response.text
    assert f"max_file_bytes = {MAX_FILE}" in response.json()["detail"]
    # Just past (the multipart framing fits in the guard's allowance): the route counts the file itself.
    response = upload(module_server, "big.mtx", b"%" * (MAX_FILE + 1))
    assert response.status_code == 413, response.text
    assert f"max_file_bytes = {MAX_FILE}" in response.json()["detail"]

    # Chunked, without Content-Length: counted as it arrives.
    def chunks():
        yield b"--b\r\nContent-Disposition: form-data; name=\"file\"; filename=\"big.mtx\"\r\n\r\n"
        for _ in range(200):
            yield b"%" * 4096

    response = module_server.client.post("/v1/files", content=chunks(),
                                         headers={"content-type": "multipart/form-data; boundary=b"})
    assert response.status_code == 413, response.text
    # An ordinary JSON body keeps its own limit, max_body_bytes, named as such.
    assert module_server.client.get("/healthz").status_code == 200


def test_openapi_documents_files_and_structures(module_server):
    schema = module_server.client.get("/openapi.json").json()
    assert {"post", "get"} <= set(schema["paths"]["/v1/files"])
    assert "delete" in schema["paths"]["/v1/files/{file_id}"]
    assert "multipart/form-data" in schema["paths"]["/v1/files"]["post"]["requestBody"]["content"]
    assert "413" in schema["paths"]["/v1/files"]["post"]["responses"]
    components = schema["components"]["schemas"]
    assert components["CooMatrix"]["properties"]["rows"]["maxItems"] == 1_000_000
    assert "LinearStructureInput" in components


def test_files_need_the_token_persist_across_restarts_and_have_a_quota(start_server):
    M, K = bar()
    content = mtx_bytes(K)
    server = start_server(RAYDAMP_TOKEN="s3cret", RAYDAMP_MAX_STORED_FILE_BYTES=str(2 * len(content) + 10))
    base = server.client.base_url
    import httpx

    assert httpx.post(f"{base}/v1/files", files={"file": ("K.mtx", content)}).status_code == 401
    assert httpx.get(f"{base}/v1/files").status_code == 401
    first = upload(server, "K.mtx", content).json()["id"]
    assert upload(server, "K2.mtx", content).status_code == 201
    response = upload(server, "K3.mtx", content)  # a third would pass max_stored_file_bytes
    assert response.status_code == 507, response.text
    assert "max_stored_file_bytes" in response.json()["detail"]
    assert len(server.client.get("/v1/files").json()["files"]) == 2
    server.restart()
    assert server.client.get(f"/v1/files/{first}").json()["nnz"] == K.nnz
    assert server.client.delete(f"/v1/files/{first}").status_code == 204
    assert upload(server, "K3.mtx", content).status_code == 201  # room again


def test_an_older_database_gains_the_files_table(tmp_path):
    import sqlite3

    from raydamp_service.kinds.jobs import JobStore

    db = tmp_path / "old.sqlite3"
    with sqlite3.connect(db) as connection:  # the tables of a database from before uploads
        connection.execute("CREATE TABLE jobs (seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, "
                           "status TEXT NOT NULL, spec TEXT NOT NULL, progress REAL NOT NULL DEFAULT 0, "
                           "attempts INTEGER NOT NULL DEFAULT 0, cancel_requested INTEGER NOT NULL DEFAULT 0, "
                           "summary TEXT, error TEXT, failed_step INTEGER, created_at TEXT NOT NULL, "
                           "started_at TEXT, finished_at TEXT)")
    connection.close()
    store = JobStore(db)
    store.open()
    try:
        record = store.add_file("K.mtx", b"%%MatrixMarket ...", (3, 3), 7)
        assert store.file(record.id).shape == (3, 3)
        assert store.file_content(record.id) == b"%%MatrixMarket ..."
        assert store.delete_file(record.id) == "deleted" and store.delete_file(record.id) == "missing"
    finally:
        store.close()


def test_a_large_structure_started_at_rest_under_its_load(start_server):
    """n = 20,000 (past max_dim = 1000, which bounds the vectors a job carries): K uploaded as a file, the
    lumped M inline, {"rest": true} as the start, a pull at the free end, two coordinates saved."""
    n = 20_000
    M, K = bar(n)
    lumped = np.asarray(M.sum(axis=1)).ravel()
    server = start_server()
    before = _peak_rss_mib(server.process.pid)
    response = upload(server, "K.mtx", mtx_bytes(K, symmetry="symmetric"))
    assert response.status_code == 201, response.text
    f = np.zeros(n)
    f[-1] = 1.0
    h, steps = 2.5e-5, 400  # h omega_max = 2.5e-5 * 2n = 1: inside Stormer-Verlet's interval
    system = {"kind": "linear_structure", "M": {"diagonal": lumped.tolist()}, "K": {"file": response.json()["id"]},
              "alpha": 0.5, "beta": 1e-7, "f": f.tolist()}
    spec = {"system": system, "method": "3s", "step_size": h, "n_steps": steps, "save_every": 100,
            "initial_state": {"rest": True}, "save_dofs": [n - 2, n - 1]}
    done = server.wait_finished(server.submit(spec), timeout=300)
    assert done["status"] == "completed", done
    trajectory = server.client.get(f"/v1/jobs/{done['id']}/trajectory").json()
    s = raydamp.LinearStructure(sparse.diags(lumped), K, alpha=0.5, beta=1e-7, f=f)
    local = raydamp.integrate(s, np.zeros(n), np.zeros(n), method="3s", h=h, n_steps=steps, save_every=100,
                              save_dofs=[n - 2, n - 1], work=True)
    np.testing.assert_allclose(trajectory["energy"], local.energy, rtol=1e-12, atol=0)
    np.testing.assert_allclose(np.array(trajectory["q"]), local.q, rtol=1e-12, atol=1e-300)
    assert trajectory["q"][-1][1] > trajectory["q"][-1][0] > 0  # the pulled end moved first and most
    assert trajectory["energy"][-1] < 0  # V = 1/2 q^T K q - f^T q: the load did work on the bar
    # The upload (1.2 MB), its parse, the structure (M, K, a few n-vectors) and the run: a few MB of data.
    peak = _peak_rss_mib(server.process.pid)
    print(f"\nservice process peak RSS: {before:.0f} MiB before the upload, {peak:.0f} MiB after the n = {n} run")
    assert peak - before < 300, (before, peak)
    # A start at rest with a q of its own, or with anything else, is refused.
    for state in ({"rest": False}, {"rest": True, "q": [0.0]}):
        response = server.client.post("/v1/jobs", json={**spec, "initial_state": state})
        assert any(where[:2] == ["body", "initial_state"] for where in locs(response)), state


def test_a_matrix_path_is_refused_saying_the_service_reads_no_paths(module_server):
    """{"file": "<path>"} is a Matrix Market path for raydamp run; the service reads no file of its machine."""
    M, K = bar()
    for name in ("K.mtx", "/etc/passwd"):
        response = module_server.client.post("/v1/jobs", json=job(structure_system(coo(M), {"file": name})))
        detail = response.json()["detail"][0]
        assert response.status_code == 422 and detail["loc"] == ["body", "system", "K", "file"], response.text
        assert "the service reads no paths" in detail["msg"], detail


def _newmark_job(material, load, h: float, t_end: float) -> dict:
    """Chopra's SDOF (m = 0.2533, c = 0.159154) with one spring to the ground, run by newmark."""
    system = raydamp.Structure([[0.2533]], springs=[raydamp.Spring((0,), material)], alpha=0.159154 / 0.2533)
    return {"system": system.to_dict(), "method": "newmark", "h": h, "t_end": t_end,
            "initial_state": {"q": [0.0], "p": [0.0]}, "load": load.to_dict()}


def test_newmark_runs_a_structure_with_springs_and_is_422_on_other_systems(module_server):
    """Issue 42: a job may ask for newmark on a Structure with springs; its numbers are the Python call's, bit
    for bit; a run that does not converge keeps its rows and names the step; another system is a 422 at
    method; /v1/structure_methods lists it with its description."""
    from raydamp.jobs import job_arguments
    from raydamp.materials import Bilinear, ElasticPlastic
    from raydamp.methods.catalogue import structure_methods

    assert module_server.client.get("/v1/structure_methods").json() == [m._asdict() for m in structure_methods()]
    pulse = raydamp.Load.harmonic([10.0], np.pi / 0.6, t_end=0.6)
    # a softening storey (b = -0.9) pushed past its capacity at h = 0.5: Newton fails at step 21
    push = raydamp.Load.harmonic([15.0], 0.05)
    specs = [_newmark_job(ElasticPlastic(10.0, 7.5), pulse, 0.01, 3.0),
             _newmark_job(Bilinear(10.0, 7.5, -0.9), push, 0.5, 20.0)]
    ids = [module_server.submit(spec) for spec in specs]
    for job_id, spec, finished in zip(ids, specs, ("completed", "failed")):
        done = module_server.wait_finished(job_id)
        model, q0, p0, options = job_arguments(spec)
        here = raydamp.integrate(model, q0, p0, **options)
        assert done["status"] == finished and done["summary"]["status"] == here.status, done
        trajectory = module_server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
        np.testing.assert_array_equal(np.array(trajectory["q"]), here.q)
        np.testing.assert_array_equal(np.array(trajectory["energy"]), here.energy)
    assert here.status == "not_converged" and len(here.t) >= 2  # the premise: the second run stops early
    assert done["failed_step"] == here.failed_step and f"step {here.failed_step} " in done["error"]
    assert len(trajectory["t"]) == done["failed_step"] >= 20  # its rows, up to the step that failed
    linear = raydamp.LinearStructure([[0.2533]], [[10.0]], alpha=0.159154 / 0.2533)
    refused = module_server.client.post("/v1/jobs", json={**specs[0], "system": linear.to_dict()})
    assert ["body", "method"] in locs(refused)
    assert "newmark" in refused.json()["detail"][0]["msg"]
    model_job = {"model": "damped_pendulum", "method": "newmark", "h": 0.01, "n_steps": 10,
                 "initial_state": {"q": [0.1], "p": [0.0]}}
    assert ["body", "method"] in locs(module_server.client.post("/v1/jobs", json=model_job))
