"""The record parser (raydamp.loads.records) reads text a piece of whole lines at a time with NumPy: the same
records and messages as a line-by-line read, memory of the samples' size, and a samples limit found from
the header or as the lines are counted (issue 44, item 1)."""

from __future__ import annotations

import io
import tracemalloc

import numpy as np
import pytest

from raydamp.loads import records
from raydamp.loads.records import parse_record, read_record


@pytest.fixture
def small_pieces(monkeypatch):
    """Pieces of 16 bytes: every record here spans several, and a line's end meets a piece's."""
    monkeypatch.setattr(records, "_PIECE", 16)


def test_text_read_in_pieces_is_the_record_its_lines_hold(small_pieces):
    content = (b"time; accel\n0.0, 1.5  # a comment\n\n0.01;-2.5e-1\n# a whole comment line\n"
               b"0.02\t3\r\n0.03 1_0\n0.04 4\n")
    record, fmt = parse_record(content, name="r.csv")
    assert fmt == "columns"
    np.testing.assert_array_equal(record.t, [0.0, 0.01, 0.02, 0.03, 0.04])
    np.testing.assert_array_equal(record.values, [1.5, -0.25, 3.0, 10.0, 4.0])  # 1_0 read as Python reads it
    record, _ = parse_record(b"1\n2\n" * 20, name="v.txt")
    assert record.t is None and record.values.tolist() == [1.0, 2.0] * 20


@pytest.mark.parametrize(("content", "message"), [
    (b"0 1\n" * 9 + b"0.5 x\n", r"v\.csv: line 10: not numbers: '0\.5 x'"),
    (b"0 1\n1 2\n" * 6 + b"3\n", r"v\.csv: every line needs the same number of columns \(found \[1, 2\]\)"),
    (b"0 1\n1 2\n" * 6 + b"3 1-2\n", r"v\.csv: line 13: not numbers: '3 1-2'"),
    (b"t v\n# nothing\n", r"v\.csv: no numbers in the file"),
    (b"1 1\n0 1\n", r"v\.csv: t: times must increase"),
    (b"0 1\n1 nan\n", r"v\.csv: values\[1\] is not finite"),
])
def test_a_bad_line_is_named_whichever_piece_it_is_in(small_pieces, content, message):
    with pytest.raises(ValueError, match=message):
        parse_record(content, name="v.csv")


def test_an_at2_record_read_in_pieces(small_pieces):
    head = b"PEER NGA\nEVENT\nUNITS OF G\nNPTS=    7, DT=   .0100 SEC\r\n"
    record, fmt = parse_record(head + b"  .1E-01  .2D-01 -.3E-01\n .4E-01\r\n  0, -.1E-01 .5E-02\n", name="a.AT2")
    assert fmt == "at2"
    np.testing.assert_allclose(record.t, np.arange(7) * 0.01, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(record.values, [0.01, 0.02, -0.03, 0.04, 0.0, -0.01, 0.005])
    with pytest.raises(ValueError, match=r"a\.AT2: line 6: '\.4X' is not a number"):
        parse_record(head + b" .1 .2 .3\n .4X\n .5 .6 .7\n", name="a.AT2")
    # all on one line: pieces end at blanks, so a long line costs no more than many short ones
    record, _ = parse_record(head + b"  .1E-01  .2E-01 -.3E-01 .4E-01 0 -.1E-01 .5E-02\n", name="a.AT2")
    assert record.values.size == 7
    with pytest.raises(ValueError, match=r"a\.AT2: line 5: '\.4X' is not a number"):
        parse_record(head + b" .1 .2 .3 .4X .5 .6 .7\n", name="a.AT2")
    with pytest.raises(ValueError, match=r"a\.AT2: the header says NPTS=7 but the record has 6 values"):
        parse_record(head + b" .1 .2 .3\n .4 .5 .6\n", name="a.AT2")
    # NPTS beyond what the file's bytes can hold: refused before an array of NPTS is made
    big = head.replace(b"    7", b"10000000")
    with pytest.raises(ValueError, match=r"NPTS=10000000 but the record has fewer values \(a file of \d+ bytes\)"):
        parse_record(big + b" .1 .2\n", name="a.AT2")


def test_a_text_line_of_a_megabyte_is_refused_before_it_is_read(small_pieces, monkeypatch):
    monkeypatch.setattr(records, "_LONGEST_LINE", 64)
    with pytest.raises(ValueError, match=r"v\.csv: line 3 is longer than 64 bytes \(a record's line holds one or two"):
        parse_record(b"0 1\n1 2\n" + b"1 " * 100 + b"\n", name="v.csv")


def test_the_samples_limit_is_found_from_the_header_or_the_lines(monkeypatch, tmp_path):
    monkeypatch.setenv("RAYDAMP_MAX_RECORD_SAMPLES", "5")
    assert records.max_record_samples() == 5
    assert parse_record(b"0 1\n" + b"".join(b"%d 1\n" % k for k in range(1, 5)), name="v.csv")[0].values.size == 5
    with pytest.raises(ValueError, match=r"v\.csv: more than 5 samples; records of at most 5 samples are read "
                                         r"\(RAYDAMP_MAX_RECORD_SAMPLES\)"):
        parse_record(b"1\n" * 6, name="v.csv")
    head = b"PEER NGA\nEVENT\nUNITS OF G\nNPTS=    6, DT=   .0100 SEC\n"
    with pytest.raises(ValueError, match=r"a\.AT2: the header says NPTS=6; records of at most 5 samples"):
        parse_record(head + b" .1 .2 .3 .4 .5 .6\n", name="a.AT2")
    out = io.BytesIO()
    np.save(out, np.ones(6))
    with pytest.raises(ValueError, match=r"v\.npy: the header announces 6 samples; records of at most 5"):
        parse_record(out.getvalue(), name="v.npy")
    (tmp_path / "v.txt").write_bytes(b"1\n" * 6)
    with pytest.raises(ValueError, match=r"more than 5 samples"):
        read_record(tmp_path / "v.txt", dt=0.1)
    monkeypatch.setenv("RAYDAMP_MAX_RECORD_SAMPLES", "many")
    with pytest.raises(ValueError, match=r"RAYDAMP_MAX_RECORD_SAMPLES must be an integer, got 'many'"):
        records.max_record_samples()
    monkeypatch.delenv("RAYDAMP_MAX_RECORD_SAMPLES")
    assert records.max_record_samples() == 10**7


def test_a_one_column_record_costs_its_samples_not_an_object_per_value():
    """Issue 44, N1: one Python float (or list) per value took 86 bytes per byte uploaded. Read in pieces
    into NumPy arrays, the peak is a few copies of samples x 8 bytes."""
    samples = 2**18
    content = b"0\n" * samples
    tracemalloc.start()
    try:
        record, _ = parse_record(content, name="col1.csv")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert record.values.size == samples
    assert peak < 6 * 8 * samples, peak / (8 * samples)  # line by line it was about 40 x 8 bytes a sample
