"""Operator heat maps: the constant mode's −1 does not set the colour range."""

import pytest

pytest.importorskip("matplotlib")  # the viz extra: skipped by a core-only install

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

import opnet  # noqa: E402
from opnet import plotting  # noqa: E402
from opnet.plotting import plot_operators  # noqa: E402


def test_the_colour_range_skips_the_constant_mode_and_says_so():
    D = np.random.default_rng(0).normal(scale=0.01, size=(6, 6))
    D[0, :] = D[:, 0] = 0.0
    D[0, 0] = -1.0  # a conformal or extrinsic D − I on the constant function
    fig = plot_operators([D, D], skip_constant=True)
    assert fig.axes[0].images[0].get_clim() == (-np.abs(D[1:, 1:]).max(), np.abs(D[1:, 1:]).max())
    assert any("constant function" in t.get_text() for t in fig.texts)
    whole = plot_operators([D], skip_constant=False)
    assert whole.axes[0].images[0].get_clim() == (-1.0, 1.0) and not whole.texts


# ---- collection figures: what each helper draws, on toy capsules (no body model) ----

from opnet.plotting import (  # noqa: E402
    SPLIT_COLOURS,
    plot_error_histograms,
    plot_operator_drift,
    plot_shape_variety,
    plot_split_matrix,
)


@pytest.fixture(scope="module")
def toy(toy_collection):
    """36 capsules: 4 subjects × 3 motions ("group": bend, bulge, both) × 3 frames, with per-subject parameters."""
    coll = toy_collection()
    subject = np.array([int(s[-2:]) for s in coll.subject])
    coll.params["phenotypes"] = np.stack([subject / 4, 1 - subject / 4], axis=1)
    return coll


def _bar_counts(ax):
    return [sum(p.get_height() for p in bars) for bars in ax.containers]


def test_the_split_matrix_holds_each_sequence_split(toy):
    fig = plot_split_matrix(toy)
    table = fig.axes[0].images[0].get_array()
    subjects, motions = toy.subjects(), ["bend", "bulge", "both"]  # the motions in the order the collection has them
    assert table.shape == (len(subjects), len(motions))
    codes = list(SPLIT_COLOURS)
    for i, s in enumerate(subjects):
        for j, m in enumerate(motions):
            assert codes[int(table[i, j])] == toy.split[toy.sequence(s, m)][0]
    assert [t.get_text() for t in fig.axes[0].get_xticklabels()] == motions
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == codes
    # a chosen subset of columns, and a motion that no subject has stays blank
    fig = plot_split_matrix(toy, motions=["both", "walk"])
    table = fig.axes[0].images[0].get_array()
    assert table.shape == (len(subjects), 2) and np.isnan(table[:, 1].filled(np.nan)).all()
    assert codes[int(table[0, 0])] == toy.split[toy.sequence(subjects[0], "both")][0]


def test_the_variety_histograms_count_subjects_and_shapes(toy):
    fig = plot_shape_variety(toy, names=["a", "b"], splits=("train", "test"))
    assert [ax.get_title() for ax in fig.axes] == ["a", "b", "RMS distance to base (cm)"]
    assert _bar_counts(fig.axes[0]) == [len(toy.subjects())]  # each subject once
    n_train, n_test = (np.sum(toy.split == s) for s in ("train", "test"))
    assert _bar_counts(fig.axes[-1]) == [n_train, n_test]
    # without subject parameters only the distances are drawn
    bare = plot_shape_variety(toy, parameters="missing")
    assert len(bare.axes) == 1 and sum(_bar_counts(bare.axes[0])) == sum(
        np.sum(toy.split == s) for s in ("train", "test", "test_subjects")
    )


def test_the_operator_drift_is_the_distance_to_the_identity(toy):
    seq = toy.sequence("subject01", "both")
    fig = plot_operator_drift(toy, seq, x=[1, 2, 3], xlabel="frame of both")
    lines = fig.axes[0].get_lines()
    assert [line.get_label() for line in lines] == list(opnet.KINDS)
    for c, line in enumerate(lines):
        D = toy.operators[seq, c, 1:, 1:].astype(float)
        expected = [np.linalg.norm(d - np.eye(len(d))) for d in D]
        np.testing.assert_allclose(line.get_ydata(), expected, rtol=1e-12)
        assert list(line.get_xdata()) == [1, 2, 3]
    assert fig.axes[0].get_xlabel() == "frame of both"
    # the frames of the sequence deform the capsule more and more
    assert np.all(np.diff(lines[0].get_ydata()) > 0)


def test_the_error_histograms_share_log_bins_and_count_every_shape():
    rng = np.random.default_rng(0)
    errors = {"net": 10 ** rng.uniform(-6, -4, 50), "NN": 10 ** rng.uniform(-4, -3, 20)}
    fig = plot_error_histograms(errors, bins=12)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and _bar_counts(ax) == [50, 20]
    edges = [[p.get_x() for p in bars] for bars in ax.containers]
    assert edges[0] == edges[1] and len(edges[0]) == 12  # one set of bins for both
    assert edges[0][0] == pytest.approx(1e4 * min(e.min() for e in errors.values()))
    assert [t.get_text().split(" (")[0] for t in ax.get_legend().get_texts()] == ["net", "NN"]
    linear = plot_error_histograms({"a": [0.0, 1e-4, 2e-4]}, log=False, bins=4)
    assert linear.axes[0].get_xscale() == "linear" and _bar_counts(linear.axes[0]) == [3]
    with pytest.raises(ValueError, match="non-positive"):
        plot_error_histograms({"a": [0.0]})


def test_error_renders_share_one_range_in_mm_with_a_colour_bar():
    pv = pytest.importorskip("pyvista")
    from opnet.data import toy

    plotting.use_static_backend()
    base = toy.capsule("quick")
    gt = np.stack([base.vertices, toy.bend(base.vertices, angle=0.5)]) * 0.5  # metres
    small = gt + 0.002  # a translation: no error once aligned
    far = np.stack([gt[1], gt[0]])  # the other shape: centimetres off
    errors = [plotting.aligned_errors(r, gt)[1] for r in (small, far)]
    top = plotting.error_top(errors)
    assert top == pytest.approx(np.percentile(np.concatenate([e.ravel() for e in errors]), 98))
    assert top < np.max(errors[1]) and plotting.error_scale(top) == (1000.0, "error (mm)")
    plotter = plotting.plot_reconstructions(gt, {"small": small, "far": far}, base.faces)
    try:
        assert list(plotter.scalar_bars.keys()) == ["error (mm)"]  # one bar, for the range every panel shares
        painted = [
            a.mapper.scalar_range
            for r in plotter.renderers
            for a in r.actors.values()
            if isinstance(a, pv.Actor) and a.mapper.scalar_visibility
        ]
        assert painted and all(np.allclose(rng, (0.0, 1000 * top)) for rng in painted)
    finally:
        plotter.close()


def test_application_figures_render_every_method_beside_the_truth_with_one_error_bar(tmp_path):
    """The interpolation strips (a row per method under the true path, evenly spaced columns) and the analogy grids
    (a row per question: A, B, C, the true X, each method), rendered off screen to PNG: one colour bar in mm whose
    range every coloured panel shares, and a picture that is not blank."""
    pv = pytest.importorskip("pyvista")
    from PIL import Image

    from opnet.data import toy

    plotting.use_static_backend()
    base = toy.capsule("quick")
    t = np.linspace(0, 1, 5)
    truth = np.stack([toy.bend(base.vertices, angle=0.6 * x) for x in t]) * 0.5  # metres
    methods = {"near": truth + 0.003 * np.sin(truth), "far": truth[::-1]}
    A, B, C = truth[:2], truth[1:3], truth[2:4]
    figures = {
        "interpolation": (plotting.plot_interpolations(methods, base.faces, t, truth=truth, columns=3), 3 * 3),
        "analogy": (
            plotting.plot_analogies(A, B, C, {n: x[:2] for n, x in methods.items()}, base.faces, truth=B),
            2 * 6,
        ),
    }
    for name, (plotter, panels) in figures.items():
        try:
            assert len(plotter.renderers) == panels and list(plotter.scalar_bars.keys()) == ["error (mm)"]
            ranges = {
                a.mapper.scalar_range
                for r in plotter.renderers
                for a in r.actors.values()
                if isinstance(a, pv.Actor) and a.mapper.scalar_visibility
            }
            (low, high) = ranges.pop()
            assert not ranges and low == 0 and high > 1  # the methods' panels share one range, in mm (not metres)
            plotter.screenshot(str(tmp_path / f"{name}.png"))
        finally:
            plotter.close()
        pixels = np.asarray(Image.open(tmp_path / f"{name}.png").convert("L"))
        assert (pixels < 250).mean() > 0.1, name  # shapes drawn on the white ground (titles and bar alone: < 0.01)


def test_training_curves_draw_every_seed_of_a_network_in_one_colour():
    def history(scale):
        return [dict(epoch=e, train_loss=scale / e, val_d_R=2 * scale / e) for e in range(1, 4)]

    fig = plotting.plot_history({"net": [history(1e-4), history(2e-4), history(3e-4)], "one": history(5e-4)})
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert len(lines) == 2 * 3 + 2  # train and val of each seed, then of the single training
    assert {line.get_color() for line in lines[:6]} == {"C0"} and {line.get_color() for line in lines[6:]} == {"C1"}
    val = [line for line in lines if line.get_linestyle() == "-"]
    assert [line.get_ydata()[0] for line in val] == pytest.approx([2, 4, 6, 10])  # ×10⁻⁴, each seed's own curve
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["net (3 seeds)", "one"]
