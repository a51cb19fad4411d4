//! Which vector instructions the processor has, checked once: the hot loops that gain most
//! from AVX2 (BVH traversal, Sobol points) are compiled twice and pick at run time, so the
//! binary still runs on any x86-64.

/// Whether the processor has AVX2 and the bit instructions that came with it (POPCNT, LZCNT,
/// BMI1), which the traversal's bookkeeping uses in place of multiply-and-shift emulations.
/// Every processor with AVX2 has them; checked all the same, once.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn has_avx2_set() -> bool {
    use std::sync::atomic::{AtomicU8, Ordering};
    // 0: not checked yet, 1: no, 2: yes.
    static FOUND: AtomicU8 = AtomicU8::new(0);
    match FOUND.load(Ordering::Relaxed) {
        0 => {
            let found = std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("popcnt")
                && std::arch::is_x86_feature_detected!("lzcnt")
                && std::arch::is_x86_feature_detected!("bmi1");
            FOUND.store(1 + found as u8, Ordering::Relaxed);
            found
        }
        state => state == 2,
    }
}
