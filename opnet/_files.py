"""Atomic file writes and the clean-up of temporary files left by killed processes (shared by data and training)."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["atomic_write", "tmp_name", "remove_stale_tmp"]


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
    finally:
        tmp.unlink(missing_ok=True)


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
