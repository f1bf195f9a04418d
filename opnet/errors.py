"""The errors about the folders and files opnet writes, whatever writes them (training, collections, the
reproduction): raised by its one-writer lock and its atomic writes, exported as ``opnet.FolderInUseError`` and
``opnet.DiskFullError``.
"""

from __future__ import annotations

__all__ = ["FolderInUseError", "DiskFullError"]


class FolderInUseError(RuntimeError):
    """Another process is writing into the folder (a training into its run directory, a reproduction into its
    output folder); the message names the folder and the holder's PID.
    """


class DiskFullError(OSError):
    """The device has no space left for a file opnet writes (``errno.ENOSPC``); the message names the file, its
    folder, the free space and about how much the file needs. The file's previous version is intact.
    """
