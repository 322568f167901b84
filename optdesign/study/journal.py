"""The study journal: the append-only record of finished cases, and the lock on its folder.

Loss-free by construction:

* The lock comes first.  :class:`Journal` opens ``journal.jsonl`` and takes an exclusive
  ``flock`` on it before anything in the folder is read, cut, moved or written (``--restart``
  included), then checks that the path still names the file it locked (a run that just
  finished may have replaced the folder: it tries again).  Two runs never write one folder.
* ``journal.jsonl`` gets one line per finished case, made durable with ``fsync`` before the
  case is reported finished (the progress, the summary): the cases that come back together share
  one fsync (group commit, at least every 0.1 s while cases come back).  A process killed at any
  instant leaves at most a torn last line (no newline); it is cut off before appending.  Lines are
  keyed by the case's id, a digest of everything its result depends on, so a resumed study (or
  a changed one in the same folder) takes a finished case only when it is the very same
  computation.
* A damaged line anywhere else (not JSON, or JSON that is not a record: no ``"id"``, no
  ``"row"``) is *quarantined*: copied with its line number to ``journal.corrupt-TIME.jsonl``
  (fsynced), then the journal is rewritten without it through a temporary file and a rename.
  Every valid record, before and after the damage, is kept; a kill at any instant leaves the old
  journal or the cleaned one.  The notes say what was moved where.
* ``--restart`` swaps in a folder with a new, empty (already locked) journal as a whole
  (:func:`optdesign.report.folder.replace_folder`): a kill leaves the old study or the new one.
* The journal is carried by a hard link whenever the study's folder is replaced (the derived
  files are swapped in as a whole at the end, :mod:`optdesign.study.execute`): it is the same
  file, with the same lock, before and after.
"""
from __future__ import annotations

import collections.abc
import fcntl
import json
import os
import threading
import time
from pathlib import Path

from ..errors import OptdesignError

JOURNAL = "journal.jsonl"
QUARANTINE = "journal.corrupt-{}.jsonl"


class Journal:
    """The append-only record of finished cases in ``folder`` (use as a context manager).
    ``records``: id -> record, a read-only mapping that holds only where each record's line
    lies in the file (:class:`Records`: a record is read back when asked for, so a journal of a
    million cases opens in memory for its ids, not its rows); ``notes``: what opening it found
    and did (damaged lines)."""

    def __init__(self, folder, restart: bool = False, produces=(), consume=None):
        self.folder = Path(folder)
        self.path = self.folder / JOURNAL
        self.restart = restart
        self.produces = tuple(produces)   # the folder's derived files (dropped by a restart)
        self.records = Records(self)
        self.notes: list = []
        self.quarantined: list = []        # (line number, quarantine file)
        self._fh = None
        self._end = 0                        # the file's size, lines added included
        self._unsynced, self.synced = False, time.monotonic()
        self._unflushed = False
        self.consume = consume               # called with each valid record as it is read (once)
        self._committer, self.durable = None, None   # group commit in a thread (commit)

    def __enter__(self):
        self._fh = _open_locked(self.path)
        try:
            if self.restart:
                self._fresh()
            self._read()
        except BaseException:
            self._fh.close()
            self._fh = None
            raise
        return self

    def __exit__(self, *exc):
        if self._fh is not None:
            try:
                self.sync()
            finally:
                if self._committer is not None:
                    self._committer.stop()
                self._fh.close()
                self._fh = None

    # --- restart ---
    def _fresh(self):
        """Forget the finished cases: the folder is replaced as a whole by one with a new, empty
        journal (locked before it is swapped in) and without the derived files."""
        from ..report.folder import replace_folder

        new = []

        def write(tmp):
            fh = open(tmp / JOURNAL, "a+b")
            new.append(fh)
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)   # nobody else can know this file yet
            return []

        try:
            replace_folder(self.folder, write, produces={JOURNAL, *self.produces}, label="study folder")
        except BaseException:
            for fh in new:
                fh.close()
            raise
        self._fh.close()
        self._fh = new[0]

    # --- reading ---
    def _read(self):
        """Index every record (its id and where its line lies), line by line: nothing but the
        index stays in memory.  Cut a torn last line; quarantine damaged lines."""
        for stale in self.folder.glob(f".{JOURNAL}.*.tmp"):   # a quarantine rewrite cut short by a kill
            stale.unlink(missing_ok=True)
        fh = self._fh
        fh.seek(0)
        spans, bad, offset, number, tail = self.records.spans, [], 0, 0, b""
        try:
            for raw in fh:
                if not raw.endswith(b"\n"):
                    tail = raw               # the last line, without its newline
                    break
                number += 1
                record, why = parse_record(raw[:-1])
                if record is None:
                    bad.append((number, raw[:-1], why))
                else:
                    spans[record["id"]] = _span(offset, len(raw))
                    if self.consume is not None:
                        self.consume(record)
                offset += len(raw)
        except OSError as exc:
            raise OptdesignError(f"{self.path}: cannot read the study journal ({exc.strerror or exc})") from None
        if tail:
            self.notes.append(f"{self.path}: the last line (line {number + 1}, {len(tail)} bytes, no newline) "
                              "was cut off: a write torn by a killed process")
        if bad:
            self._quarantine(bad)
        elif tail:
            fh.truncate(offset)
            os.fsync(fh.fileno())
        self._fh.seek(0, os.SEEK_END)
        self._end = self._fh.tell()

    def _quarantine(self, bad):
        stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
        target, n = self.folder / QUARANTINE.format(stamp), 1
        while target.exists():
            n += 1
            target = self.folder / QUARANTINE.format(f"{stamp}-{n}")
        text = "".join(json.dumps({"line": number, "why": why, "text": raw.decode("utf-8", "surrogateescape")})
                       + "\n" for number, raw, why in bad)
        _write_synced(target, text.encode())
        # the journal without the bad lines: a new file, locked before it takes the journal's name;
        # the valid lines copied over one by one, and indexed again where they lie in it
        tmp = self.folder / f".{JOURNAL}.{os.getpid()}.tmp"
        fh = open(tmp, "w+b")
        spans, skip, offset, kept = self.records.spans, {number for number, _, _ in bad}, 0, 0
        spans.clear()
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            self._fh.seek(0)
            for number, raw in enumerate(self._fh, 1):
                if number in skip or not raw.endswith(b"\n"):
                    continue
                fh.write(raw)
                spans[json.loads(raw)["id"]] = _span(offset, len(raw))
                offset, kept = offset + len(raw), kept + 1
            fh.flush()
            os.fsync(fh.fileno())
            os.replace(tmp, self.path)
            _fsync_dir(self.folder)
        except BaseException:
            fh.close()
            if tmp.exists():
                tmp.unlink()
            raise
        self._fh.close()
        self._fh = fh
        for number, raw, why in bad:
            self.quarantined.append((number, target))
        lines = ", ".join(str(number) for number, _, _ in bad[:10]) + (", ..." if len(bad) > 10 else "")
        self.notes.append(f"{self.path}: {len(bad)} damaged line{'s' if len(bad) > 1 else ''} ({lines}: "
                          f"{bad[0][2]}) moved to {target.name}; the {kept} valid records are kept")

    def add(self, record: dict, durable: bool = True):
        """Append one finished case: one line, written and made durable (fsync) at once, or with
        ``durable=False`` at the next :meth:`sync` (group commit: a case is reported finished only
        once it is durable)."""
        line = json.dumps(record, separators=(",", ":")).encode() + b"\n"
        self._fh.write(line)
        self.records.spans[record["id"]] = _span(self._end, len(line))
        self._end += len(line)
        self._unsynced = self._unflushed = True
        if durable:
            self.sync()

    def add_blocks(self, blocks):
        """Append the finished cases of ``blocks`` (:class:`~optdesign.study.blocks.Block`), a line
        each as :meth:`add` writes it, in one write; durable at the next :meth:`sync`."""
        spans, end, data = self.records.spans, self._end, []
        for block in blocks:
            text, lengths = block.journal()
            for case_id, length in zip(block.ids, lengths):
                spans[case_id] = end << 32 | length   # (_span's)
                end += length
            data.append(text)
        if data:
            self._fh.write(b"".join(data))
            self._end = end
            self._unsynced = self._unflushed = True

    def sync(self):
        """Make every line added so far durable (one flush and one fsync for all of them)."""
        if self._unsynced and self._fh is not None:
            self._fh.flush()
            os.fsync(self._fh.fileno())
            self._unsynced = self._unflushed = False
        if self._committer is not None:
            self._committer.check()
            self.durable = self._committer.asked_last
        self.synced = time.monotonic()

    def commit(self, tag):
        """Group commit without waiting: the lines added so far are written to the file now and
        made durable (fsync) by a thread of the journal's, while the caller goes on; ``durable``
        is ``tag`` once they are (commits asked while an fsync runs are covered by the next
        one).  Raises the error of a failed fsync."""
        if self._committer is None:
            self._committer = _Committer(self._fh.fileno())
        if self._unflushed:
            self._fh.flush()
            self._unflushed = False
        self._committer.ask(tag)   # (_unsynced stays: sync() makes sure whatever the thread has done)
        self.durable = self._committer.check()
        self.synced = time.monotonic()

    def committed(self):
        """The tag of the last commit made durable (:meth:`commit`)."""
        if self._committer is not None:
            self.durable = self._committer.check()
        return self.durable


    def _line(self, span: int) -> bytes:
        """The line at ``span`` (without its newline), lines added but not yet written included."""
        if self._unflushed:
            self._fh.flush()
            self._unflushed = False
        offset, length = span >> 32, span & 0xFFFFFFFF
        return os.pread(self._fh.fileno(), length, offset)[:-1]


class _Committer:
    """A thread that makes a file durable (fsync) when asked, one fsync at a time: the asks
    that come while one runs are answered together by the next (group commit)."""

    def __init__(self, fd):
        self.fd, self.cond = fd, threading.Condition()
        self.asked = self.asked_last = self.done = self.error = None
        self.stopping = False
        self.thread = threading.Thread(target=self._run, name="optdesign-journal-commit", daemon=True)
        self.thread.start()

    def ask(self, tag):
        with self.cond:
            self.asked = self.asked_last = tag
            self.cond.notify_all()

    def check(self):
        """The tag made durable last; raises the error of a failed fsync."""
        if self.error is not None:
            raise OptdesignError(f"the study journal could not be made durable (fsync: "
                                 f"{self.error.strerror or self.error})")
        return self.done

    def stop(self):
        with self.cond:
            self.stopping = True
            self.cond.notify_all()
        self.thread.join()

    def _run(self):
        while True:
            with self.cond:
                while self.asked is None and not self.stopping:
                    self.cond.wait()
                if self.asked is None:
                    return
                tag, self.asked = self.asked, None
            try:
                os.fsync(self.fd)
            except OSError as exc:
                self.error = exc
                return
            self.done = tag


class Records(collections.abc.Mapping):
    """A journal's records by id, read from the file when asked for (``spans``: id -> where its
    line lies, offset and length packed in one int: about 150 bytes per record in memory)."""

    def __init__(self, journal):
        self.journal, self.spans = journal, {}

    def __getitem__(self, key):
        return json.loads(self.journal._line(self.spans[key]))

    def __contains__(self, key):
        return key in self.spans

    def __iter__(self):
        return iter(self.spans)

    def __len__(self):
        return len(self.spans)


def _span(offset: int, length: int) -> int:
    return offset << 32 | length


def parse_record(raw: bytes):
    """(record, None) for a journal line that is a record, else (None, why it is not)."""
    try:
        record = json.loads(raw)
    except (ValueError, RecursionError):
        return None, "not JSON"
    if not isinstance(record, dict):
        return None, f"JSON {type(record).__name__}, not an object"
    if not isinstance(record.get("id"), str):
        return None, 'no "id" string'
    if not isinstance(record.get("row"), dict):
        return None, 'no "row" object'
    x = record.get("x")
    if x is not None and not (isinstance(x, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                            for v in x)):
        return None, '"x" is not a list of numbers'
    return record, None


def _open_locked(path: Path, attempts: int = 20):
    """``path`` opened for appending, with an exclusive lock held on the file it names."""
    folder = path.parent
    for _ in range(attempts):
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise OptdesignError(f"study folder {folder}: is a file, not a folder") from None
        except OSError as exc:
            raise OptdesignError(f"study folder {folder}: cannot create it ({exc.strerror or exc})") from None
        try:
            fh = open(path, "a+b")
        except IsADirectoryError:
            raise OptdesignError(f"{path}: the study journal is a folder, not a file; move it away or choose "
                                 "another --out") from None
        except OSError as exc:
            raise OptdesignError(f"{path}: cannot open the study journal for reading and appending "
                                 f"({exc.strerror or exc})") from None
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.close()
            raise OptdesignError(f"{folder}: another study is running in this folder "
                                 "(its journal is locked); wait for it or choose another --out") from None
        try:
            now = os.stat(path)
        except FileNotFoundError:
            now = None
        mine = os.fstat(fh.fileno())
        if now is not None and (now.st_ino, now.st_dev) == (mine.st_ino, mine.st_dev):
            return fh
        fh.close()                           # the folder was replaced meanwhile: lock the new journal
    raise OptdesignError(f"{path}: could not lock the study journal (the folder keeps being replaced)")


def _write_synced(path: Path, data: bytes):
    with open(path, "xb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    _fsync_dir(path.parent)


def _fsync_dir(folder: Path):
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
