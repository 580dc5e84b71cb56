"""What a dataset is made from: the settings that change its renders and the contents of its input files.

The settings are the config's fields less those their :mod:`deformsim.identity` rule leaves out (worker counts,
``generate.n``, the later stages, an option at its default that changes nothing). The inputs are named by
content: the sha256 of the mesh file's bytes, of the parsed spec, of the HDRI, texture and artwork photo files, and the
simulated bank's key. A dataset folder is named by both (:func:`data_name`).
"""

from __future__ import annotations

import hashlib
import json

from deformsim.bank.store import bank_key
from deformsim.config import Config
from deformsim.hdri import hdri_files
from deformsim.identity import content_inputs, digest, file_digest, files_digest, settings
from deformsim.sampling import artwork_photos
from deformsim.sampling.features import SURFACE, listings
from deformsim.spec.model import Spec, check_mesh_file, load_spec

# The renderer's revision: raised whenever the Blender side renders the same settings differently, so no
# dataset mixes or reuses renders of another renderer.
RENDERER = 2


def data_settings(cfg: Config) -> dict:
    """The part of a config that determines the rendered data."""
    return settings(cfg)


def texture_photos(cfg: Config) -> list[str] | None:
    """The surface texture photos the config draws from (``render.surface`` with kind photo), else None."""
    return listings(cfg).get(SURFACE.name)


def appearance_photos(cfg: Config) -> list[str] | None:
    """The artwork photos the config draws from (``render.appearance.photos``), else None."""
    a = cfg.render.appearance
    return artwork_photos(a.photos) if a is not None and a.photos is not None else None


def _photos_digest(photos: list[str] | None, root) -> str | None:
    return files_digest(photos, root) if photos else None


# How each input read by content (its rule's key) is named: from the config, the input's path and the parsed spec.
_DIGESTS = {
    "mesh": lambda cfg, path, spec: file_digest(path) if path is not None else None,
    "spec": lambda cfg, path, spec: hashlib.sha256(json.dumps(spec.model_dump(mode="json"), sort_keys=True)
                                                   .encode()).hexdigest(),
    "hdri": lambda cfg, path, spec: files_digest(list(hdri_files(path).values()), path) if path is not None else None,
    "surface": lambda cfg, path, spec: _photos_digest(texture_photos(cfg), path),
    "artwork": lambda cfg, path, spec: _photos_digest(appearance_photos(cfg), path),
}
_RECORDED_UNSET = ("mesh", "hdri")  # recorded as null when unset since the first datasets; the others left out


def input_digests(cfg: Config, spec: Spec | None = None) -> dict:
    """What the renders are made from, by content: sha256 of the mesh file, of the parsed spec (so a comment
    or a reformatting does not count, a changed range does), of the HDRI files, the surface and artwork photos
    when the config uses them (every field read by content, :meth:`Config.input_paths`), and the simulated
    bank's key when the samples use it."""
    spec = spec or load_spec(cfg.object.spec)
    mesh = cfg.object.mesh
    if mesh is not None:
        check_mesh_file(mesh)
    digests = {"renderer": RENDERER, "bank": bank_key(spec, mesh) if cfg.deform.sources.uses_bank and spec.simulation else None}
    for rule, path in content_inputs(cfg):
        value = _DIGESTS[rule.key](cfg, path, spec)
        if value is not None or rule.key in _RECORDED_UNSET:
            digests[rule.key] = value
    return digests


def data_identity(cfg: Config, spec: Spec | None = None) -> dict:
    """The settings and input contents that determine the rendered data (``generate.n`` aside)."""
    return {"settings": data_settings(cfg), "inputs": input_digests(cfg, spec)}


def data_name(cfg: Config, spec: Spec | None = None) -> str:
    """A dataset folder name for ``cfg``: ``data-`` and a digest of :func:`data_identity`."""
    return f"data-{digest(data_identity(cfg, spec))}"
