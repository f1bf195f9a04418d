"""Shape data: parametric collections (humans, heads, hands from the ``anny`` body model), your own meshes,
and smooth toy shapes for tutorials and tests.

::

    ds = opnet.data.load_collection("humans", preset="quick", root=DIR)   # builds if missing
    ds.vertices       # (N, n, 3) float32
    ds.faces          # (m, 3) int
    ds.operators      # (N, 3, k, k) float32: area, conformal, extrinsic
    ds.split          # (N,) "train" | "val" | "test" | "test_subjects"
    ds.subcollection  # (N,) "subject03/walk"
    ds.base_basis     # the stored base eigenbasis (.evals, .evecs, .mass)
    comp = opnet.data.mapped_collection(ds, "2k")   # the same shapes, operators through computed maps
"""

from . import toy
from .collections import (
    SPLITS,
    Collection,
    CollectionError,
    default_root,
    load_collection,
    load_folder,
    read_collection,
    save_collection,
)
from .mapped import mapped_collection
from .splits import furthest_point_subset, hausdorff, make_splits

__all__ = [
    "toy",
    "SPLITS",
    "Collection",
    "CollectionError",
    "load_collection",
    "load_folder",
    "read_collection",
    "save_collection",
    "mapped_collection",
    "default_root",
    "make_splits",
    "hausdorff",
    "furthest_point_subset",
    "OperatorDataset",
]


def __getattr__(name):
    if name == "OperatorDataset":  # imports torch: only when asked for
        from .torch_dataset import OperatorDataset

        return OperatorDataset
    raise AttributeError(f"module 'opnet.data' has no attribute {name!r}")
