"""Intervals over seeds and shapes, and paired comparisons (opnet.experiments.stats): coverage on data whose truth is
known, the paired test's power where an unpaired one has none, and bad input named."""

import numpy as np
import pytest

from opnet.experiments import stats


def test_the_interval_holds_the_mean_and_covers_the_truth_about_as_often_as_it_says():
    rng = np.random.default_rng(0)
    covered = 0
    for trial in range(200):
        x = 1.0 + rng.normal(0, 0.3, (3, 1)) + rng.normal(0, 1.0, (3, 60))  # seeds shift, shapes scatter
        iv = stats.interval(x)
        assert iv.low <= iv.mean <= iv.high and iv.mean == pytest.approx(x.mean())
        covered += iv.low <= 1.0 <= iv.high
    assert 0.90 <= covered / 200 <= 1.0  # Student's quantile for 3 seeds: about as often as it says, or more
    iv = stats.interval(np.full((2, 5), 4.0))
    assert (iv.low, iv.mean, iv.high, iv.std) == (4.0, 4.0, 4.0, 0.0) and iv.per_seed == (4.0, 4.0)
    assert stats.interval(np.arange(10.0)).std == 0.0  # one seed: no spread between trainings
    assert stats.interval(np.arange(10.0)).text() == f"4.5 ± {stats.interval(np.arange(10.0)).half_width:.2g}"


def test_a_paired_comparison_sees_a_small_shift_that_the_shapes_scatter_would_hide():
    rng = np.random.default_rng(1)
    hard = rng.gamma(2.0, 1.0, (3, 80))  # each shape's own difficulty, shared by both methods
    a, b = hard + 0.05, hard + rng.normal(0, 0.01, hard.shape)
    c = stats.paired_difference(a, b, names=("mine", "theirs"))
    assert not stats.paired_difference(a, b, verdict=False).verdict.endswith("better")  # one that cannot tell
    assert c.verdict == "b better" and c.difference.low > 0 and "mine − theirs" in c.text()
    assert stats.paired_difference(b, a).verdict == "a better"
    unpaired = stats.interval(a).low <= stats.interval(b).high  # the intervals of each overlap...
    assert unpaired  # ...so comparing them would show nothing; the pairing does
    same = stats.paired_difference(hard, hard + rng.normal(0, 0.01, hard.shape))
    assert same.verdict == "no difference shown" and same.difference.low < 0 < same.difference.high


def test_bad_measurements_are_named():
    with pytest.raises(ValueError, match="same seeds and shapes"):
        stats.paired_difference(np.ones((3, 5)), np.ones((2, 5)))
    with pytest.raises(ValueError, match="NaN or infinite"):
        stats.interval([1.0, np.nan])
    with pytest.raises(ValueError, match=r"\(seeds, shapes\)"):
        stats.interval(np.ones((2, 3, 4)))
    with pytest.raises(ValueError, match="level"):
        stats.interval([1.0, 2.0], level=95)


def test_the_ablation_trains_each_seed_and_its_rows_carry_intervals_and_comparisons(tiny_collection, tmp_path):
    pytest.importorskip("torch")  # trains networks (the net extra)
    import opnet

    coll = tiny_collection()
    sets = [["area"], ["area", "extrinsic"]]
    fast = dict(batch_size=8, hidden=16, epochs=2)
    table = opnet.ablation(coll, sets, depths=[1], seeds=2, run_root=tmp_path, progress=False, **fast)
    nets = [r for r in table if r.get("baseline") is None]
    assert [(r["channels"], r["seeds"]) for r in nets] == [(c, [0, 1]) for c in sets]
    for r in nets:  # the mean of the seeds' means, inside its interval; each seed its own run
        assert r["d_R"] == pytest.approx(np.mean(r["d_R_seeds"])) and r["d_R_low"] <= r["d_R"] <= r["d_R_high"]
        assert len(r["runs"]) == 2 and r["runs"][1].endswith("-s1") and r["provenance"]["seeds"] == [0, 1]
        folders = r["provenance"]["runs"]  # each seed's folder: its run name and the digest of its settings and data
        assert folders[1].startswith(r["runs"][1] + "-") and (tmp_path / folders[1] / "best.pt").is_file()
        assert r["provenance"]["checkpoints"] == [opnet.train.checkpoint_sha256(tmp_path / f) for f in folders]
        assert len(r["convergence"]) == 2 and all(isinstance(c["converged"], bool) for c in r["convergence"])
        assert np.shape(r["d_R_shapes"]) == (2, len(coll.indices("val")))
    assert " ± " in table.markdown()
    c = table.compare(["area", "extrinsic"], ["area"])
    assert c.verdict in stats.VERDICTS and c.difference.low <= c.difference.mean <= c.difference.high
    nn = stats.compare(
        table, dict(channels=["area"], depth=1), dict(baseline="nearest_neighbour", channels=["area"]), split="val"
    )
    assert nn.verdict in stats.VERDICTS  # a baseline of one row stands beside each seed
    again = opnet.ablation(
        coll, sets[:1], depths=[1], seeds=2, run_root=tmp_path, progress=False, baselines=False, **fast
    )
    assert again[0]["d_R_seeds"] == nets[0]["d_R_seeds"]  # both seeds' runs loaded, not trained again
    with pytest.raises(TypeError, match="seeds="):
        opnet.ablation(coll, sets, seed=3, **fast)
    with pytest.raises(ValueError, match="single out one"):
        stats.compare(table, dict(depth=1), dict(depth=1), split="val")
    with pytest.raises(ValueError, match="seeds must be distinct"):
        opnet.experiments.RunSpec(seeds=(0, 0))


def test_compare_pairs_seed_by_seed_and_one_training_is_never_called_better():
    rng = np.random.default_rng(2)
    base = dict(table="ablation", split="val", shapes=list(range(30)))
    err = rng.gamma(2.0, 1.0, (2, 30))
    rows = [
        dict(base, method="one", channels=["area"], depth=1, seeds=[0], d_R_shapes=err[:1].tolist()),
        dict(base, method="two", channels=["extrinsic"], depth=1, seeds=[0], d_R_shapes=(err[:1] + 5).tolist()),
        dict(base, method="pair", channels=["conformal"], depth=1, seeds=[1, 2], d_R_shapes=(err + 5).tolist()),
        dict(base, method="nn", baseline="nearest_neighbour", channels=["area"], d_R_shapes=(err[0] + 5).tolist()),
    ]
    one = stats.compare(rows, dict(method="one"), dict(method="two"), split="val")
    assert one.verdict == "no difference shown" and one.difference.high < 0  # clear on the shapes, yet one training
    with pytest.raises(ValueError, match="seeds"):
        stats.compare(rows, dict(method="one"), dict(method="pair"), split="val")
    assert stats.compare(rows, dict(method="pair"), dict(method="nn"), split="val").verdict in stats.VERDICTS


def test_a_factor_compares_with_a_multiple_of_the_other_method():
    """ "Within 5× of" and "ten times better than" are comparisons with a multiple of the other's errors."""
    rng = np.random.default_rng(3)
    base = dict(table="table1", split="test", shapes=list(range(40)), seeds=[0, 1, 2])
    err = rng.gamma(4.0, 1.0, (3, 40))
    rows = [
        dict(base, method="comp", d_R_shapes=(3 * err).tolist()),
        dict(base, method="exact", d_R_shapes=err.tolist()),
    ]
    a, b = dict(method="comp"), dict(method="exact")
    assert stats.compare(rows, a, b).verdict == "b better"  # three times the error: worse
    within = stats.compare(rows, a, b, factor=5.0)  # but within five times it
    assert within.verdict == "a better" and within.b == "5 × exact"
    np.testing.assert_allclose(within.difference.mean, np.mean(3 * err - 5 * err))
    assert stats.compare(rows, a, b, factor=2.0).verdict == "b better"
    with pytest.raises(ValueError, match="factor must be a number > 0"):
        stats.compare(rows, a, b, factor=0)


def test_a_baseline_measured_on_a_few_shapes_is_paired_on_those():
    """A slow baseline (SfL, FuncChar) measures a few of the test shapes: it is compared with a network on those, seed
    by seed, and the means are those of the shared shapes; rows whose shapes are not one's subset are refused."""
    rng = np.random.default_rng(4)
    err = rng.gamma(4.0, 1.0, (3, 40))
    few = [3, 17, 29, 35]
    rows = [
        dict(
            table="table1", split="test", method="net", shapes=list(range(40)), seeds=[0, 1, 2], d_R_shapes=err.tolist()
        ),
        dict(table="table1", split="test", method="sfl", baseline="sfl", shapes=few, d_R_shapes=[[50.0] * 4]),
        dict(table="table1", split="test", method="far", baseline="far", shapes=[40, 41], d_R_shapes=[[1.0, 1.0]]),
        dict(table="table1", split="test", method="part", baseline="part", shapes=[39, 40], d_R_shapes=[[1.0, 1.0]]),
    ]
    c = stats.compare(rows, dict(method="net"), dict(method="sfl"))
    assert c.verdict == "a better" and c.difference.n_shapes == 4
    np.testing.assert_allclose(c.difference.mean, np.mean(err[:, few] - 50.0))
    assert c.a_mean == pytest.approx(err[:, few].mean()) and c.b_mean == 50.0
    # the sets' order does not matter
    np.testing.assert_allclose(
        stats.compare(rows, dict(method="sfl"), dict(method="net")).difference.mean, 50.0 - err[:, few].mean()
    )
    for other in ("far", "part"):  # none shared, or some: not one test set's subset
        with pytest.raises(ValueError, match="neither's are a subset of the other's"):
            stats.compare(rows, dict(method="net"), dict(method=other))


def test_a_row_prints_its_interval_where_it_has_one():
    """``report.value_text``: a row over seeds as ``mean ± half-width``, one training as its value, nothing as "–"."""
    from opnet.experiments import report

    def row(s):
        errors = [1e-4 * (1 + s + 0.1 * i) for i in range(5)]
        return dict(d_R=float(np.mean(errors)), d_R_shapes=errors, shapes=list(range(5)), seed=s)

    seeded = stats.summarize_seeds([row(s) for s in range(3)], metrics=("d_R",))
    half = (seeded["d_R_high"] - seeded["d_R_low"]) / 2
    assert half > 0 and report.value_text(seeded, "d_R", 1e4) == f"{1e4 * seeded['d_R']:.3g} ± {1e4 * half:.2g}"
    assert report.value_text(row(0), "d_R", 1e4) == "1.2"  # one training: its value, three significant digits
    assert report.value_text(dict(d_R=float("nan")), "d_R") == report.value_text({}, "d_V") == "–"


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_the_seeded_applications_keep_a_worst_step_that_no_seed_measured_as_nan_without_a_warning(monkeypatch):
    """Where every path of every seed is stuck (a network that outputs one shape), the worst step over the seeds is
    NaN, as each seed's, and numpy's all-NaN warning is not raised; where one seed measured it, its value is kept."""
    from types import SimpleNamespace

    from opnet.experiments import steps

    def rows(worst):
        shapes = {f"{m}_shapes": [float("nan"), float("nan")] for m in steps.PATH_METRICS}
        return [dict(table="interpolation", method="net", kind="pose", run="r", shapes=[0, 1], smoothness_max=worst,
                     **shapes)]  # fmt: skip

    for worst, expected in (((float("nan"), float("nan")), None), ((float("nan"), 0.25), 0.25)):
        measured = iter(worst)
        monkeypatch.setattr(steps, "application_methods", lambda *a, **k: [])
        monkeypatch.setattr(steps, "applications_rows", lambda *a, **k: rows(next(measured)))
        seeds = [{"int+ext": SimpleNamespace(spec=SimpleNamespace(seed=s))} for s in (0, 1)]
        (row,) = steps.seeded_applications_rows(None, seeds, None)
        assert row["seeds"] == [0, 1]
        assert np.isnan(row["smoothness_max"]) if expected is None else row["smoothness_max"] == expected
