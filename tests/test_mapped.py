"""Collections through maps from another triangulation (opnet.data.mapped_collection) and Collection.subset."""

import numpy as np
import pytest

import opnet
from opnet.data import mapped as mapped_module
from opnet.data import mapped_collection


@pytest.fixture(scope="module")
def few(humans):
    """Six humans: two of val, two of test, two of train."""
    return humans.subset(np.concatenate([humans.indices(s)[:2] for s in ("val", "test", "train")]))


def test_subset_takes_shapes_and_remaps_the_evaluation_subset(humans):
    idx = np.concatenate([humans.eval_subset[:2], humans.indices("train")[:3]])[::-1]
    sub = humans.subset(idx)
    assert len(sub) == 5 and np.array_equal(sub.vertices, humans.vertices[idx])
    assert np.array_equal(sub.operators, humans.operators[idx]) and np.array_equal(sub.split, humans.split[idx])
    assert all(np.array_equal(sub.params[k], v[idx]) for k, v in humans.params.items())
    assert sorted(idx[sub.eval_subset]) == sorted(humans.eval_subset[:2])
    for bad in ([len(humans)], [-1], [[0, 1]], [0.5], [3, 3]):
        with pytest.raises(ValueError, match="indices"):
            humans.subset(bad)
    with pytest.raises(ValueError, match="flatnonzero"):
        humans.subset(humans.split == "test")


def test_true_maps_of_the_base_triangulation_give_the_exact_operators(few, tmp_path):
    """The 1k mesh mapped onto itself by the generator's correspondence is the identity: the fast path's operators."""
    same = mapped_collection(few, "1k", "true", root=tmp_path, n_jobs=1, progress=False)
    np.testing.assert_allclose(same.operators, few.operators, atol=1e-5)
    assert np.array_equal(same.vertices, few.vertices) and np.array_equal(same.split, few.split)
    assert np.all(same.params["map_error"] == 0) and np.all(same.params["map_coverage"] > 0.95)
    assert same.meta["maps"] == "true" and same.meta["map_resolution"] == "1k"


def test_a_failed_save_keeps_the_built_operators(few, tmp_path, monkeypatch):
    """When the final save fails (e.g. the disk filled up), the collection is returned with a warning and the
    parts stay, so the next call assembles them without recomputing a map."""
    from opnet import matching
    from opnet.data import storage

    def no_space(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(storage, "save_collection", no_space)
    with pytest.warns(UserWarning, match="could not be saved.*No space left"):
        first = mapped_collection(few, "1k", "true", root=tmp_path, n_jobs=1, chunk=4, progress=False)
    assert list(tmp_path.glob("*.part-*.npz"))
    monkeypatch.undo()
    monkeypatch.setattr(matching, "operators_through_map", lambda *a, **k: pytest.fail("recomputed a map"))
    again = mapped_collection(few, "1k", "true", root=tmp_path, n_jobs=1, chunk=4, progress=False)
    np.testing.assert_array_equal(again.operators, first.operators)
    assert not list(tmp_path.glob("*.part-*.npz"))


class Interrupted(Exception):
    """Stands for a kill or Ctrl-C in the middle of a build."""


def test_computed_maps_of_2k_meshes_are_near_the_truth_and_resume_after_an_interruption(few, tmp_path, monkeypatch):
    calls = []
    original = mapped_module._map_chunk

    def interrupted(*args):
        calls.append(len(args[2]))  # the chunk's vertices
        if calls == [4, 2]:  # the second chunk of the first build
            raise Interrupted
        return original(*args)

    monkeypatch.setattr(mapped_module, "_map_chunk", interrupted)
    with pytest.raises(Interrupted):
        mapped_collection(few, "2k", root=tmp_path, n_jobs=1, chunk=4, progress=False)
    parts = list(tmp_path.glob("*.part-*.npz"))
    assert len(parts) == 1 and not list(tmp_path.glob("*.json"))  # the finished chunk is kept; nothing loads
    with pytest.raises(opnet.data.CollectionError, match="no collection"):
        opnet.data.read_collection(tmp_path / parts[0].name.split(".part-")[0])
    calls.clear()
    comp = mapped_collection(few, "2k", root=tmp_path, n_jobs=1, chunk=4, progress=False)
    assert calls == [2]  # only the unfinished chunk
    assert not list(tmp_path.glob("*.part-*")), "parts are removed once the collection is saved"
    true = mapped_collection(few, "2k", "true", root=tmp_path, n_jobs=1, chunk=4, progress=False)
    assert np.all(comp.params["map_error"] < 0.04) and np.all(comp.params["map_orientation"] > 0.8)  # metres
    signal = np.linalg.norm(few.operators - np.eye(few.base_basis.k), axis=(2, 3))
    through_true = np.linalg.norm(true.operators - few.operators, axis=(2, 3)) / signal
    through_computed = np.linalg.norm(comp.operators - few.operators, axis=(2, 3)) / signal
    # the extrinsic channel moves least (measured: 0.08-0.20 of its signal through the true map, 0.23-0.59 computed)
    assert np.all(through_true[:, 2] < 0.3) and np.all(through_computed[:, 2] < 0.8)
    assert np.all(through_true.mean(0) < through_computed.mean(0))  # the map's error adds to the discretisation's
    again = mapped_collection(few, "2k", root=tmp_path, n_jobs=1, chunk=4, progress=False)  # cached
    assert calls == [2, 4, 2] and np.array_equal(again.operators, comp.operators)


def test_bad_input(few, tmp_path):
    with pytest.raises(ValueError, match="resolution"):
        mapped_collection(few, "3k", root=tmp_path)
    with pytest.raises(ValueError, match="maps"):
        mapped_collection(few, "2k", "exact", root=tmp_path)
    with pytest.raises(ValueError, match="chunk"):
        mapped_collection(few, "2k", root=tmp_path, chunk=0)
    with pytest.raises(ValueError, match="n_jobs"):
        mapped_collection(few, "2k", root=tmp_path, n_jobs=0)
    with pytest.raises(ValueError, match="indices is empty"):
        mapped_collection(few, "2k", root=tmp_path, indices=[])
    with pytest.raises(TypeError, match="Collection"):
        mapped_collection(few.vertices, "2k", root=tmp_path)
    with pytest.raises(ValueError, match="generated 1k humans|not made by a generator"):
        mapped_collection(_folder_collection(tmp_path), "2k", root=tmp_path)


def _folder_collection(tmp_path):
    """A collection of the user's own meshes (no generator behind it)."""
    import trimesh

    folder = tmp_path / "mine"
    folder.mkdir()
    s = trimesh.creation.icosphere(2)
    for i in range(3):
        trimesh.Trimesh(s.vertices * (1 + 0.1 * i), s.faces, process=False).export(folder / f"s{i}.ply")
    return opnet.data.load_folder(folder, k=10, progress=False)


def test_a_build_resumed_with_other_chunk_sizes_recomputes_what_does_not_fit(few, tmp_path, monkeypatch):
    original = mapped_module._map_chunk
    calls = []

    def interrupted(*args):
        calls.append(len(args[2]))  # the chunk's vertices
        if calls == [4, 2]:
            raise Interrupted
        return original(*args)

    monkeypatch.setattr(mapped_module, "_map_chunk", interrupted)
    with pytest.raises(Interrupted):
        mapped_collection(few, "1k", "true", root=tmp_path, n_jobs=1, chunk=4, progress=False)
    calls.clear()
    same = mapped_collection(few, "1k", "true", root=tmp_path, n_jobs=1, chunk=3, progress=False)
    assert calls == [3, 3]  # the finished part of 4 shapes is not one of these chunks
    np.testing.assert_allclose(same.operators, few.operators, atol=1e-5)
    calls.clear()
    again = mapped_collection(few, "1k", "true", root=tmp_path, n_jobs=1, chunk=8, progress=False, rebuild=True)
    assert calls == [6]  # rebuild: everything again, in one chunk
    np.testing.assert_allclose(again.operators, same.operators, atol=1e-6)  # the generator's batches: round-off


def test_a_few_shapes_are_spread_over_every_process():
    assert mapped_module._chunk_size(12, 32, 2) == 6  # notebook 04's dozen shapes: a part per core
    assert mapped_module._chunk_size(13, 32, 2) == 7
    assert mapped_module._chunk_size(5856, 32, 2) == 32  # a collection: parts of chunk
    assert mapped_module._chunk_size(12, 32, 1) == 12 and mapped_module._chunk_size(1, 32, 4) == 1


def test_three_way_mapped_deals_the_training_shapes_to_three_encodings(humans, monkeypatch):
    """A third of the training shapes exact, a sixth through the finer maps, the rest and the held-out shapes through
    ``mapped``'s: as many shapes as the collection, each once."""
    asked = {}

    def fine(collection, resolution, maps, *, indices, **kw):  # a stand-in for the 5k maps: recognisable operators
        asked.update(resolution=resolution, maps=maps, indices=np.asarray(indices))
        out = collection.subset(indices)
        out.operators = out.operators + 1.0
        return out

    monkeypatch.setattr(mapped_module, "mapped_collection", fine)
    coarse = humans.subset(np.arange(len(humans)))
    coarse.operators = coarse.operators + 2.0  # a stand-in for the 2k maps
    three = opnet.data.three_way_mapped(humans, coarse, "5k")
    train = humans.indices("train")
    assert len(three) == len(humans) and asked["resolution"] == "5k" and asked["maps"] == "computed"
    np.testing.assert_array_equal(asked["indices"], train[2::6])
    for split in ("val", "test", "test_subjects"):  # held out through mapped's operators
        np.testing.assert_array_equal(three.operators[three.indices(split)], coarse.operators[humans.indices(split)])
    ops = three.operators[three.indices("train")]
    shift = np.round(
        ops
        - np.concatenate(
            [
                humans.operators[np.sort(np.setdiff1d(train, np.r_[train[1::3], train[2::6]]))],
                humans.operators[train[1::3]],
                humans.operators[train[2::6]],
            ]
        )
    )
    counts = {v: int((shift.reshape(len(shift), -1)[:, 0] == v).sum()) for v in (0.0, 1.0, 2.0)}
    assert counts == {
        2.0: len(train) - len(train[1::3]) - len(train[2::6]),
        0.0: len(train[1::3]),
        1.0: len(train[2::6]),
    }
    with pytest.raises(ValueError, match="collection's shapes in its order"):
        opnet.data.three_way_mapped(humans, coarse.subset(np.arange(5)))


def test_labels_on_the_2k_mesh_are_the_generators_shapes_with_the_base_operators(few, tmp_path, monkeypatch):
    """The finer labels of the paper's appendix: each shape's 2k-vertex version as vertices and faces, the base's
    operators unchanged; cached (a file of other shapes refused); refused for a resolution that is the base's, for
    labels of labels, as the source of a mapped collection, and as a collection to save or add channels to."""
    from opnet.data import generate_shapes, humans, labels_collection
    from opnet.data.generators import resolution_map
    from opnet.data.storage import CollectionError

    labels = labels_collection(few, "2k", root=tmp_path)
    params = few.params
    truth = generate_shapes(few, params["phenotypes"], params["controls"], resolution="2k")
    assert labels.vertices.shape == (len(few), len(humans.human_faces("2k")) // 2 + 2, 3)  # closed genus 0
    np.testing.assert_allclose(labels.vertices, truth, atol=1e-6)
    assert np.array_equal(labels.faces, humans.human_faces("2k")) and labels.vertices.dtype == few.vertices.dtype
    assert np.array_equal(labels.operators, few.operators) and np.array_equal(labels.split, few.split)
    assert labels.meta["labels_resolution"] == "2k" and labels.base_basis is few.base_basis
    monkeypatch.setattr(mapped_module, "generate_shapes", lambda *a, **k: pytest.fail("built again"))
    again = labels_collection(few, "2k", root=tmp_path)
    np.testing.assert_array_equal(again.vertices, labels.vertices)
    for bad in ("1k", "3k"):
        with pytest.raises(ValueError, match=r"resolution must be one of \['2k', '5k'\]"):
            labels_collection(few, bad, root=tmp_path)
    with pytest.raises(ValueError, match="this one's are on the 2k mesh .*pass the collection it was made from"):
        labels_collection(labels, "5k", root=tmp_path)  # labels of labels
    with pytest.raises(ValueError, match="mapped collections are made from .*this one's are on the 2k mesh"):
        mapped_collection(labels, "5k", root=tmp_path)  # one check of the source for both
    # the same bodies in the same poses as the 1k shapes: the generator's correspondence carries one onto the other
    carried = np.stack([resolution_map(few, "2k") @ v for v in few.vertices.astype(np.float64)])
    gap = np.linalg.norm(carried - labels.vertices, axis=-1)
    assert np.median(gap) < 0.01, np.median(gap)  # metres
    with pytest.raises(ValueError, match="is not saved: save its source"):
        opnet.data.save_collection(labels, tmp_path / "saved")
    with pytest.raises(opnet.ChannelError, match="add channel 'offset_area' to the source"):
        labels.with_channels(["area", "offset_area"], progress=False)
    (cached,) = tmp_path.glob("*-labels2k-*.npy")
    np.save(cached, labels.vertices[:1])  # another file under its name
    monkeypatch.undo()
    with pytest.raises(CollectionError, match="delete it or pass rebuild=True"):
        labels_collection(few, "2k", root=tmp_path)
    np.testing.assert_array_equal(labels_collection(few, "2k", root=tmp_path, rebuild=True).vertices, labels.vertices)
