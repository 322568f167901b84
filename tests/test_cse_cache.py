"""Functions with common subexpressions eliminated, kept in the cache folder
(optdesign/model/cse.py), as Mechanism.function builds them: the Function read back is the one
CasADi eliminates (the same serialization: instructions, order and constants bit for bit, and
so the same numbers at any point), two graphs that differ in a number are two entries, a
damaged file is made again rather than trusted, with the cache off nothing is written, and
the files are pruned with the libraries."""
from __future__ import annotations

import casadi as ca
import numpy as np

from optdesign.kinematics.mechanism import Mechanism
from optdesign.model import compiled, cse
from optdesign.scene import load
from test_programs import cache  # noqa: F401  (the fixture: a fresh cache folder)


def graph(scale=0.1):
    """(inputs, outputs): a graph whose repeated differentiation duplicates subexpressions (what
    the elimination is for), with a constant ``scale`` in it."""
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 2)
    v = ca.vertcat(ca.sin(s * p[0]) * ca.sqrt(p[1] + s ** 2 + scale), ca.atan2(p[0] * ca.cos(s), p[1] + 2) * ca.exp(-s))
    dv = ca.jacobian(v, s)
    return [s, p], [v, dv, ca.jacobian(dv, s), ca.jacobian(dv, p)]


def eliminated(scale=0.1):
    inputs, outputs = graph(scale)
    return ca.Function("rows", inputs, outputs, ["s", "p"], ["v", "dv", "d2v", "dvdp"], {"cse": True})


def cached(scale=0.1):
    inputs, outputs = graph(scale)
    return cse.cse_function("rows", inputs, outputs, ["s", "p"], ["v", "dv", "d2v", "dvdp"])


def values(f):
    rng = np.random.default_rng(5)
    return [np.asarray(o) for o in f.map(32)(rng.uniform(-2, 2, (1, 32)), rng.uniform(0.1, 3, (2, 32)))]


def test_the_function_read_back_is_the_one_eliminated(cache):
    theirs = eliminated()
    first = cached()                                  # eliminated here, and kept
    assert first.serialize() == theirs.serialize()
    assert len(list(cache.glob("cse-*.fn"))) == 1
    again = cached()                                  # read back
    assert again.serialize() == theirs.serialize()
    assert again.n_instructions() < ca.Function("plain", *graph()).n_instructions()
    for ours, exact in zip(values(again), values(theirs)):
        assert np.array_equal(ours, exact)            # bit for bit
    cached(0.2)
    assert len(list(cache.glob("cse-*.fn"))) == 2     # another constant: another entry


def test_a_mechanism_function_is_the_eliminated_one(cache):
    scene = load("problems/seed1_jib_design.toml")
    mech = Mechanism(scene)
    dv = mech.ds(mech.q)
    outputs = {"q": mech.q, "dq": dv, "d2q": mech.ds(dv)}
    plain = mech.function("q_ds", outputs)            # CasADi's elimination, as without the cache
    mech.cse_function = cse.cse_function
    made, read = mech.function("q_ds", outputs), mech.function("q_ds", outputs)
    assert plain.serialize() == made.serialize() == read.serialize()
    assert len(list(cache.glob("cse-*.fn"))) == 1


def test_a_damaged_file_is_made_again(cache):
    theirs = eliminated()
    cached()
    (fn,) = cache.glob("cse-*.fn")
    data = bytearray(fn.read_bytes())
    data[len(data) // 2] ^= 0x01
    fn.write_bytes(bytes(data))
    assert cse._load(cache, fn.stem) is None
    assert cached().serialize() == theirs.serialize()
    assert cse._load(cache, fn.stem).serialize() == theirs.serialize()   # replaced by a whole one


def test_with_the_cache_off_nothing_is_written(cache, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_NO_COMPILE", "1")
    assert cached().serialize() == eliminated().serialize()
    assert not cache.exists() or not list(cache.glob("cse-*"))


def test_pruned_with_the_libraries(cache, monkeypatch):
    cached()
    (fn,) = cache.glob("cse-*.fn")
    monkeypatch.setattr(compiled, "max_bytes", lambda: 0)
    assert fn.stem in compiled.prune()
    assert not list(cache.glob("cse-*"))


def test_a_derived_function_is_keyed_by_what_it_is_derived_from(cache, tmp_path):
    """cse_derived: the Function CasADi eliminates from the derived outputs, read back without
    deriving them again; another base graph, or another code of the files named, is another entry."""
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 2)
    code = tmp_path / "recipe.py"
    code.write_text("# derivatives in s and p\n")
    calls = []

    def derive_from(base):
        def derive():
            calls.append(1)
            return [ca.jacobian(base, s), ca.jacobian(ca.jacobian(base, s), p)]
        return derive

    def cached_of(base):
        return cse.cse_derived("tracking", [s, p], base, derive_from(base), ["s", "p"], ["d2v", "dvdp"], code=(code,))

    base = ca.vertcat(ca.sin(s * p[0]) * ca.sqrt(p[1] + s ** 2), ca.atan2(p[0], s + 2))
    theirs = ca.Function("tracking", [s, p], derive_from(base)(), ["s", "p"], ["d2v", "dvdp"], {"cse": True})
    calls.clear()
    assert cached_of(base).serialize() == theirs.serialize() and len(calls) == 1   # derived, and kept
    assert cached_of(base).serialize() == theirs.serialize() and len(calls) == 1   # read back, not derived
    cached_of(base + 1.0)                                                            # another base graph
    code.write_text("# second derivatives in s and p\n")
    cached_of(base)                                                                  # another code
    assert len(calls) == 3 and len(list(cache.glob("cse-*.fn"))) == 3
