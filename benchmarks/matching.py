"""Benchmark: computed maps between triangulations (``opnet.matching``), and what they do to OperatorNet's input.

For ``--shapes`` evenly spaced ``val`` shapes of the humans (``test`` is never read), the same bodies are
generated on the 2k and 5k meshes and mapped onto the 1k base three ways: the true map (closest points
between triangulations of the rest pose: the error floor of the discretisation alone), the computed map,
and the computed map without the orientation term. For each it measures the seconds per map, the mean map
error (units of the base's ``sqrt(area)``, and centimetres), how many maps are mirrored (closer to the
mirror image of the truth than to the truth), the quality figures, and the error of each operator
channel against the 1k ground truth relative to the operator's own signal ``‖D − I‖``. With ``--runs``,
each finished Table 1 network there (the first seed of the paper's three and our variant, found by the reproduction's
plan at ``--preset``: ``RunSpec.run_dir``; runs missing or still training are skipped) decodes every encoding, and
its d_R (×10⁻⁴) against the 1k shapes is reported. ``report`` prints the table and the findings computed
from it; ``--json PATH`` writes everything (``benchmarks/results/matching.json`` is the shipped one, rendered in
docs/results.md, section "Other triangulations").

Run::

    .venv/bin/python benchmarks/matching.py --preset default --shapes 16 --runs ~/.cache/opnet/reproduce-default/runs
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
from shape_differences import load_span, measured, run_benchmark, torch_machine_info

import opnet

#: the maps of each resolution: (label, compute_map options; None: the true map)
MAPS = (("true", None), ("computed", {}), ("computed, no orientation term", {"orientation": False}))
#: the short names of Table 1's networks (the reproduction's plan entry → column)
NET_NAMES = {"int+ext": "Int+Ext", "int": "Int", "ext": "Ext", "ours": "ours"}


def finished_runs(runs: Path, ds, preset: str) -> tuple[dict[str, Path], list[str]]:
    """``{column: run directory}`` of Table 1's networks in ``runs`` whose training is complete (every epoch of their
    config in their history), each its first seed's run as the reproduction at ``preset`` declares it on ``ds``
    (:meth:`opnet.experiments.RunSpec.run_dir`: its name carries its settings' digest), and the folders skipped
    (not there, still training, or unreadable)."""
    from opnet.reproduce import BUDGETS, declare

    plan = declare(BUDGETS[preset])  # seed 0 of each network: a seeded reproduction's first run is the same
    done, skipped = {}, []
    for key, column in NET_NAMES.items():
        run = plan[key].spec.run_dir(runs, ds)
        try:
            epochs = json.loads((run / "config.json").read_text())["train"]["epochs"]
            history = json.loads((run / "history.json").read_text())
        except (OSError, ValueError, KeyError):
            skipped.append(run.name)
            continue
        if len(history) >= epochs and (run / "best.pt").is_file():
            done[column] = run
        else:
            skipped.append(run.name)
    return done, skipped


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection preset (quick | default | paper)")
    ap.add_argument("--shapes", type=int, default=6, help="val shapes, evenly spaced (6)")
    ap.add_argument("--resolutions", nargs="+", default=["2k", "5k"])
    ap.add_argument(
        "--runs", type=Path, default=None, help="a reproduce runs/ folder: decode with its finished table1-* networks"
    )
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def mean_d_R(net, operators, truth) -> float:
    """The mean d_R (eq. 9, m²) of ``net``'s decodings of ``operators`` against ``truth``."""
    return float(np.mean([opnet.d_R(x, g) for x, g in zip(opnet.decode(net, operators), truth)]))


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""

    from opnet.data import humans
    from opnet.data.generators import generate_shapes, resolution_map
    from opnet.matching import SurfaceMap, compute_map, operators_through_map

    info = torch_machine_info()
    ds = opnet.data.load_collection("humans", args.preset)
    basis = ds.base_basis
    val = ds.indices("val")
    idx = val[np.linspace(0, len(val) - 1, min(args.shapes, len(val))).astype(int)]
    truth_ops = ds.operators[idx].astype(np.float64)
    truth = ds.vertices[idx]
    nets, skipped = {}, []
    if args.runs is not None:
        runs, skipped = finished_runs(Path(args.runs).expanduser(), ds, args.preset)
        nets = {column: opnet.train.load_model(run, ds) for column, run in runs.items()}
    spectrum = opnet.eigenbasis(basis.mesh, 100)
    scale = float(np.sqrt(basis.mesh.area))
    rows = [
        {
            "mesh": "1k",
            "map": "exact",
            "n": len(idx),
            "operator_error": dict.fromkeys(opnet.KINDS, 0.0),
            "d_R": {name: mean_d_R(net, truth_ops, truth) for name, net in nets.items()},  # m²
        }
    ]
    signal = np.linalg.norm(truth_ops - np.eye(basis.k), axis=(2, 3))  # (N, 3)
    for res in args.resolutions:
        faces = humans.human_faces(res)
        shapes = generate_shapes(ds, ds.params["phenotypes"][idx], ds.params["controls"][idx], resolution=res)
        true_to_base = resolution_map(ds, res)  # one triangulation of the rest shape onto the other
        for label, options in MAPS:
            seconds, errors, mirrored, quality, maps = [], [], 0, [], []
            for v in shapes:
                mesh = opnet.Mesh(v, faces)
                true = SurfaceMap(basis, mesh, true_to_base)
                start = time.perf_counter()
                sm = true if options is None else compute_map(basis, mesh, base_spectrum=spectrum, **options)
                seconds.append(time.perf_counter() - start)
                err = sm.error(true)
                mirror = np.linalg.norm(sm.points - true.points * [-1, 1, 1], axis=1) / scale
                errors.append(float(err.mean()))
                mirrored += int(mirror.mean() < err.mean())
                quality.append(list(sm.quality().values()))
                maps.append(sm)
            ops = operators_through_map(maps)
            rel = (np.linalg.norm(ops - truth_ops, axis=(2, 3)) / signal).mean(0)
            coverage, orientation = np.mean(quality, axis=0)
            rows.append(
                {
                    "mesh": res,
                    "map": label,
                    "n": len(idx),
                    "s_per_map": None if options is None else float(np.mean(seconds)),
                    "map_error": float(np.mean(errors)),
                    "map_error_cm": float(np.mean(errors) * scale * 100),
                    "mirrored": mirrored,
                    "coverage": float(coverage),
                    "orientation": float(orientation),
                    "operator_error": {k: float(r) for k, r in zip(opnet.KINDS, rel)},
                    "d_R": {name: mean_d_R(net, ops, truth) for name, net in nets.items()},
                }
            )
            print(f"{res} {label}: done", flush=True)
    return {
        "date": time.strftime("%Y-%m-%d"),
        "config": {
            "preset": args.preset,
            "collection": str(ds),
            "n_shapes": len(idx),
            "split": "val",
            "resolutions": list(args.resolutions),
            "base_vertices": basis.mesh.n_vertices,
            "k": basis.k,
            "networks": list(nets),
            "skipped_runs": skipped,
        },
        "machine": info | {"loadavg_1min_at_end": round(os.getloadavg()[0], 2)},
        "rows": rows,
    }


def _g(x: float) -> str:
    """A d_R (m²) as the table shows it, ×10⁻⁴: 3 significant digits, from 10³ on as ``8.9e4``."""
    x *= 1e4
    if x < 1e3:
        return f"{x:.3g}"
    mantissa, exponent = f"{x:.1e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def _factor(x: float) -> str:
    return f"{x:.1f}" if x < 10 else f"{x:.0f}"


def _span(values, fmt=_factor) -> str:
    """``lo–hi`` of ``values`` as ``fmt`` writes them (one value when both read the same)."""
    lo, hi = fmt(min(values)), fmt(max(values))
    return lo if lo == hi else f"{lo}–{hi}"


def findings(result: dict) -> list[str]:
    """The bullet lines of the report: what the table shows, computed from it."""
    rows, n = result["rows"], result["config"]["n_shapes"]
    by = {(r["mesh"], r["map"]): r for r in rows}
    res = [m for m in result["config"]["resolutions"] if (m, "computed") in by]
    out = []
    bare = [(by[m, "computed, no orientation term"], by[m, "computed"]) for m in res]
    if bare:
        mirrored = " and ".join(f"{b['mirrored']} ({m})" for m, (b, _) in zip(res, bare))
        ratio = _span([b["map_error"] / c["map_error"] for b, c in bare], lambda x: f"{x:.1f}")
        kept = " and ".join(f"{c['mirrored']} ({m})" for m, (_, c) in zip(res, bare))
        out.append(
            f"- The orientation term: without it {mirrored} of {n} maps land on the mirror image and the mean map "
            f"error is {ratio}× larger; with it {kept} of {n} are mirrored."
        )
    exact = by.get(("1k", "exact"), {}).get("d_R", {})
    if exact:
        true = [by[m, "true"]["d_R"][k] / e for m in res for k, e in exact.items()]
        comp = [by[m, "computed"]["d_R"][k] / e for m in res for k, e in exact.items()]
        cm = _span([by[m, "computed"]["map_error_cm"] for m in res], lambda x: f"{x:.2f}")
        out.append(
            f"- The networks trained on exact 1k operators lose a factor {_span(true)} in d_R on another "
            f"triangulation even through the true map, and a factor {_span(comp)} through a computed one "
            f"(mean map error {cm} cm)."
        )
        per_net = {k: np.mean([by[m, "computed"]["d_R"][k] / e for m in res]) for k, e in exact.items()}
        least = min(per_net, key=per_net.get)
        out.append(
            f"- The {least} network degrades least through the computed maps (its d_R ×{_factor(per_net[least])} on "
            f"average over {', '.join(res)}), the {max(per_net, key=per_net.get)} one most "
            f"(×{_factor(max(per_net.values()))})."
        )
    if res:
        op = {k: np.mean([by[m, "computed"]["operator_error"][k] for m in res]) for k in opnet.KINDS}
        worst, best = max(op, key=op.get), min(op, key=op.get)
        out.append(
            f"- Operator error through the computed maps (mean over {', '.join(res)}): largest for the {worst} channel "
            f"({op[worst]:.2f}), smallest for the {best} one ({op[best]:.2f})."
        )
    return out


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c, m = result["config"], result["machine"]
    nets = c["networks"]
    out = [
        f"`{c['collection']}`: {c['n_shapes']} evenly spaced `{c['split']}` bodies generated on the "
        f"{' and '.join(c['resolutions'])} meshes and mapped onto the {c['base_vertices']}-vertex base (k = {c['k']}). "
        "Map error: the mean distance on the base between the map's image and the true map's, in cm; mirrored: maps "
        "closer to the mirror image of the truth than to the truth; operator error ‖D − D₁ₖ‖ / ‖D₁ₖ − I‖ per channel; "
        "d_R ×10⁻⁴ against the 1k body, decoded by each Table 1 network"
        + (f" (runs missing or still training, skipped: {', '.join(c['skipped_runs'])})" if c["skipped_runs"] else "")
        + ".",
        "",
        "| mesh | map | s/map | map error (cm) | mirrored | area | conf. | ext. | "
        + " | ".join(f"d_R {n}" for n in nets)
        + " |",
        "|---|---|---:|---:|---:|---:|---:|---:|" + "---:|" * len(nets),
    ]
    for r in result["rows"]:
        exact = r["map"] == "exact"
        s = "–" if r.get("s_per_map") is None else f"{r['s_per_map']:.2f}"
        err = "–" if exact else f"{r['map_error_cm']:.2f}"
        mirrored = "–" if exact else f"{r['mirrored']}/{r['n']}"
        ops = " | ".join("0" if exact else f"{r['operator_error'][k]:.2f}" for k in opnet.KINDS)
        out.append(
            f"| {r['mesh']} | {r['map']} | {s} | {err} | {mirrored} | {ops} | "
            + " | ".join(_g(r["d_R"][n]) for n in nets)
            + " |"
        )
    out += ["", *findings(result), ""]
    out.append(
        f"s/map is wall time on a machine shared with other jobs ({load_span(m)}): inflated when the load exceeds "
        "the cores; the errors are unaffected. " + measured(result["date"], m)
    )
    return "\n".join(out)


def main(argv=None):
    run_benchmark("Computed maps between triangulations", parse_args, measure, report, argv)
    return 0


if __name__ == "__main__":
    main()
