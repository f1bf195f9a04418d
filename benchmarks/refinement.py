"""Benchmark: what makes refinement by operator matching (``opnet.reconstruct``) lower d_R, measured on ``val``.

Takes a trained OperatorNet (default: the Int+Ext network that ``python -m opnet reproduce --preset P --out DIR``
trained, ``DIR/runs/table1-A+E+C-d1``), decodes every ``--every``-th ``val`` shape, and runs
:func:`opnet.reconstruct` from the decoded shapes (and from the base) with each setting of a grid: optimiser,
operators matched, smoothness weight and number of steps. It records the mean ``d_R`` and the relative operator
mismatch every 10 steps, and the seconds per shape; then coarse-to-fine schedules over ``k`` (the leading ``m × m``
operators first). ``report`` prints the mean ``d_R`` (×10⁻⁴) after 0, 10, 30, 100, 300, 1000 steps (as far as each
setting goes) and the findings computed from the grid. ``test`` is never read. ``--json PATH`` writes everything
(``benchmarks/results/refinement.json`` is the shipped one, measured at ``--preset default --every 4`` and rendered
in docs/results.md, section "Choosing the refinement on val").

Run::

    .venv/bin/python benchmarks/refinement.py --preset default --reproduce-dir ~/.cache/opnet/reproduce-default
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from shape_differences import load_span, measured, run_benchmark, torch_machine_info

import opnet

AE = ("area", "extrinsic")
#: (start, optimiser, operators, smoothness, steps, extra options)
GRID = [
    ("network", "adam", opnet.KINDS, 0.0, 100, dict(lr=1e-4)),
    ("network", "lbfgs", opnet.KINDS, 0.0, 100, {}),
    ("network", "lbfgs", opnet.KINDS, 0.01, 100, {}),
    ("network", "lbfgs", opnet.KINDS, 0.1, 300, {}),
    ("network", "lbfgs", opnet.KINDS, 1.0, 100, {}),
    ("network", "lbfgs", opnet.KINDS, 10.0, 100, {}),
    ("network", "lbfgs", AE, 0.1, 100, {}),
    ("network", "lbfgs", AE, 1.0, 1000, {}),
    ("network", "lbfgs", AE, 10.0, 300, {}),
    ("base", "lbfgs", opnet.KINDS, 0.0, 100, {}),
    ("base", "lbfgs", opnet.KINDS, 1.0, 300, {}),
]
SHOWN = (0, 10, 30, 100, 300, 1000)
EVERY = 10  # d_R and the mismatch are recorded every EVERY steps (and at the last)
#: coarse-to-fine schedules over k: (k, steps) stages, area + extrinsic, smoothness 1
COARSE_TO_FINE = [[(20, 100), (40, 100), (60, 100)], [(10, 50), (20, 50), (30, 50), (45, 50), (60, 100)]]
OPTIMISERS = {"adam": "Adam", "lbfgs": "L-BFGS"}


def label(channels) -> str:
    return "A+E+C" if tuple(channels) == tuple(opnet.KINDS) else "+".join(c[0].upper() for c in channels)


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection preset (quick | default | paper)")
    ap.add_argument(
        "--reproduce-dir",
        help="the reproduce output whose Int+Ext network is refined "
        "(default: the notebooks' folder, opnet.reproduce.notebook_out(preset))",
    )
    ap.add_argument("--every", type=int, default=4, help="use every N-th val shape (default 4)")
    ap.add_argument("--quick", action="store_true", help="only the first two settings, at most 30 steps")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""

    from opnet.evaluate import predict
    from opnet.geometric import truncate_operators
    from opnet.reproduce import notebook_out, run_path

    info = torch_machine_info()
    coll = opnet.data.load_collection("humans", args.preset)
    out = Path(args.reproduce_dir).expanduser() if args.reproduce_dir else None
    out = out or notebook_out(args.preset)
    run = run_path(out, coll, "table1", opnet.KINDS, 1)
    net = opnet.train.load_model(run, coll)
    idx = coll.indices("val")[:: args.every]
    gt = coll.vertices[idx].astype(np.float64)
    decoded = predict(net, coll.operators[idx])
    grid = [(*g[:4], min(g[4], 30), g[5]) for g in GRID[:2]] if args.quick else GRID
    rows = []
    for start, optimizer, channels, smoothness, steps, extra in grid:
        curve = []

        def record(step, X, mismatch):
            if step % EVERY == 0 or step in SHOWN or step == steps:
                curve.append([step, float(opnet.d_R(gt, X.numpy()).mean()), float(mismatch.mean())])

        chans = [opnet.KINDS.index(c) for c in channels]
        t, cpu = time.perf_counter(), time.process_time()
        opnet.reconstruct(
            coll.operators[idx][:, chans],
            coll.base_basis,
            init=decoded if start == "network" else "base",
            channels=channels,
            steps=steps,
            optimizer=optimizer,
            smoothness=smoothness,
            callback=record,
            progress=False,
            **extra,
        )
        seconds = (time.perf_counter() - t) / len(idx)
        cpu = (time.process_time() - cpu) / len(idx)
        rows.append(
            dict(
                start=start,
                optimizer=optimizer,
                operators=label(channels),
                smoothness=smoothness,
                steps=steps,
                options=extra,
                curve=curve,
                s_per_shape=seconds,
                cpu_s_per_shape=cpu,
            )
        )
        print(f"{start} {optimizer} {label(channels)} {smoothness:g}: done", flush=True)
    c2f = []
    if not args.quick:
        D = coll.operators[idx][:, [opnet.KINDS.index(c) for c in AE]].astype(np.float64)
        for schedule in COARSE_TO_FINE:
            X, t, cpu, after = decoded, time.perf_counter(), time.process_time(), []
            for m, steps in schedule:
                X = opnet.reconstruct(
                    truncate_operators(D, coll.base_basis, AE, m),
                    coll.base_basis.truncate(m),
                    init=X,
                    channels=AE,
                    steps=steps,
                    smoothness=1.0,
                    progress=False,
                )
                after.append(float(opnet.d_R(gt, X).mean()))
            c2f.append(
                dict(
                    stages=[list(s) for s in schedule],
                    operators=label(AE),
                    smoothness=1.0,
                    d_R_after=after,
                    s_per_shape=(time.perf_counter() - t) / len(idx),
                    cpu_s_per_shape=(time.process_time() - cpu) / len(idx),
                )
            )
    return {
        "date": time.strftime("%Y-%m-%d"),
        "config": {
            "preset": args.preset,
            "network": f"{run.parent.parent.name}/runs/{run.name}",
            "val_shapes": len(idx),
            "every": args.every,
            "quick": args.quick,
            "k": coll.base_basis.k,
        },
        "machine": info | {"loadavg_1min_at_end": round(os.getloadavg()[0], 2)},
        "rows": rows,
        "coarse_to_fine": c2f,
    }


# ---- report ------------------------------------------------------------------------------------------------------


def _at(row, step):
    """``(d_R, mismatch)`` of ``row`` at ``step``, or None."""
    return next(((d, m) for s, d, m in row["curve"] if s == step), None)


def _last(row):
    return row["curve"][-1]


def _find(rows, start="network", optimizer="lbfgs", operators="A+E+C", smoothness=None):
    for r in rows:
        if (r["start"], r["optimizer"], r["operators"]) == (start, optimizer, operators) and (
            smoothness is None or r["smoothness"] == smoothness
        ):
            return r
    return None


def _cost(row) -> float:
    """Seconds per shape to compare rows by: CPU time when recorded (wall time depends on the machine's load)."""
    return row.get("cpu_s_per_shape", row["s_per_shape"])


def _pct(after, before) -> str:
    return f"{100 * (after / before - 1):+.0f} %".replace("-", "−")


def _d(x) -> str:
    return f"{1e4 * x:.3f}" if x < 1e-2 else f"{1e4 * x:.1f}"


def _cpu(r) -> str:
    return f"{r['cpu_s_per_shape']:.2f}" if "cpu_s_per_shape" in r else "–"


def _fmt_setting(r) -> str:
    return f"{r['operators']}, smoothness {r['smoothness']:g}"


def _timed(result) -> str:
    return "CPU time" if all("cpu_s_per_shape" in r for r in result["rows"]) else "time"


def findings(result: dict) -> list[str]:
    """The bullet lines of the report, computed from the grid (a bullet whose rows are missing is left out)."""
    rows, out = result["rows"], []
    lbfgs, adam = _find(rows, smoothness=0.0), _find(rows, optimizer="adam")
    longest = max((r for r in rows if r["start"] == "network"), key=lambda r: r["steps"], default=None)
    if lbfgs and _at(lbfgs, 100) and longest:
        (d0, m0), (d100, m100) = _at(lbfgs, 0), _at(lbfgs, 100)
        later = [(s, _at(longest, s)[0]) for s in (300, 1000) if _at(longest, s)]
        out.append(
            f"- Steps: in 100 L-BFGS steps (A+E+C, smoothness 0) the mismatch falls {m0 / m100:,.0f}× and d_R changes "
            f"by {_pct(d100, d0)}; longer runs ({_fmt_setting(longest)}): "
            + ", ".join(f"{_pct(d, _at(longest, 0)[0])} at {s} steps" for s, d in later)
            + "."
        )
    if lbfgs and adam and _at(adam, 100) and _at(lbfgs, 100):
        d0 = _at(lbfgs, 0)[0]
        out.append(
            f"- L-BFGS against Adam (lr {adam['options'].get('lr', 1e-3):g}) at 100 steps: "
            f"{_pct(_at(lbfgs, 100)[0], d0)} against {_pct(_at(adam, 100)[0], _at(adam, 0)[0])} d_R."
        )
    ae, aec = _find(rows, operators="A+E", smoothness=0.1), _find(rows, smoothness=0.1)
    if ae and aec and _at(ae, 100) and _at(aec, 100):
        cost = (_cost(aec) / aec["steps"]) / (_cost(ae) / ae["steps"])
        out.append(
            f"- The conformal channel, at smoothness 0.1 and 100 steps: d_R {_d(_at(ae, 100)[0])} with A+E, "
            f"{_d(_at(aec, 100)[0])} with A+E+C, at {cost:.1f}× the {_timed(result)} per step."
        )
    smooth = [r for r in rows if (r["start"], r["optimizer"], r["operators"]) == ("network", "lbfgs", "A+E+C")]
    smooth = sorted((r for r in smooth if _at(r, 100)), key=lambda r: r["smoothness"])
    if len(smooth) > 1:
        lo, hi = smooth[0], smooth[-1]
        line = (
            f"- Smoothness (A+E+C, 100 steps): d_R {_d(_at(lo, 100)[0])} at weight {lo['smoothness']:g}, "
            f"{_d(_at(hi, 100)[0])} at {hi['smoothness']:g}"
        )
        long = {r["smoothness"]: _at(r, 300)[0] for r in rows if r["operators"] == "A+E" and _at(r, 300)}
        if len(long) > 1:
            line += "; at 300 steps (A+E): " + ", ".join(f"{_d(d)} at weight {w:g}" for w, d in sorted(long.items()))
        out.append(line + ".")
    base = [r for r in rows if r["start"] == "base"]
    if base:
        b = max(base, key=lambda r: r["steps"])
        out.append(
            f"- From the base ({_fmt_setting(b)}): d_R {_d(_at(b, 0)[0])} → {_d(_last(b)[1])} in {_last(b)[0]} steps "
            f"({_pct(_last(b)[1], _at(b, 0)[0])})."
        )
    single = _find(rows, operators="A+E", smoothness=1.0)
    if result["coarse_to_fine"] and single:
        per_step = _cost(single) / single["steps"]
        for c in result["coarse_to_fine"]:
            steps = sum(n for _, n in c["stages"])
            same = _at(single, steps)
            eq = min(single["curve"], key=lambda p: abs(p[0] - _cost(c) / per_step))
            line = f"- Coarse-to-fine from k = {c['stages'][0][0]} ({len(c['stages'])} stages, {steps} steps): d_R " + (
                f"{_d(c['d_R_after'][-1])}"
            )
            if same:
                line += (
                    f", against {_d(same[0])} for {steps} steps at k = {c['stages'][-1][0]}, which take "
                    f"{per_step * steps / _cost(c):.1f}× its {_timed(result)}"
                )
            out.append(line + f"; in the same {_timed(result)} the single-k run reaches {_d(eq[1])} (step {eq[0]}).")
    return out


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c, m = result["config"], result["machine"]
    out = [
        f"Network `{c['network']}` (humans at `{c['preset']}`), {c['val_shapes']} `val` shapes (every "
        f"{c['every']}-th){' (--quick)' if c['quick'] else ''}: mean d_R ×10⁻⁴ after 0, 10, 30, 100, 300, 1000 "
        "steps (as far as each setting goes), the final relative operator mismatch, and seconds per shape for the "
        "whole run: wall time, and this process's CPU time (what the comparisons below use).",
        "",
        "| start | optimiser | operators | smoothness | "
        + " | ".join(map(str, SHOWN))
        + " | final mismatch | s/shape | CPU s/shape |",
        "|---|---|---|---:|" + "---:|" * (len(SHOWN) + 3),
    ]
    for r in result["rows"]:
        opt = OPTIMISERS.get(r["optimizer"], r["optimizer"])
        if "lr" in r["options"]:
            opt += f" (lr {r['options']['lr']:g})"
        cells = [_d(p[0]) if (p := _at(r, s)) else "" for s in SHOWN]
        out.append(
            f"| {r['start']} | {opt} | {r['operators']} | {r['smoothness']:g} | "
            + " | ".join(cells)
            + f" | {_last(r)[2]:.2g} | {r['s_per_shape']:.2f} | {_cpu(r)} |"
        )
    if result["coarse_to_fine"]:
        out += [
            "",
            "| coarse-to-fine stages (k: steps), A+E, smoothness 1 | d_R after each stage | s/shape | CPU s/shape |",
            "|---|---|---:|---:|",
        ]
        for r in result["coarse_to_fine"]:
            out.append(
                f"| {', '.join(f'{k}: {n}' for k, n in r['stages'])} | {' → '.join(map(_d, r['d_R_after']))} | "
                f"{r['s_per_shape']:.2f} | {_cpu(r)} |"
            )
    out += ["", *findings(result), ""]
    out.append(
        f"s/shape is wall time on a machine shared with other jobs ({load_span(m)}): inflated, and unevenly between "
        "rows, when the load exceeds the cores; the CPU time much less so, and d_R not at all. "
        + measured(result["date"], m)
    )
    return "\n".join(out)


def main(argv=None):
    run_benchmark("Refinement on val", parse_args, measure, report, argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
