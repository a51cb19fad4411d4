//! Curve regression: small shots' baked curves against committed golden data, with tolerances:
//! `small_shot` (explicit looks) and `presets_shot` (one ring per named preset).
//!
//! Every 6th vertex of every strand of two frames is compared (position, velocity,
//! acceleration, width, colour, intensity), plus every strand's vertex count. After an intended
//! change to the effect, re-bless with `RIFT_BLESS=1 cargo test --release --test all golden::` and
//! commit tests/golden/*.csv.

use crate::common;

use rift_fx::Shot;
use rift_fx::ring::RingGenerator;

const FRAMES: [i64; 2] = [1001, 1009];
const STRIDE: usize = 6;
const COLUMNS: usize = 14;

/// Rows: opening, frame, strand, vertex (or -1 for the count row), then 14 values.
fn current(name: &str) -> Vec<(String, Vec<f64>)> {
    let shot = Shot::load(&common::root().join(format!("tests/data/{name}.toml"))).unwrap();
    let generator = RingGenerator::new(&shot, shot.frames);
    let mut rows = Vec::new();
    for frame in FRAMES {
        for ring in generator.frame(frame).rings {
            for (s, range) in ring.strand_ranges().enumerate() {
                let mut count = vec![0.0; COLUMNS];
                count[0] = range.len() as f64;
                rows.push((format!("{},{frame},{s},-1", ring.opening), count));
                for (k, i) in range.enumerate().step_by(STRIDE) {
                    let mut v = Vec::with_capacity(COLUMNS);
                    v.extend(ring.points[i].to_array().map(f64::from));
                    v.extend(ring.velocities[i].to_array().map(f64::from));
                    v.extend(ring.accelerations[i].to_array().map(f64::from));
                    v.push(ring.widths[i] as f64);
                    v.extend(ring.colors[i].to_array().map(f64::from));
                    v.push(ring.intensities[i] as f64);
                    rows.push((format!("{},{frame},{s},{k}", ring.opening), v));
                }
            }
        }
    }
    rows
}

/// Tolerance of column `c` for golden value `g`: absolute plus relative, by quantity.
fn tolerance(c: usize, g: f64) -> f64 {
    let (abs, rel) = match c {
        0..=2 => (2e-6, 1e-5),   // position, m
        3..=5 => (1e-4, 1e-4),   // velocity, m/s
        6..=8 => (2e-2, 1e-3),   // acceleration, m/s² (second differences amplify rounding)
        9 => (1e-7, 1e-5),       // width
        10..=12 => (1e-5, 1e-5), // colour
        _ => (1e-4, 1e-5),       // intensity
    };
    abs + rel * g.abs()
}

#[test]
fn curves_match_golden_data() {
    check_against_golden("small_shot");
}

#[test]
fn every_preset_matches_golden_data() {
    check_against_golden("presets_shot");
}

fn check_against_golden(name: &str) {
    let rows = current(name);
    let path = common::root().join(format!("tests/golden/{name}.csv"));
    if std::env::var_os("RIFT_BLESS").is_some() {
        let mut text = String::from(
            "# opening,frame,strand,vertex (-1: vertex count row),x,y,z,vx,vy,vz,ax,ay,az,width,r,g,b,intensity\n",
        );
        for (key, v) in &rows {
            let values: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
            text.push_str(&format!("{key},{}\n", values.join(",")));
        }
        std::fs::write(&path, text).unwrap();
        eprintln!("blessed {}", path.display());
        return;
    }
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (bless with RIFT_BLESS=1)", path.display()));
    let golden: Vec<(String, Vec<f64>)> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let parts: Vec<&str> = l.split(',').collect();
            (
                parts[..4].join(","),
                parts[4..].iter().map(|x| x.parse().unwrap()).collect(),
            )
        })
        .collect();
    assert_eq!(
        golden.len(),
        rows.len(),
        "row count differs from golden data"
    );
    let mut worst = (0.0f64, String::new());
    for ((gk, g), (ck, c)) in golden.iter().zip(&rows) {
        assert_eq!(gk, ck, "row order differs");
        if gk.ends_with(",-1") {
            assert_eq!(g[0], c[0], "{gk}: vertex count");
            continue;
        }
        for col in 0..COLUMNS {
            let ratio = (g[col] - c[col]).abs() / tolerance(col, g[col]);
            if ratio > worst.0 {
                worst = (
                    ratio,
                    format!("{gk} column {col}: golden {} now {}", g[col], c[col]),
                );
            }
        }
    }
    assert!(worst.0 <= 1.0, "outside tolerance: {}", worst.1);
}
