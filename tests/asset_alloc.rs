//! Decoding never allocates more than the file's size justifies: a counting
//! global allocator records the largest single allocation made while a
//! `.mlod` image is decoded. Its own test binary (one test) so that no other
//! test allocates while it measures.

use morphlod::asset::HEADER_LEN;
use morphlod::build::Builder;
use morphlod::Asset;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

mod common;
use common::{fix_header, grid_morph};

struct Counting;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Each decoded byte may become a few dozen bytes of arrays (a one-byte
/// strip index becomes up to six 4-byte neighbour entries, a frame byte up to
/// 8/3 collapses of 12 bytes); anything beyond this is an allocation the file
/// did not pay for. (Measured on this file: about 1.2 times its size.)
fn justified(len: usize) -> usize {
    32 * len + 4096
}

#[test]
fn decoding_allocates_what_the_file_justifies() {
    let morph = grid_morph(12, |x, y| (x as f32 * 0.7).sin() * y as f32);
    let (asset, _) = Builder::new(&morph).frames(3).build().unwrap();
    let original = asset.to_bytes();
    // Warm the rayon pool so its one-time setup is not counted.
    Asset::from_bytes(&original).unwrap();

    // Every 8-byte window overwritten with large counts, checksum repaired:
    // every count field of every section gets a turn.
    let mut worst = (0usize, 0usize);
    for at in HEADER_LEN..original.len() {
        for value in [u64::MAX, 1 << 40, u64::from(u32::MAX), 0x7F7F_7F7F] {
            let mut bytes = original.clone();
            let end = (at + 8).min(bytes.len());
            bytes[at..end].copy_from_slice(&value.to_le_bytes()[..end - at]);
            fix_header(&mut bytes);
            LARGEST.store(0, Ordering::Relaxed);
            let _ = Asset::from_bytes(&bytes);
            let largest = LARGEST.load(Ordering::Relaxed);
            if largest > worst.0 {
                worst = (largest, at);
            }
        }
    }
    assert!(
        worst.0 <= justified(original.len()),
        "a {}-byte file made the decoder allocate {} bytes at once (mutation at byte {})",
        original.len(),
        worst.0,
        worst.1
    );
}
