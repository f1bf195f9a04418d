"""A PyTorch ``Dataset`` over a :class:`~opnet.data.Collection`: (operators, vertices) pairs in float32."""

from __future__ import annotations

import numpy as np
import torch

from ..shape_difference import KINDS

__all__ = ["OperatorDataset"]


class OperatorDataset(torch.utils.data.Dataset):
    """Shapes of one split as ``(operators (C, k, k), vertices (n, 3))`` float32 tensors.

    ``channels`` picks any subset of ``("area", "conformal", "extrinsic")``, returned in the order
    given, so a model can be trained on Int, Ext or Int+Ext inputs (the paper's ablation).
    """

    def __init__(self, collection, split: str = "train", channels=KINDS):
        unknown = set(channels) - set(KINDS)
        if unknown or not channels:
            raise ValueError(f"channels must be a non-empty subset of {KINDS}, got {channels!r}.")
        self.indices = collection.indices(split)
        self.channels = tuple(channels)
        chans = [KINDS.index(c) for c in self.channels]
        self.operators = torch.from_numpy(
            np.ascontiguousarray(collection.operators[self.indices][:, chans], np.float32)
        )
        self.vertices = torch.from_numpy(np.ascontiguousarray(collection.vertices[self.indices], np.float32))

    def __len__(self) -> int:
        return len(self.indices)

    def __getitem__(self, i):
        return self.operators[i], self.vertices[i]
