"""Every request dependency of every route is a coroutine, so FastAPI calls it on the event loop.

A plain-function dependency is run in the thread pool: a hop there and back per dependency per
request. Three of them on the submission path (store, runner, settings) cost more than the
submission itself under load (benchmarks/bench_service_load.py: 484 jobs/s and POST p99 67 ms with
them, about 850 jobs/s and p99 40 ms without, on the same client).
"""

from __future__ import annotations

import inspect

from fastapi.routing import APIRoute
from raydamp_service.app import ROUTERS


def _dependency_calls(dependant):
    for sub in dependant.dependencies:
        if sub.call is not None:
            yield sub.call
        yield from _dependency_calls(sub)


def test_every_route_dependency_runs_on_the_event_loop():
    # The routers the application includes (app.ROUTERS), read directly: how FastAPI wraps
    # included routers in app.routes is its own business.
    routes = [route for router in ROUTERS for route in router.routes if isinstance(route, APIRoute)]
    checked = 0
    for route in routes:
        for call in _dependency_calls(route.dependant):
            checked += 1
            assert inspect.iscoroutinefunction(call), (
                f"{route.path}: dependency {call.__qualname__} is a plain function; FastAPI runs it in the "
                "thread pool on every request (make it async def)")
    assert checked >= 20  # the jobs routes alone use the store, runner and settings dependencies


def test_a_submission_hops_to_the_thread_pool_once(tmp_path, monkeypatch):
    """POST /v1/jobs runs its blocking part (checks, insert) in the pool in one hop. As a plain function with a
    response_model it took two: FastAPI validates a plain function's response in the pool too (a hop cost
    about 0.15 ms of the server's CPU per job, benchmarks/bench_service_load.py)."""
    import asyncio
    import math

    import anyio.to_thread
    import httpx
    from raydamp_service.app import create_app
    from raydamp_service.config import Settings

    hops = []
    run_sync = anyio.to_thread.run_sync

    async def counted(func, *args, **kwargs):
        hops.append(getattr(func, "__name__", repr(func)))
        return await run_sync(func, *args, **kwargs)

    spec = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.01, "n_steps": 100,
            "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}

    async def submit() -> httpx.Response:
        app = create_app(Settings(db=tmp_path / "jobs.sqlite3", check_workers=1))
        async with app.router.lifespan_context(app), httpx.AsyncClient(
                transport=httpx.ASGITransport(app=app), base_url="http://127.0.0.1") as client:
            monkeypatch.setattr(anyio.to_thread, "run_sync", counted)
            try:
                return await client.post("/v1/jobs", json=spec)
            finally:
                monkeypatch.setattr(anyio.to_thread, "run_sync", run_sync)

    response = asyncio.run(submit())
    assert response.status_code == 202, response.text
    assert response.headers["location"] == f"/v1/jobs/{response.json()['id']}"
    assert len(hops) == 1, hops
