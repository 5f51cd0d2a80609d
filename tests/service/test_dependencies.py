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


def test_a_builtin_submission_never_hops_to_the_thread_pool(tmp_path, monkeypatch):
    """POST /v1/jobs of a built-in model checks it on the event loop (microseconds) and inserts it there (one
    short write): no hop to the thread pool (a hop cost about 0.15 ms of the server's CPU per job,
    benchmarks/bench_service_load.py). A user's system, whose check waits for a check process, hops once.
    Both are answered with a row already stored, and handed to the runner."""
    import asyncio
    import math

    import anyio.to_thread
    import httpx

    from raydamp_service.app import create_app
    from raydamp_service.config import Settings

    hops = []
    run_sync = anyio.to_thread.run_sync

    async def counted(func, *args, **kwargs):
        hops.append(getattr(getattr(func, "func", func), "__name__", repr(func)))  # a partial: its function
        return await run_sync(func, *args, **kwargs)

    builtin = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.01, "n_steps": 100,
               "initial_state": {"q": [0.9 * math.pi], "p": [0.0]}}
    system = {"system": {"coordinates": ["x"], "potential": "x^2/2", "mass": 1.0, "eps": 0.1,
                         "damping": {"dampers": [{"on": "x", "c": 1.0}]}},
              "method": "3s", "h": 0.01, "n_steps": 100, "initial_state": {"q": [1.0], "p": [0.0]}}

    async def submit() -> list[tuple[httpx.Response, list[str], dict]]:
        app = create_app(Settings(db=tmp_path / "jobs.sqlite3", check_workers=1))
        answers = []
        async with app.router.lifespan_context(app), httpx.AsyncClient(
                transport=httpx.ASGITransport(app=app), base_url="http://127.0.0.1") as client:
            for spec in (builtin, system):
                hops.clear()
                monkeypatch.setattr(anyio.to_thread, "run_sync", counted)
                try:
                    response = await client.post("/v1/jobs", json=spec)
                finally:
                    monkeypatch.setattr(anyio.to_thread, "run_sync", run_sync)
                # Read straight from the file through a connection of its own: committed, not only written.
                import sqlite3
                with sqlite3.connect(tmp_path / "jobs.sqlite3") as db:
                    stored = dict(db.execute("SELECT id, status FROM jobs").fetchall())
                answers.append((response, list(hops), stored))
        return answers

    (built, built_hops, stored_first), (checked, checked_hops, stored_both) = asyncio.run(submit())
    assert built.status_code == 202, built.text
    assert built.headers["location"] == f"/v1/jobs/{built.json()['id']}"
    assert built_hops == []
    assert built.json()["id"] in stored_first
    assert checked.status_code == 202, checked.text
    assert checked_hops == ["_check"]
    assert set(stored_both) == {built.json()["id"], checked.json()["id"]}
