//! Which vector instructions the processor has, checked once: the hot loops that gain most
//! from AVX2 (BVH traversal, Sobol points) are compiled twice and pick at run time, so a
//! baseline build (`RUSTFLAGS="-C target-cpu=x86-64"`) runs on any x86-64 and still uses AVX2
//! where present. The default build targets x86-64-v3 (`.cargo/config.toml`): there the check
//! is answered at compile time and only the AVX2 compilation remains.
//!
//! [`run`] picks for work written once as a [`TwoWays`]: its body is compiled for AVX2 and
//! for the baseline, and everything it inlines goes with it. A call from baseline code into
//! AVX2 code cannot be inlined, so the boundary belongs at the top of a whole query (a
//! triangle query's ray set-up crossed it at about 75 instructions a query).

/// Whether the processor has AVX2 and the bit instructions that came with it (POPCNT, LZCNT,
/// BMI1), which the traversal's bookkeeping uses in place of multiply-and-shift emulations.
/// Every processor with AVX2 has them; checked all the same, once.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn has_avx2_set() -> bool {
    #[cfg(test)]
    if BASELINE_ONLY.get() {
        return false;
    }
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

/// Work compiled twice, for AVX2 with the bit instructions and for the baseline: [`run`] picks.
pub trait TwoWays {
    type Output;

    /// Does the work, in the compilation `AVX2` names (inline it into [`run`]).
    ///
    /// # Safety
    /// `AVX2` only in code compiled for AVX2, POPCNT, LZCNT and BMI1, which [`run`] ensures.
    unsafe fn run<const AVX2: bool>(self) -> Self::Output;
}

/// Runs `work` in its AVX2 compilation where the processor has AVX2 and the bit instructions
/// ([`has_avx2_set`]), else in its baseline one.
#[inline(always)]
pub fn run<W: TwoWays>(work: W) -> W::Output {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_set() {
        // SAFETY: the processor has AVX2 and the bit instructions, checked just above.
        return unsafe { run_avx2(work) };
    }
    // SAFETY: the baseline compilation.
    unsafe { work.run::<false>() }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt,lzcnt,bmi1")]
fn run_avx2<W: TwoWays>(work: W) -> W::Output {
    // SAFETY: compiled for AVX2 and the bit instructions.
    unsafe { work.run::<true>() }
}

#[cfg(test)]
thread_local! {
    /// Set by [`with_baseline`]: this thread's queries take the baseline compilation.
    static BASELINE_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` on this thread with every choice of compilation taking the baseline one, so tests
/// check what a processor without AVX2 runs.
#[cfg(test)]
pub fn with_baseline<R>(f: impl FnOnce() -> R) -> R {
    struct Restore;
    impl Drop for Restore {
        fn drop(&mut self) {
            BASELINE_ONLY.set(false);
        }
    }
    BASELINE_ONLY.set(true);
    let _restore = Restore;
    f()
}
