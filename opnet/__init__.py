"""opnet: OperatorNet (Huang et al., ICCV 2019) — shapes as shape-difference operators, and back.

Public API::

    mesh  = opnet.Mesh(vertices, faces)        # validated; raises opnet.MeshError
    mesh  = opnet.load_mesh(path)              # .ply .obj .off .stl via trimesh
    basis = opnet.eigenbasis(mesh, k)          # .evals (k,), .evecs (n, k), .mass (n,)
    D     = opnet.shape_difference(base_basis, target_mesh, kind, fmap=None)
    Ds    = opnet.shape_differences(base_basis, vertices)   # (B, 3, k, k), batched fast path
    G     = opnet.gram_matrix(basis, X);  Y = opnet.recover_embedding(G, basis)
    Dt    = opnet.interpolate(D0, D1, t, scheme="multiplicative" | "linear")
    DX    = opnet.analogy(DA, DB, DC)          # D_X = D_C D_A⁺ D_B
    opnet.testing.check_inner_product(MyInnerProduct(), mesh)   # for a new inner product: one line per failed property
    D     = opnet.encode(any_mesh, base_basis, fmap="computed")   # (3, k, k) through a computed map (pyFM)
    D     = opnet.encode(any_mesh, coll, fmap="computed")   # (C, k, k): the collection's channels, its base
    X     = opnet.decode(net, D)                 # (n, 3) on the base's triangulation (D: the network's channels)
    net   = opnet.OperatorNet(n_vertices, k=60)  # (B, 3, k, k) -> (B, n, 3); loss: opnet.rigid_alignment_loss
    coll  = opnet.data.load_collection("humans", "quick").with_channels(["area", "extrinsic", MyIP()])  # any channels
    net, history = opnet.train.fit(coll, channels=["area", MyIP()], depth=1, epochs=50, run_dir="runs/x")
    rows  = opnet.evaluate.evaluate(collection, [opnet.evaluate.operatornet_method(net, collection)])
    table = opnet.ablation(collection, channel_sets=[["area"], ["area", MyIP()]], depths=[1, 2], epochs=20)
    rows  = opnet.reproduce.reproduce("quick", "reproduce-quick")   # Table 1 + ablation -> results.json/md
    X     = opnet.reconstruct(operators, base_basis, init="base" | vertices)  # operator matching (refinement)
    Dt    = opnet.torch_ops.ShapeDifferences(base_basis)(X_tensor)            # differentiable in X (torch)
    alg   = opnet.apps.operatornet_algebra(net, collection)   # .interpolate(i, j, t), .analogy(a, b, c) as shapes
    opnet.widgets.show(opnet.widgets.interpolation_explorer(collection, [alg]))   # JupyterLab widgets

The modules ``train``, ``evaluate`` (home of ``decode``), ``experiments`` (home of ``ablation``), ``reproduce``,
``model``, ``torch_ops``, ``geometric``
(home of ``reconstruct``), ``apps`` and ``widgets`` use torch or the notebook stack, so they load on first use.
"""

from . import data, testing
from .algebra import analogy, interpolate, log_difference, relative_difference
from .errors import DiskFullError, FolderInUseError
from .fmaps import FunctionalMap, fmap_from_p2p, fmap_from_soft_map, identity_fmap
from .gram import gram_matrix, recover_embedding
from .inner_products import (
    INNER_PRODUCTS,
    AreaInnerProduct,
    ChannelError,
    ConformalInnerProduct,
    ExtrinsicInnerProduct,
    InnerProduct,
    OffsetAreaInnerProduct,
    OffsetConformalInnerProduct,
    channel_digest,
    get_inner_product,
    register_inner_product,
)
from .matching import SurfaceMap, compute_map, encode
from .mesh import Mesh, MeshError, MeshWarning, load_mesh
from .metrics import d_E, d_R, d_V, kabsch, mesh_volume, rigid_align
from .shape_difference import CHANNEL_SETS, KINDS, distortion_function, pinv_psd, shape_difference, shape_differences
from .spectral import Eigenbasis, cotan_edge_weights, eigenbasis, vertex_areas, vertex_normals

__version__ = "0.1.0"

__all__ = [
    "data",
    "testing",
    "Mesh",
    "MeshError",
    "MeshWarning",
    "load_mesh",
    "Eigenbasis",
    "eigenbasis",
    "vertex_areas",
    "vertex_normals",
    "cotan_edge_weights",
    "FunctionalMap",
    "fmap_from_p2p",
    "fmap_from_soft_map",
    "identity_fmap",
    "InnerProduct",
    "AreaInnerProduct",
    "ConformalInnerProduct",
    "ExtrinsicInnerProduct",
    "OffsetAreaInnerProduct",
    "OffsetConformalInnerProduct",
    "INNER_PRODUCTS",
    "get_inner_product",
    "register_inner_product",
    "channel_digest",
    "ChannelError",
    "FolderInUseError",
    "DiskFullError",
    "KINDS",
    "CHANNEL_SETS",
    "shape_difference",
    "shape_differences",
    "distortion_function",
    "pinv_psd",
    "gram_matrix",
    "recover_embedding",
    "matching",
    "SurfaceMap",
    "compute_map",
    "encode",
    "decode",
    "interpolate",
    "analogy",
    "relative_difference",
    "log_difference",
    "kabsch",
    "rigid_align",
    "d_R",
    "d_V",
    "d_E",
    "mesh_volume",
    "OperatorNet",
    "rigid_alignment_loss",
    "reconstruct",
    "model",
    "train",
    "evaluate",
    "reproduce",
    "experiments",
    "ablation",
    "torch_ops",
    "geometric",
    "apps",
    "widgets",
]

_TORCH_MODULES = (
    "model",
    "train",
    "evaluate",
    "reproduce",
    "experiments",
    "torch_ops",
    "geometric",
    "apps",
    "widgets",
)


def __getattr__(name):  # import torch only when the network is asked for
    import importlib

    try:
        if name in ("OperatorNet", "rigid_alignment_loss"):
            return getattr(importlib.import_module(".model", __name__), name)
        if name == "decode":
            return importlib.import_module(".evaluate", __name__).decode
        if name == "ablation":
            return importlib.import_module(".experiments", __name__).ablation
        if name == "reconstruct":
            return importlib.import_module(".geometric", __name__).reconstruct
        if name in _TORCH_MODULES:
            return importlib.import_module(f".{name}", __name__)
    except ModuleNotFoundError as exc:
        from ._extras import missing_extra

        error = missing_extra(exc, f"opnet.{name}")
        if error is None:
            raise
        raise error from exc
    raise AttributeError(f"module 'opnet' has no attribute {name!r}")
