"""The few array operations that differ between numpy and torch, so that each built-in inner product is written
once (:mod:`opnet.inner_products`) and runs on numpy arrays (``project``, float64) and on torch tensors
(``project_torch``, differentiable, any device).

:func:`weighted_gram`, :func:`einsum` and :func:`edges` dispatch on the type of their argument; :func:`areas` and
:func:`edge_weights` are the torch forms that :func:`opnet.vertex_areas` and :func:`opnet.cotan_edge_weights` call
for a tensor. torch is imported only when a tensor is passed, so the numpy path never loads it.
"""

from __future__ import annotations

import numpy as np

from . import _memo
from .mesh import corner_edges, unique_edges

__all__ = [
    "is_tensor",
    "weighted_gram",
    "project_columns",
    "left_multiply",
    "stack",
    "areas",
    "normals",
    "edges",
    "edge_weights",
    "einsum",
]

# Entries of the column-product table built at once in numpy's batched product (bounds its memory to ~32 MB), and
# of a whole table kept for the next batch on the same basis (~128 MB: k = 60 on up to ~8700 rows).
_TABLE_ENTRIES = 4_000_000
_KEPT_TABLE_ENTRIES = 16_000_000
# Below this many weight vectors one product each is faster than reading the table, even a kept one (2 cores, k = 60,
# 2800 rows: 1.9 against 5.5 ms for one vector, 12 ms either way for 16)
_TABLE_ROWS = 16


def is_tensor(x) -> bool:
    """Whether ``x`` is a torch tensor (without importing torch)."""
    return type(x).__module__.split(".")[0] == "torch"


def einsum(spec: str, *operands):
    """``numpy.einsum`` or ``torch.einsum``, by the first operand's type."""
    if is_tensor(operands[0]):
        import torch

        return torch.einsum(spec, *operands)
    return np.einsum(spec, *operands)


def stack(arrays, axis: int):
    """``numpy.stack`` or ``torch.stack``, by the first array's type."""
    if is_tensor(arrays[0]):
        import torch

        return torch.stack(arrays, dim=axis)
    return np.stack(arrays, axis=axis)


def project_columns(phi, columns):
    """``Φᵀ c`` ``(..., k, c)`` for ``Φ`` ``(n, k)`` and columns ``(..., n, c)``: numpy as one matrix product over the
    whole batch (a broadcast product loops over it, and with a transposed ``Φ`` leaves BLAS), torch batched.
    """
    if is_tensor(columns) or columns.ndim == 2:
        return phi.T @ columns
    n, lead, c = columns.shape[-2], columns.shape[:-2], columns.shape[-1]
    flat = np.moveaxis(columns, -2, 0).reshape(n, -1)  # (n, ... · c)
    return np.moveaxis((phi.T @ flat).reshape(phi.shape[1], *lead, c), 0, -2)


def left_multiply(matrix, batch):
    """``M @ X_b`` ``(B, k, k')`` for one ``M`` ``(k, k)`` and a numpy batch ``(B, k, k')``, as one matrix product."""
    k, b, c = batch.shape[1], batch.shape[0], batch.shape[2]
    flat = np.moveaxis(batch, 0, 1).reshape(k, b * c)
    return np.moveaxis((matrix @ flat).reshape(matrix.shape[0], b, c), 1, 0)


def weighted_gram(phi, weights):
    """``Φᵀ diag(w) Φ`` ``(..., k, k)`` for ``Φ`` ``(p, k)`` and weights ``(..., p)``.

    numpy: for a batch of weight vectors the product is linear in ``w``, one matrix product ``w @ T`` with the
    table ``T[p, (i, j)] = Φ[p, i] Φ[p, j]`` (upper triangle), several times faster than one product per shape;
    for a batch, the table is kept for the next batch with the same ``Φ`` (built in chunks of rows, and not kept,
    when large); fewer than ``_TABLE_ROWS`` weight vectors take one product each (the two agree to rounding, so a
    shape's operators may differ in the last bits with the size of its batch). Always float64 and exactly symmetric.
    torch: one batched product (autograd through ``w``).
    """
    if is_tensor(weights):
        return (phi.T * weights.unsqueeze(-2)) @ phi
    if weights.ndim == 1:
        return phi.T @ (weights[:, None] * phi)
    k = phi.shape[1]
    flat = weights.reshape(-1, weights.shape[-1])
    iu, ju = np.triu_indices(k)
    if len(flat) < _TABLE_ROWS:  # a few shapes: building the table would cost more than the products
        upper = np.array([(phi.T @ (w[:, None] * phi))[iu, ju] for w in flat]).reshape(len(flat), len(iu))
    elif phi.shape[0] * len(iu) <= _KEPT_TABLE_ENTRIES:  # batches of one basis: the table reused
        upper = flat @ _memo.by_content("gram table", (phi,), lambda: _gram_table(phi, iu, ju))
    else:
        upper = np.zeros((len(flat), len(iu)))
        step = max(1, _TABLE_ENTRIES // len(iu))
        for s in range(0, phi.shape[0], step):
            upper += flat[:, s : s + step] @ _gram_table(phi[s : s + step], iu, ju)
    # both triangles in one gather (twice as fast as two scattered writes)
    full = _memo.by_content(f"symmetric positions {k}", (), lambda: _symmetric_positions(k))
    return np.take(upper, full, axis=1).astype(np.float64, copy=False).reshape(*weights.shape[:-1], k, k)


def _symmetric_positions(k: int) -> np.ndarray:
    """``(k²,)``: the column of ``triu_indices(k)`` that holds entry ``(i, j)`` of a symmetric matrix, row by row."""
    iu, ju = np.triu_indices(k)
    pos = np.empty(k * k, dtype=np.intp)
    pos[iu * k + ju] = pos[ju * k + iu] = np.arange(len(iu))
    return pos


def _gram_table(phi, iu, ju):
    """``T[p, (i, j)] = Φ[p, i] Φ[p, j]`` ``(p, len(iu))`` over the upper triangle ``(iu, ju)``."""
    return phi[:, iu] * phi[:, ju]


def areas(vertices, faces):
    """Barycentric lumped mass ``(..., n)`` (length²) of vertex tensors ``(..., n, 3)`` sharing ``faces`` ``(m, 3)``."""
    faces, cross = _face_cross(vertices, faces)
    third = ((cross * cross).sum(-1) ** 0.5 / 6.0).unsqueeze(-1).expand(*cross.shape[:-1], 3)
    out = vertices.new_zeros(vertices.shape[:-1])
    return out.index_add_(-1, faces.reshape(-1), third.reshape(*third.shape[:-2], -1))


def normals(vertices, faces):
    """Area-weighted unit vertex normals ``(..., n, 3)`` of vertex tensors ``(..., n, 3)`` sharing ``faces``."""
    faces, cross = _face_cross(vertices, faces)
    per_corner = cross.unsqueeze(-2).expand(*cross.shape[:-1], 3, 3)  # (..., m, 3 corners, 3)
    out = vertices.new_zeros(vertices.shape)
    summed = out.index_add_(-2, faces.reshape(-1), per_corner.reshape(*cross.shape[:-2], -1, 3))
    import torch

    tiny = torch.finfo(summed.dtype).tiny  # a vertex without area: a zero normal, not NaN
    return summed / (summed * summed).sum(-1, keepdim=True).clamp_min(tiny) ** 0.5


def edges(faces):
    """The sorted unique edges ``(e, 2)`` of ``faces`` (:func:`opnet.mesh.unique_edges`), in the type of ``faces``."""
    if not is_tensor(faces):
        return unique_edges(faces)
    return _topology(faces)[0]


def edge_weights(vertices, faces):
    """Cotan weights ``(cot α + cot β) / 2`` ``(..., e)`` of vertex tensors, on the edges :func:`edges` of ``faces``."""
    faces = _long(faces, vertices)
    _, corner_edge = _topology(faces)
    v = vertices[..., faces, :]  # (..., m, 3, 3)
    cots = []
    for c in range(3):
        e1, e2 = v[..., (c + 1) % 3, :] - v[..., c, :], v[..., (c + 2) % 3, :] - v[..., c, :]
        cross = _cross(e1, e2)
        cots.append((e1 * e2).sum(-1) / (cross * cross).sum(-1) ** 0.5)
    import torch

    cot = torch.stack(cots, dim=-1)  # (..., m, 3): the corner order of the sparse corner-to-edge matrix
    out = vertices.new_zeros(*vertices.shape[:-2], int(corner_edge.max()) + 1)
    return out.index_add_(-1, corner_edge, 0.5 * cot.reshape(*cot.shape[:-2], -1))


def _face_cross(vertices, faces):
    """``(faces as a long tensor, (b − a) × (c − a) per face (..., m, 3))``: twice each face's area along its normal."""
    faces = _long(faces, vertices)
    v = vertices[..., faces, :]  # (..., m, 3, 3)
    return faces, _cross(v[..., 1, :] - v[..., 0, :], v[..., 2, :] - v[..., 0, :])


def _cross(a, b):
    import torch

    return torch.linalg.cross(a, b)


def _long(faces, like):
    import torch

    if not is_tensor(faces):  # a copy: torch warns about a read-only array (a Mesh's faces)
        faces = np.array(faces, dtype=np.int64)
    return torch.as_tensor(faces, dtype=torch.long, device=like.device)


_TOPOLOGY: dict = {}


def _topology(faces):
    """``(edges (e, 2), corner_edge (3m,))`` long tensors on the faces' device: the unique edges and the edge
    opposite each corner. Cached by the faces' contents (a few triangulations per session).
    """
    import torch

    f = faces.detach().cpu().numpy().astype(np.int64)
    key = (f.shape, f.tobytes(), str(faces.device))
    if key not in _TOPOLOGY:
        if len(_TOPOLOGY) >= 8:
            _TOPOLOGY.clear()
        e = unique_edges(f)
        _TOPOLOGY[key] = (
            torch.as_tensor(e, dtype=torch.long, device=faces.device),
            torch.as_tensor(corner_edges(f, e), dtype=torch.long, device=faces.device),
        )
    return _TOPOLOGY[key]
