"""Benchmark: how many vertices the PointNet autoencoder's encoder reads (``fit(architecture="pointnet", n_points=)``).

Trains the PointNet autoencoder through :func:`opnet.train.fit` on the humans of a preset once per ``--points``
value (same data, seed, epochs, batch size and learning rate), and prints the seconds per epoch and the best
``val`` d_R (×10⁻⁴); ``test`` is never read. The PointNet paragraph of docs/results.md was measured at
``--preset quick`` (80 epochs, batch 16, one torch thread).

Run::

    .venv/bin/python benchmarks/pointnet.py --preset quick --points 256 1229   # ~15 min on one core
"""

from __future__ import annotations

import argparse
import time

import torch

import opnet
from opnet.reproduce import BUDGETS


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection and budget preset (quick | default | paper)")
    ap.add_argument("--points", type=int, nargs="+", default=[256, 1229], help="values of n_points to compare")
    ap.add_argument("--epochs", type=int, default=None, help="epochs (default: the preset's Table 1 epochs)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (1)")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    budget = BUDGETS[args.preset]
    ds = opnet.data.load_collection("humans", args.preset)
    n = ds.vertices.shape[1]
    print(f"{ds}\n{'n_points':>9s} {'s/epoch':>8s} {'best val d_R e-4':>17s} {'epoch':>6s}")
    for points in args.points:
        start = time.perf_counter()
        _, history = opnet.train.fit(
            ds,
            architecture="pointnet",
            n_points=min(points, n),
            epochs=args.epochs or budget.epochs,
            batch_size=budget.batch_size,
            lr=budget.lr,
            device="cpu",
            progress=False,
        )
        best = min(history, key=lambda h: h["val_d_R"])
        print(
            f"{min(points, n):9d} {(time.perf_counter() - start) / len(history):8.2f} "
            f"{1e4 * best['val_d_R']:17.2f} {best['epoch']:6d}",
            flush=True,
        )


if __name__ == "__main__":
    main()
