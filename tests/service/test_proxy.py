"""The README's reverse-proxy example, run: nginx (Debian's) in front of a real server, with the README's block as
written but for its ports and a header deadline of one second. Skipped where nginx is not installed."""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import time
from pathlib import Path

import httpx
import pytest

NGINX = shutil.which("nginx") or next((p for p in ("/usr/sbin/nginx",) if os.access(p, os.X_OK)), None)
README = Path(__file__).resolve().parents[2] / "README.md"
pytestmark = pytest.mark.skipif(NGINX is None, reason="nginx is not installed (apt-get install -y nginx)")


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _readme_block() -> str:
    return re.search(r"```nginx\n(.*?)```", README.read_text(), re.S).group(1)


@pytest.fixture
def proxied(start_server, tmp_path):
    server = start_server(RAYDAMP_MAX_STEPS=str(10**10))
    port = _free_port()
    block = _readme_block()
    for old, new in (("listen 80;", f"listen 127.0.0.1:{port};"), (":8000;", f":{server.port};"),
                     ("client_header_timeout 10s;", "client_header_timeout 1s;")):
        assert old in block, old
        block = block.replace(old, new)
    (tmp_path / "logs").mkdir()
    conf = tmp_path / "nginx.conf"
    conf.write_text(f"{'user root;' if os.getuid() == 0 else ''}\nworker_processes 1;\npid {tmp_path}/nginx.pid;\n"
                    f"error_log {tmp_path}/logs/error.log;\nevents {{}}\nhttp {{\naccess_log off;\n"
                    + "".join(f"{kind}_temp_path {tmp_path}/{kind};\n" for kind in
                              ("client_body", "proxy", "fastcgi", "uwsgi", "scgi"))
                    + block + "}\n")
    log = (tmp_path / "logs" / "stderr.log").open("wb")
    nginx = subprocess.Popen([NGINX, "-p", str(tmp_path), "-c", str(conf), "-g", "daemon off;"], stderr=log)
    client = httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30.0)
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                if client.get("/healthz").status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert nginx.poll() is None, (tmp_path / "logs" / "stderr.log").read_text()
            assert time.monotonic() < deadline, "nginx did not answer within 30 s"
            time.sleep(0.1)
        yield server, client, port
    finally:
        client.close()
        nginx.terminate()
        nginx.wait(timeout=30)
        log.close()


def test_the_readme_proxy_serves_jobs_and_bounds_slow_and_large_requests(proxied):
    server, client, port = proxied
    spec = {"model": "damped_pendulum", "h": 0.1, "n_steps": 100, "initial_state": {"q": [1.0], "p": [0.0]}}
    submitted = client.post("/v1/jobs", json=spec)
    assert submitted.status_code == 202, submitted.text
    job = server.wait_finished(submitted.json()["id"])
    assert job["status"] == "completed"
    through = client.get(f"/v1/jobs/{job['id']}/trajectory").json()
    assert through == server.client.get(f"/v1/jobs/{job['id']}/trajectory").json() and len(through["t"]) == 101
    # A body over client_max_body_size is refused by nginx, before the service sees a byte of it.
    assert client.post("/v1/files", content=b"x" * (66 * 2**20)).status_code == 413
    # Half-sent headers: nginx closes the connection after client_header_timeout (1 s here).
    with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:  # a recv past 30 s fails the test
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n")
        answer = b""
        while piece := sock.recv(4096):
            answer += piece
    assert answer == b"" or b" 408 " in answer, answer
