"""A real `python -m raydamp_service` process per test (or per module), on a free loopback port.

The service is tested as it runs in production: its own process, uvicorn, SQLite on disk,
worker threads, signals. Every wait is bounded and generous, so a loaded machine is slow,
not red.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

# Run the service from this checkout, whether or not the package is installed.
SERVICE_DIR = Path(__file__).resolve().parents[2] / "service"
if str(SERVICE_DIR) not in sys.path:
    sys.path.insert(0, str(SERVICE_DIR))
# And so do the check processes of an app a test makes in this process: Python 3.11's forkserver does not
# take its parent's sys.path (it finds modules by PYTHONPATH), and would import an installed copy, older
# than the checkout until `make setup` runs again.
if str(SERVICE_DIR) not in os.environ.get("PYTHONPATH", "").split(os.pathsep):
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(SERVICE_DIR), os.environ.get("PYTHONPATH")]))

START_TIMEOUT = 180.0  # seconds for a process to answer /healthz (at load 16-25 a start took over 60 s)
JOB_TIMEOUT = 120.0    # seconds for a job to reach the awaited state
POLL = 0.05


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def service_env(**env: str) -> dict[str, str]:
    return {**os.environ, **env}  # PYTHONPATH names the checkout's service (above)


def _run_service(*args: str, timeout: float = 60.0, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "raydamp_service", *args], env=service_env(**env),
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture
def run_service():
    """run_service(*args, **env): run `python -m raydamp_service ARGS` expecting it to refuse to start."""
    return _run_service


class Server:
    """One service process on a database; restartable on the same database."""

    def __init__(self, db: Path, log: Path, env: dict[str, str]):
        self.db = db
        self.log = log
        self.env = env
        self.process: subprocess.Popen | None = None
        # The client sends the token when the server has one.
        self.headers = {"Authorization": f"Bearer {env['RAYDAMP_TOKEN']}"} if "RAYDAMP_TOKEN" in env else {}
        self.client: httpx.Client | None = None

    def start(self) -> Server:
        for _ in range(3):  # another process may take the free port before we bind it
            port = _free_port()
            env = service_env(**self.env, RAYDAMP_DB=str(self.db))
            with self.log.open("ab") as log:
                self.process = subprocess.Popen([sys.executable, "-m", "raydamp_service", "--port", str(port)],
                                                env=env, stdout=log, stderr=subprocess.STDOUT)
            self.port = port
            self.client = httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30.0, headers=self.headers)
            if self._wait_healthy():
                return self
            self.client.close()
        raise RuntimeError(f"the service did not start; its log:\n{self.log.read_text()[-4000:]}")

    def _wait_healthy(self) -> bool:
        deadline = time.monotonic() + START_TIMEOUT
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                return False
            try:
                if self.client.get("/healthz").status_code == 200:
                    return True
            except httpx.TransportError:
                pass
            time.sleep(0.1)
        self.kill()
        return False

    def stop(self) -> None:
        """SIGTERM: uvicorn's graceful shutdown, which runs the app's lifespan exit."""
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=30)
        self._close_client()

    def kill(self) -> None:
        """SIGKILL: a crash, no shutdown code runs."""
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGKILL)
            self.process.wait(timeout=30)
        self._close_client()

    def restart(self) -> Server:
        self.stop()
        return self.start()

    def _close_client(self) -> None:
        if self.client is not None:
            self.client.close()

    # ---- helpers for tests ----

    def submit(self, spec: dict) -> str:
        response = self.client.post("/v1/jobs", json=spec)
        assert response.status_code == 202, response.text
        return response.json()["id"]

    def job(self, job_id: str) -> dict:
        response = self.client.get(f"/v1/jobs/{job_id}")
        assert response.status_code == 200, response.text
        return response.json()

    def wait_for(self, job_id: str, predicate, timeout: float = JOB_TIMEOUT) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            job = self.job(job_id)
            if predicate(job):
                return job
            if time.monotonic() > deadline:
                raise AssertionError(f"job {job_id} did not get there in {timeout} s; last seen: {job}")
            time.sleep(POLL)

    def wait_finished(self, job_id: str, timeout: float = JOB_TIMEOUT) -> dict:
        return self.wait_for(job_id, lambda job: job["status"] in {"completed", "failed", "cancelled"}, timeout)

    def wait_for_sweep(self, sweep_id: str, timeout: float = JOB_TIMEOUT) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            view = self.client.get(f"/v1/sweeps/{sweep_id}").json()
            if view["status"] in {"completed", "failed", "cancelled"}:
                return view
            if time.monotonic() > deadline:
                raise AssertionError(f"sweep {sweep_id} did not finish in {timeout} s; last seen: {view}")
            time.sleep(POLL)


@pytest.fixture
def start_server(tmp_path: Path) -> Iterator:
    """Factory: start_server(db=None, **env) -> a running Server; all are stopped at teardown."""
    servers: list[Server] = []

    def start(db: Path | None = None, **env: str) -> Server:
        server = Server(db or tmp_path / "var" / "raydamp.sqlite3", tmp_path / f"server{len(servers)}.log", env)
        servers.append(server)
        return server.start()

    yield start
    for server in servers:
        server.stop()


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """One process shared by a module's small tests; runs of up to 10^10 steps are allowed for cancelling."""
    tmp = tmp_path_factory.mktemp("service")
    server = Server(tmp / "raydamp.sqlite3", tmp / "server.log", {"RAYDAMP_MAX_STEPS": str(10**10)}).start()
    yield server
    server.stop()


@pytest.fixture(scope="module")
def module_server(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """One process shared by a module, with the module's SERVER_ENV settings."""
    tmp = tmp_path_factory.mktemp("service")
    server = Server(tmp / "raydamp.sqlite3", tmp / "server.log", dict(getattr(request.module, "SERVER_ENV", {})))
    yield server.start()
    server.stop()


@pytest.fixture(scope="module")
def start_module_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    """start_server for a module's shared process whose settings are known only at run time (an address)."""
    tmp = tmp_path_factory.mktemp("service")
    servers: list[Server] = []

    def start(**env: str) -> Server:
        server = Server(tmp / f"raydamp{len(servers)}.sqlite3", tmp / f"server{len(servers)}.log", env)
        servers.append(server)
        return server.start()

    yield start
    for server in servers:
        server.stop()


@pytest.fixture
def store(tmp_path):
    """A job store in a fresh database, opened, closed after the test (in-process tests of the store)."""
    from raydamp_service.kinds.jobs import JobStore

    store = JobStore(tmp_path / "jobs.sqlite3")
    store.open()
    yield store
    store.close()
