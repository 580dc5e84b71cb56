"""TEMPORARY development stand-in for can.py (removed once can.py exists)."""
import bmesh
import bpy


def build_can():
    mesh = bpy.data.meshes.new("Can")
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=True, segments=64, radius1=0.033, radius2=0.033, depth=0.122)
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0, 0, 0.061))
    side = [e for e in bm.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > 0.1]
    bmesh.ops.subdivide_edges(bm, edges=side, cuts=60, use_grid_fill=True)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new("Can", mesh)
    bpy.context.scene.collection.objects.link(obj)
    for f in mesh.polygons:
        f.use_smooth = True
    g = obj.vertex_groups.new(name="side_wall")
    g.add([v.index for v in mesh.vertices if 0.004 < v.co.z < 0.118], 1.0, "REPLACE")
    obj.shape_key_add(name="Basis", from_mix=False)
    for name in ("Seal", "Tab"):
        k = obj.shape_key_add(name=name, from_mix=False)
        for i, v in enumerate(mesh.vertices):
            if v.co.z > 0.121 and v.co.x > 0:
                k.data[i].co.z += 0.003
    for name, color in (("Label", (0.8, 0.1, 0.1, 1)), ("Aluminium", (0.8, 0.8, 0.8, 1))):
        m = bpy.data.materials.new(name)
        bsdf = m.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = color
        bsdf.inputs["Metallic"].default_value = 0.8
        bsdf.inputs["Roughness"].default_value = 0.3
        obj.data.materials.append(m)
    return obj
