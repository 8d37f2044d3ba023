// morphlod: index edits applied on the GPU, for gpu::Object::prepare (a frame's changed words
// of an object's index buffer) and gpu::Crowd::prepare (an asset's index slots and records).
//
// The CPU gathers the changed words into one list, uploaded with one write, and one dispatch
// applies it. Each entry of the list is the header of a run of 1 to 16 consecutive words, so a
// run costs 8 bytes plus 4 per word, not 8 per word. A single word carries its value inline:
// [word | 1 << 31, value]; a longer run is [first word, (v << 4) | (length - 1)] with its values
// at u32 v, v + 1, .. of this same list (after the headers). Each invocation makes 16 stores,
// unrolled; store k of a shorter run repeats the run's last word (same word, same value): no
// loop and no branch. The list is padded to whole workgroups by repeating its last header. Runs
// never share a word (the invocations run in any order on a real GPU).

@group(0) @binding(0) var<storage, read> patches: array<vec2<u32>>;
@group(0) @binding(1) var<storage, read_write> indices: array<u32>;

fn run_value(at: u32) -> u32 {
    let pair = patches[at >> 1u];
    return select(pair.x, pair.y, (at & 1u) == 1u);
}

fn run_store(run: vec2<u32>, k: u32) {
    let single = run.x >= 0x80000000u;
    let i = min(k, select(run.y & 15u, 0u, single));
    // An inline word's offset is meaningless; the read is bounds-checked and not selected.
    let value = select(run_value((run.y >> 4u) + i), run.y, single);
    indices[(run.x & 0x7fffffffu) + i] = value;
}

@compute @workgroup_size(16)
fn scatter_runs(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let run = patches[id.x + id.y * groups.x * 16u];
    run_store(run, 0u);
    run_store(run, 1u);
    run_store(run, 2u);
    run_store(run, 3u);
    run_store(run, 4u);
    run_store(run, 5u);
    run_store(run, 6u);
    run_store(run, 7u);
    run_store(run, 8u);
    run_store(run, 9u);
    run_store(run, 10u);
    run_store(run, 11u);
    run_store(run, 12u);
    run_store(run, 13u);
    run_store(run, 14u);
    run_store(run, 15u);
}
