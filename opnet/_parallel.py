"""Batches of numpy work in one thread per core: numpy's elementwise arithmetic runs on one core and releases the
interpreter lock, so two batches side by side use two cores; the BLAS is held to one thread meanwhile, so that the
threads' matrix products do not oversubscribe the cores.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

from threadpoolctl import ThreadpoolController

__all__ = ["usable_cores", "thread_map"]

_CONTROLLER: list = []  # one ThreadpoolController, made at first use (finding the BLAS libraries takes ~4 ms)


def usable_cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def thread_map(fn, items, *, threads: int | None = None):
    """``fn(item)`` for each of ``items`` (a sized sequence), in order, yielded as each finishes in order: in
    ``threads`` threads (default: one per usable core, at most one per item) with a one-thread BLAS, or in this
    thread when one is enough. ``fn`` must be safe to call from several threads at once.
    """
    threads = min(len(items), usable_cores() if threads is None else threads)
    if threads <= 1:
        yield from map(fn, items)
        return
    if not _CONTROLLER:
        _CONTROLLER.append(ThreadpoolController())
    with _CONTROLLER[0].limit(limits=1, user_api="blas"), ThreadPoolExecutor(threads) as pool:
        yield from pool.map(fn, items)
