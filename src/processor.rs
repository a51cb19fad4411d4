//! The instruction set this build assumes. Optimised builds target x86-64-v3 (AVX2, FMA, BMI1/2,
//! LZCNT, MOVBE, F16C: Intel Haswell and AMD Zen on), set in `.cargo/config.toml`, which renders
//! about 10% faster than the x86-64 baseline (the Cornell box: 4.0 s against 4.4 s at 128 spp).
//! Such a binary must not run on an older processor, where its first vector instruction
//! would end it with SIGILL and no word of why; [`missing`] reads CPUID itself (the standard
//! library's feature test is answered at compile time in such a build) before anything else
//! runs.

/// The x86-64-v3 features this processor (or its operating system, for the AVX registers)
/// lacks; empty when the build can run. Always empty for a build without AVX2.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub fn missing() -> Vec<&'static str> {
    use std::arch::x86_64::{__cpuid, __cpuid_count, _xgetbv};
    let bit = |word: u32, n: u32| word >> n & 1 == 1;
    // Leaves past the maxima are not read.
    let (basic, extended) = (__cpuid(0).eax, __cpuid(0x8000_0000).eax);
    if basic < 7 || extended < 0x8000_0001 {
        return vec!["CPUID leaves 7 and 0x80000001"];
    }
    let (leaf1, leaf7, ext1) = (__cpuid(1), __cpuid_count(7, 0), __cpuid(0x8000_0001));
    let os_saves_avx = bit(leaf1.ecx, 27) && {
        // SAFETY: XGETBV exists where CPUID reports OSXSAVE (bit 27), checked first.
        let enabled = unsafe { _xgetbv(0) };
        enabled & 0b110 == 0b110
    };
    let needed = [
        ("SSE4.2", bit(leaf1.ecx, 20)),
        ("POPCNT", bit(leaf1.ecx, 23)),
        ("FMA", bit(leaf1.ecx, 12)),
        ("MOVBE", bit(leaf1.ecx, 22)),
        ("AVX", bit(leaf1.ecx, 28)),
        ("F16C", bit(leaf1.ecx, 29)),
        ("AVX2", bit(leaf7.ebx, 5)),
        ("BMI1", bit(leaf7.ebx, 3)),
        ("BMI2", bit(leaf7.ebx, 8)),
        ("LZCNT", bit(ext1.ecx, 5)),
        ("AVX register saving by the operating system", os_saves_avx),
    ];
    needed
        .iter()
        .filter(|(_, present)| !present)
        .map(|(name, _)| *name)
        .collect()
}

/// A build for the baseline runs anywhere.
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
pub fn missing() -> Vec<&'static str> {
    Vec::new()
}

/// What to tell the user when [`missing`] is not empty.
pub fn refusal(missing: &[&str]) -> String {
    format!(
        "rift: error: this build of rift is for x86-64-v3 processors (Intel Haswell, AMD Zen \
         and later), and this one lacks {}. Build one for any x86-64 processor with \
         `RUSTFLAGS=\"-C target-cpu=x86-64\" cargo build --release` (about 10% slower).",
        missing.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_processor_running_the_tests_has_what_the_build_assumes() {
        // The tests are built as the program is; a wrong CPUID bit would refuse this processor.
        assert_eq!(missing(), Vec::<&str>::new());
    }

    #[test]
    fn the_refusal_names_what_is_missing_and_how_to_build_for_it() {
        let text = refusal(&["AVX2", "BMI2"]);
        assert!(text.contains("lacks AVX2, BMI2"), "{text}");
        assert!(text.contains("target-cpu=x86-64\""), "{text}");
    }
}
