//! A check of a binary USD file (usdc, "crate") before the USD crate reads it. That reader
//! allocates what a file declares (a section's entry count, a compressed block's size, an
//! array's length) before it reads the bytes, and follows nested dictionaries by recursion: a
//! corrupt or hostile file could ask for terabytes, or for a stack deeper than the thread has,
//! and either ends the program. This walks the same layout (header, table of contents, the
//! structural sections, every field's value, nested values to a bounded depth) and refuses
//! any declared size that the bytes after it could not hold, or that passes `limit`.

/// LZ4 never expands a block by more than this factor.
const LZ4_RATIO: u64 = 255;

/// How deep nested values (dictionaries, time samples) may go.
const MAX_DEPTH: u32 = 64;

/// Checks `bytes`, a usdc file; the error says what is wrong.
pub fn check(bytes: &[u8], limit: u64) -> Result<(), String> {
    let file = Crate { bytes, limit };
    let version = (file.byte(8)?, file.byte(9)?);
    let toc = file.u64(16)?;
    let count = file.u64(toc)?;
    if count == 0 || count >= 64 {
        return Err(format!("its table of contents lists {count} sections"));
    }
    let mut fields = None;
    for i in 0..count {
        let at = toc + 8 + i * 32;
        let name = file.slice(at, 16)?;
        let (start, size) = (file.u64(at + 16)?, file.u64(at + 24)?);
        file.slice(start, size)?;
        let name = name.split(|&b| b == 0).next().unwrap_or_default();
        let section = Section { start, size };
        match name {
            b"TOKENS" => file.tokens(section)?,
            b"STRINGS" => file.counted(section.start, 4, "strings")?,
            b"FIELDS" => fields = Some(file.fields(section)?),
            b"FIELDSETS" | b"SPECS" => {
                let n = file.u64(start)?;
                let blocks = if name == b"SPECS" { 3 } else { 1 };
                file.int_blocks(start + 8, n, blocks, section)?;
            }
            b"PATHS" => {
                let n = file.u64(start)?;
                file.allocation(n, 32, "paths")?;
                let encoded = file.u64(start + 8)?;
                file.int_blocks(start + 16, encoded, 3, section)?;
            }
            _ => {}
        }
    }
    for rep in fields.unwrap_or_default() {
        file.value(rep, version, 0)?;
    }
    Ok(())
}

#[derive(Clone, Copy)]
struct Section {
    start: u64,
    size: u64,
}

struct Crate<'a> {
    bytes: &'a [u8],
    limit: u64,
}

impl Crate<'_> {
    fn slice(&self, at: u64, len: u64) -> Result<&[u8], String> {
        let end = at
            .checked_add(len)
            .filter(|&e| e <= self.bytes.len() as u64);
        end.map(|e| &self.bytes[at as usize..e as usize])
            .ok_or_else(|| format!("it declares {len} bytes at offset {at}, past its end"))
    }

    fn byte(&self, at: u64) -> Result<u8, String> {
        Ok(self.slice(at, 1)?[0])
    }

    fn u32(&self, at: u64) -> Result<u64, String> {
        let b = self.slice(at, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64)
    }

    fn u64(&self, at: u64) -> Result<u64, String> {
        let b = self.slice(at, 8)?;
        Ok(u64::from_le_bytes(b.try_into().expect("eight bytes")))
    }

    /// Bytes from `at` to the end.
    fn after(&self, at: u64) -> u64 {
        (self.bytes.len() as u64).saturating_sub(at)
    }

    /// Refuses `count` elements of `size` bytes in memory when that passes the limit.
    fn allocation(&self, count: u64, size: u64, what: &str) -> Result<(), String> {
        match count.checked_mul(size) {
            Some(bytes) if bytes <= self.limit => Ok(()),
            _ => Err(format!(
                "it declares {count} {what}, more than the {} MiB allowed for reading USD",
                self.limit >> 20
            )),
        }
    }

    /// A count at `at` of elements stored after it, `size` bytes each on disk.
    fn counted(&self, at: u64, size: u64, what: &str) -> Result<(), String> {
        let n = self.u64(at)?;
        if n.saturating_mul(size) > self.after(at + 8) {
            return Err(format!(
                "it declares {n} {what} at offset {at}, more than it holds"
            ));
        }
        self.allocation(n, size.max(8) * 4, what)
    }

    /// A compressed block at `at` (its size, then the bytes) that must unpack to `unpacked`
    /// bytes; the offset after it.
    fn block(&self, at: u64, unpacked: u64, within: Section, what: &str) -> Result<u64, String> {
        let size = self.u64(at)?;
        self.slice(at + 8, size)?;
        if at + 8 + size > within.start + within.size {
            return Err(format!("its {what} block runs past its section"));
        }
        if unpacked > size.saturating_mul(LZ4_RATIO) + 64 {
            return Err(format!(
                "it declares {unpacked} bytes of {what} in a block of {size}, more than LZ4 unpacks"
            ));
        }
        self.allocation(unpacked, 1, what)?;
        Ok(at + 8 + size)
    }

    /// `blocks` compressed integer arrays of `n` entries each, from `at`.
    fn int_blocks(&self, mut at: u64, n: u64, blocks: u32, within: Section) -> Result<u64, String> {
        // The integer coding takes two bits an entry at least; in memory each is 4 to 8 bytes.
        self.allocation(n, 16, "entries")?;
        for _ in 0..blocks {
            at = self.block(at, n / 4, within, "integers")?;
        }
        Ok(at)
    }

    fn tokens(&self, s: Section) -> Result<(), String> {
        let count = self.u64(s.start)?;
        let unpacked = self.u64(s.start + 8)?;
        self.block(s.start + 16, unpacked, s, "tokens")?;
        if count > unpacked {
            return Err(format!("it declares {count} tokens in {unpacked} bytes"));
        }
        self.allocation(count, 32, "tokens")
    }

    /// The fields' value representations, unpacked.
    fn fields(&self, s: Section) -> Result<Vec<u64>, String> {
        let n = self.u64(s.start)?;
        let at = self.int_blocks(s.start + 8, n, 1, s)?;
        let size = self.u64(at)?;
        let end = self.block(at, n.saturating_mul(8), s, "field values")?;
        let packed = self.slice(at + 8, end - at - 8)?;
        let mut reps = vec![0u8; (n * 8) as usize];
        // One LZ4 block after a chunk count of 0 (the only form the reader takes).
        match packed.split_first() {
            Some((0, block)) => {
                let got = lz4_flex::block::decompress_into(block, &mut reps)
                    .map_err(|e| format!("its field values do not unpack: {e}"))?;
                reps.truncate(got);
            }
            _ if n == 0 || size == 0 => reps.clear(),
            _ => return Err("its field values are not one LZ4 block".into()),
        }
        Ok(reps
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().expect("eight bytes")))
            .collect())
    }

    /// One value representation and whatever it points to.
    fn value(&self, rep: u64, version: (u8, u8), depth: u32) -> Result<(), String> {
        const ARRAY: u64 = 1 << 63;
        const INLINED: u64 = 1 << 62;
        const COMPRESSED: u64 = 1 << 61;
        if depth > MAX_DEPTH {
            return Err(format!("its values nest deeper than {MAX_DEPTH}"));
        }
        if rep & INLINED != 0 {
            return Ok(());
        }
        let at = rep & ((1 << 48) - 1);
        let kind = (rep >> 48) & 0xff;
        if rep & ARRAY != 0 {
            return self.array(at, kind, rep & COMPRESSED != 0, version);
        }
        match kind {
            // Dictionary: a count, then per entry a key, an offset and a value.
            31 => {
                let n = self.u64(at)?;
                if n.saturating_mul(20) > self.after(at + 8) {
                    return Err(format!("a dictionary at {at} declares {n} entries"));
                }
                let mut pos = at + 8;
                for _ in 0..n {
                    let offset_at = pos + 4;
                    let offset = self.u64(offset_at)? as i64;
                    let rep_at = (offset_at as i64).checked_add(offset).filter(|&p| p >= 0);
                    let rep_at = rep_at.ok_or("a dictionary entry points before the file")? as u64;
                    self.value(self.u64(rep_at)?, version, depth + 1)?;
                    pos = rep_at + 8;
                }
                Ok(())
            }
            // Time samples: an offset to the times, then an offset to their values' count.
            46 => {
                let times_at = (at as i64)
                    .checked_add(self.u64(at)? as i64)
                    .filter(|&p| p >= 0);
                let times_at = times_at.ok_or("time samples point before the file")? as u64;
                self.value(self.u64(times_at)?, version, depth + 1)?;
                let next = times_at + 8;
                let values_at = (next as i64)
                    .checked_add(self.u64(next)? as i64)
                    .filter(|&p| p >= 0);
                let values_at = values_at.ok_or("time samples point before the file")? as u64;
                let n = self.u64(values_at)?;
                self.counted(values_at, 8, "time samples")?;
                for i in 0..n {
                    self.value(self.u64(values_at + 8 + i * 8)?, version, depth + 1)?;
                }
                Ok(())
            }
            // Token, path, string and layer-offset vectors, selection maps and relocates: a
            // count of entries of 4 bytes or more.
            40 | 41 | 45 | 49 | 50 | 58 => self.counted(at, 4, "entries"),
            48 => self.array(at, 9, false, version),
            // List ops: a header byte, then up to six counted vectors.
            32..=39 | 54 | 55 => {
                let header = self.byte(at)?;
                let mut pos = at + 1;
                for bit in 1..7 {
                    if header & (1 << bit) != 0 {
                        let n = self.u64(pos)?;
                        self.counted(pos, 4, "list entries")?;
                        pos += 8 + n * 4;
                    }
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// An array of type `kind` at `at`: its length, and its elements or compressed block.
    fn array(
        &self,
        at: u64,
        kind: u64,
        compressed: bool,
        (major, minor): (u8, u8),
    ) -> Result<(), String> {
        if at == 0 {
            return Ok(());
        }
        let mut pos = at;
        if (major, minor) < (0, 5) {
            pos += 4;
        }
        let (n, data) = if (major, minor) < (0, 7) {
            (self.u32(pos)?, pos + 4)
        } else {
            (self.u64(pos)?, pos + 8)
        };
        let size = element_size(kind);
        self.allocation(n, size.max(8), "array entries")?;
        match (compressed && n >= 4, kind) {
            // Integers: coded, in one compressed block.
            (true, 3..=6) => self.packed(data, n),
            // Floating point: coded integers ('i'), or a table of values and coded indices ('t').
            (true, 7..=9 | 56) => match self.byte(data)? {
                b'i' => self.packed(data + 1, n),
                b't' => {
                    let entries = self.u32(data + 1)?;
                    let table = entries.saturating_mul(size);
                    if table > self.after(data + 5) {
                        return Err(format!("an array's table at {at} runs past the end"));
                    }
                    self.packed(data + 5 + table, n)
                }
                code => Err(format!(
                    "an array at {at} is packed by an unknown code {code}"
                )),
            },
            _ if n.saturating_mul(size) > self.after(data) => Err(format!(
                "an array at {at} declares {n} entries, more than it holds"
            )),
            _ => Ok(()),
        }
    }

    /// A compressed block of `n` coded integers at `at`: its size, then the bytes.
    fn packed(&self, at: u64, n: u64) -> Result<(), String> {
        let size = self.u64(at)?;
        if size > self.after(at + 8) {
            return Err(format!(
                "a compressed block at {at} of {size} bytes runs past the end"
            ));
        }
        // The integer coding takes two bits an entry at least.
        if n / 4 > size.saturating_mul(LZ4_RATIO) + 64 {
            return Err(format!(
                "{n} coded integers declared at {at} cannot come from {size} packed bytes"
            ));
        }
        Ok(())
    }
}

/// Bytes an element of crate type `kind` takes on disk (strings, tokens and paths are
/// stored as 4-byte indices; 8 for what is not an element type).
fn element_size(kind: u64) -> u64 {
    match kind {
        1 | 2 => 1,                              // bool, uchar
        7 => 2,                                  // half
        3 | 4 | 8 | 10 | 11 | 12 | 21 | 57 => 4, // int, uint, float, string, token, asset, vec2h, path expression
        25 => 6,                                 // vec3h
        5 | 6 | 9 | 18 | 20 | 22 | 29 | 56 => 8, // int64, uint64, double, quath, vec2f, vec2i, vec4h, time code
        24 | 26 => 12,                           // vec3f, vec3i
        17 | 19 | 28 | 30 => 16,                 // quatf, vec2d, vec4f, vec4i
        23 => 24,                                // vec3d
        13 | 16 | 27 => 32,                      // matrix2d, quatd, vec4d
        14 => 72,                                // matrix3d
        15 => 128,                               // matrix4d
        _ => 8,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_too_short_for_its_header_is_refused() {
        assert!(check(b"PXR-USDC", 1 << 30).is_err());
    }

    #[test]
    fn an_array_longer_than_the_file_is_refused() {
        let mut bytes = vec![0u8; 64];
        bytes[8..16].copy_from_slice(&1_000_000_000u64.to_le_bytes());
        let file = Crate {
            bytes: &bytes,
            limit: 1 << 30,
        };
        // A point3f array of 10^9 entries declared in 64 bytes.
        assert!(file.array(8, 24, false, (0, 8)).is_err());
        assert!(file.array(8, 24, true, (0, 8)).is_err());
        bytes[8..16].copy_from_slice(&4u64.to_le_bytes());
        let file = Crate {
            bytes: &bytes,
            limit: 1 << 30,
        };
        assert!(file.array(8, 24, false, (0, 8)).is_ok());
    }
}
