"""The error family of optdesign (and how a Ctrl-C and CasADi's messages are handled).

Every message names the item (file, table, key, construction, sweep value), shows what was
found and says what to do.  All of them derive from :class:`OptdesignError`, and each also
derives from the builtin exception a Python user would expect (``ValueError``).
"""
import re


class OptdesignError(Exception):
    """Base class of all errors raised on purpose by optdesign."""


class SceneError(OptdesignError, ValueError):
    """A scene that does not parse or does not validate (file, table, key, line)."""


class ExpressionError(SceneError):
    """An expression that does not parse or names something unknown."""


class AssemblyError(OptdesignError, ValueError):
    """A construction that cannot be assembled at some sweep value, or reaches its limit
    (lock-up) position there.  ``construction`` names it and ``s`` is the located sweep value
    (both None when not known)."""

    def __init__(self, message, construction=None, s=None):
        super().__init__(message)
        self.construction, self.s = construction, s

    def __reduce__(self):  # keep the attributes through pickling (study workers)
        return type(self), (str(self), self.construction, self.s)


class DeadCentreError(OptdesignError, ValueError):
    """The drive coordinate stops moving inside the stroke (k = dq/ds vanishes); ``s`` is the
    located sweep value (None when not known)."""

    def __init__(self, message, s=None):
        super().__init__(message)
        self.s = s

    def __reduce__(self):
        return type(self), (str(self), self.s)


class ArgumentError(OptdesignError, ValueError):
    """A value handed to a front door (a function argument, a command-line option) that is out
    of range, not finite, or too large for this machine; the message names the argument."""


class ResultError(OptdesignError, ValueError):
    """A result that holds NaN or inf: the message names the quantity (and body, point or
    constraint) and the first stroke position where it appears."""


class OutputError(OptdesignError, OSError):
    """A result file that cannot be written where it was asked for (a folder, a read-only or
    full disk, a path under a file, the kernel's /proc): the message names the path and what
    to do (report/files.py); ``errno`` and ``strerror`` are the OSError's."""

    def __init__(self, message, errno=None, strerror=None):
        super().__init__(message)
        self.errno, self.strerror = errno, strerror

    def __str__(self):
        return self.args[0]

    def __reduce__(self):
        return type(self), (str(self), self.errno, self.strerror)


class SolverError(OptdesignError, RuntimeError):
    """A numerical solver that failed (IPOPT, an integrator)."""


# --- Ctrl-C through CasADi -------------------------------------------------------------------------
# CasADi checks for Ctrl-C inside its long calls (IPOPT's iterations, an integrator's steps, a
# mapped evaluation) and stops them within milliseconds, but it turns the KeyboardInterrupt into
# a failed call: a RuntimeError whose message says 'KeyboardInterrupt', or an IPOPT status
# 'NonIpopt_Exception_Thrown' that looks like any failed solve.  A loop that tries again after a
# failed call would swallow the Ctrl-C.  So the front doors run their long work ``interruptible``:
# a Ctrl-C is remembered (and still stops the CasADi call at once), and every place that handles a
# failed CasADi call first calls :func:`check_interrupt`, which raises KeyboardInterrupt.

class _Interrupt:
    pending = False   # a Ctrl-C arrived while a front door's work ran (reset when it ends)
    depth = 0


def interrupt_pending() -> bool:
    return _Interrupt.pending


def check_interrupt(exc=None):
    """Raise KeyboardInterrupt if a Ctrl-C arrived, or if ``exc`` (a RuntimeError from CasADi)
    is a Ctrl-C that CasADi reported as a failed call."""
    if _Interrupt.pending or (exc is not None and "KeyboardInterrupt" in str(exc)):
        _Interrupt.pending = True
        raise KeyboardInterrupt


class interruptible:
    """While this runs (in the main thread): a Ctrl-C sets the pending flag and raises
    KeyboardInterrupt at once, wherever Python or CasADi is; the flag lets the code that
    catches CasADi's failed calls see that it was a Ctrl-C (:func:`check_interrupt`).  Nested
    uses share the outermost handler."""

    def __enter__(self):
        import signal
        import threading

        self.previous = None
        if _Interrupt.depth == 0:
            _Interrupt.pending = False
            if threading.current_thread() is threading.main_thread():
                previous = signal.getsignal(signal.SIGINT)
                if previous is signal.default_int_handler:   # leave a caller's own handler alone
                    self.previous = signal.signal(signal.SIGINT, _on_sigint)
        _Interrupt.depth += 1
        return self

    def __exit__(self, exc_type, exc, tb):
        import signal

        _Interrupt.depth -= 1
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        if _Interrupt.depth == 0:
            lost, _Interrupt.pending = _Interrupt.pending, False
            # a Ctrl-C that CasADi's Python conversions swallowed (the handler's KeyboardInterrupt
            # raised inside SWIG's array typemap is taken for "not convertible", the work goes on)
            # or turned into "SystemError: ... returned a result with an exception set": raised
            # here, when the front door's work ends (simulate's columns after the integration:
            # 2 runs in 20 under load ended with exit 0 or a traceback instead of 130)
            if lost and (exc_type is None or issubclass(exc_type, SystemError)):
                raise KeyboardInterrupt from None
        return False


def _on_sigint(signum, frame):
    _Interrupt.pending = True
    raise KeyboardInterrupt


def resume_after_interrupt():
    """Forget the pending Ctrl-C (the caller handled it, e.g. to save what finished); the
    handler stays, so a second Ctrl-C stops that at once."""
    _Interrupt.pending = False


class OptimisationInterrupted(KeyboardInterrupt):
    """Ctrl-C during ``optimise``: ``result`` is the best design of the starts that finished
    before it (an OptimisationResult marked ``interrupted``), or None when none had.  From a
    motor catalogue (``optimise_catalogue``), ``result``, ``finished`` and ``total`` are the
    interrupted motor's and ``catalogue`` is the catalogue so far (a CatalogueResult whose
    ``best`` is None when nothing was decided); from a plain ``optimise``, ``catalogue`` is None."""

    def __init__(self, result=None, finished=0, total=0, catalogue=None):
        super().__init__()
        self.result, self.finished, self.total, self.catalogue = result, finished, total, catalogue


def worker_process(parent=None):
    """Set up a forked worker process: Ctrl-C is left to the parent (which stops the pool and
    keeps what finished), and the worker dies with its parent (Linux: PR_SET_PDEATHSIG), so a
    parent killed with SIGKILL leaves no worker behind to fail on its closed pipe
    (BrokenPipeError tracebacks).  ``parent``: the parent's process id (``os.getpid()`` before
    the fork), to catch a parent that died before the worker asked to die with it."""
    import os
    import signal
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)   # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):  # pragma: no cover - no libc to ask
            pass
    if parent is not None and os.getppid() != parent:   # it died before the prctl
        os._exit(0)
    one_blas_thread()
    keep_freed_memory()


# what Dask's nanny sets for its workers (distributed.nanny.pre-spawn-environ), and joblib's
BLAS_THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def one_blas_thread():
    """One BLAS (and OpenMP) thread in a worker process, unless the user set the number: a pool
    already runs a process per core, and the threads of CasADi's OpenBLAS (IPOPT's MUMPS) only
    spin on the other processes' cores.  Measured on the 2-core machine of results/scaling.md
    (seed1_jib_design, 32 warm-started optimisations in one process, 4 interleaved pairs at load
    ~8): 3.6-4.0 s of CPU with Dask's worker variables unset, 2.8-3.5 s with
    ``OPENBLAS_NUM_THREADS=1``.  CasADi loads its OpenBLAS at the first IPOPT solve, where the
    variables set here count; one the parent loaded before the fork is told directly."""
    import os

    for name in BLAS_THREADS:
        os.environ.setdefault(name, "1")
    if os.environ["OPENBLAS_NUM_THREADS"] != "1":
        return
    try:
        import ctypes

        import casadi

        lib = ctypes.CDLL(os.path.join(os.path.dirname(casadi.__file__), "libcasadi-tp-openblas.so.0"),
                          mode=os.RTLD_NOLOAD)   # only if loaded already (else OSError)
        lib.openblas_set_num_threads(1)
    except (ImportError, OSError, AttributeError):   # not loaded yet, or another CasADi build
        pass


# glibc's malloc in a worker process (its variables, as a process started afresh reads them): what
# a batch frees kept for the next one.  By default the memory of a batch's arrays (megabytes each)
# goes back to the system and the next batch faults it in again, page by page: in a truck-crane
# analyse study on the pool (20,000 cases, load 8) 240,000-270,000 page faults and 11 % of the
# workers' CPU in the kernel, 72,000-80,000 and 4 % with these (a worker keeps up to
# TRIM_THRESHOLD of freed memory)
KEEP_MEMORY = {"MALLOC_MMAP_THRESHOLD_": 32 << 20, "MALLOC_TRIM_THRESHOLD_": 256 << 20, "MALLOC_TOP_PAD_": 64 << 20}
_MALLOPT = {"MALLOC_TRIM_THRESHOLD_": -1, "MALLOC_TOP_PAD_": -2, "MALLOC_MMAP_THRESHOLD_": -3}


def keep_freed_memory():
    """:data:`KEEP_MEMORY` set in this process with glibc's mallopt (a forked worker: the
    variables are read when a process starts), unless the user set any of them."""
    import os
    import sys

    if not sys.platform.startswith("linux") or any(name in os.environ for name in KEEP_MEMORY):
        return
    try:
        import ctypes

        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # pragma: no cover - no C library to ask
        return
    for name, value in KEEP_MEMORY.items():
        mallopt(_MALLOPT[name], value)


# --- CasADi's own messages ---------------------------------------------------------------------------
# CasADi's log lines ('CasADi - DATE WARNING("...") [file:line]') and its SUNDIALS callbacks'
# failures ('rhs failed: KeyboardInterrupt'), each written in pieces, the first piece one of these
_CASADI_LINE = re.compile(r"CasADi - |(rhs|rhsB|rhsQ|rhsQB|ehfun|jtimesF|jtimesB|psolve|psolveB|lsolveF|lsolveB"
                          r"|psetup|psetupB|lsetup|lsetupB) failed: ")


class _WithoutCasadiMessages:
    """A text stream that passes everything on but CasADi's own log lines ('CasADi - DATE
    WARNING("Failed to calculate multipliers") [file:line]', 'rhs failed: ...', written in
    pieces through Python's sys.stdout/sys.stderr): they speak of CasADi's internals, not of
    the user's scene, and what they mean is reported by optdesign in its own words (a failed
    start, an integrator that gave up, a Ctrl-C)."""

    def __init__(self, stream):
        self._stream, self._dropping = stream, False

    def write(self, text):
        if not self._dropping and _CASADI_LINE.match(text):
            self._dropping = True
        if self._dropping:
            end = text.find("\n")
            if end < 0:
                return len(text)
            self._dropping = False
            rest = text[end + 1:]
            if rest:
                self._stream.write(rest)
            return len(text)
        return self._stream.write(text)

    def __getattr__(self, name):
        return getattr(self._stream, name)


class casadi_messages_hidden:
    """While this runs, CasADi's log lines written to sys.stdout and sys.stderr are dropped
    (everything else passes unchanged).  Nested uses wrap once."""

    def __enter__(self):
        import sys

        self.saved = sys.stdout, sys.stderr
        if not isinstance(sys.stdout, _WithoutCasadiMessages):
            sys.stdout = _WithoutCasadiMessages(sys.stdout)
        if not isinstance(sys.stderr, _WithoutCasadiMessages):
            sys.stderr = _WithoutCasadiMessages(sys.stderr)
        return self

    def __exit__(self, *exc):
        import sys

        sys.stdout, sys.stderr = self.saved
        return False
