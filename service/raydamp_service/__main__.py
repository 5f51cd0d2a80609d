"""`python -m raydamp_service [--host H] [--port P]`: serve the job API with uvicorn. `raydamp serve` reaches it
through the entry point ``serve_command`` (group "raydamp.commands"): the library never imports the service."""

from __future__ import annotations

import argparse
import logging
import sys

import uvicorn
from pydantic import ValidationError

from .app import create_app
from .config import Settings, is_loopback
from .edge import deadlines
from .kinds.jobs import JobStore
from .tasks import lock
from .tasks.store import StoreUnavailable


def _refuse(message: str) -> None:
    """One line on stderr and exit status 2: what is wrong and what to do, no traceback."""
    print(f"raydamp-service: {message}", file=sys.stderr)
    sys.exit(2)


def _arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    parser.add_argument("--host", help="address to bind (default: RAYDAMP_HOST or 127.0.0.1)")
    parser.add_argument("--port", type=int, help="port to bind (default: RAYDAMP_PORT or 8000)")
    parser.add_argument("--workers", type=int, help="runs executed at once (default: RAYDAMP_WORKERS or 2)")
    return parser


def serve_command(argv: list[str]) -> int:
    """`raydamp serve [--host H] [--port P] [--workers N]`, checked under its own name, then handed to main."""
    parser = argparse.ArgumentParser(prog="raydamp serve",
                                     description="run the job service (same as python -m raydamp_service)")
    _arguments(parser).parse_args(argv)
    main(argv)
    return 0


def main(argv: list[str] | None = None) -> None:
    args = _arguments(argparse.ArgumentParser(prog="raydamp-service", description="Serve the raydamp job API.")
                      ).parse_args(argv)
    # Command-line values win over the environment; absent ones fall back to it.
    overrides = {name: value for name, value in vars(args).items() if value is not None}
    try:
        settings = Settings(**overrides)
    except ValidationError as error:
        first = error.errors()[0]
        _refuse(f"bad setting RAYDAMP_{str(first['loc'][0]).upper()}: {first['msg']}")
    if not is_loopback(settings.host) and settings.token is None:
        _refuse(f"binding to {settings.host} lets other machines submit, read and cancel jobs: set RAYDAMP_TOKEN "
                "to a secret that clients send as 'Authorization: Bearer <token>', or bind 127.0.0.1")
    try:  # the lock first, and kept (the lifespan counts a second hold); the store opened (again by the lifespan):
        lock.hold(settings.db)  # to refuse here with one line, not a traceback
        store = JobStore(settings.db)
        store.open()
    except (lock.DatabaseInUse, StoreUnavailable) as error:
        _refuse(str(error))
    except OSError as error:  # the lock file's
        _refuse(str(StoreUnavailable(settings.db, error)))
    store.close()
    sys.setswitchinterval(0.001)  # threads serialising trajectories hand the event loop the GIL back sooner
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    # One process only: the job queue and the cancel tokens live in it.
    uvicorn.run(create_app(settings), host=settings.host, port=settings.port, access_log=settings.access_log,
                http=deadlines.protocol(settings.header_seconds))


if __name__ == "__main__":
    main()
