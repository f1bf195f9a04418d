"""The command line: ``python -m opnet train | evaluate | reproduce`` (``--help`` on each)."""

from __future__ import annotations

import argparse
import json
import os
import sys

from .shape_difference import KINDS


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m opnet", description="OperatorNet: train, evaluate, reproduce the paper."
    )
    sub = p.add_subparsers(dest="command", required=True)

    t = sub.add_parser(
        "train",
        help="train OperatorNet on a collection (resumable; runs under torchrun with DDP)",
        description="Train OperatorNet on the train split of a generated collection, selecting the best "
        "epoch on val. Re-running the same command continues an interrupted run. Under "
        "`torchrun --nproc_per_node N` the global batch is split across N processes "
        "(DistributedDataParallel; gloo on CPU, nccl on GPU).",
    )
    t.add_argument(
        "--collection",
        default="humans",
        help="a generated collection (humans, heads, hands; default humans) or the path of a saved "
        "collection's .json manifest (opnet.data.save_collection, e.g. of load_folder's result)",
    )
    t.add_argument(
        "--preset",
        default="quick",
        choices=["quick", "default", "paper"],
        help="collection size: quick (hundreds of shapes), default (thousands), paper (≈20 000)",
    )
    t.add_argument("--resolution", default=None, help="humans only: 1k (default), 2k or 5k vertices")
    t.add_argument("--data-seed", type=int, default=0, help="seed of the generated collection (default 0)")
    t.add_argument(
        "--channels",
        default=None,
        help="input operators, comma-separated subset of area,conformal,extrinsic, or a short name "
        "(A+E+C, Area, Ext, Conf, A+E, A+C, E+C); default all three (OperatorNet only)",
    )
    t.add_argument(
        "--depth", type=int, default=None, choices=[1, 2, 3, 4], help="convolution layers in OperatorNet's encoder (1)"
    )
    t.add_argument(
        "--epochs", type=_positive, default=50, help="passes over the training split (50); more continues a run"
    )
    t.add_argument("--batch-size", type=_positive, default=32, help="shapes per step, global across processes (32)")
    t.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (1e-3)")
    t.add_argument("--seed", type=int, default=0, help="initialisation and shuffling seed (0)")
    t.add_argument("--hidden", type=_positive, default=1024, help="width of the two hidden dense layers (1024)")
    t.add_argument(
        "--no-subtract-identity",
        action="store_true",
        help="feed the network D instead of D - I (the default subtracts the identity)",
    )
    t.add_argument(
        "--variant",
        default="paper",
        choices=["paper", "ours"],
        help="paper: the paper's network; ours: standardised inputs, a displacement from the base and a "
        "one-cycle learning rate (README, 'our variant')",
    )
    t.add_argument(
        "--schedule",
        default=None,
        choices=["constant", "onecycle"],
        help="learning rate over the run (default: constant for paper, onecycle for ours)",
    )
    t.add_argument(
        "--architecture",
        default="operatornet",
        choices=["operatornet", "pointnet"],
        help="operatornet (default), or pointnet: the PointNet autoencoder baseline, which reads the "
        "coordinates (same decoder, loss and checkpoints; --channels/--variant do not apply)",
    )
    t.add_argument("--points", type=_positive, default=None, help="pointnet: vertices the encoder reads (256)")
    t.add_argument("--device", default="auto", help="auto (CUDA if present), cpu, cuda, cuda:N")
    t.add_argument("--run-dir", required=True, help="folder for config.json, latest.pt, best.pt, history.json")
    t.add_argument("--restart", action="store_true", help="replace the run in --run-dir instead of resuming it")
    t.add_argument(
        "--data-root", default=None, help="where collections are cached (default $OPNET_DATA_DIR or ~/.cache/opnet)"
    )

    e = sub.add_parser(
        "evaluate",
        help="evaluate a trained run beside the NN and base-shape baselines",
        description="Evaluate the best checkpoint of a run on the 50-shape subset, test and unseen "
        "subjects (d_R ×1e-4, d_V, d_E; mean and median), with the nearest-neighbour "
        "(same channels) and base-shape baselines. The collection is the one the run was "
        "trained on.",
    )
    e.add_argument("--run-dir", required=True, help="a folder written by `python -m opnet train`")
    e.add_argument(
        "--collection",
        default=None,
        help="the saved collection's .json the run was trained on, when it "
        "is not a generated one (default: the run's own)",
    )
    e.add_argument("--device", default="auto", help="auto, cpu, cuda")
    e.add_argument("--json", default=None, help="also write the rows to this JSON file")
    e.add_argument("--data-root", default=None, help="where collections are cached")

    r = sub.add_parser(
        "reproduce",
        help="Table 1 and the ablation: data, training, evaluation, results.json/md",
        description="Build the humans at a preset, train Table 1's networks (Int+Ext, Int, Ext) and "
        "the ablation grid (depth 1-4 x 7 input sets), evaluate against NN and the base "
        "shape, and write OUT/results.json, OUT/results.md and OUT/figures/. A second "
        "call skips finished runs; an interrupted one continues.",
    )
    r.add_argument(
        "--preset",
        default="quick",
        choices=["quick", "default", "paper"],
        help="quick: minutes on a laptop CPU; default: about an hour on 2 cores; paper: GPU",
    )
    r.add_argument("--out", default=None, help="output folder (default reproduce-<preset>)")
    r.add_argument("--device", default="auto", help="auto, cpu, cuda")
    r.add_argument("--no-ablation", action="store_true", help="only Table 1")
    r.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    r.add_argument(
        "--no-applications",
        action="store_true",
        help="skip the PointNet autoencoder and the analogy / interpolation benchmarks",
    )
    r.add_argument(
        "--no-refine",
        action="store_true",
        help="skip the operator-matching rows (geometric baseline, + refinement; seconds per shape)",
    )
    r.add_argument(
        "--no-maps",
        action="store_true",
        help="skip the computed-map rows (Table 1's Comp networks, other triangulations; maps take "
        "about 0.6 s per shape and core)",
    )
    r.add_argument("--data-root", default=None, help="where collections are cached")
    return p


def _init_distributed(device: str):
    """Initialise the process group when started by torchrun (WORLD_SIZE > 1): nccl for CUDA, else gloo."""
    if int(os.environ.get("WORLD_SIZE", "1")) <= 1:
        return False
    import torch

    from .train import resolve_device

    backend = "nccl" if resolve_device(device).type == "cuda" else "gloo"
    if backend == "nccl":
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", 0)))
    torch.distributed.init_process_group(backend)
    return True


def _rank() -> int:
    import torch

    return torch.distributed.get_rank()


def _barrier() -> None:
    import torch

    torch.distributed.barrier()


def _table(rows) -> str:
    out = [f"{'method':34s} {'split':15s} {'n':>5s} {'d_R e-4':>9s} {'(median)':>9s} {'d_V':>7s} {'d_E':>7s}"]
    for r in rows:
        out.append(
            f"{r['method']:34s} {r['split']:15s} {r['n_shapes']:5d} {1e4 * r['d_R']:9.3f} "
            f"{1e4 * r['d_R_median']:9.3f} {r['d_V']:7.4f} {r['d_E']:7.4f}"
        )
    return "\n".join(out)


def _collection(args):
    from .data import load_collection, read_collection

    if args.collection.endswith(".json"):
        return read_collection(args.collection)
    if args.collection not in ("humans", "heads", "hands"):
        _parser().error(
            f"--collection must be humans, heads, hands or a saved collection's .json, not {args.collection!r}"
        )
    return load_collection(
        args.collection, args.preset, args.data_root, resolution=args.resolution, seed=args.data_seed
    )


def main(argv=None) -> int:
    """Run a command; opnet's own errors are printed as one line (exit status 1), not as a traceback."""
    from .data import CollectionError
    from .mesh import MeshError
    from .train import CheckpointError, TrainingError

    args = _parser().parse_args(argv)
    try:
        return _run(args)
    except (CheckpointError, TrainingError, CollectionError, MeshError, ValueError) as exc:
        print(f"python -m opnet {args.command}: error: {exc}", file=sys.stderr)
        return 1


def _run(args) -> int:
    from .data import load_collection, read_collection

    if args.command == "train":
        from .train import fit, parse_channels

        try:
            channels = None if args.channels is None else parse_channels(args.channels)
        except ValueError as exc:
            _parser().error(str(exc))
        distributed = _init_distributed(args.device)
        try:
            if distributed and _rank() != 0:
                _barrier()  # rank 0 builds the collection if it is missing, the others then read it
            coll = _collection(args)
            if distributed and _rank() == 0:
                _barrier()
            _, history = fit(
                coll,
                channels=channels,
                depth=args.depth or 1,
                epochs=args.epochs,
                batch_size=args.batch_size,
                lr=args.lr,
                seed=args.seed,
                device=args.device,
                run_dir=args.run_dir,
                resume=not args.restart,
                hidden=args.hidden,
                subtract_identity=not args.no_subtract_identity,
                variant=args.variant,
                schedule=args.schedule,
                architecture=args.architecture,
                n_points=args.points,
            )
        finally:
            if distributed:
                import torch

                torch.distributed.destroy_process_group()
        best = min(history, key=lambda h: h["val_d_R"]) if history else None
        if best and int(os.environ.get("RANK", "0")) == 0:
            print(f"best epoch {best['epoch']}: val d_R {1e4 * best['val_d_R']:.3f}e-4; checkpoints in {args.run_dir}")
        return 0

    if args.command == "evaluate":
        from .evaluate import (
            TEST_SETS,
            base_shape_method,
            evaluate,
            nearest_neighbour_method,
            operatornet_method,
            pointnet_method,
        )
        from .train import _checkpoint_path, _model_from_checkpoint, _read_checkpoint, resolve_device

        path = _checkpoint_path(args.run_dir)
        ckpt = _read_checkpoint(path, map_location=resolve_device(args.device))  # read once
        d = ckpt["config"]["data"]
        if args.collection:
            coll = read_collection(args.collection)
        elif d["preset"] in ("quick", "default", "paper"):
            coll = load_collection(d["name"], d["preset"], args.data_root, resolution=d["resolution"], seed=d["seed"])
        else:
            _parser().error(
                f"{args.run_dir} was trained on {d['name']!r}, not a generated collection: pass its "
                "manifest with --collection PATH.json"
            )
        net = _model_from_checkpoint(ckpt, path, coll, device=args.device)
        if hasattr(net, "channels"):
            methods = [operatornet_method(net, coll), nearest_neighbour_method(coll, net.channels)]
        else:  # the PointNet autoencoder
            methods = [pointnet_method(net, coll), nearest_neighbour_method(coll, KINDS)]
        rows = evaluate(coll, methods + [base_shape_method(coll)], TEST_SETS)
        print(_table(rows))
        if args.json:
            with open(args.json, "w") as f:
                json.dump(rows, f, indent=1)
        return 0

    from .reproduce import reproduce

    rows = reproduce(
        args.preset,
        args.out,
        device=args.device,
        ablation=not args.no_ablation,
        figures=not args.no_figures,
        refine=not args.no_refine,
        applications=not args.no_applications,
        maps=not args.no_maps,
        data_root=args.data_root,
        progress=True,
    )
    print(_table([r for r in rows if r["table"] == "table1"]))
    print(f"results: {args.out or f'reproduce-{args.preset}'}/results.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
