"""`raydamp jobs ...` against a tiny fake HTTP server in this process: a download cut short leaves the
old file as it was (exit 1), local file errors name --out (exit 2), a bad --url, --limit or a reply that
is not JSON is one line, never a traceback."""

from __future__ import annotations

import http.server
import subprocess
import sys
import threading
from pathlib import Path

import pytest

RAYDAMP = [sys.executable, "-m", "raydamp"]
BODY = bytes(range(256)) * 40  # 10240 bytes


class _Handler(http.server.BaseHTTPRequestHandler):
    """/v1/jobs/<how>/trajectory answers as ``how`` says; /v1/jobs answers with a web page."""

    def do_GET(self):  # noqa: N802 -- http.server's name
        how = self.path.split("/")[3].split("?")[0] if self.path.count("/") >= 3 else "list"
        self.send_response(200)
        self.close_connection = True
        if how == "list":
            page = b"<html><body>not a raydamp service</body></html>"
            self._send(page, {"Content-Type": "text/html", "Content-Length": str(len(page))})
        elif how == "whole":
            self._send(BODY, {"Content-Length": str(len(BODY))})
        elif how == "short":  # promises 100000 bytes, sends 1004 and closes
            self._send(BODY[:1004], {"Content-Length": "100000"})
        elif how == "chunked":  # one chunk, then the connection closes without the last (empty) chunk
            self._send(b"3e8\r\n" + BODY[:1000] + b"\r\n", {"Transfer-Encoding": "chunked"})

    def _send(self, body: bytes, headers: dict) -> None:
        for key, value in headers.items():
            self.send_header(key, value)
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args) -> None:  # quiet
        pass


@pytest.fixture(scope="module")
def url():
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def jobs(url: str | None, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*RAYDAMP, "jobs", *(["--url", url] if url else []), *args], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


def test_a_whole_download_replaces_the_file(url, tmp_path):
    (tmp_path / "tr.nc").write_bytes(b"old")
    done = jobs(url, "fetch", "whole", "--out", "tr.nc", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "tr.nc").read_bytes() == BODY and [p.name for p in tmp_path.iterdir()] == ["tr.nc"]


@pytest.mark.parametrize("how", ["short", "chunked"])
def test_a_download_cut_short_exits_1_and_leaves_the_old_file(url, tmp_path, how):
    """Before, a short body gave "wrote tr.nc (1004 bytes)" and exit 0, a broken chunked one an
    IncompleteRead traceback; both left a cut-off file in place of the old one."""
    (tmp_path / "tr.nc").write_bytes(b"old")
    done = jobs(url, "fetch", how, "--out", "tr.nc", cwd=tmp_path)
    assert done.returncode == 1, done.stderr
    assert "cut short" in done.stderr and "Traceback" not in done.stderr and done.stderr.count("\n") == 1
    assert (tmp_path / "tr.nc").read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["tr.nc"]  # no partial file left behind


@pytest.mark.parametrize(("out", "message"), [("d.nc", "--out d.nc: is a directory"),
                                              ("nodir/x.nc", "--out nodir/x.nc: no such directory nodir")])
def test_a_local_file_error_names_out_and_exits_2(url, tmp_path, out, message):
    """Before: "no service at ..." (the file's OSError taken for the connection's)."""
    (tmp_path / "d.nc").mkdir()
    done = jobs(url, "fetch", "whole", "--out", out, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and "no service" not in done.stderr


@pytest.mark.parametrize(("args", "code", "message"), [
    (["--url", "notaurl", "list"], 2, "--url notaurl: not an http:// or https:// address"),
    (["--url", "http://127.0.0.1:port", "list"], 2, "--url http://127.0.0.1:port: not a URL"),
    (["list", "--limit", "0"], 2, "argument --limit: expected an integer >= 1, got '0'"),
])
def test_bad_arguments_exit_2_naming_the_flag(tmp_path, args, code, message):
    done = jobs(None, *args, cwd=tmp_path)
    assert done.returncode == code and message in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_a_reply_that_is_not_json_exits_1(url, tmp_path):
    done = jobs(url, "list", cwd=tmp_path)
    assert done.returncode == 1, done.stderr
    assert "the reply was not JSON (text/html" in done.stderr and "Traceback" not in done.stderr


def test_url_and_token_may_follow_the_action(url, tmp_path):
    """`raydamp jobs fetch ID --out F --url U` was refused ("unrecognized arguments: --url"): --url had to come
    before the action. Given after it, it is used; given on both sides, the later one wins."""
    done = jobs(None, "fetch", "whole", "--out", "tr.nc", "--url", url, "--token", "t", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "tr.nc").read_bytes() == BODY
    both = jobs("http://127.0.0.1:1", "fetch", "whole", "--out", "again.nc", "--url", url, cwd=tmp_path)
    assert both.returncode == 0 and (tmp_path / "again.nc").read_bytes() == BODY, both.stderr
    # Before the action, as it always worked: the action's own (absent) --url does not reset it.
    before = jobs(url, "fetch", "whole", "--out", "before.nc", cwd=tmp_path)
    assert before.returncode == 0 and (tmp_path / "before.nc").read_bytes() == BODY, before.stderr
