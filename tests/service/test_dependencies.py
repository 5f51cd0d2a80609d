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
