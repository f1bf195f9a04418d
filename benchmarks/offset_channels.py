"""Benchmark: which extrinsic information decodes best, the paper's extrinsic operator or FuncChar's offset surface?

Trains the paper's OperatorNet (depth 1, the preset's Table 1 budget: epochs, batch size, learning rate, width;
one seed) through :func:`opnet.ablation` on three channel sets of the humans at a preset:

- ``Int+Ext``: area + conformal + extrinsic (the paper's Table 1 network);
- ``Int+Off``: area + conformal + the offset surface's area and conformal operators (FuncChar's set, Corman et
  al. 2017: they determine the shape up to a rigid motion);
- ``Int+Ext+Off``: all five,

each in its own run directory under ``--runs`` (a second call reuses finished runs, an interrupted one resumes), and
reports ``d_R`` (×10⁻⁴; median), ``d_V`` and ``d_E`` on ``val``, ``test`` and ``test_subjects``, the seconds each
network trained, and nearest-neighbour retrieval on the same channels. Nothing is chosen here: every set trains
with the same budget, and the test sets are read once, to report.

Run::

    .venv/bin/python benchmarks/offset_channels.py --preset quick --runs build/offset-channels-quick
    .venv/bin/python benchmarks/offset_channels.py --preset default --runs build/offset-channels-default \\
        --json results/offset_channels.json        # 3 networks, about 15 min each on 2 cores
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from shape_differences import load_span, measured, run_benchmark, torch_machine_info

import opnet

INT = ["area", "conformal"]
#: the channel sets compared, by the name the report gives them
SETS = {
    "Int+Ext": [*INT, "extrinsic"],
    "Int+Off": [*INT, "offset_area", "offset_conformal"],
    "Int+Ext+Off": [*INT, "extrinsic", "offset_area", "offset_conformal"],
}
SPLITS = ("val", "test", "test_subjects")
METRICS = ("d_R", "d_R_median", "d_V", "d_E")


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection and budget preset (quick | default | paper)")
    ap.add_argument("--runs", required=True, help="folder for the run directories (reused to resume)")
    ap.add_argument("--epochs", type=int, default=None, help="epochs of every network (default: the preset's Table 1)")
    ap.add_argument("--seed", type=int, default=0, help="seed of every run (default 0)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""

    from opnet.reproduce import BUDGETS

    info = torch_machine_info()
    budget = BUDGETS[args.preset]
    epochs = budget.epochs if args.epochs is None else args.epochs
    wanted = list(dict.fromkeys(c for channels in SETS.values() for c in channels))
    coll = opnet.data.load_collection("humans", args.preset).with_channels(wanted)
    results = opnet.ablation(
        coll,
        list(SETS.values()),
        depths=(1,),
        epochs=epochs,
        run_root=args.runs,
        test_sets=SPLITS,
        batch_size=budget.batch_size,
        lr=budget.lr,
        hidden=budget.hidden,
        seeds=(args.seed,),
    )
    names = {tuple(channels): name for name, channels in SETS.items()}
    rows = []
    for r in results:
        row = dict(
            channels=names.get(tuple(r["channels"]), "+".join(r["channels"])),
            method="Nearest neighbour" if r.get("depth") is None else "OperatorNet",
            split=r["split"],
            n_shapes=r["n_shapes"],
        )
        row |= {m: r[m] for m in METRICS}
        if r.get("depth") is not None:
            row |= dict(epochs=r["epochs"], train_seconds=r["train_seconds"])
        rows.append(row)
    return {
        "date": time.strftime("%Y-%m-%d"),
        "config": {
            "preset": args.preset,
            "train_shapes": len(coll.indices("train")),
            "epochs": epochs,
            "batch_size": budget.batch_size,
            "lr": budget.lr,
            "hidden": budget.hidden,
            "seed": args.seed,
            "depth": 1,
            "variant": "paper",
            "offset_t": opnet.inner_products.OFFSET,
        },
        "machine": info | {"loadavg_1min_at_end": round(os.getloadavg()[0], 2)},
        "rows": rows,
    }


def _cell(row: dict | None) -> str:
    """``d_R (median)`` ×10⁻⁴ of a row, ``–`` for a split not measured."""
    return "–" if row is None else f"{1e4 * row['d_R']:.3g} ({1e4 * row['d_R_median']:.3g})"


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c, m, rows = result["config"], result["machine"], result["rows"]
    at = {(r["channels"], r["method"], r["split"]): r for r in rows}
    out = [
        f"humans at `{c['preset']}` ({c['train_shapes']} `train` shapes); the paper's OperatorNet, depth {c['depth']}, "
        f"{c['epochs']} epochs, batch {c['batch_size']}, lr {c['lr']:g}, seed {c['seed']}, through `opnet.ablation`; "
        f"offset distance t = {c['offset_t']:g}. d_R ×10⁻⁴ m², mean (median); d_V and d_E on `test`.",
        "",
        "| channels | method | val d_R | test d_R | d_V | d_E | unseen subjects d_R | train s |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name in SETS:
        for method in ("OperatorNet", "Nearest neighbour"):
            val, test, subj = (at.get((name, method, s)) for s in SPLITS)
            if test is None:
                continue
            seconds = f"{test['train_seconds']:.0f}" if "train_seconds" in test else "–"
            out.append(
                f"| {name} | {method} | {_cell(val)} | {_cell(test)} | {test['d_V']:.3g} | {test['d_E']:.3g} | "
                f"{_cell(subj)} | {seconds} |"
            )
    out.append("")
    ref = {s: at.get(("Int+Ext", "OperatorNet", s)) for s in SPLITS}
    for name in ("Int+Off", "Int+Ext+Off"):
        if all(ref.values()) and all(at.get((name, "OperatorNet", s)) for s in SPLITS):
            ratios = ", ".join(
                f"{s} {at[(name, 'OperatorNet', s)]['d_R'] / ref[s]['d_R']:.2f}×" for s in SPLITS if ref[s]["d_R"]
            )
            out.append(f"- OperatorNet on {name}'s d_R / on Int+Ext's (the paper's): {ratios}.")
    out += [
        "",
        f"Training times are wall time ({load_span(m)}; a run's time is the sum of its epochs', in whichever call "
        "they ran): inflated when other jobs shared the cores; the errors do not depend on it. "
        + measured(result["date"], m),
    ]
    return "\n".join(out)


def main(argv=None):
    run_benchmark("Offset-surface channels against the extrinsic one", parse_args, measure, report, argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
