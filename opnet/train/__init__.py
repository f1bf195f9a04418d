"""Training OperatorNet (section 5) and the PointNet autoencoder: :func:`~opnet.train.fit`, run directories,
atomic checkpoints, exact resume, DDP.

:func:`fit` reads its hyper-parameters into a :class:`TrainConfig` (``opnet.train.config``, which also generates
the options of ``python -m opnet train``), takes the train and val tensors of the collection and builds the network
(``opnet.train.network``), opens the run directory, resuming the run found there (``opnet.train.rundir``), and
runs the epochs (``opnet.train.loop``).

A run directory holds ``config.json`` (what was trained on and how), ``latest.pt`` (the state after the last
finished epoch: the commit point a killed run resumes from, to the same weights and history as an uninterrupted
run), ``best.pt`` (the weights with the lowest validation ``d_R``) and ``history.json`` (one record per epoch); each
is written atomically, and checkpoints are read with ``torch.load(weights_only=True)``. The docstring of
``opnet.train.rundir`` describes each file.

Under ``torchrun --nproc_per_node N`` the model is wrapped in DistributedDataParallel and every global batch is split
across the N processes; the result equals a single-process run with the same ``batch_size`` up to floating-point
summation order, and only rank 0 writes the run directory (``opnet.train.loop``).
"""

from __future__ import annotations

import contextlib
import dataclasses

import torch
from tqdm.auto import tqdm

from ..devices import resolve_device
from ..model import rigid_alignment_loss
from ..shape_difference import CHANNEL_SETS
from .config import SCHEDULES, TrainConfig, parse_channels
from .curves import Convergence, convergence
from .loop import TrainingError, adam, placement, run_epochs
from .network import build_network, training_data
from .rundir import (
    RUN_FILES,
    CheckpointError,
    RunDir,
    RunState,
    checkpoint_path,
    checkpoint_sha256,
    collection_fingerprint,
    load_model,
    model_from_checkpoint,
    read_checkpoint,
    read_history,
    run_config,
    run_digest,
)

__all__ = [
    "fit",
    "convergence",
    "Convergence",
    "load_model",
    "read_history",
    "collection_fingerprint",
    "run_digest",
    "checkpoint_sha256",
    "parse_channels",
    "resolve_device",
    "TrainingError",
    "CheckpointError",
    "CHANNEL_SETS",
    "RUN_FILES",
    "SCHEDULES",
    "TrainConfig",
    "read_checkpoint",
    "checkpoint_path",
    "model_from_checkpoint",
]


def fit(
    collection,
    *,
    channels=None,
    depth: int = 1,
    epochs: int = 50,
    batch_size: int = 32,
    lr: float = 1e-3,
    operator_noise: float = 0.0,
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
    checkpoint_every: float = 30.0,
) -> tuple[torch.nn.Module, list[dict]]:
    """Train OperatorNet (or the PointNet autoencoder) on the ``train`` split of ``collection``; returns the best
    network on ``val`` and the history.

    Parameters
    ----------
    collection : opnet.data.Collection
        Shapes with their operators (``"train"`` and ``"val"`` splits are used; the test splits never).
    channels : channels or str, optional
        Input operators: any of the collection's channels (:attr:`~opnet.data.storage.Collection.channels`), as
        names, inner products (your own: add it first with :meth:`~opnet.data.storage.Collection.with_channels`),
        ``"area,extrinsic"`` or a short name of :data:`opnet.CHANNEL_SETS` (``"A+E+C"``, ``"Ext"``, ...). Default:
        all of the collection's. The run records each channel's name and implementation digest; resuming it with
        another implementation is refused.
    depth : encoder depth, 1 to 4 (the paper's ablation; 1 is its model).
    epochs : passes over the training split. Resuming with more epochs continues the run.
    batch_size : shapes per optimiser step (the global batch under ``torchrun``).
    lr : Adam's learning rate (the peak one under ``schedule="onecycle"``).
    operator_noise : Gaussian noise added to every training input at every step, per entry ``operator_noise`` times
        that entry's standard deviation over the training operators (OperatorNet only; ``0``, the default: none).
        Meant as a model of a computed map's error, which is of the order of that deviation; the docs' results page
        ("Generalisation") measures how little white noise models it. Each epoch's noise is a function of ``seed``
        and the epoch, so a resumed run is exact.
    seed : initialisation and shuffling (epoch ``e`` is shuffled by ``numpy.random.default_rng([seed, e])``).
    device : ``"auto"`` (CUDA when available), ``"cpu"``, ``"cuda"``...
    run_dir : path, optional
        Where the config, checkpoints and history go (see ``opnet.train.rundir``). ``None``: nothing is written.
    resume : bool
        ``True``: continue the run found in ``run_dir`` (it must have the same data, network and
        hyper-parameters, else :class:`CheckpointError`); a finished run is just loaded. ``False``: replace it.
    progress : bool, optional
        A progress bar over epochs with the train loss, the val ``d_R`` (×10⁻⁴) and the time left (default: on).
    hidden, subtract_identity : see :class:`opnet.OperatorNet`. The network sees ``D − I`` by default.
    variant : ``"paper"`` (the paper's architecture) or ``"ours"`` (:data:`opnet.model.VARIANTS`: standardised
        inputs, a displacement from the base, and ``schedule="onecycle"``); the variant section of ``docs/results.md``.
    schedule : the learning rate over the run: ``"constant"`` (as the paper's code trains; default for ``"paper"``) or
        ``"onecycle"`` (default for ``"ours"``): a cosine warm-up from ``lr/25`` to ``lr`` over the first 5 % of
        the steps, then a cosine decay towards ``lr/2.5e5`` at the end of the run (as
        ``torch.optim.lr_scheduler.OneCycleLR``).
        It is a function of the step and the planned number of epochs, so a ``"onecycle"`` run resumes only with
        the same ``epochs``.
    standardize, residual : override the variant's network options one by one (see :class:`opnet.OperatorNet`),
        e.g. to measure each part of ``"ours"`` alone.
    architecture : ``"operatornet"`` (default), ``"pointnet"``: the PointNet autoencoder
        (:class:`opnet.model.PointNetAutoencoder`), which reads the shapes' coordinates instead of their operators
        and is trained with the same loss, checkpoints and resume (``channels``, ``depth`` and the variant's
        options do not apply to it; ``hidden`` and ``schedule`` do); ``"pointnet_stn"``: the same with PointNet's
        input transform (:class:`opnet.model.PointNetTransformerAutoencoder`); ``"pointnet2"``: a PointNet++
        encoder (:class:`opnet.model.PointNet2Autoencoder`).
    n_points : how many vertices the PointNet encoder reads (spread over the base shape by
        :meth:`~opnet.model.PointNetAutoencoder.choose_points`); default 256 for the point-set autoencoders.
    checkpoint_every : seconds between the checkpoints written to ``run_dir`` (``latest.pt`` with ``best.pt``
        and ``history.json``); the last epoch is always written, and ``0`` writes every epoch. A run killed in
        between resumes from its last checkpoint and replays the epochs after it to the same result (each epoch's
        shuffle is a function of ``seed`` and the epoch), so at most this much work is repeated; it is not part
        of the run's settings.

    Returns
    -------
    net : OperatorNet (or PointNetAutoencoder), the weights of the epoch with the lowest val ``d_R``, in eval mode
        on ``device``.
    history : list of dict, one per epoch: ``epoch``, ``train_loss``, ``val_d_R`` (length²), ``seconds``.

    Raises
    ------
    TrainingError : the loss became NaN or infinite (the message names the epoch and the last good checkpoint).
    CheckpointError : ``run_dir`` holds a run of other data or settings, or an unreadable checkpoint.
    opnet.FolderInUseError : another process is training into ``run_dir`` (its PID named).
    ValueError : a bad hyper-parameter (:class:`TrainConfig`'s checks), or a collection without ``train`` or
        ``val`` shapes or with NaN there.
    """
    arguments = locals()  # fit's options are TrainConfig's fields, by name
    config = TrainConfig(**{f.name: arguments[f.name] for f in dataclasses.fields(TrainConfig)})
    channels = config.channel_names(collection)
    place = placement(config.device)  # the device, DDP rank and number of processes
    data = training_data(collection, channels, config.pointnet, place.device)
    net = build_network(collection, config, channels, data.train_in).to(place.device)
    optimizer = adam(net.parameters(), config.lr)
    record = run_config(collection, channels, net, config, place.device, place.world)

    run = RunDir(run_dir, place.rank, place.world) if run_dir is not None else None
    with run.writer() if run is not None else contextlib.nullcontext():  # one writer per run directory
        state = (
            RunState()
            if run is None
            else run.open(
                record, collection, channels, resume=resume, net=net, optimizer=optimizer, device=place.device
            )
        )
        bar = tqdm(
            total=config.epochs,
            initial=min(state.start, config.epochs),
            desc="train pointnet" if config.pointnet else f"train {'+'.join(c[:4] for c in channels)} d{config.depth}",
            unit="epoch",
            disable=(progress is False) or place.rank != 0,
        )
        try:
            run_epochs(net, optimizer, data, state, config, place, run=run, bar=bar, loss=rigid_alignment_loss)
        finally:
            bar.close()
        if run is not None:
            run.load_best(net, state, place.device)
        elif state.best_epoch > 0:
            net.load_state_dict(state.best_weights)
    return net.eval(), state.history
