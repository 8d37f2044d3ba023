// morphlod: a frame's index edits of a crowd asset, applied on the GPU (gpu::Crowd::prepare).
//
// The CPU gathers every changed index slot of every instance into one list of (slot, value)
// patches, uploaded with one write; one invocation applies one patch. No loop and no bounds
// branch: the list is padded to whole workgroups by repeating its last patch (same slot, same
// value, so the order of the duplicates does not matter). The dispatch is 2D when the
// workgroups exceed one dimension's limit; patches are numbered row by row.

@group(0) @binding(0) var<storage, read> patches: array<vec2<u32>>;
@group(0) @binding(1) var<storage, read_write> indices: array<u32>;

@compute @workgroup_size(64)
fn scatter(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let edit = patches[id.x + id.y * groups.x * 64u];
    indices[edit.x] = edit.y;
}
