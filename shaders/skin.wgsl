// morphlod: linear blend skinning from a clip's baked keys (morph first, then skin, as glTF
// says). Compiled before morph.wgsl (gpu::MORPH_WGSL), which declares the one buffer read here,
// `skin_data: array<u32>` (one binding, so that a crowd's vertex stage, already near the
// 8-storage-buffer limit, can take it too), as gpu::GpuSkin writes it:
//
//   words 0..4:  N (intervals), J (joints), V (the word where the vertex skin starts), 0;
//   from word 4: the clip baked once (skin::BakedClip): per key i in 0..=N (t = i / N) and
//                joint j the three rows of its 3x4 joint matrix, 12 f32 at 4 + 12 (i J + j);
//   from word V: per vertex 6 words: its 4 joint indices as u16 pairs (j0 | j1 << 16,
//                j2 | j3 << 16) and its 4 weights as f32 bits (unused influences: weight 0).
//
// Per object only the clip's phase t (the uniforms) selects the keys: keys k = min(floor(t N),
// N - 1) and k + 1 are blended by t N - k (skin::BakedClip::matrices_at is this rule on the
// CPU), so no joint matrix is uploaded per frame. Everything is unrolled, with no loop and no
// branch (a vertex-stage loop leaks host memory per draw on lavapipe, see morph.wgsl).

// A position and a normal after skinning (object space; the normal not normalised).
struct Skinned {
    position: vec3<f32>,
    normal: vec3<f32>,
}

// Four words of skin_data from `at`, as floats.
fn skin_vec4(at: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(vec4<u32>(skin_data[at], skin_data[at + 1u], skin_data[at + 2u], skin_data[at + 3u]));
}

// Joint `joint`'s rows at key `key`, as the columns of a mat3x4 (column r = row r).
fn joint_rows(key: u32, joint: u32) -> mat3x4<f32> {
    let at = 4u + 12u * (key * skin_data[1] + joint);
    return mat3x4<f32>(skin_vec4(at), skin_vec4(at + 4u), skin_vec4(at + 8u));
}

// The vertex's skin matrix at key `key`: sum_i w_i M(j_i), its 4 influences unrolled.
fn skin_rows(key: u32, joints: vec4<u32>, weights: vec4<f32>) -> mat3x4<f32> {
    return weights.x * joint_rows(key, joints.x) + weights.y * joint_rows(key, joints.y)
        + weights.z * joint_rows(key, joints.z) + weights.w * joint_rows(key, joints.w);
}

// Skins the morphed position `p` and normal `n` of vertex `vertex` at the clip's phase `t`
// (clamped to [0, 1]): the skin matrix blended between the two keys around t, applied to the
// position (w = 1) and to the normal (w = 0; its 3x3 part, glTF's reference shader and
// three.js do the same).
fn skin_vertex(p: vec3<f32>, n: vec3<f32>, vertex: u32, t: f32) -> Skinned {
    let intervals = skin_data[0];
    let f = clamp(t, 0.0, 1.0) * f32(intervals);
    let key = min(u32(f), intervals - 1u);
    let s = f - f32(key);
    let at = skin_data[2] + 6u * vertex;
    let packed = vec2<u32>(skin_data[at], skin_data[at + 1u]);
    let joints = vec4<u32>(packed.x & 0xffffu, packed.x >> 16u, packed.y & 0xffffu, packed.y >> 16u);
    let weights = skin_vec4(at + 2u);
    let m = (1.0 - s) * skin_rows(key, joints, weights) + s * skin_rows(key + 1u, joints, weights);
    let p1 = vec4<f32>(p, 1.0);
    let n0 = vec4<f32>(n, 0.0);
    var out: Skinned;
    out.position = vec3<f32>(dot(m[0], p1), dot(m[1], p1), dot(m[2], p1));
    out.normal = vec3<f32>(dot(m[0], n0), dot(m[1], n0), dot(m[2], n0));
    return out;
}
