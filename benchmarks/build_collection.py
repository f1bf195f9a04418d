"""Benchmark: building a shape collection from scratch (meshes, operators, splits, evaluation subset, file).

Times ``opnet.data.load_collection(name, preset, rebuild=True)`` stage by stage into a temporary
folder, after loading the body model once so that anny's one-time asset cache (about 2 minutes,
``ANNY_CACHE_DIR``) is not counted. Target: the ``default`` human collection in under 3 minutes on
2 CPU cores.

Run::

    .venv/bin/python benchmarks/build_collection.py                    # humans, default preset
    .venv/bin/python benchmarks/build_collection.py --preset quick --name hands
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from unittest import mock

import opnet
from opnet.data import anny_adapter, build, generators, storage

TARGET_SECONDS = 180.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--name", default="humans", choices=sorted(generators.GENERATORS))
    parser.add_argument("--preset", default="default", choices=list(generators.PRESETS))
    parser.add_argument("--resolution", default=None, help="humans: 1k (default), 2k or 5k")
    args = parser.parse_args()

    t0 = time.perf_counter()
    models = {
        "humans": lambda: anny_adapter.human_model(args.resolution or "1k"),
        "heads": anny_adapter.head_model,
        "hands": anny_adapter.hand_model,
    }
    models[args.name]()  # anny's one-time cache and model construction, not counted
    warm = time.perf_counter() - t0

    stages: dict[str, float] = {}

    def timed(label, fn):
        def wrapper(*a, **k):
            t = time.perf_counter()
            out = fn(*a, **k)
            stages[label] = stages.get(label, 0.0) + time.perf_counter() - t
            return out

        return wrapper

    patches = [
        mock.patch.object(anny_adapter, "evaluate", timed("meshes (anny)", anny_adapter.evaluate)),
        mock.patch.object(build, "eigenbasis", timed("base eigenbasis", build.eigenbasis)),
        mock.patch.object(build, "shape_differences", timed("operators (fast path)", build.shape_differences)),
        mock.patch.object(storage, "save_collection", timed("write + checksum", storage.save_collection)),
    ]
    with tempfile.TemporaryDirectory() as root:
        for p in patches:
            p.start()
        t = time.perf_counter()
        coll = opnet.data.load_collection(
            args.name, args.preset, root, resolution=args.resolution, rebuild=True, progress=False
        )
        total = time.perf_counter() - t
        for p in patches:
            p.stop()
        size = sum(f.stat().st_size for f in os.scandir(root)) / 1e6

    print(f"# Collection build: {args.name}, preset {args.preset}, resolution {coll.meta['resolution']}\n")
    print(
        f"{len(coll)} shapes × {coll.vertices.shape[1]} vertices, k = {coll.base_basis.k}; {size:.0f} MB on disk; "
        f"{os.cpu_count()} CPUs; body model loaded in {warm:.1f} s beforehand (not counted)\n"
    )
    print("| stage | seconds |\n|---|---:|")
    for label, s in stages.items():
        print(f"| {label} | {s:.1f} |")
    print(f"| other (design, splits, evaluation subset) | {total - sum(stages.values()):.1f} |")
    print(f"| **total** | **{total:.1f}** |\n")
    if args.name == "humans" and args.preset == "default" and coll.meta["resolution"] == "1k":
        verdict = "MET" if total < TARGET_SECONDS else "MISSED"
        print(f"target: default humans in < {TARGET_SECONDS:.0f} s on 2 cores: {total:.0f} s → {verdict}")


if __name__ == "__main__":
    main()
