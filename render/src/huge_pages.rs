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
