//! The live heap bytes of the whole process, for the test binaries that measure memory by
//! allocation (tests/frame_memory.rs, tests/crowd_alloc.rs, tests/baseline_sizes.rs), each
//! alone in its binary so that no other test allocates while it measures. A binary includes
//! this file (`#[path = "common/live_heap.rs"] mod live_heap;`) and installs the allocator:
//! `#[global_allocator] static ALLOCATOR: live_heap::Counting = live_heap::Counting;`.
#![allow(dead_code)] // each binary uses a part of it

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering};

/// The system allocator, counting the bytes allocated and not yet freed (by every thread; a
/// driver's own `malloc`s are not Rust allocations and are not counted).
pub struct Counting;

static LIVE: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LIVE.fetch_add(layout.size() as isize, Ordering::SeqCst);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size() as isize, Ordering::SeqCst);
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LIVE.fetch_add(new_size as isize - layout.size() as isize, Ordering::SeqCst);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Heap bytes live now.
pub fn live() -> isize {
    LIVE.load(Ordering::SeqCst)
}

/// The heap bytes `value` holds: what dropping it frees.
pub fn held<T>(value: T) -> usize {
    let before = live();
    drop(value);
    (before - live()) as usize
}
