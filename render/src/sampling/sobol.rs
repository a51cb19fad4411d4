//! Owen-scrambled Sobol points, four dimensions at a time, bit-for-bit equal to
//! `sobol_burley::sample_4d` but cheaper per call for the way the integrator draws them.
//!
//! Two costs of the library call repeat for every set of a path and are paid once here:
//! - The shuffled sample index depends only on the pixel seed and the index, so it is computed
//!   when the stream starts, not for every set.
//! - A Sobol point is the XOR of the direction numbers of the set bits of its index (a linear
//!   map over GF(2)). The library walks the 16 index bits one at a time; here the direction
//!   numbers are pre-XORed four bits at a time into 16-entry tables, so a point costs four
//!   loads and three XORs. This took about a tenth of the render time on the Cornell box before.
//!
//! The scramble then runs the library's arithmetic on the four lanes, compiled for AVX2 where
//! the processor has it (see [`SobolSample::dimensions_4d`]): 2.5% of the Cornell box's
//! instructions.

use crate::sampling::SOBOL_SETS;
use sobol_burley::parts::{hash, owen_scramble_rev};
use std::sync::OnceLock;

/// Dimension sets covered by the tables: the path's sets and the one that holds the time.
pub const TABLE_SETS: usize = SOBOL_SETS as usize + 1;

/// Per set, per 4-bit group of the top 16 bits of the reversed index, the XOR of the direction
/// numbers for each of the 16 values of that group.
struct Tables {
    groups: [[[Lanes; 16]; 4]; TABLE_SETS],
}

/// Four dimensions' direction-number XORs, aligned for one vector load.
#[derive(Clone, Copy, Default)]
#[repr(C, align(16))]
struct Lanes([u32; 4]);

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let mut groups = [[[Lanes::default(); 16]; 4]; TABLE_SETS];
        for (set, set_groups) in groups.iter_mut().enumerate() {
            for (group, entries) in set_groups.iter_mut().enumerate() {
                for (value, entry) in entries.iter_mut().enumerate() {
                    // The group's bits sit at the top of the reversed index: group 0 holds bits
                    // 31..28, whose most significant bit is the index's lowest bit.
                    let rev_index = (value as u32) << (28 - 4 * group);
                    *entry =
                        Lanes(sobol_burley::parts::sobol_int4_rev(rev_index, set as u32).into());
                }
            }
        }
        Tables { groups }
    })
}

/// The Sobol points of one sample index in one pixel.
#[derive(Clone, Copy)]
pub struct SobolSample {
    /// The index after the seed's Owen shuffle, bit-reversed.
    shuffled_rev_index: u32,
    seed: u32,
    tables: &'static Tables,
}

impl SobolSample {
    /// Sample `index` (below 2¹⁶) of the sequence decorrelated by `seed`.
    pub fn new(index: u32, seed: u32) -> Self {
        Self {
            shuffled_rev_index: owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x79c6_8e4a)),
            seed,
            tables: tables(),
        }
    }

    /// Dimensions 4·`set` to 4·`set` + 3 of the sample, in [0, 1), for `set` below
    /// [`TABLE_SETS`]. The library's arithmetic on four lanes, compiled for AVX2 where the
    /// processor has it: the baseline instruction set has no 32-bit vector multiply or byte
    /// shuffle, so the five multiplies of the scramble and the two bit reversals took twice
    /// the instructions there.
    #[inline]
    pub fn dimensions_4d(&self, set: usize) -> [f32; 4] {
        crate::platform::cpu::run(Points { sample: self, set })
    }

    /// [`Self::dimensions_4d`], lane by lane (loops the compiler turns into vector code).
    #[inline(always)]
    fn points(&self, set: usize) -> [f32; 4] {
        let groups = &self.tables.groups[set];
        let i = self.shuffled_rev_index;
        let (a, b) = (&groups[0][nibble(i, 0)].0, &groups[1][nibble(i, 1)].0);
        let (c, d) = (&groups[2][nibble(i, 2)].0, &groups[3][nibble(i, 3)].0);
        // The per-dimension scramble keys, as the library derives them.
        let seed = self.seed.wrapping_mul(0x9c8f_2d3b) ^ set as u32;
        const KEYS: [u32; 4] = [0x912f_69ba, 0x174f_18ab, 0x691e_72ca, 0xb40c_c1b8];
        let mut out = [0.0; 4];
        for lane in 0..4 {
            let sobol = a[lane] ^ b[lane] ^ c[lane] ^ d[lane];
            let scrambled = owen_scramble_rev(sobol, hash(seed ^ KEYS[lane])).reverse_bits();
            out[lane] = f32::from_bits((scrambled >> 9) | 0x3f80_0000) - 1.0;
        }
        out
    }
}

/// [`SobolSample::dimensions_4d`] in either compilation ([`crate::platform::cpu::run`]).
struct Points<'a> {
    sample: &'a SobolSample,
    set: usize,
}

impl crate::platform::cpu::TwoWays for Points<'_> {
    type Output = [f32; 4];

    #[inline(always)]
    unsafe fn run<const AVX2: bool>(self) -> [f32; 4] {
        self.sample.points(self.set)
    }
}

/// Group `g` (0 to 3) of the top 16 bits of the reversed index `i`.
#[inline(always)]
fn nibble(i: u32, g: usize) -> usize {
    ((i >> (28 - 4 * g)) & 0xf) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both compilations (the one this processor picks, and the baseline one) against the
    /// library.
    #[test]
    fn equals_the_library_bit_for_bit() {
        for seed in [0u32, 1, 0xdead_beef, 77_777] {
            for index in (0..300).chain([4095, 65_535]) {
                let s = SobolSample::new(index, seed);
                for set in 0..TABLE_SETS {
                    let library = sobol_burley::sample_4d(index, set as u32, seed);
                    let at = format!("seed {seed} index {index} set {set}");
                    assert_eq!(s.dimensions_4d(set), library, "{at}");
                    let baseline = crate::platform::cpu::with_baseline(|| s.dimensions_4d(set));
                    assert_eq!(baseline, library, "{at}, baseline");
                }
            }
        }
    }
}
