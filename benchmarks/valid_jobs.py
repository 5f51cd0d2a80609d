#!/usr/bin/env python3
"""Valid traffic of every kind against a running service, for `make fuzz` (issue 44): random but valid jobs of
every system kind (built-in models with every method, expression systems, chains, linear structures by COO and by
uploaded Matrix Market file, structures with hysteretic springs, envelopes and collapse, events, thermal noise),
every load form (harmonic, series, expression, an uploaded record, terms) and ground motion, sweeps, and uploads
of every format (.AT2, CSV columns, .npy, .mtx); each finished job's results are read back (its view, trajectory
as JSON and as a file, a plot, its events). Counts every answer by status; a 5xx, or a valid job whose run fails,
is a finding. Schemathesis fuzzes what is invalid; this reaches what is valid, which random generation rarely does.

    .venv/bin/python benchmarks/valid_jobs.py --base http://127.0.0.1:8000 --seconds 60
"""

from __future__ import annotations

import argparse
import io
import random
import threading
import time
from collections import Counter

import httpx
import numpy as np

METHODS = ("3s", "2s", "sv", "rksb", "baoab", "rks", "rk", "ck", "midpoint", "gauss2")
THERMAL = ("3s", "2s", "baoab")
FINISHED = {"completed", "failed", "cancelled", "non_finite", "diverged", "event", "collapsed", "not_converged"}


def at2(values: np.ndarray, dt: float) -> bytes:
    lines = ["PEER NGA STRONG MOTION DATABASE RECORD", "VALID TRAFFIC", "ACCELERATION TIME SERIES IN UNITS OF G",
             f"NPTS= {values.size:6d}, DT= {dt:.4f} SEC"]
    lines += ["".join(f"{v:15.7E}" for v in values[k:k + 5]) for k in range(0, values.size, 5)]
    return ("\n".join(lines) + "\n").encode()


def npy(array: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.save(out, array)
    return out.getvalue()


def mtx_tridiagonal(n: int, k: float) -> bytes:
    entries = [f"{i + 1} {i + 1} {2 * k!r}" for i in range(n)] + [f"{i + 2} {i + 1} {-k!r}" for i in range(n - 1)]
    return (f"%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {len(entries)}\n" + "\n".join(entries)
            + "\n").encode()


class ValidTraffic:
    """Threads posting valid work to base until stop is set; counts answers, finished statuses and findings."""

    def __init__(self, base: str, seed: int = 0):
        self.base, self.seed = base, seed
        self.stop = threading.Event()
        self.answers: Counter = Counter()  # (what, status)
        self.finished: Counter = Counter()  # (kind, final status)
        self.findings: list[str] = []
        self._lock = threading.Lock()
        self.models = httpx.get(base + "/v1/models", timeout=60).json()
        self.records: list[str] = []  # uploaded record ids (two columns t, value)
        self.matrices: dict[int, str] = {}  # n -> an uploaded tridiagonal K

    # ---- counting ----
    def _answer(self, what: str, response: httpx.Response) -> httpx.Response:
        with self._lock:
            self.answers[(what, response.status_code)] += 1
            if response.status_code >= 500:
                self.findings.append(f"{what}: {response.status_code} {response.text[:300]}")
        return response

    def _finding(self, text: str) -> None:
        with self._lock:
            self.findings.append(text)

    # ---- what is sent ----
    def _upload(self, client: httpx.Client, rng: random.Random) -> None:
        n = rng.randint(50, 3000)
        dt = rng.choice((0.005, 0.01, 0.02))
        values = np.sin(np.arange(n) * dt * rng.uniform(1, 20)) * rng.uniform(0.05, 0.5)
        form = rng.choice(("at2", "csv", "npy", "mtx", "one column"))
        if form == "at2":
            name, content = "rec.AT2", at2(values, dt)
        elif form == "csv":
            name = "rec.csv"
            content = "".join(f"{k * dt:.6f},{v:.10e}\n" for k, v in enumerate(values)).encode()
        elif form == "npy":
            name, content = "rec.npy", npy(np.column_stack([np.arange(n) * dt, values]))
        elif form == "one column":
            name, content = "col.txt", "".join(f"{float(v)!r}\n" for v in values).encode()
        else:
            size = rng.choice((3, 8, 40))
            name, content = "K.mtx", mtx_tridiagonal(size, rng.uniform(10, 1000))
        response = self._answer(f"upload {form}", client.post("/v1/files", files={"file": (name, content)}))
        if response.status_code == 201:
            file_id = response.json()["id"]
            with self._lock:
                if form == "mtx":
                    self.matrices[size] = file_id
                elif form != "one column":
                    self.records = (self.records + [file_id])[-20:]
        elif response.status_code != 429:
            self._finding(f"a valid {form} upload: {response.status_code} {response.text[:300]}")

    def _load(self, rng: random.Random, n: int, terms: bool = True) -> dict:
        direction = [rng.uniform(-1, 1) for _ in range(n)]
        forms = ["harmonic", "series", "expression"] + (["terms"] if terms else []) + (["file"] if self.records else [])
        form = rng.choice(forms)
        if form == "harmonic":
            return {"harmonic": {"amplitude": direction, "omega": rng.uniform(0.5, 20), "phase": rng.uniform(0, 3)}}
        if form == "series":
            t = sorted(rng.uniform(0, 2) for _ in range(rng.randint(2, 40)))
            t = [x + 1e-3 * k for k, x in enumerate(t)]
            return {"series": {"t": t, "values": [rng.uniform(-1, 1) for _ in t], "direction": direction,
                               "hold": rng.random() < 0.5}}
        if form == "expression":
            parameters = {"F0": rng.uniform(0, 5), "w": rng.uniform(1, 9)}
            return {"expression": {"expression": "F0*sin(w*t)*exp(-t)", "parameters": parameters,
                                   "direction": direction}}
        if form == "file":
            return {"file": {"id": rng.choice(self.records), "direction": direction, "factor": rng.uniform(0.5, 9.81)}}
        terms = [self._load(rng, n, terms=False) for _ in range(rng.randint(1, 3))]
        return {"terms": terms, "amplitude": rng.uniform(0.1, 2)}

    def _ground(self, rng: random.Random, n: int) -> dict:
        forms = ["harmonic", "series", "expression"] + (["file"] if self.records else [])
        form = rng.choice(forms)
        if form == "harmonic":
            acceleration = {"harmonic": {"amplitude": rng.uniform(0.1, 3), "omega": rng.uniform(1, 30)}}
        elif form == "series":
            t = [0.01 * k for k in range(rng.randint(2, 200))]
            acceleration = {"series": {"t": t, "values": [rng.uniform(-3, 3) for _ in t]}}
        elif form == "expression":
            acceleration = {"expression": {"expression": "a*sin(7*t)", "parameters": {"a": rng.uniform(0, 3)}}}
        else:
            acceleration = {"file": {"id": rng.choice(self.records), "factor": 9.81}}
        return {"acceleration": acceleration, "direction": [1.0] * n, "factor": rng.uniform(0.5, 2)}

    def _builtin(self, rng: random.Random) -> dict:
        model = rng.choice(self.models)
        dim = model["dim"]
        q = [rng.uniform(-0.5, 0.5) + (1.0 if "kepler" in model["name"] and i == 0 else 0.0) for i in range(dim)]
        p = [rng.uniform(-0.3, 0.3) + (1.0 if "kepler" in model["name"] and i == 1 else 0.0) for i in range(dim)]
        job = {"model": model["name"], "method": rng.choice(METHODS), "h": rng.choice((0.001, 0.01, 0.05)),
               "n_steps": rng.randint(1, 3000), "initial_state": {"q": q, "p": p},
               "save_every": rng.choice((1, 1, 7, 100)), "work": rng.random() < 0.7}
        if rng.random() < 0.2:
            job["save_dofs"] = sorted(rng.sample(range(dim), rng.randint(1, dim)))
        if rng.random() < 0.1:
            job.update(method=rng.choice(THERMAL), temperature=rng.uniform(0, 0.5), seed=rng.randint(0, 99))
        if rng.random() < 0.1:
            job["dense"] = True
        return job

    def _system(self, rng: random.Random) -> dict:
        kind = rng.choice(("expression", "chain", "coo structure", "file structure", "springs", "events"))
        base = {"method": rng.choice(("3s", "2s", "rks")), "h": 0.01, "n_steps": rng.randint(10, 2000),
                "save_every": rng.choice((1, 10))}
        if kind == "expression":
            potential = rng.choice(("(2*a^2 - 2*a*b + b^2)/2", "a^2/2 + b^2/2 + c*a^2*b^2", "1 - cos(a) + b^4/4"))
            damping = rng.choice(({"dampers": [{"on": "a - b", "c": 0.1}]}, {"diagonal": [0.1, 0.2]}))
            system = {"coordinates": ["a", "b"], "potential": potential, "damping": damping,
                      "parameters": {"c": rng.uniform(0, 1)} if "c*" in potential else {},
                      "mass": [1.0, rng.uniform(0.5, 2)],
                      "eps": rng.uniform(0, 1)}
            job = {**base, "system": system, "initial_state": {"q": [0.5, -0.2], "p": [0.0, 0.1]}}
            if rng.random() < 0.4:
                job["load"] = self._load(rng, 2)
            return job
        if kind == "chain":
            n = rng.randint(4, 512)
            bond = rng.choice(("fput", "harmonic", "toda", "morse"))
            system = {"kind": "chain", "n": n, "bond": bond}
            return {**base, "system": system, "initial_state": {"mode": rng.randint(1, n), "amplitude": 0.1}}
        if kind == "events":
            return {**base, "model": "damped_pendulum", "parameters": {"eps": rng.uniform(0, 0.2)},
                    "initial_state": {"q": [2.0], "p": [0.0]},
                    "events": [{"g": "q[0]", "direction": rng.choice((-1, 0, 1)), "terminal": rng.random() < 0.3}]}
        if kind == "springs":
            springs = [{"dofs": [0], "material": {"kind": "bilinear", "k": 100.0, "fy": 2.0, "b": 0.05}},
                       {"dofs": [0, 1], "material": {"kind": "bilinear", "k": 80.0, "fy": 1.5, "b": 0.1}}]
            system = {"kind": "structure", "M": {"diagonal": [1.0, 1.0]}, "springs": springs, "alpha": 0.3}
            job = {**base, "system": system, "initial_state": {"rest": True}, "method": "3s",
                   "envelope": rng.sample(["drift", "force", "displacement", "residual_drift"], 2)}
            if rng.random() < 0.5:
                job["load"] = {"harmonic": {"amplitude": [30.0, 30.0], "omega": 6.0, "t_end": 1.5}}
            else:
                job["ground_motion"] = self._ground(rng, 2)
            if rng.random() < 0.3:
                job["collapse"] = rng.uniform(0.05, 1.0)
            return job
        n = rng.choice(tuple(self.matrices) if kind == "file structure" and self.matrices else (3, 8))
        k = rng.uniform(10, 1000)
        if kind == "file structure" and n in self.matrices:
            stiffness = {"file": self.matrices[n]}
        else:
            rows = list(range(n)) + list(range(1, n)) + list(range(n - 1))
            cols = list(range(n)) + list(range(n - 1)) + list(range(1, n))
            stiffness = {"coo": {"shape": [n, n], "rows": rows, "cols": cols,
                                 "values": [2 * k] * n + [-k] * (2 * n - 2)}}
        system = {"kind": "linear_structure", "M": {"diagonal": [1.0] * n}, "K": stiffness,
                  "alpha": rng.uniform(0, 0.5), "beta": rng.uniform(0, 1e-3)}
        job = {**base, "system": system, "initial_state": {"rest": True}}
        if rng.random() < 0.5:
            job["load"] = self._load(rng, n)
        else:
            job["ground_motion"] = self._ground(rng, n)
        return job

    def _sweep(self, rng: random.Random) -> dict:
        job = {"model": "damped_pendulum", "method": rng.choice(("3s", "2s")), "h": 0.05,
               "n_steps": rng.randint(10, 400), "initial_state": {"q": [1.0], "p": [0.0]}}
        grid = rng.choice(({"eps": [0.0, 0.05, 0.1, 0.2]}, {"eps": {"start": 0.0, "stop": 0.5, "num": 6}}))
        return {"job": job, "grid": grid}

    def _forget_files(self, text: str) -> None:
        with self._lock:
            self.records = [file_id for file_id in self.records if file_id not in text]
            self.matrices = {n: file_id for n, file_id in self.matrices.items() if file_id not in text}

    # ---- reading back ----
    def _wait(self, client: httpx.Client, path: str, deadline: float) -> dict | None:
        while time.monotonic() < deadline and not self.stop.is_set():
            response = self._answer("poll", client.get(path))
            if response.status_code != 200:
                return None
            view = response.json()
            if view["status"] in FINISHED:
                return view
            time.sleep(0.05)
        return None

    def _read(self, client: httpx.Client, rng: random.Random, job_id: str, view: dict, kind: str) -> None:
        with self._lock:
            self.finished[(kind, view["status"])] += 1
        if view["status"] == "failed":
            self._finding(f"a valid {kind} job failed: {view.get('error')} (spec {str(view['spec'])[:300]})")
        if not view.get("trajectory"):
            return
        path = f"/v1/jobs/{job_id}"
        self._answer("trajectory", client.get(path + "/trajectory", params={"every": rng.choice((1, 3, 50))}))
        fmt = rng.choice(("csv", "npz", "netcdf"))
        self._answer(f"trajectory {fmt}", client.get(path + "/trajectory", params={"format": fmt}))
        plot = rng.choice(("energy", "phase"))
        self._answer(f"plot {plot}", client.get(f"{path}/plots/{plot}.png", params={"width": 300, "height": 200}))
        if view["spec"].get("events"):
            self._answer("events.csv", client.get(path + "/events.csv"))
        if rng.random() < 0.3:
            self._answer("delete job", client.delete(path))

    def worker(self, index: int) -> None:
        rng = random.Random(self.seed * 1000 + index)
        with httpx.Client(base_url=self.base, timeout=120) as client:
            while not self.stop.is_set():
                try:
                    self._one(client, rng)
                except httpx.HTTPError as error:  # the server going away ends the run; anything else is a finding
                    if not self.stop.is_set():
                        self._finding(f"transport: {type(error).__name__}: {error}")
                        time.sleep(0.5)

    def _one(self, client: httpx.Client, rng: random.Random) -> None:
        roll = rng.random()
        if roll < 0.12 or not self.records:
            self._upload(client, rng)
            return
        if roll < 0.2:
            response = self._answer("post sweep", client.post("/v1/sweeps", json=self._sweep(rng)))
            if response.status_code == 202:
                sweep_id = response.json()["id"]
                view = self._wait(client, f"/v1/sweeps/{sweep_id}", time.monotonic() + 120)
                if view is not None:
                    with self._lock:
                        self.finished[("sweep", view["status"])] += 1
                    if view["status"] == "completed":
                        self._answer("sweep result", client.get(f"/v1/sweeps/{sweep_id}/result"))
            elif response.status_code != 429:
                self._finding(f"a valid sweep: {response.status_code} {response.text[:300]}")
            return
        kind, job = ("built-in", self._builtin(rng)) if roll < 0.55 else ("system", self._system(rng))
        response = self._answer(f"post {kind}", client.post("/v1/jobs", json=job))
        if response.status_code == 422 and kind == "built-in":
            return  # a method the model cannot take (an implicit one on a model without its Hessian): the catalogue's
        if response.status_code == 422 and "no uploaded file with id" in response.text:
            self._forget_files(response.text)  # deleted meanwhile (by the fuzzer's DELETEs): a right answer
            return
        if response.status_code != 202:
            if response.status_code != 429:
                self._finding(f"a valid {kind} job: {response.status_code} {response.text[:400]} ({str(job)[:300]})")
            return
        job_id = response.json()["id"]
        view = self._wait(client, f"/v1/jobs/{job_id}", time.monotonic() + 120)
        if view is not None:
            self._read(client, rng, job_id, view, kind)

    def run(self, seconds: float, threads: int = 2) -> None:
        workers = [threading.Thread(target=self.worker, args=(k,), daemon=True) for k in range(threads)]
        for thread in workers:
            thread.start()
        self.stop.wait(seconds)
        self.stop.set()
        for thread in workers:
            thread.join(timeout=180)

    def report(self) -> str:
        total = sum(self.answers.values())
        errors = sum(n for (_, status), n in self.answers.items() if status >= 500)
        jobs = sum(n for (kind, _), n in self.finished.items() if kind != "sweep")
        sweeps = sum(n for (kind, status), n in self.finished.items() if kind == "sweep" and status == "completed")
        by_status = Counter()
        for (_, status), n in self.answers.items():
            by_status[status] += n
        lines = [f"valid traffic: {total} requests ({', '.join(f'{s} x{n}' for s, n in sorted(by_status.items()))}), "
                 f"{errors} server errors; {jobs} jobs finished, {sweeps} sweeps completed",
                 "  jobs by kind and final status: " + ", ".join(f"{k} {s} x{n}" for (k, s), n in
                                                                  sorted(self.finished.items())),
                 "  refusals: " + (", ".join(f"{what} {status} x{n}" for (what, status), n in
                                             sorted(self.answers.items()) if 400 <= status < 500) or "none"),
                 f"  findings: {len(self.findings)}"]
        lines += [f"    {text}" for text in sorted(set(self.findings))[:30]]
        return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", required=True)
    parser.add_argument("--seconds", type=float, default=60)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    traffic = ValidTraffic(args.base, args.seed)
    traffic.run(args.seconds, args.threads)
    print(traffic.report())


if __name__ == "__main__":
    main()
