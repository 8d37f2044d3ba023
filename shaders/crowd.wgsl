// morphlod: a crowd, many instances of one asset drawn by one multi-draw (gpu::Crowd).
// Compiled after shade.wgsl (gpu::CROWD_WGSL).
//
// Which instance a vertex belongs to travels in the index arithmetic, not in instance_index:
// every instance's draw record has base_vertex = slot * vertex_count and its indices name the
// asset's own vertices, so the vertex stage sees vertex_index = slot * n + v and recovers both.
// Why not first_instance: lavapipe (and any device without INDIRECT_FIRST_INSTANCE) drops a
// nonzero first_instance of an indirect draw, and base_vertex is core everywhere. The vertex
// stage therefore reads the poses and surface from storage buffers by v (vertex pulling), not
// as vertex attributes: attribute fetch would add base_vertex to the address.
//
// A restart index (0xFFFFFFFF) is compared before base_vertex is added, so strips restart as in
// an object's own buffer.
//
// The weight animation is summed here, per vertex, over a fixed 8 (target, weight) slots per
// instance: the instance's 8 largest weights, in ascending target order (the CPU sum's order),
// unused slots at weight 0. Unrolled, no loop and no branch: on lavapipe a vertex stage with a
// loop over targets leaked host memory on every draw (morph.wgsl, examples/driver_leak.rs).

struct Scene {
    // Projection * view, world to clip space.
    view_proj: mat4x4<f32>,
    // xyz: world-space direction towards the light; w: ambient term.
    light: vec4<f32>,
    // 1: the shader encodes the textured colour to sRGB (linear target).
    encode_srgb: u32,
    _pad0: u32,
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

// One instance, 192 bytes (gpu::crowd::InstanceData).
struct Instance {
    model: mat4x4<f32>,
    // Inverse transpose of model's 3x3 in the xyz of the first three columns.
    normal_model: mat4x4<f32>,
    color: vec4<f32>,
    // Weights of the 8 target slots (0..4, 4..8).
    weights_lo: vec4<f32>,
    weights_hi: vec4<f32>,
    // The target of each slot, one byte each (slots 0..4 in x, 4..8 in y, low byte first).
    targets: vec2<u32>,
    // Blend parameter between V(0) and V(1).
    t: f32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> scene: Scene;
@group(0) @binding(1) var<uniform> mesh: Mesh;
@group(0) @binding(2) var<storage, read> instances: array<Instance>;
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

// sum_j w_j D_{k_j}(v) over the 8 slots, in slot order, as the CPU sums (left to right).
fn target_offset(inst: Instance, v: u32) -> vec3<f32> {
    let a = inst.targets.x;
    let b = inst.targets.y;
    var s = inst.weights_lo.x * delta_at(slot_target(a, 0u), v);
    s = s + inst.weights_lo.y * delta_at(slot_target(a, 1u), v);
    s = s + inst.weights_lo.z * delta_at(slot_target(a, 2u), v);
    s = s + inst.weights_lo.w * delta_at(slot_target(a, 3u), v);
    s = s + inst.weights_hi.x * delta_at(slot_target(b, 0u), v);
    s = s + inst.weights_hi.y * delta_at(slot_target(b, 1u), v);
    s = s + inst.weights_hi.z * delta_at(slot_target(b, 2u), v);
    s = s + inst.weights_hi.w * delta_at(slot_target(b, 3u), v);
    return s;
}

fn normal_offset(inst: Instance, v: u32) -> vec3<f32> {
    let a = inst.targets.x;
    let b = inst.targets.y;
    var s = inst.weights_lo.x * normal_delta_at(slot_target(a, 0u), v);
    s = s + inst.weights_lo.y * normal_delta_at(slot_target(a, 1u), v);
    s = s + inst.weights_lo.z * normal_delta_at(slot_target(a, 2u), v);
    s = s + inst.weights_lo.w * normal_delta_at(slot_target(a, 3u), v);
    s = s + inst.weights_hi.x * normal_delta_at(slot_target(b, 0u), v);
    s = s + inst.weights_hi.y * normal_delta_at(slot_target(b, 1u), v);
    s = s + inst.weights_hi.z * normal_delta_at(slot_target(b, 2u), v);
    s = s + inst.weights_hi.w * normal_delta_at(slot_target(b, 3u), v);
    return s;
}

// The blended object-space position of vertex v of an instance: the rule of morph.wgsl's
// local_position, with the offset summed here instead of on the CPU.
fn local_position(inst: Instance, v: u32) -> vec3<f32> {
    return mix(pose0_at(v), pose1_at(v), inst.t) + target_offset(inst, v);
}

@vertex
fn vs_crowd(@builtin(vertex_index) index: u32) -> CrowdOut {
    let slot = index / mesh.vertex_count;
    return instance_vertex(slot, index - slot * mesh.vertex_count);
}

// The discrete-LOD renderer (gpu::crowd::discrete, the crowd bench's comparison): one
// instanced draw per level over triangle lists of the asset's own vertices, base_vertex 0, the
// instance's block number in instance_index. Direct draws keep first_instance on every device
// (lavapipe drops it in indirect draws only).
@vertex
fn vs_levels(@builtin(vertex_index) v: u32, @builtin(instance_index) slot: u32) -> CrowdOut {
    return instance_vertex(slot, v);
}

// Vertex v of the instance whose block is instances[slot].
fn instance_vertex(slot: u32, v: u32) -> CrowdOut {
    let inst = instances[slot];
    let world = inst.model * vec4<f32>(local_position(inst, v), 1.0);
    let s = 12u * v;
    let n0 = vec3<f32>(surface[s], surface[s + 1u], surface[s + 2u]);
    let n1 = vec3<f32>(surface[s + 3u], surface[s + 4u], surface[s + 5u]);
    let local_normal = unit_or_zero(mix(n0, n1, inst.t) + normal_offset(inst, v));
    var out: CrowdOut;
    out.clip = scene.view_proj * world;
    out.world = world.xyz;
    out.tint = inst.color;
    out.normal = unit_or_zero((inst.normal_model * vec4<f32>(local_normal, 0.0)).xyz);
    out.uv = vec2<f32>(surface[s + 6u], surface[s + 7u]);
    out.color = vec4<f32>(surface[s + 8u], surface[s + 9u], surface[s + 10u], surface[s + 11u]);
    return out;
}

@fragment
fn fs_crowd(in: CrowdOut) -> @location(0) vec4<f32> {
    let texel = textureSample(base_texture, base_sampler, in.uv);
    let material = Material(mesh.mode, in.tint, mesh.base_color, scene.light, scene.encode_srgb);
    return shade_surface(in.world, 0u, in.normal, texel, in.color, material);
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
    let p = local_position(instances[probe.slot], v);
    probed[3u * v] = p.x;
    probed[3u * v + 1u] = p.y;
    probed[3u * v + 2u] = p.z;
}
