# SPDX-License-Identifier: MIT OR Apache-2.0
"""Headless check that the exporter refuses what it cannot export, with a clear message.

    blender -b --factory-startup --python-exit-code 1 --python tools/blender/test_refusals.py
"""
import importlib.util
import os
import tempfile

import bpy

spec = importlib.util.spec_from_file_location(
    "bevy_hair_export", os.path.join(os.path.dirname(os.path.abspath(__file__)), "bevy_hair_export.py"))
exporter = importlib.util.module_from_spec(spec)
spec.loader.exec_module(exporter)
out = os.path.join(tempfile.mkdtemp(), "x.hair")


def refused(what, obj, expect):
    try:
        exporter.export_hair(obj, out, bpy.context.evaluated_depsgraph_get())
    except ValueError as e:
        assert expect in str(e), (what, str(e))
        print(f"refused ({what}): {e}")
        return
    raise AssertionError(f"{what}: exported, should have been refused")


refused("no object", None, "no object")
refused("mesh without hair", bpy.data.objects["Cube"], "has no hair")
refused("camera", bpy.data.objects["Camera"], "not a mesh")
# A hair-curves object with no curves.
bpy.context.view_layer.objects.active = bpy.data.objects["Cube"]
bpy.ops.object.curves_empty_hair_add()
refused("empty hair curves", bpy.context.active_object, "no hair strands")
# Strand length limits, on the writer's checks directly.
for points, expect in ((1, "at least 2"), (65_537, "at most 65536")):
    try:
        exporter._check([[(0.0, 0.0, 0.0)] * points], "test")
        raise AssertionError(f"{points} points accepted")
    except ValueError as e:
        assert expect in str(e), str(e)
        print(f"refused ({points}-point strand): {e}")
# The operator reports the error instead of raising.
exporter.register()
bpy.context.view_layer.objects.active = bpy.data.objects["Cube"]
try:
    result = bpy.ops.export_scene.bevy_hair(filepath=out)
except RuntimeError as e:  # background mode turns an ERROR report into RuntimeError
    result = str(e)
print("operator on a mesh without hair:", result)
assert "has no hair" in str(result) or result == {'CANCELLED'}, result
print("all refusals OK")
