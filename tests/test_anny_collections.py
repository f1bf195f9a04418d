"""Collections built from the anny body model (humans, heads, hands): meshes, splits, determinism, caching."""

import numpy as np
import pytest
import trimesh

import opnet
from opnet.data import hands, heads
from opnet.data.humans import ACTIONS

# the fixtures `root` and `humans` (the quick humans, built once per test session) are in conftest.py


def test_api_fields(humans):
    N = len(humans)
    assert humans.vertices.shape == (N, 1229, 3) and humans.vertices.dtype == np.float32
    assert humans.operators.shape == (N, 3, 60, 60) and humans.operators.dtype == np.float32
    assert humans.split.shape == humans.subcollection.shape == (N,)
    assert humans.base_basis.evecs.shape == (1229, 60)
    assert humans.params["phenotypes"].shape == (N, 6)


def test_shared_watertight_connectivity(humans):
    rng = np.random.default_rng(0)
    for i in rng.choice(len(humans), 12, replace=False):
        mesh = humans.mesh(i)  # validates: one component, manifold, no zero-area faces
        assert trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).is_watertight
        assert opnet.mesh_volume(mesh.vertices, mesh.faces) > 0


def test_operators_are_those_of_the_stored_base(humans):
    i = humans.indices("test")[0]
    for c, kind in enumerate(opnet.KINDS):
        D = opnet.shape_difference(humans.base_basis, humans.mesh(i), kind)
        np.testing.assert_allclose(humans.operators[i, c], D, atol=1e-4 * np.abs(D).max())
    base = opnet.shape_difference(humans.base_basis, humans.base_basis.mesh, "area")
    np.testing.assert_allclose(base, np.eye(60), atol=1e-10)


def test_paper_like_splits(humans):
    test_sc = set(humans.subcollection[humans.split == "test"])
    assert len(test_sc) == 10  # ten held-out (subject, motion) sequences, as the paper's DFAUST test set
    assert set(humans.params["motion"][humans.split == "test"]) <= set(ACTIONS)
    train_sc = set(humans.subcollection[humans.split == "train"])
    for held in ("val", "test", "test_subjects"):
        assert set(humans.subcollection[humans.split == held]).isdisjoint(train_sc)
    unseen = set(humans.subjects("test_subjects"))
    assert unseen.isdisjoint(humans.subject[humans.split != "test_subjects"])
    assert all(sc.startswith(f"{s}/") for sc, s in zip(humans.subcollection, humans.subject))
    assert set(humans.split[humans.eval_subset]) == {"test"}


def test_cache_is_reused_and_upgrades_rebuild(humans, root, monkeypatch):
    again = opnet.data.load_collection("humans", "quick", root, seed=np.int64(0))
    np.testing.assert_array_equal(again.vertices, humans.vertices)
    from opnet.data import generators

    # a new generator version is another file: an upgrade rebuilds instead of failing
    monkeypatch.setattr(generators, "GENERATOR_VERSION", "test")
    rebuilt = opnet.data.load_collection("humans", "quick", root, progress=False)
    assert rebuilt.meta["generator_version"] == "test"
    assert (root / f"humans-quick-1k-seed0-v{humans.meta['generator_version']}.json").is_file()
    with pytest.raises(ValueError, match="seed must be an integer"):
        opnet.data.load_collection("humans", "quick", root, seed=0.5)


def test_sequences_have_no_repeated_frames(humans):
    for sc in set(humans.subcollection):
        frames = humans.vertices[humans.subcollection == sc].reshape((humans.subcollection == sc).sum(), -1)
        d = np.abs(frames[:, None] - frames[None]).max(-1)
        assert (d[np.triu_indices(len(frames), 1)] > 1e-4).all(), sc


def test_resolutions_hold_the_same_shapes(humans, root):
    fine = opnet.data.load_collection("humans", "quick", root, resolution="2k", progress=False)
    assert fine.vertices.shape[1] == 2000 and not np.array_equal(fine.faces.shape, humans.faces.shape)
    for a, b in (
        (fine.split, humans.split),
        (fine.subcollection, humans.subcollection),
        (fine.eval_subset, humans.eval_subset),
        (fine.params["controls"], humans.params["controls"]),
    ):
        np.testing.assert_array_equal(a, b)
    extent = lambda v: v.max(axis=1) - v.min(axis=1)  # noqa: E731
    np.testing.assert_allclose(extent(fine.vertices), extent(humans.vertices), atol=0.03)  # metres


def test_same_seed_same_collection(humans, tmp_path):
    rebuilt = opnet.data.load_collection("humans", "quick", tmp_path / "one", progress=False)
    again = opnet.data.load_collection("humans", "quick", tmp_path / "two", progress=False)
    np.testing.assert_array_equal(again.operators, rebuilt.operators)  # to the bit, by the same code
    np.testing.assert_array_equal(rebuilt.vertices, humans.vertices)
    # the fixture's may come from the data cache, written by an earlier opnet whose products rounded otherwise
    np.testing.assert_allclose(rebuilt.operators, humans.operators, rtol=0, atol=1e-6 * np.abs(humans.operators).max())
    np.testing.assert_array_equal(rebuilt.split, humans.split)
    other = opnet.data.load_collection("humans", "quick", tmp_path, seed=1, progress=False)
    assert not np.array_equal(other.split, humans.split)


def test_unknown_names_and_presets(root):
    with pytest.raises(ValueError, match="unknown collection"):
        opnet.data.load_collection("cats", "quick", root)
    with pytest.raises(ValueError, match="unknown preset"):
        opnet.data.load_collection("humans", "huge", root)


@pytest.mark.parametrize(
    "name, n_vertices, motions", [("heads", 4200, heads.HEAD_EXPRESSIONS), ("hands", 1609, hands.HAND_GESTURES)]
)
def test_part_collections(root, quick_collection, name, n_vertices, motions):
    coll = quick_collection(name)
    assert coll.vertices.shape[1:] == (n_vertices, 3) and coll.operators.shape[1:] == (3, 60, 60)
    assert set(coll.params["motion"]) == set(motions) | {"random"}
    assert len(set(coll.subcollection[coll.split == "test"])) == 10
    for i in np.random.default_rng(0).choice(len(coll), 5, replace=False):
        coll.mesh(i)  # one component, manifold, no degenerate faces
    mid = np.flatnonzero(coll.subcollection == coll.subcollection[0])  # a sequence moves away from the base
    drift = [np.linalg.norm(coll.operators[i, 2, 1:, 1:] - np.eye(59)) for i in mid]
    assert max(drift) > 1.1 * min(drift)  # the peak of the expression or gesture differs from its neutral frame
    with pytest.raises(ValueError, match="resolutions"):
        opnet.data.load_collection(name, "quick", root, resolution="2k")


def _same_held_out(humans, root, **draws):
    """The quick humans with ``draws`` (``load_collection``'s bodies, poses), checked to hold the same shapes out."""
    more = opnet.data.load_collection("humans", "quick", root, progress=False, **draws)
    assert len(more) == len(humans) and (more.split == humans.split).all()
    held = humans.split != "train"  # val and the test sets: the same shapes, bit for bit
    assert np.array_equal(more.vertices[held], humans.vertices[held])
    assert np.array_equal(more.operators[held], humans.operators[held])
    assert np.array_equal(more.eval_subset, humans.eval_subset)
    return more


@pytest.mark.parametrize("bodies", ["sequence", "shape", "mixed"])
def test_more_bodies_same_shapes_held_out(humans, root, bodies):
    more = _same_held_out(humans, root, bodies=bodies)
    train = humans.split == "train"
    np.testing.assert_array_equal(more.params["controls"], humans.params["controls"])  # the same poses
    kept = np.isclose(more.params["phenotypes"], humans.params["phenotypes"]).all(1)
    new = np.flatnonzero(train)[1::2] if bodies == "mixed" else np.flatnonzero(train)
    assert not kept[new].any() and kept[~np.isin(np.arange(len(humans)), new)].all()
    sequences = len(set(humans.subcollection[train]))
    expected = {"sequence": sequences, "shape": int(train.sum()), "mixed": len(new) + len(set(humans.subject[train]))}
    assert len(set(more.subject[train])) == expected[bodies] > len(set(humans.subject[train]))
    subs = {
        "sequence": sequences,
        "shape": int(train.sum()),
        "mixed": len(new) + len(set(humans.subcollection[new - 1])),
    }
    assert len(set(more.subcollection[train])) == subs[bodies]  # a sub-collection is one body's motion
    # each training body's shapes share one phenotype; the file is another one than the default's
    for s in set(more.subject[train]):
        assert len(np.unique(more.params["phenotypes"][more.subject == s], axis=0)) == 1
    assert more.meta["bodies"] == bodies and "bodies" not in humans.meta
    assert (root / (opnet.data.generators.stem_name(more.meta) + ".json")).is_file()


@pytest.mark.parametrize("poses", ["quarter", "mixed", "random"])
def test_more_random_poses_same_shapes_held_out(humans, root, poses):
    more = _same_held_out(humans, root, poses=poses)
    np.testing.assert_array_equal(more.params["phenotypes"], humans.params["phenotypes"])  # the same bodies
    moving = np.flatnonzero((humans.split == "train") & (humans.params["motion"] != "random"))
    new = {"quarter": moving[1::4], "mixed": moving[1::2], "random": moving}[poses]
    changed = ~np.isclose(more.params["controls"], humans.params["controls"]).reshape(len(humans), -1).all(1)
    np.testing.assert_array_equal(np.flatnonzero(changed), new)  # exactly these shapes re-posed
    assert (more.params["motion"][new] == "random").all() and (more.params["frame"][new] == -1).all()
    kept = np.setdiff1d(np.arange(len(humans)), new)
    np.testing.assert_array_equal(more.params["motion"][kept], humans.params["motion"][kept])
    assert set(more.subcollection[new]) == {f"{s}/random" for s in more.subject[new]}
    assert more.meta["poses"] == poses and "poses" not in humans.meta
    both = opnet.data.load_collection("humans", "quick", root, bodies="shape", poses=poses, progress=False)
    assert np.array_equal(both.params["controls"], more.params["controls"])  # the draws are independent
    assert opnet.data.generators.stem_name(both.meta).endswith(f"-bodies-shape-poses-{poses}")


def test_bodies_refused(root):
    with pytest.raises(ValueError, match="bodies must be one of"):
        opnet.data.load_collection("humans", "quick", root, bodies="person")
    with pytest.raises(ValueError, match="animals' bodies are blends"):
        opnet.data.load_collection("animals", "quick", root, bodies="shape")
    with pytest.raises(ValueError, match="poses must be one of"):
        opnet.data.load_collection("humans", "quick", root, poses="dance")
    with pytest.raises(ValueError, match="their poses come from their clips"):
        opnet.data.load_collection("animals", "quick", root, poses="random")
    with pytest.raises(ValueError, match="pick the same training shapes"):
        opnet.data.load_collection("humans", "quick", root, bodies="mixed", poses="quarter")
