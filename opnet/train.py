"""Training OperatorNet (section 5) and the PointNet autoencoder: :func:`~opnet.train.fit`, run directories,
atomic checkpoints, exact resume, DDP.

A run directory holds four files, each written atomically (temporary file + ``os.replace``):

``config.json``
    what was trained on and how: the collection (name, preset, resolution, seed, generator version and a
    SHA-256 fingerprint of its arrays), the network (its ``config()``), the hyper-parameters, and
    the training-code version (``TRAINING_VERSION``), the opnet / torch versions and the device.
``latest.pt``
    the state after the last finished epoch: weights, Adam state, history, best epoch. It is the commit
    point: a run killed at any moment (even by SIGKILL) resumes from it, and a resumed CPU run ends with the
    same weights and history as an uninterrupted one (each epoch's shuffling is seeded by ``(seed, epoch)``,
    and nothing else is random).
``best.pt``
    the weights with the lowest validation ``d_R`` so far (model selection on ``val`` only; ``test`` and
    ``test_subjects`` are never read here).
``history.json``
    one record per epoch: ``epoch``, ``train_loss`` and ``val_d_R`` (eq. 9, length², e.g. m²), ``seconds``.

Checkpoints hold only tensors, numbers, strings, lists and dicts, and are read with
``torch.load(weights_only=True)``: a checkpoint is data, never code.

Under ``torchrun --nproc_per_node N`` (the process group initialised by ``python -m opnet train``), the
model is wrapped in :class:`~torch.nn.parallel.DistributedDataParallel`: every global batch of
``batch_size`` shapes is split across the N processes, and the loss is weighted so that the gradient is
that of the whole global batch; the result equals a single-process run with the same ``batch_size`` up to
floating-point summation order. Only rank 0 writes the run directory.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import torch
from tqdm.auto import tqdm

from ._checks import check_int, check_number
from ._files import atomic_write, remove_stale_tmp
from .model import ARCHITECTURES, VARIANTS, OperatorNet, build_model, rigid_alignment_loss
from .shape_difference import KINDS

__all__ = [
    "fit",
    "load_model",
    "read_history",
    "collection_fingerprint",
    "parse_channels",
    "resolve_device",
    "TrainingError",
    "CheckpointError",
    "CHANNEL_SETS",
    "RUN_FILES",
    "SCHEDULES",
]

CHECKPOINT_FORMAT = "opnet-checkpoint"
CHECKPOINT_VERSION = 1
# Bump when a change to the training code changes what a run produces: runs of other versions are not resumed.
TRAINING_VERSION = 1
#: The files of a run directory (this module's docstring says what each holds).
RUN_FILES = ("config.json", "latest.pt", "best.pt", "history.json")
#: The learning-rate schedules of :func:`fit`: the paper's constant rate, or one cycle (our variant's).
SCHEDULES = ("constant", "onecycle")
_VARIANT_SCHEDULE = {"paper": "constant", "ours": "onecycle"}

#: The paper's input combinations (Table 1 and the ablation of Appendix B), by their short names.
CHANNEL_SETS = {
    "Area": ("area",),
    "Ext": ("extrinsic",),
    "Conf": ("conformal",),
    "A+E": ("area", "extrinsic"),
    "A+C": ("area", "conformal"),
    "E+C": ("conformal", "extrinsic"),
    "A+E+C": KINDS,
}


class TrainingError(RuntimeError):
    """Training cannot go on (for example the loss became NaN); the message names the last good checkpoint."""


class CheckpointError(RuntimeError):
    """A checkpoint or run directory that is unreadable, or that belongs to other data or another network."""


def parse_channels(channels) -> tuple[str, ...]:
    """``"area,extrinsic"``, ``"A+E"`` or a sequence of kinds → a tuple of kinds in the order given."""
    if isinstance(channels, str):
        channels = CHANNEL_SETS[channels] if channels in CHANNEL_SETS else [c.strip() for c in channels.split(",")]
    channels = tuple(channels)
    if not channels or not set(channels) <= set(KINDS) or len(set(channels)) != len(channels):
        raise ValueError(
            f"channels must be a non-empty subset of {KINDS} without repeats (or one of "
            f"{list(CHANNEL_SETS)}), got {channels!r}."
        )
    return channels


def resolve_device(device="auto") -> torch.device:
    """``"auto"`` → CUDA when available, else the CPU; anything else is passed to :class:`torch.device`."""
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(device)
    except (RuntimeError, TypeError):
        raise ValueError(f"device must be 'auto', 'cpu', 'cuda' or 'cuda:N', got {device!r}.") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError("device='cuda' was asked for but torch sees no CUDA GPU; use device='auto' or 'cpu'.")
    return device


def collection_fingerprint(collection) -> str:
    """SHA-256 (hex) of a collection's vertices, operators, splits and base eigenbasis: what a model depends on."""
    h = hashlib.sha256()
    for a in (
        collection.vertices,
        collection.operators,
        collection.split.astype(str),
        collection.base_basis.evecs,
        collection.base_basis.evals,
    ):
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.data)
    return h.hexdigest()


def _data_config(collection) -> dict:
    meta = collection.meta
    return dict(
        name=meta.get("name"),
        preset=meta.get("preset"),
        resolution=meta.get("resolution"),
        seed=meta.get("seed"),
        generator_version=meta.get("generator_version"),
        fingerprint=collection_fingerprint(collection),
        n_vertices=int(collection.vertices.shape[1]),
        k=int(collection.base_basis.k),
    )


def _describe(config: dict) -> str:
    d, m = config["data"], config["model"]
    data = f"{d['name']}/{d['preset']}/{d['resolution']} seed {d['seed']} (data {d['fingerprint'][:12]})"
    if m.get("architecture", "operatornet") != "operatornet":
        return f"{data}, {m['architecture']}"
    return f"{data}, channels {','.join(m['channels'])}, depth {m['depth']}"


# ----------------------------------------------------------------------------------------------------------
# files


def _save_torch(obj, path: Path) -> None:
    atomic_write(path, lambda f: torch.save(obj, f))


def _save_json(obj, path: Path) -> None:
    atomic_write(path, lambda f: f.write(json.dumps(obj, indent=1).encode()))


def _read_checkpoint(path: Path, map_location="cpu") -> dict:
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(
            f"no checkpoint at {path}: train one with opnet.train.fit(..., run_dir=...) or "
            "`python -m opnet train --run-dir ...`, or check the path."
        )
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as exc:  # truncated, not a zip, pickled code refused by weights_only, ...
        raise CheckpointError(
            f"{path} is not a readable opnet checkpoint ({type(exc).__name__}): it is corrupt or "
            "was not written by opnet. Delete it (or the run directory) and train again."
        ) from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != CHECKPOINT_FORMAT:
        raise CheckpointError(f"{path} is not an opnet checkpoint (no '{CHECKPOINT_FORMAT}' header).")
    if not {"config", "model", "epoch"} <= set(ckpt):
        raise CheckpointError(
            f"{path} is an incomplete opnet checkpoint (no {sorted({'config', 'model', 'epoch'} - set(ckpt))}); "
            "delete it and train again."
        )
    if ckpt.get("version") != CHECKPOINT_VERSION:
        raise CheckpointError(
            f"{path} has checkpoint version {ckpt.get('version')}; this opnet reads "
            f"{CHECKPOINT_VERSION}. Train it again with this version."
        )
    return ckpt


def _checkpoint_path(path) -> Path:
    path = Path(path)
    return path / "best.pt" if path.is_dir() else path


def read_history(run_dir) -> list[dict]:
    """The per-epoch history of a run (from its ``latest.pt``, the authoritative copy)."""
    return _read_checkpoint(Path(run_dir) / "latest.pt")["history"]


def load_model(path, collection=None, *, channels=None, device="cpu"):
    """The trained network stored at ``path``: a run directory (its ``best.pt``) or a ``.pt`` checkpoint.

    An :class:`opnet.OperatorNet`, or an :class:`opnet.model.PointNetAutoencoder` for a run of
    ``architecture="pointnet"``.

    With ``collection`` and/or ``channels``, raises :class:`CheckpointError` naming both sides when the
    checkpoint was trained on other data (another fingerprint) or other input channels. The network is
    returned in eval mode on ``device``.
    """
    path = _checkpoint_path(path)
    return _model_from_checkpoint(
        _read_checkpoint(path, map_location=resolve_device(device)), path, collection, channels=channels, device=device
    )


def _model_from_checkpoint(ckpt: dict, path, collection=None, *, channels=None, device="cpu"):
    """:func:`load_model` on a checkpoint already read (``path`` names it in errors)."""
    config = ckpt["config"]
    if channels is not None and "channels" not in config["model"]:
        raise CheckpointError(
            f"{path} holds a {config['model'].get('architecture')} network, which reads no "
            "operators: load it without channels=."
        )
    if channels is not None and tuple(parse_channels(channels)) != tuple(config["model"]["channels"]):
        raise CheckpointError(
            f"{path} was trained on channels {','.join(config['model']['channels'])}, not "
            f"{','.join(parse_channels(channels))}; load the run trained on those channels."
        )
    if collection is not None:
        data = _data_config(collection)
        if data != config["data"]:
            got = dict(config, data=data)
            raise CheckpointError(
                f"{path} was trained on {_describe(config)}, but this collection is "
                f"{_describe(got)}; use a model trained on this collection."
            )
    net = build_model(config["model"])
    net.load_state_dict(ckpt["model"])
    return net.to(resolve_device(device)).eval()


# ----------------------------------------------------------------------------------------------------------
# training


def _distributed() -> tuple[int, int]:
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return 0, 1


def _shard(batch: np.ndarray, rank: int, world: int) -> tuple[np.ndarray, np.ndarray]:
    """The part of a global batch that this rank computes, and the weights of its shapes.

    A rank left without a shape gets one with weight 0, so that every process runs forward and backward as DDP
    requires.
    """
    part = np.array_split(batch, world)[rank]
    if len(part) == 0:
        return batch[:1], np.zeros(1)
    return part, np.ones(len(part))


@torch.no_grad()
def _val_d_R(net, inputs, vertices, batch_size=256) -> float:
    net.eval()
    total = 0.0
    for s in range(0, len(inputs), batch_size):
        pred = net(inputs[s : s + batch_size]).double()
        total += rigid_alignment_loss(pred, vertices[s : s + batch_size].double(), reduction="none").sum().item()
    net.train()
    return total / len(inputs)


def fit(
    collection,
    *,
    channels=None,
    depth: int = 1,
    epochs: int = 50,
    batch_size: int = 32,
    lr: float = 1e-3,
    seed: int = 0,
    device="auto",
    run_dir=None,
    resume: bool = True,
    progress: bool | None = None,
    hidden: int = 1024,
    subtract_identity: bool = True,
    variant: str = "paper",
    schedule: str | None = None,
    standardize: bool | None = None,
    residual: bool | None = None,
    architecture: str = "operatornet",
    n_points: int | None = None,
) -> tuple[torch.nn.Module, list[dict]]:
    """Train OperatorNet (or the PointNet autoencoder) on the ``train`` split of ``collection``; returns the best
    network on ``val`` and the history.

    Parameters
    ----------
    collection : opnet.data.Collection
        Shapes with their operators (``"train"`` and ``"val"`` splits are used; the test splits never).
    channels : kinds or str, optional
        Input operators: a subset of ``("area", "conformal", "extrinsic")``, ``"area,extrinsic"`` or a short
        name of :data:`CHANNEL_SETS` (``"A+E+C"``, ``"Ext"``, ...). Default: all three.
    depth : encoder depth, 1 to 4 (the paper's ablation; 1 is its model).
    epochs : passes over the training split. Resuming with more epochs continues the run.
    batch_size : shapes per optimiser step (the global batch under ``torchrun``).
    lr : Adam's learning rate (the peak one under ``schedule="onecycle"``).
    seed : initialisation and shuffling (epoch ``e`` is shuffled by ``numpy.random.default_rng([seed, e])``).
    device : ``"auto"`` (CUDA when available), ``"cpu"``, ``"cuda"``...
    run_dir : path, optional
        Where the config, checkpoints and history go (see the module docstring). ``None``: nothing is written.
    resume : bool
        ``True``: continue the run found in ``run_dir`` (it must have the same data, network and
        hyper-parameters, else :class:`CheckpointError`); a finished run is just loaded. ``False``: replace it.
    progress : bool, optional
        A progress bar over epochs with the train loss, the val ``d_R`` (×10⁻⁴) and the time left (default: on).
    hidden, subtract_identity : see :class:`opnet.OperatorNet`. The network sees ``D − I`` by default.
    variant : ``"paper"`` (the paper's architecture) or ``"ours"`` (:data:`opnet.model.VARIANTS`: standardised
        inputs, a displacement from the base, and ``schedule="onecycle"``); the README's variant section.
    schedule : the learning rate over the run: ``"constant"`` (the paper's; default for ``"paper"``) or
        ``"onecycle"`` (default for ``"ours"``): a cosine warm-up from ``lr/25`` to ``lr`` over the first 5 % of
        the steps, then a cosine decay towards ``lr/2.5e5`` at the end of the run (as
        ``torch.optim.lr_scheduler.OneCycleLR``).
        It is a function of the step and the planned number of epochs, so a ``"onecycle"`` run resumes only with
        the same ``epochs``.
    standardize, residual : override the variant's network options one by one (see :class:`opnet.OperatorNet`),
        e.g. to measure each part of ``"ours"`` alone (``benchmarks/variants.py``).
    architecture : ``"operatornet"`` (default) or ``"pointnet"``: the PointNet autoencoder
        (:class:`opnet.model.PointNetAutoencoder`), which reads the shapes' coordinates instead of their operators
        and is trained with the same loss, checkpoints and resume (``channels``, ``depth`` and the variant's
        options do not apply to it; ``hidden`` and ``schedule`` do).
    n_points : how many vertices the PointNet encoder reads (spread over the base shape by
        :meth:`~opnet.model.PointNetAutoencoder.choose_points`); default 256 for ``architecture="pointnet"``
        (``benchmarks/pointnet.py`` measures the choice: as accurate as all the vertices, 5× faster).

    Returns
    -------
    net : OperatorNet (or PointNetAutoencoder), the weights of the epoch with the lowest val ``d_R``, in eval mode
        on ``device``.
    history : list of dict, one per epoch: ``epoch``, ``train_loss``, ``val_d_R`` (length²), ``seconds``.

    Raises
    ------
    TrainingError : the loss became NaN or infinite (the message names the epoch and the last good checkpoint).
    CheckpointError : ``run_dir`` holds a run of other data or settings, or an unreadable checkpoint.
    """
    if architecture not in ARCHITECTURES:
        raise ValueError(f"architecture must be one of {list(ARCHITECTURES)}, got {architecture!r}.")
    pointnet = ARCHITECTURES[architecture][1] == "vertices"  # what the network reads
    if pointnet and (
        channels is not None
        or variant != "paper"
        or standardize is not None
        or residual is not None
        or depth != 1
        or subtract_identity is not True
    ):
        raise ValueError(
            "architecture='pointnet' reads coordinates, not operators: channels, depth, variant, "
            "subtract_identity, standardize and residual are OperatorNet's options; leave them unset."
        )
    if not pointnet and n_points is not None:
        raise ValueError(
            "n_points is the PointNet autoencoder's option (architecture='pointnet'); OperatorNet reads "
            "operators, not points: leave it unset."
        )
    n_points = 256 if n_points is None else n_points
    channels = parse_channels(KINDS if channels is None else channels)
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {list(VARIANTS)}, got {variant!r}.")
    schedule = _VARIANT_SCHEDULE[variant] if schedule is None else schedule
    if schedule not in SCHEDULES:
        raise ValueError(f"schedule must be one of {SCHEDULES}, got {schedule!r}.")
    for name, value in (("epochs", epochs), ("batch_size", batch_size), ("hidden", hidden), ("n_points", n_points)):
        check_int(name, value)
    check_number("lr", lr)
    device = resolve_device(device)
    rank, world = _distributed()
    if device.type == "cuda" and world > 1:
        device = torch.device("cuda", int(os.environ.get("LOCAL_RANK", 0)))
    train_idx, val_idx = collection.indices("train"), collection.indices("val")
    if len(train_idx) == 0 or len(val_idx) == 0:
        raise ValueError(
            f"the collection needs shapes in both 'train' and 'val' (it has {len(train_idx)} and "
            f"{len(val_idx)}); give it a splits.csv or use a larger preset."
        )
    chans = [KINDS.index(c) for c in channels]
    read = (
        {"vertices": collection.vertices}
        if pointnet
        else {"operators": collection.operators, "vertices": collection.vertices}
    )
    for name, arr in read.items():
        bad = ~np.isfinite(arr[np.concatenate([train_idx, val_idx])]).reshape(len(train_idx) + len(val_idx), -1).all(1)
        if bad.any():
            raise ValueError(
                f"the collection's {name} hold NaN or infinite values in {bad.sum()} train/val shapes "
                f"(first: shape {np.concatenate([train_idx, val_idx])[bad][0]}); repair or drop them."
            )

    def tensors(idx):  # (network input, target vertices)
        X = torch.from_numpy(np.ascontiguousarray(collection.vertices[idx], dtype=np.float32)).to(device)
        if pointnet:
            return X, X
        return torch.from_numpy(np.ascontiguousarray(collection.operators[idx][:, chans], dtype=np.float32)).to(
            device
        ), X

    (train_in, train_X), (val_in, val_X) = tensors(train_idx), tensors(val_idx)
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        options = {
            **VARIANTS[variant],
            **{k: v for k, v in (("standardize", standardize), ("residual", residual)) if v is not None},
        }
        if pointnet:
            n = collection.vertices.shape[1]
            net = build_model(dict(architecture=architecture, n_vertices=n, n_points=min(n_points, n), hidden=hidden))
            net.choose_points(collection.base_basis.mesh.vertices)
        else:
            net = OperatorNet(
                collection.vertices.shape[1],
                collection.base_basis.k,
                channels,
                depth,
                hidden,
                subtract_identity,
                **options,
            )
            net.set_statistics(train_in.cpu(), collection.base_basis.mesh.vertices)
    net.to(device)
    optimizer = torch.optim.Adam(net.parameters(), lr=lr)
    config = dict(
        data=_data_config(collection),
        model=net.config(),
        train=dict(epochs=epochs, batch_size=batch_size, lr=lr, seed=seed, schedule=schedule, version=TRAINING_VERSION),
        versions=dict(opnet=_opnet_version(), torch=str(torch.__version__)),
        device=str(device),
        world_size=world,
    )

    history, best_val, best_epoch, start = [], math.inf, 0, 0
    run_dir = Path(run_dir) if run_dir is not None else None
    if run_dir is not None:
        if run_dir.exists() and not run_dir.is_dir():
            raise ValueError(f"run_dir {run_dir} is a file; give a directory path.")
        if rank == 0 and run_dir.is_dir():
            remove_stale_tmp(run_dir.glob(".*.tmp-*"))  # left by a killed run
        latest = run_dir / "latest.pt"
        if latest.exists() and resume:
            ckpt = _read_checkpoint(latest, map_location=device)
            _check_same_run(ckpt["config"], config, run_dir)
            if ckpt["epoch"] > epochs:
                raise CheckpointError(
                    f"{run_dir} has already trained {ckpt['epoch']} epochs, more than epochs={epochs}; "
                    f"ask for epochs >= {ckpt['epoch']} to load it, or resume=False (--restart) to "
                    "train it again."
                )
            net.load_state_dict(ckpt["model"])
            optimizer.load_state_dict(ckpt["optimizer"])
            history, best_val, best_epoch, start = ckpt["history"], ckpt["best_val"], ckpt["best_epoch"], ckpt["epoch"]
        elif rank == 0:
            for name in RUN_FILES:
                (run_dir / name).unlink(missing_ok=True)
            run_dir.mkdir(parents=True, exist_ok=True)
            _save_json(config, run_dir / "config.json")
        if world > 1:
            torch.distributed.barrier()

    model = net
    if world > 1:
        model = torch.nn.parallel.DistributedDataParallel(
            net, device_ids=[device.index] if device.type == "cuda" else None
        )
    net.train()
    n = len(train_idx)
    steps_per_epoch = -(-n // batch_size)
    step, total_steps = start * steps_per_epoch, epochs * steps_per_epoch
    bar = tqdm(
        total=epochs,
        initial=min(start, epochs),
        desc="train pointnet" if pointnet else f"train {'+'.join(c[:4] for c in channels)} d{depth}",
        unit="epoch",
        disable=(progress is False) or rank != 0,
    )
    try:
        for epoch in range(start + 1, epochs + 1):
            t0 = time.perf_counter()
            order = np.random.default_rng([seed, epoch]).permutation(n)
            loss_sum = torch.zeros((), dtype=torch.float64, device=device)
            for s in range(0, n, batch_size):
                batch = order[s : s + batch_size]
                part, weight = _shard(batch, rank, world)
                pred = model(train_in[part])
                finite = torch.isfinite(pred).all()
                # a non-finite output is replaced by zeros for Kabsch; the step is refused below in any case
                per_shape = rigid_alignment_loss(
                    torch.where(finite, pred, torch.zeros_like(pred)), train_X[part], reduction="none"
                )
                weight = torch.as_tensor(weight, dtype=per_shape.dtype, device=device)
                # DDP averages gradients over the `world` ranks: scale so that the sum is the global batch mean
                loss = (per_shape * weight).sum() * (world / len(batch))
                ok = (finite & torch.isfinite(loss)).to(torch.int32)
                if world > 1:  # every rank stops together
                    torch.distributed.all_reduce(ok, op=torch.distributed.ReduceOp.MIN)
                if not ok.item():  # before the step (earlier steps of this epoch are lost; the checkpoint is not)
                    _diverged(epoch, "the network's output or training loss", history, start, run_dir, lr)
                if schedule == "onecycle":
                    for group in optimizer.param_groups:
                        group["lr"] = _onecycle(step, total_steps, lr)
                step += 1
                optimizer.zero_grad(set_to_none=True)
                loss.backward()
                optimizer.step()
                loss_sum += (per_shape.detach() * weight).sum().double()
            if world > 1:
                torch.distributed.all_reduce(loss_sum)
            train_loss = loss_sum.item() / n
            val = _val_d_R(net, val_in, val_X)
            if not (math.isfinite(val) and math.isfinite(train_loss)):  # e.g. the last step made the weights NaN
                _diverged(epoch, f"the validation d_R ({val})", history, start, run_dir, lr)
            history.append(dict(epoch=epoch, train_loss=train_loss, val_d_R=val, seconds=time.perf_counter() - t0))
            improved = val < best_val
            if improved:
                best_val, best_epoch = val, epoch
            if run_dir is not None and rank == 0:
                state = dict(format=CHECKPOINT_FORMAT, version=CHECKPOINT_VERSION, config=config)
                if improved:
                    _save_torch(dict(state, epoch=epoch, model=net.state_dict(), val_d_R=val), run_dir / "best.pt")
                _save_json(history, run_dir / "history.json")
                _save_torch(
                    dict(
                        state,
                        epoch=epoch,
                        model=net.state_dict(),
                        optimizer=optimizer.state_dict(),
                        history=history,
                        best_val=best_val,
                        best_epoch=best_epoch,
                    ),
                    run_dir / "latest.pt",
                )
            if improved and run_dir is None:
                best_state = {k: v.detach().clone() for k, v in net.state_dict().items()}
            bar.update(1)
            bar.set_postfix(loss=f"{train_loss:.3g}", val_dR=f"{val * 1e4:.3g}e-4", best=best_epoch)
    finally:
        bar.close()
    if run_dir is not None:
        if world > 1:
            torch.distributed.barrier()  # rank 0 has written best.pt
        if best_epoch > 0:
            net.load_state_dict(_read_checkpoint(run_dir / "best.pt", map_location=device)["model"])
    elif best_epoch > 0:
        net.load_state_dict(best_state)
    return net.eval(), history


def _diverged(epoch, what, history, start, run_dir, lr):
    good = (
        f"{run_dir / 'latest.pt'} (epoch {history[-1]['epoch'] if history else start})"
        if run_dir is not None and (history or start)
        else "none"
    )
    raise TrainingError(
        f"{what} became NaN or infinite in epoch {epoch}; the last good checkpoint is {good}. Lower "
        f"lr (now {lr}), or check the collection for NaN or extreme operators."
    )


def _check_same_run(saved: dict, wanted: dict, run_dir: Path) -> None:
    """Refuse to resume a run of other data, another network or other hyper-parameters (``epochs`` may grow)."""
    fix = "choose another run_dir, or pass resume=False (CLI: --restart) to replace it."
    old_arch, new_arch = (c.get("model", {}).get("architecture", "operatornet") for c in (saved, wanted))
    if old_arch != new_arch:
        raise CheckpointError(f"{run_dir} holds a {old_arch} run, not a {new_arch} one; {fix}")
    for part in ("data", "model", "train"):
        old, new = dict(saved.get(part, {})), dict(wanted[part])
        if part == "model" and old.get("architecture", "operatornet") == "operatornet":
            old = {**_model_defaults(), **old}  # runs saved before an option existed were trained with its default
        if part == "train":
            old = {"schedule": "constant", **old}  # runs saved before schedules existed
            if new.get("schedule") == "constant":  # a constant learning rate may go on for more epochs
                old.pop("epochs", None), new.pop("epochs", None)
        if old != new:
            diff = ", ".join(
                f"{k}={old.get(k)!r} there but {new.get(k)!r} here"
                for k in sorted(set(old) | set(new))
                if old.get(k) != new.get(k) and k != "fingerprint"
            )
            if part == "data":
                diff = f"{_describe(saved)} there but {_describe(wanted)} here" + (f" ({diff})" if diff else "")
            raise CheckpointError(f"{run_dir} holds a run with other {part} settings: {diff}; {fix}")


def _onecycle(step: int, total: int, lr: float) -> float:
    """The learning rate at ``step`` of ``total`` under ``schedule="onecycle"`` (see :func:`fit`)."""
    warm = 0.05 * total

    def cos(start, end, frac):
        return end + (start - end) * 0.5 * (1 + math.cos(math.pi * frac))

    if step < warm:
        return cos(lr / 25, lr, step / warm)
    return cos(lr, lr / 25 / 1e4, (step - warm) / max(total - warm, 1))


def _model_defaults() -> dict:
    import inspect

    return {
        name: p.default
        for name, p in inspect.signature(OperatorNet).parameters.items()
        if p.default is not inspect.Parameter.empty and name not in ("k", "channels", "depth", "hidden")
    }


def _opnet_version() -> str:
    from . import __version__

    return __version__
