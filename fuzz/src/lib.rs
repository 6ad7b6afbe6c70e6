//! Shared by the fuzz targets: a global allocator that aborts on any single allocation over
//! 1 GiB. libFuzzer's `-malloc_limit_mb` relies on a sanitizer's malloc hooks, which a stable
//! (sanitizer-free) build does not have; its `-rss_limit_mb` still bounds the total.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;

/// The largest allocation an input may cause.
pub const LIMIT_BYTES: usize = 1 << 30;

pub struct LimitedAlloc;

fn check(size: usize) {
    if size > LIMIT_BYTES {
        // stderr is unbuffered: no allocation here. The abort is reported by libFuzzer as a
        // crash, with the input saved.
        let _ = std::io::stderr().write_all(b"==ERROR: fuzz target: one allocation over 1 GiB\n");
        std::process::abort();
    }
}

// SAFETY: forwards to the system allocator unchanged; only the size is looked at first.
unsafe impl GlobalAlloc for LimitedAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        check(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        check(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        check(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}
