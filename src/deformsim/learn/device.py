"""Where torch runs: the device, the number of CPU threads, the training steps' number format and the optimiser's
kernel."""

from __future__ import annotations

import functools
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


@functools.cache
def native_bfloat16(device_type: str) -> bool:
    """Whether devices of ``device_type`` compute bfloat16 natively: a CPU with AVX-512 BF16 or AMX tiles (elsewhere
    torch emulates it, slower than float32), or a CUDA GPU that supports it."""
    if device_type == "cuda":
        return torch.cuda.is_bf16_supported()
    cpu = torch.cpu
    return any(getattr(cpu, probe, lambda: False)() for probe in ("_is_avx512_bf16_supported", "_is_amx_tile_supported"))


def step_autocast(precision: str, device: torch.device) -> torch.autocast:
    """The context a training step's forward pass runs in: bfloat16 autocast for ``train.precision`` bfloat16, or auto
    on a device that computes it natively (:func:`native_bfloat16`); float32 (autocast off) otherwise. The backward
    pass follows the forward's formats; weights and their gradients stay float32."""
    return torch.autocast(device.type, dtype=torch.bfloat16, enabled=step_bfloat16(precision, device))


def step_bfloat16(precision: str, device: torch.device) -> bool:
    """Whether ``train.precision`` runs the training steps on ``device`` in bfloat16."""
    return precision == "bfloat16" or (precision == "auto" and native_bfloat16(device.type))
