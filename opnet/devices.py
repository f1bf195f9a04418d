"""Where torch computes: :func:`resolve_device` reads a ``device`` argument (``"auto"``, ``"cpu"``, ``"cuda:1"``,
a :class:`torch.device`) the same way for training (:mod:`opnet.train`), reconstruction (:mod:`opnet.geometric`)
and the command line. It sits below both, so neither imports the other for it.
"""

from __future__ import annotations

import torch

__all__ = ["resolve_device"]


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
