"""Materials: the can's printed label and brushed aluminium, and randomised user-mesh surfaces.

Everything is created once and updated in place on later calls, so memory stays bounded over thousands
of samples: one label image ("LabelImage") whose pixels are overwritten, one material per role.
"""

from __future__ import annotations

import bpy
import numpy as np

from deformsim.blender.can_label import make_label
from deformsim.sampling import CanDesign, MaterialParams
from deformsim.spec.model import Material

LABEL_IMAGE = "LabelImage"
OBJECT_MATERIAL = "ObjectMaterial"
_KINDS = {  # Principled settings per spec material kind
    "metal": {"Metallic": 1.0, "Coat Weight": 0.0, "Anisotropic": 0.3},
    "plastic": {"Metallic": 0.0, "Coat Weight": 0.0, "Anisotropic": 0.0},
    "painted": {"Metallic": 0.0, "Coat Weight": 0.6, "Anisotropic": 0.0},
}


def _material(name: str) -> tuple[bpy.types.Material, bool]:
    """The material called ``name`` and whether it was just created (5.0: always node based)."""
    mat = bpy.data.materials.get(name)
    return (mat, False) if mat else (bpy.data.materials.new(name), True)


def _bsdf(mat: bpy.types.Material) -> bpy.types.Node:
    return next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")


def _set(bsdf: bpy.types.Node, values: dict) -> None:
    for name, value in values.items():
        bsdf.inputs[name].default_value = value


def _bump(mat: bpy.types.Material, bsdf: bpy.types.Node, scale: float, strength: float) -> None:
    """Fine noise bump in object space (metres): brushing and rolling marks."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    coord = nodes.new("ShaderNodeTexCoord")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = scale
    noise.inputs["Detail"].default_value = 4.0
    bump = nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = strength
    bump.inputs["Distance"].default_value = 0.0002
    links.new(coord.outputs["Object"], noise.inputs["Vector"])
    links.new(noise.outputs["Fac"], bump.inputs["Height"])
    links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])


def label_image(width: int = 512, height: int = 256) -> bpy.types.Image:
    """The one label image, created on first use (8-bit sRGB) and resized in place when asked."""
    img = bpy.data.images.get(LABEL_IMAGE)
    if img is None:
        img = bpy.data.images.new(LABEL_IMAGE, width, height, alpha=True)
    elif tuple(img.size) != (width, height):
        img.scale(width, height)
    return img


def can_materials(obj: bpy.types.Object) -> None:
    """Give ``obj`` slot 0 "Label" (printed aluminium) and slot 1 "Aluminium" (brushed metal)."""
    label, new = _material("Label")
    if new:
        bsdf = _bsdf(label)
        tex = label.node_tree.nodes.new("ShaderNodeTexImage")
        tex.name = LABEL_IMAGE
        tex.image = label_image()
        uv = label.node_tree.nodes.new("ShaderNodeUVMap")
        uv.uv_map = "UVMap"
        label.node_tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])
        label.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
        _set(bsdf, {"Metallic": 0.7, "Roughness": 0.3, "Coat Weight": 0.35, "Coat Roughness": 0.08})
        _bump(label, bsdf, 900.0, 0.03)
    alu, new = _material("Aluminium")
    if new:
        bsdf = _bsdf(alu)
        _set(bsdf, {"Base Color": (0.8, 0.8, 0.82, 1.0), "Metallic": 1.0, "Roughness": 0.3,
                    "Anisotropic": 0.5})
        _bump(alu, bsdf, 1500.0, 0.05)
    mats = obj.data.materials
    mats.clear()
    mats.append(label)
    mats.append(alu)


def set_label(design: CanDesign, width: int = 512, height: int = 256) -> None:
    """Print ``design`` into the shared "LabelImage" (pixels overwritten; no new image per sample)."""
    img = label_image(width, height)
    pixels = np.ascontiguousarray(make_label(design, width, height)[::-1])  # Blender rows go bottom-up
    img.pixels.foreach_set(pixels.ravel())
    img.update()
    img.update_tag()
    # Cycles with persistent data keeps an image it has loaded until the image's parameters change; the
    # label is opaque, so flipping the (unused) alpha mode makes it reload the new pixels at no cost.
    img.alpha_mode = "NONE" if img.alpha_mode == "STRAIGHT" else "STRAIGHT"


def apply_material(obj: bpy.types.Object, spec_material: Material, params: MaterialParams) -> None:
    """Give a user mesh its one material: ``spec_material.kind`` with ``params`` colour and roughness."""
    mat, new = _material(OBJECT_MATERIAL)
    bsdf = _bsdf(mat)
    if new:
        _bump(mat, bsdf, 1200.0, 0.02)
    _set(bsdf, {**_KINDS[spec_material.kind], "Base Color": (*params.color, 1.0), "Roughness": params.roughness,
                "Coat Roughness": 0.1})
    mats = obj.data.materials
    if list(mats) != [mat]:
        mats.clear()
        mats.append(mat)
        obj.data.polygons.foreach_set("material_index", np.zeros(len(obj.data.polygons), np.int32))
