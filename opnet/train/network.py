"""What :func:`opnet.train.fit` trains: the tensors of a collection's train and val splits, and the network built
for them (seeded, with its input statistics and base shape set).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..model import VARIANTS, OperatorNet, build_model

__all__ = ["TrainData", "training_data", "build_network"]


@dataclass
class TrainData:
    """The network inputs (operators, or vertices for the PointNet autoencoder) and the target vertices of the train
    and val splits, float32 on the training device.
    """

    train_in: torch.Tensor
    train_X: torch.Tensor
    val_in: torch.Tensor
    val_X: torch.Tensor

    def input_std(self) -> torch.Tensor:
        """The per-entry standard deviation of the training inputs ``(C, k, k)`` (the unit of ``operator_noise``)."""
        return self.train_in.double().std(0, correction=0).to(self.train_in.dtype)


def training_data(collection, channels, pointnet: bool, device) -> TrainData:
    """The train and val tensors of ``collection``, checked.

    Parameters
    ----------
    collection : opnet.data.Collection
        Needs shapes in ``train`` and ``val``, and finite arrays there.
    channels : tuple of str
        The channels read, in order (``()`` for the PointNet autoencoder).
    pointnet : bool
        The network reads the vertices rather than the operators.
    device : torch.device
        Where the tensors go.

    Returns
    -------
    TrainData

    Raises
    ------
    ValueError
        An empty ``train`` or ``val`` split, or NaN or infinite values in the arrays read from them.
    """
    train_idx, val_idx = collection.indices("train"), collection.indices("val")
    if len(train_idx) == 0 or len(val_idx) == 0:
        raise ValueError(
            f"the collection needs shapes in both 'train' and 'val' (it has {len(train_idx)} and "
            f"{len(val_idx)}); give it a splits.csv or use a larger preset."
        )
    chans = collection.channel_indices(channels) if channels else []
    seen = np.concatenate([train_idx, val_idx])
    read = {"vertices": collection.vertices[seen]}
    if not pointnet:  # only the channels the network reads
        read = {"operators": collection.operators[seen][:, chans], **read}
    for name, arr in read.items():
        bad = ~np.isfinite(arr).reshape(len(seen), -1).all(1)
        if bad.any():
            which = f" (channels {list(channels)})" if name == "operators" else ""
            raise ValueError(
                f"the collection's {name} hold NaN or infinite values in {bad.sum()} train/val shapes "
                f"(first: shape {seen[bad][0]}){which}; repair or drop them."
            )

    def tensors(idx):  # (network input, target vertices)
        X = torch.from_numpy(np.ascontiguousarray(collection.vertices[idx], dtype=np.float32)).to(device)
        if pointnet:
            return X, X
        return torch.from_numpy(np.ascontiguousarray(collection.operators[idx][:, chans], dtype=np.float32)).to(
            device
        ), X

    return TrainData(*tensors(train_idx), *tensors(val_idx))


def build_network(collection, config, channels, train_in: torch.Tensor) -> torch.nn.Module:
    """The untrained network of ``config`` for ``collection``, initialised from ``config.seed`` (the global random
    state is left as it was).

    Parameters
    ----------
    collection : opnet.data.Collection
        Its vertex count, basis size and base shape.
    config : opnet.train.TrainConfig
        The architecture and its options.
    channels : tuple of str
        The channels OperatorNet reads.
    train_in : torch.Tensor
        The training inputs: OperatorNet's input statistics are computed from them.

    Returns
    -------
    torch.nn.Module
        An :class:`opnet.OperatorNet` (with ``channel_digests``, what evaluation checks) or an
        :class:`opnet.model.PointNetAutoencoder` (its points chosen), on the CPU.
    """
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        options = {
            **VARIANTS[config.variant],
            **{k: v for k, v in (("standardize", config.standardize), ("residual", config.residual)) if v is not None},
        }
        if config.pointnet:
            n = collection.vertices.shape[1]
            net = build_model(
                dict(
                    architecture=config.architecture, n_vertices=n, n_points=min(config.points, n), hidden=config.hidden
                )
            )
            net.choose_points(collection.base_basis.mesh.vertices)
        else:
            net = OperatorNet(
                collection.vertices.shape[1],
                collection.base_basis.k,
                channels,
                config.depth,
                config.hidden,
                config.subtract_identity,
                **options,
            )
            net.set_statistics(train_in.cpu(), collection.base_basis.mesh.vertices)
            net.channel_digests = {c: collection.digests.get(c) for c in channels}  # what evaluation checks
    return net
