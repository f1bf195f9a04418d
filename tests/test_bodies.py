"""Anny bodies, heads and hands (opnet.data.humans, heads, hands and anny_adapter): shapes, validity, motions,
determinism, the adapter's version check and model cache."""

import pytest

pytest.importorskip("anny")  # the data extra: skipped by a core-only install

import numpy as np
import torch
import trimesh

import opnet
from opnet.data import anny_adapter, hands, heads, humans
from opnet.data.subjects import AVERAGE_SUBJECT, PHENOTYPES, random_subjects

N_BONES = 104


@pytest.fixture(scope="module")
def rng():
    return np.random.default_rng(0)


@pytest.fixture(scope="module")
def sample():
    """Random subjects with a mix of action frames and random poses."""
    rng = np.random.default_rng(1)
    poses = np.concatenate([humans.action_poses(a, 8)[[2, 4]] for a in humans.ACTIONS] + [humans.random_poses(12, rng)])
    return random_subjects(len(poses), rng), poses


def _world_joints(subjects, poses):
    """Posed joint positions ``(N, bones, 3)`` and bone rotations relative to the rest ``(N, bones, 3, 3)``."""
    model = anny_adapter.human_model("1k")
    s = torch.from_numpy(subjects)
    with torch.no_grad():
        out = model(
            pose_parameters=torch.from_numpy(poses),
            phenotype_kwargs={k: s[:, i] for i, k in enumerate(PHENOTYPES)},
        )
    posed, rest = out["bone_poses"].numpy(), out["rest_bone_poses"].numpy()
    turn = posed[..., :3, :3] @ np.swapaxes(rest[..., :3, :3], -1, -2)
    return posed[..., :3, 3], turn


def _signed_flexion(joints, turns, labels, upper, lower, end, hinge):
    """Signed angle (degrees) between two limb segments about the posed hinge axis of ``upper``."""
    i, j, k = (labels.index(b) for b in (upper, lower, end))
    a, b = joints[:, j] - joints[:, i], joints[:, k] - joints[:, j]
    axis = np.einsum("nij,j->ni", turns[:, i], hinge)
    return np.degrees(np.arctan2(np.einsum("ni,ni->n", np.cross(a, b), axis), np.einsum("ni,ni->n", a, b)))


# -- humans ------------------------------------------------------------------------------------


def test_shapes_and_dtypes(rng):
    assert humans.ACTIONS and len(humans.ACTIONS) >= 10 and len(PHENOTYPES) == 6
    P = humans.action_poses("walk", 5)
    assert P.shape == (5, N_BONES, 4, 4) and P.dtype == np.float64
    assert humans.random_poses(3, rng).shape == (3, N_BONES, 4, 4)
    assert np.array_equal(humans.rest_pose(), np.broadcast_to(np.eye(4), (N_BONES, 4, 4)))
    S = random_subjects(7, rng)
    assert S.shape == (7, 6) and S.dtype == np.float64 and S.min() >= 0 and S.max() <= 1
    for res, n in [("1k", 1229), ("2k", 2000), ("5k", 5000)]:
        V = humans.human_vertices(S[:2], P[:2], res)
        f = humans.human_faces(res)
        assert V.shape == (2, n, 3) and V.dtype == np.float64
        assert f.dtype == np.int64 and f.shape[1] == 3 and f.max() == n - 1
    with pytest.raises(ValueError):
        humans.human_vertices(S[:2], P[:3])
    with pytest.raises(ValueError):
        humans.action_poses("moonwalk", 4)
    with pytest.raises(ValueError):
        humans.joint_poses({"knee_flex": 10})


def test_subjects_are_adults(rng):
    S = random_subjects(2000, rng)
    age = S[:, PHENOTYPES.index("age")]
    assert 0.77 <= age.min() and age.max() <= 0.86  # 20 to 70 years on anny's age axis
    assert S[:, 0].std() > 0.25  # both genders and everything in between
    heights = np.ptp(humans.human_vertices(S[:200], np.repeat(humans.rest_pose()[None], 200, 0))[..., 2], axis=1)
    assert 1.35 < heights.min() and heights.max() < 2.1


def test_poses_are_rotations(rng):
    P = np.concatenate(
        [humans.action_poses(a, 6, amplitude=1.5) for a in humans.ACTIONS] + [humans.random_poses(50, rng)]
    )
    R = P[..., :3, :3]
    assert np.allclose(R @ np.swapaxes(R, -1, -2), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0)
    assert np.array_equal(P[..., :3, 3], np.zeros(P.shape[:-2] + (3,)))
    assert np.array_equal(P[..., 3, :], np.broadcast_to([0.0, 0.0, 0.0, 1.0], P.shape[:-2] + (4,)))


def test_angles_are_clipped_to_limits():
    lo, hi = humans.JOINT_LIMITS["knee_flex.L"]
    over = humans.joint_poses({"knee_flex.L": [hi + 50, hi]})
    under = humans.joint_poses({"knee_flex.L": [lo - 50, lo]})
    assert np.allclose(over[0], over[1]) and np.allclose(under[0], under[1])


def test_actions_are_smooth_loops():
    n = 64
    for action in humans.ACTIONS:
        P = humans.action_poses(action, n)
        R = P[:, :, :3, :3]
        step = np.einsum("fbji,fbjk->fbik", R, np.roll(R, -1, axis=0))  # frame k to k+1, and last to first
        angle = np.degrees(np.arccos(np.clip((np.trace(step, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
        assert angle.max() < 20, action
        V = humans.human_vertices(np.tile(AVERAGE_SUBJECT, (n, 1)), P)
        assert np.linalg.norm(np.diff(V, axis=0), axis=-1).max() < 0.15, action
        assert np.ptp(V, axis=0).max() > 0.05, action  # it does move
    one_shot = ("arm_raise", "knee_bend", "jumping_jacks", "punch", "one_leg_balance", "wave", "forward_bend", "kick")
    for action in one_shot:
        assert np.allclose(humans.action_poses(action, 10)[0], humans.rest_pose()), action
    assert np.allclose(humans.action_poses("walk", 10, amplitude=0.0), humans.rest_pose())


def test_meshes_valid_at_every_resolution(sample):
    S, P = sample
    for res in humans.RESOLUTIONS:
        f = humans.human_faces(res)
        for v in humans.human_vertices(S, P, res):
            opnet.Mesh(v, f)  # raises on any defect
        rest = humans.human_vertices(np.array([AVERAGE_SUBJECT]), humans.rest_pose()[None], res)[0]
        mesh = trimesh.Trimesh(rest, f, process=False)
        assert mesh.is_watertight and len(mesh.split(only_watertight=False)) == 1


def test_resolutions_agree(sample):
    S, P = sample
    V = {res: humans.human_vertices(S, P, res) for res in humans.RESOLUTIONS}
    F = {res: humans.human_faces(res) for res in humans.RESOLUTIONS}
    area = {res: opnet.mesh.face_areas(V[res], F[res]).sum(-1) for res in V}
    for res in ("2k", "5k"):
        assert np.abs(area[res] / area["1k"] - 1).max() < 0.05
        assert np.abs(np.ptp(V[res], axis=1) - np.ptp(V["1k"], axis=1)).max() < 0.02  # metres
        assert len(F[res]) != len(F["1k"])


def test_knees_and_elbows_never_bend_backwards(rng):
    overbent = humans.joint_poses({"knee_flex.L": -90, "elbow_flex.R": -90})  # clipped to the limits
    poses = np.concatenate(
        [humans.action_poses(a, 16, amplitude=1.3) for a in humans.ACTIONS] + [humans.random_poses(200, rng), overbent]
    )
    subjects = random_subjects(len(poses), rng)
    joints, turns = _world_joints(subjects, poses)
    labels = anny_adapter.human_model("1k").bone_labels
    elbow = np.array(humans._LEFT_ELBOW_HINGE)
    for side, mirror in (("L", np.array([1, 1, 1])), ("R", np.array([1, -1, -1]))):
        knee = _signed_flexion(
            joints, turns, labels, f"upperleg01.{side}", f"lowerleg01.{side}", f"foot.{side}", np.array([1.0, 0, 0])
        )
        arm = _signed_flexion(
            joints, turns, labels, f"upperarm01.{side}", f"lowerarm01.{side}", f"wrist.{side}", elbow * mirror
        )
        assert knee.min() > 0 and knee.max() < 150, side
        assert arm.min() > 0 and arm.max() < 150, side


def test_no_limb_through_the_body(rng):
    """anny's triangle-triangle test between parts that share no bone: no action frame has an
    intersection (fingers touching each other aside), and random poses hardly ever do (a hand
    grazing a thigh, about 1 in 4000)."""
    from anny.utils.collision import SelfInterpenetrationModule

    model = anny_adapter.human_model("1k")
    detector = SelfInterpenetrationModule(model)
    faces = humans.human_faces("1k")
    weights, indices = model.vertex_bone_weights.numpy(), model.vertex_bone_indices.numpy()
    main_bone = indices[np.arange(len(indices)), weights.argmax(1)]
    finger = np.array(["finger" in label for label in model.bone_labels])[main_bone[faces[:, 0]]]

    def intersects(v):
        hit = detector.detect_self_intersections(torch.from_numpy(v)).numpy()
        bad = np.flatnonzero(hit >= 0)
        return not (finger[bad] & finger[hit[bad]]).all()

    poses = np.concatenate([humans.action_poses(a, 8) for a in humans.ACTIONS])
    subjects = random_subjects(len(poses), rng)
    assert not any(intersects(v) for v in humans.human_vertices(subjects, poses))
    random = humans.human_vertices(random_subjects(100, rng), humans.random_poses(100, rng))
    assert sum(intersects(v) for v in random) <= 2


def test_deterministic():
    S1, P1 = random_subjects(20, np.random.default_rng(5)), humans.random_poses(20, np.random.default_rng(6))
    S2, P2 = random_subjects(20, np.random.default_rng(5)), humans.random_poses(20, np.random.default_rng(6))
    assert np.array_equal(S1, S2) and np.array_equal(P1, P2)
    assert np.array_equal(humans.human_vertices(S1, P1, "2k"), humans.human_vertices(S2, P2, "2k"))
    assert np.array_equal(humans.action_poses("punch", 12), humans.action_poses("punch", 12))


# -- heads -------------------------------------------------------------------------------------


def test_heads(rng):
    assert anny_adapter.facial_action_labels(anny_adapter.head_model()) == heads.FACIAL_ACTIONS
    assert len(heads.HEAD_EXPRESSIONS) >= 8
    f = heads.head_faces()
    seq = heads.expression_sequence("smile", 8)
    assert seq.shape == (8, len(heads.FACIAL_ACTIONS)) and np.allclose(seq[0], 0)
    assert np.isclose(seq[4].max(), 1.0) and np.all(np.diff(seq[:5, heads.FACIAL_ACTIONS.index("mouthSmileLeft")]) > 0)
    W = np.concatenate(
        [
            np.stack([heads.expression_sequence(e, 2)[1] for e in heads.HEAD_EXPRESSIONS]),
            heads.random_expressions(10, rng),
        ]
    )
    assert W.min() >= 0 and W.max() <= 1
    V = heads.head_vertices(random_subjects(len(W), rng), W)
    assert V.shape == (len(W), f.max() + 1, 3) and V.dtype == np.float64
    for v in V:
        opnet.Mesh(v, f)
    neutral = heads.head_vertices(np.array([AVERAGE_SUBJECT]), np.zeros((1, len(heads.FACIAL_ACTIONS))))[0]
    nose = neutral[neutral[:, 1].argmin()]
    assert nose[2] > 0.05 and neutral[:, 2].max() > 0.15  # upright, facing -y, neck joint at the origin


# -- hands -------------------------------------------------------------------------------------


def test_hands(rng):
    assert len(hands.HAND_GESTURES) >= 8
    f = hands.hand_faces()
    seq = hands.gesture_sequence("fist", 8)
    assert seq.shape == (8, 21, 4, 4) and np.allclose(seq[0], np.eye(4))
    P = np.concatenate(
        [np.stack([hands.gesture_sequence(g, 2)[1] for g in hands.HAND_GESTURES]), hands.random_hand_poses(10, rng)]
    )
    V = hands.hand_vertices(random_subjects(len(P), rng), P)
    assert V.shape == (len(P), f.max() + 1, 3) and V.dtype == np.float64
    for v in V:
        opnet.Mesh(v, f)
    rest = hands.hand_vertices(np.array([AVERAGE_SUBJECT]), np.eye(4)[None, None].repeat(21, 1))[0]
    tip = rest[np.linalg.norm(rest, axis=1).argmax()]
    assert tip[2] < -0.05 and tip[1] < -0.05  # hanging as in the A-pose: fingers down and forward
    fist = hands.hand_vertices(np.array([AVERAGE_SUBJECT]), hands.gesture_sequence("fist", 2)[1:])[0]
    assert np.linalg.norm(fist, axis=1).max() < 0.8 * np.linalg.norm(rest, axis=1).max()


# -- the anny adapter --------------------------------------------------------------------------


@pytest.mark.parametrize("found", ["0.6.1", "0.7.0", "1.0"])
def test_an_unsupported_anny_is_named_at_import(found):
    with pytest.raises(ImportError, match=rf"need anny >=0\.6\.2,<0\.7.*but anny {found} is installed.*pip install"):
        anny_adapter._check_anny_version(found)
    for ok in ("0.6.2", "0.6.10", "0.6.3.dev1"):
        anny_adapter._check_anny_version(ok)


class _Unmoved:
    """A world transformation that leaves the blend shape as parsed."""

    def apply(self, x):
        return x


def test_the_blend_shape_parser_gives_annys_tensors_bit_for_bit(tmp_path):
    """opnet parses anny's blend-shape files with numpy (the models' first build, minutes → seconds); on shipped files
    of every size, and on a vertex named twice, the tensors equal anny's own parser's to the bit, in both dtypes; a
    file anny would refuse is left to anny, which raises its own error."""
    import gzip

    from anny.models import full_model

    anny_adapter._prepare_anny()
    ours = full_model.load_blend_shape
    assert ours.func is anny_adapter._load_blend_shape  # installed by every model build
    annys = ours.args[0]
    files = sorted((full_model.get_anny_root_dir() / "data").rglob("*.target.gz"), key=lambda f: f.stat().st_size)
    assert len(files) > 1000
    twice = tmp_path / "twice.target.gz"
    with gzip.open(twice, "wt") as f:
        f.write("2 0.1 0.2 0.3\n0 1e-3 -2.5 7\n2 -0.4 0.5 0.6\n")
    sample = [*files[:: len(files) // 6], files[-1], twice]
    for path in sample:
        for dtype in (torch.float32, torch.float64):
            expected = annys(path, 20000, _Unmoved(), dtype)
            assert torch.equal(ours(path, 20000, _Unmoved(), dtype), expected), path
    assert ours(twice, 3, _Unmoved(), torch.float64)[2].tolist() == [-0.4, 0.5, 0.6]  # the last line wins
    bad = {"outside": "0 0.1 0.2 0.3\n5 0 0 0\n", "short": "0 0.1 0.2\n1 0 0 0\n", "text": "0 0.1 0.2 x\n"}
    for name, text in bad.items():
        path = tmp_path / f"{name}.target.gz"
        with gzip.open(path, "wt") as f:
            f.write(text)
        with pytest.raises(Exception) as annys_error:
            annys(path, 3, _Unmoved(), torch.float64)
        with pytest.raises(type(annys_error.value)):
            ours(path, 3, _Unmoved(), torch.float64)


def test_editing_the_model_building_code_rebuilds_the_cached_model(tmp_path, monkeypatch):
    """Anny caches the decimated bodies' model data under a key of the builder's arguments; the key includes a
    digest of opnet's building code, so an edited builder is run again instead of answered from the old cache."""
    from anny.models.model_data import ModelData
    from anny.paths import get_anny_cache_path

    anny_adapter.human_model("1k")  # anny's own cache holds model data from here on
    stored = next(get_anny_cache_path().rglob("*.safetensors"))
    data = ModelData.load_safetensors(stored)
    monkeypatch.setattr("anny.paths._ANNY_CACHE_DIR", [tmp_path])
    runs = []

    def first(n_vertices, code_version):
        runs.append("first")
        return data

    def edited(n_vertices, code_version):
        runs.append("edited")  # the same function, edited
        return data

    for build in (first, edited):
        build.__name__ = "_decimated_notoes_model_data"
    monkeypatch.setattr(anny_adapter, "_decimated_notoes_model_data", first)
    anny_adapter._decimated_model_data(2000)
    anny_adapter._decimated_model_data(2000)
    assert runs == ["first"]  # the second call was answered from the cache
    monkeypatch.setattr(anny_adapter, "_decimated_notoes_model_data", edited)
    anny_adapter._decimated_model_data(2000)
    assert runs == ["first", "edited"]
    assert anny_adapter.model_code_version(first) != anny_adapter.model_code_version(edited)
    assert len(list(tmp_path.rglob("_decimated_notoes_model_data_*.safetensors"))) == 2


def test_the_adapter_lists_the_human_resolutions():
    assert set(anny_adapter.RESOLUTIONS) == set(humans.RESOLUTIONS)


def test_building_a_model_keeps_a_notebooks_stdout_and_prints_nothing_from_warp():
    """anny's Warp helpers, imported when a model's cache is built, set ``sys.stdout = sys.__stdout__`` (a Jupyter
    kernel's later prints then leave the notebook) and Warp prints a greeting and a CUDA warning from C; in a fresh
    process (Warp starts once), with a stand-in for the kernel's stdout, the adapter's import keeps both clean."""
    import subprocess
    import sys

    pytest.importorskip("warp")
    code = (
        "import io, sys; from opnet.data import anny_adapter; kernel = io.StringIO(); sys.stdout = kernel; "
        "anny_adapter._import_anny_warp(); assert sys.stdout is kernel, sys.stdout; "
        "assert 'anny.utils.warp_mesh_utils' in sys.modules; print('stderr works', file=sys.stderr)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stderr.strip() == "stderr works", result.stderr
    assert result.stdout == ""
