"""Materials: the can's printed label and brushed aluminium, and randomised user-mesh surfaces.

Everything is created once and updated in place on later calls, so memory stays bounded over thousands
of samples: one label image ("LabelImage") whose pixels are overwritten, one material per role.
"""

from __future__ import annotations

import bpy
import numpy as np

from deformsim.blender.part.can_label import make_label
from deformsim.sampling import CanDesign, MaterialParams
from deformsim.spec.model import Material

LABEL_IMAGE = "LabelImage"
OBJECT_MATERIAL = "ObjectMaterial"
_KINDS = {  # Principled settings per spec material kind
    "metal": {"Metallic": 1.0, "Coat Weight": 0.0, "Anisotropic": 0.3},
    "plastic": {"Metallic": 0.0, "Coat Weight": 0.0, "Anisotropic": 0.0},
    "painted": {"Metallic": 0.0, "Coat Weight": 0.6, "Anisotropic": 0.0},
}
# Crease layer (Cycles' Geometry "Pointiness": 0.5 flat, above convex, below concave), see add_creases.
CREASE_GEOMETRY = "CreaseGeometry"  # its Geometry node; present = the material has the layer
CREASE_IN = "Crease In "  # + BSDF input name: the mix whose A input takes that input's (per-sample) value
RIDGE = (0.53, 0.58)  # pointiness from which a ridge starts to show bare metal, and where it is fully bare
FOLD = (0.485, 0.44)  # pointiness from which a fold starts to darken, and where it is fully dark
FOLD_DARKEN = 0.3  # base colour factor in a full fold
BARE = {"Base Color": (0.8, 0.8, 0.82, 1.0), "Metallic": 1.0, "Roughness": 0.45, "Coat Weight": 0.0}
SCUFF_SCALE = 350.0  # noise scale (per metre, object space) breaking the ridge mask into scuffs
_creases = False  # set by enable_creases: OBJECT_MATERIAL gets the layer when it is created


def _material(name: str) -> tuple[bpy.types.Material, bool]:
    """The material called ``name`` and whether it was just created (5.0: always node based)."""
    mat = bpy.data.materials.get(name)
    return (mat, False) if mat else (bpy.data.materials.new(name), True)


def _bsdf(mat: bpy.types.Material) -> bpy.types.Node:
    return next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")


def _set(bsdf: bpy.types.Node, values: dict) -> None:
    """Set BSDF inputs; where the crease layer sits in front of one, its entry mix takes the value."""
    for name, value in values.items():
        bsdf.inputs[name].default_value = value
        entry = bsdf.id_data.nodes.get(CREASE_IN + name)
        if entry is not None:
            _socket(entry.inputs, "A_Color" if entry.data_type == "RGBA" else "A_Float").default_value = value


def _socket(sockets, identifier: str):
    """The socket with this identifier (Mix nodes have several sockets of each name)."""
    return next(s for s in sockets if s.identifier == identifier)


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


def _map_range(nodes, value, lo: float, hi: float) -> bpy.types.NodeSocket:
    """Clamped linear 0..1 ramp of ``value`` from ``lo`` to ``hi`` (``hi < lo``: a falling ramp)."""
    ramp = nodes.new("ShaderNodeMapRange")
    ramp.clamp = True
    ramp.inputs["From Min"].default_value, ramp.inputs["From Max"].default_value = lo, hi
    value.id_data.links.new(value, ramp.inputs["Value"])
    return ramp.outputs["Result"]


def _mix_into(bsdf: bpy.types.Node, name: str, factor, target, blend: str = "MIX") -> None:
    """Put a Mix (A = what fed input ``name`` so far, B = ``target``, by ``factor``) in front of that input."""
    tree = bsdf.id_data
    sock = bsdf.inputs[name]
    color = sock.type == "RGBA"
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = ("RGBA" if color else "FLOAT"), blend
    kind = "Color" if color else "Float"
    a, b = _socket(mix.inputs, f"A_{kind}"), _socket(mix.inputs, f"B_{kind}")
    b.default_value = target
    tree.links.new(factor, _socket(mix.inputs, "Factor_Float"))
    if sock.is_linked:
        tree.links.new(sock.links[0].from_socket, a)
    else:  # a constant: this mix becomes the input's entry, where _set writes later values
        a.default_value = sock.default_value
        mix.name = CREASE_IN + name
    tree.links.new(_socket(mix.outputs, f"Result_{kind}"), sock)


def add_creases(mat: bpy.types.Material, ridges: bool = True) -> None:
    """Insert the crease layer in front of ``mat``'s Principled BSDF (once; no-op if it is there).

    Folds (pointiness below :data:`FOLD`) darken the base colour towards :data:`FOLD_DARKEN` times itself;
    with ``ridges``, sharp convex ridges (above :data:`RIDGE`) turn to scuffed bare aluminium (:data:`BARE`:
    bright base colour, metallic, rougher, no coat), the mask broken up by a small noise so it reads as
    scuffing rather than a clean line. Constant BSDF inputs move to the mixes' A inputs (see :func:`_set`).
    """
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    if CREASE_GEOMETRY in nodes:
        return
    bsdf = _bsdf(mat)
    geo = nodes.new("ShaderNodeNewGeometry")
    geo.name = CREASE_GEOMETRY
    pointiness = geo.outputs["Pointiness"]
    _mix_into(bsdf, "Base Color", _map_range(nodes, pointiness, *FOLD), (FOLD_DARKEN,) * 3 + (1.0,), "MULTIPLY")
    if not ridges:
        return
    coord = nodes.new("ShaderNodeTexCoord")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = SCUFF_SCALE
    noise.inputs["Detail"].default_value = 6.0
    noise.inputs["Roughness"].default_value = 0.65
    links.new(coord.outputs["Object"], noise.inputs["Vector"])
    scuff = nodes.new("ShaderNodeMapRange")
    scuff.clamp = True
    scuff.inputs["From Min"].default_value, scuff.inputs["From Max"].default_value = 0.35, 0.6
    scuff.inputs["To Min"].default_value = 0.25
    links.new(noise.outputs["Fac"], scuff.inputs["Value"])
    mask = nodes.new("ShaderNodeMath")
    mask.operation, mask.use_clamp = "MULTIPLY", True
    links.new(_map_range(nodes, pointiness, *RIDGE), mask.inputs[0])
    links.new(scuff.outputs["Result"], mask.inputs[1])
    for name, target in BARE.items():
        _mix_into(bsdf, name, mask.outputs["Value"], target)


def enable_creases(obj: bpy.types.Object, enabled: bool = True) -> None:
    """Switch the crease layer on (``render.creases``): once per process, after the object is built.

    The can's "Label" gets ridges and folds, its bare "Aluminium" folds only; a user mesh's material gets
    both when :func:`apply_material` creates it (or now, if it exists). Off, no material is touched.
    """
    global _creases
    _creases = enabled
    if not enabled:
        return
    for mat in obj.data.materials:
        if mat is not None and mat.name in ("Label", "Aluminium", OBJECT_MATERIAL):
            add_creases(mat, ridges=mat.name != "Aluminium")


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
    if _creases:
        add_creases(mat)
    _set(bsdf, {**_KINDS[spec_material.kind], "Base Color": (*params.color, 1.0), "Roughness": params.roughness,
                "Coat Roughness": 0.1})
    mats = obj.data.materials
    if list(mats) != [mat]:
        mats.clear()
        mats.append(mat)
        obj.data.polygons.foreach_set("material_index", np.zeros(len(obj.data.polygons), np.int32))
