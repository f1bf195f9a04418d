"""Benchmark: computed maps between triangulations (``opnet.matching``), and what they do to OperatorNet's input.

For ``--shapes`` evenly spaced ``val`` shapes of the humans (``test`` is never read), the same bodies are
generated on the 2k and 5k meshes and mapped onto the 1k base three ways: the true map (closest points
between triangulations of the rest pose: the error floor of the discretisation alone), the computed map,
and the computed map without the orientation term. For each it prints the seconds per map, the mean map
error (units of the base's ``sqrt(area)``, and centimetres), how many maps are mirrored (closer to the
mirror image of the truth than to the truth), the quality figures, and the error of each operator
channel against the 1k ground truth relative to the operator's own signal ``‖D − I‖``. With ``--runs``,
each Table 1 network there decodes every encoding, and its d_R (×10⁻⁴) against the 1k shapes is printed.

Run::

    .venv/bin/python benchmarks/matching.py --preset default --shapes 16 --runs /path/to/reproduce-default/runs
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import opnet
from opnet.data import humans
from opnet.data.generators import generate_shapes, resolution_map
from opnet.matching import SurfaceMap, compute_map, operators_through_map


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection preset (quick | default | paper)")
    ap.add_argument("--shapes", type=int, default=6, help="val shapes, evenly spaced (6)")
    ap.add_argument("--resolutions", nargs="+", default=["2k", "5k"])
    ap.add_argument(
        "--runs", type=Path, default=None, help="a reproduce runs/ folder: decode with its table1-* networks"
    )
    args = ap.parse_args(argv)
    ds = opnet.data.load_collection("humans", args.preset)
    basis = ds.base_basis
    val = ds.indices("val")
    idx = val[np.linspace(0, len(val) - 1, min(args.shapes, len(val))).astype(int)]
    truth_ops = ds.operators[idx].astype(np.float64)
    nets = {}
    if args.runs is not None:
        for run in sorted(args.runs.glob("table1-*-d1*")):
            nets[run.name] = opnet.train.load_model(run, ds)
    spectrum = opnet.eigenbasis(basis.mesh, 100)
    print(f"{ds}; {len(idx)} val shapes")
    header = (
        f"{'mesh':>4s} {'map':>14s} {'s/map':>6s} {'err':>7s} {'cm':>5s} {'mirrored':>8s} {'coverage':>8s} "
        f"{'orient.':>7s} {'area':>6s} {'conf.':>6s} {'ext.':>6s}" + "".join(f" {n[7:]:>16s}" for n in nets)
    )
    print(header)
    if nets:
        exact = [
            np.mean([opnet.d_R(x, g) for x, g in zip(opnet.decode(net, truth_ops), ds.vertices[idx])]) * 1e4
            for net in nets.values()
        ]
        print(
            f"{'1k':>4s} {'exact':>14s} {'':>6s} {'':>7s} {'':>5s} {'':>8s} {'':>8s} {'':>7s} {0:6.3f} {0:6.3f} "
            f"{0:6.3f}" + "".join(f" {e:16.3g}" for e in exact)
        )
    signal = np.linalg.norm(truth_ops - np.eye(basis.k), axis=(2, 3))  # (N, 3)
    for res in args.resolutions:
        faces = humans.human_faces(res)
        shapes = generate_shapes(ds, ds.params["phenotypes"][idx], ds.params["controls"][idx], resolution=res)
        true_to_base = resolution_map(ds, res)  # one triangulation of the rest shape onto the other
        for label, options in (("true", None), ("computed", {}), ("no orientation", {"orientation": False})):
            seconds, errors, mirrored, quality, maps = [], [], 0, [], []
            for v in shapes:
                mesh = opnet.Mesh(v, faces)
                true = SurfaceMap(basis, mesh, true_to_base)
                start = time.perf_counter()
                sm = true if options is None else compute_map(basis, mesh, base_spectrum=spectrum, **options)
                seconds.append(time.perf_counter() - start)
                err = sm.error(true)
                mirror = np.linalg.norm(sm.points - true.points * [-1, 1, 1], axis=1) / np.sqrt(basis.mesh.area)
                errors.append(err.mean())
                mirrored += int(mirror.mean() < err.mean())
                quality.append(list(sm.quality().values()))
                maps.append(sm)
            ops = operators_through_map(maps)
            rel = (np.linalg.norm(ops - truth_ops, axis=(2, 3)) / signal).mean(0)
            coverage, orientation = np.mean(quality, axis=0)
            cm = np.mean(errors) * np.sqrt(basis.mesh.area) * 100
            line = (
                f"{res:>4s} {label:>14s} {np.mean(seconds) if options is not None else 0:6.2f} {np.mean(errors):7.4f} "
                f"{cm:5.2f} {mirrored:>3d}/{len(idx):<4d} {coverage:8.3f} {orientation:7.3f} "
                f"{rel[0]:6.3f} {rel[1]:6.3f} {rel[2]:6.3f}"
            )
            for net in nets.values():
                recon = opnet.decode(net, ops)
                line += f" {np.mean([opnet.d_R(x, g) for x, g in zip(recon, ds.vertices[idx])]) * 1e4:16.3g}"
            print(line, flush=True)
    print(
        "err: mean distance on the base between the map's image and the truth's, in sqrt(base area); "
        "area/conf./ext.: ‖D − D_true‖ / ‖D_true − I‖ against the 1k operators"
    )


if __name__ == "__main__":
    main()
