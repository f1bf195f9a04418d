"""Atomic file writes, the clean-up of temporary files left by killed processes, one writer per folder (shared by
data, training and the reproduction), one builder at a time of a cache (anny's model data, opnet's collections), and
file descriptor 2 silenced for a compiled library's own prints.
"""

from __future__ import annotations

import errno
import os
import shutil
import sys
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

from .errors import DiskFullError, FolderInUseError

__all__ = [
    "atomic_write",
    "tmp_name",
    "remove_stale_tmp",
    "writer_lock",
    "build_lock",
    "silenced_fd2",
    "LOCK_NAME",
]

#: The file in a folder that :func:`writer_lock` locks; it holds the writer's PID and what it is (read only to say who
#: holds it).
LOCK_NAME = ".opnet-writer.lock"


def tmp_name(path: Path, suffix: str = "") -> Path:
    """The temporary name this process writes ``path`` under: ``.<name>.tmp-<pid><suffix>`` beside it."""
    return path.with_name(f".{path.name}.tmp-{os.getpid()}{suffix}")


def atomic_write(path, write) -> None:
    """Write ``path`` through ``write(binary_file)`` into a temporary file, fsync, rename over ``path``, fsync the
    folder: a reader (or a later run after a crash or SIGKILL) sees the old file or the new one, never a part.
    """
    path = Path(path)
    tmp = tmp_name(path)
    try:
        with open(tmp, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except (OSError, RuntimeError) as exc:
        written = tmp.stat().st_size if tmp.exists() else 0
        tmp.unlink(missing_ok=True)
        if _no_space(exc, path.parent):
            raise _disk_full(path, written) from exc
        raise
    finally:
        tmp.unlink(missing_ok=True)


def _no_space(exc: BaseException, folder: Path) -> bool:
    """Whether ``exc`` comes from a full device: an ``ENOSPC`` (or quota) ``OSError`` in its chain, or an error of a
    writer that reports none (torch's serializer: ``unexpected pos``) while the folder's device has under 1 MiB free.
    """
    seen = exc
    while seen is not None:
        if isinstance(seen, OSError) and seen.errno in (errno.ENOSPC, errno.EDQUOT):
            return True
        seen = seen.__cause__ or seen.__context__
    try:
        return isinstance(exc, RuntimeError) and shutil.disk_usage(folder).free < 1 << 20
    except OSError:
        return False


def _disk_full(path: Path, written: int) -> DiskFullError:
    """The error of a write of ``path`` that found the device full after ``written`` bytes."""
    free = shutil.disk_usage(path.parent).free
    previous = path.stat().st_size if path.exists() else 0
    needed = max(previous, written)
    size = f"about {_size(needed)} (its previous version's size)" if previous >= written else f"over {_size(needed)}"
    kept = f"the previous {path.name} is intact" if previous else f"there was no earlier {path.name}"
    return DiskFullError(
        errno.ENOSPC,
        f"no space left on the device for {path.name} in {path.parent}: {_size(free)} free, and it needs {size}; "
        f"{kept}. Free some space there (or give another folder) and run again: a run resumes from its last "
        "checkpoint.",
    )


def _size(n: float) -> str:
    """Bytes in a unit a person reads: ``"3.2 MB"``."""
    if n < 1000:
        return f"{n:.0f} B"
    for unit in ("kB", "MB", "GB"):
        n /= 1000
        if n < 1000 or unit == "GB":
            return f"{n:.1f} {unit}"


def remove_stale_tmp(paths) -> None:
    """Delete the temporary files among ``paths`` whose writing process (the pid in the name) no longer runs."""
    for tmp in paths:
        pid = tmp.name.rsplit("-", 1)[-1].split(".")[0]
        try:
            os.kill(int(pid), 0)
        except (ValueError, ProcessLookupError):
            tmp.unlink(missing_ok=True)
        except PermissionError:  # alive, someone else's
            pass


@contextmanager
def silenced_fd2():
    """File descriptor 2 sent to ``os.devnull`` for the block, and put back after it (``sys.stderr`` flushed first).

    A compiled library writes to fd 2 directly, past ``sys.stderr``, and a Jupyter kernel shows what reaches that
    descriptor, from its own process or a worker's, as the cell's stderr. Only around a call whose messages opnet
    checks or replaces itself: in a plain process ``sys.stderr`` writes to fd 2 as well, so a warning printed in
    the block is lost too (an exception still propagates). One thread at a time (the descriptor is the process's).
    """
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


@contextmanager
def writer_lock(folder, what: str):
    """Hold ``folder`` (created when missing) for this process's writing, ``what`` naming the writer in the message
    another gets: an exclusive lock on ``folder / LOCK_NAME`` (``fcntl.flock``), which the OS releases when this
    process ends, however it ends, so a killed writer leaves no stale lock. A second writer, in another process or in
    this one, gets :class:`FolderInUseError` at once. Readers take no lock: every file is written atomically
    (:func:`atomic_write`). Where ``fcntl`` is missing (Windows) no lock is taken.
    """
    fcntl = _fcntl()
    if fcntl is None:  # no advisory locks: one writer is the user's care there
        yield
        return
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid, _, holder = os.pread(fd, 256, 0).decode(errors="replace").strip().partition("\n")
            raise FolderInUseError(
                f"{folder} is being written by {holder or 'another writer'} (process {pid or 'unknown'}); wait for it "
                f"to end or stop it, or give this {what} another folder."
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n{what}\n".encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


#: The locks of :func:`build_lock` this process holds: path -> the thread holding it.
_HELD: dict = {}


#: What ``flock`` raises where the file system keeps no locks (NFS without lockd, Lustre without ``-o flock``, some
#: FUSE mounts): :func:`build_lock` then goes on without one.
_NO_LOCKS = {errno.ENOLCK, errno.ENOSYS, errno.EOPNOTSUPP, errno.EINVAL}


@contextmanager
def build_lock(path, what: str = "it"):
    """Wait for, then hold, an exclusive lock on the file ``path`` (its folder created when missing): one process at a
    time builds a cache, so another waits and then reads the finished file instead of a part of it (anny's model data,
    whose writer is not atomic) or instead of building it again (opnet's collections, minutes each); ``what`` names
    the work in the warning given when it has to wait, with the holder's PID. ``fcntl.flock``, released by the OS
    when the holder dies; the lock file stays (removing it would race with a process about to lock it). Re-entrant
    in one thread (a nested use holds it already); another thread of the process waits like another process. No lock
    where ``fcntl`` is missing (Windows), where the file cannot be opened at all (a read-only folder, whose cache
    another process cannot be writing either) or where the file system keeps no locks (a warning says so).
    """
    fcntl = _fcntl()
    path = Path(path).absolute()
    me = threading.get_ident()
    fd = None if fcntl is None or _HELD.get(path) == me else _open_lock_file(path)
    if fd is None:
        yield
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
            warnings.warn(
                f"waiting for another process (or thread) building {what} (lock {path}, held by process {holder})",
                stacklevel=3,
            )
            fcntl.flock(fd, fcntl.LOCK_EX)
        except OSError as exc:
            if exc.errno not in _NO_LOCKS:
                raise
            warnings.warn(f"{path.parent} keeps no file locks ({exc.strerror}): building {what} unlocked", stacklevel=3)
            os.close(fd)
            fd = None
        if fd is None:
            yield
            return
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, str(os.getpid()).encode(), 0)  # who holds it, for the warning of the next one
        except OSError:  # a lock file opened read-only: the lock holds all the same
            pass
        _HELD[path] = me
        try:
            yield
        finally:
            del _HELD[path]
    finally:
        if fd is not None:
            os.close(fd)  # releases the lock


def _open_lock_file(path: Path):
    """A descriptor of the lock file ``path``, created (with its folder) when missing, or opened read-only where it
    cannot be written (``flock`` works on it too); ``None`` where it cannot be opened at all.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        pass
    try:
        return os.open(path, os.O_RDONLY)
    except OSError:
        return None


def _fcntl():
    """The ``fcntl`` module, or ``None`` where it is missing (Windows)."""
    try:
        import fcntl
    except ImportError:
        return None
    return fcntl
