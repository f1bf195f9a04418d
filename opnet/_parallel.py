"""Batches of numpy work in one thread per core: numpy's elementwise arithmetic runs on one core and releases the
interpreter lock, so two batches side by side use two cores; the BLAS is held to one thread meanwhile, so that the
threads' matrix products do not oversubscribe the cores.
"""

from __future__ import annotations

import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

from threadpoolctl import ThreadpoolController

__all__ = ["usable_cores", "thread_map", "exit_with_parent", "cluster_backend", "chunk_map"]

# the one-thread BLAS while any thread_map runs, and the controller that found the BLAS libraries
_STATE = {"limiter": None, "active": 0, "controller": None, "modules": -1}
_LOCK = threading.Lock()
_WATCHED: dict = {}  # the parent a worker process watches (exit_with_parent), once per process


def usable_cores() -> int:
    """The cores this process may use: ``OPNET_THREADS`` when set, else the CPUs it may run on (Python 3.13's
    ``os.process_cpu_count``, or the affinity mask), at most the CPU quota of its cgroup (Linux containers).
    """
    if os.environ.get("OPNET_THREADS"):
        return max(1, int(os.environ["OPNET_THREADS"]))
    if hasattr(os, "process_cpu_count"):
        cores = os.process_cpu_count() or 1
    else:
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    try:  # cgroup v2: "max 100000" (no quota) or "200000 100000" (two CPUs' worth)
        quota, period = open("/sys/fs/cgroup/cpu.max").read().split()[:2]
        if quota != "max":
            cores = min(cores, max(1, int(int(quota) / int(period))))
    except (OSError, ValueError):
        pass
    return cores


def _one_blas_thread(enter: bool) -> None:
    """Hold the BLAS to one thread while any :func:`thread_map` runs; restore it when the last one ends."""
    with _LOCK:
        if enter:
            if _STATE["active"] == 0:
                # the controller made again once Python has imported modules since: a BLAS loaded since (torch's)
                # is held too (finding the libraries takes a few ms, a fifth of one shape's operators). A BLAS
                # loaded without a new module (ctypes) is missed until the next import.
                if _STATE["modules"] != len(sys.modules):
                    _STATE["controller"], _STATE["modules"] = ThreadpoolController(), len(sys.modules)
                _STATE["limiter"] = _STATE["controller"].limit(limits=1, user_api="blas")
            _STATE["active"] += 1
        else:
            _STATE["active"] -= 1
            if _STATE["active"] == 0:
                _STATE["limiter"].restore_original_limits()


def thread_map(fn, items, *, threads: int | None = None, hold_blas: bool = True):
    """``fn(item)`` for each of ``items`` (a sized sequence), in order, yielded as each finishes in order: in
    ``threads`` threads (default :func:`usable_cores`, at most one per item), or in this thread when one is enough.
    ``fn`` must be safe to call from several threads at once.

    With ``hold_blas`` (default) the BLAS runs one thread meanwhile, also in this thread, so that the results do not
    depend on the number of threads (a BLAS sums in an order that depends on its own thread count). Close the
    generator (``contextlib.closing``) when a caller may stop before the end: the BLAS gets its threads back then.
    """
    threads = min(len(items), usable_cores() if threads is None else threads)
    if hold_blas:
        _one_blas_thread(True)
    try:
        if threads <= 1:
            yield from map(fn, items)
        else:
            with ThreadPoolExecutor(threads) as pool:
                yield from pool.map(fn, items)
    finally:
        if hold_blas:
            _one_blas_thread(False)


def exit_with_parent(interval: float = 2.0) -> None:
    """In a worker process (joblib's, which outlive a killed parent until their task ends): end this process once the
    one that started it is gone, checked every ``interval`` seconds in a daemon thread (started once per process).
    What it was doing must be safe to stop at any moment, as a training is (it resumes from its last epoch).
    """
    if _WATCHED or not hasattr(os, "getppid"):
        return
    _WATCHED["parent"] = parent = os.getppid()

    def watch():
        while os.getppid() == parent:
            threading.Event().wait(interval)
        os._exit(1)

    threading.Thread(target=watch, name="opnet-exit-with-parent", daemon=True).start()


def cluster_backend():
    """The joblib backend the caller chose with ``joblib.parallel_config`` when it runs tasks beyond this machine's
    processes and threads (Dask's ``"dask"``, Ray's ...), else ``None`` (joblib's own loky, threading,
    multiprocessing or sequential backends, or joblib not installed).
    """
    try:
        from joblib import parallel
    except ImportError:
        return None
    backend, _ = parallel.get_active_backend()
    local = (
        parallel.LokyBackend,
        parallel.ThreadingBackend,
        parallel.MultiprocessingBackend,
        parallel.SequentialBackend,
    )
    return None if type(backend) in local else backend  # exact types: Ray's subclasses the multiprocessing one


def chunk_map(fn, chunks, *, here: bool = False):
    """``fn(chunk)`` for each of ``chunks``, yielded in order: as tasks of the cluster's joblib backend when one is
    active (:func:`cluster_backend`: one task per chunk, spread over all of its workers) and ``here`` is false, else
    one after the other in this process (``fn`` may use this machine's cores itself, as the operators' fast path
    does).
    """
    if here or cluster_backend() is None:
        yield from map(fn, chunks)
        return
    import joblib

    with joblib.Parallel(n_jobs=-1, return_as="generator") as parallel:
        yield from parallel(joblib.delayed(fn)(c) for c in chunks)
