"""Benchmark: how many vertices the PointNet autoencoder's encoder reads (``fit(architecture="pointnet", n_points=)``).

Trains the PointNet autoencoder through :func:`opnet.train.fit` on the humans of a preset once per ``--points``
value (same data, seed, epochs, batch size and learning rate), and prints the seconds per epoch and the best
``val`` d_R (×10⁻⁴); ``test`` is never read. ``--json PATH`` also writes the results; the shipped
``benchmarks/results/pointnet.json`` (rendered on the docs' benchmarks page) was measured at ``--preset quick``.

Run::

    .venv/bin/python benchmarks/pointnet.py --preset quick --points 256 1229   # ~15 min on one core
    .venv/bin/python benchmarks/pointnet.py --preset quick --json benchmarks/results/pointnet.json
"""

from __future__ import annotations

import argparse
import os
import time

import torch
from shape_differences import run_benchmark

import opnet
from opnet.reproduce import BUDGETS


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection and budget preset (quick | default | paper)")
    ap.add_argument("--points", type=int, nargs="+", default=[256, 1229], help="values of n_points to compare")
    ap.add_argument("--epochs", type=int, default=None, help="epochs (default: the preset's Table 1 epochs)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (1)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""
    torch.set_num_threads(args.threads)
    budget = BUDGETS[args.preset]
    ds = opnet.data.load_collection("humans", args.preset)
    n = ds.vertices.shape[1]
    epochs = args.epochs or budget.epochs
    result = dict(date=time.strftime("%Y-%m-%d"), preset=args.preset, shapes=len(ds), vertices=n, epochs=epochs)
    result |= dict(batch_size=budget.batch_size, lr=budget.lr, threads=args.threads, cpu_count=os.cpu_count())
    result |= dict(torch=torch.__version__, loadavg_1min_at_start=round(os.getloadavg()[0], 2), rows=[])
    for points in args.points:
        start = time.perf_counter()
        _, history = opnet.train.fit(
            ds,
            architecture="pointnet",
            n_points=min(points, n),
            epochs=epochs,
            batch_size=budget.batch_size,
            lr=budget.lr,
            device="cpu",
            progress=False,
        )
        best = min(history, key=lambda h: h["val_d_R"])
        seconds = (time.perf_counter() - start) / len(history)
        row = dict(n_points=min(points, n), s_per_epoch=seconds, best_val_d_R=best["val_d_R"], best_epoch=best["epoch"])
        result["rows"].append(row)
        print(f"n_points {row['n_points']}: {seconds:.2f} s/epoch, best val d_R {1e4 * row['best_val_d_R']:.2f}e-4")
    result["loadavg_1min_at_end"] = round(os.getloadavg()[0], 2)
    return result


def report(r: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    out = [
        f"humans at `{r['preset']}` ({r['shapes']} shapes, {r['vertices']} vertices): {r['epochs']} epochs, batch "
        f"{r['batch_size']}, lr {r['lr']}, {r['threads']} torch thread(s); the encoder's points are farthest-first "
        "on the base when fewer than the vertices.",
        "",
        "| n_points | s/epoch | best val d_R ×10⁻⁴ | at epoch |",
        "|---:|---:|---:|---:|",
    ]
    out += [
        f"| {x['n_points']} | {x['s_per_epoch']:.2f} | {1e4 * x['best_val_d_R']:.2f} | {x['best_epoch']} |"
        for x in r["rows"]
    ]
    out += [
        "",
        f"Measured {r['date']} on {r['cpu_count']} cores, torch {r['torch']}; load average "
        f"{r['loadavg_1min_at_start']} at the start, {r['loadavg_1min_at_end']} at the end.",
    ]
    return "\n".join(out)


def main(argv=None):
    run_benchmark("PointNet encoder points", parse_args, measure, report, argv)


if __name__ == "__main__":
    main()
