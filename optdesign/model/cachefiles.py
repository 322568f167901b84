"""Files of the compile cache that many processes share (a command, its forked workers, the
background compiler, other runs): atomic writes, file locks, and which process of a run is the
first to meet a failed entry (so that the run says so once)."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path


def first_in_this_run(marker: Path) -> bool:
    """True for the first process of this run (its process group: a command and the workers it
    forks) to meet the failed ``marker``: the others say nothing (a failure found by each of a
    command's workers was said once by each).  Recorded beside the marker (``.said``: the last
    run's group), under a file lock; where that cannot be done, True."""
    import fcntl

    try:
        fd = os.open(marker.with_name(marker.name + ".said"), os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        run = str(os.getpgid(0)).encode()
        if os.read(fd, 64) == run:
            return False
        os.lseek(fd, 0, os.SEEK_SET)
        os.ftruncate(fd, 0)
        os.write(fd, run)
        return True
    except OSError:
        return True
    finally:
        os.close(fd)


def write_atomic(path: Path, data: bytes):
    """``data`` into ``path`` through a temporary file beside it, renamed onto it once synced."""
    tmp = path.with_name(f"{path.name}.tmp{os.getpid()}")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class FileLock:
    """An exclusive lock on a file (fcntl), blocking or not; ``with`` gives whether it is held."""

    def __init__(self, path: Path, block: bool):
        self.path, self.block, self.fd = path, block, None

    def __enter__(self) -> bool:
        try:
            import fcntl
        except ImportError:   # pragma: no cover - no locks on this platform: build anyway
            return True
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | (0 if self.block else fcntl.LOCK_NB))
            return True
        except OSError:
            os.close(self.fd)
            self.fd = None
            return False

    def __exit__(self, *exc):
        if self.fd is not None:
            os.close(self.fd)   # releases the lock
            self.fd = None


def entry_name(prefix: str, parts) -> str:
    """A cache entry's name: ``prefix`` and a hash of ``parts`` (bytes, each ended by a NUL)."""
    h = hashlib.sha256()
    for part in parts:
        h.update(part)
        h.update(b"\0")
    return f"{prefix}-{h.hexdigest()[:32]}"


def code_hash(files) -> str:
    """A hash of the files' text: part of a cache key where that code writes what is cached, so
    that a change of it makes a new entry instead of reading one it no longer writes."""
    h = hashlib.sha256()
    for f in files:
        h.update(Path(f).read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


__all__ = ["FileLock", "code_hash", "entry_name", "first_in_this_run", "write_atomic"]

