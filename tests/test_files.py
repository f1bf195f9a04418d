"""One builder at a time of a cache (anny's model data, written in place; opnet's collections): opnet._files.build_lock
and the body model's use of it; file descriptor 2 silenced around a compiled library's call (silenced_fd2)."""

import os
import subprocess
import sys
import time

import pytest

import opnet._files

fcntl = pytest.importorskip("fcntl")  # advisory locks: none on Windows

# The writer: takes the lock, says so, waits until the reader is about to take it too, then writes the cache file in
# place in ten slow pieces (as anny's save_safetensors does, on the file's final name).
WRITER = """
import os, sys, time
from opnet._files import build_lock
lock, path, ready, waiting = sys.argv[1:]
with build_lock(lock):
    open(ready, "w").close()
    while not os.path.exists(waiting):
        time.sleep(0.01)
    with open(path, "w") as f:
        for i in range(10):
            f.write(f"piece {i}\\n"); f.flush(); time.sleep(0.2)
"""

# The reader: says it is about to take the lock, waits for it, then reads the file as anny's cache_builder does.
READER = """
import os, sys
from opnet._files import build_lock
lock, path, waiting = sys.argv[1:]
open(waiting, "w").close()
with build_lock(lock, "the test's file"):
    print(open(path).read() if os.path.exists(path) else "missing", end="")
"""


def _wait_for(path, process, seconds=60):
    deadline = time.monotonic() + seconds
    while not path.exists():
        assert process.poll() is None and time.monotonic() < deadline, f"{path.name} did not appear"
        time.sleep(0.02)


def test_a_second_process_waits_for_the_builder_and_reads_the_whole_file(tmp_path):
    lock, path = tmp_path / "cache" / ".lock", tmp_path / "model.safetensors"
    ready, waiting = tmp_path / "ready", tmp_path / "waiting"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(lock), str(path), str(ready), str(waiting)])
    try:
        _wait_for(ready, writer)  # the writer holds the lock
        args = [sys.executable, "-c", READER, str(lock), str(path), str(waiting)]
        read = subprocess.run(args, capture_output=True, text=True, timeout=120)
    finally:
        try:
            writer.wait(60)
        except subprocess.TimeoutExpired:  # the reader never came: the writer still waits for it
            writer.kill()
            writer.wait()
    assert writer.returncode == 0 and read.returncode == 0, read.stderr
    assert read.stdout == "".join(f"piece {i}\n" for i in range(10))  # not a part of it
    assert "waiting for another process (or thread) building the test's file" in read.stderr  # it said why it waits
    assert f"held by process {writer.pid})" in read.stderr  # and for whom


def test_a_file_system_without_locks_builds_unlocked_with_a_warning(tmp_path, monkeypatch):
    """Where flock fails for want of locks (NFS without lockd: ENOLCK; Lustre, some FUSE mounts), the build goes on
    without one and says so; another error of flock is raised, not swallowed."""
    import errno

    def no_locks(fd, operation):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    ran = []
    with pytest.warns(UserWarning, match="keeps no file locks.*building the cache unlocked"):
        with opnet._files.build_lock(tmp_path / ".lock", "the cache"):
            ran.append(True)
    assert ran == [True] and not opnet._files._HELD

    def broken(fd, operation):
        raise OSError(errno.EBADF, "Bad file descriptor")

    monkeypatch.setattr(fcntl, "flock", broken)
    with pytest.raises(OSError, match="Bad file descriptor"):
        with opnet._files.build_lock(tmp_path / ".lock", "the cache"):
            ran.append(False)
    assert ran == [True]


def test_a_killed_builder_leaves_no_lock_and_one_thread_may_nest_it(tmp_path):
    lock, ready = tmp_path / ".lock", tmp_path / "ready"
    hold = (
        f"from opnet._files import build_lock\nwith build_lock({str(lock)!r}):\n    open({str(ready)!r}, 'w').close()\n"
    )
    holder = subprocess.Popen([sys.executable, "-c", hold + "    import time; time.sleep(600)\n"])
    try:
        _wait_for(ready, holder)
        assert _held(lock)
    finally:
        holder.kill()
        holder.wait()
    assert not _held(lock)
    with opnet._files.build_lock(lock):  # taken at once
        assert _held(lock)
        with opnet._files.build_lock(lock):  # nested in one thread: held already, not a wait for itself
            assert _held(lock)
        assert _held(lock)
    assert not _held(lock)


def _held(lock) -> bool:
    """Whether another open file description holds ``lock``'s flock (``False`` where there is no such file)."""
    try:
        fd = os.open(lock, os.O_RDWR)
    except FileNotFoundError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)
    return False


def test_the_body_models_are_built_under_the_lock_in_annys_cache(monkeypatch, tmp_path):
    anny = pytest.importorskip("anny")  # the body model's extra
    from anny import paths

    from opnet.data import anny_adapter as adapter

    monkeypatch.setattr(paths, "_ANNY_CACHE_DIR", [tmp_path])
    monkeypatch.setattr(adapter, "_prepare_anny", lambda: None)  # Warp's import: seconds, not what is tested
    lock = tmp_path / ".opnet-build.lock"
    seen = []

    class Model:  # anny.Anny's stand-in: records whether the lock is held while it builds
        def __init__(self, **kw):
            seen.append((kw["topology"], _held(lock)))

        @classmethod
        def from_model_data(cls, data, **kw):
            seen.append(("from model data", _held(lock)))
            return cls(topology=data)

        def to(self, dtype):
            return self

        def eval(self):
            return self

        def requires_grad_(self, flag):
            return self

    monkeypatch.setattr(anny, "Anny", Model)
    monkeypatch.setattr(adapter, "_decimated_model_data", lambda n: seen.append((n, _held(lock))) or f"{n} vertices")
    builders = (adapter.human_model, adapter.head_model, adapter.hand_model)
    for build in builders:
        build.cache_clear()
    try:
        adapter.human_model("1k")
        adapter.human_model("2k")  # the decimated body: anny's cached data built from opnet's code
        adapter.head_model()
        adapter.hand_model()
    finally:
        for build in builders:
            build.cache_clear()
    assert seen == [
        ("notoes_collapse10pc", True),
        (2000, True),
        ("from model data", True),
        ("2000 vertices", True),
        ("head", True),
        ("hand.R", True),
    ]


def test_silenced_fd2_drops_what_a_compiled_library_writes_to_fd_2_and_puts_it_back(capfd):
    """What is written to file descriptor 2 in the block (as MeshFix's C code does) reaches no one; fd 2 works after
    it, also when the block raises."""
    os.write(2, b"before\n")
    with opnet._files.silenced_fd2():
        os.write(2, b"MeshFix could not fix everything\n")
    with pytest.raises(ValueError), opnet._files.silenced_fd2():
        os.write(2, b"then an error\n")
        raise ValueError("raised in the block")
    os.write(2, b"after\n")
    assert capfd.readouterr().err == "before\nafter\n"
