"""The ``raydamp`` command line."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="raydamp", description="raydamp command line")
    commands = parser.add_subparsers(dest="command", required=True)
    rep = commands.add_parser("reproduce", help="run the paper's experiments; write figures and REPORT.md")
    rep.add_argument("--out", required=True, help="directory for the figures and REPORT.md")
    rep.add_argument("--quick", action="store_true", help="reduced time spans (for CI)")
    rep.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.command == "reproduce":
        try:
            from .reproduce import run
        except ImportError as exc:  # matplotlib or scipy missing
            print(f"raydamp reproduce needs the analysis extra (pip install 'raydamp[analysis]'): {exc}",
                  file=sys.stderr)
            return 2
        claims = run(args.out, quick=args.quick, progress=not args.no_progress)
        failed = [c for c in claims if not c.passed]
        print(f"{len(claims) - len(failed)} of {len(claims)} claims hold; report: {args.out}/REPORT.md")
        for c in failed:
            print(f"  FAIL {c.where}: {c.claim}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
