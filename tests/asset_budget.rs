//! Issue 13 item 2: a small file must not make a huge asset. A `.mlod` whose 4,096 frames
//! repeat one frame costs two bytes a frame in the file; after load it must hold that
//! frame once, and a file over the memory budget is refused before it is decoded.
//!
//! These tests measure the resident set (`/proc/self/statm`), so they live in their own
//! test binary and take one lock: nothing else allocates beside them.

use morphlod::asset::{AssetError, AssetLoadOptions};
use morphlod::build::Builder;
use morphlod::deform::{DeformError, DeformingModel};
use morphlod::Asset;
use std::sync::Mutex;

mod common;
use common::grid_morph;

static ALONE: Mutex<()> = Mutex::new(());

/// Resident set in bytes (Linux: the second field of `/proc/self/statm`, in 4 KiB pages).
fn rss() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").expect("/proc/self/statm");
    let pages: u64 = statm.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * 4096
}

const MB: u64 = 1 << 20;

/// A valid file (checksum included) of a `side`² grid whose `frames` frames all repeat
/// frame 0: 160 KB for 71² vertices and 4,096 frames.
fn repeated_frames(side: u32, frames: usize) -> Vec<u8> {
    let morph = grid_morph(side, |x, y| ((x * 7 + y * 3) % 5) as f32 * 0.1);
    let (mut asset, _) = Builder::new(&morph).frames(1).build().expect("build");
    let frame = asset.frames[0].clone();
    asset.frames = vec![frame; frames];
    asset.to_bytes()
}

/// Bound: the load grows the resident set by at most 16 MB. When every frame held its own
/// copy it grew by 4,096 × 5,040 collapses × 12 B = 248 MB.
#[test]
fn repeated_frames_load_once_and_stay_small() {
    let _alone = ALONE.lock().unwrap();
    let bytes = repeated_frames(71, 4096);
    assert!(
        bytes.len() < 200_000,
        "the crafted file is {} bytes",
        bytes.len()
    );
    // Warm the allocator and the thread pool on a small file first.
    drop(Asset::from_bytes(&repeated_frames(5, 4)).unwrap());

    let before = rss();
    let asset = Asset::from_bytes(&bytes).expect("a valid file");
    let growth = rss().saturating_sub(before);
    assert!(
        growth < 16 * MB,
        "loading a {}-byte file grew the resident set by {} MB (bound 16 MB)",
        bytes.len(),
        growth / MB
    );
    assert_eq!(asset.frames.len(), 4096);
    assert_eq!(asset.distinct_frames(), 1);
    assert!(
        asset.heap_bytes() < 2 * bytes.len(),
        "the asset holds {} bytes for a {}-byte file",
        asset.heap_bytes(),
        bytes.len()
    );

    // The model too holds the one frame once (bound: 32 MB more).
    let before = rss();
    let model = DeformingModel::new(&asset).expect("a valid asset");
    let growth = rss().saturating_sub(before);
    assert_eq!(model.distinct_frames(), 1);
    assert!(
        growth < 32 * MB,
        "the model grew the resident set by {} MB (bound 32 MB)",
        growth / MB
    );
    // DeformingModel::with_budget's estimate is above what a frame really takes.
    let slots = asset.s0.indices.len();
    let collapses = asset.frames[0].len();
    let estimate = 16 * slots + 64 * collapses + 256;
    assert!(
        model.frame_bytes()[0] <= estimate,
        "{:?} > {estimate}",
        model.frame_bytes()[0]
    );
}

/// A file whose load would need more than the budget is refused with `OverBudget`, and
/// nothing large is allocated (the resident set grows by under 1 MB).
#[test]
fn over_budget_file_is_refused_before_allocating() {
    let _alone = ALONE.lock().unwrap();
    let bytes = repeated_frames(71, 4096);
    let options = AssetLoadOptions {
        max_bytes: 64 * 1024,
    };
    drop(Asset::from_bytes_with(&repeated_frames(5, 4), &AssetLoadOptions::default()).unwrap());

    let before = rss();
    let result = Asset::from_bytes_with(&bytes, &options);
    let growth = rss().saturating_sub(before);
    match result {
        Err(AssetError::OverBudget { needed, budget }) => {
            assert_eq!(budget, 64 * 1024);
            assert!(needed > budget);
        }
        other => panic!("expected OverBudget, got {other:?}"),
    }
    assert!(
        growth < MB,
        "the refused load grew the resident set by {growth} bytes"
    );
    let message = Asset::from_bytes_with(&bytes, &options)
        .unwrap_err()
        .to_string();
    assert!(message.contains("--memory-budget"), "{message}");

    // From a path: a file longer than the budget is refused before it is read.
    let path = std::env::temp_dir().join(format!("morphlod-budget-{}.mlod", std::process::id()));
    std::fs::write(&path, &bytes).unwrap();
    let tiny = AssetLoadOptions { max_bytes: 1000 };
    let result = Asset::load_with(&path, &tiny);
    std::fs::remove_file(&path).unwrap();
    assert!(
        matches!(result, Err(AssetError::OverBudget { needed, budget: 1000 }) if needed == bytes.len() as u64),
        "{result:?}"
    );

    // The default budget takes it; a tiny model budget refuses the model, typed.
    let asset = Asset::from_bytes(&bytes).unwrap();
    assert!(matches!(
        DeformingModel::with_budget(&asset, 1024),
        Err(DeformError::OverBudget { budget: 1024, .. })
    ));
}
