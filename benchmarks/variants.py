"""Benchmark: each idea of OperatorNet's ``variant="ours"`` alone, on ``val``, with the paper's training budget.

Trains, through :func:`opnet.train.fit` (same data, seed, epochs, batch size and peak learning rate for all):

- ``paper``: the paper's network (fed ``D − I``, constant learning rate);
- ``standardize``: + per-entry standardised inputs ``(D − μ) / σ``;
- ``standardize+residual``: + decoding a displacement from the base;
- ``onecycle``: the paper's network with the one-cycle learning rate only;
- ``ours``: all three (``variant="ours"``),

each in its own run directory under ``--out`` (a second call reuses finished runs, an interrupted one resumes),
and prints the best ``val`` d_R (×10⁻⁴), its epoch, the training time and the ratio to ``paper``. ``test`` is never
read. The variant table of docs/results.md was measured at ``--preset default`` (60 epochs, batch 32).

Run::

    .venv/bin/python benchmarks/variants.py --preset quick --out build/variants-quick     # ~10 min on 2 cores
    .venv/bin/python benchmarks/variants.py --preset default --out build/variants-default # ~1 h on 2 cores
"""

from __future__ import annotations

import argparse
import sys

import opnet
from opnet.reproduce import BUDGETS

IDEAS = {
    "paper": dict(),
    "standardize": dict(standardize=True),
    "standardize+residual": dict(standardize=True, residual=True),
    "onecycle": dict(schedule="onecycle"),
    "ours": dict(variant="ours"),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection and budget preset (quick | default | paper)")
    ap.add_argument("--out", required=True, help="folder for the run directories (reused to resume)")
    ap.add_argument("--ideas", nargs="+", default=list(IDEAS), choices=list(IDEAS), help="which ideas to train")
    ap.add_argument("--seed", type=int, default=0, help="seed of every run (default 0)")
    args = ap.parse_args(argv)
    budget = BUDGETS[args.preset]
    coll = opnet.data.load_collection("humans", args.preset)
    rows = []
    for name in args.ideas:
        _, hist = opnet.train.fit(
            coll,
            epochs=budget.epochs,
            batch_size=budget.batch_size,
            lr=budget.lr,
            seed=args.seed,
            run_dir=f"{args.out}/{name}",
            **IDEAS[name],
        )
        best = min(hist, key=lambda h: h["val_d_R"])
        rows.append((name, best["val_d_R"], best["epoch"], sum(h["seconds"] for h in hist)))
    ref = next((r[1] for r in rows if r[0] == "paper"), None)
    print(
        f"\n# OperatorNet variants on val · preset {args.preset} ({budget.epochs} epochs, batch {budget.batch_size}, "
        f"seed {args.seed})\n"
    )
    print("| idea | best val d_R ×10⁻⁴ | epoch | train s | vs paper |")
    print("|---|---:|---:|---:|---:|")
    for name, val, epoch, secs in rows:
        ratio = f"{ref / val:.2f}×" if ref else "–"
        print(f"| {name} | {1e4 * val:.3f} | {epoch} | {secs:.0f} | {ratio} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
