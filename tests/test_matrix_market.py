"""raydamp.systems.matrix_market.read_header: a Matrix Market header checked against the file's size before
the reader allocates what it announces, for bytes, paths and file objects; read_matrix checks it first."""

from __future__ import annotations

import io

import numpy as np
import pytest
import scipy.io
import scipy.sparse

import raydamp
from raydamp.systems.matrix_market import MatrixMarketHeader, read_header
from raydamp.systems.structure import read_matrix

LYING = b"%%MatrixMarket matrix coordinate real general\n5 5 1000000000\n1 1 1.0\n"


def _mtx(matrix, **options) -> bytes:
    out = io.BytesIO()
    scipy.io.mmwrite(out, matrix, **options)
    return out.getvalue()


def test_the_header_of_a_coordinate_file():
    K = scipy.sparse.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(6, 6), format="csc")
    assert read_header(_mtx(K, symmetry="general")) == MatrixMarketHeader(shape=(6, 6), entries=16, layout="coordinate",
                                                                          field="real", symmetry="general")
    assert read_header(_mtx(K, symmetry="symmetric")).entries == 11  # the lower triangle: 6 + 5


def test_a_header_announcing_more_than_the_file_holds_is_refused(tmp_path):
    (tmp_path / "lying.mtx").write_bytes(LYING)
    for source in (LYING, tmp_path / "lying.mtx", io.BytesIO(LYING)):
        with pytest.raises(ValueError, match=r"^K: the header announces 1000000000 entries, more than a file of "
                                              r"69 bytes can hold$"):
            read_header(source, "K")
    # read_matrix refuses it before reading (scipy would first allocate 10^9 entries).
    with pytest.raises(ValueError, match="^M: the header announces 1000000000 entries"):
        read_matrix(io.BytesIO(LYING), "M")
    with pytest.raises(ValueError, match="^M: the header announces 1000000000 entries"):
        read_matrix(str(tmp_path / "lying.mtx"), "M")
    # A general dense file stores rows x cols entries of at least 2 bytes each.
    with pytest.raises(ValueError, match="^matrix: the header announces 1000000 entries, more than a file of 57 bytes"):
        read_header(b"%%MatrixMarket matrix array real general\n1000 1000\n1\n2\n3\n")


def test_a_huge_dimension_with_few_entries_is_refused_before_reading(tmp_path):
    # 59 bytes announcing 10^11 x 10^11 with one entry: scipy went on to allocate 745 GiB of column pointers
    # (a MemoryError, or the machine's memory) - an API audit.
    huge = b"%%MatrixMarket matrix coordinate real general\n100000000000 100000000000 1\n1 1 1.0\n"
    (tmp_path / "huge.mtx").write_bytes(huge)
    with pytest.raises(ValueError, match=r"^M: the header announces a 100000000000 x 100000000000 matrix with 1 "
                                          r"stored entries: mostly empty rows, whose column pointers alone would take "
                                          r"745 GiB"):
        raydamp.LinearStructure(str(tmp_path / "huge.mtx"), np.eye(2))
    # Empty rows are allowed while their pointers stay small: 5 masses, one spring.
    few = b"%%MatrixMarket matrix coordinate real symmetric\n5 5 1\n2 2 4.0\n"
    assert read_header(few).shape == (5, 5)
    assert read_matrix(io.BytesIO(few)).shape == (5, 5)


def test_a_dense_symmetric_file_stores_its_lower_triangle():
    """The bug this caught: the check counted rows x cols entries in a symmetric dense file, which stores
    n (n + 1) / 2, so scipy's own mmwrite of a 100 x 100 identity as symmetric (10,153 bytes) was refused."""
    content = _mtx(np.eye(100), symmetry="symmetric")
    assert len(content) == 10_153
    header = read_header(content)
    assert (header.layout, header.symmetry, header.entries) == ("array", "symmetric", 5050)
    matrix = read_matrix(io.BytesIO(content))
    assert matrix.shape == (100, 100) and matrix.nnz == 100 and abs(matrix - scipy.sparse.eye(100)).sum() == 0
    skew = read_header(_mtx(np.array([[0.0, 2.0], [-2.0, 0.0]]), symmetry="skew-symmetric"))
    assert skew.entries == 1  # without the diagonal


def test_a_file_object_is_left_where_it_was_and_unreadable_files_say_so(tmp_path):
    content = _mtx(scipy.sparse.eye(3, format="csc"))
    file = io.BytesIO(b"xx" + content)
    file.seek(2)
    assert read_header(file).shape == (3, 3) and file.tell() == 2
    with pytest.raises(ValueError, match="^K: cannot read it as Matrix Market: "):
        read_header(b"hello\n", "K")
    with pytest.raises(ValueError, match="^K: no Matrix Market file at "):
        read_header(tmp_path / "none.mtx", "K")
