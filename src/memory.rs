//! Memory guards: refuse work that cannot fit before allocating any of it, with a message that
//! says what to change, rather than run for a while and abort on a failed allocation.

use anyhow::bail;

/// The memory a command may use: `--max-memory` when given, else what the system reports as
/// available (Linux `MemAvailable`); `None` when neither is known.
pub fn budget(max_memory: Option<u64>) -> Option<u64> {
    max_memory.or_else(available)
}

/// `MemAvailable` from `/proc/meminfo`, in bytes.
fn available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// Fails when `needed` bytes for `what` exceed `budget`; `advice` says how to need less.
pub fn ensure_fits(
    what: &str,
    needed: u64,
    budget: Option<u64>,
    advice: &str,
) -> anyhow::Result<()> {
    match budget {
        Some(budget) if needed > budget => bail!(
            "{what} needs {} of memory, more than the {} available; {advice}",
            human(needed),
            human(budget)
        ),
        _ => Ok(()),
    }
}

/// A size such as `512M`, `8G` or `1.5T` (binary units; a plain number is bytes).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let text = text.trim();
    let (number, unit) = match text.find(|c: char| c.is_ascii_alphabetic()) {
        Some(at) => text.split_at(at),
        None => (text, ""),
    };
    let scale: u64 = match unit.to_ascii_uppercase().trim_end_matches(['B', 'I']) {
        "" => 1,
        "K" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        "T" => 1 << 40,
        _ => {
            return Err(format!(
                "unknown unit {unit:?} in {text:?} (use K, M, G or T)"
            ));
        }
    };
    let value: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("expected a size such as 8G, got {text:?}"))?;
    if !(value.is_finite() && value > 0.0) || value * scale as f64 >= u64::MAX as f64 {
        return Err(format!("expected a positive size such as 8G, got {text:?}"));
    }
    Ok((value * scale as f64) as u64)
}

/// `bytes` in the largest binary unit that keeps a number ≥ 1.
pub fn human(bytes: u64) -> String {
    let units = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < units.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{value:.1} {}", units[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_units_and_bad_ones_are_refused() {
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("8G"), Ok(8 << 30));
        assert_eq!(parse_size("8GiB"), Ok(8 << 30));
        assert_eq!(parse_size("1.5k"), Ok(1536));
        assert_eq!(parse_size("4096"), Ok(4096));
        for bad in ["", "G", "-1G", "0", "8X", "nanG", "1e30T"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
        assert_eq!(human(1536), "1.5 KiB");
        assert_eq!(human(3 << 40), "3.0 TiB");
    }

    #[test]
    fn work_beyond_the_budget_is_refused_with_advice() {
        assert!(ensure_fits("x", 10, Some(10), "").is_ok());
        assert!(ensure_fits("x", 10, None, "").is_ok());
        let err = ensure_fits("the frame", 11 << 30, Some(1 << 30), "lower --res")
            .unwrap_err()
            .to_string();
        assert!(err.contains("11.0 GiB") && err.contains("1.0 GiB") && err.contains("lower --res"));
    }
}
