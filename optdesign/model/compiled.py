"""Compiled CasADi Functions, cached on disk.

A scene's Functions (the reduced model over the stroke, the design problem's NLP) are written as
C, compiled once with the system's C compiler (``$CC`` or ``gcc``) into a shared library in the
user's cache folder (``platformdirs.user_cache_dir("optdesign")/compiled``, or
``$OPTDESIGN_CACHE_DIR``), and loaded with ``ca.external`` (``ca.nlpsol`` for an NLP) whenever
the same graph comes again: in a later run, in a study's worker processes, on a Dask worker of
the same machine.  An entry's name is a hash of the graph (CasADi's serialization of the
Function), the kind of code (and the text of our code that writes its C), the compiler's
identity and version, its flags, CasADi's version and this module's format; parameter values are
inputs of the graphs, not part of them, so ``--set`` and a study's cases reuse one entry.  Beside
each library a small JSON file holds its SHA-256: an entry whose library does not match it (a
torn write, a damaged file) or does not load is removed and built again.  The cache keeps within
1 GB (``$OPTDESIGN_CACHE_MAX_MB``): the least recently used libraries go first (:func:`prune`).

When.  Compiling takes seconds (a reduced model about 2 s of one core, a design NLP longer), more
than a single command needs, so by default (``OPTDESIGN_COMPILE=background``) a run that misses
the cache starts the compiler in a detached background process and evaluates on CasADi's
virtual machine itself; later runs load the library.  Work that is long enough to repay the
wait (a study, before it hands cases to its workers; the benchmarks) asks for the library at
once (``wait=True``, or ``OPTDESIGN_COMPILE=wait`` for everything).  ``OPTDESIGN_NO_COMPILE=1``
(or ``OPTDESIGN_COMPILE=off``) turns the cache off: nothing is compiled or loaded.

Without a compiler, or when compiling fails, the Functions run on CasADi's virtual machine and a
:class:`CompileWarning` says so once per process (a failed compile is noted in the cache and not
retried for a day).  The numbers are the same either way: the C code does the virtual machine's
operations in the same order in IEEE arithmetic (no fast-math, no fused multiply-adds), which
tests/test_compiled.py checks.

This module imports nothing heavy at its top: ``python -m optdesign.model.compiled JOB`` is the
background compiler.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
import warnings
from pathlib import Path

from .cachefiles import FileLock, code_hash, first_in_this_run, write_atomic

FORMAT = 1
# -march=native (the key names the processor: a shared cache folder keeps one library per kind
# of processor); IEEE arithmetic kept: no fast-math, no contraction into fused multiply-adds
FLAGS = ("-O1", "-ftree-vectorize", "-march=native", "-fno-math-errno", "-fno-trapping-math",
         "-ffp-contract=off", "-fPIC", "-shared")
# gcc's optimiser takes minutes on the single straight-line function of a large NLP's Hessian
# (truck crane: 1.7 MB of C, -O1 21 s of CPU, -O0 2.4 s; -O0 still runs it 2.7 times faster than
# the virtual machine, -O1 3.7 times): a source larger than this is compiled without optimisation
LARGE_SOURCE = 300_000


# an NLP solver's functions are called at every iteration of every start, so they repay a longer
# compile: optimised (-O1) up to this size of C, -O0 beyond (and -O0 again if -O1 fails).
# crane_luffing_drive's design NLP, 2.7 MB of C: -O1 52 s of CPU once; its Hessian 10.8 -> 3.8 ms
# per call, its constraint Jacobian 3.1 -> 1.2 ms, phase 1's Jacobian 4.6 -> 0.9 ms (the same
# numbers: no fast-math, no contraction); the knuckle press's 10.4 MB stays at -O0
NLP_OPTIMISED_SOURCE = 4_000_000


def flags_for(size: int, optimised_up_to: int = LARGE_SOURCE) -> tuple:
    return ("-O0", *FLAGS[1:]) if size > optimised_up_to else FLAGS


# the compiler's bounds (gcc needed 14.6 GB at -O0 for an exact-Hessian SQP of the press's duty
# cycle): at most MAX_SOURCE of C, COMPILER_MEMORY and COMPILE_TIMEOUT_S, else marked failed.
# Issue 27's knuckle press: 10.4 MB of C, gcc -O0 33 s of CPU and 1.2 GB; so about 25 MB fits
# in COMPILER_MEMORY (was 8 MB: the knuckle press ran on the virtual machine)
MAX_SOURCE = 25_000_000
# a graph serialized in more than MAX_GRAPH is not written as C (crane_luffing_drive's NLP: 40.8
# MB, 669 MB of C after 80 s; the largest that compiles, level_luffing_cylinder's, 1.3 MB)
MAX_GRAPH = 4_000_000
COMPILER_MEMORY = 3 << 30
COMPILE_TIMEOUT_S = 900


# the cache's libraries at most CACHE_MAX_BYTES ($OPTDESIGN_CACHE_MAX_MB; a day of our tests left
# 764 MB); a compiler's temporary files older than STALE_S are a killed process's: removed
CACHE_MAX_BYTES = 1_000_000_000
STALE_S = 3600
_TEMPORARY = re.compile(r"\.(tmp|fn|src|job)\d+")


def _limit_memory():
    """In the compiler's process (before exec): at most COMPILER_MEMORY of address space."""
    try:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (COMPILER_MEMORY, COMPILER_MEMORY))
    except (ImportError, ValueError, OSError):
        pass


RETRY_AFTER_S = 86400.0   # a failed compile is tried again after a day (or with another compiler)

_compiler = []           # [None] or [{"path", "version"}], found once per process
_warned = set()
_children = []           # background compilers started by this process (reaped when done)


class CompileWarning(UserWarning):
    """Models run on CasADi's virtual machine: no C compiler, or compiling failed."""


def mode() -> str:
    """'off', 'wait' or 'background' (see the module's docstring)."""
    if os.environ.get("OPTDESIGN_NO_COMPILE", "").strip() not in ("", "0"):
        return "off"
    m = os.environ.get("OPTDESIGN_COMPILE", "background").strip().lower()
    return m if m in ("off", "wait", "background") else "background"


def cache_dir() -> Path:
    env = os.environ.get("OPTDESIGN_CACHE_DIR")
    if env:
        return Path(env)
    try:
        import platformdirs   # the user's cache folder on every platform (XDG on Linux)

        return Path(platformdirs.user_cache_dir("optdesign")) / "compiled"
    except ImportError:   # pragma: no cover - a declared dependency
        return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "optdesign" / "compiled"


def compiler():
    """The C compiler ({"path", "version"}) or None; looked up once per process."""
    if not _compiler:
        found = shutil.which(os.environ.get("CC", "gcc"))
        info = None
        if found:
            try:
                out = subprocess.run([found, "--version"], capture_output=True, text=True, timeout=30)
                if out.returncode == 0 and out.stdout.strip():
                    info = {"path": os.path.realpath(found), "version": out.stdout.strip().splitlines()[0]}
            except (OSError, subprocess.SubprocessError):
                info = None
        _compiler.append(info)
    return _compiler[0]


def processor() -> str:
    """What -march=native compiles for: the processor's model and its instruction set flags."""
    try:
        info = {}
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() in ("model name", "flags", "Features", "CPU implementer", "CPU part"):
                info.setdefault(key.strip(), value.strip())
        if info:
            return json.dumps(info, sort_keys=True)
    except OSError:
        pass
    import platform

    return f"{platform.machine()} {platform.processor()}"


def say_once(what: str, message: str):
    if what not in _warned:
        _warned.add(what)
        warnings.warn(message, CompileWarning, stacklevel=3)


def entry_key(kind: str, graph: str, extra=None) -> str | None:
    """The cache key of a graph (None when nothing is to be compiled: off, or no compiler)."""
    if mode() == "off":
        return None
    cc = compiler()
    if cc is None:
        say_once("compiler", "optdesign: no C compiler found (gcc, or $CC): the models run on CasADi's virtual "
                 "machine, slower (set OPTDESIGN_NO_COMPILE=1 to choose this)")
        return None
    import casadi

    h = hashlib.sha256()
    for part in (str(FORMAT), casadi.__version__, cc["path"], cc["version"], processor(), " ".join(FLAGS),
                 str(LARGE_SOURCE), kind,
                 json.dumps(extra, sort_keys=True, default=repr)):
        h.update(part.encode())
        h.update(b"\0")
    h.update(graph.encode())
    return f"{kind}-{h.hexdigest()[:32]}"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def lookup(key: str) -> Path | None:
    """The library of ``key`` when the cache holds it whole; a damaged entry is removed."""
    folder = cache_dir()
    lib, meta = folder / f"{key}.so", folder / f"{key}.json"
    try:
        recorded = json.loads(meta.read_text())["sha256"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    try:
        if _sha256(lib) == recorded:
            _touch(lib)
            return lib
    except OSError:
        pass
    remove(key)   # damaged: built again
    return None


def _touch(lib: Path):
    """Mark ``lib`` used now (its mtime: what :func:`prune` orders by), at most once a minute."""
    try:
        now = time.time()
        if now - lib.stat().st_mtime > 60:
            os.utime(lib, (now, now))
    except OSError:
        pass


def max_bytes() -> int:
    env = os.environ.get("OPTDESIGN_CACHE_MAX_MB", "").strip()
    try:
        return int(float(env) * 1e6) if env else CACHE_MAX_BYTES
    except ValueError:
        say_once("max", f"optdesign: OPTDESIGN_CACHE_MAX_MB={env!r} is not a number of megabytes; "
                        f"using {CACHE_MAX_BYTES / 1e6:g}")
        return CACHE_MAX_BYTES


def prune(keep: str | None = None) -> list:
    """Keep the cache within :func:`max_bytes`: the least recently used libraries (never ``keep``)
    and stale temporary files removed; returns the keys removed."""
    folder, now, limit = cache_dir(), time.time(), max_bytes()
    entries = []
    try:
        files = list(folder.iterdir())
    except OSError:
        return []
    for f in files:
        try:
            st = f.stat()
        except OSError:
            continue
        if _TEMPORARY.search(f.name):
            if now - st.st_mtime > STALE_S:
                f.unlink(missing_ok=True)
        elif f.suffix in (".so", ".npz", ".fn"):   # libraries, instruction programs (programs.py), Functions (cse.py)
            entries.append((st.st_mtime, st.st_size, f.stem))
    total, removed = sum(size for _, size, _ in entries), []
    for _, size, key in sorted(entries):
        if total <= limit:
            break
        if key != keep:
            remove(key)
            total -= size
            removed.append(key)
    return removed


def remove(key: str):
    for suffix in (".json", ".so", ".npz", ".fn"):
        try:
            (cache_dir() / f"{key}{suffix}").unlink()
        except OSError:
            pass


def _failed_recently(key: str) -> bool:
    marker = cache_dir() / f"{key}.failed"
    try:
        if time.time() - marker.stat().st_mtime < RETRY_AFTER_S:
            if key not in _warned and first_in_this_run(marker):
                say_once(key, f"optdesign: compiling {key} failed (see {marker}): it runs on CasADi's virtual "
                              "machine, slower")
            _warned.add(key)
            return True
    except OSError:
        pass
    return False


def library(key: str, prepare, wait: bool | None = None, graph_bytes: int = 0) -> Path | None:
    """The library of ``key``: from the cache, else built now (``wait``) or in a background
    process (then None: this run uses the virtual machine) from the job ``prepare()`` writes
    (see :func:`run_job`); a graph of more than MAX_GRAPH serialized bytes is not compiled."""
    found = lookup(key)
    if found is not None or _failed_recently(key):
        return found
    if graph_bytes > MAX_GRAPH:
        try:
            cache_dir().mkdir(parents=True, exist_ok=True)
            write_atomic(cache_dir() / f"{key}.failed", f"OSError: a graph of {graph_bytes / 1e6:.1f} MB (serialized) "
                          f"is more than this cache compiles ({MAX_GRAPH / 1e6:g} MB)\n".encode())
        except OSError:
            pass
        _failed_recently(key)   # says so once
        return None
    wait = mode() == "wait" if wait is None else wait
    folder = cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not wait:
            with FileLock(folder / f"{key}.lock", block=False) as free:
                if not free:
                    return None   # being compiled by another process
        job = dict(prepare(folder), key=key)
    except (OSError, NotImplementedError) as exc:
        say_once("folder", f"optdesign: cannot use the compile cache {folder} ({exc}): the models run on "
                           "CasADi's virtual machine, slower")
        return None
    if not wait:
        _start_background(job)
        return None
    run_job(job, block=True)
    found = lookup(key)
    if found is None:
        _failed_recently(key)
    return found


def _start_background(job: dict):
    """Start ``python -m optdesign.model.compiled JOB`` detached."""
    global _children
    _children = [c for c in _children if c.poll() is None]
    folder = cache_dir()
    path = folder / f"{job['key']}.job{os.getpid()}.json"
    job = dict(job, cleanup=[*job.get("cleanup", ()), str(path)])
    write_atomic(path, json.dumps(job).encode())
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    try:
        _children.append(subprocess.Popen(
            [sys.executable, "-m", "optdesign.model.compiled", str(path)], cwd=str(folder), env=env,
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
    except OSError as exc:
        _cleanup(job)
        say_once("background", f"optdesign: cannot start the background compiler ({exc}): the models run on "
                               "CasADi's virtual machine, slower")


def _cleanup(job: dict):
    for done in job.get("cleanup", ()):
        Path(done).unlink(missing_ok=True)


def run_job(job: dict, block: bool = True) -> bool:
    """Build one cache entry: write its C (``source``: the file is there; ``nlpsol``: CasADi's
    code of the solver's functions), compile it to a temporary file, record its SHA-256, move it
    in place.  One builder per entry at a time (a lock file); True when the entry is there."""
    folder, key = cache_dir(), job["key"]
    with FileLock(folder / f"{key}.lock", block=block) as held:
        if not held:
            _cleanup(job)
            return False
        if lookup(key) is not None:
            _cleanup(job)
            return True
        stem = folder / f"{key}.tmp{os.getpid()}"
        c_file = Path(f"{stem}.c")
        try:
            t0 = time.perf_counter()
            if job["kind"] == "nlpsol":
                _nlpsol_source(job, c_file)
            else:
                shutil.copyfile(job["source"], c_file)
            generate_s = time.perf_counter() - t0
            cc = compiler()
            if cc is None:
                raise OSError("no C compiler")
            t0 = time.perf_counter()
            size = c_file.stat().st_size
            if size > MAX_SOURCE:
                raise OSError(f"{size / 1e6:.1f} MB of C is more than this cache compiles ({MAX_SOURCE / 1e6:g} MB)")
            # (an interval program's C sets its own levels: its operations O3, its list of calls O0)
            flags = FLAGS if job.get("own_levels") else flags_for(size, job.get("optimised_up_to", LARGE_SOURCE))
            if job.get("level") and flags[0] != "-O0":
                flags = (job["level"], *flags[1:])
            out = _compile(cc, flags, c_file, stem)
            if out.returncode != 0 and flags[0] != "-O0" and not job.get("own_levels"):
                flags = ("-O0", *FLAGS[1:])   # the optimiser ran out of memory or time: unoptimised
                out = _compile(cc, flags, c_file, stem)
            if out.returncode != 0:
                raise OSError(f"{cc['path']} exited with status {out.returncode}: {out.stderr[-2000:]}")
            meta = {"sha256": _sha256(Path(f"{stem}.so")), "compiler": cc, "flags": list(flags), "kind": job["kind"],
                    "name": job.get("name"), "generate_s": generate_s, "compile_s": time.perf_counter() - t0,
                    "created": time.strftime("%Y-%m-%d %H:%M:%S")}
            os.replace(f"{stem}.so", folder / f"{key}.so")
            write_atomic(folder / f"{key}.json", json.dumps(meta, indent=1).encode())
            (folder / f"{key}.failed").unlink(missing_ok=True)
            prune(keep=key)
            return True
        except Exception as exc:   # noqa: BLE001 - any failure means: use the virtual machine
            write_atomic(folder / f"{key}.failed", f"{type(exc).__name__}: {exc}\n".encode())
            return False
        finally:
            for leftover in (c_file, Path(f"{stem}.so")):
                leftover.unlink(missing_ok=True)
            _cleanup(job)


def _compile(cc, flags, c_file: Path, stem: Path):
    try:
        return subprocess.run([cc["path"], *flags, str(c_file), "-o", f"{stem}.so", "-lm"], capture_output=True,
                              text=True, timeout=COMPILE_TIMEOUT_S,
                              preexec_fn=_limit_memory if os.name == "posix" else None)
    except subprocess.TimeoutExpired:
        return subprocess.CompletedProcess([], 1, "", f"timed out after {COMPILE_TIMEOUT_S} s")


def nlpsol_key(graph: str, plugin: str, functions: dict | None = None):
    """The cache key of an NLP solver's library (its serialized NLP ``graph``, the ``plugin``, the
    options that change its functions): the one key :func:`solver` stores under and a caller
    that looks the library up itself (design/sqp.py) must use."""
    return entry_key("nlpsol", graph, {"plugin": plugin, **(functions or {}), "optimised_up_to": NLP_OPTIMISED_SOURCE})


def _nlpsol_source(job, c_file: Path):
    """C of an NLP solver's functions (CasADi's code generator), from the NLP's serialized Function."""
    import casadi as ca

    nlp = ca.Function.deserialize(Path(job["function"]).read_text())
    solver = ca.nlpsol("compiled_nlp", job["plugin"], nlp, job["options"])
    cwd, stem = os.getcwd(), f"nlpsol_{os.getpid()}"   # CasADi wants a C identifier for a name
    try:   # and writes the file into the current folder
        os.chdir(c_file.parent)
        solver.generate_dependencies(f"{stem}.c", {"with_header": False})
        os.replace(f"{stem}.c", c_file)
    finally:
        Path(c_file.parent / f"{stem}.c").unlink(missing_ok=True)
        os.chdir(cwd)


# --- the two kinds of entry ------------------------------------------------------------------
def external(func, name: str, source, wait: bool | None = None, level: str | None = None, load=None, code=()):
    """``func`` (a CasADi Function) compiled: a ``ca.external`` of the cached library (or what
    ``load(path)`` makes of it), or None (virtual machine).  ``source(name)`` writes its C (a
    function named ``name``), the code in the files ``code`` (in the key, as is ``level``: the
    flag in place of FLAGS' -O1; a source above LARGE_SOURCE is still compiled at -O0)."""
    graph, own = func.serialize(), {"name": name, **({"level": level} if level else {}), **({"writer": code_hash(code)} if code else {})}
    if (key := entry_key("external", graph, own)) is None:
        return None

    def prepare(folder):
        c_file = folder / f"{key}.src{os.getpid()}.c"
        write_atomic(c_file, source(name).encode())
        return {"kind": "source", **own, "source": str(c_file), "cleanup": [str(c_file)]}

    path = library(key, prepare, wait, graph_bytes=len(graph))
    load = load or (lambda lib: __import__("casadi").external(name, lib))
    return _load(key, lambda: load(str(path))) if path else None


def solver(name: str, plugin: str, nlp, options: dict, wait: bool | None = None):
    """``ca.nlpsol(name, plugin, nlp, options)`` whose functions (objective, constraints and
    their derivatives) come from the cached library when there is one; else built from the NLP
    (a Function (x, p) -> (f, g)) on the virtual machine, and compiled for the next time."""
    import casadi as ca

    functions = {k: v for k, v in options.items() if k in ("ipopt.hessian_approximation", "expand")}
    graph = nlp.serialize()
    key = nlpsol_key(graph, plugin, functions)

    def prepare(folder):
        serial = folder / f"{key}.fn{os.getpid()}"
        write_atomic(serial, graph.encode())
        return {"kind": "nlpsol", "name": name, "plugin": plugin, "options": functions, "function": str(serial),
                "optimised_up_to": NLP_OPTIMISED_SOURCE, "cleanup": [str(serial)]}

    path = library(key, prepare, wait, graph_bytes=len(graph)) if key is not None else None
    if path is not None:
        loaded = _load(key, lambda: ca.nlpsol(name, plugin, str(path), options))
        if loaded is not None:
            return loaded
    return ca.nlpsol(name, plugin, nlp, options)


def _load(key, make):
    try:
        return make()
    except RuntimeError as exc:   # a library that does not load: rebuilt next time
        remove(key)
        say_once(key, f"optdesign: the compiled library {key} did not load ({exc}); it will be rebuilt")
        return None


if __name__ == "__main__":   # the background compiler: python -m optdesign.model.compiled JOB
    job_file = Path(sys.argv[1])
    try:
        spec = json.loads(job_file.read_text())
    except (OSError, ValueError):
        sys.exit(1)
    sys.exit(0 if run_job(spec, block=False) else 1)
