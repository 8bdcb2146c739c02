# SPDX-License-Identifier: MIT OR Apache-2.0
"""Export a Blender groom to Cem Yuksel's `.hair` format, as bevy_hair reads it.

Install as an add-on (Edit > Preferences > Add-ons > Install..., pick this file), then
File > Export > bevy_hair (.hair) exports the hair of the active object. Headless:

    blender -b scene.blend --python-exit-code 1 --python tools/blender/bevy_hair_export.py \
        -- --object Head --out groom.hair

or, from another script, import this file by path and call `export_hair(obj, path, depsgraph)`.

What is exported:
  * a mesh object: its particle systems of type 'HAIR' (parent strands only), as the
    modifier stack evaluates them, in the mesh's object space; the mesh is the scalp;
  * a hair-curves object: every curve's points, moved into the object space of its surface
    mesh (the scalp) when it has one, with the `radius` attribute as thickness.

Axes and units follow Blender's glTF exporter, so the hair lines up with the scalp exported
as glTF: Blender (x, y, z) becomes (x, z, -y), metres, +Y up.
"""

bl_info = {
    "name": "bevy_hair .hair export",
    "author": "bevy_hair contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "File > Export > bevy_hair (.hair)",
    "description": "Export particle hair or hair curves as a .hair file for bevy_hair",
    "category": "Import-Export",
}

import struct
import sys

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ExportHelper

# Header flags of the .hair format: which arrays follow the header.
HAS_SEGMENTS = 1 << 0
HAS_POINTS = 1 << 1
HAS_THICKNESS = 1 << 2
HEADER_BYTES = 128
INFO_BYTES = 88
# Segments per strand are a u16 in the file.
MAX_STRAND_POINTS = 65_536


def to_engine(v):
    """Blender Z-up to glTF/Bevy Y-up, exactly as Blender's glTF exporter maps positions."""
    return (v[0], v[2], -v[1])


def _particle_strands(obj_eval):
    """Parent strands of every enabled HAIR particle system of an evaluated mesh object,
    in its object space. Returns a list of point lists (Blender axes)."""
    strands = []
    for mod in obj_eval.modifiers:
        if mod.type != 'PARTICLE_SYSTEM':
            continue
        psys = mod.particle_system
        if psys.settings.type != 'HAIR':
            continue
        for p in psys.particles:
            # `co_object` with the *evaluated* object and modifier gives object space.
            # (`hair_key.co` crashes Blender 3.4 on unedited hair; the original modifier
            # gives the strand's own frame instead.)
            strands.append([tuple(k.co_object(obj_eval, mod, p)) for k in p.hair_keys])
    return strands


def _curves_strands(obj_eval):
    """Points (and radii, or None) of every curve of an evaluated hair-curves object, in
    the space of its surface mesh when it has one, else in its own object space."""
    curves = obj_eval.data
    n_points = len(curves.points)
    n_curves = len(curves.curves)
    flat = [0.0] * (3 * n_points)
    curves.attributes["position"].data.foreach_get("vector", flat)
    offsets = [0] * (n_curves + 1)
    curves.curve_offset_data.foreach_get("value", offsets)
    radius_attr = curves.attributes.get("radius")
    radii = None
    if radius_attr is not None and radius_attr.domain == 'POINT':
        radii = [0.0] * n_points
        radius_attr.data.foreach_get("value", radii)

    matrix = obj_eval.matrix_world
    surface = curves.surface
    if surface is not None:
        # Into the scalp's object space, where the scalp mesh's own vertices are.
        matrix = surface.matrix_world.inverted() @ matrix

    strands, thickness = [], []
    for c in range(n_curves):
        a, b = offsets[c], offsets[c + 1]
        strands.append([tuple(matrix @ _vec(flat, i)) for i in range(a, b)])
        if radii is not None:
            # Radius along the strand, scaled with the transform (uniform scale assumed).
            scale = matrix.to_scale()
            s = (abs(scale[0]) + abs(scale[1]) + abs(scale[2])) / 3.0
            thickness.append([2.0 * radii[i] * s for i in range(a, b)])
    return strands, (thickness if radii is not None else None)


def _vec(flat, i):
    from mathutils import Vector
    return Vector((flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]))


def _check(strands, what):
    if not strands:
        raise ValueError(f"{what} has no hair strands to export")
    for i, s in enumerate(strands):
        if len(s) < 2:
            raise ValueError(f"{what}: strand {i} has {len(s)} point(s); a .hair strand needs at least 2")
        if len(s) > MAX_STRAND_POINTS:
            raise ValueError(
                f"{what}: strand {i} has {len(s)} points; a .hair strand has at most {MAX_STRAND_POINTS}"
            )


def hair_bytes(strands, thickness=None, info=""):
    """The .hair file for strands of (x, y, z) points (already in engine axes), with an
    optional thickness per point, laid out as crates/hair_sim/src/groom/hair_file.rs reads it."""
    n_points = sum(len(s) for s in strands)
    flags = HAS_SEGMENTS | HAS_POINTS | (HAS_THICKNESS if thickness is not None else 0)
    text = info.encode("utf-8")[:INFO_BYTES]
    # Default segments 0, thickness 1, transparency 0, colour white: the arrays override them.
    header = struct.pack("<4sIIII5f88s", b"HAIR", len(strands), n_points, flags, 0,
                         1.0, 0.0, 1.0, 1.0, 1.0, text)
    assert len(header) == HEADER_BYTES
    out = bytearray(header)
    out += struct.pack(f"<{len(strands)}H", *(len(s) - 1 for s in strands))
    out += struct.pack(f"<{3 * n_points}f", *(c for s in strands for p in s for c in p))
    if thickness is not None:
        out += struct.pack(f"<{n_points}f", *(t for s in thickness for t in s))
    return bytes(out)


def export_hair(obj, path, depsgraph):
    """Write the hair of `obj` (a mesh with HAIR particle systems, or a hair-curves object)
    to `path` as a .hair file. Raises ValueError when there is nothing valid to export.
    Returns a summary dict; its "scalp" names the mesh object to export alongside."""
    if obj is None:
        raise ValueError("no object given: select the mesh with hair, or the hair curves object")
    obj_eval = obj.evaluated_get(depsgraph)
    thickness = None
    if obj.type == 'MESH':
        if not any(m.type == 'PARTICLE_SYSTEM' and m.particle_system.settings.type == 'HAIR'
                   for m in obj.modifiers):
            raise ValueError(f"object '{obj.name}' has no hair: no particle system of type HAIR")
        strands = _particle_strands(obj_eval)
        kind, scalp = "particles", obj.name
    elif obj.type == 'CURVES':
        strands, thickness = _curves_strands(obj_eval)
        kind = "curves"
        scalp = obj.data.surface.name if obj.data.surface is not None else None
    else:
        raise ValueError(f"object '{obj.name}' is a {obj.type}, not a mesh with particle hair or hair curves")
    _check(strands, f"object '{obj.name}'")

    engine = [[to_engine(p) for p in s] for s in strands]
    info = f"bevy_hair export, Blender {bpy.app.version_string}, {obj.name}"
    data = hair_bytes(engine, thickness, info)
    with open(path, "wb") as f:
        f.write(data)
    return {
        "path": str(path),
        "object": obj.name,
        "kind": kind,
        "scalp": scalp,
        "strands": len(engine),
        "points": sum(len(s) for s in engine),
        "points_per_strand": sorted({len(s) for s in engine}),
        "thickness": thickness is not None,
        "axes": "engine: (x, z, -y) of Blender, metres, +Y up",
        "space": f"object space of '{scalp}'" if scalp else f"object space of '{obj.name}'",
        "bytes": len(data),
    }


class EXPORT_SCENE_OT_bevy_hair(bpy.types.Operator, ExportHelper):
    """Export the active object's hair (particle hair or hair curves) as a .hair file"""

    bl_idname = "export_scene.bevy_hair"
    bl_label = "Export bevy_hair (.hair)"
    bl_options = {'PRESET'}

    filename_ext = ".hair"
    filter_glob: StringProperty(default="*.hair", options={'HIDDEN'})

    def execute(self, context):
        try:
            result = export_hair(context.active_object, self.filepath, context.evaluated_depsgraph_get())
        except ValueError as e:
            self.report({'ERROR'}, str(e))
            return {'CANCELLED'}
        scalp = result["scalp"]
        where = (f"export the mesh '{scalp}' with it (positions are in its object space)"
                 if scalp else "no scalp surface set: positions are in the curves' object space")
        self.report({'INFO'}, f"{result['strands']} strands, {result['points']} points; {where}")
        return {'FINISHED'}


def menu_func_export(self, context):
    self.layout.operator(EXPORT_SCENE_OT_bevy_hair.bl_idname, text="bevy_hair (.hair)")


def register():
    bpy.utils.register_class(EXPORT_SCENE_OT_bevy_hair)
    bpy.types.TOPBAR_MT_file_export.append(menu_func_export)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_func_export)
    bpy.utils.unregister_class(EXPORT_SCENE_OT_bevy_hair)


def _main(argv):
    import argparse
    parser = argparse.ArgumentParser(prog="bevy_hair_export.py", description="Export an object's hair as .hair")
    parser.add_argument("--object", required=True, help="name of the mesh with particle hair, or of the hair curves")
    parser.add_argument("--out", required=True, help=".hair file to write")
    args = parser.parse_args(argv)
    obj = bpy.data.objects.get(args.object)
    if obj is None:
        raise ValueError(f"no object named '{args.object}' in this file")
    result = export_hair(obj, args.out, bpy.context.evaluated_depsgraph_get())
    print("bevy_hair export:", result)


if __name__ == "__main__":
    # Run with `-- ARGS`: export headless. Run without: register the add-on in this session.
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if args:
        _main(args)
    else:
        register()
