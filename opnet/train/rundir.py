"""Run directories and checkpoints: what :func:`opnet.train.fit` writes, how a run resumes, and loading its network.

A run directory holds five files, each written atomically (temporary file + ``os.replace``):

``config.json``
    what was trained on and how: the collection (name, preset, resolution, seed, generator version and a
    SHA-256 fingerprint of its arrays), the network (its ``config()``), the hyper-parameters, and
    the training-code version (``TRAINING_VERSION``), the opnet / torch versions and the device.
``latest.pt``
    the state after the last checkpointed epoch (one every ``checkpoint_every`` seconds, 30 by default, and the
    last epoch): weights, Adam state, history, best epoch. It is the commit point: a run killed at any moment
    (even by SIGKILL) resumes from it, replaying the epochs after it, and a resumed CPU run ends with the same
    weights and history as an uninterrupted one (each epoch's shuffling is seeded by ``(seed, epoch)``, and
    nothing else is random).
``previous.pt``
    the ``latest.pt`` before it, kept when a new one is written: a ``latest.pt`` that cannot be read (a disk
    fault) costs one checkpoint interval, not the run, since the run resumes from it (with a warning that says so).
``best.pt``
    the weights with the lowest validation ``d_R`` up to ``latest.pt``'s epoch, written with it (model
    selection on ``val`` only; ``test`` and ``test_subjects`` are never read here).
``history.json``
    one record per epoch up to ``latest.pt``'s, written with it: ``epoch``, ``train_loss`` and ``val_d_R``
    (eq. 9, length², e.g. m²), ``seconds``.

Checkpoints hold only tensors, numbers, strings, lists and dicts, and are read with
``torch.load(weights_only=True)``: a checkpoint is data, never code. Only rank 0 of a DDP run writes the run
directory (:class:`RunDir`).
"""

from __future__ import annotations

import contextlib
import hashlib
import inspect
import json
import math
import os
import shutil
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from .._files import atomic_write, remove_stale_tmp, writer_lock
from ..devices import resolve_device
from ..inner_products import channel_digest, get_inner_product, split_channels
from ..model import OperatorNet, build_model
from ..shape_difference import KINDS

__all__ = [
    "RunDir",
    "RunState",
    "CheckpointError",
    "RUN_FILES",
    "FINGERPRINT_VERSION",
    "collection_fingerprint",
    "run_digest",
    "checkpoint_sha256",
    "run_config",
    "read_checkpoint",
    "checkpoint_path",
    "read_history",
    "load_model",
    "model_from_checkpoint",
]

CHECKPOINT_FORMAT = "opnet-checkpoint"
CHECKPOINT_VERSION = 1
# Bump when a change to the training code changes what a run produces: runs of other versions are not resumed.
# 2: subnormal numbers flushed to zero while training; 3: only in the optimiser's step, in one thread
# (opnet.train.loop.optimizer_step)
TRAINING_VERSION = 3
#: The files of a run directory (this module's docstring says what each holds).
RUN_FILES = ("config.json", "latest.pt", "previous.pt", "best.pt", "history.json")

# 2: the fingerprint covers the operators of the run's own channels, and the data config records their identities
# (1: all of the collection's operators, which were opnet.KINDS).
FINGERPRINT_VERSION = 2


class CheckpointError(RuntimeError):
    """A checkpoint or run directory that is unreadable, or that belongs to other data or another network."""


# ----------------------------------------------------------------------------------------------------------
# what a run was trained on


def collection_fingerprint(collection, channels=None) -> str:
    """SHA-256 (hex) of what a model depends on.

    Parameters
    ----------
    collection : opnet.data.Collection
        Its vertices, splits and base eigenbasis are hashed.
    channels : sequence of str, optional
        Whose operators are hashed: default all of them; ``()``: none (a network that reads coordinates).

    Returns
    -------
    str
        The hex digest.
    """
    h = hashlib.sha256()
    ops = (
        ()
        if channels is not None and len(channels) == 0
        else (collection.operators if channels is None else collection.operators_for(channels),)
    )
    for a in (
        collection.vertices,
        *ops,
        collection.split.astype(str),
        collection.base_basis.evecs,
        collection.base_basis.evals,
    ):
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.data)
    return h.hexdigest()


def _data_config(collection, channels, version: int = FINGERPRINT_VERSION) -> dict:
    """What a run was trained on: the collection's identity (with a generated collection's ``bodies`` and ``poses`` when
    they are not the design's), a fingerprint of the arrays the network reads (its ``channels``' operators) and, from
    version 2 on, those channels' names and digests. ``version=1`` gives the
    config of a run made before channels were data (the fingerprint of all the operators, opnet.KINDS).
    """
    meta = collection.meta
    if version == 1:
        if not set(KINDS) <= set(collection.channels):
            raise CheckpointError(
                f"this run was trained before channels were recorded, on a collection of the operators {KINDS}; "
                f"load it with a collection that holds them (collection.with_channels({list(KINDS)}))."
            )
        fingerprint = collection_fingerprint(collection, KINDS)
    else:
        fingerprint = collection_fingerprint(collection, channels)
    out = dict(
        name=meta.get("name"),
        preset=meta.get("preset"),
        resolution=meta.get("resolution"),
        seed=meta.get("seed"),
        generator_version=meta.get("generator_version"),
        fingerprint=fingerprint,
        n_vertices=int(collection.vertices.shape[1]),
        k=int(collection.base_basis.k),
    )
    out.update({key: meta[key] for key in ("bodies", "poses") if key in meta})  # a generated collection's draws
    if version >= 2:
        out.update(
            fingerprint_version=version,
            channels=[{k: c[k] for k in ("name", "digest")} for c in collection.identities(channels)]
            if channels
            else [],
        )
    return out


#: The fields of :class:`~opnet.train.TrainConfig` that do not set a run's weights (where it runs, how often it is
#: checkpointed), left out of :func:`run_digest`.
NOT_WEIGHTS = ("device", "checkpoint_every")


def run_digest(collection, **fit_options) -> str:
    """A digest of everything that sets the weights of ``fit(collection, **fit_options)``: 10 hex digits of SHA-256
    over the training settings (every field of :class:`~opnet.train.TrainConfig` but the device and the checkpoint
    interval, with the channels by name and the schedule and PointNet points resolved), the data the network reads
    (the collection's identity and the fingerprint of its arrays, :func:`collection_fingerprint`), its channels'
    implementation digests and the training code's version (``TRAINING_VERSION``).

    Two calls of :func:`opnet.train.fit` with one digest train the same weights, bit for bit, on one machine (a test
    says so); a changed budget, collection or channel implementation gives another digest. The reproduction names
    each run's folder by it (:meth:`opnet.experiments.RunSpec.run_dir`), so a changed setting never meets an old run.

    Parameters
    ----------
    collection : opnet.data.Collection
        The data trained on.
    **fit_options
        The keyword arguments of :func:`opnet.train.fit` (``channels``, ``epochs``, ``lr``, ``seed``...).

    Returns
    -------
    str
        10 hex digits.
    """
    from .config import TrainConfig

    config = TrainConfig(**fit_options)
    channels = config.channel_names(collection)
    train = {k: v for k, v in config.as_kwargs().items() if k not in NOT_WEIGHTS}
    train.update(
        channels=list(channels),
        schedule=config.lr_schedule,
        n_points=config.points if config.pointnet else None,
        lr=float(config.lr),
        operator_noise=float(config.operator_noise),
        version=TRAINING_VERSION,
    )
    record = dict(train=train, data=comparable(_data_config(collection, channels)))
    return hashlib.sha256(json.dumps(record, sort_keys=True, default=str).encode()).hexdigest()[:10]


def checkpoint_sha256(path) -> str:
    """SHA-256 (hex) of a checkpoint file's bytes: a run directory's ``best.pt`` (``path`` a run directory) or a
    ``.pt`` file. ``best.pt`` holds no timings, so one training on one machine always gives the same bytes: its
    digest names the training (what the reproduction's rows record in their ``provenance``).
    """
    path = checkpoint_path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}: train the run first, or check the path.")
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def comparable(data: dict) -> dict:
    """A run's data config as compared on resume and load: each channel by its name and digest only (what else an
    entry holds, such as where its class lives, is information), without a generated collection's draws (``bodies``,
    ``poses``: information too, for ``opnet evaluate`` to load the collection; the fingerprint tells their data apart,
    and runs saved before they were recorded hold none).
    """
    data = {k: v for k, v in data.items() if k not in ("bodies", "poses")}
    if "channels" not in data:
        return data
    return dict(data, channels=[{"name": c["name"], "digest": c["digest"]} for c in data["channels"]])


def run_config(collection, channels, net, config, device, world: int) -> dict:
    """The ``config.json`` of a run (also stored in each of its checkpoints).

    Parameters
    ----------
    collection : opnet.data.Collection
        Trained on.
    channels : tuple of str
        The channels the network reads (``()`` for the PointNet autoencoder).
    net : torch.nn.Module
        The network (its ``config()``).
    config : opnet.train.TrainConfig
        The hyper-parameters.
    device : torch.device
        Where it trains.
    world : int
        The number of DDP processes.

    Returns
    -------
    dict
        ``data``, ``model``, ``train``, ``versions``, ``device``, ``world_size`` and ``channel_specs`` (where each
        channel's class can be imported again, ``module:Class`` or ``None``: information, not compared on resume).
    """
    specs = {c["name"]: c["spec"] for c in collection.identities(channels)} if channels else {}
    return dict(
        channel_specs=specs,
        data=_data_config(collection, channels),
        model=net.config(),
        train=dict(
            epochs=config.epochs,
            batch_size=config.batch_size,
            lr=config.lr,
            seed=config.seed,
            schedule=config.lr_schedule,
            version=TRAINING_VERSION,
            **({"operator_noise": config.operator_noise} if config.operator_noise else {}),  # older runs match
        ),
        versions=dict(opnet=_opnet_version(), torch=str(torch.__version__)),
        device=str(device),
        world_size=world,
    )


def _run_channels(config: dict) -> tuple:
    """The channels a run's network reads (``()`` for one that reads coordinates)."""
    return tuple(config["model"].get("channels", ()))


def _describe(config: dict) -> str:
    d, m = config["data"], config["model"]
    draws = "".join(f" {k}={d[k]}" for k in ("bodies", "poses") if k in d)
    data = f"{d['name']}/{d['preset']}/{d['resolution']} seed {d['seed']}{draws} (data {d['fingerprint'][:12]})"
    if m.get("architecture", "operatornet") != "operatornet":
        return f"{data}, {m['architecture']}"
    return f"{data}, channels {','.join(m['channels'])}, depth {m['depth']}"


def _model_defaults() -> dict:
    return {
        name: p.default
        for name, p in inspect.signature(OperatorNet).parameters.items()
        if p.default is not inspect.Parameter.empty and name not in ("k", "channels", "depth", "hidden")
    }


def _opnet_version() -> str:
    from .. import __version__

    return __version__


# ----------------------------------------------------------------------------------------------------------
# files


def _save_torch(obj, path: Path) -> None:
    atomic_write(path, lambda f: torch.save(obj, f))


def _save_json(obj, path: Path) -> None:
    atomic_write(path, lambda f: f.write(json.dumps(obj, indent=1).encode()))


def _keep_previous(latest: Path, previous: Path) -> None:
    """Keep ``latest`` (if any) as ``previous`` before a new one replaces it: a hard link, renamed into place (a
    copy where the file system has no links), so that ``previous`` is always a whole file.
    """
    if not latest.exists():
        return
    tmp = previous.with_name(f".{previous.name}.tmp-{os.getpid()}")
    tmp.unlink(missing_ok=True)
    try:
        os.link(latest, tmp)
    except OSError:
        shutil.copyfile(latest, tmp)
    os.replace(tmp, previous)


def _read_latest(run_dir: Path, device) -> dict:
    """The checkpoint a run resumes from: ``latest.pt``, or, when it cannot be read, ``previous.pt`` (the one
    before it) with a warning naming both; :class:`CheckpointError` when neither can be read.
    """
    latest, previous = run_dir / "latest.pt", run_dir / "previous.pt"
    try:
        return read_checkpoint(latest, map_location=device)
    except CheckpointError as exc:
        if not previous.is_file():
            raise
        try:
            ckpt = read_checkpoint(previous, map_location=device)
        except CheckpointError:
            raise exc from None
        warnings.warn(
            f"{latest} cannot be read ({exc}); the run resumes from previous.pt, the checkpoint before it (epoch "
            f"{ckpt['epoch']}), and trains the epochs after it again.",
            stacklevel=4,
        )
        return ckpt


def read_checkpoint(path, map_location="cpu") -> dict:
    """The checkpoint at ``path`` (a ``.pt`` file written by :func:`opnet.train.fit`), checked.

    Parameters
    ----------
    path : path
        The file.
    map_location : str or torch.device
        Where its tensors go (:func:`torch.load`).

    Returns
    -------
    dict
        ``format``, ``version``, ``config``, ``epoch``, ``model`` (a state dict), and for ``latest.pt`` the
        optimiser state, ``history``, ``best_val`` and ``best_epoch``.

    Raises
    ------
    CheckpointError
        No file, an unreadable one, not an opnet checkpoint, incomplete, or of another checkpoint version.
    """
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


def checkpoint_path(path) -> Path:
    """The checkpoint a path names: a run directory's ``best.pt``, or ``path`` itself (a ``.pt`` file)."""
    path = Path(path)
    return path / "best.pt" if path.is_dir() else path


def read_history(run_dir) -> list[dict]:
    """The per-epoch history of a run (from its ``latest.pt``, the authoritative copy)."""
    return read_checkpoint(Path(run_dir) / "latest.pt")["history"]


# ----------------------------------------------------------------------------------------------------------
# loading a trained network


def load_model(path, collection=None, *, channels=None, device="cpu"):
    """The trained network stored at ``path``: a run directory (its ``best.pt``) or a ``.pt`` checkpoint.

    Parameters
    ----------
    path : path
        A run directory or a checkpoint file.
    collection : opnet.data.Collection, optional
        With it, a checkpoint trained on other data (another fingerprint) is refused.
    channels : channels, optional
        With them, a checkpoint trained on other input channels (or another implementation of one) is refused.
    device : str or torch.device
        Where the network goes.

    Returns
    -------
    torch.nn.Module
        An :class:`opnet.OperatorNet`, or an :class:`opnet.model.PointNetAutoencoder` for a run of
        ``architecture="pointnet"``, in eval mode on ``device``.

    Raises
    ------
    CheckpointError
        An unreadable checkpoint, or one of other data or channels (the message names both sides).
    """
    path = checkpoint_path(path)
    return model_from_checkpoint(
        read_checkpoint(path, map_location=resolve_device(device)), path, collection, channels=channels, device=device
    )


def _check_channels(config: dict, channels, path) -> None:
    """Refuse ``channels`` (names or inner products) other than a run's, or an inner product whose implementation
    differs from the one the run was trained with.
    """
    items = [c if isinstance(c, str) and ":" not in c else get_inner_product(c) for c in split_channels(channels)]
    names = tuple(c if isinstance(c, str) else c.name for c in items)
    saved = _run_channels(config)
    if names != saved:
        raise CheckpointError(
            f"{path} was trained on channels {','.join(saved)}, not {','.join(names)}; load the run trained on those "
            "channels."
        )
    recorded = {c["name"]: c["digest"] for c in config["data"].get("channels", [])}
    for item in items:
        if isinstance(item, str):
            continue
        ip = get_inner_product(item)
        if recorded.get(ip.name) not in (None, channel_digest(ip)):
            raise CheckpointError(
                f"{path} was trained on channel {ip.name!r} as computed by another implementation (digest "
                f"{recorded[ip.name]}; this {type(ip).__name__} has {channel_digest(ip)}): its code or parameters "
                "changed since. Train again on the new channel (another run_dir, or resume=False), or restore the "
                "class."
            )


def _channel_mismatch(saved: dict, here: dict) -> str:
    """A sentence naming the channels whose implementation differs between a run and a collection ('' if none)."""
    theirs = {c["name"]: c["digest"] for c in saved.get("channels", [])}
    ours = {c["name"]: c["digest"] for c in here.get("channels", [])}
    changed = [n for n in theirs if None not in (theirs[n], ours.get(n)) and theirs[n] != ours[n]]
    if not changed:
        return ""
    return (
        f" Its channels {changed} were computed by another implementation (digests "
        f"{[theirs[n] for n in changed]} there, {[ours[n] for n in changed]} here): compute them with the class the "
        "run was trained with, or train again."
    )


def model_from_checkpoint(ckpt: dict, path, collection=None, *, channels=None, device="cpu"):
    """:func:`load_model` on a checkpoint already read (:func:`read_checkpoint`); ``path`` names it in errors.

    Parameters
    ----------
    ckpt : dict
        The checkpoint.
    path : path
        Its file, for messages.
    collection, channels, device
        As in :func:`load_model`.

    Returns
    -------
    torch.nn.Module
        The network, in eval mode on ``device``.
    """
    config = ckpt["config"]
    if channels is not None and "channels" not in config["model"]:
        raise CheckpointError(
            f"{path} holds a {config['model'].get('architecture')} network, which reads no "
            "operators: load it without channels=."
        )
    if channels is not None:
        _check_channels(config, channels, path)
    if collection is not None:
        data = _data_config(collection, _run_channels(config), config["data"].get("fingerprint_version", 1))
        if comparable(data) != comparable(config["data"]):
            got = dict(config, data=data)
            raise CheckpointError(
                f"{path} was trained on {_describe(config)}, but this collection is "
                f"{_describe(got)}; use a model trained on this collection." + _channel_mismatch(config["data"], data)
            )
    net = build_model(config["model"])
    net.load_state_dict(ckpt["model"])
    net.channel_digests = {c["name"]: c["digest"] for c in config["data"].get("channels", [])}
    return net.to(resolve_device(device)).eval()


# ----------------------------------------------------------------------------------------------------------
# a run: opened (resumed or replaced), checkpointed every `checkpoint_every` seconds and at its end


def _check_same_run(saved: dict, wanted: dict, run_dir: Path) -> None:
    """Refuse to resume a run of other data, another network or other hyper-parameters (``epochs`` may grow)."""
    fix = "choose another run_dir, or pass resume=False (CLI: --restart) to replace it."
    old_arch, new_arch = (c.get("model", {}).get("architecture", "operatornet") for c in (saved, wanted))
    if old_arch != new_arch:
        raise CheckpointError(f"{run_dir} holds a {old_arch} run, not a {new_arch} one; {fix}")
    for part in ("model", "data", "train"):  # model first: a change of channels also changes the data read
        old, new = dict(saved.get(part, {})), dict(wanted[part])
        if part == "data":
            old, new = comparable(old), comparable(new)
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
                diff += _channel_mismatch(saved["data"], wanted["data"])
            raise CheckpointError(f"{run_dir} holds a run with other {part} settings: {diff}; {fix}")


@dataclass
class RunState:
    """Where a run stands: what :func:`opnet.train.fit` keeps across epochs, and ``latest.pt`` across processes.

    Attributes
    ----------
    history : list of dict
        One record per finished epoch.
    best_val : float
        The lowest validation ``d_R`` so far.
    best_epoch : int
        Its epoch (0: none yet).
    start : int
        The epochs done when this call began (those of the run resumed).
    best_weights : dict, optional
        A copy of the best epoch's state dict, kept in memory (written to ``best.pt`` with the next checkpoint).
    """

    history: list = field(default_factory=list)
    best_val: float = math.inf
    best_epoch: int = 0
    start: int = 0
    best_weights: dict | None = None


class RunDir:
    """The run directory of a call of :func:`opnet.train.fit`: opened once (resumed or replaced), then
    checkpointed (:meth:`save_epoch`) by rank 0 only.

    Parameters
    ----------
    path : path
        The directory (created when missing; a file there is refused).
    rank, world : int
        This process's DDP rank and the number of processes.
    """

    def __init__(self, path, rank: int = 0, world: int = 1):
        path = Path(path)
        if path.exists() and not path.is_dir():
            raise ValueError(f"run_dir {path} is a file; give a directory path.")
        self.path, self.rank, self.world = path, rank, world
        self.config: dict | None = None
        self.best_written = 0  # the epoch of the best.pt this process wrote or found (0: none)
        self.latest_epoch = 0  # the epoch of the latest.pt this process wrote or resumed (0: none)

    def writer(self):
        """A context in which this process is the run directory's one writer (a lock that the OS releases when the
        process ends; rank 0 only, the one that writes): another training into it gets :class:`opnet.FolderInUseError`.
        """
        if self.rank != 0:
            return contextlib.nullcontext()
        return writer_lock(self.path, "training (opnet.train.fit)")

    def open(self, config: dict, collection, channels, *, resume: bool, net, optimizer, device) -> RunState:
        """Resume the run found here into ``net`` and ``optimizer``, or start it afresh.

        Parameters
        ----------
        config : dict
            The wanted run's :func:`run_config`; its ``data`` is put in the format of a run found here that was
            begun with an older fingerprint version (the config then written to the checkpoints).
        collection : opnet.data.Collection
            Trained on.
        channels : tuple of str
            The channels the network reads.
        resume : bool
            ``True``: continue the run in ``latest.pt`` (same data, network and hyper-parameters, and no more
            epochs than ``config``'s); ``False``: delete the run's files and write a new ``config.json``.
        net : torch.nn.Module
            Receives the run's weights when resumed.
        optimizer : torch.optim.Optimizer
            Receives the run's optimiser state when resumed.
        device : torch.device
            Where the checkpoint's tensors go.

        Returns
        -------
        RunState
            The resumed run's history and best epoch, or a fresh state.

        Raises
        ------
        CheckpointError
            ``latest.pt`` is unreadable, or holds a run of other settings or of more epochs.
        """
        run_dir, state = self.path, RunState()
        if self.rank == 0 and run_dir.is_dir():
            remove_stale_tmp(run_dir.glob(".*.tmp-*"))  # left by a killed run
        latest = run_dir / "latest.pt"
        if latest.exists() and resume:
            ckpt = _read_latest(run_dir, device)
            version = ckpt["config"].get("data", {}).get("fingerprint_version", 1)
            if version != FINGERPRINT_VERSION:  # a run begun before channels were data goes on in its own format
                config["data"] = _data_config(collection, channels, version)
            _check_same_run(ckpt["config"], config, run_dir)
            epochs = config["train"]["epochs"]
            if ckpt["epoch"] > epochs:
                raise CheckpointError(
                    f"{run_dir} has already trained {ckpt['epoch']} epochs, more than epochs={epochs}; "
                    f"ask for epochs >= {ckpt['epoch']} to load it, or resume=False (--restart) to "
                    "train it again."
                )
            net.load_state_dict(ckpt["model"])
            fused = [
                group.get("fused") for group in optimizer.param_groups
            ]  # this torch's choice (opnet.train.loop.adam)
            optimizer.load_state_dict(ckpt["optimizer"])
            for group, choice in zip(optimizer.param_groups, fused, strict=True):  # not the checkpoint's machine's
                group["fused"] = choice
            state = RunState(ckpt["history"], ckpt["best_val"], ckpt["best_epoch"], ckpt["epoch"])
            self.best_written = state.best_epoch  # written with (before) that latest.pt
            self.latest_epoch = state.start
        elif self.rank == 0:
            for name in RUN_FILES:
                (run_dir / name).unlink(missing_ok=True)
            run_dir.mkdir(parents=True, exist_ok=True)
            _save_json(config, run_dir / "config.json")
        if self.world > 1:
            torch.distributed.barrier()
        self.config = config
        return state

    def save_epoch(self, epoch: int, state: RunState, net, optimizer) -> None:
        """Write a checkpoint of the epoch just finished (rank 0 only): ``best.pt`` (from ``state.best_weights``)
        if the best epoch changed since the last one, ``history.json``, then ``latest.pt``, the commit point.

        Parameters
        ----------
        epoch : int
            The epoch (from 1).
        state : RunState
            The run after this epoch, with the best epoch's weights.
        net : torch.nn.Module
            The network (not its DDP wrapper).
        optimizer : torch.optim.Optimizer
            Its optimiser.
        """
        self.latest_epoch = epoch  # on every rank: what a divergence message names
        if self.rank != 0:
            return
        run_dir = self.path
        header = dict(format=CHECKPOINT_FORMAT, version=CHECKPOINT_VERSION, config=self.config)
        if state.best_epoch != self.best_written and state.best_weights is not None:
            best = dict(header, epoch=state.best_epoch, model=state.best_weights, val_d_R=state.best_val)
            _save_torch(best, run_dir / "best.pt")
            self.best_written = state.best_epoch
        _save_json(state.history, run_dir / "history.json")
        _keep_previous(run_dir / "latest.pt", run_dir / "previous.pt")
        _save_torch(
            dict(
                header,
                epoch=epoch,
                model=net.state_dict(),
                optimizer=optimizer.state_dict(),
                history=state.history,
                best_val=state.best_val,
                best_epoch=state.best_epoch,
            ),
            run_dir / "latest.pt",
        )

    def load_best(self, net, state: RunState, device) -> None:
        """Put the best epoch's weights (``best.pt``, once rank 0 has written it) into ``net``, if there is one."""
        if self.world > 1:
            torch.distributed.barrier()  # rank 0 has written best.pt
        if state.best_epoch > 0:
            net.load_state_dict(read_checkpoint(self.path / "best.pt", map_location=device)["model"])
