// morphlod: a crowd instance at one of its frame's coarsest LODs, written from the frame's tail
// list (gpu::Crowd, src/gpu/crowd/tail.rs) into the instance's compact area.
//
// `tails` holds, per frame, its tail triangles (three tail vertices each, latest degenerate
// first, so the triangles of a LOD are a prefix) and its tail vertices (three words each: the
// mesh's vertex, the step counted from the tail's first LOD at which it collapses, or
// 0xffffffff for never, and the tail vertex it falls into). A job writes its first `count`
// triangles, each corner walked along the collapses before `level` (its survivor: the
// DESIGN's oracle), as `a b c restart`: one strip per triangle at even parity, so the crowd's
// strip pipeline draws it with its orientation. One workgroup of LANES invocations per job;
// the dispatch is padded to a rectangle of workgroups by repeating the last job (the same
// words, the same values).

struct Job {
    dst: u32,
    triangles: u32,
    vertices: u32,
    level: u32,
    count: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> jobs: array<Job>;
@group(0) @binding(1) var<storage, read> tails: array<u32>;
@group(0) @binding(2) var<storage, read_write> indices: array<u32>;

// The survivor of tail vertex `first` at the job's LOD, as the mesh's vertex. The chain ends:
// each link is a later step.
fn survivor(job: Job, first: u32) -> u32 {
    var at = job.vertices + 3u * first;
    while tails[at + 1u] < job.level {
        at = job.vertices + 3u * tails[at + 2u];
    }
    return tails[at];
}

// Invocations per job: a distant body's list is ~30 triangles; an NVIDIA warp is 32 wide (on
// llvmpipe 16, 32 and 64 measured alike within noise: docs/benchmarks-log.md, "Distant instances
// from shared tail lists").
const LANES: u32 = 32u;

@compute @workgroup_size(LANES)
fn expand_tails(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    let job = jobs[group.x + group.y * groups.x];
    for (var t = lane; t < job.count; t += LANES) {
        let corners = job.triangles + 3u * t;
        let out = job.dst + 4u * t;
        indices[out] = survivor(job, tails[corners]);
        indices[out + 1u] = survivor(job, tails[corners + 1u]);
        indices[out + 2u] = survivor(job, tails[corners + 2u]);
        indices[out + 3u] = 0xffffffffu;
    }
}
