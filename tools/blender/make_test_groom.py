# SPDX-License-Identifier: MIT OR Apache-2.0
"""Build a test head and groom in Blender and export them for bevy_hair's round-trip tests.

    blender -b --factory-startup --python-exit-code 1 \
        --python tools/blender/make_test_groom.py -- --out assets/blender

Writes to OUT:
  head_{point,corner}_{float,byte}.glb  the head (UV sphere, r = 0.1 m) with the scalp
                                        painted black, one colour-attribute variant each
  groom_particles.hair                  particle hair (64 combed parents x 8 points)
  groom_curves.hair                     the same hair as a hair-curves object, resampled
                                        to 4..8 points per strand, with thickness
  strands.json                          Blender's own strand points, engine axes
  summary.json                          versions, options, colour verdicts, counts
"""

import argparse
import importlib.util
import json
import math
import os
import struct
import sys

import bpy
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
SCALP_Z = 0.02  # Blender z above which the head is scalp (painted black)
HAIR_LENGTH = 0.15
HAIR_STEP = 7  # Blender 3.4 makes hair_step + 1 keys per strand
STRANDS = 64


def load_exporter():
    spec = importlib.util.spec_from_file_location("bevy_hair_export", os.path.join(HERE, "bevy_hair_export.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def f32(x):
    """Round to f32 and then to 7 decimals: what the .hair file holds, printed stably."""
    return round(struct.unpack("<f", struct.pack("<f", x))[0], 7)


def make_head():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, segments=32, ring_count=16, location=(0, 0, 0))
    head = bpy.context.active_object
    head.name = head.data.name = "Head"
    # The scalp as a vertex group too: particle density follows it.
    group = head.vertex_groups.new(name="scalp")
    group.add([v.index for v in head.data.vertices if v.co.z > SCALP_Z], 1.0, 'REPLACE')
    return head


# --- glTF colour variants ---------------------------------------------------------------

def paint(mesh, domain, data_type):
    attr = mesh.color_attributes.new(name="scalp_paint", type=data_type, domain=domain)
    black, white = (0.0, 0.0, 0.0, 1.0), (1.0, 1.0, 1.0, 1.0)
    if domain == 'POINT':
        for v, d in zip(mesh.vertices, attr.data):
            d.color = black if v.co.z > SCALP_Z else white
    else:
        for loop, d in zip(mesh.loops, attr.data):
            d.color = black if mesh.vertices[loop.vertex_index].co.z > SCALP_Z else white
    idx = mesh.color_attributes.find(attr.name)
    # The glTF exporter writes the *render* colour attribute as COLOR_0.
    mesh.color_attributes.active_color = attr
    mesh.color_attributes.render_color_index = idx
    return attr


def read_glb(path):
    """POSITION and COLOR_0 (as floats 0..1) of every primitive of a .glb, in pure Python."""
    with open(path, "rb") as f:
        data = f.read()
    magic, _version, _length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF", path
    json_len, json_type = struct.unpack_from("<II", data, 12)
    assert json_type == 0x4E4F534A  # "JSON"
    doc = json.loads(data[20:20 + json_len])
    bin_at = 20 + json_len
    bin_len, bin_type = struct.unpack_from("<II", data, bin_at)
    assert bin_type == 0x004E4942  # "BIN\0"
    blob = data[bin_at + 8:bin_at + 8 + bin_len]

    def accessor(i):
        acc = doc["accessors"][i]
        view = doc["bufferViews"][acc["bufferView"]]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc["type"]]
        fmt, size, scale = {5126: ("f", 4, None), 5121: ("B", 1, 255.0), 5123: ("H", 2, 65535.0)}[acc["componentType"]]
        stride = view.get("byteStride", width * size)
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        out = []
        for n in range(acc["count"]):
            vals = struct.unpack_from(f"<{width}{fmt}", blob, start + n * stride)
            out.append(tuple(v / scale for v in vals) if scale else vals)
        return out

    prims = []
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            attrs = prim["attributes"]
            prims.append((accessor(attrs["POSITION"]),
                          accessor(attrs["COLOR_0"]) if "COLOR_0" in attrs else None))
    return prims


def check_glb(path):
    """Every vertex must be black above the scalp line (glTF y = Blender z) and white below."""
    wrong = total = 0
    has_color = True
    for positions, colors in read_glb(path):
        if colors is None:
            has_color = False
            continue
        for p, c in zip(positions, colors):
            total += 1
            want = 0.0 if p[1] > SCALP_Z else 1.0
            if any(abs(c[k] - want) > 0.01 for k in range(3)):
                wrong += 1
    ok = has_color and total > 0 and wrong == 0
    return {"ok": ok, "has_color_0": has_color, "vertices": total, "wrong_vertices": wrong}


def export_variants(head, out):
    verdicts = {}
    for domain, data_type, name in [('POINT', 'FLOAT_COLOR', "head_point_float.glb"),
                                    ('CORNER', 'BYTE_COLOR', "head_corner_byte.glb"),
                                    ('POINT', 'BYTE_COLOR', "head_point_byte.glb"),
                                    ('CORNER', 'FLOAT_COLOR', "head_corner_float.glb")]:
        attr = paint(head.data, domain, data_type)
        bpy.ops.object.select_all(action='DESELECT')
        head.select_set(True)
        bpy.context.view_layer.objects.active = head
        path = os.path.join(out, name)
        bpy.ops.export_scene.gltf(filepath=path, export_format='GLB', export_colors=True,
                                  use_selection=True, export_apply=True, export_materials='NONE',
                                  export_animations=False, export_extras=False)
        verdicts[name] = dict(check_glb(path), domain=domain, data_type=data_type)
        print(f"colour variant {name}: {'RIGHT' if verdicts[name]['ok'] else 'WRONG'} {verdicts[name]}")
        head.data.color_attributes.remove(attr)
    return verdicts


# --- particle hair ------------------------------------------------------------------------

def grow_particles(head):
    head.modifiers.new("hair", 'PARTICLE_SYSTEM')
    psys = head.particle_systems[0]
    psys.name = "hair"
    psys.seed = 1
    psys.vertex_group_density = "scalp"
    s = psys.settings
    s.name = "hair"
    s.type = 'HAIR'
    s.count = STRANDS
    s.hair_length = HAIR_LENGTH
    s.hair_step = HAIR_STEP
    s.child_type = 'NONE'
    # Emission from faces is not reproducible in Blender 3.4 (the roots change from run to
    # run whatever the seed); from vertices, stepped not random, it is.
    s.emit_from = 'VERT'
    s.use_emit_random = False
    return psys


def comb(head, psys):
    """Place every key: straight out along the root normal, bent down and back with k^2."""
    # Particle edit mode once, so the original system holds editable hair keys.
    bpy.context.view_layer.objects.active = head
    bpy.ops.object.mode_set(mode='PARTICLE_EDIT')
    bpy.ops.object.mode_set(mode='OBJECT')
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = head.evaluated_get(depsgraph)
    mod = ev.modifiers["hair"]
    pe = ev.particle_systems["hair"]
    step = HAIR_LENGTH / HAIR_STEP
    combed = []
    for i, (p, q) in enumerate(zip(psys.particles, pe.particles)):
        root = q.hair_keys[0].co_object(ev, mod, q)
        normal = root.normalized()
        side = 0.0005 * ((i % 5) - 2)  # a little spread so strands differ
        strand = [root.copy()]
        for k in range(1, len(p.hair_keys)):
            bend = Vector((side * k, 0.0012 * k * k, -0.0018 * k * k))  # back (+y), down (-z)
            target = root + normal * (step * k) + bend
            # Write the original key through the evaluated object/modifier/particle: that
            # is the frame the hair lives in, and the edit then survives re-evaluation.
            p.hair_keys[k].co_object_set(ev, mod, q, target)
            strand.append(target)
        combed.append(strand)
    bpy.context.view_layer.update()
    return combed


def read_particles(head):
    """Blender's strand points, straight from the evaluated particle system."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = head.evaluated_get(depsgraph)
    mod = ev.modifiers["hair"]
    return [[k.co_object(ev, mod, p) for k in p.hair_keys]
            for p in ev.particle_systems["hair"].particles]


# --- hair curves ----------------------------------------------------------------------------

def make_curves(head):
    """The particle hair as a hair-curves object on the head, under its own transform, with
    a radius per point and 4..8 points per strand (a Resample Curve node)."""
    bpy.ops.object.select_all(action='DESELECT')
    head.select_set(True)
    bpy.context.view_layer.objects.active = head
    before = set(bpy.data.objects)
    bpy.ops.curves.convert_from_particle_system()
    obj = next(o for o in bpy.data.objects if o not in before)
    obj.name = obj.data.name = "HairCurves"
    obj.data.surface = head
    # Move the object but not the hair: positions go through both world matrices.
    world = Matrix.Translation((0.01, -0.02, 0.05)) @ Matrix.Rotation(math.radians(30), 4, 'Z')
    local = world.inverted() @ obj.matrix_world
    positions = obj.data.attributes["position"]
    flat = [0.0] * (3 * len(positions.data))
    positions.data.foreach_get("vector", flat)
    for i in range(0, len(flat), 3):
        p = local @ Vector(flat[i:i + 3])
        flat[i:i + 3] = p[:]
    positions.data.foreach_set("vector", flat)
    obj.matrix_world = world
    radius = obj.data.attributes.get("radius") or obj.data.attributes.new("radius", 'FLOAT', 'POINT')
    offsets = [0] * (len(obj.data.curves) + 1)
    obj.data.curve_offset_data.foreach_get("value", offsets)
    radii = [0.0] * len(radius.data)
    for c in range(len(offsets) - 1):
        n = offsets[c + 1] - offsets[c]
        for j in range(n):
            radii[offsets[c] + j] = 0.00005 * (2.0 - j / (n - 1))  # radius 0.1 mm at the root, 0.05 mm at the tip
    radius.data.foreach_set("value", radii)
    obj.data.update_tag()
    add_resample(obj)
    return obj


def add_resample(obj):
    tree = bpy.data.node_groups.new("resample", 'GeometryNodeTree')
    tree.inputs.new('NodeSocketGeometry', "Geometry")
    tree.outputs.new('NodeSocketGeometry', "Geometry")
    n_in = tree.nodes.new('NodeGroupInput')
    n_out = tree.nodes.new('NodeGroupOutput')
    index = tree.nodes.new('GeometryNodeInputIndex')
    mod5 = tree.nodes.new('ShaderNodeMath')
    mod5.operation = 'MODULO'
    mod5.inputs[1].default_value = 5.0
    add4 = tree.nodes.new('ShaderNodeMath')
    add4.operation = 'ADD'
    add4.inputs[1].default_value = 4.0
    resample = tree.nodes.new('GeometryNodeResampleCurve')
    resample.mode = 'COUNT'
    links = tree.links
    links.new(index.outputs[0], mod5.inputs[0])
    links.new(mod5.outputs[0], add4.inputs[0])
    links.new(add4.outputs[0], resample.inputs["Count"])
    links.new(n_in.outputs[0], resample.inputs["Curve"])
    links.new(resample.outputs[0], n_out.inputs[0])
    mod = obj.modifiers.new("resample", 'NODES')
    mod.node_group = tree


def read_curves(obj):
    """Blender's evaluated curve points through the point API, in the surface's space."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(depsgraph)
    data = ev.data
    to_scalp = data.surface.matrix_world.inverted() @ ev.matrix_world
    strands, radii = [], []
    for curve in data.curves:
        pts = curve.points
        strands.append([to_scalp @ Vector(p.position) for p in pts])
        radii.append([2.0 * p.radius for p in pts])
    return strands, radii


# --- main ------------------------------------------------------------------------------------

def engine_json(strands):
    return [[[f32(p[0]), f32(p[2]), f32(-p[1])] for p in s] for s in strands]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", required=True)
    args = parser.parse_args(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    exporter = load_exporter()

    head = make_head()
    verdicts = export_variants(head, out)

    psys = grow_particles(head)
    combed = comb(head, psys)
    particles = read_particles(head)
    # The evaluated hair must be the combed shape, not the default straight one.
    worst = max((a - b).length for s, t in zip(combed, particles) for a, b in zip(s, t))
    assert len(particles) == STRANDS and all(len(s) == HAIR_STEP + 1 for s in particles), "unexpected key count"
    assert worst < 1e-6, f"combed hair not seen by the evaluated export: off by {worst} m"
    # Roots sit on the sphere's vertices, on the scalp.
    assert all(abs(s[0].length - 0.1) < 1e-5 and s[0].z > SCALP_Z for s in particles), "roots off the scalp"

    depsgraph = bpy.context.evaluated_depsgraph_get()
    res_p = exporter.export_hair(head, os.path.join(out, "groom_particles.hair"), depsgraph)
    print("particles:", res_p)

    curves = make_curves(head)
    curve_strands, curve_thickness = read_curves(curves)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    res_c = exporter.export_hair(curves, os.path.join(out, "groom_curves.hair"), depsgraph)
    print("curves:", res_c)

    strands = {
        "axes": "engine (x, z, -y) of Blender, metres, +Y up; scalp's object space",
        "particles": {"object": res_p["object"], "scalp": res_p["scalp"], "strands": engine_json(particles)},
        "curves": {"object": res_c["object"], "scalp": res_c["scalp"], "strands": engine_json(curve_strands),
                   "thickness": [[f32(t) for t in s] for s in curve_thickness]},
    }
    with open(os.path.join(out, "strands.json"), "w") as f:
        json.dump(strands, f, separators=(",", ":"), sort_keys=True)
        f.write("\n")

    summary = {
        "blender": bpy.app.version_string,
        "gltf_exporter": ".".join(str(v) for v in __import__("io_scene_gltf2").bl_info["version"]),
        "gltf_options": {"export_format": "GLB", "export_colors": True, "use_selection": True,
                         "export_apply": True, "export_materials": "NONE"},
        "head": {"object": head.name, "uv_sphere": {"radius": 0.1, "segments": 32, "rings": 16},
                 "scalp": f"Blender z > {SCALP_Z} (engine y > {SCALP_Z}) black, the rest white"},
        "colour_variants": verdicts,
        "particles": {"file": "groom_particles.hair", "emit_from": "VERT", "use_emit_random": False,
                      "seed": 1, "hair_length": HAIR_LENGTH, "hair_step": HAIR_STEP,
                      "strands": res_p["strands"], "points": res_p["points"],
                      "points_per_strand": res_p["points_per_strand"], "thickness": res_p["thickness"],
                      "scalp": res_p["scalp"], "combed_max_error_m": 0.0 if worst < 1e-7 else f32(worst)},
        "curves": {"file": "groom_curves.hair", "made_by": "curves.convert_from_particle_system + Resample Curve (4..8 points)",
                   "strands": res_c["strands"], "points": res_c["points"],
                   "points_per_strand": res_c["points_per_strand"], "thickness": res_c["thickness"],
                   "scalp": res_c["scalp"]},
    }
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2, sort_keys=True)
        f.write("\n")
    print("summary:", json.dumps({k: v["ok"] for k, v in verdicts.items()}))


main()
