"""HDRI discovery without bpy: Blender's studio lights or a user folder."""

from __future__ import annotations

import pytest

from deformsim.errors import UserError
from deformsim.hdri import list_hdris

STUDIO_LIGHTS = ["city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset"]


def test_list_hdris_default_is_blenders_studio_lights():
    assert list_hdris(None) == STUDIO_LIGHTS


def test_list_hdris_user_folder(tmp_path):
    for name in ("b.HDR", "a.exr", "notes.txt"):
        (tmp_path / name).write_bytes(b"x")
    assert list_hdris(tmp_path) == ["a", "b"]


@pytest.mark.parametrize("make", ["missing", "empty", "duplicate"])
def test_list_hdris_bad_folder_is_user_error(tmp_path, make):
    folder = tmp_path / "hdris"
    if make != "missing":
        folder.mkdir()
    if make == "duplicate":
        (folder / "sky.exr").write_bytes(b"x")
        (folder / "sky.hdr").write_bytes(b"x")
    with pytest.raises(UserError, match="hdris"):
        list_hdris(folder)


def test_lighting_hdris_draws_only_the_named_ones(tmp_path):
    from deformsim.hdri import drawn_hdris

    for name in ("a", "b", "c"):
        (tmp_path / f"{name}.exr").write_bytes(b"x")
    assert drawn_hdris(tmp_path) == ["a", "b", "c"]
    assert drawn_hdris(tmp_path, ["c", "a"]) == ["a", "c"]
    with pytest.raises(UserError, match="lighting.hdris: no HDRI named 'd' \\(have: a, b, c\\)"):
        drawn_hdris(tmp_path, ["a", "d"])
