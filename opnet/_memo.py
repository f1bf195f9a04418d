"""Values derived from arrays, kept by the arrays' contents: the topology of a triangle list (its edges, the sparse
matrices that scatter face and corner values) and the product tables of a basis, which every batch of shapes on
the same mesh and basis would otherwise rebuild.

Keys are a digest of the arrays' bytes, shapes and dtypes, so an array edited in place is a new key, never a stale
hit. Kept values are made read-only; the least recently used go first once :data:`MAX_BYTES` would be exceeded.
"""

from __future__ import annotations

import hashlib
import threading
import weakref
from collections import OrderedDict

import numpy as np
import scipy.sparse as sp

__all__ = ["by_content", "clear"]

#: Bytes of arrays kept at most (the k = 60 tables of a 1k-vertex mesh's basis and edges take ~60 MB).
MAX_BYTES = 512 * 2**20

_KEPT: OrderedDict = OrderedDict()  # key -> (value, bytes)
_LOCK = threading.Lock()  # the fast path's threads share the kept values
_TOTAL = [0]  # bytes kept
_FROZEN: dict = {}  # id of a kept array -> (weak reference to it, its digest)


def _digest(arrays) -> bytes:
    h = hashlib.blake2b(digest_size=20)
    for a in arrays:
        h.update(_array_digest(a))
    return h.digest()


def _array_digest(a) -> bytes:
    """The digest of one array's shape, dtype and bytes; a kept value (read-only, :func:`_freeze`) is hashed once,
    the first time it is a key.
    """
    known = _FROZEN.get(id(a))
    kept = known is not None and known[0]() is a and not a.flags.writeable
    if kept and known[1] is not None:
        return known[1]
    c = np.ascontiguousarray(a)
    h = hashlib.blake2b(f"{c.shape}{c.dtype.str};".encode(), digest_size=20)
    h.update(c.data)
    if kept:
        _FROZEN[id(a)] = (known[0], h.digest())
    return h.digest()


def _nbytes(value) -> int:
    if isinstance(value, tuple):
        return sum(map(_nbytes, value))
    if sp.issparse(value):
        return sum(getattr(value, n).nbytes for n in ("data", "indices", "indptr"))
    return value.nbytes


def _freeze(value):
    if isinstance(value, tuple):
        return tuple(map(_freeze, value))
    for a in (value.data, value.indices, value.indptr) if sp.issparse(value) else (value,):
        a.setflags(write=False)
    # a kept array that owns its bytes (no writeable array sees them) may key another value: its digest is taken
    # once, when first needed. The callback runs before the array's memory is freed, so a reused id is never
    # mistaken for it; it takes no lock (an eviction under _LOCK may run it).
    if isinstance(value, np.ndarray) and value.flags.owndata:
        _FROZEN[id(value)] = (weakref.ref(value, lambda _, i=id(value): _FROZEN.pop(i, None)), None)
    return value


def by_content(tag: str, arrays, build):
    """``build()`` (an array, a sparse matrix or a tuple of them), computed once per ``tag`` and contents of
    ``arrays``; a value larger than :data:`MAX_BYTES` is returned without being kept.
    """
    key = (tag, _digest(arrays))
    with _LOCK:
        if key in _KEPT:
            _KEPT.move_to_end(key)
            return _KEPT[key][0]
    value = _freeze(build())  # outside the lock: two threads may build one value, and keep either
    size = _nbytes(value)
    if size <= MAX_BYTES:
        with _LOCK:
            if key in _KEPT:  # another thread built it meanwhile: keep one
                return _KEPT[key][0]
            while _KEPT and _TOTAL[0] + size > MAX_BYTES:
                _TOTAL[0] -= _KEPT.popitem(last=False)[1][1]
            _KEPT[key] = (value, size)
            _TOTAL[0] += size
    return value


def clear() -> None:
    """Forget every kept value."""
    with _LOCK:
        _KEPT.clear()
        _TOTAL[0] = 0
