"""A process that gets ready to draw a result's figures while the result is being computed.

Importing matplotlib, Pillow and the drawing modules costs a third of a second of CPU, which
an optimisation's command would otherwise spend after the solve, on the user's time.
:class:`FigureProcess` forks as soon as the scene is loaded: the child imports them while the
parent solves (on the other core), then waits for the result; :meth:`FigureProcess.write`
sends it and gets back the paths of the figures written (:func:`.design_figures.write_figures`,
whose own forks then start from a process that has everything imported).  report.html shows the
numbers result.json holds (its drive-train section reads the file), so the child writes it only
after the parent says result.json is written (:meth:`FigureProcess.receive`): the figures are
drawn while the parent computes and writes the JSON, the page after it.

The process lives for one command: Python's cyclic collector is off while it imports and what
it has imported and built ahead is frozen (``gc.freeze``), out of the collections that follow
(0.3 s of its 3.3 s of CPU went to them, 0.1 s after; forked children inherit it frozen, so
their collections do not touch those pages).

Where anything goes wrong with the process (it was killed, a Ctrl-C reached it, the platform
cannot fork), :meth:`~FigureProcess.write` returns None and the caller draws in its own process:
the figures never depend on it.  An error while drawing (ffmpeg failing, a full disk) is raised
in the parent as it would be there."""
from __future__ import annotations

import gc
import multiprocessing
import os
import pickle
import traceback
from pathlib import Path

from ..errors import OptdesignError


class FigureProcess:
    """A forked process, ready to draw the figures of one optimisation result (use as a
    context manager: the process ends with the block, whether it drew or not)."""

    def __init__(self, scene=None):
        """``scene``: the scene whose optimum will be analysed for the folder (a motor
        catalogue's: with every motor, in the order tried), built by the process once it has
        imported (report/drive_train.prebuild): :meth:`analysis` then runs that build."""
        self._proc = None
        if "fork" not in multiprocessing.get_all_start_methods():
            return
        context = multiprocessing.get_context("fork")
        self._conn, theirs = context.Pipe()
        self._proc = context.Process(target=_serve, args=(theirs, self._conn, scene, os.getpid()))   # not a daemon: it forks
        self._proc.start()
        theirs.close()

    def begin(self, design):
        """Have the process analyse the optimum at ``design`` now, before :meth:`analysis` asks
        for it (design/multistart.optimise's ``polished``: the best start's design once polished,
        while this process certifies and reports it: report/drive_train.analyse_ahead)."""
        if self._proc is None:
            return
        try:
            self._conn.send(("begin", design))
        except (pickle.PicklingError, TypeError, AttributeError, OSError):
            self.close()

    def analysis(self, result, catalogue=None):
        """The analysis the folder needs, made by the process (from the build it made beforehand
        when that is of the same scene): with the motor ``catalogue`` whose best ``result`` is,
        every motor at its design (report/drive_train.catalogue_analysis), else the optimum's
        (report/design_cases.optimum_analysis); None when the process is not there or the
        analysis failed there (the caller then makes it, and sees its error)."""
        if self._proc is None:
            return None
        try:
            self._conn.send(("analysis", None if catalogue is not None else result, catalogue))
            kind, value = self._conn.recv()
        except (pickle.PicklingError, TypeError, AttributeError, EOFError, OSError):
            self.close()
            return None
        return value if kind == "ok" else None

    def write(self, result, folder, workers, animate, analysis=None) -> list | None:
        """The figures of ``result`` written into ``folder`` by the process (paths), or None
        when the process is not there to draw them (the caller then draws them itself)."""
        return self.receive() if self.send(result, folder, workers, animate, analysis) else None

    def send(self, result, folder, workers, animate, analysis=None) -> bool:
        """Start drawing the figures of ``result`` (``analysis``: its optimum's, from
        report/design_cases.optimum_analysis, or None to make it there); False (and the process
        ended) when it cannot: :meth:`receive` then has nothing to give."""
        if self._proc is None:
            return False
        try:
            self._conn.send((result, str(folder), workers, animate, analysis))
            return True
        except (pickle.PicklingError, TypeError, AttributeError, OSError):   # pickled before anything is sent
            self.close()
            return False

    def receive(self) -> list | None:
        """The paths of the figures :meth:`send` asked for, or None when the process is gone
        (the caller then draws them itself); an error while drawing is raised here.  Call it
        once result.json is in the folder: the process writes report.html from it then."""
        if self._proc is None:
            return None
        try:
            self._conn.send("result.json written")
            kind, value = self._conn.recv()
        except (EOFError, OSError):
            return None
        finally:
            self.close()
        if kind == "error":
            raise value
        return [Path(p) for p in value]

    def close(self):
        if self._proc is None:
            return
        proc, self._proc = self._proc, None
        self._conn.close()           # the child, waiting for a result, reads the end of the pipe and exits
        proc.join(timeout=2)
        if proc.is_alive():
            proc.kill()
            proc.join()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _serve(conn, parents, scene, parent):
    """The child: import, build the analysis of ``scene`` (if given), answer the requests for the
    analysis, wait for one result, draw its figures, send the paths (or the error).  As the
    optimiser's workers (errors.worker_process): Ctrl-C is the parent's (which ends this process
    with the block, or sends it the interrupted result to draw), and it dies with its parent
    (``parent``: its process id), also one killed by SIGKILL, and its own drawing processes with it."""
    parents.close()                  # so that the parent's exit ends the wait (EOFError)
    try:
        from ..errors import worker_process
        from .design_figures import _import_for_children, write_figures

        worker_process(parent)
        gc.disable()                 # the imports leave little to collect (their collections: 0.1 s)
        try:
            _import_for_children()
        finally:
            gc.enable()
        gc.freeze()                  # what is here now lives as long as the process: never scanned again
        if scene is not None:
            _prebuild(scene)
            gc.freeze()              # (the build: its collections while drawing 0.1 s less CPU)
        job = conn.recv()
        while isinstance(job[0], str) and job[0] in ("begin", "analysis"):
            if job[0] == "begin":
                from .drive_train import analyse_ahead

                analyse_ahead(job[1])
            else:
                conn.send(_analysis(*job[1:]))
            job = conn.recv()
        result, folder, workers, animate, analysis = job
        if analysis is not None:
            from .design_cases import keep_optimum_analysis

            keep_optimum_analysis(result, analysis)
        try:
            # report.html waits for the parent's word that result.json is written (receive)
            reply = ("ok", [str(p) for p in write_figures(result, Path(folder), workers, animate,
                                                          before_html=conn.recv)])
        except OptdesignError as exc:
            reply = ("error", exc)
        except Exception:            # a bug: its traceback, in the parent's error
            reply = ("error", RuntimeError("drawing the figures failed:\n" + traceback.format_exc()))
        try:
            conn.send(reply)
        except (pickle.PicklingError, TypeError, AttributeError):
            conn.send(("error", OptdesignError(str(reply[1]))))
    except BaseException:            # the parent is gone, or Ctrl-C: the parent draws, or stops
        pass
    finally:
        os._exit(0)


def _prebuild(scene):
    from .drive_train import prebuild

    try:
        prebuild(scene)
    except Exception:   # noqa: BLE001 - the analysis is then built when asked (its error raised by the command)
        pass


def _analysis(result, catalogue):
    """("ok", the analysis :meth:`FigureProcess.analysis` asks for), or ("none", None) when it
    failed here: the command makes it then (and reports its error)."""
    from .design_cases import optimum_analysis
    from .drive_train import catalogue_analysis

    try:
        return ("ok", catalogue_analysis(catalogue) if catalogue is not None else optimum_analysis(result))
    except Exception:   # noqa: BLE001
        return ("none", None)
