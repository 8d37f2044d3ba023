//! Table 1's sizes (`morphlod bench --baselines`), measured: a counting global allocator gives
//! the heap bytes of each model's buffers as what dropping it frees, on the bench's cow (its QEM
//! sequence and strips). LodStrips' own size reports (its model, Table 1's row, and its
//! runtime state) are its buffers; no baseline reports more than its buffers hold; and with
//! one instance's runtime state each, LodStrips holds the fewest bytes (the paper's claim, a
//! size; the baselines keep their state inside the model, so model and state are measured
//! together). Its own test binary (one test) so that no other test allocates while it
//! measures; tests/suite/baselines.rs checks the bench's report of the same sizes.

use live_heap::held;
use morphlod::lodstrips::{LodStrips, StripsState};
use morphlod::simplify::SimplifyOptions;

#[path = "../src/bin/morphlod/baselines/mod.rs"]
#[allow(dead_code)] // the bench uses what the sizes do not (regions, LODs)
mod model;

use model::mts::Mts;
use model::pm::ProgressiveMesh;
use model::skip_strips::SkipStrips;
use model::Baseline;

#[path = "common/live_heap.rs"]
mod live_heap;

#[global_allocator]
static ALLOCATOR: live_heap::Counting = live_heap::Counting;

#[test]
fn lodstrips_holds_the_fewest_bytes() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cow.off");
    let mesh = morphlod::io::load_mesh(&path, &Default::default()).expect("the cow loads");
    let seq = morphlod::simplify::simplify(
        &mesh.positions,
        &mesh.triangles,
        &SimplifyOptions::default(),
    );
    let strips = morphlod::strip::stripify(&mesh.triangles, mesh.positions.len());

    let lodstrips = LodStrips::build(&strips, &seq).expect("LodStrips builds");
    let state = StripsState::new(&lodstrips);
    let reported = (lodstrips.byte_size(), state.heap_bytes());
    let measured = (held(state), held(lodstrips));
    let measured = (measured.1, measured.0);
    println!(
        "LodStrips: model {} and state {} bytes, reported {reported:?}",
        measured.0, measured.1
    );
    // The allocator's bytes are the buffers' capacities: equal to their lengths here, but for
    // a few words of rounding.
    for (what, m, r) in [
        ("model", measured.0, reported.0),
        ("state", measured.1, reported.1),
    ] {
        assert!(
            m.abs_diff(r) <= 64,
            "LodStrips reports its {what} as {r} bytes, its buffers hold {m}"
        );
    }
    let ours = measured.0 + measured.1;

    let baselines: [(&str, Box<dyn Baseline>); 3] = [
        (
            "PM",
            Box::new(ProgressiveMesh::build(&mesh.triangles, &seq).expect("PM")),
        ),
        ("MTS", Box::new(Mts::build(&strips, &seq).expect("MTS"))),
        (
            "Skip Strips",
            Box::new(SkipStrips::build(&strips, &seq).expect("Skip Strips")),
        ),
    ];
    for (name, model) in baselines {
        let reported = model.model_bytes() + model.state_bytes();
        let theirs = held(model);
        println!("{name}: model and state {theirs} bytes, reported {reported}");
        assert!(
            reported <= theirs,
            "{name} reports {reported} bytes, its buffers hold {theirs}"
        );
        assert!(
            ours < theirs,
            "LodStrips holds {ours} bytes, {name} {theirs}"
        );
    }
}
