"""Draw the README's picture, ``docs/_static/overview.png``: the base body, one generated body, and that body's
three shape differences against the base (``D − I``: the input channels of the paper's architecture figure).

Run from the repository root (about 20 s, on the cached ``quick`` humans):
``.venv/bin/python docs/_scripts/overview.py``.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import opnet  # noqa: E402
from opnet import plotting  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "_static" / "overview.png"


def main() -> None:
    plotting.headless()
    coll = opnet.data.load_collection("humans", preset="quick", progress=False)
    test = coll.indices("test")
    # the test shape whose operators are farthest from the base's: the clearest picture of a shape difference
    i = int(
        test[np.argmax(np.linalg.norm(coll.operators[test] - np.eye(coll.operators.shape[-1]), axis=(2, 3)).sum(1))]
    )
    base = (coll.base_basis.mesh.vertices, coll.faces)
    body = (coll.vertices[i].astype(np.float64), coll.faces)
    plotter = plotting.plot_meshes([base, body], camera="xz", zoom=1.3, window_size=(520, 520))
    renders = plotter.screenshot(return_img=True)
    plotter.close()

    k = coll.operators.shape[-1]
    rows, cols = np.nonzero(renders[..., :3].min(axis=2) < 250)  # crop the white margin of the renders
    renders = renders[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]
    fig = plt.figure(figsize=(13, 3.3), dpi=110)
    grid = fig.add_gridspec(1, 4, width_ratios=[1.6, 1, 1, 1], wspace=0.3)
    ax = fig.add_subplot(grid[0])
    ax.imshow(renders)
    ax.set_axis_off()
    ax.set_title("the base shape, and a body of the test set", fontsize=9)
    ops = coll.operators[i] - np.eye(k)
    for c, name in enumerate(coll.channels):
        a = fig.add_subplot(grid[1 + c])
        m = float(np.percentile(np.abs(ops[c, 1:, 1:]), 99.5))  # a few large entries would wash out the rest
        im = a.imshow(ops[c], cmap="RdBu_r", vmin=-m, vmax=m)
        a.set_title(f"{name} shape difference, D − I", fontsize=9)
        a.set_xlabel(f"eigenfunction of the base (1–{k})", fontsize=8)
        a.set_xticks([])
        a.set_yticks([])
        fig.colorbar(im, ax=a, fraction=0.046, pad=0.03).ax.tick_params(labelsize=7)
    note = "entries have no unit; colour range: 99.5th percentile of |entry| off the constant mode"
    fig.text(0.99, 0.01, note, ha="right", fontsize=7)
    fig.suptitle(
        "A body as OperatorNet reads it: three shape differences against the base, as channels "
        "(the paper's architecture figure, left)",
        fontsize=10,
    )
    OUT.parent.mkdir(exist_ok=True)
    fig.savefig(OUT, bbox_inches="tight")
    print(f"wrote {OUT} ({OUT.stat().st_size / 1024:.0f} KB), shape {i}")


if __name__ == "__main__":
    main()
