"""CasADi Functions with their common subexpressions eliminated, kept in the cache folder of
compiled code, so that a warm run reads a large graph's eliminated form from a file instead of
eliminating them again.

:meth:`~optdesign.kinematics.mechanism.Mechanism.function` builds its SX Functions with CasADi's
``cse`` option (repeated differentiation duplicates much of a graph).  The elimination costs far
more than building the graph: crane_luffing_drive's exchange tracking (d2v/ds2 and d(dv/ds)/dp
of its 31 rows) has 248,000 instructions before and 18,400 after, 0.06 s to build and 2.3 s to
eliminate, once per motor and again in every forked worker that runs an objective phase; the
rows' s-derivatives 0.5 s per motor.  Here the Function is built without the elimination, its
serialization hashed (the graph as it is: the key), and the eliminated Function read from the
entry of that key (``cse-<key>.fn``, CasADi's serialization of it, with ``cse-<key>.json``
holding its SHA-256, written last); on a miss it is eliminated as before and kept.  CasADi
(de)serializes a Function exactly: the same instructions in the same order and the constants bit
for bit, so the numbers are those of the Function eliminated here.  The key holds CasADi's
version and this module's code.  Without a writable cache folder, or with the cache off
(``OPTDESIGN_NO_COMPILE``), the elimination runs each time.  The files count in the cache's
size and are pruned as its libraries are (:func:`.compiled.prune`)."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import casadi as ca

from .cachefiles import entry_name

FORMAT = 1


def cse_function(name: str, inputs: list, outputs: list, names_in: list, names_out: list) -> ca.Function:
    """``ca.Function(name, inputs, outputs, names_in, names_out, {"cse": True})`` (SX), from
    the cache folder when an earlier run eliminated the same graph."""
    from . import compiled

    if compiled.mode() == "off":
        return ca.Function(name, inputs, outputs, names_in, names_out, {"cse": True})
    plain = ca.Function(name, inputs, outputs, names_in, names_out)
    return _cached(plain.serialize(), (), lambda: ca.Function(name, inputs, outputs, names_in, names_out, {"cse": True}))


def cse_derived(name: str, inputs: list, base, derive, names_in: list, names_out: list, code=()) -> ca.Function:
    """``cse_function(name, inputs, derive(), names_in, names_out)``, keyed by the expressions
    ``base`` that ``derive()`` makes its outputs from (a pure function of ``base``'s graph, such as
    its derivatives) rather than by the outputs' own graph, which is not built on a hit: the
    exchange's tracking (derivatives of the rows' s-derivatives in s and p) has 248,000
    instructions before elimination, 0.9 s to differentiate, build and serialize for its key, where
    the rows' s-derivatives take 0.05 s.  The key holds the graph of ``base``, the names and the
    code of the files ``code`` (the modules whose code derives the outputs), so that a change of
    any of them makes a new entry."""
    from . import compiled

    if compiled.mode() == "off":
        return ca.Function(name, inputs, derive(), names_in, names_out, {"cse": True})
    plain = ca.Function(f"{name}_base", inputs, [base])
    tag = [json.dumps([name, list(names_in), list(names_out)]).encode()] + [Path(f).read_bytes() for f in code]
    return _cached(plain.serialize(), tag, lambda: ca.Function(name, inputs, derive(), names_in, names_out, {"cse": True}))


def _cached(graph: str, tag, eliminate) -> ca.Function:
    """The eliminated Function of the entry keyed by ``graph`` and ``tag`` (bytes), or
    ``eliminate()`` kept under that key."""
    from . import compiled

    folder, key = compiled.cache_dir(), entry_name(
        "cse", (str(FORMAT).encode(), ca.__version__.encode(), Path(__file__).read_bytes(), *tag, graph.encode()))
    found = _load(folder, key)
    if found is not None:
        compiled._touch(folder / f"{key}.fn")
        return found
    func = eliminate()
    _store(folder, key, func.serialize().encode())
    return func


def _load(folder: Path, key: str):
    """The Function of the entry ``key`` if its files are whole, else None."""
    try:
        data = (folder / f"{key}.fn").read_bytes()
        meta = json.loads((folder / f"{key}.json").read_text())
        if meta.get("sha256") != hashlib.sha256(data).hexdigest() or meta.get("format") != FORMAT:
            return None
        return ca.Function.deserialize(data.decode())
    except (OSError, ValueError, KeyError, TypeError, AttributeError, RuntimeError, UnicodeDecodeError):
        return None


def _store(folder: Path, key: str, data: bytes):
    """Write the serialized Function and then its key file (a torn write is not trusted)."""
    from .cachefiles import write_atomic

    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_atomic(folder / f"{key}.fn", data)
        write_atomic(folder / f"{key}.json", json.dumps({"format": FORMAT,
                                                         "sha256": hashlib.sha256(data).hexdigest()}).encode())
    except OSError:
        pass   # a read-only or full cache folder: eliminated again next time
