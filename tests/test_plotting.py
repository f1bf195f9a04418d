"""Operator heat maps: the constant mode's −1 does not set the colour range."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

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
