"""The only module of opnet that imports the body model `anny`_: model building, caching and evaluation.

:mod:`opnet.data.humans`, :mod:`~opnet.data.heads` and :mod:`~opnet.data.hands` describe shapes in numpy
(subjects, joint angles, expressions); everything that touches anny — its models, its result keys, the
internal functions used to rig the decimated 2k/5k bodies — lives here, so that an anny upgrade is checked
and mended in one place. Importing this module checks the installed anny against :data:`ANNY_VERSIONS`.

Anny builds and caches its model data on first use (in ``$ANNY_CACHE_DIR``, by default ``~/.cache/anny``): about
12 s for the body and 11 s for the hand on 2 cores, most of it parsing 1136 blend-shape files, which opnet has numpy
do (``_load_blend_shape``; anny's own line-by-line parser took 64 s for the body); the decimated bodies that
opnet builds itself are cached there too, under a key that includes :func:`model_code_version`, so that editing
opnet's model-building code rebuilds them instead of silently reusing the old ones. Models are kept in memory.

.. _anny: https://pypi.org/project/anny/
"""

from __future__ import annotations

import contextlib
import functools
import gzip
import hashlib
import re
import sys
import types
from importlib.metadata import version

import numpy as np
from tqdm.auto import tqdm

from .._extras import require
from .._files import build_lock, silenced_fd2
from .subjects import PHENOTYPES

#: The anny releases opnet is tested with (the decimated bodies use anny 0.6 internals).
ANNY_VERSIONS = ((0, 6, 2), (0, 7, 0))  # [lowest, first unsupported)


def _check_anny_version(found: str) -> None:
    parts = tuple(int(p) for p in re.findall(r"\d+", found)[:3])
    lo, hi = ANNY_VERSIONS
    if not lo <= parts < hi:
        want = f">={'.'.join(map(str, lo))},<{'.'.join(map(str, hi))}"
        raise ImportError(
            f"opnet's body models need anny {want} (they use anny's internals to rig the decimated bodies), "
            f"but anny {found} is installed: pip install 'anny{want}'."
        )


anny = require("anny", "opnet.data.anny_adapter")
_check_anny_version(version("anny"))
torch = require("torch", "opnet.data.anny_adapter")

__all__ = [
    "ANNY_VERSIONS",
    "RESOLUTIONS",
    "human_model",
    "head_model",
    "hand_model",
    "model_code_version",
    "faces",
    "template_vertices",
    "bone_labels",
    "facial_action_labels",
    "evaluate",
]

#: Human topologies by approximate vertex count. "1k" is anny's own 1229-vertex mesh; anny ships
#: no finer simplification of its body (its "collapse5pc"/"collapse3pc" meshes have 615 and 369
#: vertices), so "2k" and "5k" are quadric decimations of anny's full 12272-vertex "notoes" mesh
#: to exactly 2000 and 5000 vertices, rigged by anny's own retopology (blendshapes and skinning
#: weights interpolated at the projection of each vertex onto the full mesh).
RESOLUTIONS = {"1k": "notoes_collapse10pc", "2k": "notoes_quadric2000", "5k": "notoes_quadric5000"}

_QUADRIC_PREFIX = "notoes_quadric"


@functools.cache
def _prepare_anny() -> None:
    """What every model build needs first, once per process: Warp's import (:func:`_import_anny_warp`) and the
    numpy blend-shape parser (:func:`_load_blend_shape`) in place of anny's own.
    """
    _import_anny_warp()
    from anny.models import full_model

    if getattr(full_model, "load_blend_shape", None) is not None:
        full_model.load_blend_shape = functools.partial(_load_blend_shape, full_model.load_blend_shape)


def _load_blend_shape(anny_loader, filename, vertices_count, world_transformation, dtype):
    """The blend-shape loader of anny 0.6.2 (``full_model.load_blend_shape``): a gzipped text file of ``id dx dy dz``
    lines (decimetres) as a ``(vertices_count, 3)`` tensor of ``dtype`` in anny's frame, zero where no line names the
    vertex.

    anny parses the lines one by one into torch (about 1 s per 20 000 lines: 61 s of the body model's first build
    on 2 cores, for 6.9 million lines in 1136 files); here numpy parses the whole file at once, about 9× faster, and
    gives the same tensor bit for bit (a line's values are parsed to float64 and then cast to ``dtype`` either way;
    tested on the shipped files). A file of another layout is left to ``anny_loader``.
    """
    with gzip.open(filename, "rb") as f:
        tokens = f.read().split()
    try:
        data = np.array(tokens, dtype=np.float64).reshape(-1, 4)
    except ValueError:  # not four numbers a line: anny's own error
        return anny_loader(filename, vertices_count, world_transformation, dtype)
    ids = data[:, 0].astype(np.int64)
    if (ids != data[:, 0]).any() or (ids < 0).any() or (ids >= vertices_count).any():
        return anny_loader(filename, vertices_count, world_transformation, dtype)  # anny's own error
    last = len(ids) - 1 - np.unique(ids[::-1], return_index=True)[1]  # a vertex named twice: its last line, as anny
    blend = np.zeros((vertices_count, 3))
    blend[ids[last]] = data[last, 1:]
    return world_transformation.apply(torch.from_numpy(blend).to(dtype))


@functools.cache
def _import_anny_warp() -> None:
    """Import anny's NVIDIA Warp helpers (its retopology uses them when it builds a model's cache) the way a notebook
    needs: the module sets ``sys.stdout = sys.__stdout__`` when imported, which sends every later ``print`` of a
    Jupyter kernel to the terminal instead of the notebook, and Warp's first use prints a greeting and, on a machine
    without a GPU, a CUDA warning from C to file descriptor 2. Here ``sys.stdout`` is kept, fd 2 is silenced for the
    import, and Warp's log level stays at warnings (its kernels' load times are not printed either). Once per process.
    """
    try:
        import warp
    except ImportError:  # an anny without Warp's code paths
        return
    warp.config.log_level = max(warp.config.log_level, warp.LOG_WARNING)
    stdout = sys.stdout
    try:
        with silenced_fd2():
            import anny.utils.warp_mesh_utils  # noqa: F401
    finally:
        sys.stdout = stdout


def _decimated_notoes_model_data(n_vertices: int, code_version: str):
    """Anny model data on a quadric decimation of the "notoes" mesh to ``n_vertices`` vertices.

    Mirrors anny's ``build_alternative_topology_model_data`` (anny 0.6.2) with a decimated target
    mesh instead of a shipped one; the phenotype blendshapes are compacted as ``anny.Anny`` does.
    ``code_version`` is not used here: it is part of anny's cache key (see :func:`model_code_version`).
    """
    pv = require("pyvista", "opnet's 2k and 5k human models")
    from anny.models.full_model import build_anny_model_data
    from anny.models.model_data import RigConfig, TopologyConfig, with_bone_orientation
    from anny.models.model_transforms import (
        apply_anny_cached_orientation,
        apply_retopology_from_mesh,
        compact_phenotype_blendshapes,
    )
    from anny.models.retopology import _load_target_topology_mesh
    from anny.utils.mesh_utils import triangulate_faces

    rig = RigConfig.from_string("anny")
    reference = build_anny_model_data(
        rig=with_bone_orientation(rig, "blender"),
        topology=TopologyConfig.from_string("anny"),
        local_changes="none",
        facial_actions="none",
    )
    vertices, quads = _load_target_topology_mesh("notoes")
    faces = np.asarray(triangulate_faces(vertices, quads), dtype=np.int64)
    full = pv.PolyData(vertices.numpy(), np.hstack([np.full((len(faces), 1), 3), faces]).ravel())
    # a closed triangle mesh with V vertices has 2V - 4 faces
    decimated = full.decimate(1 - (2 * n_vertices - 4) / len(faces), volume_preservation=True)
    target_faces = torch.tensor(decimated.faces.reshape(-1, 4)[:, 1:], dtype=torch.int64)
    data = apply_retopology_from_mesh(
        reference,
        target_vertices=torch.as_tensor(np.asarray(decimated.points), dtype=torch.float64),
        target_faces=target_faces,
        source_vertices=reference.template_vertices,
        source_faces=reference.faces,
        symmetry_axis=0,
    )
    data = apply_anny_cached_orientation(data)
    return compact_phenotype_blendshapes(data, phenotypes="default")


def model_code_version(build=_decimated_notoes_model_data) -> str:
    """A digest (16 hex digits) of opnet's model-building function ``build`` as it runs, and of what it calls:
    its compiled code (not the file on disk, which may have been edited since it was imported) and the versions
    of anny and of VTK (the decimation).

    It is passed to ``build`` as ``code_version``, which anny's cache hashes with the other arguments:
    a changed function gets a new cache entry, never the model data the old code built.
    """
    pv = require("pyvista", "opnet's 2k and 5k human models")
    versions = f"anny {version('anny')} vtk {tuple(pv.vtk_version_info)}".encode()
    return hashlib.sha256(_code_digest(build.__code__) + versions).hexdigest()[:16]


def _code_digest(code: types.CodeType) -> bytes:
    """SHA-256 of compiled code: its bytecode, names and constants (nested functions included), the same in
    every process of one Python version (``marshal`` output is not: it depends on reference counts).
    """
    parts = [code.co_code, repr(code.co_names).encode(), repr(code.co_varnames).encode()]
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            parts.append(_code_digest(c))
        else:
            parts.append(repr(sorted(map(repr, c)) if isinstance(c, frozenset) else c).encode())
    return hashlib.sha256(b"\0".join(parts)).digest()


def _decimated_model_data(n_vertices: int):
    """Cached :func:`_decimated_notoes_model_data` (anny's ``cache_builder``, keyed by the code's version)."""
    from anny.models.model_data import cache_builder

    build = _decimated_notoes_model_data
    return cache_builder(build)(n_vertices, code_version=model_code_version(build))


def _one_builder():
    """The lock held while a model is built or read from anny's cache: anny writes a model's cache file in place
    (``save_safetensors`` on its final name), so a second process starting on a cold cache would read a part of it;
    with the lock it waits for the first to finish, then reads the whole file (:func:`opnet._files.build_lock` on
    ``.opnet-build.lock`` in anny's cache folder).
    """
    from anny.paths import get_anny_cache_path

    folder = get_anny_cache_path()
    if folder is None:  # anny without a cache: nothing written, nothing to wait for
        return contextlib.nullcontext()
    return build_lock(folder / ".opnet-build.lock", "anny's model data")


def _ready(model):
    return model.to(torch.float64).eval().requires_grad_(False)


@functools.lru_cache(maxsize=None)
def human_model(resolution: str = "1k"):
    """The anny body model of a resolution (:data:`RESOLUTIONS`), float64, dense LBS skinning.

    The same rig (104 bones, ``bone_labels``) for every resolution, so one pose array
    poses all of them alike. The decimated models' data is cached by anny next to its own.
    """
    if resolution not in RESOLUTIONS:
        raise ValueError(f"resolution must be one of {list(RESOLUTIONS)}, got {resolution!r}.")
    _prepare_anny()
    topology = RESOLUTIONS[resolution]
    with _one_builder():
        if topology.startswith(_QUADRIC_PREFIX):
            model = anny.Anny.from_model_data(
                _decimated_model_data(int(topology[len(_QUADRIC_PREFIX) :])),
                skinning_method="lbs",
                pose_parameterization="local-ref",
                bone_orientation="cached",
                root_identity_orientation=False,
            )
        else:
            model = anny.Anny(topology=topology, skinning_method="lbs")
    return _ready(model)


@functools.lru_cache(maxsize=None)
def head_model():
    """Anny's head model (``topology="head"``, rig ``"anny-head"``) with its 52 facial actions, float64."""
    _prepare_anny()
    with _one_builder():
        model = anny.Anny(topology="head", rig="anny-head", facial_actions="all", skinning_method="lbs")
    return _ready(model)


@functools.lru_cache(maxsize=None)
def hand_model():
    """Anny's right hand (``topology="hand.R"``, rig ``"anny-hand.R"``: wrist and 20 finger bones), float64.

    Posed in anny's ``"local-bone"`` parameterization: each bone turns in its own axes, ``y`` along
    the bone and ``x`` the flexion hinge.
    """
    _prepare_anny()
    with _one_builder():
        model = anny.Anny(
            topology="hand.R", rig="anny-hand.R", skinning_method="lbs", pose_parameterization="local-bone"
        )
    return _ready(model)


def faces(model) -> np.ndarray:
    """A model's triangles ``(m, 3)`` int64."""
    return model.faces.numpy().astype(np.int64)


def template_vertices(model) -> np.ndarray:
    """A model's template vertices ``(n, 3)`` float64 in metres (a copy)."""
    return model.template_vertices.numpy().copy()


def bone_labels(model) -> tuple[str, ...]:
    """A model's bone names, in the order of its pose parameters."""
    return tuple(model.bone_labels)


def facial_action_labels(model) -> tuple[str, ...]:
    """A model's facial action names, in the order of its expression weights."""
    return tuple(model.facial_action_labels)


def _posed(result, vertices):
    return result["vertices"][:, vertices]


def _rest_from_root(result, vertices):
    # the facial actions are blendshapes of the rest mesh, placed with the root joint at the origin
    return result["rest_vertices"][:, vertices] - result["rest_bone_heads"][:, :1]


def _posed_in_rest_root(result, vertices):
    # with an identity root delta anny puts the root bone at the origin with identity axes;
    # turning by the rest root orientation brings the part back to its rest orientation
    return torch.einsum("bij,bnj->bni", result["rest_bone_poses"][:, 0, :3, :3], result["vertices"][:, vertices])


_READERS = {"posed": _posed, "rest_from_root": _rest_from_root, "posed_in_rest_root": _posed_in_rest_root}


def evaluate(model, subjects: np.ndarray, *, read: str, vertices=None, batch_size: int = 256, **inputs) -> np.ndarray:
    """Vertices ``(N, n, 3)`` float64 in metres from batches of model calls on ``subjects`` ``(N, 6)``.

    Parameters
    ----------
    model : an anny model (:func:`human_model`, :func:`head_model`, :func:`hand_model`).
    subjects : (N, 6) phenotype values in :data:`~opnet.data.subjects.PHENOTYPES` order.
    read : which vertices: ``"posed"``; ``"rest_from_root"`` (the unposed mesh with its root joint at the
        origin); ``"posed_in_rest_root"`` (posed, the root bone kept in its rest orientation at the origin).
    vertices : indices of the vertices to keep (default all).
    batch_size : shapes per model call.
    inputs : per-shape arrays ``(N, ...)`` passed to the model by keyword (``pose_parameters``,
        ``facial_actions``).
    """
    if read not in _READERS:
        raise ValueError(f"read must be one of {list(_READERS)}, got {read!r}.")
    keep = slice(None) if vertices is None else torch.as_tensor(np.atleast_1d(np.asarray(vertices, dtype=np.int64)))
    reader, n_vertices = _READERS[read], model.template_vertices[keep].shape[0]
    out = np.empty((len(subjects), n_vertices, 3))
    starts = range(0, len(subjects), batch_size)
    with torch.no_grad():
        for start in tqdm(starts, desc="meshes", unit="batch", disable=len(starts) < 8):
            batch = slice(start, start + batch_size)
            s = torch.from_numpy(subjects[batch])
            result = model(
                phenotype_kwargs={label: s[:, i] for i, label in enumerate(PHENOTYPES)},
                **{key: torch.from_numpy(value[batch]) for key, value in inputs.items()},
            )
            out[batch] = reader(result, keep).numpy()
    return out
