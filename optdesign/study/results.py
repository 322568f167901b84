"""What a study run produced (:class:`StudyResult`), and the interruption that keeps it."""
from __future__ import annotations

import dataclasses
from pathlib import Path

from ..errors import OptdesignError
from .rows import Rows


class StudyInterrupted(KeyboardInterrupt):
    """A study stopped by Ctrl-C; ``result`` holds what was finished (and kept)."""

    def __init__(self, message, result):
        super().__init__(message)
        self.result = result


class ClusterLost(OptdesignError):
    """The Dask scheduler was lost in the middle of a study: every case that had come back is
    kept in the journal (``finished`` of ``total``, in ``journal``); running the same study
    again with the same folder resumes it.  ``result`` holds what was finished."""

    def __init__(self, message, finished=0, total=0, journal=None, result=None):
        super().__init__(message)
        self.finished, self.total, self.journal, self.result = finished, total, journal, result


@dataclasses.dataclass(frozen=True)
class StudyResult:
    """What a study run produced: ``rows`` (one dict per finished case, in case order: the
    CSV's columns with numbers as numbers; a read-only :class:`~optdesign.study.rows.Rows` that
    holds them column by column and builds a row's dict when asked for), the folder and its
    files, and counts."""

    study: "Study"  # noqa: F821  (optdesign.study.study.Study)
    folder: Path
    rows: Rows               # a list of dicts given is turned into Rows
    complete: bool
    computed: int            # cases computed by this run
    reused: int              # finished cases found in the journal
    wall_s: float
    paths: list
    notes: tuple = ()        # what opening the journal found and did (a torn last line cut, damaged lines moved), files not written

    def __post_init__(self):
        if not isinstance(self.rows, Rows):
            object.__setattr__(self, "rows", Rows(self.rows))

    def __repr__(self):
        state = "complete" if self.complete else "incomplete"
        return (f"StudyResult({str(self.folder)!r}: {len(self.rows)} cases ({self.computed} computed now, "
                f"{self.reused} from the journal), {state})")

    def to_dict(self) -> dict:
        """Plain data (numbers, lists, dicts: ready for json.dumps); the study by its scene."""
        from ..scene.plain import plain, result_dict

        out = result_dict(self, "study", skip=("study", "rows"))
        out["rows"] = plain(list(self.rows))
        scene = getattr(self.study, "scene", None)
        if scene is not None:
            out.update(title=scene.title, file=scene.path)
        return plain(out)

    def column(self, name):
        """A column as a float array (missing values as nan)."""
        return self.rows.column(name)
