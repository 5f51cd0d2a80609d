"""Uploaded files are parsed once per id (issue 27, F4: eight submissions naming one 46 MB file parsed
it eight times, 10-13 s each, 2.3 GB)."""

from __future__ import annotations

import io
import threading

import pytest

from raydamp_service.checks.uploads import ParsedFiles

sparse = pytest.importorskip("scipy.sparse")
scipy_io = pytest.importorskip("scipy.io")


class CountingStore:
    def __init__(self, files: dict[str, bytes]):
        self.files, self.reads, self.lock = files, 0, threading.Lock()

    def file_content(self, file_id: str) -> bytes | None:
        with self.lock:
            self.reads += 1
        return self.files.get(file_id)

    def file_exists(self, file_id: str) -> bool:
        return file_id in self.files


def _mtx(n: int) -> bytes:
    out = io.BytesIO()
    scipy_io.mmwrite(out, sparse.diags([2.0] * n).tocoo())
    return out.getvalue()


def test_eight_concurrent_resolutions_read_and_parse_once():
    store = CountingStore({"a" * 32: _mtx(20_000)})
    parsed = ParsedFiles(store, max_entries=10**6)
    start, results = threading.Barrier(8), []

    def resolve():
        start.wait()
        results.append(parsed("a" * 32))

    threads = [threading.Thread(target=resolve) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert store.reads == 1 and len(results) == 8 and all(r is results[0] for r in results)
    assert results[0].shape == (20_000, 20_000) and results[0].nnz == 20_000


def test_unknown_ids_are_not_cached_and_the_oldest_parse_is_dropped_past_the_bound():
    store = CountingStore({"a" * 32: _mtx(100), "b" * 32: _mtx(100)})
    parsed = ParsedFiles(store, max_entries=150)
    with pytest.raises(ValueError, match="no uploaded file with id 'ccc"):
        parsed("c" * 32)
    parsed("a" * 32)
    parsed("b" * 32)  # 200 entries > 150: a's parse is dropped
    parsed("b" * 32)
    assert store.reads == 3
    parsed("a" * 32)
    assert store.reads == 4
    parsed.forget("a" * 32)
    parsed("a" * 32)
    assert store.reads == 5


def test_a_file_forgotten_while_it_is_parsed_is_not_cached():
    """A run parsing a file while a DELETE of it forgot it put the parse back in the cache afterwards: the next
    submission naming the deleted file passed its check and got 409 at its insert, not 422 naming the file (a
    loaded test run). The parse finishing after forget() is handed to its caller and not kept."""

    class SlowStore(CountingStore):
        def __init__(self, files):
            super().__init__(files)
            self.reading, self.release = threading.Event(), threading.Event()

        def file_content(self, file_id):
            content = super().file_content(file_id)
            self.reading.set()  # read; its parse is still to come
            self.release.wait(30)
            return content

    store = SlowStore({"a" * 32: _mtx(10)})
    parsed = ParsedFiles(store, max_entries=10**6)
    result = []
    run = threading.Thread(target=lambda: result.append(parsed("a" * 32)))
    run.start()
    assert store.reading.wait(30)
    parsed.forget("a" * 32)  # DELETE /v1/files/<id>, while the run parses it
    del store.files["a" * 32]
    store.release.set()
    run.join()
    assert result[0].shape == (10, 10)
    with pytest.raises(ValueError, match="no uploaded file with id"):
        parsed("a" * 32)


def test_a_file_deleted_after_its_parse_is_not_served_from_the_cache():
    """A check process's cache is not told of a DELETE (the server's is): a stale parse let a check pass that the
    job's insert then refused with 409 "deleted while this submission was being checked" instead of the 422 at the
    path (tests/service/test_record_loads.py, flaky under load). A cached parse is served only while its file is."""
    store = CountingStore({"a" * 32: _mtx(3)})
    parsed = ParsedFiles(store, max_entries=10**6)
    assert parsed("a" * 32).shape == (3, 3) and parsed("a" * 32).shape == (3, 3) and store.reads == 1
    del store.files["a" * 32]
    with pytest.raises(ValueError, match="no uploaded file with id"):
        parsed("a" * 32)
