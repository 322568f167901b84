"""Instruction programs (:func:`.vectorised.instruction_program`) kept in the cache folder of
compiled code, so that a warm run reads a large graph's instructions from a file instead of
from CasADi one call at a time.

Reading crane_luffing_drive's screening rows (its NLP's objective and rows expanded to SX:
143,000 instructions) takes about 1.1 s of CPU per motor (the expansion 0.1 s, the instructions
1 s); the file, about 0.25 s.  The file holds the same program (the same operations on the same
work entries in the same order, the constants bit for bit), so the numbers are those of the
program made here.  An entry is ``program-<key>.npz`` (its arrays) and ``program-<key>.json``
(its key and the arrays' SHA-256, written last): the key is a hash of the graph (its serialized
MX or SX), CasADi's version and this module's and vectorised.py's code; a file that does not
match is made again and replaced.  Without a writable cache folder, or with the cache off
(``OPTDESIGN_NO_COMPILE``), the program is made each time.  The files count in the cache's
size and are pruned as its libraries are (:func:`.compiled.prune`)."""
from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path

import casadi as ca
import numpy as np

from . import vectorised
from .cachefiles import entry_name
from .vectorised import BINARY, UNARY, instruction_program

FORMAT = 1
_OPS = {**{f: op for op, f in BINARY.items()}, **{f: op for op, f in UNARY.items()}}


def cached_program(func: ca.Function) -> tuple:
    """(work size, program) of ``func`` expanded to SX (as it is when SX): from the cache folder
    when an earlier run made it, else made (:func:`.vectorised.instruction_program`, whose
    ``NotImplementedError`` is raised) and kept there."""
    work, rows, constants, made = _cached(func)
    return (work, made) if made is not None else _program(rows, constants, work)


def cached_rows(func: ca.Function) -> tuple:
    """(work size, rows, constants): the program of :func:`cached_program` in its stored arrays
    (:func:`_store`; what :mod:`.programs_c` runs), without building the Python list."""
    work, rows, constants, made = _cached(func)
    if rows is None:
        rows, constants = _rows(made)
    return work, rows, constants


def _cached(func):
    """(work, rows, constants, None) read from the cache folder, or (work, None, None, program)
    made (and kept there)."""
    from . import compiled

    folder = name = None
    if compiled.mode() != "off":
        folder, name = compiled.cache_dir(), entry_name("program", (
            str(FORMAT).encode(), ca.__version__.encode(), Path(__file__).read_bytes(),
            Path(vectorised.__file__).read_bytes(), func.serialize().encode()))
        found = _load_arrays(folder, name)
        if found is not None:
            compiled._touch(folder / f"{name}.npz")
            return (*found, None)
    sx = func if func.is_a("SXFunction") else func.expand()
    program = instruction_program(sx)
    if folder is not None:
        _store(folder, name, sx.sz_w(), program)
    return sx.sz_w(), None, None, program


def _load(folder: Path, name: str):
    """(work size, program) of the entry ``name`` if its files are whole, else None."""
    found = _load_arrays(folder, name)
    return None if found is None else _program(found[1], found[2], found[0])


def _load_arrays(folder: Path, name: str):
    """(work size, rows, constants) of the entry ``name`` if its files are whole and make a
    program (:func:`_valid`), else None."""
    try:
        data = (folder / f"{name}.npz").read_bytes()
        meta = json.loads((folder / f"{name}.json").read_text())
        if meta.get("sha256") != hashlib.sha256(data).hexdigest() or meta.get("format") != FORMAT:
            return None
        with np.load(io.BytesIO(data), allow_pickle=False) as arrays:
            rows, constants = arrays["rows"], arrays["constants"]
        work = int(meta["work"])
    except (OSError, ValueError, KeyError, TypeError, AttributeError, EOFError):
        return None
    return (work, rows, constants) if _valid(rows, constants) else None


def _valid(rows, constants) -> bool:
    """Whether the stored arrays make a program: known kinds and operations, enough constants."""
    if rows.ndim != 2 or rows.shape[1] != 5:
        return False
    kind, op = rows[:, 0], rows[:, 1]
    return not (np.any((kind < 0) | (kind > 4)) or np.count_nonzero(kind == 2) > len(constants)
                or not np.all(np.isin(op[kind == 3], list(BINARY))) or not np.all(np.isin(op[kind == 4], list(UNARY))))


def _program(rows, constants, work):
    """(work, program) from the stored arrays, or None when they do not make one (an operation
    unknown here, too few constants).  Built column by column (crane_luffing_drive's screening
    rows, 143,000 instructions: 0.36 -> 0.24 s of CPU against a loop over the rows, medians of 7)."""
    if not _valid(rows, constants):
        return None
    kind, op = rows[:, 0], rows[:, 1]
    constants = np.asarray(constants).tolist()
    binary = {a: BINARY[a] for a in np.unique(op[kind == 3]).tolist()}
    unary = {a: UNARY[a] for a in np.unique(op[kind == 4]).tolist()}
    values = iter(constants)
    program = [(k, a, b0, c) if k < 2 else (2, next(values), None, c) if k == 2 else
               (3, binary[a], (b0, b1), c) if k == 3 else (4, unary[a], b0, c)
               for k, a, b0, b1, c in zip(*(rows[:, j].tolist() for j in range(5)))]
    return work, program


def _rows(program: list):
    """The stored arrays of a program: rows (kind, operation or input/output number, b0, b1, c)
    and the constants in order."""
    rows = np.zeros((len(program), 5), np.int64)
    constants = []
    for i, (kind, a, b, c) in enumerate(program):
        if kind == 2:
            constants.append(a)
            a, b = 0, (0, 0)
        elif kind in (3, 4):
            a = _OPS[a]
        b = b if isinstance(b, tuple) else (b, 0)
        rows[i] = (kind, a, b[0], b[1], c)
    return rows, np.asarray(constants, np.float64)


def _store(folder: Path, name: str, work: int, program: list):
    """Write the program's arrays and then their key file (a torn write is not trusted)."""
    from .cachefiles import write_atomic

    rows, constants = _rows(program)
    buf = io.BytesIO()
    np.savez(buf, rows=rows.astype(np.int32) if rows.size and np.abs(rows).max() < 2**31 else rows,
             constants=constants)
    data = buf.getvalue()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_atomic(folder / f"{name}.npz", data)
        write_atomic(folder / f"{name}.json", json.dumps({"format": FORMAT, "work": int(work),
                                                          "sha256": hashlib.sha256(data).hexdigest()}).encode())
    except OSError:
        pass   # a read-only or full cache folder: made again next time
