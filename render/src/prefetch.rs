//! Asking the cache for data a moment before it is read, where the address is known early and
//! the read would otherwise wait on memory.

/// Asks the cache for every line of `items` (a no-op where the processor has no such hint).
#[inline(always)]
pub fn prefetch<T>(items: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let start = items.as_ptr().cast::<u8>();
        for line in (0..std::mem::size_of_val(items)).step_by(64) {
            // SAFETY: prefetching never faults, and the address lies within `items`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.add(line).cast()) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = items;
}
