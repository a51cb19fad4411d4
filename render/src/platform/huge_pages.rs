//! Large arrays that rays read at random (BVH nodes, leaf primitives) backed by 2 MiB pages
//! where the kernel gives them on request (transparent huge pages in `madvise` mode, Linux's
//! usual default). With 4 KiB pages, a ray's few dozen reads scattered over tens of megabytes
//! each miss the TLB as well as the cache.

/// The size of a huge page on x86-64 and most AArch64 kernels.
const HUGE_PAGE: usize = 2 << 20;

/// An empty vector with room for `capacity` items, whose whole 2 MiB spans the kernel is asked
/// to back with huge pages before they are first written (smaller ones are left as they are).
pub fn with_capacity<T>(capacity: usize) -> Vec<T> {
    let mut out: Vec<T> = Vec::with_capacity(capacity);
    advise(
        out.as_mut_ptr().cast(),
        out.capacity() * std::mem::size_of::<T>(),
    );
    out
}

/// `items` gathered into a vector from [`with_capacity`].
pub fn collect<T>(items: impl IntoIterator<Item = T, IntoIter: ExactSizeIterator>) -> Vec<T> {
    let items = items.into_iter();
    let mut out = with_capacity(items.len());
    out.extend(items);
    out
}

/// `items`, built elsewhere, moved into huge pages: copied into a vector from
/// [`with_capacity`] when it spans one, returned as it is when it is too small to.
pub fn adopt<T>(items: Vec<T>) -> Vec<T> {
    if items.capacity() * std::mem::size_of::<T>() < HUGE_PAGE {
        return items;
    }
    collect(items)
}

/// Asks for huge pages over the 2 MiB-aligned spans of `bytes` bytes from `start`. Only
/// advice: where the kernel declines, the memory keeps its ordinary pages.
#[cfg(target_os = "linux")]
fn advise(start: *mut u8, bytes: usize) {
    if bytes < HUGE_PAGE {
        return;
    }
    let first = (start as usize).next_multiple_of(HUGE_PAGE);
    let end = (start as usize + bytes) / HUGE_PAGE * HUGE_PAGE;
    if first < end {
        // SAFETY: the span lies inside one live allocation of ours, and MADV_HUGEPAGE changes
        // only how it is paged, never its contents or whether it is mapped.
        unsafe {
            libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise(_: *mut u8, _: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_vectors_stay_put_and_large_ones_keep_their_items() {
        let small: Vec<u32> = (0..1000).collect();
        let at = small.as_ptr();
        let kept = adopt(small);
        assert_eq!(kept.as_ptr(), at, "a small vector is not copied");
        let large: Vec<u64> = (0..(HUGE_PAGE as u64)).collect();
        let moved = adopt(large);
        assert_eq!(moved.len(), HUGE_PAGE);
        assert!(moved.iter().enumerate().all(|(i, &v)| v == i as u64));
        let gathered = collect((0..5u8).map(|k| k * 2));
        assert_eq!(gathered, [0, 2, 4, 6, 8]);
    }
}
