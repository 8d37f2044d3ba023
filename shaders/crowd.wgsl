// morphlod: a crowd, many instances of one asset drawn by one multi-draw (gpu::Crowd).
// Compiled after shade.wgsl (gpu::CROWD_WGSL).
//
// Which instance a vertex belongs to reaches the vertex stage one of two ways (gpu::CrowdPath):
//
// * First instance (vs_fetch_*): the draw record of slot s has first_instance = s and
//   base_vertex = 0, so instance_index is the slot and vertex_index the asset's own vertex. The
//   poses and surface attributes arrive as vertex buffers (fixed-function fetch); only the
//   instance's placement and pose (by instance_index) and the target deltas (by vertex_index)
//   are storage reads. Needs INDIRECT_FIRST_INSTANCE: without it wgpu requires first_instance = 0. The
//   discrete-LOD renderer (gpu::DiscreteCrowd) draws with these entry points too, over
//   triangle lists, with direct instanced draws (which set instance_index on every device).
// * Base vertex (vs_pull_*), any device: the record has base_vertex = s * vertex_count and its
//   indices name the asset's own vertices, so the vertex stage sees vertex_index = s * n + v and
//   recovers both. Attribute fetch would add base_vertex to the address, so this path reads
//   the poses and surface from storage buffers by v (vertex pulling). A restart index
//   (0xFFFFFFFF) is compared before base_vertex is added, so strips restart as in an object's
//   own buffer.
//
// An asset with a surface draws with the *_surface* entry points and fs_surface (normal, UV,
// colour per vertex); one without with the *_plain* ones and fs_plain (faceted: position and
// instance colour only).
//
// An asset with morph targets draws with the *_targets8 entry points: the weight animation is
// summed here, per vertex, over a fixed 8 (target, weight) slots per instance: the instance's
// 8 largest weights, in ascending target order (the CPU sum's order), unused slots at weight
// 0. Unrolled, no loop and no branch: on lavapipe a vertex stage with a loop over targets
// leaked host memory on every draw (morph.wgsl, examples/driver_leak.rs). An asset of at most
// 4 targets fills only slots 0..4 and draws with *_targets4 (the first 4 slots: half the delta
// loads); an asset without targets with the entry points without the sum. The slots left out
// hold weight 0 and would add exact zeros, so each draws the same pixels as the 8-slot sum
// (tests/suite/crowd.rs).

struct Scene {
    // Projection * view, world to clip space.
    view_proj: mat4x4<f32>,
    // xyz: world-space direction towards the light; w: ambient term.
    light: vec4<f32>,
    // 1: the shader encodes the textured colour to sRGB (linear target).
    encode_srgb: u32,
    // The crowd's clock in seconds (gpu::Crowd::set_clock): root motion's time.
    clock: f32,
    _pad1: u32,
    _pad2: u32,
}

// What one asset's draw shares.
struct Mesh {
    // The material's base colour factor (textured mode).
    base_color: vec4<f32>,
    vertex_count: u32,
    // Shade mode (shade.wgsl): 0 faceted, 2 smooth, 3 textured.
    mode: u32,
    _pad0: u32,
    _pad1: u32,
}

// One instance's placement, 144 bytes (gpu::crowd::InstanceBlock), written where it changes.
struct Placement {
    model: mat4x4<f32>,
    // Inverse transpose of model's 3x3.
    normal_model: mat3x3<f32>,
    // Root motion: xyz the world-space velocity per second, w the clock at which model holds.
    motion: vec4<f32>,
    color: vec4<f32>,
}

// One instance's pose, 48 bytes (gpu::crowd::PoseBlock), written each frame it moves.
struct Pose {
    // Weights of the 8 target slots (0..4, 4..8).
    weights_lo: vec4<f32>,
    weights_hi: vec4<f32>,
    // The target of each slot, one byte each (slots 0..4 in x, 4..8 in y, low byte first).
    targets: vec2<u32>,
    // Blend parameter between V(0) and V(1).
    t: f32,
    // A skinned asset's clip phase (crowd_skin.wgsl); unread without a skin.
    clip_t: f32,
}

// One instance as the functions below read it: its placement and its pose.
struct Instance {
    model: mat4x4<f32>,
    normal_model: mat3x3<f32>,
    // Where root motion has taken it since its placement, world space.
    offset: vec3<f32>,
    color: vec4<f32>,
    weights_lo: vec4<f32>,
    weights_hi: vec4<f32>,
    targets: vec2<u32>,
    t: f32,
}

@group(0) @binding(0) var<uniform> scene: Scene;
@group(0) @binding(1) var<uniform> mesh: Mesh;
@group(0) @binding(2) var<storage, read> placements: array<Placement>;
// V(0), V(1): x, y, z per vertex.
@group(0) @binding(3) var<storage, read> pose0: array<f32>;
@group(0) @binding(4) var<storage, read> pose1: array<f32>;
// Target k's delta for vertex i at 3 (k n + i).
@group(0) @binding(5) var<storage, read> deltas: array<f32>;
// Per vertex n0 (3), n1 (3), uv (2), colour (4): gpu::SURFACE_STRIDE; a zero buffer without.
@group(0) @binding(6) var<storage, read> surface: array<f32>;
@group(0) @binding(7) var<storage, read> normal_deltas: array<f32>;
@group(0) @binding(8) var base_texture: texture_2d<f32>;
@group(0) @binding(9) var base_sampler: sampler;
@group(0) @binding(10) var<storage, read> poses: array<Pose>;

// Instance `slot`: its placement and its pose.
fn instance_at(slot: u32) -> Instance {
    let b = placements[slot];
    let p = poses[slot];
    let offset = (scene.clock - b.motion.w) * b.motion.xyz;
    return Instance(b.model, b.normal_model, offset, b.color, p.weights_lo, p.weights_hi, p.targets, p.t);
}

struct CrowdOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    // The instance's colour (faceted and smooth modes).
    @location(1) @interpolate(flat) tint: vec4<f32>,
    @location(2) normal: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) color: vec4<f32>,
}

fn pose0_at(v: u32) -> vec3<f32> {
    let a = 3u * v;
    return vec3<f32>(pose0[a], pose0[a + 1u], pose0[a + 2u]);
}

fn pose1_at(v: u32) -> vec3<f32> {
    let a = 3u * v;
    return vec3<f32>(pose1[a], pose1[a + 1u], pose1[a + 2u]);
}

fn delta_at(k: u32, v: u32) -> vec3<f32> {
    let a = 3u * (k * mesh.vertex_count + v);
    return vec3<f32>(deltas[a], deltas[a + 1u], deltas[a + 2u]);
}

fn normal_delta_at(k: u32, v: u32) -> vec3<f32> {
    let a = 3u * (k * mesh.vertex_count + v);
    return vec3<f32>(normal_deltas[a], normal_deltas[a + 1u], normal_deltas[a + 2u]);
}

// Target of slot j (0..4) of a packed word.
fn slot_target(word: u32, j: u32) -> u32 {
    return (word >> (8u * j)) & 255u;
}

// s + sum_j w_j D_{k_j}(v) over the 4 slots of one packed word (weights w), left to right
// as the CPU sums. add_normal_deltas4 is the same over the normal deltas.
fn add_deltas4(s: vec3<f32>, w: vec4<f32>, word: u32, v: u32) -> vec3<f32> {
    var r = s + w.x * delta_at(slot_target(word, 0u), v);
    r = r + w.y * delta_at(slot_target(word, 1u), v);
    r = r + w.z * delta_at(slot_target(word, 2u), v);
    return r + w.w * delta_at(slot_target(word, 3u), v);
}

fn add_normal_deltas4(s: vec3<f32>, w: vec4<f32>, word: u32, v: u32) -> vec3<f32> {
    var r = s + w.x * normal_delta_at(slot_target(word, 0u), v);
    r = r + w.y * normal_delta_at(slot_target(word, 1u), v);
    r = r + w.z * normal_delta_at(slot_target(word, 2u), v);
    return r + w.w * normal_delta_at(slot_target(word, 3u), v);
}

// The offsets over the first 4 slots: all an asset of at most 4 targets fills (its slots 4..8
// hold weight 0, which would add exact zeros).
fn target_offset4(inst: Instance, v: u32) -> vec3<f32> {
    return add_deltas4(vec3<f32>(0.0), inst.weights_lo, inst.targets.x, v);
}

fn normal_offset4(inst: Instance, v: u32) -> vec3<f32> {
    return add_normal_deltas4(vec3<f32>(0.0), inst.weights_lo, inst.targets.x, v);
}

// The offsets over all 8 slots, in slot order.
fn target_offset(inst: Instance, v: u32) -> vec3<f32> {
    return add_deltas4(target_offset4(inst, v), inst.weights_hi, inst.targets.y, v);
}

fn normal_offset(inst: Instance, v: u32) -> vec3<f32> {
    return add_normal_deltas4(normal_offset4(inst, v), inst.weights_hi, inst.targets.y, v);
}

// The blended object-space position of vertex v of an instance: the rule of morph.wgsl's
// local_position, with the offset summed here instead of on the CPU.
fn local_position(inst: Instance, v: u32) -> vec3<f32> {
    return mix(pose0_at(v), pose1_at(v), inst.t) + target_offset(inst, v);
}

// The world-space unit normal of an instance's object-space (unnormalised) normal.
fn world_normal(inst: Instance, normal: vec3<f32>) -> vec3<f32> {
    let local_normal = unit_or_zero(normal);
    return unit_or_zero(inst.normal_model * local_normal);
}

// What every entry point does once it has the vertex's object-space position and world-space
// normal: the instance's transform, and the surface's UV and colour passed on.
fn crowd_vertex(
    inst: Instance,
    position: vec3<f32>,
    normal: vec3<f32>,
    uv: vec2<f32>,
    color: vec4<f32>,
) -> CrowdOut {
    let world = inst.model * vec4<f32>(position, 1.0) + vec4<f32>(inst.offset, 0.0);
    var out: CrowdOut;
    out.clip = scene.view_proj * world;
    out.world = world.xyz;
    out.tint = inst.color;
    out.normal = normal;
    out.uv = uv;
    out.color = color;
    return out;
}

// The surface attributes of vertex v, pulled (an asset with a surface).
struct Attributes {
    n0: vec3<f32>,
    n1: vec3<f32>,
    uv: vec2<f32>,
    color: vec4<f32>,
}

fn attributes_at(v: u32) -> Attributes {
    let s = 12u * v;
    return Attributes(
        vec3<f32>(surface[s], surface[s + 1u], surface[s + 2u]),
        vec3<f32>(surface[s + 3u], surface[s + 4u], surface[s + 5u]),
        vec2<f32>(surface[s + 6u], surface[s + 7u]),
        vec4<f32>(surface[s + 8u], surface[s + 9u], surface[s + 10u], surface[s + 11u]),
    );
}

// What a mesh without a surface hands the fragment stage: faceted shading needs only the
// world position and the instance's colour (3 + 4 varyings instead of CrowdOut's 16: llvmpipe
// sets up every varying of every triangle).
struct PlainOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) tint: vec4<f32>,
}

fn plain_vertex(inst: Instance, position: vec3<f32>) -> PlainOut {
    let world = inst.model * vec4<f32>(position, 1.0) + vec4<f32>(inst.offset, 0.0);
    var out: PlainOut;
    out.clip = scene.view_proj * world;
    out.world = world.xyz;
    out.tint = inst.color;
    return out;
}

// Base-vertex path, an asset with a surface: vertex v of an instance with the given offsets
// (position, normal).
fn pulled(inst: Instance, v: u32, offset: vec3<f32>, normal_offset: vec3<f32>) -> CrowdOut {
    let a = attributes_at(v);
    let position = mix(pose0_at(v), pose1_at(v), inst.t) + offset;
    let normal = world_normal(inst, mix(a.n0, a.n1, inst.t) + normal_offset);
    return crowd_vertex(inst, position, normal, a.uv, a.color);
}

// Base-vertex path, an asset without a surface.
fn pulled_plain(inst: Instance, v: u32, offset: vec3<f32>) -> PlainOut {
    return plain_vertex(inst, mix(pose0_at(v), pose1_at(v), inst.t) + offset);
}

// The base-vertex path's entry points: with and without a surface, each without targets, with
// 4 and with 8 weight slots.
@vertex
fn vs_pull_surface(@builtin(vertex_index) index: u32) -> CrowdOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    return pulled(instance_at(slot), v, vec3<f32>(0.0), vec3<f32>(0.0));
}

@vertex
fn vs_pull_surface_targets4(@builtin(vertex_index) index: u32) -> CrowdOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled(inst, v, target_offset4(inst, v), normal_offset4(inst, v));
}

@vertex
fn vs_pull_surface_targets8(@builtin(vertex_index) index: u32) -> CrowdOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled(inst, v, target_offset(inst, v), normal_offset(inst, v));
}

@vertex
fn vs_pull_plain(@builtin(vertex_index) index: u32) -> PlainOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    return pulled_plain(instance_at(slot), v, vec3<f32>(0.0));
}

@vertex
fn vs_pull_plain_targets4(@builtin(vertex_index) index: u32) -> PlainOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled_plain(inst, v, target_offset4(inst, v));
}

@vertex
fn vs_pull_plain_targets8(@builtin(vertex_index) index: u32) -> PlainOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled_plain(inst, v, target_offset(inst, v));
}

// First-instance path: the poses (buffer slots 0 and 1) and, for an asset with a surface, its
// interleaved attributes (buffer slot 2, gpu::SURFACE_STRIDE), as morph.wgsl's vs_surface
// reads them.
struct Poses {
    @location(0) v0: vec3<f32>,
    @location(1) v1: vec3<f32>,
}

struct FetchedSurface {
    @location(2) n0: vec3<f32>,
    @location(3) n1: vec3<f32>,
    @location(4) uv: vec2<f32>,
    @location(5) color: vec4<f32>,
}

// First-instance path, an asset with a surface: its vertex with the given offsets.
fn fetched(
    inst: Instance,
    p: Poses,
    s: FetchedSurface,
    offset: vec3<f32>,
    normal_offset: vec3<f32>,
) -> CrowdOut {
    let position = mix(p.v0, p.v1, inst.t) + offset;
    let normal = world_normal(inst, mix(s.n0, s.n1, inst.t) + normal_offset);
    return crowd_vertex(inst, position, normal, s.uv, s.color);
}

// The first-instance path's entry points: with and without a surface, each without targets,
// with 4 and with 8 weight slots.
@vertex
fn vs_fetch_surface(p: Poses, s: FetchedSurface, @builtin(instance_index) slot: u32) -> CrowdOut {
    return fetched(instance_at(slot), p, s, vec3<f32>(0.0), vec3<f32>(0.0));
}

@vertex
fn vs_fetch_surface_targets4(
    p: Poses,
    s: FetchedSurface,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> CrowdOut {
    let inst = instance_at(slot);
    return fetched(inst, p, s, target_offset4(inst, v), normal_offset4(inst, v));
}

@vertex
fn vs_fetch_surface_targets8(
    p: Poses,
    s: FetchedSurface,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> CrowdOut {
    let inst = instance_at(slot);
    return fetched(inst, p, s, target_offset(inst, v), normal_offset(inst, v));
}

@vertex
fn vs_fetch_plain(p: Poses, @builtin(instance_index) slot: u32) -> PlainOut {
    let inst = instance_at(slot);
    return plain_vertex(inst, mix(p.v0, p.v1, inst.t));
}

@vertex
fn vs_fetch_plain_targets4(
    p: Poses,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> PlainOut {
    let inst = instance_at(slot);
    return plain_vertex(inst, mix(p.v0, p.v1, inst.t) + target_offset4(inst, v));
}

@vertex
fn vs_fetch_plain_targets8(
    p: Poses,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> PlainOut {
    let inst = instance_at(slot);
    return plain_vertex(inst, mix(p.v0, p.v1, inst.t) + target_offset(inst, v));
}

// An asset with a surface: shaded by its mode (faceted, smooth or textured).
@fragment
fn fs_surface(in: CrowdOut) -> @location(0) vec4<f32> {
    let texel = textureSample(base_texture, base_sampler, in.uv);
    let material = Material(mesh.mode, in.tint, mesh.base_color, scene.light, scene.encode_srgb);
    return shade_surface(in.world, 0u, in.normal, texel, in.color, material);
}

// An asset without a surface: faceted in the instance's colour, as an object's fs_main (the
// arithmetic of shade_surface's faceted mode).
@fragment
fn fs_plain(in: PlainOut) -> @location(0) vec4<f32> {
    return shade_plain(in.world, 0u, mesh.mode, in.tint, scene.light);
}

// The blended positions of one instance, written for checking (gpu::Crowd::blended_positions):
// the vertex stage's own local_position, one invocation per vertex.
struct Probe {
    slot: u32,
}
@group(1) @binding(0) var<uniform> probe: Probe;
@group(1) @binding(1) var<storage, read_write> probed: array<f32>;

@compute @workgroup_size(64)
fn cs_positions(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v >= mesh.vertex_count {
        return;
    }
    let p = local_position(instance_at(probe.slot), v);
    probed[3u * v] = p.x;
    probed[3u * v + 1u] = p.y;
    probed[3u * v + 2u] = p.z;
}
