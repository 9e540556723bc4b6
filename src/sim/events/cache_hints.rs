//! Cache hints: ask for a line before it is read. They never fault and change
//! no result.

/// A hint to bring `r`'s cache line in; it never faults and changes nothing.
#[inline(always)]
pub(crate) fn prefetch<T>(r: &T) {
    prefetch_ptr(r as *const T);
}

/// [`prefetch`] of `v[k]` for any `k`, without a bounds check: out of range
/// it fetches a useless line (for guesses that may be off, e.g. cells across
/// a periodic edge, or event partners that are codes rather than disks).
#[inline(always)]
pub(crate) fn prefetch_index<T>(v: &[T], k: usize) {
    prefetch_ptr(v.as_ptr().wrapping_add(k));
}

#[inline(always)]
fn prefetch_ptr<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: prefetching is only a hint to the cache; any address is allowed.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(p.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
