"""Shape data: parametric collections (humans, heads, hands from the ``anny`` body model), your own meshes,
and smooth toy shapes for tutorials and tests.

Layers, each importing only those below it: :mod:`~opnet.data.storage` (the :class:`Collection` and its
on-disk format) and :mod:`~opnet.data.build` (a collection from vertices); :mod:`~opnet.data.humans`,
:mod:`~opnet.data.heads`, :mod:`~opnet.data.hands` (shapes described in numpy, evaluated by
:mod:`~opnet.data.anny_adapter`, the only module that imports anny); :mod:`~opnet.data.generators` (the named
collections and :func:`load_collection`), :mod:`~opnet.data.folder` (your own meshes) and
:mod:`~opnet.data.mapped` (operators through computed maps).

::

    ds = opnet.data.load_collection("humans", preset="quick", root=DIR)   # builds if missing
    ds.vertices       # (N, n, 3) float32
    ds.faces          # (m, 3) int
    ds.operators      # (N, 3, k, k) float32: area, conformal, extrinsic
    ds.split          # (N,) "train" | "val" | "test" | "test_subjects"
    ds.subcollection  # (N,) "subject03/walk"
    ds.subject        # (N,) "subject03"; ds.sequence("subject03", "walk") -> its indices
    ds.base_basis     # the stored base eigenbasis (.evals, .evecs, .mass)
    comp = opnet.data.mapped_collection(ds, "2k")   # the same shapes, operators through computed maps
"""

from . import toy
from .folder import load_folder
from .generators import load_collection
from .mapped import mapped_collection
from .splits import furthest_point_subset, hausdorff, make_splits
from .storage import SPLITS, Collection, CollectionError, default_root, read_collection, save_collection

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
