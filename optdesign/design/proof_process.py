"""A motor catalogue's energy proofs (:mod:`.energy_bound`) sought in forked processes while the
command's own process builds a motor's problem (issue 31).

The proofs of crane_luffing_drive take ~3.5 s of CPU (the 4 kW motor proved in ~1.4 s, the
5.5 kW motor's attempt given up at its budget in ~2 s), and the 5.5 kW motor's build and
screening ~1.5 s: one after the other in one process, the second core idle.  :class:`Proofs`
seeks each motor's proof in a process of its own, forked once the bound is built
(:class:`~.catalogue.Prover`): the catalogue (:func:`~.catalogue.optimise_catalogue`) seeks the
motor it must decide and, when that one's proof looks likely, the next one's too, while it
prepares a motor here.  A verdict (an :class:`~.energy_bound.EnergyProof` or None) is the one
the same code gives in this process (the budget is counted, not timed); once a motor is not
proved, the proofs of larger motors are not needed and their processes are ended.

Should a process die, be unable to start, or give no verdict within ``WAIT`` seconds (a process
that hangs: it is ended), its verdict is found here (the same one); an error in it is raised here
as it would be here.  Ctrl-C is the command's: the processes ignore it and
end with the block (and die with this process, as a pool's workers)."""
from __future__ import annotations

import multiprocessing
import os
import pickle
import traceback


WAIT = 600.0   # seconds a verdict is waited for (crane_luffing_drive's take ~1.5-3 s of CPU); then found here


class Proofs:
    """The verdicts of ``prover`` on ``motors``, sought in forked processes when ``fork`` and the
    platform can (else here, when asked); use as a context manager: the processes end with the
    block."""

    def __init__(self, prover, motors, fork=True):
        self.prover, self.motors, self._verdicts, self._sought = prover, list(motors), {}, {}
        self.forked = (fork and "fork" in multiprocessing.get_all_start_methods() and bool(self.motors)
                       and prover.ready())
        if self.forked:   # the first guess made before any fork: the processes find the bound's programs loaded
            prover.likely(self.motors[0])

    def seek(self, k):
        """Motor ``k``'s proof sought in a process of its own (if it is not sought or known)."""
        if not self.forked or k >= len(self.motors) or k in self._verdicts or k in self._sought:
            return
        context = multiprocessing.get_context("fork")
        conn, theirs = context.Pipe(duplex=False)
        proc = context.Process(target=_prove, args=(self.prover, self.motors[k], theirs, os.getpid()), daemon=True)
        proc.start()
        theirs.close()
        self._sought[k] = (proc, conn)

    def seek_from(self, k):
        """Motor ``k``'s proof sought, and the next motor's too when this one's looks likely
        (:meth:`~.catalogue.Prover.likely`: its verdict will then be asked next)."""
        self.seek(k)
        if self.forked and self.prover.likely(self.motors[k]):
            self.seek(k + 1)

    def decided(self, k) -> bool:
        """Whether motor ``k``'s verdict is in (without waiting)."""
        if k not in self._verdicts and k in self._sought and _ready(self._sought[k][1]):
            self._receive(k)
        return k in self._verdicts

    def verdict(self, k):
        """Motor ``k``'s proof, or None (not proved, or outside the proof: the prover's ``why``);
        waits for it.  Asked only once every smaller motor was proved; once one is not, the
        larger motors' processes are ended."""
        self.seek(k)
        if k not in self._verdicts and k in self._sought:
            self._receive(k)
        if k not in self._verdicts:   # no process, or it died: found here (the same verdict)
            self._verdicts[k] = self.prover.prove(self.motors[k])
        if self._verdicts[k] is None:
            for j in [j for j in self._sought if j > k]:
                self._end(j)
        return self._verdicts[k]

    def _receive(self, k):
        proc, conn = self._sought[k]
        try:
            if not conn.poll(WAIT):   # it hangs (the budget is counted: it should not): ended, found here
                return
            kind, value = conn.recv()
        except (EOFError, OSError, pickle.UnpicklingError):   # it died: found here
            return
        finally:
            self._end(k)
        if kind == "error":
            raise value
        self._verdicts[k] = value

    def _end(self, k):
        proc, conn = self._sought.pop(k)
        conn.close()
        if proc.is_alive():
            proc.terminate()
        proc.join()

    def close(self):
        for k in list(self._sought):
            self._end(k)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _ready(conn) -> bool:
    try:
        return conn.poll(0)
    except (EOFError, OSError):
        return True   # (the receive sees the end)


def _prove(prover, motor, conn, parent):
    """A process: ``motor``'s verdict sent."""
    from ..errors import worker_process

    try:
        worker_process(parent)   # Ctrl-C left to the parent; dies with it
        conn.send(("ok", prover.prove(motor)))
    except Exception as exc:   # raised in the parent as it would be there (with this traceback)
        try:
            exc.add_note("in the energy proof's process:\n" + traceback.format_exc())
            conn.send(("error", exc))
        except Exception:   # noqa: BLE001 - not picklable: its traceback
            conn.send(("error", RuntimeError("the energy proof failed:\n" + traceback.format_exc())))
    except BaseException:   # noqa: BLE001 - the parent is gone: nothing to tell
        pass
    finally:
        conn.close()
        os._exit(0)
