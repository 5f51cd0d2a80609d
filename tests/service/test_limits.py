"""Admission limits against a real service: body size before parsing, the queue bound, time overflow,
and 422s that survive hostile input. Each case is a reproducer from the service audit (issue 9)."""

from __future__ import annotations

import contextlib
import json
import math
import socket
from concurrent.futures import ThreadPoolExecutor

import httpx

PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.2,
            "t_end": 200, "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}
LONG_RUN = {**{k: v for k, v in PENDULUM.items() if k != "t_end"}, "step_size": 0.001, "n_steps": 4 * 10**9,
            "save_every": 10**6}
JSON = {"content-type": "application/json"}
# 10^5 steps: not a quick run (JobWork.quick, which has a lane of its own), so it waits in the queue.
NOT_QUICK = {**PENDULUM, "t_end": 20_000}


def six_megabytes() -> bytes:
    """A syntactically valid spec padded to 6 MB with a list of 600,000 short strings."""
    return json.dumps({**PENDULUM, "padding": ["0123456"] * 600_000}).encode()


def test_a_6_mb_body_is_413_naming_the_limit_before_parsing(server):
    body = six_megabytes()
    assert len(body) > 6_000_000
    # The 2 s budget is the audit's: before, a 1 MB body stalled every client for 5.7 s.
    with httpx.Client(base_url=str(server.client.base_url), timeout=2.0) as client:
        response = client.post("/v1/jobs", content=body, headers=JSON)
    assert response.status_code == 413, response.text[:300]
    assert "max_body_bytes = 2097152" in response.json()["detail"]
    assert server.client.get("/healthz").status_code == 200


def test_a_chunked_body_is_counted_as_it_arrives(server):
    body = six_megabytes()

    def chunks():  # no Content-Length: the guard must count the bytes itself
        for start in range(0, len(body), 65536):
            yield body[start:start + 65536]

    before = len(server.client.get("/v1/jobs", params={"limit": 1000}).json()["jobs"])
    with httpx.Client(base_url=str(server.client.base_url), timeout=10.0) as client:
        response = client.post("/v1/jobs", content=chunks(), headers=JSON)
    assert response.status_code == 413, response.text[:300]
    assert len(server.client.get("/v1/jobs", params={"limit": 1000}).json()["jobs"]) == before


def test_a_body_just_under_the_limit_is_parsed(server):
    spec = {**PENDULUM, "padding": "x" * (2 * 2**20 - 1000)}
    response = server.client.post("/v1/jobs", json=spec)
    assert response.status_code == 422  # reached validation: the padding field is unknown
    assert response.json()["detail"][0]["loc"] == ["body", "padding"]
    assert len(response.content) < 10_000  # the 2 MB string is not echoed whole


def test_a_list_of_200_000_bad_items_is_one_short_422(server):
    # The audit's 1 MB body of 200,000 strings: it stalled every client and came back as 22.9 MB of errors.
    body = json.dumps({**PENDULUM, "initial_state": {"q": ["x"] * 200_000, "p": [0.0]}}).encode()
    assert len(body) < 2 * 2**20  # under the body limit: the schema's own bound must catch it
    response = server.client.post("/v1/jobs", content=body, headers=JSON)
    assert response.status_code == 422
    detail = response.json()["detail"]
    assert [error["loc"] for error in detail] == [["body", "initial_state", "q"]] and detail[0]["type"] == "too_long"
    assert len(response.content) < 5_000


def test_a_lone_surrogate_model_name_is_422_not_500(server):
    body = json.dumps({**PENDULUM, "model": "\ud800"}).encode()  # ensure_ascii writes the escape \\ud800
    response = server.client.post("/v1/jobs", content=body, headers=JSON)
    assert response.status_code == 422, response.text[:300]
    assert response.json()["detail"][0]["loc"][:2] == ["body", "model"]


def test_a_run_whose_time_overflows_is_refused_naming_step_size(server):
    spec = {**{k: v for k, v in PENDULUM.items() if k != "t_end"}, "step_size": 1e308, "n_steps": 1000}
    response = server.client.post("/v1/jobs", json=spec)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert detail[0]["loc"] == ["body", "step_size"] and "finite" in detail[0]["msg"]
    # A finite product runs and ends at a finite time (from rest at the bottom, so the state stays finite).
    job_id = server.submit({**spec, "step_size": 1e305, "initial_state": {"q": [0.0], "p": [0.0]}})
    job = server.wait_finished(job_id)
    assert job["status"] == "completed" and job["summary"]["t_final"] == 1e305 * 1000


def test_the_queue_bound_answers_429_with_retry_after(start_server):
    server = start_server(RAYDAMP_WORKERS="1", RAYDAMP_MAX_QUEUED="2", RAYDAMP_MAX_STEPS=str(10**10))
    running = server.submit(LONG_RUN)
    server.wait_for(running, lambda job: job["status"] == "running")
    queued = [server.submit(NOT_QUICK) for _ in range(2)]
    response = server.client.post("/v1/jobs", json=NOT_QUICK)
    assert response.status_code == 429, response.text
    assert response.headers["retry-after"] == "5"
    assert "max_queued" in response.json()["detail"]
    assert len(server.client.get("/v1/jobs").json()["jobs"]) == 3  # the refused job was not stored

    server.client.post(f"/v1/jobs/{queued[0]}/cancel")  # room for one more
    assert server.client.post("/v1/jobs", json=NOT_QUICK).status_code == 202
    server.client.post(f"/v1/jobs/{running}/cancel")
    assert server.wait_finished(running)["status"] == "cancelled"


def test_concurrent_submissions_never_pass_the_bound(start_server):
    server = start_server(RAYDAMP_WORKERS="1", RAYDAMP_MAX_QUEUED="5", RAYDAMP_MAX_STEPS=str(10**10))
    running = server.submit(LONG_RUN)
    server.wait_for(running, lambda job: job["status"] == "running")
    def post(_):
        with httpx.Client(base_url=str(server.client.base_url), timeout=30.0) as client:
            return client.post("/v1/jobs", json=NOT_QUICK).status_code

    with ThreadPoolExecutor(8) as pool:
        codes = list(pool.map(post, range(24)))
    assert codes.count(202) == 5 and codes.count(429) == 19, codes
    server.client.post(f"/v1/jobs/{running}/cancel")


def test_large_bodies_are_handled_a_few_at_once(tmp_path):
    """A body's parse and validation hold the event loop (70 ms for a 1.7 MB structure): thirty such POSTs at
    once held /healthz for 2.9 s (an audit). max_large_bodies of them are handled at once; another gets 429
    at once, and small bodies pass meanwhile. In-process, around an app that holds each body it gets."""
    import asyncio

    from raydamp_service.config import Settings
    from raydamp_service.edge.guard import RequestGuard

    async def scenario():
        release, holding = asyncio.Event(), []

        async def app(scope, receive, send):
            while (await receive()).get("more_body"):
                pass
            holding.append(scope["path"])
            await release.wait()
            await send({"type": "http.response.start", "status": 200, "headers": []})
            await send({"type": "http.response.body", "body": b"{}"})

        guard = RequestGuard(app, Settings(db=tmp_path / "jobs.sqlite3", large_body_bytes=1000, max_large_bodies=2))
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=guard), base_url="http://127.0.0.1") as client:
            large = [asyncio.create_task(client.post("/v1/jobs", content=b"x" * 2000)) for _ in range(2)]
            while len(holding) < 2:
                await asyncio.sleep(0.001)
            third = await client.post("/v1/jobs", content=b"x" * 2000)
            small = asyncio.create_task(client.post("/v1/jobs", content=b"x" * 100))
            while len(holding) < 3:  # the small one reached the app beside the two large ones
                await asyncio.sleep(0.001)
            release.set()
            done = [await task for task in (*large, small)]
            again = await client.post("/v1/jobs", content=b"x" * 2000)  # both slots given back
        return third, done, again, guard.large_bodies

    third, done, again, left = asyncio.run(scenario())
    assert third.status_code == 429 and third.headers["retry-after"] == "5", third.text
    assert "max_large_bodies" in third.json()["detail"]
    assert [r.status_code for r in done] == [200, 200, 200] and again.status_code == 200 and left == 0


@contextlib.contextmanager
def _half_sent(port: int, count: int, start: bytes):
    """count connections that sent start and nothing more; closed at the end whatever happened (a socket left
    open failed a later test with its ResourceWarning)."""
    connections = []
    try:
        for _ in range(count):
            connections.append(socket.create_connection(("127.0.0.1", port)))
            connections[-1].sendall(start)
        yield connections
    finally:
        for connection in connections:
            connection.close()


def test_a_body_that_does_not_arrive_is_408_and_gives_back_its_place(start_server):
    """Two uploads that announced 300 KiB and sent nothing held both max_large_bodies places for as long as
    their connections lived: every honest large request got 429 (a service audit). Past body_seconds each
    gets 408, and a large request then passes."""
    import time

    server = start_server(RAYDAMP_BODY_SECONDS="1")
    with _half_sent(server.port, 2, b"POST /v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json"
                                    b"\r\nContent-Length: 307200\r\n\r\n{") as idle:
        time.sleep(0.3)
        big = {"model": "damped_pendulum", "h": 0.1, "n_steps": 10, "initial_state": {"q": [1.0], "p": [0.0]},
               "name_padding": "x" * 300_000}
        assert server.client.post("/v1/jobs", json=big).status_code == 429  # both places held meanwhile
        for connection in idle:
            connection.settimeout(10)
            answer = b""
            while piece := connection.recv(4096):  # the headers and the body may come apart; then the close
                answer += piece
            assert answer.startswith(b"HTTP/1.1 408") and b"body_seconds = 1 s" in answer, answer[:300]
    time.sleep(0.1)
    answered = server.client.post("/v1/jobs", json=big)
    assert answered.status_code == 422 and answered.json()["detail"][0]["loc"][-1] == "name_padding", answered.text


def test_half_sent_headers_are_dropped_after_header_seconds(start_server):
    """A connection that sent "G" and nothing more was held for as long as its client liked: two clients with
    10,500 each made the server drop 463 of 731 /healthz probes (a service audit). Past header_seconds it is
    closed; a request whose headers arrived in time is served whatever its length, and keep-alive still works."""
    import time

    server = start_server(RAYDAMP_HEADER_SECONDS="1")
    with _half_sent(server.port, 50, b"G") as half:
        # A keep-alive client whose second request is sent within the deadline of the first response's end.
        with httpx.Client(base_url=f"http://127.0.0.1:{server.port}") as client:
            assert client.get("/healthz").status_code == 200
            time.sleep(0.5)
            assert client.get("/healthz").status_code == 200
        started = time.monotonic()
        for connection in half:
            connection.settimeout(10)
            assert connection.recv(100) == b""  # closed by the server, answering nothing
        assert time.monotonic() - started < 5
    assert server.client.get("/healthz").status_code == 200


def test_a_slow_but_steady_body_is_not_cut_by_the_body_deadline(tmp_path):
    """One deadline for the whole body refused an honest 64 MiB upload over a link under 4.5 Mbit/s (a review):
    each piece received extends it by its bytes at min_body_bytes_per_second. In-process: 10 pieces of 2000 bytes,
    0.15 s apart (13 kB/s), against body_seconds 0.5: at a floor of 10,000 bytes/s each piece buys 0.2 s and the
    body passes; at 20,000 bytes/s (0.1 s a piece) it falls behind and gets 408, as it does with no floor."""
    import asyncio

    from raydamp_service.config import Settings
    from raydamp_service.edge.guard import RequestGuard

    async def scenario(rate: int) -> int:
        async def app(scope, receive, send):
            while (await receive()).get("more_body"):
                pass
            await send({"type": "http.response.start", "status": 200, "headers": []})
            await send({"type": "http.response.body", "body": b"{}"})

        guard = RequestGuard(app, Settings(db=tmp_path / "jobs.sqlite3", body_seconds=0.5,
                                           min_body_bytes_per_second=rate))

        async def pieces():
            for _ in range(10):
                await asyncio.sleep(0.15)
                yield b"x" * 2000

        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=guard), base_url="http://127.0.0.1") as client:
            return (await client.post("/v1/jobs", content=pieces())).status_code

    assert asyncio.run(scenario(10_000)) == 200
    assert asyncio.run(scenario(20_000)) == 408
    assert asyncio.run(scenario(0)) == 408
