"""``raydamp jobs ...`` and ``raydamp sweeps ...``: list, show, cancel, delete and download the
jobs and sweeps of a running service (``raydamp serve``) from a terminal. Plain HTTP through the
standard library; the service's address from --url or RAYDAMP_URL, its token from --token or
RAYDAMP_TOKEN. Exit codes: 0 done, 1 the service refused (its message printed) or its reply was
unusable (not JSON, a download cut short: the file named by --out is then left as it was), 2 no
service, or a bad argument (--url, --limit, --out)."""

from __future__ import annotations

import argparse
import http.client
import json
import os
import secrets
import sys
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

from .output_paths import file_problem

__all__ = ["client_command", "add_client_commands"]

_DEFAULT_URL = "http://127.0.0.1:8000"
_PIECE = 1 << 20


def _limit(text: str) -> int:
    try:
        value = int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


def add_client_commands(commands) -> None:
    """The jobs and sweeps subcommands, on the command line's subparsers (commands.py)."""
    for kind in ("jobs", "sweeps"):
        one = kind[:-1]
        parser = commands.add_parser(kind, help=f"list, show, cancel, delete or download the {kind} of a running "
                                                "service")
        url_help = f"the service (default: RAYDAMP_URL or {_DEFAULT_URL})"
        token_help = "bearer token (default: RAYDAMP_TOKEN)"
        parser.add_argument("--url", help=url_help)
        parser.add_argument("--token", help=token_help)
        # Also after the action (`jobs fetch ID --url U`): argparse gives each subparser its own options, and
        # SUPPRESS leaves the value given before the action in place when none is given after it.
        connection = argparse.ArgumentParser(add_help=False)
        connection.add_argument("--url", default=argparse.SUPPRESS, help=url_help)
        connection.add_argument("--token", default=argparse.SUPPRESS, help=token_help)
        actions = parser.add_subparsers(dest="action", required=True)
        listing = actions.add_parser("list", help=f"newest {kind} first", parents=[connection])
        listing.add_argument("--status", choices=["queued", "running", "completed", "failed", "cancelled"])
        listing.add_argument("--limit", type=_limit, default=20, help="at most this many (default 20)")
        for action, text in (("show", "its status and summary as JSON"), ("cancel", f"stop a queued or running {one}"),
                             ("delete", f"remove a finished {one} with its results (or cancel a running one)")):
            actions.add_parser(action, help=text, parents=[connection]).add_argument("id")
        fetch = actions.add_parser("fetch", help="download its results to a file", parents=[connection])
        fetch.add_argument("id")
        fetch.add_argument("--out", required=True, help="the file: .nc" + (", .npz, .csv or .json" if kind == "jobs"
                                                                            else ""))


class _Refused(Exception):
    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


class _BadReply(Exception):
    """The service answered, but not with what the command can use (exit code 1)."""


class _LocalFile(Exception):
    """The file named by --out could not be written (exit code 2)."""


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
        try:
            body = response.read()
        except http.client.HTTPException as error:  # a broken chunked body
            raise _BadReply(f"the reply was cut short ({error!r})") from None
    try:
        return json.loads(body) if body else None
    except (json.JSONDecodeError, UnicodeDecodeError):
        kind = response.headers.get("Content-Type") or "no Content-Type"
        raise _BadReply(f"the reply was not JSON ({kind}, {len(body)} bytes); is --url a raydamp service?") from None


def _field(reply, key: str):
    """``reply[key]``; _BadReply when the JSON is not an object holding it."""
    if not isinstance(reply, dict) or key not in reply:
        raise _BadReply(f"the reply has no {key!r}; is --url a raydamp service?")
    return reply[key]


def _base_problem(base: str) -> str | None:
    """Why ``base`` is no http(s) address urllib can request, or None."""
    try:
        parts = urllib.parse.urlsplit(base)
        _ = parts.port  # raises ValueError for a port that is not a number in range
    except ValueError as error:
        return f"not a URL ({error})"
    if parts.scheme not in ("http", "https") or not parts.hostname:
        return "not an http:// or https:// address (e.g. http://127.0.0.1:8000)"
    return None


_FORMATS = {".nc": "netcdf", ".npz": "npz", ".csv": "csv", ".json": "json"}


def _temporary_beside(out: str) -> tuple[str, int]:
    """(path, descriptor) of a new file in --out's directory, so that the finished download is
    renamed into place in one step; created as open() would, with the umask's permissions."""
    target = Path(out)
    path = str(target.with_name(f".{target.name}.{secrets.token_hex(4)}.part"))
    try:
        return path, os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as error:
        raise _LocalFile(f"--out {out}: {error.strerror}") from None


def _copy(response, descriptor: int, out: str) -> int:
    """Bytes of the response written to the descriptor; _BadReply when the connection breaks."""
    written = 0
    with open(descriptor, "wb") as file:
        while True:
            try:
                piece = response.read(_PIECE)
            except (OSError, http.client.HTTPException) as error:  # reset, timed out, a broken chunk
                raise _BadReply(f"the download was cut short after {written} bytes ({error!r}); {out} is "
                                "unchanged") from None
            if not piece:
                return written
            try:
                file.write(piece)
            except OSError as error:
                raise _LocalFile(f"--out {out}: {error.strerror}") from None
            written += len(piece)


def _download(response, out: str) -> int:
    """Write the response to ``out`` whole or not at all (a cut-off file would replace a good one);
    returns the bytes written."""
    expected = response.headers.get("Content-Length")
    path, descriptor = _temporary_beside(out)
    try:
        with response:
            written = _copy(response, descriptor, out)
        # http.client ends a body that stops short of its Content-Length without an error: count it here
        if expected is not None and expected.isdigit() and written != int(expected):
            raise _BadReply(f"the download was cut short: {written} of {expected} bytes; {out} is unchanged")
        try:
            os.replace(path, out)
        except OSError as error:
            raise _LocalFile(f"--out {out}: {error.strerror}") from None
    finally:
        if os.path.exists(path):
            os.unlink(path)
    return written


def _fetch(kind: str, args, base: str, token: str | None, root: str) -> int:
    suffix = Path(args.out).suffix.lower()
    allowed = _FORMATS if kind == "jobs" else {".nc": "netcdf"}
    if suffix not in allowed:
        raise _LocalFile(f"--out: unknown format {suffix!r} (known: {', '.join(allowed)})")
    if problem := file_problem(args.out):  # before the request: the service is not asked for nothing
        raise _LocalFile(f"--out {args.out}: {problem}")
    path = f"{root}/{_quoted(args.id)}/trajectory" if kind == "jobs" else f"{root}/{_quoted(args.id)}/result"
    written = _download(_request(base, token, "GET", path, {"format": allowed[suffix]}), args.out)
    print(f"wrote {args.out} ({written} bytes)")
    return 0


def _list(kind: str, args, base: str, token: str | None, root: str) -> int:
    params = {"limit": args.limit, **({"status": args.status} if args.status else {})}
    rows = _field(_json(_request(base, token, "GET", root, params)), kind)
    for row in rows:
        what = row.get("model", f"{row.get('members')} members")
        extra = f"  {row['method']}" if "method" in row else ""
        print(f"{row['id']}  {row['status']:<9} {100 * row['progress']:5.1f}%  {what}{extra}  "
              f"{row['created_at']}")
    if not rows:
        print(f"no {kind}")
    return 0


def _quoted(task_id: str) -> str:
    """An id as one path segment: "a?b" asked for job "a", and "a b" was reported as no service (CLI audit)."""
    return urllib.parse.quote(task_id, safe="")


def _act(kind: str, args, base: str, token: str | None) -> int:
    root = f"/v1/{kind}"
    if args.action == "list":
        return _list(kind, args, base, token, root)
    if args.action == "fetch":
        return _fetch(kind, args, base, token, root)
    if args.action == "show":
        print(json.dumps(_json(_request(base, token, "GET", f"{root}/{_quoted(args.id)}")), indent=2))
    elif args.action == "cancel":
        view = _json(_request(base, token, "POST", f"{root}/{_quoted(args.id)}/cancel"))
        print(f"{args.id}: {_field(view, 'status')} (cancel requested)")
    elif args.action == "delete":
        response = _request(base, token, "DELETE", f"{root}/{_quoted(args.id)}")
        print(f"{args.id}: removed" if response.status == 204 else
              f"{args.id}: {_field(_json(response), 'status')}, cancel requested; delete again once it has stopped")
    return 0


def client_command(args) -> int:
    kind = args.command
    base = args.url or os.environ.get("RAYDAMP_URL") or _DEFAULT_URL
    token = args.token or os.environ.get("RAYDAMP_TOKEN")
    fail = f"raydamp {kind} {args.action}:"
    if problem := _base_problem(base):
        print(f"{fail} {'--url' if args.url else 'RAYDAMP_URL'} {base}: {problem}", file=sys.stderr)
        return 2
    try:
        return _act(kind, args, base, token)
    except _Refused as refused:
        print(f"{fail} the service answered {refused.status}: {refused}", file=sys.stderr)
        return 1
    except _BadReply as bad:
        print(f"{fail} {bad}", file=sys.stderr)
        return 1
    except _LocalFile as local:
        print(f"{fail} {local}", file=sys.stderr)
        return 2
    except (urllib.error.URLError, OSError, http.client.HTTPException) as error:
        reason = getattr(error, "reason", error)
        print(f"{fail} no service at {base} ({reason}); start one with `raydamp serve` or give --url", file=sys.stderr)
        return 2
