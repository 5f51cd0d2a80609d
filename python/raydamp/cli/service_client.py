"""``raydamp jobs ...`` and ``raydamp sweeps ...``: list, show, cancel, delete and download the
jobs and sweeps of a running service (``raydamp serve``) from a terminal. Plain HTTP through the
standard library; the service's address from --url or RAYDAMP_URL, its token from --token or
RAYDAMP_TOKEN. Exit codes: 0 done, 1 the service refused (its message printed), 2 no service."""

from __future__ import annotations

import json
import os
import sys
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

__all__ = ["client_command", "add_client_commands"]

_DEFAULT_URL = "http://127.0.0.1:8000"
_PIECE = 1 << 20


def add_client_commands(commands) -> None:
    """The jobs and sweeps subcommands, on the command line's subparsers (commands.py)."""
    for kind in ("jobs", "sweeps"):
        one = kind[:-1]
        parser = commands.add_parser(kind, help=f"list, show, cancel, delete or download the {kind} of a running "
                                                "service")
        parser.add_argument("--url", help=f"the service (default: RAYDAMP_URL or {_DEFAULT_URL})")
        parser.add_argument("--token", help="bearer token (default: RAYDAMP_TOKEN)")
        actions = parser.add_subparsers(dest="action", required=True)
        listing = actions.add_parser("list", help=f"newest {kind} first")
        listing.add_argument("--status", choices=["queued", "running", "completed", "failed", "cancelled"])
        listing.add_argument("--limit", type=int, default=20)
        for action, text in (("show", "its status and summary as JSON"), ("cancel", f"stop a queued or running {one}"),
                             ("delete", f"remove a finished {one} with its results (or cancel a running one)")):
            actions.add_parser(action, help=text).add_argument("id")
        fetch = actions.add_parser("fetch", help="download its results to a file")
        fetch.add_argument("id")
        fetch.add_argument("--out", required=True, help="the file: .nc" + (", .npz, .csv or .json" if kind == "jobs"
                                                                            else ""))


class _Refused(Exception):
    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


def _request(base: str, token: str | None, method: str, path: str, params: dict | None = None):
    url = base.rstrip("/") + path + ("?" + urllib.parse.urlencode(params) if params else "")
    request = urllib.request.Request(url, method=method, headers={"Accept": "application/json"})
    if token:
        request.add_header("Authorization", f"Bearer {token}")
    try:
        return urllib.request.urlopen(request, timeout=60)
    except urllib.error.HTTPError as error:
        body = error.read().decode("utf-8", "replace")
        try:
            detail = json.loads(body).get("detail", body)
        except (json.JSONDecodeError, AttributeError):
            detail = body
        raise _Refused(error.code, detail if isinstance(detail, str) else json.dumps(detail)) from None


def _json(response) -> dict | None:
    with response:
        body = response.read()
    return json.loads(body) if body else None


_FORMATS = {".nc": "netcdf", ".npz": "npz", ".csv": "csv", ".json": "json"}


def client_command(args) -> int:
    kind = args.command
    base = args.url or os.environ.get("RAYDAMP_URL") or _DEFAULT_URL
    token = args.token or os.environ.get("RAYDAMP_TOKEN")
    root = f"/v1/{kind}"
    try:
        if args.action == "list":
            params = {"limit": args.limit, **({"status": args.status} if args.status else {})}
            rows = _json(_request(base, token, "GET", root, params))[kind]
            for row in rows:
                what = row.get("model", f"{row.get('members')} members")
                extra = f"  {row['method']}" if "method" in row else ""
                print(f"{row['id']}  {row['status']:<9} {100 * row['progress']:5.1f}%  {what}{extra}  "
                      f"{row['created_at']}")
            if not rows:
                print(f"no {kind}")
        elif args.action == "show":
            print(json.dumps(_json(_request(base, token, "GET", f"{root}/{args.id}")), indent=2))
        elif args.action == "cancel":
            view = _json(_request(base, token, "POST", f"{root}/{args.id}/cancel"))
            print(f"{args.id}: {view['status']} (cancel requested)")
        elif args.action == "delete":
            response = _request(base, token, "DELETE", f"{root}/{args.id}")
            print(f"{args.id}: removed" if response.status == 204 else
                  f"{args.id}: {_json(response)['status']}, cancel requested; delete again once it has stopped")
        elif args.action == "fetch":
            suffix = Path(args.out).suffix.lower()
            allowed = _FORMATS if kind == "jobs" else {".nc": "netcdf"}
            if suffix not in allowed:
                print(f"raydamp {kind} fetch: --out: unknown format {suffix!r} (known: {', '.join(allowed)})",
                      file=sys.stderr)
                return 2
            path = f"{root}/{args.id}/trajectory" if kind == "jobs" else f"{root}/{args.id}/result"
            response = _request(base, token, "GET", path, {"format": allowed[suffix]})
            written = 0
            with response, open(args.out, "wb") as out:
                while piece := response.read(_PIECE):
                    out.write(piece)
                    written += len(piece)
            print(f"wrote {args.out} ({written} bytes)")
    except _Refused as refused:
        print(f"raydamp {kind} {args.action}: the service answered {refused.status}: {refused}", file=sys.stderr)
        return 1
    except (urllib.error.URLError, OSError) as error:
        reason = getattr(error, "reason", error)
        print(f"raydamp {kind} {args.action}: no service at {base} ({reason}); start one with `raydamp serve` "
              "or give --url", file=sys.stderr)
        return 2
    return 0
