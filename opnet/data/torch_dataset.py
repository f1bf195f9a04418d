"""A PyTorch ``Dataset`` over a :class:`~opnet.data.Collection`: (operators, vertices) pairs in float32."""

from __future__ import annotations

import numpy as np
import torch

__all__ = ["OperatorDataset"]


class OperatorDataset(torch.utils.data.Dataset):
    """Shapes of one split as ``(operators (C, k, k), vertices (n, 3))`` float32 tensors.

    ``channels`` picks any of the collection's channels (names or inner products,
    :meth:`~opnet.data.storage.Collection.channel_names`), returned in the order given; default all of
    ``collection.channels``. So a model can be trained on Int, Ext or
    Int+Ext inputs (the paper's ablation), or on a channel of your own.
    """

    def __init__(self, collection, split: str = "train", channels=None):
        self.indices = collection.indices(split)
        self.channels = collection.channel_names(collection.channels if channels is None else channels)
        chans = collection.channel_indices(self.channels)
        self.operators = torch.from_numpy(
            np.ascontiguousarray(collection.operators[self.indices][:, chans], np.float32)
        )
        self.vertices = torch.from_numpy(np.ascontiguousarray(collection.vertices[self.indices], np.float32))

    def __len__(self) -> int:
        return len(self.indices)

    def __getitem__(self, i):
        return self.operators[i], self.vertices[i]
