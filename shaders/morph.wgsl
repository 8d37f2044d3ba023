// morphlod: blend two poses of one mesh and shade it.
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
// Fragment stage: normals come from screen-space derivatives of the world position,
// n = normalize(cross(dpdy(p), dpdx(p))), not from a per-vertex normal attribute. Why:
//  * the mesh deforms, so per-vertex normals would have to be blended too, and a linear blend
//    of two unit normals is not the normal of the blended surface;
//  * the LOD changes the triangles around a vertex at every step, so any per-vertex normal
//    would be stale after a collapse; the derivative normal is always the facet normal of the
//    triangle actually drawn, at no memory cost;
//  * it is the same for a triangle drawn from a strip or from a list (orientation included:
//    the construction uses screen axes, so it always points towards the viewer for a
//    right-handed world and a y-up projection), which the strip-vs-list image test relies on.
// The cost is flat (faceted) shading, which is what a LOD viewer wants to show anyway.

struct Uniforms {
    // Projection * view, world to clip space.
    view_proj: mat4x4<f32>,
    // Object to world space.
    model: mat4x4<f32>,
    // Base colour (rgb; a is written to the target unchanged).
    color: vec4<f32>,
    // xyz: world-space direction towards the light (need not be unit); w: ambient term in [0, 1].
    light: vec4<f32>,
    // Blend parameter between pose 0 and pose 1.
    t: f32,
    // 0: base colour; 1: one colour per strip (region), from the instance index.
    mode: u32,
}

@group(0) @binding(0) var<uniform> u: Uniforms;
@group(0) @binding(1) var<storage, read> offsets: array<f32>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    // The indirect draw of region r has first_instance = r when the device supports
    // INDIRECT_FIRST_INSTANCE (0 otherwise), so this is the strip id for strip colouring.
    @location(1) @interpolate(flat) strip: u32,
}

@vertex
fn vs_main(
    @location(0) v0: vec3<f32>,
    @location(1) v1: vec3<f32>,
    @builtin(instance_index) instance: u32,
    @builtin(vertex_index) vertex: u32,
) -> VertexOut {
    let at = 3u * vertex;
    let local = mix(v0, v1, u.t) + vec3<f32>(offsets[at], offsets[at + 1u], offsets[at + 2u]);
    let world = u.model * vec4<f32>(local, 1.0);
    var out: VertexOut;
    out.clip = u.view_proj * world;
    out.world = world.xyz;
    out.strip = instance;
    return out;
}

// A well-spread, stable colour per strip id (integer hash; u32 arithmetic wraps in WGSL).
fn strip_colour(id: u32) -> vec3<f32> {
    var h = id * 2654435761u;
    h = h ^ (h >> 15u);
    h = h * 2246822519u;
    h = h ^ (h >> 13u);
    let rgb = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
    // Keep every channel away from black so shading stays visible.
    return 0.25 + 0.75 * rgb;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    // Each derivative is scaled to its largest component first: for a mesh ~1e19 across,
    // dot(c, c) would overflow f32 (n = 0, ambient only), and for one ~1e-22 across it would
    // underflow; scaled, the normal is the same at every size.
    let a = dpdy(in.world);
    let b = dpdx(in.world);
    let c = cross(a / max(max(abs(a.x), max(abs(a.y), abs(a.z))), 1e-37),
                  b / max(max(abs(b.x), max(abs(b.y), abs(b.z))), 1e-37));
    // A zero-area fragment footprint gives c = 0: n stays 0 and the fragment gets ambient only,
    // instead of the NaN that normalize(0) would produce.
    let n = c * inverseSqrt(max(dot(c, c), 1e-30));
    let diffuse = max(dot(n, normalize(u.light.xyz)), 0.0);
    let shade = u.light.w + (1.0 - u.light.w) * diffuse;
    var base = u.color.rgb;
    if u.mode == 1u {
        base = strip_colour(in.strip);
    }
    return vec4<f32>(base * shade, u.color.a);
}
