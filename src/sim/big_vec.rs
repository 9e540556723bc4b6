//! Large arrays of the engine and the event calendar, in memory the kernel may
//! back with huge pages.

/// Arrays smaller than this stay on ordinary pages.
const HUGE_MIN_BYTES: usize = 4 << 20;

/// `n` copies of `value` in memory that the kernel may back with 2 MB pages
/// (Linux transparent huge pages in `madvise` mode). Events of a large system touch
/// disks at random places; with 4 kB pages nearly every such access also misses
/// the TLB. The advice is given before the pages are first written, so they are
/// allocated huge at once; it is only advice (ignored where unsupported).
pub fn big_vec<T: Clone>(n: usize, value: T) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    advise_huge_pages(v.as_mut_ptr() as *mut u8, n * std::mem::size_of::<T>());
    v.resize(n, value);
    v
}

/// Collect an iterator of known length into a [`big_vec`]-style allocation.
pub fn big_vec_from<T>(n: usize, items: impl IntoIterator<Item = T>) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    advise_huge_pages(v.as_mut_ptr() as *mut u8, n * std::mem::size_of::<T>());
    v.extend(items);
    v
}

#[cfg(target_os = "linux")]
fn advise_huge_pages(ptr: *mut u8, bytes: usize) {
    const HUGE: usize = 2 << 20;
    if bytes < HUGE_MIN_BYTES {
        return;
    }
    // The whole 2 MB pages inside the allocation.
    let start = (ptr as usize).div_ceil(HUGE) * HUGE;
    let end = (ptr as usize + bytes) / HUGE * HUGE;
    if end > start {
        // SAFETY: [start, end) lies inside the allocation just made; MADV_HUGEPAGE
        // changes no contents, only how the kernel backs the pages.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_ptr: *mut u8, _bytes: usize) {}
