//! The production path and the file format pinned down.
//!
//! * `production_path_walk_matches_the_reference`: `Builder` → `.mlod` bytes → `Asset::from_bytes`
//!   → `DeformingModel`, then a random walk of `(t, Lod::MaxError(e))` with frame switches, where
//!   `e` takes the (bfloat16-quantised) errors stored in the file: after every step the strips
//!   (a mirror updated only through the dirty log, decoded by the GPU's strip rules) draw the
//!   reference mesh of frame `k` at the LOD the error bound selects, computed here from the
//!   loaded sequence; the model of the asset before saving resolves every request alike.
//! * `golden_file_matches_a_fresh_build`: `tests/data/golden_grid.mlod` (see
//!   `tests/data/README.md`) must still load, hold what a fresh build holds, and, while the
//!   format version is unchanged, be byte for byte what the encoder writes today. A format change
//!   made in the encoder and decoder together fails here until the version is bumped.

use crate::common;

use std::path::{Path, PathBuf};

use common::{grid_morph, Mirror, Rng};
use morphlod::collapse::canonical_multiset;
use morphlod::io::LoadOptions;
use morphlod::io::MorphSource;
use morphlod::{Asset, Builder, DeformingModel, DeformingState, Lod};

/// The golden file's source: a 9 × 9 grid whose heights are exact binary fractions (no
/// transcendental functions, so every platform builds the same poses), 4 frames.
fn golden_asset() -> Asset {
    let morph = grid_morph(9, |x, y| {
        ((x * 7 + y * 3) % 5) as f32 * 0.25 + (x * y) as f32 / 64.0
    });
    Builder::new(&morph)
        .frames(4)
        .build()
        .expect("the golden grid builds")
        .0
}

fn golden_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden_grid.mlod")
}

/// Regenerates the golden file: `MORPHLOD_BLESS=1 cargo test --test suite asset_golden::`.
fn bless_requested() -> bool {
    std::env::var("MORPHLOD_BLESS").is_ok_and(|v| v == "1")
}

#[test]
fn golden_file_matches_a_fresh_build() {
    let fresh = golden_asset();
    let bytes = fresh.to_bytes();
    let path = golden_path();
    if bless_requested() {
        std::fs::write(&path, &bytes).expect("tests/data is writable");
        eprintln!("wrote {} ({} bytes)", path.display(), bytes.len());
    }
    let golden = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; regenerate it with `MORPHLOD_BLESS=1 cargo test --test suite asset_golden::`",
            path.display()
        )
    });
    // Older files must keep loading, with the same content.
    let loaded = Asset::from_bytes(&golden).unwrap_or_else(|e| {
        panic!(
            "the golden file no longer loads ({e}): files written by earlier versions of the \
             format must stay readable"
        )
    });
    assert!(
        loaded == fresh,
        "the golden file loads, but holds another asset than a fresh build of its source"
    );
    let version = u16::from_le_bytes([golden[8], golden[9]]);
    let current = fresh.format_version();
    if version == current {
        assert!(
            golden == bytes,
            "the encoder writes other bytes than tests/data/golden_grid.mlod ({} vs {} bytes) \
             under the same format version {current}. If the format changed on purpose: bump \
             asset::VERSION (or VERSION_PLAIN), keep reading version-{version} files (keep this golden file as \
             golden_grid_v{version}.mlod and load it here), then write the new golden file with \
             `MORPHLOD_BLESS=1 cargo test --test suite asset_golden::`",
            bytes.len(),
            golden.len()
        );
    }
}

/// The coarsest LOD of `frame` whose collapse errors, as distances (square roots of the stored
/// mean squared distances), are all at most `bound`.
fn lod_for_error(asset: &Asset, frame: usize, bound: f32) -> usize {
    asset.frames[frame]
        .collapses
        .iter()
        .take_while(|c| c.error.max(0.0).sqrt() <= bound)
        .count()
}

#[test]
fn production_path_walk_matches_the_reference() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_head.glb");
    let morph = morphlod::io::load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("morph".into()),
    )
    .expect("the head's animation loads");
    const FRAMES: usize = 5;
    let (built, _) = Builder::new(&morph)
        .frames(FRAMES)
        .build()
        .expect("the head builds");
    let bytes = built.to_bytes();
    let asset = Asset::from_bytes(&bytes).expect("the file reads back");
    assert!(asset == built, "the asset survives its file unchanged");
    let model = DeformingModel::new(&asset).expect("the loaded asset is valid");
    let unsaved = DeformingModel::new(&built).expect("the built asset is valid");
    let tris = morph.triangles();

    // Error bounds: stored errors (exact ties with the file's quantised values), values between
    // them, below all and above all.
    let mut bounds: Vec<f32> = asset
        .frames
        .iter()
        .flat_map(|seq| seq.collapses.iter().map(|c| c.error.max(0.0).sqrt()))
        .collect();
    bounds.sort_by(f32::total_cmp);
    bounds.dedup();
    let mut rng = Rng(0x000D_15C0);
    let mut state = DeformingState::new(&model);
    let mut mirror = Mirror::new(state.region_offsets(), state.indices(), state.lengths());
    let mut seen = (0usize, 0usize);
    for step in 0..150 {
        let t = match rng.below(3) {
            0 => rng.below(FRAMES) as f32 / (FRAMES - 1) as f32,
            _ => rng.unit(),
        };
        let bound = match rng.below(8) {
            0 => -1.0,
            1 => f32::MAX,
            2 => {
                let i = rng.below(bounds.len() - 1);
                0.5 * (bounds[i] + bounds[i + 1])
            }
            _ => bounds[rng.below(bounds.len())],
        };
        let lod = Lod::MaxError(bound);
        state.set(&model, t, lod).expect("valid request");
        let k = (t * (FRAMES - 1) as f32).round() as usize;
        let l = lod_for_error(&asset, k, bound);
        let at = format!("step {step}: t {t}, MaxError({bound}) → frame {k}, LOD {l}");
        assert_eq!((state.frame(), state.lod()), (k, l), "{at}");
        assert_eq!(
            unsaved.resolve(k, lod),
            Ok(l),
            "{at}: the asset before saving resolves another LOD"
        );
        let dirty = state.take_dirty();
        mirror.upload(&dirty, state.indices(), state.lengths());
        assert_eq!(
            canonical_multiset(mirror.triangles()),
            canonical_multiset(asset.frames[k].reference_mesh(tris, l)),
            "{at}: drawn triangles differ from the reference"
        );
        seen.0 += usize::from(l > 0 && l < asset.frames[k].len());
        seen.1 += usize::from(k != 0 && k != FRAMES - 1);
    }
    assert!(
        seen.0 >= 50 && seen.1 >= 20,
        "the walk must visit intermediate LODs and frames: {seen:?}"
    );
}
