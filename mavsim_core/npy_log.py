"""Append-only ``.npy`` logs that survive an abrupt kill.

A log is an ordinary NumPy ``.npy`` file holding a 1-D structured array (one record
per row, named fields with units in their names), so ``np.load(path)`` reads it and
``log["pos_n_m"]`` is a column.  Rows are packed with :mod:`struct` into a chunk
buffer and appended a chunk at a time; after each chunk the header's row count is
rewritten in place.  The header is padded to a fixed size, so the count always fits.
If the process dies, the file holds every complete chunk written so far and the
header counts only complete rows (the count is computed from the file size), so it
is still a valid ``.npy``: at most the rows of the last, unwritten chunk are lost.

This is file I/O for the process loops (the flight controller's and the simulator's);
nothing here reads a clock.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import BinaryIO, Sequence

import numpy as np

MAGIC = b"\x93NUMPY\x01\x00"  # format version 1.0
HEADER_BYTES = 4096  # magic + length + dict + padding; room for a few hundred field names
ROW_COUNT_WIDTH = 14  # digits reserved for the row count in the header


def _header(dtype: np.dtype, rows: int) -> bytes:
    """A version-1.0 header of exactly HEADER_BYTES for ``rows`` records of ``dtype``."""
    descr = np.lib.format.dtype_to_descr(dtype)
    shape = f"({rows:d},)".ljust(ROW_COUNT_WIDTH + 2)  # spaces inside the literal are harmless
    text = "{'descr': %r, 'fortran_order': False, 'shape': %s, }" % (descr, shape)
    room = HEADER_BYTES - len(MAGIC) - 2
    if len(text) + 1 > room:
        raise ValueError(f"too many fields for a {HEADER_BYTES}-byte .npy header")
    body = text.ljust(room - 1) + "\n"
    return MAGIC + struct.pack("<H", room) + body.encode("latin1")


class NpyLogWriter:
    """Write rows of ``fields`` (name, struct code) to ``path`` in chunks of ``chunk_rows``.

    Struct codes: ``"d"`` float64, ``"f"`` float32, ``"q"`` int64, ``"B"`` uint8 ...
    ``append(*values)`` packs one row (values in field order); the chunk is written when
    full, by :meth:`flush`, and by :meth:`close`.
    """

    def __init__(self, path: str | Path, fields: Sequence[tuple[str, str]], chunk_rows: int = 250) -> None:
        self.path = Path(path)
        self.fields = tuple(fields)
        fmt = "<" + "".join(code for _, code in self.fields)
        self._struct = struct.Struct(fmt)
        self.dtype = np.dtype([(name, "<" + code) for name, code in self.fields])
        if self.dtype.itemsize != self._struct.size:
            raise ValueError("field layout mismatch between struct and numpy")
        self.row_bytes = self._struct.size
        self.chunk_rows = max(1, int(chunk_rows))
        self._buf = bytearray(self.row_bytes * self.chunk_rows)
        self._pack_into = self._struct.pack_into
        self._n = 0  # rows in the chunk buffer
        self.rows_written = 0
        self._f: BinaryIO | None = open(self.path, "wb")  # None once closed
        self._f.write(_header(self.dtype, 0))
        self._f.flush()

    def append(self, *values: float) -> None:
        self._pack_into(self._buf, self._n * self.row_bytes, *values)
        self._n += 1
        if self._n == self.chunk_rows:
            self.flush()

    def flush(self) -> None:
        """Write the buffered rows, then the header's new row count (each step flushed to the OS)."""
        f = self._f
        if f is None:
            return
        n, self._n = self._n, 0  # counted out before the write: a SIGTERM's SystemExit raised just after
        if n:  # it (between two bytecodes) must not leave the rows in the buffer for close() to write again
            f.write(memoryview(self._buf)[: n * self.row_bytes])
            f.flush()
        end = f.seek(0, 2)
        rows = (end - HEADER_BYTES) // self.row_bytes  # complete rows on disk, whatever happened before
        if rows != self.rows_written:
            f.seek(0)
            f.write(_header(self.dtype, rows))
            f.seek(0, 2)
            f.flush()
            self.rows_written = rows

    def close(self) -> None:
        if self._f is not None:
            try:
                self.flush()
            finally:
                self._f.close()
                self._f = None

    @property
    def closed(self) -> bool:
        return self._f is None


def read_npy_log(path: str | Path) -> np.ndarray:
    """The records of a log (also one whose writer was killed: complete rows only)."""
    with open(path, "rb") as f:
        version = np.lib.format.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(f)
        else:
            shape, _, dtype = np.lib.format.read_array_header_2_0(f)
        start = f.tell()
        f.seek(0, 2)
        on_disk = (f.tell() - start) // dtype.itemsize
        f.seek(start)
        rows = min(shape[0] if shape else 0, on_disk)
        return np.fromfile(f, dtype=dtype, count=rows)
