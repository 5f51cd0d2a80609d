"""`python -m raydamp_service [--host H] [--port P]`: serve the job API with uvicorn."""

from __future__ import annotations

import argparse
import logging

import uvicorn

from .app import create_app
from .config import Settings


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="raydamp-service", description="Serve the raydamp job API.")
    parser.add_argument("--host", help="address to bind (default: RAYDAMP_HOST or 127.0.0.1)")
    parser.add_argument("--port", type=int, help="port to bind (default: RAYDAMP_PORT or 8000)")
    parser.add_argument("--workers", type=int, help="runs executed at once (default: RAYDAMP_WORKERS or 2)")
    args = parser.parse_args(argv)
    # Command-line values win over the environment; absent ones fall back to it.
    overrides = {name: value for name, value in vars(args).items() if value is not None}
    settings = Settings(**overrides)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    # One process only: the job queue and the cancel tokens live in it.
    uvicorn.run(create_app(settings), host=settings.host, port=settings.port)


if __name__ == "__main__":
    main()
