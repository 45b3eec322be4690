//! The `g1tess` command line: see `src/cli/`.

fn main() -> std::process::ExitCode {
    g1tess::run_cli()
}

/// On Linux, the command line's large buffers ask the kernel for transparent huge pages.
///
/// The mesh, its tables and the stitch plan of a 2 M-triangle mesh fill about 880 MB of
/// fresh pages; faulting them in 4 KiB at a time took 0.9 s of system time (of 2.3 s
/// wall) in `tessellate --scheme flat --level 1`, and 0.4–0.55 s with huge pages, where the
/// kernel offers them only on request (`transparent_hugepage/enabled` = `madvise`, the
/// common default). The allocator is the system's; only the request is added, on the
/// whole 2 MiB pages inside allocations of [`huge::LARGE`] bytes or more. The library
/// itself leaves the allocator to its host.
#[cfg(target_os = "linux")]
mod huge {
    use std::alloc::{GlobalAlloc, Layout, System};

    /// The size of a transparent huge page on x86-64 and most aarch64 kernels.
    const HUGE: usize = 2 << 20;
    /// Allocations from this size on get the request: below it, rounding to whole huge
    /// pages would leave little inside.
    pub const LARGE: usize = 4 * HUGE;

    /// [`System`], with `madvise(MADV_HUGEPAGE)` on large allocations.
    pub struct HugePages;

    /// Asks for huge pages on the whole huge pages inside `size` bytes at `p`. Advice only:
    /// a kernel that refuses it (or has no transparent huge pages) changes nothing.
    fn advise(p: *mut u8, size: usize) {
        if p.is_null() || size < LARGE {
            return;
        }
        let start = (p as usize).next_multiple_of(HUGE);
        let end = (p as usize + size) / HUGE * HUGE;
        if end > start {
            // SAFETY: the range lies inside the allocation just made; the advice changes
            // how its pages are backed, never their contents.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
    }

    // SAFETY: every method is `System`'s, with advice added on the memory it returns.
    unsafe impl GlobalAlloc for HugePages {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            // SAFETY: the caller's contract, passed on.
            let p = unsafe { System.alloc(layout) };
            advise(p, layout.size());
            p
        }

        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            // SAFETY: the caller's contract, passed on.
            let p = unsafe { System.alloc_zeroed(layout) };
            advise(p, layout.size());
            p
        }

        unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
            // SAFETY: the caller's contract, passed on.
            unsafe { System.dealloc(p, layout) }
        }

        unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            // SAFETY: the caller's contract, passed on.
            let q = unsafe { System.realloc(p, layout, new_size) };
            advise(q, new_size);
            q
        }
    }

    #[global_allocator]
    static ALLOCATOR: HugePages = HugePages;
}
