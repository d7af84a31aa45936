//! The `tapeshape` binary's memory allocator: the system's, asking Linux
//! for transparent huge pages on large blocks.
//!
//! Why: a whole `tapeshape predict` touches about 80 MB of fresh memory (the
//! cached model's basis, the smooth basis, the meshes, the per-round
//! arrays), and with 4 KiB pages that was about 20,000 page faults, each
//! clearing a page: a fifth of the process's time (`perf stat`; issue 13's
//! 120 ms target). Two remedies, measured together with `perf stat -r 20`
//! on the cached quick-set prediction: 19,600 -> 4,200 page faults and
//! 138 -> 111 ms; without the huge-page hint, 13,300 faults and 120-131 ms.
//!
//! - [`HugePageHint`]: blocks of at least 2 MiB are aligned to 2 MiB and
//!   advised `MADV_HUGEPAGE` (ignored where transparent huge pages are
//!   `never`); everything else goes to the system allocator as is.
//! - [`tune`]: glibc keeps freed memory and serves blocks below 32 MiB from
//!   its heap, so the arrays a prediction allocates round after round reuse
//!   pages already in place.
//!
//! glibc's own `GLIBC_TUNABLES=glibc.malloc.hugetlb=1` does about as well
//! (111 ms), but tunables are read only from the environment at process
//! start, which a user's shell does not set; mimalloc (branch `h/mimalloc`)
//! was as fast but held 163 MiB at its peak, above the 150 MiB target. No
//! crate offers only this hint, so it is written here.

use std::alloc::{GlobalAlloc, Layout, System};

/// Size of a huge page on x86-64 and aarch64 Linux, and the smallest block
/// given the hint.
const HUGE: usize = 2 << 20;

/// The system allocator with the huge-page hint on blocks of at least
/// 2 MiB (see the module docs).
pub struct HugePageHint;

impl HugePageHint {
    /// The layout a large block is allocated with: aligned to a huge page,
    /// so that its whole huge pages can be advised.
    fn large(layout: Layout) -> Option<Layout> {
        (layout.size() >= HUGE)
            .then(|| layout.align_to(HUGE).ok())
            .flatten()
    }
}

/// Asks for huge pages on the whole huge pages of `[p, p + size)`; `p` is
/// aligned to [`HUGE`]. Advice only: a failure changes nothing.
fn advise(p: *mut u8, size: usize) {
    let len = size & !(HUGE - 1);
    if !p.is_null() && len > 0 {
        // SAFETY: [p, p + len) lies inside the block just allocated, and
        // MADV_HUGEPAGE changes no content, only how pages are backed.
        unsafe {
            libc::madvise(p.cast(), len, libc::MADV_HUGEPAGE);
        }
    }
}

// SAFETY: every block comes from `System` and goes back to it with the same
// layout it was allocated with: the choice between the plain and the
// aligned layout depends only on the size, which the caller passes back
// unchanged.
unsafe impl GlobalAlloc for HugePageHint {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        match Self::large(layout) {
            Some(big) => {
                // SAFETY: `big` has a non-zero size (at least HUGE).
                let p = unsafe { System.alloc(big) };
                advise(p, big.size());
                p
            }
            // SAFETY: forwarded as the caller gave it.
            None => unsafe { System.alloc(layout) },
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        match Self::large(layout) {
            Some(big) => {
                // Advised before it is zeroed: the system's aligned
                // `alloc_zeroed` writes the zeros itself, which would fault
                // every small page in before the advice.
                // SAFETY: as in `alloc`; the block is `big.size()` bytes.
                unsafe {
                    let p = System.alloc(big);
                    advise(p, big.size());
                    if !p.is_null() {
                        std::ptr::write_bytes(p, 0, big.size());
                    }
                    p
                }
            }
            // SAFETY: forwarded as the caller gave it.
            None => unsafe { System.alloc_zeroed(layout) },
        }
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        let layout = Self::large(layout).unwrap_or(layout);
        // SAFETY: `p` was allocated by `System` with this very layout.
        unsafe { System.dealloc(p, layout) }
    }

    unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let new_layout = match Layout::from_size_align(new_size, layout.align()) {
            Ok(l) => l,
            Err(_) => return std::ptr::null_mut(),
        };
        if Self::large(layout).is_none() && Self::large(new_layout).is_none() {
            // SAFETY: a plain block stays a plain block: forwarded.
            return unsafe { System.realloc(p, layout, new_size) };
        }
        // A block that is or becomes large: a new block, the contents
        // copied, the old one freed (as the default `realloc` does).
        // SAFETY: `new_layout` is valid and non-zero (one of the sizes is
        // at least HUGE, and a shrink to 0 is not allowed by the caller's
        // contract); the old block is valid for `layout.size()` bytes.
        unsafe {
            let q = self.alloc(new_layout);
            if !q.is_null() {
                std::ptr::copy_nonoverlapping(p, q, layout.size().min(new_size));
                self.dealloc(p, layout);
            }
            q
        }
    }
}

/// Tunes glibc's allocator for this program's working set (call first
/// thing in `main`): blocks below 32 MiB come from the heap rather than
/// from fresh mappings, and freed heap memory is kept for the next block.
/// Why: a prediction allocates and frees arrays of 0.3-2 MB round after
/// round (segment rows, vertex vectors); as fresh mappings each one's pages
/// were faulted in and cleared again every round (about 10,000 page faults
/// per `tapeshape predict`, measured with `perf record -e page-faults`).
/// No-op elsewhere than glibc.
pub fn tune() {
    #[cfg(target_env = "gnu")]
    // SAFETY: mallopt only sets allocator parameters; called before any
    // other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
        libc::mallopt(libc::M_TOP_PAD, 16 << 20);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Large blocks are aligned to a huge page, and contents survive every
    /// kind of growth and shrinking across the threshold.
    #[test]
    fn blocks_keep_their_contents_across_the_threshold() {
        let a = HugePageHint;
        let sizes = [64, HUGE - 8, HUGE, 3 * HUGE + 24, 100, 5 * HUGE, 8];
        let mut layout = Layout::from_size_align(sizes[0], 8).unwrap();
        // SAFETY: sizes are non-zero; each block is used within its size
        // and freed with the layout it was last given.
        unsafe {
            let mut p = a.alloc(layout);
            assert!(!p.is_null());
            for i in 0..layout.size() {
                *p.add(i) = (i % 251) as u8;
            }
            for &size in &sizes[1..] {
                let keep = layout.size().min(size);
                p = a.realloc(p, layout, size);
                assert!(!p.is_null());
                layout = Layout::from_size_align(size, 8).unwrap();
                if size >= HUGE {
                    assert!(
                        (p as usize).is_multiple_of(HUGE),
                        "a large block is aligned"
                    );
                }
                for i in 0..keep {
                    assert_eq!(
                        *p.add(i),
                        (i % 251) as u8,
                        "byte {i} after resizing to {size}"
                    );
                }
                for i in keep..size {
                    *p.add(i) = (i % 251) as u8;
                }
            }
            a.dealloc(p, layout);
            let z = Layout::from_size_align(3 * HUGE, 16).unwrap();
            let q = a.alloc_zeroed(z);
            assert!(!q.is_null() && (q as usize).is_multiple_of(HUGE));
            assert!((0..z.size()).step_by(4093).all(|i| *q.add(i) == 0));
            a.dealloc(q, z);
        }
    }
}
