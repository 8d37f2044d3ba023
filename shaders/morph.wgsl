// morphlod: blend two poses of one mesh and shade it. Compiled after shade.wgsl (the shading
// it shares with crowd.wgsl) and skin.wgsl (skinning): gpu::MORPH_WGSL is the three files
// concatenated.
//
// Vertex stage: every vertex has its position in pose 0 (buffer slot 0, location 0) and in
// pose 1 (buffer slot 1, location 1); the drawn position is mix(v0, v1, t) with the exact t
// of the frame, plus the vertex's offset sum_k w_k D_k over the morph targets of a weight
// animation (offsets[3 i .. 3 i + 3] for vertex i, read by vertex index, so the index buffer
// addresses offsets and poses alike). The connectivity (the index buffer) is edited on the
// CPU; positions never are.
//
// The offsets are summed on the CPU (gpu::Object::set_target_weights) and this stage has no
// loop and no branch. Why: on lavapipe (Mesa 22.3) every draw of a vertex shader with a loop
// over the targets leaked about 0.2 MB of host memory (a window at 90 fps grew by gigabytes;
// examples/driver_leak.rs reproduces it with plain wgpu). An object without targets binds a
// small zero buffer: WebGPU defines an out-of-range storage read to return a value from inside
// the buffer or zero, so every vertex reads a zero offset.
//
// Two vertex stages share this module. vs_main draws a position-only mesh (V(0), V(1)). vs_surface
// draws a mesh with a surface (gpu::Object with a Surface): it also reads per-vertex normals at
// t = 0 and t = 1, UVs and colours (buffer slot 2, interleaved), and a normal offset per vertex
// summed on the CPU exactly like the position offset, and hands the fragment stage
// normalize(mix(n0, n1, t) + noff) in world space. Still no loop and no branch over targets.
// vs_skinned and vs_skinned_surface are the same two stages for a skinned asset: the morphed
// position and normal are then skinned at the clip's phase (skin.wgsl: morph first, then skin,
// as glTF says); cs_skinned and cs_skinned_surface (at the end) run the same functions in a
// compute pass, so a test reads back exactly what the vertex stage draws.
//
// Fragment stage of a position-only mesh (fs_main), and the faceted mode of fs_surface: normals
// come from screen-space derivatives of the world position,
// n = normalize(cross(dpdy(p), dpdx(p))), not from a per-vertex normal attribute. Why:
//  * the mesh deforms, so per-vertex normals would have to be blended too, and a linear blend
//    of two unit normals is not the normal of the blended surface;
//  * the LOD changes the triangles around a vertex at every step, so any per-vertex normal
//    would be stale after a collapse; the derivative normal is always the facet normal of the
//    triangle actually drawn, at no memory cost;
//  * it is the same for a triangle drawn from a strip or from a list (orientation included:
//    the construction uses screen axes, so it always points towards the viewer for a
//    right-handed world and a y-up projection), which the strip-vs-list image test relies on.
// The cost is flat (faceted) shading, which is what a LOD viewer wants to show anyway. A mesh that
// brings its own normals (a surface) can be drawn smooth: the source's normals are blended like
// the positions (glTF's rule for morph targets), and a LOD step moves every attribute vertex of a
// collapsed vertex onto a surviving vertex, whose own normal is then used: an approximation the
// simplifier's attribute metric keeps small.

struct Uniforms {
    // Projection * view, world to clip space.
    view_proj: mat4x4<f32>,
    // Object to world space.
    model: mat4x4<f32>,
    // The inverse transpose of model's upper 3x3 (columns xyz; w unused): takes normals to world
    // space under any invertible model matrix, non-uniform scale included.
    normal_model: mat4x4<f32>,
    // The object's colour (rgb; a is written to the target unchanged): faceted and smooth modes.
    color: vec4<f32>,
    // The material's base colour factor (linear rgba): textured mode.
    base_color: vec4<f32>,
    // xyz: world-space direction towards the light (need not be unit); w: ambient term in [0, 1].
    light: vec4<f32>,
    // Blend parameter between pose 0 and pose 1.
    t: f32,
    // 0: faceted, object colour; 1: faceted, one colour per strip (region), from the instance
    // index; 2: smooth, object colour; 3: smooth, textured (base colour * texture * vertex colour).
    mode: u32,
    // 1: encode the textured mode's linear colour to sRGB (the target format stores values as
    // is); 0: the target is sRGB and encodes itself.
    encode_srgb: u32,
    // The clip's phase in [0, 1] (skinned layouts only; skin.wgsl).
    clip_t: f32,
}

@group(0) @binding(0) var<uniform> u: Uniforms;
@group(0) @binding(1) var<storage, read> offsets: array<f32>;
// Only in the surface layout: the normal offsets (like `offsets`), the base-colour texture
// (sRGB, so samples are linear) and its sampler.
@group(0) @binding(2) var<storage, read> normal_offsets: array<f32>;
@group(0) @binding(3) var base_texture: texture_2d<f32>;
@group(0) @binding(4) var base_sampler: sampler;
// Only in the skinned layouts: the asset's baked clip and its per-vertex joints and weights
// (skin.wgsl says how they are laid out).
@group(0) @binding(5) var<storage, read> skin_data: array<u32>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    // The indirect draw of region r has first_instance = r when the device supports
    // INDIRECT_FIRST_INSTANCE (0 otherwise), so this is the strip id for strip colouring.
    @location(1) @interpolate(flat) strip: u32,
}

// The position-only stage's output plus the surface attributes.
struct SurfaceOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) strip: u32,
    // World-space unit normal of the vertex (interpolated, renormalised per fragment).
    @location(2) normal: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) color: vec4<f32>,
}

// The blended position of vertex `vertex` in object space: the one rule both stages use.
fn local_position(v0: vec3<f32>, v1: vec3<f32>, vertex: u32) -> vec3<f32> {
    let at = 3u * vertex;
    return mix(v0, v1, u.t) + vec3<f32>(offsets[at], offsets[at + 1u], offsets[at + 2u]);
}

// The blended normal of vertex `vertex` in object space (not normalised).
fn local_normal(n0: vec3<f32>, n1: vec3<f32>, vertex: u32) -> vec3<f32> {
    let at = 3u * vertex;
    let noff = vec3<f32>(normal_offsets[at], normal_offsets[at + 1u], normal_offsets[at + 2u]);
    return mix(n0, n1, u.t) + noff;
}

// A position-only vertex at object-space position `local`.
fn plain_out(local: vec3<f32>, instance: u32) -> VertexOut {
    let world = u.model * vec4<f32>(local, 1.0);
    var out: VertexOut;
    out.clip = u.view_proj * world;
    out.world = world.xyz;
    out.strip = instance;
    return out;
}

// A surface vertex at object-space position `local` with object-space normal `normal`.
fn surface_out(local: vec3<f32>, normal: vec3<f32>, uv: vec2<f32>, color: vec4<f32>, instance: u32) -> SurfaceOut {
    let world = u.model * vec4<f32>(local, 1.0);
    var out: SurfaceOut;
    out.clip = u.view_proj * world;
    out.world = world.xyz;
    out.strip = instance;
    out.normal = unit_or_zero((u.normal_model * vec4<f32>(unit_or_zero(normal), 0.0)).xyz);
    out.uv = uv;
    out.color = color;
    return out;
}

// The attributes of a position-only vertex.
struct PlainIn {
    @location(0) v0: vec3<f32>,
    @location(1) v1: vec3<f32>,
    @builtin(instance_index) instance: u32,
    @builtin(vertex_index) vertex: u32,
}

// The attributes of a vertex with a surface.
struct SurfaceIn {
    @location(0) v0: vec3<f32>,
    @location(1) v1: vec3<f32>,
    @location(2) n0: vec3<f32>,
    @location(3) n1: vec3<f32>,
    @location(4) uv: vec2<f32>,
    @location(5) color: vec4<f32>,
    @builtin(instance_index) instance: u32,
    @builtin(vertex_index) vertex: u32,
}

@vertex
fn vs_main(in: PlainIn) -> VertexOut {
    return plain_out(local_position(in.v0, in.v1, in.vertex), in.instance);
}

@vertex
fn vs_surface(in: SurfaceIn) -> SurfaceOut {
    let p = local_position(in.v0, in.v1, in.vertex);
    return surface_out(p, local_normal(in.n0, in.n1, in.vertex), in.uv, in.color, in.instance);
}

// The skinned stages: the morphed position (and normal) as above, then skinned at the clip's
// phase (skin.wgsl).
@vertex
fn vs_skinned(in: PlainIn) -> VertexOut {
    let p = local_position(in.v0, in.v1, in.vertex);
    let skinned = skin_vertex(p, vec3<f32>(0.0), in.vertex, u.clip_t);
    return plain_out(skinned.position, in.instance);
}

@vertex
fn vs_skinned_surface(in: SurfaceIn) -> SurfaceOut {
    let p = local_position(in.v0, in.v1, in.vertex);
    let skinned = skin_vertex(p, local_normal(in.n0, in.n1, in.vertex), in.vertex, u.clip_t);
    return surface_out(skinned.position, skinned.normal, in.uv, in.color, in.instance);
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return shade_plain(in.world, in.strip, u.mode, u.color, u.light);
}

@fragment
fn fs_surface(in: SurfaceOut) -> @location(0) vec4<f32> {
    // Sampled before any mode test: textureSample needs uniform control flow (implicit
    // derivatives), and the mode is uniform anyway.
    let texel = textureSample(base_texture, base_sampler, in.uv);
    let material = Material(u.mode, u.color, u.base_color, u.light, u.encode_srgb);
    return shade_surface(in.world, in.strip, in.normal, texel, in.color, material);
}

// The probe of a skinned object (gpu::Object::skinned_pose): the vertex stages' positions and
// normals (object space, before the model transform; the normal not normalised), computed by
// the same functions from V(0), V(1) and the surface read as storage, written 6 floats a vertex.
@group(1) @binding(0) var<storage, read> probe_v0: array<f32>;
@group(1) @binding(1) var<storage, read> probe_v1: array<f32>;
// The surface buffer (12 floats a vertex: n0, n1, uv, colour); any buffer without a surface.
@group(1) @binding(2) var<storage, read> probe_surface: array<f32>;
@group(1) @binding(3) var<storage, read_write> probed: array<f32>;

fn probe_vec3(values: vec3<f32>, at: u32) {
    probed[at] = values.x;
    probed[at + 1u] = values.y;
    probed[at + 2u] = values.z;
}

// Vertex `v`'s morphed position from the probe's copies of V(0) and V(1).
fn probe_position(v: u32) -> vec3<f32> {
    let at = 3u * v;
    let v0 = vec3<f32>(probe_v0[at], probe_v0[at + 1u], probe_v0[at + 2u]);
    let v1 = vec3<f32>(probe_v1[at], probe_v1[at + 1u], probe_v1[at + 2u]);
    return local_position(v0, v1, v);
}

@compute @workgroup_size(64)
fn cs_skinned(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v >= arrayLength(&probe_v0) / 3u {
        return;
    }
    let skinned = skin_vertex(probe_position(v), vec3<f32>(0.0), v, u.clip_t);
    probe_vec3(skinned.position, 6u * v);
    probe_vec3(skinned.normal, 6u * v + 3u);
}

@compute @workgroup_size(64)
fn cs_skinned_surface(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v >= arrayLength(&probe_v0) / 3u {
        return;
    }
    let at = 12u * v;
    let n0 = vec3<f32>(probe_surface[at], probe_surface[at + 1u], probe_surface[at + 2u]);
    let n1 = vec3<f32>(probe_surface[at + 3u], probe_surface[at + 4u], probe_surface[at + 5u]);
    let skinned = skin_vertex(probe_position(v), local_normal(n0, n1, v), v, u.clip_t);
    probe_vec3(skinned.position, 6u * v);
    probe_vec3(skinned.normal, 6u * v + 3u);
}
