"""The add-on's work on Blender data, apart from the operators: a mesh with shape keys as the
arrays morphlod takes, and each level morphlod returns as a new object.

morphlod collapses edges onto existing vertices, so a level's vertices are a subset of the
source's: every shape key of a kept vertex is the source key's coordinates, copied, and every
corner's UVs are the source corner's.
"""

import bpy
import numpy as np


class LodError(Exception):
    """A mesh or option the add-on cannot take; its text is shown to the user."""


class MeshArrays:
    """A mesh object's data for morphlod: its face corners split into *attribute vertices*
    (one per distinct (vertex, UVs, material) combination with seams on, one per vertex
    otherwise), positions, shape-key deltas and UVs per attribute vertex, and triangles over
    them. morphlod welds the copies of a vertex again (they share position and every key's
    delta), keeps the seams between them in place and never tears them."""

    def __init__(self, obj, use_seams, uv_name):
        mesh = obj.data
        self.object = obj
        mesh.calc_loop_triangles()
        self.triangle_count = len(mesh.loop_triangles)
        if self.triangle_count == 0:
            raise LodError(f"{obj.name} has no faces")
        tri_loops = _get(mesh.loop_triangles, "loops", np.int32, 3)
        loop_vertex = _get(mesh.loops, "vertex_index", np.int32, 1)
        loop_total = _get(mesh.polygons, "loop_total", np.int32, 1)
        self.loop_polygon = np.repeat(np.arange(len(mesh.polygons), dtype=np.int32), loop_total)
        self.uv_maps = {
            layer.name: _get(layer.data, "uv", np.float32, 2) for layer in mesh.uv_layers
        }
        if uv_name is not None and uv_name not in self.uv_maps:
            raise LodError(f"{obj.name} has no UV map '{uv_name}'")

        # Attribute vertices: distinct (vertex, every UV map's value, material) per corner.
        columns = [loop_vertex.astype(np.int64)[:, None]]
        if use_seams:
            for uv in self.uv_maps.values():
                columns.append(uv.view(np.uint32).astype(np.int64))
            if len(mesh.materials) > 1:
                material = _get(mesh.polygons, "material_index", np.int32, 1)
                columns.append(material[self.loop_polygon].astype(np.int64)[:, None])
        keys = np.concatenate(columns, axis=1)
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        inverse = inverse.reshape(-1)
        self.attribute_loop = first.astype(np.int64)  # a source corner of each
        self.attribute_vertex = loop_vertex[first].astype(np.int64)  # its Blender vertex
        self.triangles = inverse[tri_loops].astype(np.uint32)

        # Shape keys: absolute coordinates per key, the basis first.
        shape_keys = mesh.shape_keys
        vertex_count = len(mesh.vertices)
        if shape_keys is None:
            self.key_names = []
            self.key_co = [_get(mesh.vertices, "co", np.float32, 3)]
            deltas = np.zeros((0, vertex_count, 3), np.float32)
        else:
            if not shape_keys.use_relative:
                raise LodError(f"{obj.name}'s shape keys are absolute: only relative keys are supported")
            blocks = list(shape_keys.key_blocks)
            reference = shape_keys.reference_key
            if blocks[0] != reference:
                raise LodError(f"{obj.name}'s reference key is not its first")
            self.key_names = [b.name for b in blocks[1:]]
            self.key_co = [_get(b.data, "co", np.float32, 3) for b in blocks]
            index = {b.name: i for i, b in enumerate(blocks)}
            deltas = np.empty((len(blocks) - 1, vertex_count, 3), np.float32)
            for k, block in enumerate(blocks[1:]):
                relative = self.key_co[index[block.relative_key.name]]
                deltas[k] = self.key_co[k + 1] - relative
                if block.vertex_group:
                    deltas[k] *= _group_weights(obj, block.vertex_group, vertex_count)[:, None]
        self.positions = np.ascontiguousarray(self.key_co[0][self.attribute_vertex])
        self.targets = np.ascontiguousarray(deltas[:, self.attribute_vertex])
        self.uvs = None
        if use_seams and uv_name is not None:
            self.uvs = np.ascontiguousarray(self.uv_maps[uv_name][self.attribute_loop])

    def pose_weights(self, poses):
        """The weight sets to protect: ``"KEYS"`` (the basis and every key alone at 1: None,
        morphlod's default), ``"ACTION"`` (the basis and the shape-key action at each of its
        keyframes) or ``"BASIS"``."""
        t = len(self.key_names)
        if poses == "KEYS" or t == 0:
            return None
        if poses == "BASIS":
            return np.zeros((1, t), np.float32)
        shape_keys = self.object.data.shape_keys
        action = shape_keys.animation_data.action if shape_keys.animation_data else None
        if action is None:
            raise LodError(f"{self.object.name}'s shape keys have no action: choose another pose set")
        curves = {}
        for curve in action.fcurves:
            name = _key_of_path(curve.data_path)
            if name in self.key_names:
                curves[name] = curve
        frames = sorted({round(k.co[0], 6) for c in curves.values() for k in c.keyframe_points})
        if not frames:
            raise LodError(f"action '{action.name}' has no shape-key keyframes")
        blocks = shape_keys.key_blocks
        weights = np.zeros((len(frames) + 1, t), np.float32)
        for row, frame in enumerate(frames, start=1):
            for k, name in enumerate(self.key_names):
                curve = curves.get(name)
                weights[row, k] = curve.evaluate(frame) if curve else blocks[name].value
        return weights

    def source_triangles(self, level):
        """A level's triangles as ``(m, 3)`` source Blender vertices and the source corner of
        each of their corners."""
        corners = level.vertices[level.triangles].astype(np.int64)
        return self.attribute_vertex[corners], self.attribute_loop[corners]


def make_lod(arrays, level, name, collection):
    """A new object ``name`` in ``collection`` holding ``level`` of the source object, with
    every shape key, UV map, material, vertex group, modifier, the shape-key action and the
    drivers (re-targeted at the new object where they pointed at the source)."""
    source = arrays.object
    faces_src, corner_loops = arrays.source_triangles(level)
    kept = np.unique(faces_src)
    new_of = np.full(len(source.data.vertices), -1, np.int64)
    new_of[kept] = np.arange(len(kept))
    faces = new_of[faces_src]
    m = len(faces)

    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(kept))
    mesh.vertices.foreach_set("co", arrays.key_co[0][kept].ravel())
    mesh.loops.add(3 * m)
    mesh.loops.foreach_set("vertex_index", faces.ravel().astype(np.int32))
    mesh.polygons.add(m)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * m, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(m, 3, np.int32))
    # Face data from the source face of each triangle's first corner.
    polygon = arrays.loop_polygon[corner_loops[:, 0]]
    src_polygons = source.data.polygons
    mesh.polygons.foreach_set("material_index", _get(src_polygons, "material_index", np.int32, 1)[polygon])
    mesh.polygons.foreach_set("use_smooth", _get(src_polygons, "use_smooth", bool, 1)[polygon])
    mesh.update(calc_edges=True)
    loops = corner_loops.ravel()
    for uv_name, uv in arrays.uv_maps.items():
        layer = mesh.uv_layers.new(name=uv_name)
        layer.data.foreach_set("uv", uv[loops].ravel())
    if source.data.uv_layers.active is not None:
        mesh.uv_layers.active = mesh.uv_layers[source.data.uv_layers.active.name]
    for material in source.data.materials:
        mesh.materials.append(material)
    source_vertex = mesh.attributes.new("morphlod_source_vertex", "INT", "POINT")
    source_vertex.data.foreach_set("value", kept.astype(np.int32))

    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    # The object's custom properties: drivers that read them from the source read them from
    # the copy once re-targeted, as on a duplicate.
    for key in source.keys():
        obj[key] = source[key]
    obj.parent = source.parent
    obj.parent_type = source.parent_type
    obj.parent_bone = source.parent_bone
    obj.matrix_parent_inverse = source.matrix_parent_inverse.copy()
    obj.matrix_basis = source.matrix_basis.copy()
    _copy_vertex_groups(source, obj, kept)
    _copy_shape_keys(source, obj, arrays, kept)
    _copy_modifiers(source, obj)
    return obj


def _copy_vertex_groups(source, obj, kept):
    for group in source.vertex_groups:
        obj.vertex_groups.new(name=group.name)
    if not source.vertex_groups:
        return
    vertices = source.data.vertices
    for new, old in enumerate(kept.tolist()):
        for element in vertices[old].groups:
            obj.vertex_groups[element.group].add([new], element.weight, "REPLACE")


def _copy_shape_keys(source, obj, arrays, kept):
    key = source.data.shape_keys
    if key is None:
        return
    blocks = []
    for block, co in zip(key.key_blocks, arrays.key_co):
        new = obj.shape_key_add(name=block.name, from_mix=False)
        new.data.foreach_set("co", co[kept].ravel())
        blocks.append(new)
    new_key = obj.data.shape_keys
    new_key.use_relative = key.use_relative
    new_key.eval_time = key.eval_time
    by_name = {b.name: b for b in blocks}
    for block, new in zip(key.key_blocks, blocks):
        new.slider_max = 10.0
        new.slider_min = block.slider_min
        new.slider_max = block.slider_max
        new.value = block.value
        new.mute = block.mute
        new.interpolation = block.interpolation
        new.vertex_group = block.vertex_group
        new.relative_key = by_name[block.relative_key.name]
    if key.animation_data is None:
        return
    data = new_key.animation_data_create()
    data.action = key.animation_data.action
    # The same paths (key_blocks["NAME"].value) name the same keys on the new Key.
    retarget = {key: new_key, source: obj, source.data: obj.data}
    for curve in key.animation_data.drivers:
        _copy_driver(curve, new_key, retarget)


def _copy_driver(curve, new_key, retarget):
    try:
        new = new_key.driver_add(curve.data_path, curve.array_index)
    except TypeError:  # not an array property: no index
        new = new_key.driver_add(curve.data_path)
    driver, source = new.driver, curve.driver
    driver.type = source.type
    driver.expression = source.expression
    driver.use_self = source.use_self
    for var in source.variables:
        copy = driver.variables.new()
        copy.name = var.name
        copy.type = var.type
        for target, new_target in zip(var.targets, copy.targets):
            if var.type == "SINGLE_PROP":
                new_target.id_type = target.id_type
            new_target.id = retarget.get(target.id, target.id)
            new_target.data_path = target.data_path
            new_target.bone_target = target.bone_target
            new_target.transform_type = target.transform_type
            new_target.transform_space = target.transform_space
            new_target.rotation_mode = target.rotation_mode
    while new.modifiers:
        new.modifiers.remove(new.modifiers[0])
    for point in curve.keyframe_points:
        new.keyframe_points.insert(point.co[0], point.co[1])
    for modifier in curve.modifiers:
        copy = new.modifiers.new(modifier.type)
        _copy_properties(modifier, copy)


def _copy_modifiers(source, obj):
    for modifier in source.modifiers:
        copy = obj.modifiers.new(modifier.name, modifier.type)
        _copy_properties(modifier, copy)


def _copy_properties(source, target):
    for prop in source.bl_rna.properties:
        if prop.is_readonly or prop.identifier in {"name", "type", "rna_type"}:
            continue
        try:
            setattr(target, prop.identifier, getattr(source, prop.identifier))
        except (AttributeError, TypeError, ValueError, RuntimeError):
            pass  # a property that does not apply to the copy (e.g. set only on creation)


def _get(collection, attribute, dtype, width):
    out = np.empty(len(collection) * width, dtype)
    collection.foreach_get(attribute, out)
    return out.reshape(-1, width) if width > 1 else out


def _group_weights(obj, name, vertex_count):
    group = obj.vertex_groups.get(name)
    weights = np.zeros(vertex_count, np.float32)
    if group is None:
        return weights
    for v in obj.data.vertices:
        for element in v.groups:
            if element.group == group.index:
                weights[v.index] = element.weight
    return weights


def _key_of_path(path):
    """``NAME`` of ``key_blocks["NAME"].value``, else None."""
    prefix, suffix = 'key_blocks["', '"].value'
    if path.startswith(prefix) and path.endswith(suffix):
        return path[len(prefix) : -len(suffix)].replace('\\"', '"')
    return None
