// morphlod: a crowd's skinned assets (gpu::Crowd, issue 51). Compiled after shade.wgsl,
// crowd.wgsl and skin.wgsl (gpu::CROWD_SKIN_WGSL), into a module of its own: an asset without
// a skin keeps crowd.wgsl's module, bind group layout and cost.
//
// The asset's clip and vertex skin (gpu::GpuSkin, laid out in skin.wgsl) are one more storage
// binding, shared by every instance of the asset: the vertex stage's 8th (the 8 a stage may
// bind by default). Per instance only its clip phase, the pose block's last word (`clip_t`),
// selects the keys: no joint matrix is uploaded per frame. Morph first (the instance's blend
// and target slots, as crowd.wgsl), then skin (skin_vertex), positions and normals; the
// instance's transform last. Unrolled like the rest: no loop, no branch.

@group(0) @binding(11) var<storage, read> skin_data: array<u32>;

// Skins an instance's morphed vertex at the instance's clip phase.
fn skinned_at(slot: u32, v: u32, position: vec3<f32>, normal: vec3<f32>) -> Skinned {
    return skin_vertex(position, normal, v, poses[slot].clip_t);
}

// The skinned object-space position of vertex v of instance `slot` (8 slots summed): what
// cs_skinned_positions writes back.
fn skinned_position(slot: u32, v: u32) -> vec3<f32> {
    return skinned_at(slot, v, local_position(instance_at(slot), v), vec3<f32>(0.0)).position;
}

// Base-vertex path, an asset with a surface, skinned.
fn pulled_skinned(inst: Instance, slot: u32, v: u32, offset: vec3<f32>, normal_offset: vec3<f32>) -> CrowdOut {
    let a = attributes_at(v);
    let morphed = mix(pose0_at(v), pose1_at(v), inst.t) + offset;
    let s = skinned_at(slot, v, morphed, mix(a.n0, a.n1, inst.t) + normal_offset);
    return crowd_vertex(inst, s.position, world_normal(inst, s.normal), a.uv, a.color);
}

// Base-vertex path, an asset without a surface, skinned (the normal is not used).
fn pulled_plain_skinned(inst: Instance, slot: u32, v: u32, offset: vec3<f32>) -> PlainOut {
    let morphed = mix(pose0_at(v), pose1_at(v), inst.t) + offset;
    return plain_vertex(inst, skinned_at(slot, v, morphed, vec3<f32>(0.0)).position);
}

@vertex
fn vs_pull_surface_skinned(@builtin(vertex_index) index: u32) -> CrowdOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    return pulled_skinned(instance_at(slot), slot, v, vec3<f32>(0.0), vec3<f32>(0.0));
}

@vertex
fn vs_pull_surface_targets4_skinned(@builtin(vertex_index) index: u32) -> CrowdOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled_skinned(inst, slot, v, target_offset4(inst, v), normal_offset4(inst, v));
}

@vertex
fn vs_pull_surface_targets8_skinned(@builtin(vertex_index) index: u32) -> CrowdOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled_skinned(inst, slot, v, target_offset(inst, v), normal_offset(inst, v));
}

@vertex
fn vs_pull_plain_skinned(@builtin(vertex_index) index: u32) -> PlainOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    return pulled_plain_skinned(instance_at(slot), slot, v, vec3<f32>(0.0));
}

@vertex
fn vs_pull_plain_targets4_skinned(@builtin(vertex_index) index: u32) -> PlainOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled_plain_skinned(inst, slot, v, target_offset4(inst, v));
}

@vertex
fn vs_pull_plain_targets8_skinned(@builtin(vertex_index) index: u32) -> PlainOut {
    let slot = index / mesh.vertex_count;
    let v = index - slot * mesh.vertex_count;
    let inst = instance_at(slot);
    return pulled_plain_skinned(inst, slot, v, target_offset(inst, v));
}

// First-instance path, an asset with a surface, skinned.
fn fetched_skinned(
    inst: Instance,
    slot: u32,
    v: u32,
    p: Poses,
    s: FetchedSurface,
    offset: vec3<f32>,
    normal_offset: vec3<f32>,
) -> CrowdOut {
    let morphed = mix(p.v0, p.v1, inst.t) + offset;
    let k = skinned_at(slot, v, morphed, mix(s.n0, s.n1, inst.t) + normal_offset);
    return crowd_vertex(inst, k.position, world_normal(inst, k.normal), s.uv, s.color);
}

// First-instance path, an asset without a surface, skinned.
fn fetched_plain_skinned(inst: Instance, slot: u32, v: u32, p: Poses, offset: vec3<f32>) -> PlainOut {
    let morphed = mix(p.v0, p.v1, inst.t) + offset;
    return plain_vertex(inst, skinned_at(slot, v, morphed, vec3<f32>(0.0)).position);
}

@vertex
fn vs_fetch_surface_skinned(
    p: Poses,
    s: FetchedSurface,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> CrowdOut {
    return fetched_skinned(instance_at(slot), slot, v, p, s, vec3<f32>(0.0), vec3<f32>(0.0));
}

@vertex
fn vs_fetch_surface_targets4_skinned(
    p: Poses,
    s: FetchedSurface,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> CrowdOut {
    let inst = instance_at(slot);
    return fetched_skinned(inst, slot, v, p, s, target_offset4(inst, v), normal_offset4(inst, v));
}

@vertex
fn vs_fetch_surface_targets8_skinned(
    p: Poses,
    s: FetchedSurface,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> CrowdOut {
    let inst = instance_at(slot);
    return fetched_skinned(inst, slot, v, p, s, target_offset(inst, v), normal_offset(inst, v));
}

@vertex
fn vs_fetch_plain_skinned(
    p: Poses,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> PlainOut {
    return fetched_plain_skinned(instance_at(slot), slot, v, p, vec3<f32>(0.0));
}

@vertex
fn vs_fetch_plain_targets4_skinned(
    p: Poses,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> PlainOut {
    let inst = instance_at(slot);
    return fetched_plain_skinned(inst, slot, v, p, target_offset4(inst, v));
}

@vertex
fn vs_fetch_plain_targets8_skinned(
    p: Poses,
    @builtin(vertex_index) v: u32,
    @builtin(instance_index) slot: u32,
) -> PlainOut {
    let inst = instance_at(slot);
    return fetched_plain_skinned(inst, slot, v, p, target_offset(inst, v));
}

// The skinned positions of one instance, written for checking (gpu::Crowd::blended_positions
// of a skinned asset): the vertex stage's own morph and skin, one invocation per vertex.
@compute @workgroup_size(64)
fn cs_skinned_positions(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v >= mesh.vertex_count {
        return;
    }
    let p = skinned_position(probe.slot, v);
    probed[3u * v] = p.x;
    probed[3u * v + 1u] = p.y;
    probed[3u * v + 2u] = p.z;
}
