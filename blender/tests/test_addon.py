"""The morphlod LODs add-on in real Blender, headless:

    blender -b --factory-startup --python-exit-code 1 --python blender/tests/test_addon.py

(.ci/run runs it with the package installed in $BLENDER_USER_SCRIPTS/modules and the add-on
zipped in $MORPHLOD_ADDON_ZIP.) It installs and enables the add-on as a user would (from the zip,
or from blender/morphlod_lods without one), imports assets/makehuman_face.glb with Blender's glTF
importer (52 shape keys, the 'expressions' action), gives one key a slider range and a driver and the object a vertex group,
runs "Make LODs (keep shape keys)" at 0.5, 0.25 and 0.1 and checks every level against the
original: each shape key's coordinates at the kept vertices bit for bit, key names, values,
slider ranges, relative keys, vertex group weights, UV maps (each corner's UVs are a corner of the source vertex),
materials, the action and the re-targeted driver, triangle counts against the requested
fractions, and the time. Then "Export LODs" writes the set with morphlod's
exporter, checked by the Khronos glTF validator (.ci/gltf-validator; skipped outside CI when
node or the package is missing), and one frame of the original and the LODs with jawOpen at 1
is rendered with Workbench to $MORPHLOD_BLENDER_OUT/face_lods.png (and to docs/blender_lods.png
with MORPHLOD_UPDATE_DOCS=1). Any failed check raises, so Blender exits 1.
"""

import json
import math
import os
import shutil
import subprocess
import sys
import time

import bpy
import numpy as np

# Debian 12's Blender 3.4.1 glTF importer still uses np.bool, which its numpy (1.24) removed;
# the alias is what the importer meant. Only the importer needs it, not the add-on.
if not hasattr(np, "bool"):
    np.bool = bool

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FACE = os.path.join(REPO, "assets", "makehuman_face.glb")
OUT = os.environ.get("MORPHLOD_BLENDER_OUT", os.path.join(REPO, "target", "blender"))
FRACTIONS = [0.5, 0.25, 0.1]
# The goal is 3 levels in under 10 s on the 2-core machine (python/README.md has the figures);
# the check allows a loaded machine 3 times that unless MORPHLOD_BLENDER_GOAL_S says otherwise.
TIME_GOAL_S = float(os.environ.get("MORPHLOD_BLENDER_GOAL_S", "30"))


def in_ci():
    return os.environ.get("CI", "").lower() not in ("", "0", "false")


def check(condition, message):
    if not condition:
        raise AssertionError(message)


def enable_addon():
    archive = os.environ.get("MORPHLOD_ADDON_ZIP")
    if archive:
        bpy.ops.preferences.addon_install(filepath=archive, overwrite=True)
    else:
        sys.path.insert(0, os.path.join(REPO, "blender"))
    bpy.ops.preferences.addon_enable(module="morphlod_lods")
    check(hasattr(bpy.ops.morphlod, "make_lods"), "the add-on registered no operator")


def import_face():
    bpy.ops.import_scene.gltf(filepath=FACE)
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    check(len(meshes) == 1, f"expected one mesh, got {meshes}")
    face = meshes[0]
    keys = face.data.shape_keys.key_blocks
    check(len(keys) == 53, f"expected the basis and 52 shape keys, got {len(keys)}")
    # A slider range, a value and a driver to carry over (the import has none).
    keys["jawOpen"].slider_max = 1.5
    keys["jawOpen"].value = 0.25
    group = face.vertex_groups.new(name="jaw")
    group.add(list(range(0, len(face.data.vertices), 3)), 0.75, "REPLACE")
    face["smile"] = 0.5
    curve = face.data.shape_keys.driver_add('key_blocks["mouthSmileLeft"].value')
    var = curve.driver.variables.new()
    var.name = "smile"
    var.targets[0].id_type = "OBJECT"
    var.targets[0].id = face
    var.targets[0].data_path = '["smile"]'
    curve.driver.expression = "smile"
    return face


def corners(mesh):
    """Per loop: its vertex and, per UV map, its UV."""
    n = len(mesh.loops)
    vertex = np.empty(n, np.int32)
    mesh.loops.foreach_get("vertex_index", vertex)
    uvs = {}
    for layer in mesh.uv_layers:
        uv = np.empty(2 * n, np.float32)
        layer.data.foreach_get("uv", uv)
        uvs[layer.name] = uv.reshape(-1, 2)
    return vertex, uvs


def key_co(block):
    co = np.empty(3 * len(block.data), np.float32)
    block.data.foreach_get("co", co)
    return co.reshape(-1, 3)


def check_lod(face, lod, fraction, source_triangles):
    name = lod.name
    mesh = lod.data
    triangles = len(mesh.polygons)
    budget = math.floor(fraction * source_triangles)
    check(all(len(p.vertices) == 3 for p in mesh.polygons), f"{name}: not all triangles")
    # The finest step with at most the budget: at most 2 % under it on this mesh.
    check(0.98 * budget <= triangles <= budget, f"{name}: {triangles} triangles for {fraction} of {source_triangles}")
    source = np.empty(len(mesh.vertices), np.int32)
    mesh.attributes["morphlod_source_vertex"].data.foreach_get("value", source)
    check(len(np.unique(source)) == len(source), f"{name}: a source vertex kept twice")

    keys, lod_keys = face.data.shape_keys, mesh.shape_keys
    check(len(lod_keys.key_blocks) == len(keys.key_blocks), f"{name}: shape key count")
    for block, copy in zip(keys.key_blocks, lod_keys.key_blocks):
        what = f"{name}: key {block.name}"
        check(copy.name == block.name, f"{what}: named {copy.name}")
        exact = np.array_equal(key_co(copy).view(np.uint32), key_co(block)[source].view(np.uint32))
        check(exact, f"{what}: coordinates differ from the original's at the kept vertices")
        check(copy.value == block.value, f"{what}: value {copy.value} != {block.value}")
        check((copy.slider_min, copy.slider_max) == (block.slider_min, block.slider_max), f"{what}: slider range")
        check(copy.relative_key.name == block.relative_key.name, f"{what}: relative key")
        check(copy.mute == block.mute and copy.vertex_group == block.vertex_group, f"{what}: mute / group")
    check(lod_keys.animation_data.action == keys.animation_data.action, f"{name}: the shape-key action")
    drivers = lod_keys.animation_data.drivers
    check(len(drivers) == 1 and drivers[0].data_path == 'key_blocks["mouthSmileLeft"].value', f"{name}: driver")
    check(drivers[0].driver.variables[0].targets[0].id == lod, f"{name}: driver not re-targeted at the LOD")
    check(lod_keys.key_blocks["mouthSmileLeft"].value == 0.5, f"{name}: the driver does not drive")

    check([m.name for m in mesh.materials] == [m.name for m in face.data.materials], f"{name}: materials")
    check([g.name for g in lod.vertex_groups] == ["jaw"], f"{name}: vertex groups")
    weights = [{e.group: e.weight for e in v.groups}.get(0, 0.0) for v in mesh.vertices]
    check(weights == [0.75 if s % 3 == 0 else 0.0 for s in source.tolist()], f"{name}: vertex group weights")
    check(lod.matrix_world == face.matrix_world, f"{name}: placement")
    # Every corner's UVs are those of a corner of its source vertex (the seams kept, no UV
    # made up); the pairs are compared as bits.
    src_vertex, src_uvs = corners(face.data)
    lod_vertex, lod_uvs = corners(mesh)
    check(sorted(lod_uvs) == sorted(src_uvs), f"{name}: UV maps {sorted(lod_uvs)}")
    for uv_name, uv in src_uvs.items():
        have = set(zip(src_vertex.tolist(), map(tuple, uv.view(np.uint32).tolist())))
        pairs = zip(source[lod_vertex].tolist(), map(tuple, lod_uvs[uv_name].view(np.uint32).tolist()))
        check(all(p in have for p in pairs), f"{name}: a corner's UV in {uv_name} is no corner of its vertex")
    return triangles, len(source)


def validate(path):
    harness = os.path.join(REPO, ".ci", "gltf-validator")
    node = shutil.which("node")
    if node is None or not os.path.isdir(os.path.join(harness, "node_modules", "gltf-validator")):
        check(not in_ci(), "node or the glTF validator is missing under CI: run .ci/run's install")
        print(f"skipped: the glTF validator (node and `(cd .ci/gltf-validator && npm ci)`) for {path}")
        return
    run = subprocess.run([node, os.path.join(harness, "validate.mjs"), path], capture_output=True, text=True)
    report = json.loads(run.stdout.strip().splitlines()[-1])
    print(f"validator: {report['errors']} errors, {report['warnings']} warnings: {report['messages'][:5]}")
    check(run.returncode == 0 and report["errors"] == 0, f"the validator found errors: {report}")


def check_export(path, lods):
    with open(path, "rb") as f:
        data = f.read()
    length = int.from_bytes(data[12:16], "little")
    document = json.loads(data[20 : 20 + length])
    check("MSFT_lod" in document.get("extensionsUsed", []), "no MSFT_lod in the exported file")
    meshes = document["meshes"]
    check(len(meshes) == len(lods) + 1, f"{len(meshes)} meshes for the original and {len(lods)} LODs")
    for mesh in meshes:
        targets = mesh["primitives"][0].get("targets", [])
        check(len(targets) == 52, f"{mesh['name']}: {len(targets)} targets")


def render(face, lods, path):
    """One Workbench frame: the original and its LODs side by side, jawOpen at 1, each labelled."""
    scene = bpy.context.scene
    objects = [face] + lods
    width = 0.42
    labels = ["original"] + [f"LOD{i}: {len(o.data.polygons)} triangles" for i, o in enumerate(lods, 1)]
    for i, (obj, text) in enumerate(zip(objects, labels)):
        obj.location.x += i * width
        # The imported action sets every key at each frame: off, so jawOpen shows at 1.
        obj.data.shape_keys.animation_data.action = None
        obj.data.shape_keys.key_blocks["jawOpen"].value = 1.0
        curve = bpy.data.curves.new(f"label{i}", "FONT")
        curve.body = text
        curve.align_x = "CENTER"
        curve.size = 0.035
        label = bpy.data.objects.new(f"label{i}", curve)
        label.location = (i * width, 0.0, 0.52)
        label.rotation_euler = (math.pi / 2, 0.0, 0.0)
        scene.collection.objects.link(label)
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = width * len(objects)
    camera.location = (width * (len(objects) - 1) / 2, -3.0, 0.685)
    camera.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.show_cavity = True
    scene.display.shading.color_type = "TEXTURE"
    scene.render.resolution_x = 1200
    scene.render.resolution_y = 330
    scene.render.film_transparent = False
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path)
    pixels = np.array(image.pixels[:]).reshape(-1, 4)
    check(pixels[:, :3].std() > 0.05, f"{path}: the render is blank")


def main():
    os.makedirs(OUT, exist_ok=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    enable_addon()
    face = import_face()
    bpy.context.view_layer.objects.active = face
    face.data.calc_loop_triangles()
    source_triangles = len(face.data.loop_triangles)

    # Without the package the operator says how to install it and changes nothing.
    saved = sys.modules.get("morphlod")
    sys.modules["morphlod"] = None  # makes `import morphlod` fail
    try:
        bpy.ops.morphlod.make_lods()
        raise AssertionError("make_lods ran without the package")
    except RuntimeError as e:
        check("pip install --no-deps --target" in str(e), f"no install hint: {e}")
    finally:
        if saved is None:
            del sys.modules["morphlod"]
        else:
            sys.modules["morphlod"] = saved
    check(f"{face.name}_LODs" not in bpy.data.collections, "a collection made without the package")

    start, cpu = time.perf_counter(), time.process_time()
    result = bpy.ops.morphlod.make_lods(levels=", ".join(map(str, FRACTIONS)), poses="KEYS")
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    check(result == {"FINISHED"}, f"make_lods: {result}")
    lods = sorted(bpy.data.collections[f"{face.name}_LODs"].objects, key=lambda o: o.name)
    # Evaluate drivers and world matrices.
    bpy.context.scene.frame_set(bpy.context.scene.frame_current)
    check(len(lods) == len(FRACTIONS), f"{len(lods)} LOD objects")
    for lod, fraction in zip(lods, FRACTIONS):
        triangles, vertices = check_lod(face, lod, fraction, source_triangles)
        print(f"{lod.name}: {triangles} triangles ({fraction}), {vertices} vertices, every key exact")
    # CPU time (all threads) beside wall time: on a machine shared with other work it is the
    # steadier figure, and the simplification runs mostly on one thread.
    print(f"make_lods: {len(FRACTIONS)} levels of {source_triangles} triangles, 52 keys, in {elapsed:.2f} s ({cpu:.2f} s CPU)")
    check(elapsed < TIME_GOAL_S, f"make_lods took {elapsed:.2f} s, the goal is under {TIME_GOAL_S} s")

    exported = os.path.join(OUT, "face_lods.glb")
    start, cpu = time.perf_counter(), time.process_time()
    result = bpy.ops.morphlod.export_lods(filepath=exported)
    check(result == {"FINISHED"}, f"export_lods: {result}")
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    print(f"export_lods: {exported} ({os.path.getsize(exported)} bytes) in {elapsed:.2f} s ({cpu:.2f} s CPU)")
    check_export(exported, lods)
    validate(exported)

    picture = os.path.join(OUT, "face_lods.png")
    render(face, lods, picture)
    print(f"rendered {picture}")
    if os.environ.get("MORPHLOD_UPDATE_DOCS"):
        shutil.copyfile(picture, os.path.join(REPO, "docs", "blender_lods.png"))
    print("blender: 1 passed, 0 failed")


main()
