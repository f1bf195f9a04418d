"""The command line: ``python -m opnet train | evaluate | reproduce`` (``--help`` on each)."""

from __future__ import annotations

import argparse
import json
import os
import sys


def _parser() -> argparse.ArgumentParser:
    from .data.generators import BODIES, POSES
    from .experiments.config import EvaluateConfig, ReproduceConfig
    from .experiments.plan import PRESETS
    from .options import add_arguments as add_config
    from .train.config import add_arguments

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
        help="a generated collection (humans, heads, hands, animals; default humans) or the path of a saved "
        "collection's .json manifest (opnet.data.save_collection, e.g. of load_folder's result)",
    )
    t.add_argument(
        "--preset",
        default="quick",
        choices=list(PRESETS),
        help="collection size: quick (hundreds of shapes), default (thousands), paper (≈20 000)",
    )
    t.add_argument("--resolution", default=None, help="humans only: 1k (default), 2k or 5k vertices")
    t.add_argument("--data-seed", type=int, default=0, help="seed of the generated collection (default 0)")
    t.add_argument(
        "--bodies",
        default="subject",
        choices=list(BODIES),
        help="generated humans, heads, hands: a body per training subject (default), or one of its own for each "
        "training sequence, each training shape, or every other training shape (mixed); the same shapes held out",
    )
    t.add_argument(
        "--poses",
        default="sequence",
        choices=list(POSES),
        help="generated humans, heads, hands: the training shapes' poses as designed (motion sequences plus a few "
        "random poses; default), a random pose instead for every fourth (quarter) or every other (mixed) training "
        "shape of a motion sequence, or for every training shape (random); the same shapes held out",
    )
    add_arguments(t)  # the hyper-parameters: one option per field of opnet.train.TrainConfig
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
    add_config(e, EvaluateConfig)  # one option per field of opnet.experiments.config.EvaluateConfig

    r = sub.add_parser(
        "reproduce",
        help="Table 1 and the ablation: data, training, evaluation, results.json/md",
        description="Build a collection at a preset, run the plan's entries (Table 1's networks and baselines, "
        "the rows beside it, the refinements, the ablation grid of depth 1-4 x 7 input sets and any of your own), "
        "and write OUT/results.json, OUT/results.md and OUT/figures/ after each entry. A second call loads finished "
        "runs; an interrupted one continues.",
    )
    add_config(r, ReproduceConfig)  # one option per field of opnet.experiments.config.ReproduceConfig
    return p


def _init_distributed(device: str):
    """Initialise the process group when started by torchrun (WORLD_SIZE > 1): nccl for CUDA, else gloo."""
    if int(os.environ.get("WORLD_SIZE", "1")) <= 1:
        return False
    import torch

    from .devices import resolve_device

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
    from .data.generators import GENERATORS

    if args.collection.endswith(".json"):
        for key, default in (("bodies", "subject"), ("poses", "sequence")):
            if getattr(args, key, default) != default:
                _parser().error(f"--{key} draws new {key} for a generated collection, not for a saved .json one")
        return read_collection(args.collection)
    if args.collection not in GENERATORS:
        _parser().error(
            f"--collection must be one of {', '.join(GENERATORS)} or a saved collection's .json, not "
            f"{args.collection!r}"
        )
    return load_collection(
        args.collection,
        args.preset,
        args.data_root,
        resolution=args.resolution,
        seed=args.data_seed,
        bodies=getattr(args, "bodies", "subject"),
        poses=getattr(args, "poses", "sequence"),
    )


def _channels(coll, text: str) -> list:
    """``--channels`` as a list of channels: names the collection holds stay names, the others are resolved (built-in,
    registered, or ``module:Class`` imported); an unknown or unimportable one raises naming it.
    """
    from .inner_products import get_inner_product, split_channels

    out = []
    for c in split_channels(text):
        ip = c if isinstance(c, str) and c in coll.channels else get_inner_product(c)
        if not isinstance(ip, str) and ip.name in coll.channels:
            ip = coll.channel_names([ip])[0]  # held already: its implementation is checked, its name kept
        out.append(ip)
    return out


def main(argv=None) -> int:
    """Run a command; opnet's own errors are printed as one line (exit status 1), not as a traceback."""
    from .data import CollectionError
    from .errors import DiskFullError, FolderInUseError
    from .mesh import MeshError
    from .train import CheckpointError, TrainingError

    args = _parser().parse_args(argv)
    try:
        return _run(args)
    except (CheckpointError, TrainingError, CollectionError, MeshError, ValueError, FolderInUseError) as exc:
        print(f"python -m opnet {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except DiskFullError as exc:  # its message without the "[Errno 28]" prefix
        print(f"python -m opnet {args.command}: error: {exc.strerror}", file=sys.stderr)
        return 1


def _run(args) -> int:
    from .data import load_collection, read_collection

    if args.command == "train":
        from .train import fit
        from .train.config import config_from_args

        config = config_from_args(args)  # a bad value is refused before the collection is built
        distributed = _init_distributed(config.device)
        try:
            if distributed and _rank() != 0:
                _barrier()  # rank 0 builds the collection (and new channels) if missing, the others then read them
            coll = _collection(args)
            channels = None if config.channels is None else _channels(coll, config.channels)
            if channels is not None:
                coll = coll.with_channels([*coll.channels, *(c for c in channels if c not in coll.channels)])
            if distributed and _rank() == 0:
                _barrier()
            _, history = fit(
                coll, **dict(config.as_kwargs(), channels=channels), run_dir=args.run_dir, resume=not args.restart
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
        from .data.generators import PRESETS as DATA_PRESETS
        from .devices import resolve_device
        from .evaluate import (
            base_shape_method,
            evaluate,
            nearest_neighbour_method,
            operatornet_method,
            pointnet_method,
            test_sets_for,
        )
        from .experiments.config import EvaluateConfig
        from .experiments.spec import POINT_LABELS
        from .options import config_from_args
        from .train import checkpoint_path, model_from_checkpoint, read_checkpoint

        config = config_from_args(EvaluateConfig, args)
        path = checkpoint_path(config.run_dir)
        ckpt = read_checkpoint(path, map_location=resolve_device(config.device))  # read once
        d = ckpt["config"]["data"]
        if config.collection:
            coll = read_collection(config.collection)
        elif d["preset"] in DATA_PRESETS:
            coll = load_collection(
                d["name"],
                d["preset"],
                config.data_root,
                resolution=d["resolution"],
                seed=d["seed"],
                bodies=d.get("bodies", "subject"),
                poses=d.get("poses", "sequence"),
            )
        else:
            _parser().error(
                f"{config.run_dir} was trained on {d['name']!r}, not a generated collection: pass its "
                "manifest with --collection PATH.json"
            )
        specs = ckpt["config"].get("channel_specs", {})
        wanted = [c["name"] for c in d.get("channels", []) if c["name"] not in coll.channels]  # channels of the user's
        lost = [name for name in wanted if not specs.get(name)]
        if lost:
            raise ValueError(
                f"{config.run_dir} was trained on the channels {lost}, whose class was not importable (defined in a "
                "notebook or a script run as __main__); evaluate it from Python: "
                "opnet.train.load_model(run_dir, collection.with_channels([..., MyIP()])), or move the class into a "
                "module on the Python path and train again."
            )
        if wanted:
            coll = coll.with_channels([*coll.channels, *(specs[name] for name in wanted)])
        net = model_from_checkpoint(ckpt, path, coll, device=config.device)
        if hasattr(net, "channels"):
            methods = [operatornet_method(net, coll), nearest_neighbour_method(coll, net.channels)]
        else:  # a point-set autoencoder
            info = dict(architecture=net.architecture)
            label = POINT_LABELS[net.architecture]
            methods = [pointnet_method(net, coll, label, info=info), nearest_neighbour_method(coll)]
        rows = evaluate(coll, methods + [base_shape_method(coll)], test_sets_for(coll))
        print(_table(rows))
        if config.json:
            with open(config.json, "w") as f:
                json.dump(rows, f, indent=1)
        return 0

    from .experiments.config import ReproduceConfig
    from .options import config_from_args
    from .reproduce import default_out, reproduce

    config = config_from_args(ReproduceConfig, args, progress=True)
    rows = reproduce(config)
    print(_table([r for r in rows if r["table"] == "table1"]))
    print(f"results: {config.out or default_out(config.preset, config.collection)}/results.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
