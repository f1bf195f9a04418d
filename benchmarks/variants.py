"""Benchmark: each idea of OperatorNet's ``variant="ours"`` alone, on ``val``, with one training budget for all.

Trains, through :func:`opnet.train.fit` (same data, seed, epochs, batch size and peak learning rate for all):

- ``paper``: the paper's network (fed ``D − I``, a constant learning rate, as the paper's code trains);
- ``standardize``: + per-entry standardised inputs ``(D − μ) / σ``;
- ``standardize+residual``: + decoding a displacement from the base;
- ``onecycle``: the paper's network with the one-cycle learning rate only;
- ``ours``: all three (``variant="ours"``),

each in its own run directory under ``--out`` (a second call reuses finished runs, an interrupted one resumes),
and reports the best ``val`` d_R (×10⁻⁴), its epoch, the training time and the ratio to ``paper``, with the
findings computed from them. ``test`` is never read. ``--json PATH`` writes everything
(``benchmarks/results/variants.json``, at ``--preset default``: 60 epochs, batch 32, is the shipped one, rendered in
docs/results.md, section "Our variant").

Run::

    .venv/bin/python benchmarks/variants.py --preset quick --out build/variants-quick     # ~10 min on 2 cores
    .venv/bin/python benchmarks/variants.py --preset default --out ~/.cache/opnet/variants-default --json x.json
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from shape_differences import load_span, measured, run_benchmark, torch_machine_info

import opnet

IDEAS = {
    "paper": dict(),
    "standardize": dict(standardize=True),
    "standardize+residual": dict(standardize=True, residual=True),
    "onecycle": dict(schedule="onecycle"),
    "ours": dict(variant="ours"),
}
#: what each idea is, as the report's table names it
DESCRIPTIONS = {
    "paper": "the paper's network (fed `D − I`, constant lr)",
    "standardize": "+ per-entry standardisation of the inputs, `(D − μ) / σ` over `train`",
    "standardize+residual": "+ standardisation + decoding a displacement from the base",
    "onecycle": "one-cycle learning rate only",
    "ours": 'standardisation + displacement + one-cycle = `variant="ours"`',
}


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection and budget preset (quick | default | paper)")
    ap.add_argument("--out", required=True, help="folder for the run directories (reused to resume)")
    ap.add_argument("--ideas", nargs="+", default=list(IDEAS), choices=list(IDEAS), help="which ideas to train")
    ap.add_argument("--seed", type=int, default=0, help="seed of every run (default 0)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""

    from opnet.reproduce import BUDGETS

    info = torch_machine_info()
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
        rows.append(
            dict(
                idea=name,
                options=IDEAS[name],
                best_val_d_R=best["val_d_R"],
                epoch=best["epoch"],
                epochs=len(hist),
                train_s=sum(h["seconds"] for h in hist),
            )
        )
    return {
        "date": time.strftime("%Y-%m-%d"),
        "config": {
            "preset": args.preset,
            "train_shapes": len(coll.indices("train")),
            "val_shapes": len(coll.indices("val")),
            "epochs": budget.epochs,
            "batch_size": budget.batch_size,
            "lr": budget.lr,
            "seed": args.seed,
            "channels": "A+E+C",
            "depth": 1,
        },
        "machine": info | {"loadavg_1min_at_end": round(os.getloadavg()[0], 2)},
        "rows": rows,
    }


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c, m, rows = result["config"], result["machine"], result["rows"]
    by = {r["idea"]: r for r in rows}
    ref = by.get("paper", {}).get("best_val_d_R")
    out = [
        f"humans at `{c['preset']}` ({c['train_shapes']} `train`, {c['val_shapes']} `val` shapes), Int+Ext, depth "
        f"{c['depth']}, {c['epochs']} epochs, batch {c['batch_size']}, peak lr {c['lr']:g}, seed {c['seed']}, each "
        "through `opnet.train.fit`: best `val` d_R ×10⁻⁴, its epoch, the training time and the ratio to the paper's "
        "network.",
        "",
        "| idea | best val d_R | epoch | train s | vs the paper's network |",
        "|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        ratio = "–" if ref is None else "1" if r["idea"] == "paper" else f"{ref / r['best_val_d_R']:.2f}×"
        out.append(
            f"| {DESCRIPTIONS.get(r['idea'], r['idea'])} | {1e4 * r['best_val_d_R']:.3f} | {r['epoch']} | "
            f"{r['train_s']:.0f} | {ratio} |"
        )
    out.append("")
    if ref is not None and "ours" in by:
        singles = {k: ref / by[k]["best_val_d_R"] for k in ("standardize", "onecycle") if k in by}
        ours = ref / by["ours"]["best_val_d_R"]
        line = f'- `variant="ours"` is {ours:.2f}× better than the paper\'s network on `val`'
        if singles:
            prod = 1.0
            for v in singles.values():
                prod *= v
            line += (
                f"; its parts alone: standardisation {singles.get('standardize', float('nan')):.2f}×, one-cycle "
                f"{singles.get('onecycle', float('nan')):.2f}× (their product {prod:.2f}×)"
            )
        out.append(line + ".")
    if ref is not None and "standardize+residual" in by and "standardize" in by:
        gain = by["standardize"]["best_val_d_R"] / by["standardize+residual"]["best_val_d_R"]
        out.append(
            f"- Decoding a displacement on top of standardisation: {gain:.2f}× better than standardisation alone."
        )
    out += [
        "",
        f"Training times are wall time on a machine shared with other jobs ({load_span(m)} of the "
        "last call; a run's time is the sum of its epochs', in whichever call they ran): inflated, and unevenly "
        "between rows, when the load exceeds the cores; the errors do not depend on it. " + measured(result["date"], m),
    ]
    return "\n".join(out)


def main(argv=None):
    run_benchmark("OperatorNet variants on val", parse_args, measure, report, argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
