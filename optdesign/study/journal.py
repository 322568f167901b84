"""The study journal: the append-only record of finished cases, and how its folder is written.

Loss-free by construction:

* ``journal.jsonl`` gets one line per finished case, written with a single ``write`` and made
  durable with ``fsync`` before the next case is recorded.  A process killed at any instant
  leaves at most one torn last line (no newline, or not valid JSON); :meth:`Journal.open`
  ignores it and cuts it off before appending.  Lines are keyed by the case's id, a digest of
  everything its result depends on, so a resumed study (or a changed one in the same folder)
  takes a finished case only when it is the very same computation.
* ``cases.csv`` and every other file are written whole through a temporary file and a rename
  (:func:`optdesign.report.output.write_atomic`): never half-written.
* An exclusive lock on the journal stops two runs from writing the same folder at once.
"""
from __future__ import annotations

import fcntl
import json
import os
from pathlib import Path

from ..errors import OptdesignError

JOURNAL = "journal.jsonl"


class Journal:
    """The append-only record of finished cases in ``folder`` (use as a context manager)."""

    def __init__(self, folder):
        self.path = Path(folder) / JOURNAL
        self.records: dict = {}
        self._fh = None

    def __enter__(self):
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.path, "a+b")
        try:
            fcntl.flock(self._fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._fh.close()
            raise OptdesignError(f"{self.path.parent}: another study is running in this folder "
                                 "(its journal is locked); wait for it or choose another --out") from None
        self._read()
        return self

    def __exit__(self, *exc):
        self._fh.close()
        self._fh = None

    def _read(self):
        """Load every complete line; cut a torn last line off the file."""
        fh = self._fh
        fh.seek(0)
        data = fh.read()
        good = 0
        for line in data.splitlines(keepends=True):
            if not line.endswith(b"\n"):
                break
            try:
                record = json.loads(line)
            except ValueError:
                break
            self.records[record["id"]] = record
            good += len(line)
        if good < len(data):
            fh.truncate(good)
            os.fsync(fh.fileno())
        fh.seek(0, os.SEEK_END)

    def add(self, record: dict):
        """Append one finished case, durably (one write, then fsync)."""
        line = json.dumps(record, separators=(",", ":")).encode() + b"\n"
        self._fh.write(line)
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self.records[record["id"]] = record
