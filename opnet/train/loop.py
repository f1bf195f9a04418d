"""The epoch loop of :func:`opnet.train.fit`: shuffled batches, Adam steps on eq. 9, validation, DDP, NaN stop.

Under ``torchrun --nproc_per_node N`` (the process group initialised by ``python -m opnet train``), the
model is wrapped in :class:`~torch.nn.parallel.DistributedDataParallel`: every global batch of
``batch_size`` shapes is split across the N processes (``_shard``), and the loss is weighted so that the
gradient is that of the whole global batch; the result equals a single-process run with the same ``batch_size`` up
to floating-point summation order. Only rank 0 writes the run directory.
"""

from __future__ import annotations

import math
import os
import time
from typing import NamedTuple

import numpy as np
import torch

from ..devices import resolve_device
from ..model import rigid_alignment_loss
from .rundir import RunState

__all__ = ["TrainingError", "Placement", "placement", "run_epochs", "optimizer_step"]


class TrainingError(RuntimeError):
    """Training cannot go on (for example the loss became NaN); the message names the last good checkpoint."""


def _distributed() -> tuple[int, int]:
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return 0, 1


class Placement(NamedTuple):
    """Where a process trains: its device, its DDP rank and the number of processes (0 and 1 without DDP)."""

    device: torch.device
    rank: int
    world: int


def placement(device) -> Placement:
    """Where this process trains.

    Parameters
    ----------
    device : str or torch.device
        As :func:`~opnet.train.resolve_device` reads it; under DDP on CUDA, this process's GPU is ``LOCAL_RANK``'s.

    Returns
    -------
    Placement
        The device, this process's rank and the number of processes of the initialised process group.
    """
    device = resolve_device(device)
    rank, world = _distributed()
    if device.type == "cuda" and world > 1:
        device = torch.device("cuda", int(os.environ.get("LOCAL_RANK", 0)))
    return Placement(device, rank, world)


def _shard(batch: np.ndarray, rank: int, world: int) -> tuple[np.ndarray, np.ndarray]:
    """Where the shapes of a global batch that this rank computes stand in ``batch``, and their weights.

    A rank left without a shape gets the first one with weight 0, so that every process runs forward and backward as
    DDP requires.
    """
    positions = np.array_split(np.arange(len(batch)), world)[rank]
    if len(positions) == 0:
        return np.zeros(1, dtype=np.int64), np.zeros(1)
    return positions, np.ones(len(positions))


@torch.no_grad()
def _val_d_R(net, inputs, vertices, batch_size=256, loss=rigid_alignment_loss) -> float:
    net.eval()
    total = 0.0
    for s in range(0, len(inputs), batch_size):
        pred = net(inputs[s : s + batch_size]).double()
        total += loss(pred, vertices[s : s + batch_size].double(), reduction="none").sum().item()
    net.train()
    return total / len(inputs)


def _onecycle(step: int, total: int, lr: float) -> float:
    """The learning rate at ``step`` of ``total`` under ``schedule="onecycle"`` (see :func:`opnet.train.fit`)."""
    warm = 0.05 * total

    def cos(start, end, frac):
        return end + (start - end) * 0.5 * (1 + math.cos(math.pi * frac))

    if step < warm:
        return cos(lr / 25, lr, step / warm)
    return cos(lr, lr / 25 / 1e4, (step - warm) / max(total - warm, 1))


def _diverged(epoch, what, run, lr):
    written = run is not None and run.latest_epoch > 0
    good = f"{run.path / 'latest.pt'} (epoch {run.latest_epoch})" if written else "none"
    raise TrainingError(
        f"{what} became NaN or infinite in epoch {epoch}; the last good checkpoint is {good}. Lower "
        f"lr (now {lr}), or check the collection for NaN or extreme operators."
    )


def adam(parameters, lr: float) -> torch.optim.Adam:
    """Adam with torch's fused kernel where this torch has one for the parameters' device (the CPU since torch
    2.4, CUDA): the same update as the default implementation, up to rounding, and faster; torch's default
    implementation elsewhere.
    """
    parameters = list(parameters)
    try:
        return torch.optim.Adam(parameters, lr=lr, fused=True)
    except (RuntimeError, TypeError, ValueError):  # no fused kernel for this device or torch version
        return torch.optim.Adam(parameters, lr=lr)


def optimizer_step(optimizer, device) -> None:
    """``optimizer.step()``; on the CPU in this thread alone, with subnormal numbers (below 1.2e-38 in float32)
    flushed to zero as its inputs and results, then the thread count and the flag as they were.

    Adam's second moments of the weights whose gradients all but vanish fall below that: a fifth of a ``default``
    run's optimiser state after 60 epochs, where x86 takes a slow path that made each optimiser step of that run 3
    to 6 times as long (one thread: 105-181 ms against 16-32 ms, beside 40-90 ms for the forward and backward
    passes). The flag belongs to a thread, and a worker thread of torch takes it from the thread that starts it, for
    good: so it is set only while no worker runs (one thread), and the forward and backward passes, whatever threads
    run them and whenever they were started, never flush. The update is elementwise: its result is that of any
    number of threads.
    """
    if device.type != "cpu":
        optimizer.step()
        return
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    flushed = not _flushing() and torch.set_flush_denormal(True)
    try:
        optimizer.step()
    finally:
        if flushed:
            torch.set_flush_denormal(False)
        torch.set_num_threads(threads)


def _flushing() -> bool:
    """Whether this thread flushes subnormal numbers to zero already (the caller's own setting, left as it is)."""
    return torch.tensor([1e-39], dtype=torch.float32).mul(1.0).item() == 0.0


def run_epochs(
    net, optimizer, data, state: RunState, config, place: Placement, *, run=None, bar, loss=rigid_alignment_loss
) -> None:
    """Train ``net`` from epoch ``state.start + 1`` to ``config.epochs``, updating ``state`` after each epoch.

    Epoch ``e`` visits the training shapes in the order ``numpy.random.default_rng([seed, e]).permutation(n)``,
    in global batches of ``config.batch_size``; a non-finite output, loss or validation ``d_R`` stops the run
    before the step (:class:`TrainingError`).

    Parameters
    ----------
    net : torch.nn.Module
        The network, on ``place.device`` (wrapped in DDP here when ``place.world > 1``).
    optimizer : torch.optim.Adam
        Its optimiser (its learning rate set at each step under ``schedule="onecycle"``).
    data : opnet.train.network.TrainData
        The network inputs and target vertices of the train and val splits, on ``place.device``.
    state : RunState
        The run so far (resumed or fresh); its history, best epoch and, without ``run``, best weights are updated.
    config : opnet.train.TrainConfig
        ``epochs``, ``batch_size``, ``lr``, ``seed``, the schedule and ``checkpoint_every``.
    place : Placement
        The device the network and ``data`` are on, this process's DDP rank and the number of processes.
    run : opnet.train.rundir.RunDir, optional
        Written (by rank 0) after the first epoch that ends ``config.checkpoint_every`` seconds or more after the
        last write, and after the last epoch; ``None``: nothing is written. The best weights are kept in
        ``state.best_weights`` in any case.
    bar : tqdm.tqdm
        The progress bar over epochs (updated here, closed by the caller).
    loss : callable
        ``loss(pred, target, reduction="none")``, per shape (eq. 9, :func:`opnet.model.rigid_alignment_loss`).

    Raises
    ------
    TrainingError
        The network's output, the loss or the validation ``d_R`` became NaN or infinite.
    """
    epochs, batch_size, seed = config.epochs, config.batch_size, config.seed
    lr, schedule = config.lr, config.lr_schedule
    device, rank, world = place
    history, start = state.history, state.start
    model = net
    if world > 1:
        model = torch.nn.parallel.DistributedDataParallel(
            net, device_ids=[device.index] if device.type == "cuda" else None
        )
    net.train()
    n = len(data.train_in)
    noise = config.operator_noise * data.input_std() if config.operator_noise else None
    steps_per_epoch = -(-n // batch_size)
    step, total_steps = start * steps_per_epoch, epochs * steps_per_epoch
    saved = time.perf_counter()  # when the run directory was last written (opened, for the first checkpoint)
    for epoch in range(start + 1, epochs + 1):
        t0 = time.perf_counter()
        order = np.random.default_rng([seed, epoch]).permutation(n)
        if noise is not None:  # this epoch's noise: a function of the seed and the epoch (exact resume, any rank)
            draw = torch.Generator(device=device).manual_seed(
                int(np.random.default_rng([seed, epoch, 1]).integers(2**62))
            )
        loss_sum = torch.zeros((), dtype=torch.float64, device=device)
        for s in range(0, n, batch_size):
            batch = order[s : s + batch_size]
            positions, weight = _shard(batch, rank, world)
            part = batch[positions]
            inputs = data.train_in[part]
            if noise is not None:  # drawn for the global batch, so that the ranks split the same noise
                drawn = torch.randn((len(batch), *noise.shape), generator=draw, device=device, dtype=noise.dtype)
                inputs = inputs + drawn[positions] * noise
            pred = model(inputs)
            finite = torch.isfinite(pred).all()
            # a non-finite output is replaced by zeros for Kabsch; the step is refused below in any case
            per_shape = loss(torch.where(finite, pred, torch.zeros_like(pred)), data.train_X[part], reduction="none")
            weight = torch.as_tensor(weight, dtype=per_shape.dtype, device=device)
            # DDP averages gradients over the `world` ranks: scale so that the sum is the global batch mean
            batch_loss = (per_shape * weight).sum() * (world / len(batch))
            ok = (finite & torch.isfinite(batch_loss)).to(torch.int32)
            if world > 1:  # every rank stops together
                torch.distributed.all_reduce(ok, op=torch.distributed.ReduceOp.MIN)
            if not ok.item():  # before the step (earlier steps of this epoch are lost; the checkpoint is not)
                _diverged(epoch, "the network's output or training loss", run, lr)
            if schedule == "onecycle":
                for group in optimizer.param_groups:
                    group["lr"] = _onecycle(step, total_steps, lr)
            step += 1
            optimizer.zero_grad(set_to_none=True)
            batch_loss.backward()
            optimizer_step(optimizer, device)
            loss_sum += (per_shape.detach() * weight).sum().double()
        if world > 1:
            torch.distributed.all_reduce(loss_sum)
        train_loss = loss_sum.item() / n
        val = _val_d_R(net, data.val_in, data.val_X, loss=loss)
        if not (math.isfinite(val) and math.isfinite(train_loss)):  # e.g. the last step made the weights NaN
            _diverged(epoch, f"the validation d_R ({val})", run, lr)
        history.append(dict(epoch=epoch, train_loss=train_loss, val_d_R=val, seconds=time.perf_counter() - t0))
        if val < state.best_val:
            state.best_val, state.best_epoch = val, epoch
            state.best_weights = {k: v.detach().clone() for k, v in net.state_dict().items()}
        if run is not None and (epoch == epochs or time.perf_counter() - saved >= config.checkpoint_every):
            run.save_epoch(epoch, state, net, optimizer)
            saved = time.perf_counter()
        bar.update(1)
        bar.set_postfix(loss=f"{train_loss:.3g}", val_dR=f"{val * 1e4:.3g}e-4", best=state.best_epoch)
