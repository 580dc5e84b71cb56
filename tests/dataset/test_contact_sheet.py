"""Dense maps as pictures on a contact sheet: the near part bright, deformation in heat colours, masks white."""

from __future__ import annotations

import numpy as np

from deformsim.dataset.contact_sheet import map_image
from deformsim.dataset.dense import DEFORM_SCALE, encode_u16, mask_image, save_png


def test_depth_shows_near_brighter_deformation_hotter_and_masks_white(tmp_path):
    on = np.zeros((8, 8), bool)
    on[2:6, 2:6] = True
    depth = np.where(on, np.linspace(400, 600, 8)[None, :], 0.0)  # nearer on the left
    deform = np.where(on, np.linspace(0, 3, 8)[None, :], 0.0)
    save_png(tmp_path / "depth.png", encode_u16(depth, 1.0))
    save_png(tmp_path / "deform.png", encode_u16(deform, DEFORM_SCALE))
    save_png(tmp_path / "mask.png", mask_image(on))
    d = np.asarray(map_image("depth", tmp_path / "depth.png"))
    assert d[3, 2] > d[3, 5] > 0 and d[0, 0] == 0
    heat = np.asarray(map_image("deform", tmp_path / "deform.png")).astype(int)
    assert heat[3, 5].sum() > heat[3, 2].sum() and heat[0, 0].sum() == 0
    assert (np.asarray(map_image("mask", tmp_path / "mask.png")) == np.where(on, 255, 0)).all()
