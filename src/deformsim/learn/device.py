"""Where torch runs: the device and the number of CPU threads."""

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
