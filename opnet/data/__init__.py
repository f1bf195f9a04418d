"""Shape data: parametric collections (humans, heads, hands from the ``anny`` body model), your own meshes,
and smooth toy shapes for tutorials and tests.

Layers, each importing only from those before it (``tests/test_data_layers.py`` checks it):

1. :mod:`~opnet.data.storage` (the :class:`Collection` and its on-disk format), :mod:`~opnet.data.splits`,
   :mod:`~opnet.data.subjects`, :mod:`~opnet.data.motion`, :mod:`~opnet.data.toy`;
2. :mod:`~opnet.data.build` (a collection from vertices) and :mod:`~opnet.data.anny_adapter` (the only module of
   opnet that imports anny);
3. :mod:`~opnet.data.humans`, :mod:`~opnet.data.heads`, :mod:`~opnet.data.hands` (shapes described in numpy),
   :mod:`~opnet.data.animals` (the rigged animals of an asset package, posed in numpy);
4. :mod:`~opnet.data.generators` (the named collections and :func:`load_collection`), :mod:`~opnet.data.folder`
   (your own meshes);
5. :mod:`~opnet.data.profiles` (what applies to each collection the reproduction runs on: :class:`Profile`);
6. :mod:`~opnet.data.mapped` (operators through computed maps), :mod:`~opnet.data.torch_dataset`.

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

from . import animals, toy
from .folder import load_folder
from .generators import generate_shapes, load_collection
from .mapped import half_mapped, labels_collection, mapped_collection, three_way_mapped
from .profiles import PROFILES, Profile, profile, profile_of, register_profile
from .splits import furthest_point_subset, hausdorff, make_splits
from .storage import SPLITS, Collection, CollectionError, default_root, read_collection, save_collection

__all__ = [
    "animals",
    "toy",
    "SPLITS",
    "Collection",
    "CollectionError",
    "load_collection",
    "generate_shapes",
    "load_folder",
    "read_collection",
    "save_collection",
    "mapped_collection",
    "labels_collection",
    "half_mapped",
    "three_way_mapped",
    "Profile",
    "PROFILES",
    "profile",
    "profile_of",
    "register_profile",
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
