"""Inner products on vertex functions, expressed in a basis: ``K = Φᵀ M Φ``.

A shape difference (eq. 2 of the paper) needs one thing from an inner product: the
``k × k`` matrix ``K = Φᵀ M Φ`` of some positive semi-definite operator ``M`` on the
mesh's vertex functions, for a basis ``Φ`` ``(n, k)``. Subclass :class:`InnerProduct`
and implement :meth:`InnerProduct.project` to add a new one::

    class Gram(opnet.InnerProduct):
        name = "gram"
        def project(self, vertices, faces, evecs):
            F = evecs.T @ (opnet.vertex_areas(vertices, faces)[:, None] * vertices)
            return F @ F.T

Override :meth:`InnerProduct.project_batch` as well when a vectorised form over many
shapes with the same faces exists (the three built-ins do), and :meth:`InnerProduct.pull_back` when
the inner product has a better form on a mesh of another triangulation than the default
``(P Φ)ᵀ M (P Φ)`` (area and extrinsic lump their masses, as the fast path does). Implement
:meth:`InnerProduct.project_torch` (the same matrix from torch tensors, differentiable) to use it where the
coordinates are optimised: :func:`opnet.reconstruct` and :class:`opnet.torch_ops.ShapeDifferences`. The
built-ins are written once for numpy and torch (``opnet._backend`` holds the few operations that differ).

**Channels are data.** A channel is an inner product's :attr:`~InnerProduct.name` plus a digest of its
implementation (:func:`channel_digest`: the code of its class, without docstrings, and its parameters).
Collections and runs record both, so operators computed by one version of a class are never mixed with another's.
A channel is given as an instance, a class, a built-in or registered name (:func:`register_inner_product`), or
``"package.module:Class"`` (imported; how the command line names your own class).

**The channel vocabulary** lives here too: :func:`~opnet.inner_products.split_channels` reads what a user or the command
line writes (``"area,mod:Class"``, a short name of :data:`~opnet.inner_products.CHANNEL_SETS` such as ``"A+E"``, one
channel or a sequence), :func:`channel_names` names channels without looking them up, and :func:`channel_label` gives a
combination its display name (``Int+Ext``, ``A+E``, ``Area+my ip``).
"""

from __future__ import annotations

import ast
import hashlib
import importlib
import inspect
import textwrap
import types

import numpy as np

from . import _backend as B
from . import _memo
from ._checks import describe
from ._deprecation import renamed_keyword
from .mesh import REFUSE_QUALITY
from .spectral import (
    areas_and_cotan_weights,
    areas_weights_and_worst_quality,
    cotan_edge_weights,
    vertex_areas,
    vertex_normals,
)

__all__ = [
    "InnerProduct",
    "AreaInnerProduct",
    "ConformalInnerProduct",
    "ExtrinsicInnerProduct",
    "OffsetAreaInnerProduct",
    "OffsetConformalInnerProduct",
    "offset_surface",
    "OFFSET",
    "INNER_PRODUCTS",
    "KINDS",
    "CHANNEL_SETS",
    "ChannelError",
    "split_channels",
    "channel_names",
    "channel_label",
    "get_inner_product",
    "get_inner_products",
    "register_inner_product",
    "known_inner_products",
    "has_torch_form",
    "channel_digest",
    "channel_identity",
    "rigid_motion_change",
    "checked_gram",
    "batch_grams",
    "is_built_in",
    "BUILT_IN_TYPES",
]


#: The paper's three shape differences, in the channel order of a collection built without ``channels=``.
KINDS = ("area", "conformal", "extrinsic")
#: The paper's input combinations (Table 1 and the ablation of Appendix B), by their short names.
CHANNEL_SETS = {
    "Area": ("area",),
    "Ext": ("extrinsic",),
    "Conf": ("conformal",),
    "A+E": ("area", "extrinsic"),
    "A+C": ("area", "conformal"),
    "E+C": ("conformal", "extrinsic"),
    "A+E+C": KINDS,
}


class ChannelError(ValueError):
    """A channel (inner product) that is unknown, that takes a built-in name, that cannot be imported, or that a
    collection or run recorded with another implementation; the message names the channel and the fix.
    """


class InnerProduct:
    """An inner product ``⟨f, g⟩ = fᵀ M g`` on vertex functions, one per shape.

    Subclasses set :attr:`name` (a channel's name: not a built-in one, without ``,`` or ``:``) and implement
    :meth:`project`; :meth:`project_torch` is optional.
    """

    name = "custom"

    def project(self, vertices: np.ndarray, faces: np.ndarray, evecs: np.ndarray) -> np.ndarray:
        """``Φᵀ M Φ`` ``(k, k)`` for one shape: vertices ``(n, 3)``, faces ``(m, 3)``, ``Φ`` ``(n, k)``.

        ``M`` is the operator of this inner product on that shape; ``Φ`` may be any
        basis of vertex functions on it (its own eigenbasis or the base's one).
        """
        raise NotImplementedError(f"{type(self).__name__} must implement project(vertices, faces, evecs).")

    def project_batch(self, vertices: np.ndarray, faces: np.ndarray, evecs: np.ndarray) -> np.ndarray:
        """``Φᵀ M_b Φ`` ``(B, k, k)`` for shapes ``(B, n, 3)`` sharing ``faces``; loops :meth:`project` by default."""
        return np.stack([self.project(v, faces, evecs) for v in vertices])

    def project_torch(self, vertices, faces, evecs):
        """``Φᵀ M_b Φ`` ``(B, k, k)`` from torch tensors, differentiable in ``vertices``.

        ``vertices`` ``(B, n, 3)`` (float32 or float64, any device), ``faces`` ``(m, 3)`` long and ``evecs``
        ``(n, k)`` in the vertices' dtype and device. Optional: it is what :func:`opnet.reconstruct` and
        :class:`opnet.torch_ops.ShapeDifferences` call; it must equal :meth:`project` (checked by
        :func:`opnet.testing.check_inner_product`).
        """
        raise NotImplementedError(
            f"{type(self).__name__} (inner product {self.name!r}) has no torch form: implement "
            "project_torch(vertices (B, n, 3) tensor, faces (m, 3) long tensor, evecs (n, k) tensor) -> (B, k, k), "
            "differentiable, to optimise coordinates against it (opnet.reconstruct, opnet.torch_ops)."
        )

    def pull_back(self, vertices: np.ndarray, faces: np.ndarray, to_base, evecs: np.ndarray) -> np.ndarray:
        """``(P Φ)ᵀ M (P Φ)`` ``(k, k)``: this inner product of a mesh with another triangulation, on base functions.

        ``vertices`` ``(n_mesh, 3)`` and ``faces`` are the mesh's, ``Φ`` ``(n_base, k)`` base functions and
        ``P`` ``(n_mesh, n_base)`` a soft map (row-stochastic, e.g. barycentric): mesh vertex ``p`` lies at
        the base point ``P[p] @ base_vertices``, so ``P Φ`` are the base functions carried onto the mesh.
        This is the paper's ``Cᵀ K_i C`` with a full target basis (``C = Φ_iᵀ A_i P Φ_0``), and the fast path
        when ``P`` is the identity.
        """
        return self.project(vertices, faces, to_base @ evecs)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


class AreaInnerProduct(InnerProduct):
    """The ``L²`` inner product, ``M = A`` (lumped mass). In a shape's own basis ``K = I``."""

    name = "area"
    version = 1  # bump when the numbers change (channel_digest)

    def project(self, vertices, faces, evecs):
        return _area_gram(vertices, faces, evecs)

    project_batch = project_torch = project

    def pull_back(self, vertices, faces, to_base, evecs):
        """The mesh's lumped masses carried onto the base vertices, ``Φᵀ diag(Pᵀ a) Φ``.

        This is ``(P Φ)ᵀ A (P Φ)`` lumped by rows, as the fast path's mass is lumped; it is exact for
        the identity map and, unlike the unlumped form, does not shrink the high frequencies that a
        barycentric ``P`` averages.
        """
        return B.weighted_gram(evecs, to_base.T @ vertex_areas(vertices, faces))


class ConformalInnerProduct(InnerProduct):
    """The ``H¹`` (Dirichlet) inner product, ``M = W`` (cotan stiffness). In a shape's own basis ``K = Λ``."""

    name = "conformal"
    version = 1

    def project(self, vertices, faces, evecs):
        return _conformal_gram(vertices, faces, evecs)

    project_batch = project_torch = project


class ExtrinsicInnerProduct(InnerProduct):
    """The paper's extrinsic inner product ``M = E^D`` (eq. 7; the difference is eq. 8).

    ``E(i, j) = ‖v_i − v_j‖² A_i A_j`` and ``E^D = diag(E 1) − E`` is the Laplacian of the
    complete graph with weights ``E``. Since ``E = u aᵀ + a uᵀ − 2 Y Yᵀ`` with
    ``u = A|v|²`` and ``Y = A v`` (rank ≤ 5), ``Φᵀ E^D Φ`` costs ``O(n k²)`` and no
    ``n × n`` matrix is formed.
    """

    name = "extrinsic"
    version = 1

    def project(self, vertices, faces, evecs):
        return _extrinsic_gram(evecs, vertex_areas(vertices, faces), vertices)

    project_batch = project_torch = project

    def pull_back(self, vertices, faces, to_base, evecs):
        """Lumped, like the area's: masses ``Pᵀ a`` on the base vertices, at the mass-weighted mean position
        of the mesh points that land around each (a base vertex that receives no mass has no weight).

        Unlike the area's, this is an approximation of ``(P Φ)ᵀ E^D (P Φ)``: the spread of the positions
        around each mean is dropped. It is exact for the identity map.
        """
        a = vertex_areas(vertices, faces)
        mass = to_base.T @ a
        moment = to_base.T @ (a[:, None] * vertices)
        where = mass > 0
        positions = np.zeros_like(moment)
        positions[where] = moment[where] / mass[where, None]
        return _extrinsic_gram(evecs, mass, positions)


#: The default offset distance of :class:`OffsetAreaInnerProduct` and :class:`OffsetConformalInnerProduct`, relative
#: to the square root of the shape's area (about 1.3 cm on a 1.7 m body, whose area is about 1.7 m²).
OFFSET = 0.01


def offset_surface(vertices, faces, t: float = OFFSET):
    """The offset surface ``X + d N(X)`` ``(..., n, 3)`` of vertices ``(..., n, 3)`` (numpy or torch) sharing ``faces``.

    ``N`` are the area-weighted unit vertex normals (:func:`opnet.vertex_normals`) and the distance is relative
    to the shape's size: ``d = t √(area of the shape)``, so the offset scales with the shape, and two poses of
    one body (nearly the same area) are offset by nearly the same distance. Keep ``d`` below the smallest radius of
    curvature that matters (on the 1k humans, fingers and toes are a few centimetres across): beyond it, the
    offset surface folds over itself there.
    """
    areas = vertex_areas(vertices, faces)  # (..., n)
    d = t * areas.sum(-1)[..., None, None] ** 0.5
    return vertices + d * vertex_normals(vertices, faces)


class OffsetAreaInnerProduct(InnerProduct):
    """The area inner product of the offset surface, ``M = A(X + d N)``
    (:func:`~opnet.inner_products.offset_surface`).

    FuncChar (Corman et al. 2017) encodes a shape by the area and conformal shape differences of the shape and of
    its offset surface, and proves that together they determine the shape up to a rigid motion. As ``t → 0`` the
    operator tends to the area one: to first order, each vertex's area grows by ``2 d H A`` (``H`` the mean
    curvature, positive where the surface bends away from its normals), so the new information is the
    mean-curvature-weighted area, which the intrinsic operators cannot see. ``t`` is relative to the shape's size
    (:data:`OFFSET` by default); it is a parameter of the channel's identity (:func:`channel_digest`).
    """

    name = "offset_area"
    version = 1

    def __init__(self, t: float = OFFSET):
        self.t = float(t)

    def project(self, vertices, faces, evecs):
        return _area_gram(offset_surface(vertices, faces, self.t), faces, evecs)

    project_batch = project_torch = project


class OffsetConformalInnerProduct(InnerProduct):
    """The conformal (Dirichlet) inner product of the offset surface, ``M = W(X + d N)``
    (:func:`~opnet.inner_products.offset_surface`).

    With :class:`OffsetAreaInnerProduct` and the shape's own area and conformal ones, FuncChar's full set. As ``t →
    0`` it tends to the conformal operator; a uniform scaling leaves cotangent weights unchanged, so offsetting a
    sphere changes nothing, and what it sees is how the offset stretches the surface unevenly (where its principal
    curvatures differ). ``t`` as for :class:`OffsetAreaInnerProduct`.
    """

    name = "offset_conformal"
    version = 1

    def __init__(self, t: float = OFFSET):
        self.t = float(t)

    def project(self, vertices, faces, evecs):
        return _conformal_gram(offset_surface(vertices, faces, self.t), faces, evecs)

    project_batch = project_torch = project


def _area_gram(vertices, faces, evecs):
    """``Φᵀ A Φ`` (numpy ``(..., k, k)`` or torch ``(B, k, k)``): the area inner product, written once."""
    return B.weighted_gram(evecs, vertex_areas(vertices, faces))


def _conformal_gram(vertices, faces, evecs):
    """``Φᵀ W Φ`` with the cotan stiffness ``W`` (numpy or torch)."""
    return _edge_gram(evecs, faces, cotan_edge_weights(vertices, faces))


def _edge_gram(evecs, faces, weights):
    """``Σ_e w_e (φ_i − φ_j)(φ_i − φ_j)ᵀ`` ``(..., k, k)`` for edge weights ``(..., e)`` on ``unique_edges(faces)``."""
    edges = B.edges(faces)
    if B.is_tensor(evecs) or B.is_tensor(weights):
        return B.weighted_gram(evecs[edges[:, 0]] - evecs[edges[:, 1]], weights)
    # numpy: the differences kept for the next batch on the same basis and faces (their table is then found without
    # hashing them again)
    diffs = _memo.by_content("edge differences", (evecs, faces), lambda: evecs[edges[:, 0]] - evecs[edges[:, 1]])
    return B.weighted_gram(diffs, weights)


def _extrinsic_gram(evecs, a, vertices):
    """``Φᵀ E^D Φ`` for masses ``a`` ``(..., n)`` at positions ``(..., n, 3)`` (numpy or torch)."""
    total = a.sum(-1)[..., None]
    # distances are translation invariant: centring first avoids cancellation (Σ y is then ~0, not exactly)
    v = vertices - (B.einsum("...n,...ni->...i", a, vertices) / total)[..., None, :]
    u = a * B.einsum("...ni,...ni->...n", v, v)
    y = a[..., None] * v  # (..., n, 3)
    rowsum = u * total + a * u.sum(-1)[..., None] - 2 * B.einsum("...ni,...i->...n", y, y.sum(-2))  # E 1
    p = B.project_columns(evecs, B.stack([a, u, y[..., 0], y[..., 1], y[..., 2]], -1))  # Φᵀ (a, u, Y): (..., k, 5)
    left = p[..., [1, 0, 2, 3, 4]]
    left[..., 2:] *= -2  # Φᵀ E Φ = (Φᵀu)(Φᵀa)ᵀ + (Φᵀa)(Φᵀu)ᵀ − 2 (ΦᵀY)(ΦᵀY)ᵀ, one product
    return B.weighted_gram(evecs, rowsum) - left @ p.swapaxes(-1, -2)


@renamed_keyword("kinds", "channels")
def get_inner_products(channels) -> list[InnerProduct]:
    """The inner products of a non-empty sequence of channels (each as in :func:`get_inner_product`), without
    repeats.
    """
    if isinstance(channels, (str, InnerProduct)):
        raise TypeError(f"channels must be a sequence of channels, e.g. ({channels!r},), not a single one.")
    ips = [get_inner_product(channel) for channel in channels]
    if not ips:
        raise ValueError("channels is empty: ask for at least one of opnet.KINDS (or an InnerProduct).")
    names = [ip.name for ip in ips]
    if len(set(names)) != len(names):
        raise ValueError(f"channels names a channel twice: {names}; give each once.")
    return ips


# -- the channel vocabulary: what users and the command line write, and display names ----------------------------

_LABELS = {KINDS: "Int+Ext", ("area", "conformal"): "Int", ("extrinsic",): "Ext"}
_SHORT = {"area": "Area", "conformal": "Conf", "extrinsic": "Ext"}


def split_channels(channels) -> list:
    """``"area,extrinsic"`` (names or ``"module:Class"``, comma-separated), a short name of
    :data:`~opnet.inner_products.CHANNEL_SETS` (``"A+E"``), one channel or a sequence of channels → a list of channels
    (names, instances, classes).
    """
    if isinstance(channels, str):
        if channels in CHANNEL_SETS:
            return list(CHANNEL_SETS[channels])
        return [c.strip() for c in channels.split(",")]
    if isinstance(channels, InnerProduct) or (isinstance(channels, type) and issubclass(channels, InnerProduct)):
        return [channels]
    return list(channels)


def channel_names(channels) -> tuple[str, ...]:
    """Names of ``channels`` (names as they are, inner products by their ``name``; a string is read by
    :func:`~opnet.inner_products.split_channels`), without looking the names up.
    """
    if isinstance(channels, str):
        channels = split_channels(channels)
    return tuple(c if isinstance(c, str) else get_inner_product(c).name for c in channels)


def channel_label(channels) -> str:
    """A display name of an input combination: the paper's ``Int+Ext`` (all three), ``Int`` (area + conformal),
    ``Ext`` (extrinsic) or the ablation's short names (``Area``, ``Conf``, ``A+E``, ``A+C``, ``E+C``); with channels
    of your own, their names joined by ``+`` (built-ins shortened: ``Area+my ip``). For display only: rows keep the
    channels themselves in their ``channels`` field.
    """
    channels = channel_names(channels)
    if set(channels) <= set(KINDS):
        key = tuple(c for c in KINDS if c in channels)
        if key in _LABELS:
            return _LABELS[key]
        return next(name for name, names in CHANNEL_SETS.items() if set(names) == set(key))
    return "+".join(_SHORT.get(c, c) for c in channels)


def checked_gram(ip: InnerProduct, method: str, *args) -> np.ndarray:
    """``ip.<method>(*args)`` (``"project"``, ``"project_batch"`` or ``"pull_back"``), checked: a real, finite,
    symmetric ``(k, k)`` matrix (``(B, k, k)`` for a batch), ``k`` the number of basis functions (the last
    argument's columns). A user-defined inner product that returns anything else is named in the error.
    """
    evecs = args[-1]
    shape = (len(args[0]), evecs.shape[1], evecs.shape[1]) if method == "project_batch" else (evecs.shape[1],) * 2
    K = getattr(ip, method)(*args)
    where = f"{type(ip).__name__}.{method} (inner product {ip.name!r})"
    if not isinstance(K, np.ndarray) or K.dtype.kind not in "fiu" or K.shape != shape:
        raise ValueError(
            f"{where} returned {describe(K)}; it must return Φᵀ M Φ, a real array of shape {shape} "
            f"(k = {shape[-1]} basis functions: evecs.shape[1])."
        )
    if not np.isfinite(K).all():
        raise ValueError(f"{where} returned NaN or infinite values; check the operator M on this shape.")
    scale = np.abs(K).max(axis=(-2, -1), keepdims=True)
    if np.any(np.abs(K - np.swapaxes(K, -1, -2)) > 1e-8 * scale):
        raise ValueError(
            f"{where} returned a non-symmetric matrix; Φᵀ M Φ of an inner product is symmetric "
            "(symmetrise M, e.g. (M + Mᵀ) / 2)."
        )
    return K


def batch_grams(ips, vertices: np.ndarray, faces: np.ndarray, evecs: np.ndarray, worst=None) -> list | None:
    """``Φᵀ M_b Φ`` ``(B, k, k)`` of each inner product in ``ips`` for shapes ``(B, n, 3)`` sharing ``faces`` (the
    fast path's batch). The paper's three built-ins share one pass over the faces (their operators need only the
    vertex areas and the cotan weights); any other is its :meth:`~InnerProduct.project_batch`, checked
    (:func:`checked_gram`).

    ``worst``: an array ``(B,)`` to fill with each shape's worst face quality from that pass
    (``opnet.spectral.areas_weights_and_worst_quality``; the shapes' spans checked already); then ``None`` is
    returned, and no operator computed, where a shape has a collapsed face (quality below
    ``opnet.mesh.REFUSE_QUALITY``).
    """
    paper = (AreaInnerProduct, ConformalInnerProduct, ExtrinsicInnerProduct)
    kind = [type(ip) if type(ip) in paper and is_built_in(ip) else None for ip in ips]
    if worst is not None:
        areas, weights, worst[:] = areas_weights_and_worst_quality(vertices, faces, ConformalInnerProduct in kind)
        if (worst < REFUSE_QUALITY).any():
            return None
    elif ConformalInnerProduct in kind:
        areas, weights = areas_and_cotan_weights(vertices, faces)
    elif any(kind):
        areas = vertex_areas(vertices, faces)
    out = []
    for ip, cls in zip(ips, kind):
        if cls is None:
            out.append(checked_gram(ip, "project_batch", vertices, faces, evecs))
            continue
        if cls is AreaInnerProduct:
            K = B.weighted_gram(evecs, areas)
        elif cls is ConformalInnerProduct:
            K = _edge_gram(evecs, faces, weights)
        else:
            K = _extrinsic_gram(evecs, areas, vertices)
        if not np.isfinite(K).all():
            raise ValueError(
                f"{type(ip).__name__}.project_batch (inner product {ip.name!r}) returned NaN or infinite values; "
                "check the shapes (opnet.mesh.check_shapes: collapsed faces, coordinates out of range)."
            )
        out.append(K)
    return out


def is_built_in(ip) -> bool:
    """Whether ``ip`` is an instance of a built-in class (:data:`BUILT_IN_TYPES`) that overrides none of its methods
    on the instance: its numpy code is opnet's, safe to run in several threads and to share a pass over the faces.
    """
    return type(ip) in BUILT_IN_TYPES and not {"project", "project_batch"} & set(vars(ip))


#: The built-in inner products by name: what a ``kind`` string stands for. The paper's three (:data:`KINDS`:
#: ``"area"``, ``"conformal"``, ``"extrinsic"``) and FuncChar's offset-surface ones (``"offset_area"``,
#: ``"offset_conformal"``, at the default distance :data:`OFFSET`; another ``t`` is an instance of their class).
INNER_PRODUCTS = {
    ip.name: ip
    for ip in (
        AreaInnerProduct(),
        ConformalInnerProduct(),
        ExtrinsicInnerProduct(),
        OffsetAreaInnerProduct(),
        OffsetConformalInnerProduct(),
    )
}
_REGISTRY: dict = {}  # the user's, by name (register_inner_product)
#: The classes of the built-in channels (numpy code that is safe to call from several threads at once).
BUILT_IN_TYPES = frozenset(type(ip) for ip in INNER_PRODUCTS.values())


def known_inner_products() -> dict:
    """The channels a name resolves to: the built-ins, then the registered ones (name → instance)."""
    return {**INNER_PRODUCTS, **_REGISTRY}


def _checked_custom(ip: InnerProduct) -> InnerProduct:
    name = ip.name
    if not isinstance(name, str) or not name.strip() or "," in name or ":" in name:
        raise ChannelError(
            f"{type(ip).__name__}.name must be a non-empty string without ',' or ':' (channels are listed as "
            f"'area,extrinsic' and imported as 'module:Class'), got {name!r}."
        )
    if name in CHANNEL_SETS:
        raise ChannelError(
            f"{type(ip).__name__}.name {name!r} is a short name of a set of built-in channels "
            f"({sorted(CHANNEL_SETS)}); give your inner product another name."
        )
    builtin = INNER_PRODUCTS.get(name)
    if builtin is not None and type(ip) is not type(builtin):
        raise ChannelError(
            f"{type(ip).__name__} takes the built-in channel name {name!r}; give your inner product a name of its "
            f"own (name = 'my {name}'): the built-ins are {sorted(INNER_PRODUCTS)}."
        )
    return ip


def get_inner_product(kind) -> InnerProduct:
    """The inner product of one channel: an :class:`InnerProduct` instance or subclass, a built-in name
    (``"area"``, ``"conformal"``, ``"extrinsic"``), a name registered with :func:`register_inner_product`, or
    ``"package.module:Class"`` (imported; the class is instantiated without arguments).
    """
    if isinstance(kind, InnerProduct):
        return _checked_custom(kind)
    if isinstance(kind, type) and issubclass(kind, InnerProduct):
        return _checked_custom(kind())
    known = known_inner_products()
    if isinstance(kind, str) and kind in known:
        return known[kind]
    if isinstance(kind, str) and ":" in kind:
        return _import_inner_product(kind)
    raise ChannelError(
        f"unknown channel {kind!r}; the known channels are {sorted(known)}. For your own inner product pass the "
        "instance (collection.with_channels([..., MyIP()])), opnet.register_inner_product(MyIP()) once, or "
        "'package.module:MyIP'."
    )


def _import_inner_product(spec: str) -> InnerProduct:
    module_name, _, attr = spec.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ChannelError(
            f"channel {spec!r}: the module {module_name!r} does not import ({type(exc).__name__}: {exc}); put it on "
            "the Python path (pip install -e your package, or PYTHONPATH) or fix the module name."
        ) from None
    obj = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ChannelError(f"channel {spec!r}: the module {module_name!r} has no {attr!r}.")
        obj = getattr(obj, part)
    if not (isinstance(obj, InnerProduct) or (isinstance(obj, type) and issubclass(obj, InnerProduct))):
        raise ChannelError(
            f"channel {spec!r} is a {type(obj).__name__}, not an opnet.InnerProduct (class or instance)."
        )
    return get_inner_product(obj)


def register_inner_product(ip, *, replace: bool = False) -> InnerProduct:
    """Make ``ip`` (an instance or class) known by its name, so that ``"its name"`` works wherever a channel is
    asked for (the command line, collections read back from disk). A name already registered by another
    implementation is refused unless ``replace=True``. Returns the instance.
    """
    ip = get_inner_product(ip if isinstance(ip, (InnerProduct, type)) else _not_an_inner_product(ip))
    if ip.name in INNER_PRODUCTS:
        return ip  # a built-in is known already
    old = _REGISTRY.get(ip.name)
    if old is not None and not replace and channel_digest(old) != channel_digest(ip):
        raise ChannelError(
            f"the channel name {ip.name!r} is registered already by another implementation "
            f"({type(old).__name__}, digest {channel_digest(old)}); pass replace=True, or choose another name."
        )
    _REGISTRY[ip.name] = ip
    return ip


def _not_an_inner_product(obj):
    raise TypeError(f"register_inner_product takes an opnet.InnerProduct instance or class, got {describe(obj)}.")


def has_torch_form(ip) -> bool:
    """Whether the inner product implements :meth:`InnerProduct.project_torch`."""
    return type(get_inner_product(ip)).project_torch is not InnerProduct.project_torch


# attributes that are not code: the interpreter's, the dataclass and abc machinery's, and what pickling adds
_NOT_CODE = ("__doc__", "__module__", "__qualname__", "__dict__", "__weakref__", "__firstlineno__", "__slotnames__")


def _code_text(cls: type) -> str:
    """The code of a class's own attributes: each function's syntax tree without its docstring (from its source,
    found through its code object, so a class redefined under the same name in one file or notebook is told
    apart), its compiled code where there is no source; other attributes by a stable text (:func:`_param_text`;
    dunder data such as ``__dataclass_fields__`` and ``_abc_impl`` left out).
    """
    parts = []
    for key, value in sorted(vars(cls).items()):
        func = getattr(value, "__func__", value)
        if hasattr(func, "__code__"):
            parts.append(f"{key}={_function_text(func)}")
        elif isinstance(value, property):
            parts.append(f"{key}=property({', '.join(_function_text(f) for f in (value.fget, value.fset) if f)})")
        elif not (key in _NOT_CODE or key.startswith("__") or key == "_abc_impl"):
            parts.append(f"{key}={_param_text(value)}")
    return "\n".join(parts)


def _function_text(func) -> str:
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    except (OSError, TypeError, SyntaxError, IndentationError):  # no source (exec, a lambda in an expression, ...)
        return _code_digest(func.__code__, func.__doc__)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (
            isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
            and body
            and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant)
            and isinstance(body[0].value.value, str)
        ):
            node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree)


def _code_digest(code: types.CodeType, doc: str | None = None) -> str:
    consts = [_code_digest(c) if isinstance(c, types.CodeType) else repr(c) for c in code.co_consts if c is not doc]
    return hashlib.sha256(repr((code.co_code, code.co_names, code.co_varnames, consts)).encode()).hexdigest()


def _param_text(value) -> str:
    """A text of a parameter that is the same in every process: arrays by a digest of their bytes, containers
    element by element (sets sorted), functions by their code, and objects whose ``repr`` shows a memory address by
    their type alone.
    """
    if isinstance(value, np.ndarray):
        return f"array{value.shape}{value.dtype}:{hashlib.sha256(np.ascontiguousarray(value).data).hexdigest()}"
    if isinstance(value, (list, tuple)):
        return f"{type(value).__name__}({', '.join(map(_param_text, value))})"
    if isinstance(value, (set, frozenset)):
        return f"{type(value).__name__}({', '.join(sorted(map(_param_text, value)))})"
    if isinstance(value, dict):
        return "{" + ", ".join(sorted(f"{_param_text(k)}: {_param_text(v)}" for k, v in value.items())) + "}"
    func = getattr(value, "__func__", value)
    if hasattr(func, "__code__"):
        return _function_text(func)
    text = repr(value)
    return type(value).__qualname__ if " at 0x" in text else text


def channel_digest(ip) -> str:
    """16 hex digits identifying an inner product's implementation: its class's code and that of its bases up
    to :class:`InnerProduct` (docstrings and comments left out), and its instance's attributes (e.g. a
    parameter ``t``; attributes starting with ``_`` are taken for caches and left out). Editing the code of a class
    changes it, so its operators stored before are refused.

    A class that sets ``version`` in its own body (any value) manages its identity itself: that class's part of the
    digest then depends on the version instead of its code (a subclass's own code still counts) (the built-ins do:
    their numbers are pinned by tests, and a refactoring of them must not make every stored collection stale). It
    also misses changes to module-level helpers that the class calls.
    """
    ip = get_inner_product(ip)
    h = hashlib.sha256()
    for cls in type(ip).__mro__:
        if cls in (InnerProduct, object):
            continue
        own = vars(cls).get("version")  # a class's own version stands for its code; a subclass's code still counts
        code = f"version {own!r}" if own is not None else _code_text(cls)
        h.update(f"{cls.__qualname__}\n{code}\n".encode())  # not its module: moving a class keeps its identity
    params = sorted((k, _param_text(v)) for k, v in vars(ip).items() if not k.startswith("_"))  # _x: caches
    h.update(repr(params).encode())
    return h.hexdigest()[:16]


def channel_identity(ip) -> dict:
    """``{"name", "digest", "spec"}`` of a channel: what runs record. ``spec`` is ``"module:Class"`` when the class
    can be imported again (not one typed in a notebook or script run as ``__main__``), else ``None``.
    """
    ip = get_inner_product(ip)
    cls = type(ip)
    importable = cls.__module__ not in ("__main__", "builtins") and "<locals>" not in cls.__qualname__
    spec = f"{cls.__module__}:{cls.__qualname__}" if importable and ip.name not in INNER_PRODUCTS else None
    return {"name": ip.name, "digest": channel_digest(ip), "spec": spec}


def rigid_motion_change(ip, vertices: np.ndarray, faces: np.ndarray, evecs: np.ndarray) -> float:
    """Relative change ``‖K(R v + t) − K(v)‖ / ‖K(v)‖`` of ``Φᵀ M Φ`` under a fixed rotation and translation of
    one shape (``(n, 3)``); ~1e-15 for a rigid-invariant inner product (intrinsic or distance-based ones).
    """
    c, s = np.cos([0.3, -0.7, 1.1]), np.sin([0.3, -0.7, 1.1])
    rx = np.array([[1, 0, 0], [0, c[0], -s[0]], [0, s[0], c[0]]])
    ry = np.array([[c[1], 0, s[1]], [0, 1, 0], [-s[1], 0, c[1]]])
    rz = np.array([[c[2], -s[2], 0], [s[2], c[2], 0], [0, 0, 1]])
    size = np.ptp(vertices, axis=0).max()
    moved = vertices @ (rz @ ry @ rx).T + size * np.array([0.5, -1.0, 2.0])
    ip = get_inner_product(ip)
    K = checked_gram(ip, "project", vertices, faces, evecs)
    return float(np.linalg.norm(checked_gram(ip, "project", moved, faces, evecs) - K) / max(np.linalg.norm(K), 1e-300))
