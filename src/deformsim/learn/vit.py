"""Vision transformers as ``features`` sequences: torchvision's ViT-B/16 and DINOv2 ViT-S/14, and their weights.

Both read any input size: images are resized to 224 px (ViT-B/16: 14 x 14 patches of 16 px, the size its
position embedding was trained at; DINOv2: 16 x 16 patches of 14 px, its 37 x 37 position grid interpolated
bicubically as DINOv2 itself does). ``features()`` holds ``[0]`` the patch embedding with the class token and
position embedding, ``[1..12]`` the transformer blocks, ``[13]`` the final LayerNorm read at the class token,
as an (N, C, 1, 1) map so the pooled-feature path of every backbone serves them. The stem between them outputs
tokens (N, 1 + patches, C): these backbones have no spatial map for ``train.target: localise``.

:func:`vit_b_16_state` maps torchvision's file, :func:`dinov2_state` DINOv2's ``dinov2_vits14_pretrain.pth``
(from ``torch.hub``'s download of Meta's URL) onto these modules.
"""

from __future__ import annotations

from functools import partial

import torch
from torch import nn
from torch.nn import functional as F

SIZE = 224  # input side the embeddings read
DEPTH = 12


class ClassToken(nn.Module):
    """The final LayerNorm at the class token, as an (N, C, 1, 1) map."""

    def __init__(self, dim: int, eps: float = 1e-6):
        super().__init__()
        self.ln = nn.LayerNorm(dim, eps=eps)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.ln(x[:, 0])[:, :, None, None]


def _sized(x: torch.Tensor) -> torch.Tensor:
    return x if x.shape[-1] == SIZE and x.shape[-2] == SIZE else F.interpolate(
        x, size=(SIZE, SIZE), mode="bilinear", align_corners=False, antialias=True)


class ViTEmbed(nn.Module):
    """torchvision's ViT-B/16 front: 16 px patches, class token, learned 197-token position embedding."""

    def __init__(self, dim: int = 768, patch: int = 16):
        super().__init__()
        self.conv_proj = nn.Conv2d(3, dim, patch, patch)
        self.class_token = nn.Parameter(torch.zeros(1, 1, dim))
        self.pos_embedding = nn.Parameter(torch.empty(1, (SIZE // patch) ** 2 + 1, dim).normal_(std=0.02))
        fan_in = 3 * patch * patch
        nn.init.trunc_normal_(self.conv_proj.weight, std=(1 / fan_in) ** 0.5)
        nn.init.zeros_(self.conv_proj.bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.conv_proj(_sized(x)).flatten(2).transpose(1, 2)
        return torch.cat([self.class_token.expand(len(x), -1, -1), x], dim=1) + self.pos_embedding


def vit_b_16_features() -> nn.Sequential:
    from torchvision.models.vision_transformer import EncoderBlock

    norm = partial(nn.LayerNorm, eps=1e-6)
    blocks = [EncoderBlock(12, 768, 3072, 0.0, 0.0, norm) for _ in range(DEPTH)]
    return nn.Sequential(ViTEmbed(), *blocks, ClassToken(768))


def _mapped(state: dict, front: dict[str, str], blocks: str, final: str) -> dict:
    """``state`` in these modules' names: the embedding's keys by ``front``, block ``i`` (keys after the prefix
    ``blocks``) to ``i + 1``, the final norm (prefix ``final``) to the class-token LayerNorm; the rest left out."""
    out = {}
    for key, value in state.items():
        if key in front:
            out[front[key]] = value
        elif key.startswith(blocks):
            index, _, rest = key.removeprefix(blocks).partition(".")
            out[f"{int(index) + 1}.{rest}"] = value
        elif key.startswith(final):
            out[f"{DEPTH + 1}.ln.{key.rpartition('.')[2]}"] = value
    return out


def vit_b_16_state(state: dict) -> dict:
    """torchvision's ViT-B/16 state dict as a :func:`vit_b_16_features` one (the classifier left out)."""
    front = {"conv_proj.weight": "0.conv_proj.weight", "conv_proj.bias": "0.conv_proj.bias",
             "class_token": "0.class_token", "encoder.pos_embedding": "0.pos_embedding"}
    return _mapped(state, front, "encoder.layers.encoder_layer_", "encoder.ln.")


class Dinov2Embed(nn.Module):
    """DINOv2's front: 14 px patches, class token, a 37 x 37 position grid interpolated to the patch grid."""

    def __init__(self, dim: int = 384, patch: int = 14, grid: int = 37):
        super().__init__()
        self.proj = nn.Conv2d(3, dim, patch, patch)
        self.cls_token = nn.Parameter(torch.zeros(1, 1, dim).normal_(std=1e-6))
        self.pos_embed = nn.Parameter(torch.empty(1, grid * grid + 1, dim).normal_(std=0.02))
        self.grid = grid

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.proj(_sized(x))
        side = x.shape[-1]
        x = x.flatten(2).transpose(1, 2)
        grid = self.pos_embed[:, 1:].reshape(1, self.grid, self.grid, -1).permute(0, 3, 1, 2)
        grid = F.interpolate(grid, size=(side, side), mode="bicubic", align_corners=False)
        pos = torch.cat([self.pos_embed[:, :1], grid.permute(0, 2, 3, 1).flatten(1, 2)], dim=1)
        return torch.cat([self.cls_token.expand(len(x), -1, -1), x], dim=1) + pos


class Dinov2Block(nn.Module):
    """Pre-norm transformer block with LayerScale, in DINOv2's names (norm1, attn.qkv, attn.proj, ls1.gamma ...)."""

    def __init__(self, dim: int = 384, heads: int = 6):
        super().__init__()
        self.heads = heads
        self.norm1, self.norm2 = nn.LayerNorm(dim, eps=1e-6), nn.LayerNorm(dim, eps=1e-6)
        self.attn = nn.Module()
        self.attn.qkv, self.attn.proj = nn.Linear(dim, 3 * dim), nn.Linear(dim, dim)
        self.mlp = nn.Module()
        self.mlp.fc1, self.mlp.fc2 = nn.Linear(dim, 4 * dim), nn.Linear(4 * dim, dim)
        self.ls1, self.ls2 = nn.Module(), nn.Module()
        self.ls1.gamma, self.ls2.gamma = nn.Parameter(torch.full((dim,), 1e-5)), nn.Parameter(torch.full((dim,), 1e-5))

    def _attention(self, x: torch.Tensor) -> torch.Tensor:
        n, length, dim = x.shape
        q, k, v = self.attn.qkv(x).reshape(n, length, 3, self.heads, dim // self.heads).permute(2, 0, 3, 1, 4)
        return self.attn.proj(F.scaled_dot_product_attention(q, k, v).transpose(1, 2).reshape(n, length, dim))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x + self.ls1.gamma * self._attention(self.norm1(x))
        return x + self.ls2.gamma * self.mlp.fc2(F.gelu(self.mlp.fc1(self.norm2(x))))


def dinov2_vits14_features() -> nn.Sequential:
    net = nn.Sequential(Dinov2Embed(), *(Dinov2Block() for _ in range(DEPTH)), ClassToken(384))
    for m in net.modules():
        if isinstance(m, nn.Linear):
            nn.init.trunc_normal_(m.weight, std=0.02)
            nn.init.zeros_(m.bias)
    return net


def dinov2_state(state: dict) -> dict:
    """DINOv2's ViT-S/14 checkpoint as a :func:`dinov2_vits14_features` state dict (``mask_token`` left out)."""
    front = {"cls_token": "0.cls_token", "pos_embed": "0.pos_embed", "patch_embed.proj.weight": "0.proj.weight",
             "patch_embed.proj.bias": "0.proj.bias"}
    return _mapped(state, front, "blocks.", "norm.")
