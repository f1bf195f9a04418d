"""One builder at a time of a cache that another library writes in place (anny's model data): opnet._files.build_lock
and the body model's use of it."""

import fcntl
import os
import subprocess
import sys
import time

import pytest

import opnet._files

# The writer: takes the lock, says so, then writes the cache file in place in ten slow pieces (as anny's
# save_safetensors does, on the file's final name).
WRITER = """
import sys, time
from opnet._files import build_lock
lock, path, ready = sys.argv[1:]
with build_lock(lock):
    open(ready, "w").close()
    with open(path, "w") as f:
        for i in range(10):
            f.write(f"piece {i}\\n"); f.flush(); time.sleep(0.4)
"""

# The reader: waits for the lock, then reads the file the way anny's cache_builder does (exists, then load).
READER = """
import os, sys
from opnet._files import build_lock
lock, path = sys.argv[1:]
with build_lock(lock):
    print(open(path).read() if os.path.exists(path) else "missing", end="")
"""


def test_a_second_process_waits_for_the_builder_and_reads_the_whole_file(tmp_path):
    lock, path, ready = tmp_path / "cache" / ".lock", tmp_path / "model.safetensors", tmp_path / "ready"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(lock), str(path), str(ready)])
    try:
        deadline = time.monotonic() + 60
        while not ready.exists():  # the writer holds the lock
            assert writer.poll() is None and time.monotonic() < deadline, "the writer did not take the lock"
            time.sleep(0.02)
        read = subprocess.run([sys.executable, "-c", READER, str(lock), str(path)], capture_output=True, text=True)
    finally:
        writer.wait(60)
    assert writer.returncode == 0 and read.returncode == 0, read.stderr
    assert read.stdout == "".join(f"piece {i}\n" for i in range(10))  # not a part of it


def test_a_killed_builder_leaves_no_lock(tmp_path):
    lock, ready = tmp_path / ".lock", tmp_path / "ready"
    hold = (
        f"from opnet._files import build_lock\nwith build_lock({str(lock)!r}):\n    open({str(ready)!r}, 'w').close()\n"
    )
    holder = subprocess.Popen([sys.executable, "-c", hold + "    import time; time.sleep(600)\n"])
    deadline = time.monotonic() + 60
    while not ready.exists():
        assert holder.poll() is None and time.monotonic() < deadline
        time.sleep(0.02)
    assert _held(lock)
    holder.kill()
    holder.wait()
    assert not _held(lock)
    with opnet._files.build_lock(lock):  # taken at once
        assert _held(lock)


def _held(lock) -> bool:
    """Whether another open file description holds ``lock``'s flock."""
    fd = os.open(lock, os.O_RDWR)
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
    seen = []

    class Model:  # anny.Anny's stand-in: records whether the lock is held while it builds
        def __init__(self, **kw):
            seen.append((kw["topology"], _held(tmp_path / ".opnet-build.lock")))

        def to(self, dtype):
            return self

        def eval(self):
            return self

        def requires_grad_(self, flag):
            return self

    monkeypatch.setattr(anny, "Anny", Model)
    builders = (adapter.human_model, adapter.head_model, adapter.hand_model)
    for build in builders:
        build.cache_clear()
    try:
        adapter.human_model("1k")
        adapter.head_model()
        adapter.hand_model()
    finally:
        for build in builders:
            build.cache_clear()
    assert seen == [("notoes_collapse10pc", True), ("head", True), ("hand.R", True)]
