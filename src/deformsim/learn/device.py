"""Where torch runs: the device, the number of CPU threads, and the optimiser's kernel."""

from __future__ import annotations

import os

import torch

from deformsim.errors import UserError


def set_threads() -> None:
    torch.set_num_threads(max(1, len(os.sched_getaffinity(0))))


def pick_device(name: str) -> torch.device:
    """``auto``: cuda when available, else cpu."""
    if name == "cuda" and not torch.cuda.is_available():
        raise UserError("train.device is cuda but torch sees no CUDA GPU (use auto or cpu)")
    return torch.device("cuda" if name == "cuda" or (name == "auto" and torch.cuda.is_available()) else "cpu")


def adam(params, lr: float) -> torch.optim.Adam:
    """Adam over ``params`` in one fused kernel per step (CPU and CUDA): the same update as the per-tensor loop, in a
    fraction of its time (VGG-16's last conv has 2.4 million weights)."""
    return torch.optim.Adam(params, lr=lr, fused=True)
