//! Blosc (version 1) decompression, as OpenVDB writes it: a 16-byte header, a table of block
//! offsets, and per block one compressed stream or one per byte of the element type ("split"),
//! then byte-unshuffled. OpenVDB compresses with LZ4; zlib is read too. Every length and offset
//! comes from the file, so each is checked before it is used.

use std::io::Read;

const HEADER: usize = 16;
const FORMAT_VERSION: u8 = 2;
const DO_SHUFFLE: u8 = 0x1;
const MEMCPYED: u8 = 0x2;
const DO_BITSHUFFLE: u8 = 0x4;
const FUTURE_FLAGS: u8 = 0x8;
const DONT_SPLIT: u8 = 0x10;
/// Blocks are split per byte of the type only when each split holds at least this many bytes
/// (and the type has at most `MAX_SPLITS` bytes): Blosc's own rule, kept for old files.
const MIN_SPLIT_BYTES: usize = 128;
const MAX_SPLITS: usize = 16;

/// The compressors Blosc names by the top three bits of its flags.
const LZ4: u8 = 1;
const ZLIB: u8 = 3;

/// Decompresses one Blosc buffer that must hold exactly `expected` bytes.
pub fn decompress(src: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    if src.len() < HEADER {
        return Err(format!(
            "a Blosc block of {} bytes has no header",
            src.len()
        ));
    }
    let word = |at: usize| u32::from_le_bytes([src[at], src[at + 1], src[at + 2], src[at + 3]]);
    let (version, flags, typesize) = (src[0], src[2], src[3] as usize);
    let (size, blocksize, compressed) = (word(4) as usize, word(8) as usize, word(12) as usize);
    if version > FORMAT_VERSION || flags & FUTURE_FLAGS != 0 {
        return Err(format!(
            "Blosc format {version} (flags {flags:#x}) is newer than rift reads"
        ));
    }
    if size != expected {
        return Err(format!(
            "a Blosc block holds {size} bytes where {expected} were expected"
        ));
    }
    if compressed != src.len() {
        return Err(format!(
            "a Blosc block says it is {compressed} bytes long but {} follow",
            src.len()
        ));
    }
    if size == 0 {
        return Ok(Vec::new());
    }
    if flags & MEMCPYED != 0 {
        return src[HEADER..]
            .get(..size)
            .filter(|_| src.len() == HEADER + size)
            .map(<[u8]>::to_vec)
            .ok_or_else(|| "a stored Blosc block has the wrong length".to_owned());
    }
    if flags & DO_BITSHUFFLE != 0 {
        return Err(
            "Blosc bit-shuffled data is not read by rift (OpenVDB writes byte shuffles)".into(),
        );
    }
    if blocksize == 0 || typesize == 0 {
        return Err("a Blosc block has a zero block or type size".into());
    }
    let codec = flags >> 5;
    if codec != LZ4 && codec != ZLIB {
        let name = ["blosclz", "lz4", "snappy", "zlib", "zstd"].get(codec as usize);
        return Err(format!(
            "Blosc compressor {} is not read by rift (OpenVDB writes lz4; zlib is read too)",
            name.unwrap_or(&"unknown")
        ));
    }
    let blocks = size.div_ceil(blocksize);
    let starts = src
        .get(HEADER..HEADER + 4 * blocks)
        .ok_or("a Blosc block's offset table is cut short")?;
    let mut out = vec![0u8; size];
    let mut scratch = vec![0u8; blocksize];
    for (b, chunk) in out.chunks_mut(blocksize).enumerate() {
        let start = u32::from_le_bytes(starts[4 * b..4 * b + 4].try_into().unwrap()) as usize;
        let whole = chunk.len() == blocksize;
        let splits = if flags & DONT_SPLIT == 0
            && whole
            && typesize <= MAX_SPLITS
            && chunk.len() / typesize >= MIN_SPLIT_BYTES
        {
            typesize
        } else {
            1
        };
        let shuffled = flags & DO_SHUFFLE != 0 && typesize > 1;
        let target = if shuffled {
            &mut scratch[..chunk.len()]
        } else {
            &mut chunk[..]
        };
        decode_block(src, start, splits, codec, target)?;
        if shuffled {
            unshuffle(typesize, &scratch[..chunk.len()], chunk);
        }
    }
    Ok(out)
}

/// Decodes the `splits` streams of one block starting at byte `at` of `src` into `out`.
fn decode_block(
    src: &[u8],
    mut at: usize,
    splits: usize,
    codec: u8,
    out: &mut [u8],
) -> Result<(), String> {
    let part = out.len() / splits;
    for piece in out.chunks_mut(part).take(splits) {
        let length = src
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes(b.try_into().unwrap()) as usize)
            .ok_or("a Blosc stream's length lies past the end of its block")?;
        at += 4;
        let data = src
            .get(at..at.saturating_add(length))
            .ok_or("a Blosc stream runs past the end of its block")?;
        at += length;
        if length == piece.len() {
            piece.copy_from_slice(data);
            continue;
        }
        let written = match codec {
            LZ4 => {
                lz4_flex::block::decompress_into(data, piece).map_err(|e| format!("LZ4: {e}"))?
            }
            _ => {
                let mut decoder = flate2::read::ZlibDecoder::new(data);
                decoder
                    .read_exact(piece)
                    .map_err(|e| format!("zlib: {e}"))?;
                piece.len()
            }
        };
        if written != piece.len() {
            return Err(format!(
                "a Blosc stream gave {written} bytes where {} were expected",
                piece.len()
            ));
        }
    }
    Ok(())
}

/// Byte-unshuffles: the shuffled block holds every element's first byte, then every second
/// byte, and so on; bytes past the last whole element stay where they are.
fn unshuffle(typesize: usize, shuffled: &[u8], out: &mut [u8]) {
    let elements = shuffled.len() / typesize;
    for i in 0..elements {
        for j in 0..typesize {
            out[i * typesize + j] = shuffled[j * elements + i];
        }
    }
    let whole = elements * typesize;
    out[whole..].copy_from_slice(&shuffled[whole..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Blosc buffer built by hand: one block, stored (not compressed) in `splits` streams.
    fn stored(values: &[f32], split: bool) -> Vec<u8> {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let n = values.len();
        let shuffled: Vec<u8> = (0..4)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .map(|(i, j)| bytes[4 * i + j])
            .collect();
        let mut out = vec![
            FORMAT_VERSION,
            1,
            DO_SHUFFLE | (LZ4 << 5) | if split { 0 } else { DONT_SPLIT },
            4,
        ];
        out.extend((bytes.len() as u32).to_le_bytes());
        out.extend((bytes.len() as u32).to_le_bytes());
        out.extend(0u32.to_le_bytes());
        out.extend(20u32.to_le_bytes());
        let streams = if split { 4 } else { 1 };
        for piece in shuffled.chunks(shuffled.len() / streams) {
            out.extend((piece.len() as u32).to_le_bytes());
            out.extend(piece);
        }
        let total = out.len() as u32;
        out[12..16].copy_from_slice(&total.to_le_bytes());
        out
    }

    #[test]
    fn stored_streams_unshuffle_to_the_values() {
        let values: Vec<f32> = (0..512).map(|i| i as f32 * 0.25 - 7.0).collect();
        for split in [false, true] {
            let out = decompress(&stored(&values, split), 2048).unwrap();
            let back: Vec<f32> = out
                .chunks(4)
                .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
                .collect();
            assert_eq!(back, values, "split {split}");
        }
    }

    #[test]
    fn lengths_that_disagree_are_refused() {
        let values = vec![1.0f32; 512];
        let good = stored(&values, true);
        assert!(
            decompress(&good, 2044)
                .unwrap_err()
                .contains("2048 bytes where 2044")
        );
        assert!(decompress(&good[..good.len() - 1], 2048).is_err());
        let mut bad = good.clone();
        bad[16] = 0xff; // the block starts past the end
        assert!(decompress(&bad, 2048).is_err());
        let mut zstd = good;
        zstd[2] = DO_SHUFFLE | (4 << 5);
        assert!(decompress(&zstd, 2048).unwrap_err().contains("zstd"));
    }
}
