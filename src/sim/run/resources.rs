//! CPU time and memory of the running simulation (Linux /proc; zero elsewhere).

/// CPU seconds used by the calling thread (falls back to process CPU time).
pub fn thread_cpu_seconds() -> f64 {
    // schedstat: first field is nanoseconds spent on the CPU.
    for path in ["/proc/thread-self/schedstat", "/proc/self/schedstat"] {
        if let Ok(s) = std::fs::read_to_string(path)
            && let Some(ns) = s
                .split_whitespace()
                .next()
                .and_then(|v| v.parse::<f64>().ok())
        {
            return ns * 1e-9;
        }
    }
    0.0
}

/// Peak resident memory of the process (VmHWM), in bytes.
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

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
