"""Instruction programs kept in the cache folder (optdesign/model/programs.py), as the
screening of many designs uses them (design/screening.py: ManyDesigns): the program read back
is the one made from the graph (the same operations, work entries and constants), the designs'
numbers are CasADi's own (its map of the Function), a damaged file is made again rather than
trusted, and with the cache off nothing is written."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from optdesign.design.screening import ManyDesigns
from optdesign.model import programs
from optdesign.model.vectorised import instruction_program


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(folder))
    monkeypatch.delenv("OPTDESIGN_NO_COMPILE", raising=False)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "background")
    return folder


def graph(scale=0.1):
    """An MX Function (x, p) -> (f, g) over the operations a mechanism's rows use, with a
    constant ``scale`` in it (two graphs that differ in a number are two entries)."""
    x, p = ca.MX.sym("x", 3), ca.MX.sym("p", 2)
    g = ca.vertcat(ca.sin(x[0]) * p[0] + ca.atan2(x[1], x[2] + 2), ca.sqrt(x[0] ** 2 + x[1] ** 2 + scale),
                   ca.fmax(x[2], p[1]) - ca.cos(x[1]) ** 3, ca.if_else(x[0] > 0.5, x[1] / (1 + x[2] ** 2), -x[0]),
                   ca.exp(-x[2]) * ca.fabs(x[0] - p[1]) + scale * ca.mtimes(x.T, x))
    return ca.Function("rows", [x, p], [ca.sumsqr(g), g])


def designs(m=64):
    rng = np.random.default_rng(3)
    return rng.uniform(-1, 1, (3, m)), rng.uniform(0.2, 2, (2, m))


def casadi_values(f, X, P):
    return [np.asarray(v) for v in f.map(X.shape[1])(X, P)]


def test_the_program_read_back_is_the_one_made(cache):
    f = graph()
    made = instruction_program(f.expand())
    work, first = programs.cached_program(f)        # made, and kept
    assert first == made and work == f.expand().sz_w()
    assert len(list(cache.glob("program-*.npz"))) == 1
    assert programs.cached_program(f) == (work, made)   # read back
    X, P = designs()
    for ours, theirs in zip(ManyDesigns(f)(X, P), casadi_values(f, X, P)):
        np.testing.assert_allclose(ours, theirs, rtol=1e-14, atol=1e-14)
    programs.cached_program(graph(0.2))
    assert len(list(cache.glob("program-*.npz"))) == 2   # another constant: another entry


def test_a_damaged_file_is_made_again(cache):
    f = graph()
    work, made = programs.cached_program(f)
    (npz,) = cache.glob("program-*.npz")
    data = bytearray(npz.read_bytes())
    data[len(data) // 2] ^= 0xFF
    npz.write_bytes(bytes(data))
    assert programs._load(cache, npz.stem) is None
    assert programs.cached_program(f) == (work, made)
    assert programs._load(cache, npz.stem) == (work, made)   # replaced by a whole one


def test_with_the_cache_off_nothing_is_written(cache, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_NO_COMPILE", "1")
    f = graph()
    assert programs.cached_program(f)[1] == instruction_program(f.expand())
    assert not cache.exists() or not list(cache.glob("program-*"))


def test_arrays_that_do_not_make_a_program_are_not_trusted(cache):
    """A whole file (its SHA-256 matches) whose arrays name an operation unknown here, an
    instruction kind out of range, or fewer constants than constant instructions is made
    again, not read as a program."""
    f = graph()
    work, made = programs.cached_program(f)
    rows, constants = [], []
    for kind, a, b, c in made:   # the stored form (programs._store)
        if kind == 2:
            constants.append(a)
            a, b = 0, (0, 0)
        elif kind in (3, 4):
            a = programs._OPS[a]
        b = b if isinstance(b, tuple) else (b, 0)
        rows.append((kind, a, b[0], b[1], c))
    rows = np.array(rows, np.int64)
    assert programs._program(rows, constants, work) == (work, made)   # the whole arrays make it
    binary = np.flatnonzero(rows[:, 0] == 3)[0]
    unknown = rows.copy()
    unknown[binary, 1] = 10_000
    assert programs._program(unknown, constants, work) is None
    bad_kind = rows.copy()
    bad_kind[0, 0] = 7
    assert programs._program(bad_kind, constants, work) is None
    assert programs._program(rows, constants[:-1], work) is None
