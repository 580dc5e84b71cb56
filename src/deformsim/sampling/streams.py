"""The named random streams of sampling and compositing: one table, one function that makes the generator.

A stream's generator is ``default_rng([seed, *keys, *tail])``: ``keys`` say which sample or image it draws for,
``tail`` tells the streams of one key apart. Each option with a stream of its own draws without moving any other
draw, so turning it on leaves everything else as it was. A new stream is one line of :data:`STREAMS`, with a tail
no stream of the same keys uses; a render feature declares its own (:data:`deformsim.sampling.features.STREAMS` holds
both). With ``generate.paired`` a sample's streams take its pair's index (the deformed twin's), and an image's
streams its twin's image id, so twins draw alike (:func:`deformsim.sampling.sample_params`).
"""

from __future__ import annotations

import hashlib
from typing import NamedTuple

import numpy as np


class Stream(NamedTuple):
    keys: tuple[str, ...]  # what the stream is keyed by after the seed: "index" (a sample's), "image" (stable_int(id))
    tail: tuple[int, ...]  # the words after the keys that tell this stream apart from the others of its keys
    purpose: str


STREAMS: dict[str, Stream] = {
    "sample": Stream(("index",), (), "a sample's deformation, openings, HDRI, cameras, design, material and tilt"),
    "source": Stream(("index",), (1,), "a deformed sample's source, bank entry and amount (deform.sources)"),
    "framing": Stream(("index",), (5,), "each image's fill, offset, partial cut, lens and f-number (camera.*)"),
    "shape": Stream(("index",), (6,), "the part's shape: can size, scale, taper and bulge (object.shapes)"),
    "appearance": Stream(("index",), (7,), "the printed artwork, photo, gloss and ink roughness (render.appearance)"),
    "regions": Stream(("index",), (8,), "the colour and roughness of each material region (spec material.regions)"),
    "print": Stream(("index",), (9,), "the printed marks of each finish with print (spec material and regions)"),
    "image": Stream(("image",), (), "an image's composite: background, framing and camera effects"),
    "flip": Stream(("image",), (0xF11F,), "whether the composite mirrors the part (composite.flip_part)"),
    "shadow": Stream(("image",), (0x5AAD,), "how strongly the shadow darkens the background (composite.shadow_strength)"),
    "scene": Stream(("image",), (0x5CE7,), "whether the image shows its rendered surface scene (composite.surface)"),
    "balance": Stream((), (0xBA1A,), "the class-balanced assignment of background photos (composite.balance_backgrounds)"),
}


def stream(name: str, seed: int, *keys: int) -> np.random.Generator:
    """The generator of stream ``name`` for run ``seed`` and the stream's ``keys`` (a sample index, an image's
    :func:`stable_int`)."""
    return generator(STREAMS[name], seed, *keys, name=name)


def generator(s: Stream, seed: int, *keys: int, name: str = "") -> np.random.Generator:
    """The generator of stream ``s`` (called ``name``) for run ``seed`` and its ``keys``."""
    if len(keys) != len(s.keys):
        raise TypeError(f"stream {name!r} takes {len(s.keys)} key(s) ({', '.join(s.keys) or 'none'}), got {len(keys)}")
    return np.random.default_rng([seed, *keys, *s.tail])


def stable_int(iid: str) -> int:
    """A process-independent 64-bit integer for an image id (unlike ``hash``): the key of its streams."""
    return int.from_bytes(hashlib.blake2b(iid.encode("utf-8", "surrogateescape"), digest_size=8).digest(), "little")
