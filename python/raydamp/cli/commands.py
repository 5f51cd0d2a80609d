"""The ``raydamp`` command line: its parser, and each command handed to the module that runs it."""

from __future__ import annotations

import argparse
import sys

from .external import add_external_commands, run_external
from .thermal_options import add_thermal_options


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="raydamp", description="raydamp command line")
    commands = parser.add_subparsers(dest="command", required=True)
    rep = commands.add_parser("reproduce", help="run the paper's experiments; write figures and REPORT.md")
    rep.add_argument("--out", required=True, help="directory for the figures and REPORT.md")
    rep.add_argument("--quick", action="store_true", help="reduced time spans (for CI)")
    rep.add_argument("--no-progress", action="store_true", help="no progress bar")
    run = commands.add_parser("run", help="run a job file (the service's job JSON); print a summary")
    run.add_argument("spec", help="a JSON file: model or system, method, h, t_end or n_steps, "
                                  "initial_state, save_every")
    run.add_argument("--out", help="write the solution: .nc (NetCDF), .npz or .csv")
    run.add_argument("--plot", help="draw the energy (and H - H0 + W when recorded) to this PNG")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_thermal_options(run, "an ensemble member i of the same seed draws stream i")
    swp = commands.add_parser("sweep", help="run a grid of jobs over a spec file through Dask; write NetCDF or Zarr")
    swp.add_argument("spec", help="a job JSON file (as for run): the grid's base point")
    swp.add_argument("--grid", action="append", default=[], metavar="NAME=VALUES",
                     help="an axis: name=start:stop:num (ends included; add :log for a geometric range) or "
                          "name=v1,v2,...; name is a model parameter (eps, k, ...), h, method, composition, "
                          "tableau or q0[i]/p0[i]; repeat for more axes (every combination runs)")
    swp.add_argument("--out", help="write the Dataset: .nc (NetCDF) or .zarr (written chunk by chunk)")
    swp.add_argument("--chunk-size", type=int, default=1000, help="members per task (default 1000)")
    swp.add_argument("--scheduler", help="a Dask scheduler's address (default: RAYDAMP_DASK_SCHEDULER, else a "
                                         "LocalCluster on this machine)")
    swp.add_argument("--workers", type=int, default=2, help="worker processes of the LocalCluster (default 2)")
    swp.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_thermal_options(swp, "member k of the sweep draws stream K + k")
    adv = commands.add_parser("advise", help="for a job file's linear structure: each method's stability limit, "
                                             "step and predicted time to reach a tolerance")
    adv.add_argument("spec", help="a job JSON file (as for run) whose system is a linear structure")
    adv.add_argument("--t-end", type=float, help="the span of the run (default: the file's t_end)")
    adv.add_argument("--tolerance", type=float, required=True,
                     help="the error allowed, relative to the initial amplitude (e.g. 1e-6)")
    adv.add_argument("--omega", type=float, help="the circular frequency of the one mode the error model weights "
                                                 "when the file gives no start and no load (default: the lowest "
                                                 "natural frequency); ignored when it does")
    adv.add_argument("--no-measure", action="store_true", help="no trial steps: compare by step counts only")
    from .service_client import add_client_commands

    add_client_commands(commands)
    commands.add_parser("methods", help="list the methods and their tableaux")
    commands.add_parser("models", help="list the built-in models and their parameters")
    external = add_external_commands(commands)
    # An external command parses its own arguments: what this parser does not know is handed to it.
    args, rest = parser.parse_known_args(argv)
    if args.command in external:
        return run_external(args.command, external[args.command], rest)
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    if args.command == "run":
        from .run_command import run_file

        return run_file(args.spec, out=args.out, plot=args.plot, progress=not args.no_progress,
                        temperature=args.temperature, seed=args.seed, stream=args.stream)
    if args.command == "advise":
        from .advise_command import advise_file

        return advise_file(args.spec, t_end=args.t_end, tolerance=args.tolerance, omega=args.omega,
                           measure=not args.no_measure)
    if args.command == "sweep":
        try:
            from .sweep_command import sweep_file
        except ImportError as exc:  # dask, xarray or zarr missing
            print(f"raydamp sweep needs the sweep extra (pip install 'raydamp[sweep]'): {exc}", file=sys.stderr)
            return 2
        return sweep_file(args.spec, args.grid, out=args.out, chunk_size=args.chunk_size, scheduler=args.scheduler,
                          workers=args.workers, progress=not args.no_progress, temperature=args.temperature,
                          seed=args.seed, stream=args.stream)
    if args.command in ("jobs", "sweeps"):
        from .service_client import client_command

        return client_command(args)
    if args.command == "methods":
        from ..methods.catalogue import linear_structure_methods, methods, structure_methods

        # What each method runs: every system, a LinearStructure only (midpoint, gauss4: implicit steps of its
        # whole linear system), or a Structure with springs only (newmark, which methods() lists apart).
        linear_only = linear_structure_methods()
        for m, applies in [*((m, "LinearStructure only" if m.name in linear_only else "any system")
                             for m in methods()),
                           *((m, "Structure with springs only") for m in structure_methods())]:
            print(f"{m.name:<8} {m.tableau or '':<9} order {m.order}  {'damped' if m.damped else 'eps = 0 only'}"
                  f"  [{applies}]  {m.description}")
        return 0
    if args.command == "models":
        from ..systems.models import describe_models

        for model in describe_models():
            params = ", ".join(f"{p['name']}={p['default']}" for p in model["parameters"])
            print(f"{model['name']:<18} dim {model['dim']}  ({params})  {model['description']}")
        return 0
    if args.command == "reproduce":
        from .output_paths import directory_problem

        if problem := directory_problem(args.out):  # before the experiments, which take minutes
            print(f"raydamp reproduce: --out {args.out}: {problem}", file=sys.stderr)
            return 2
        try:
            from ..reproduce import run
        except ImportError as exc:  # matplotlib or scipy missing
            print(f"raydamp reproduce needs the analysis extra (pip install 'raydamp[analysis]'): {exc}",
                  file=sys.stderr)
            return 2
        try:
            claims = run(args.out, quick=args.quick, progress=not args.no_progress)
        except KeyboardInterrupt:  # a traceback before; the figures made so far stay in --out
            print(f"raydamp reproduce: interrupted; the figures made so far are in {args.out} (no REPORT.md)",
                  file=sys.stderr)
            return 130
        failed = [c for c in claims if not c.passed]
        print(f"{len(claims) - len(failed)} of {len(claims)} claims hold; report: {args.out}/REPORT.md")
        for c in failed:
            print(f"  FAIL {c.where}: {c.claim}" + (" (the paper's; the report's note explains it)"
                                                    if c.paper_error else ""))
        # A script or CI running it learns of a claim the code no longer meets from the exit status.
        return 1 if any(not c.paper_error for c in failed) else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
