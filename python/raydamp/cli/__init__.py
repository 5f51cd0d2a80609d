"""The ``raydamp`` command line.

commands.py builds the parser and hands each command to its module: run_command.py (``raydamp
run``: a job file in this process), sweep_command.py (``raydamp sweep``: a grid over Dask),
service_client.py (``raydamp jobs``/``sweeps``: a running service over HTTP); external.py finds
the commands other packages add through entry points (``raydamp serve``, from raydamp_service).
"""

from .commands import main

__all__ = ["main"]
