"""Sweep tables as files: written as CSV (floats round-trip exactly) or Parquet, and read
back as numpy columns. Shared by the CLI (``selfmanip sweep --out``) and the plots
(``selfmanip plot table.csv``)."""

from __future__ import annotations

import csv
import errno
import os
import sys
from typing import Callable, Mapping, TextIO

import numpy as np

from .errors import InvalidInputError


def _temp_name(name: str, pid: int) -> str:
    """The hidden temporary name a write of ``name`` by process ``pid`` uses beside it (the
    MCAP writer, ``selfmanip-sim/src/mcap.rs``, names its own the same way)."""
    return f".{name}.{pid}.tmp"


def _process_is_gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OSError, OverflowError):
        return False   # it exists (another user's), or cannot be asked about: keep its file
    return False


def remove_stale_temp_files(directory: str, name: str) -> None:
    """Removes from ``directory`` the temporary files of earlier writes of ``name`` whose
    process is gone (killed mid-write, SIGKILL: nothing else removed them); a write still
    running keeps its own."""
    prefix, suffix = f".{name}.", ".tmp"
    try:
        entries = os.listdir(directory)
    except OSError:
        return
    for entry in entries:
        pid = entry[len(prefix):-len(suffix)] if entry.startswith(prefix) and entry.endswith(suffix) else ""
        if pid.isdigit() and int(pid) != os.getpid() and _process_is_gone(int(pid)):
            try:
                os.remove(os.path.join(directory, entry))
            except OSError:
                pass


def write_atomically(path: str, write: Callable[[str], None]) -> None:
    """Calls ``write(tmp)`` on a temporary file beside ``path``, then renames it to ``path``:
    a reader never sees a partial file, and whatever stops the write (an error, Ctrl-C) removes
    the temporary file; one a killed write left behind is removed by the next write of
    ``path``. A missing directory is reported against ``path``, not the temporary file."""
    directory = os.path.dirname(path) or "."
    if not os.path.isdir(directory):
        raise FileNotFoundError(errno.ENOENT, f"no directory {directory!r} to write into", path)
    remove_stale_temp_files(directory, os.path.basename(path))
    tmp = os.path.join(directory, _temp_name(os.path.basename(path), os.getpid()))
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise


def write_table(table: Mapping[str, np.ndarray], path: str | None, out: TextIO | None = None) -> None:
    """A sweep table as CSV (floats round-trip exactly) or Parquet (pandas + pyarrow)."""
    if path and path.endswith(".parquet"):
        import pandas as pd

        write_atomically(path, lambda tmp: pd.DataFrame(table).to_parquet(tmp, index=False))
        return
    if path and not path.endswith(".csv"):
        raise InvalidInputError(f"`--out`: expected a .csv or .parquet file, got {path!r}", "--out")
    cols = list(table)
    n = len(table[cols[0]]) if cols else 0

    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return repr(float(v))
        if isinstance(v, (np.integer,)):
            return str(int(v))
        return str(v)

    def emit(f):
        w = csv.writer(f, lineterminator="\n")
        w.writerow(cols)
        for i in range(n):
            w.writerow([fmt(table[c][i]) for c in cols])

    if path:
        def emit_file(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                emit(f)

        write_atomically(path, emit_file)
    else:
        emit(out or sys.stdout)


def _check_not_empty(path: str, what: str) -> None:
    if os.path.getsize(path) == 0:
        raise InvalidInputError(f"{path}: the file is empty (expected {what})", "path")


def read_table(path: str) -> dict[str, np.ndarray]:
    """A sweep table written by :func:`write_table` (or pandas) as numpy columns."""
    what = "a sweep table from `selfmanip sweep --out`"
    _check_not_empty(path, what)
    if path.endswith(".parquet"):
        import pandas as pd

        try:
            df = pd.read_parquet(path)
        except Exception as e:  # pyarrow raises its own types for a file that is not Parquet
            raise InvalidInputError(f"{path}: not a Parquet table ({e})", "path") from None
        return {c: df[c].to_numpy() for c in df.columns}
    with open(path, encoding="utf-8", newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise InvalidInputError(f"{path}: the file is empty (expected {what})", "path")
    header, body = rows[0], rows[1:]
    if not body:
        raise InvalidInputError(f"{path}: the table has a header but no rows", "path")
    out: dict[str, np.ndarray] = {}
    for j, c in enumerate(header):
        col = [r[j] if j < len(r) else "" for r in body]
        try:
            if c in ("strategy", "word", "status", "error"):
                out[c] = np.asarray(col, dtype=str)
            elif c == "flew":
                if not set(col) <= {"True", "False"}:
                    raise ValueError(c)
                out[c] = np.asarray([v == "True" for v in col], dtype=bool)
            elif c == "n_events":
                out[c] = np.asarray([int(v) for v in col], dtype=np.int64)
            else:
                out[c] = np.asarray([float(v) for v in col], dtype=float)
        except ValueError:
            out[c] = np.asarray(col, dtype=str)
    return out
