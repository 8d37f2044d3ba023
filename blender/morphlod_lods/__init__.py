"""morphlod LODs: levels of detail of a mesh with shape keys that keep every shape key.

Blender's Decimate modifier cannot be applied to a mesh with shape keys, and decimating once
per key gives results of different vertex counts. morphlod only collapses edges onto existing
vertices, so every level's vertices are a subset of the original's and every shape key carries
over exactly. One collapse sequence is simplified over a set of poses at once (every key at 1,
the shape-key action's keyframes, or the basis only), so each level's triangles serve every
pose.

Object > "Make LODs (keep shape keys)" (also in the sidebar's morphlod tab) makes one object per
level in a collection NAME_LODs; "Export LODs (glTF, MSFT_lod)" writes the set with morphlod's
glTF exporter. Both need morphlod's Python package (python/ in morphlod's repository) where
Blender's Python finds it; without it they say how to install it.
"""

bl_info = {
    "name": "morphlod LODs",
    "author": "morphlod",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Object > Make LODs (keep shape keys); Sidebar > morphlod",
    "description": "Levels of detail of meshes with shape keys, every key kept exactly (morphlod)",
    "category": "Object",
}

import os
import sys
import tempfile
import time

import bpy
import numpy as np
from bpy.props import EnumProperty, FloatProperty, PointerProperty, StringProperty, BoolProperty
from bpy_extras.io_utils import ExportHelper

from .lods import LodError, MeshArrays, make_lod


def modules_folder():
    """Blender's user modules folder, where the add-on looks for the package."""
    return bpy.utils.user_resource("SCRIPTS", path="modules")


def install_hint():
    return (
        "morphlod's Python package is not installed for Blender's Python "
        f"{sys.version.split()[0]}: from a clone of morphlod run "
        f'`pip install --no-deps --target "{modules_folder()}" ./python` '
        "(needs a Rust toolchain; or pip install a built wheel the same way) and run again"
    )


def import_morphlod():
    """The morphlod package, or None. Blender puts the user modules folder on sys.path at
    start, except with --factory-startup: then it is added here."""
    try:
        import morphlod
    except ImportError:
        folder = modules_folder()
        if not os.path.isdir(folder) or folder in sys.path:
            return None
        sys.path.append(folder)
        try:
            import morphlod
        except ImportError:
            return None
    return morphlod


def package_or_report(operator):
    """The package, or None with the install hint reported."""
    morphlod = import_morphlod()
    if morphlod is None:
        operator.report({"ERROR"}, install_hint())
    return morphlod


def finish(operator, lines):
    """Prints the result lines (the console, a headless run) and reports them (the status bar)."""
    for line in lines:
        print(line)
    operator.report({"INFO"}, "; ".join(lines))
    return {"FINISHED"}


def parse_levels(text, kind):
    try:
        values = [float(v) for v in text.replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise LodError(f"levels '{text}': give numbers separated by commas") from None
    if not values:
        raise LodError("give at least one level")
    return {"fractions": values} if kind == "FRACTIONS" else {"errors": values}


LEVEL_KINDS = [
    ("FRACTIONS", "Fractions", "Triangle fractions in (0, 1], decreasing: 0.5, 0.25, 0.1"),
    ("ERRORS", "Error", "Error bounds relative to the bounding-box diagonal, increasing: 0.002, 0.01"),
]
POSE_SETS = [
    ("KEYS", "Every key at 1", "The basis and every shape key alone at 1"),
    ("ACTION", "Action keyframes", "The basis and the shape-key action at each of its keyframes"),
    ("BASIS", "Basis only", "Only the basis shape: the keys are carried but not protected"),
]


class LodOptions:
    """The options both operators and the sidebar share."""

    level_kind: EnumProperty(name="Levels", items=LEVEL_KINDS, default="FRACTIONS")
    levels: StringProperty(
        name="Levels",
        default="0.5, 0.25, 0.1",
        description="Fractions of the triangles (0.5, 0.25, 0.1) or error bounds (0.002, 0.01), comma-separated",
    )
    poses: EnumProperty(name="Protect", items=POSE_SETS, default="KEYS")
    use_seams: BoolProperty(
        name="Seams from the UV map",
        default=True,
        description="Keep UV seams (and material borders) in place and never torn; the UV error counts",
    )
    uv_map: StringProperty(name="UV map", default="", description="The UV map whose error counts (empty: the active one)")
    uv_weight: FloatProperty(name="UV weight", default=4.0, min=0.0, description="Weight of the UV error (0: geometry only)")
    distance_weight: FloatProperty(
        name="Distance weight",
        default=4.0,
        min=0.0,
        description="Weight of the distance term: lower error at coarse levels; 0 is much faster",
    )

    def copy_to(self, other):
        for name in ("level_kind", "levels", "poses", "use_seams", "uv_map", "uv_weight", "distance_weight"):
            setattr(other, name, getattr(self, name))

    def draw_options(self, layout):
        layout.prop(self, "level_kind", expand=True)
        layout.prop(self, "levels", text="")
        layout.prop(self, "poses")
        layout.prop(self, "use_seams")
        layout.prop(self, "uv_weight")
        layout.prop(self, "distance_weight")


class MorphlodSettings(LodOptions, bpy.types.PropertyGroup):
    """The sidebar's settings, per scene."""


def arrays_of(obj, options):
    uv_name = options.uv_map or (obj.data.uv_layers.active.name if obj.data.uv_layers.active else None)
    return MeshArrays(obj, options.use_seams, uv_name)


def lod_collection(obj):
    """The collection NAME_LODs beside the object's, emptied of an earlier run's objects."""
    name = f"{obj.name}_LODs"
    collection = bpy.data.collections.get(name)
    if collection is None:
        collection = bpy.data.collections.new(name)
        parent = obj.users_collection[0] if obj.users_collection else bpy.context.scene.collection
        parent.children.link(collection)
    for old in list(collection.objects):
        mesh = old.data
        bpy.data.objects.remove(old)
        if mesh is not None and mesh.users == 0:
            bpy.data.meshes.remove(mesh)
    return collection


class MORPHLOD_OT_make_lods(LodOptions, bpy.types.Operator):
    """Make levels of detail of the active mesh that keep every shape key exactly"""

    bl_idname = "morphlod.make_lods"
    bl_label = "Make LODs (keep shape keys)"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH" and obj.mode == "OBJECT"

    def draw(self, context):
        self.draw_options(self.layout)

    def execute(self, context):
        morphlod = package_or_report(self)
        if morphlod is None:
            return {"CANCELLED"}
        obj = context.active_object
        wm = context.window_manager
        try:
            levels_kw = parse_levels(self.levels, self.level_kind)
            start = time.perf_counter()
            arrays = arrays_of(obj, self)
            wm.progress_begin(0, 100)
            levels = morphlod.simplify(
                arrays.positions,
                arrays.triangles,
                arrays.targets if arrays.key_names else None,
                target_names=arrays.key_names,
                poses=arrays.pose_weights(self.poses),
                uvs=arrays.uvs,
                uv_weight=self.uv_weight,
                distance_weight=self.distance_weight,
                progress=lambda stage, fraction: wm.progress_update(100 * fraction),
                **levels_kw,
            )
        except (LodError, morphlod.MorphlodError, ValueError, TypeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        simplified = time.perf_counter() - start
        collection = lod_collection(obj)
        collection["morphlod_source"] = obj.name
        for name in ("level_kind", "levels", "poses", "use_seams", "uv_map", "uv_weight", "distance_weight"):
            collection[f"morphlod_{name}"] = getattr(self, name)
        lines = []
        for i, level in enumerate(levels, start=1):
            lod = make_lod(arrays, level, f"{obj.name}_LOD{i}", collection)
            triangles = len(level.triangles)
            lod["morphlod_fraction"] = level.fraction
            lod["morphlod_error"] = level.error
            lines.append(
                f"LOD{i}: {triangles} triangles ({100 * triangles / arrays.triangle_count:.1f} % of "
                f"{arrays.triangle_count}), error {100 * level.error:.3f} % of the diagonal"
            )
        total = time.perf_counter() - start
        lines.append(
            f"{len(levels)} LODs of {obj.name} ({len(arrays.key_names)} shape keys) in {total:.2f} s "
            f"(simplification {simplified:.2f} s) in collection {collection.name}"
        )
        return finish(self, lines)


class MORPHLOD_OT_export_lods(ExportHelper, bpy.types.Operator):
    """Export the active mesh's LOD set (made by Make LODs) as one glTF binary with MSFT_lod,
    written by morphlod's exporter: every level keeps all shape keys, UVs, the material and
    the shape-key animation"""

    bl_idname = "morphlod.export_lods"
    bl_label = "Export LODs (glTF, MSFT_lod)"
    filename_ext = ".glb"
    filter_glob: StringProperty(default="*.glb", options={"HIDDEN"})

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH" and f"{obj.name}_LODs" in bpy.data.collections

    def execute(self, context):
        morphlod = package_or_report(self)
        if morphlod is None:
            return {"CANCELLED"}
        obj = context.active_object
        collection = bpy.data.collections[f"{obj.name}_LODs"]
        settings = {n[len("morphlod_"):]: collection[n] for n in collection.keys() if n.startswith("morphlod_")}
        try:
            if settings.get("source") != obj.name:
                raise LodError(f"{collection.name} was not made from {obj.name}: run Make LODs first")
            start = time.perf_counter()
            with tempfile.TemporaryDirectory() as folder:
                source = os.path.join(folder, f"{obj.name}.glb")
                export_source(context, obj, source)
                written = morphlod.load(source)
                arrays = MeshArrays(obj, False, None)
                weights = file_pose_weights(arrays, settings["poses"], written.target_names)
                levels = morphlod.export(
                    source,
                    self.filepath,
                    pose_weights=weights,
                    uv_weight=settings["uv_weight"],
                    distance_weight=settings["distance_weight"],
                    **parse_levels(settings["levels"], settings["level_kind"]),
                )
        except (LodError, morphlod.MorphlodError, ValueError, TypeError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        lines = [
            f"LOD{i}: {len(level.triangles)} triangles, error {100 * level.error:.3f} % of the diagonal"
            for i, level in enumerate(levels)
        ]
        lines.append(f"wrote {self.filepath} in {time.perf_counter() - start:.2f} s")
        return finish(self, lines)


def export_source(context, obj, path):
    """The object alone as Blender's glTF exporter writes it (shape keys, UVs, normals,
    material, shape-key animation), for morphlod's exporter to read."""
    selected = list(context.selected_objects)
    active = context.view_layer.objects.active
    try:
        for other in selected:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        result = bpy.ops.export_scene.gltf(
            filepath=path,
            export_format="GLB",
            use_selection=True,
            export_apply=False,
            export_morph=True,
            export_animations=True,
        )
        if "FINISHED" not in result:
            raise LodError(f"Blender's glTF exporter did not write {obj.name}")
    finally:
        obj.select_set(False)
        for other in selected:
            other.select_set(True)
        context.view_layer.objects.active = active


def file_pose_weights(arrays, poses, file_targets):
    """The pose set's weights over the targets of the exported file (Blender's exporter
    leaves muted keys out), by name."""
    names = arrays.key_names
    if not file_targets:
        return None
    weights = arrays.pose_weights(poses)
    if weights is None:  # every key at 1: over the file's targets
        t = len(file_targets)
        return np.vstack([np.zeros((1, t), np.float32), np.eye(t, dtype=np.float32)])
    column = [names.index(n) for n in file_targets]
    return weights[:, column]


class VIEW3D_PT_morphlod(bpy.types.Panel):
    bl_label = "morphlod LODs"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "morphlod"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.morphlod_lods
        if import_morphlod() is None:
            box = layout.box()
            box.label(text="morphlod's Python package is missing:", icon="ERROR")
            box.label(text=f"pip install --no-deps --target {modules_folder()} ./python")
        settings.draw_options(layout)
        op = layout.operator(MORPHLOD_OT_make_lods.bl_idname)
        settings.copy_to(op)
        layout.operator(MORPHLOD_OT_export_lods.bl_idname)
        obj = context.active_object
        collection = bpy.data.collections.get(f"{obj.name}_LODs") if obj else None
        if collection is not None:
            for lod in collection.objects:
                if "morphlod_error" in lod:
                    layout.label(
                        text=f"{lod.name}: {len(lod.data.polygons)} tris, error {100 * lod['morphlod_error']:.2f} %"
                    )


def menu_entry(self, context):
    self.layout.separator()
    self.layout.operator(MORPHLOD_OT_make_lods.bl_idname)
    self.layout.operator(MORPHLOD_OT_export_lods.bl_idname)


CLASSES = (MorphlodSettings, MORPHLOD_OT_make_lods, MORPHLOD_OT_export_lods, VIEW3D_PT_morphlod)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.morphlod_lods = PointerProperty(type=MorphlodSettings)
    bpy.types.VIEW3D_MT_object.append(menu_entry)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(menu_entry)
    del bpy.types.Scene.morphlod_lods
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
