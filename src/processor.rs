//! The instruction set this build assumes. Optimised x86-64 builds target x86-64-v3 (AVX2,
//! FMA, BMI1/2, LZCNT, MOVBE, F16C: Intel Haswell and AMD Zen on; `.cargo/config.toml`), which
//! renders the Cornell box in 0.89x the time of the baseline build, with the same pixels.
//!
//! Such a binary must not start on an older processor, where its first vector instruction would
//! end it with SIGILL and no word of why. The check cannot be Rust: every Rust function of the
//! build may use those instructions (the compiler's own feature test is answered at compile
//! time, and even copying a small array uses 256-bit moves). So it is a few lines of assembly,
//! run from the ELF constructor list before the standard library starts: CPUID for the features,
//! XGETBV for the operating system saving the AVX registers; on a refusal it writes the
//! message with the `write` system call and exits with status 1. (Linux only: elsewhere an
//! x86-64-v3 build has no such check.)

#[cfg(all(target_os = "linux", target_arch = "x86_64", target_feature = "avx2"))]
mod check {
    /// Bits of CPUID leaf 1's ECX the build needs: FMA (12), SSE4.2 (20), MOVBE (22), POPCNT (23),
    /// OSXSAVE (27), AVX (28), F16C (29).
    const LEAF1_ECX: u32 = 1 << 12 | 1 << 20 | 1 << 22 | 1 << 23 | 1 << 27 | 1 << 28 | 1 << 29;
    /// Bits of CPUID leaf 7's EBX: BMI1 (3), AVX2 (5), BMI2 (8).
    const LEAF7_EBX: u32 = 1 << 3 | 1 << 5 | 1 << 8;
    /// Bit of CPUID leaf 0x80000001's ECX: LZCNT (5).
    const EXTENDED_ECX: u32 = 1 << 5;

    /// What a refused processor is told.
    const REFUSAL_TEXT: &[u8] = b"rift: error: this build of rift is for x86-64-v3 processors \
        (Intel Haswell, AMD Zen and later); this processor lacks some of AVX2, FMA, BMI1, BMI2, \
        LZCNT, MOVBE, F16C, or its system does not save the AVX registers. Build rift for any \
        x86-64 processor with RUSTFLAGS=\"-C target-cpu=x86-64\" cargo build --release (about 10% \
        slower).\n";

    /// [`REFUSAL_TEXT`] as bytes in place, for the assembly to write.
    static REFUSAL: [u8; REFUSAL_TEXT.len()] = *REFUSAL_TEXT.first_chunk().unwrap();

    // `rift_processor_supported` returns 1 in EAX when the processor has every feature, else 0;
    // `rift_processor_check`, in the constructor list, refuses the processor when it returns 0.
    std::arch::global_asm!(
        ".pushsection .text.rift_processor_supported,\"ax\",@progbits",
        ".globl rift_processor_supported",
        ".hidden rift_processor_supported",
        ".p2align 4",
        "rift_processor_supported:",
        "push rbx", // CPUID writes EBX, which the caller keeps
        "xor eax, eax",
        "cpuid",
        "cmp eax, 7",
        "jb 2f",
        "mov eax, 0x80000000",
        "cpuid",
        "cmp eax, 0x80000001",
        "jb 2f",
        "mov eax, 1",
        "xor ecx, ecx",
        "cpuid",
        "and ecx, {leaf1}",
        "cmp ecx, {leaf1}",
        "jne 2f",
        "xor ecx, ecx", // OSXSAVE is set, so XGETBV exists: XCR0 must enable SSE and AVX state
        "xgetbv",
        "and eax, 6",
        "cmp eax, 6",
        "jne 2f",
        "mov eax, 7",
        "xor ecx, ecx",
        "cpuid",
        "and ebx, {leaf7}",
        "cmp ebx, {leaf7}",
        "jne 2f",
        "mov eax, 0x80000001",
        "cpuid",
        "and ecx, {extended}",
        "cmp ecx, {extended}",
        "jne 2f",
        "mov eax, 1",
        "pop rbx",
        "ret",
        "2:",
        "xor eax, eax",
        "pop rbx",
        "ret",
        ".popsection",
        ".pushsection .text.rift_processor_check,\"ax\",@progbits",
        ".p2align 4",
        "rift_processor_check:",
        "call rift_processor_supported",
        "test eax, eax",
        "jz 2f",
        "ret",
        "2:",
        "mov eax, 1", // write(2, message, length)
        "mov edi, 2",
        "lea rsi, [rip + {message}]",
        "mov edx, {length}",
        "syscall",
        "mov eax, 231", // exit_group(1)
        "mov edi, 1",
        "syscall",
        "ud2",
        ".popsection",
        ".pushsection .init_array,\"aw\",@init_array",
        ".p2align 3",
        ".quad rift_processor_check",
        ".popsection",
        leaf1 = const LEAF1_ECX,
        leaf7 = const LEAF7_EBX,
        extended = const EXTENDED_ECX,
        length = const REFUSAL_TEXT.len(),
        message = sym REFUSAL,
    );
}

#[cfg(test)]
mod tests {
    /// True when this processor runs what the build targets (always, for a build without AVX2).
    fn supported() -> bool {
        #[cfg(all(target_os = "linux", target_arch = "x86_64", target_feature = "avx2"))]
        {
            unsafe extern "C" {
                fn rift_processor_supported() -> u32;
            }
            // SAFETY: the routine only reads CPUID and XCR0 and keeps the registers the C
            // calling convention asks it to.
            unsafe { rift_processor_supported() == 1 }
        }
        #[cfg(not(all(target_os = "linux", target_arch = "x86_64", target_feature = "avx2")))]
        true
    }

    #[test]
    fn the_processor_running_the_tests_has_what_the_build_assumes() {
        // The tests are built as the program is; a wrong CPUID bit would refuse this processor
        // (the constructor would have ended the test binary before it got here).
        assert!(supported());
    }
}
