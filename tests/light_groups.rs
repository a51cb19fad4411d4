//! Light groups: emitters that name a `light_group` get their own EXR layer, the rest go to
//! `lightgroup.default`, and the layers sum to the beauty within float rounding, light through
//! openings included (a room lit only through a window and a ringed door; the showcase's two
//! rings). Split renders merge them like the beauty, and checkpoints carry them.

use crate::common;

use common::{largest_difference, rift, rift_env, root, signal, start, stderr, wait_for_progress};
use rift_render::frame::film::{ExrLayer, read_exr_layer};
use std::path::{Path, PathBuf};

/// A copy of `examples/shots/<name>.toml` in `dir`, its mesh paths made absolute and `edit`
/// applied to its TOML.
fn shot_with(dir: &Path, name: &str, edit: impl FnOnce(&mut toml::Table)) -> PathBuf {
    let assets = root().join("examples/assets");
    let text = std::fs::read_to_string(root().join(format!("examples/shots/{name}.toml")))
        .unwrap()
        .replace("../assets/", &format!("{}/", assets.display()));
    let mut table: toml::Table = text.parse().unwrap();
    edit(&mut table);
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, toml::to_string(&table).unwrap()).unwrap();
    path
}

/// Sets `light_group` on the array entry of `section` called `name` (at `inner`, a sub-table
/// path, when given).
fn group(t: &mut toml::Table, section: &str, name: &str, inner: &[&str], group: &str) {
    let entries = t[section].as_array_mut().unwrap();
    let entry = entries
        .iter_mut()
        .find(|e| e["name"].as_str() == Some(name))
        .unwrap_or_else(|| panic!("no {section} called {name}"));
    let mut table = entry.as_table_mut().unwrap();
    for key in inner {
        table = table
            .entry(key.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            .as_table_mut()
            .unwrap();
    }
    table.insert("light_group".into(), toml::Value::String(group.into()));
}

/// The lit-through room with its two lamps and the door's ring in groups of their own.
pub(crate) fn lit_through(dir: &Path) -> PathBuf {
    shot_with(dir, "lit_through", |t| {
        group(t, "object", "lamp", &[], "lamp");
        group(t, "object", "blue_lamp", &[], "blue");
        group(t, "portal", "door", &["surface", "strands"], "ring");
    })
}

pub(crate) fn render(dir: &Path, shot: &Path, out: &str, extra: &[&str]) {
    render_env(dir, shot, out, extra, &[]);
}

/// [`render`] with the environment variables `env` set.
pub(crate) fn render_env(
    dir: &Path,
    shot: &Path,
    out: &str,
    extra: &[&str],
    env: &[(&str, &Path)],
) {
    let mut args = vec![
        "render",
        shot.to_str().unwrap(),
        "-o",
        out,
        "--res",
        "64",
        "36",
    ];
    args.extend_from_slice(extra);
    let r = rift_env(dir, &args, env);
    assert!(r.status.success(), "{args:?}: {}", stderr(&r));
}

/// By how much the `layers` (each `{name}.R/G/B`) miss summing to the beauty: the largest
/// difference over pixels and channels, relative to the beauty (at least 1e-3).
pub(crate) fn layers_miss_beauty(image: &ExrLayer, layers: &[&str]) -> f64 {
    let c = &image.channels;
    let mut worst = 0.0f64;
    for channel in ["R", "G", "B"] {
        for (i, &beauty) in c[channel].iter().enumerate() {
            let sum: f64 = (layers.iter())
                .map(|name| c[&format!("{name}.{channel}")][i] as f64)
                .sum();
            let d = (sum - beauty as f64).abs() / (beauty.abs() as f64).max(1e-3);
            worst = worst.max(d);
        }
    }
    worst
}

/// Checks that the image's light-group layers are `expect` and sum to its beauty pixel by
/// pixel; returns each group's mean.
pub(crate) fn assert_groups_sum_to_beauty(path: &Path, expect: &[&str]) -> Vec<(String, f64)> {
    let layer = read_exr_layer(path).unwrap();
    let c = &layer.channels;
    let mut names: Vec<&str> = c
        .keys()
        .filter_map(|k| k.strip_prefix("lightgroup.")?.strip_suffix(".R"))
        .collect();
    names.sort();
    let mut want = expect.to_vec();
    want.sort();
    assert_eq!(names, want, "light-group layers");
    let layers: Vec<String> = names.iter().map(|g| format!("lightgroup.{g}")).collect();
    let layers: Vec<&str> = layers.iter().map(String::as_str).collect();
    let worst = layers_miss_beauty(&layer, &layers);
    assert!(
        worst <= 1e-5,
        "{}: the groups miss the beauty by {worst:e}",
        path.display()
    );
    names
        .iter()
        .map(|g| {
            let v = &c[&format!("lightgroup.{g}.G")];
            (
                g.to_string(),
                v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64,
            )
        })
        .collect()
}

#[test]
fn groups_sum_to_the_beauty_through_openings_and_on_the_showcase() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = lit_through(d);
    render(d, &shot, "lit.exr", &["--spp", "16"]);
    let means =
        assert_groups_sum_to_beauty(&d.join("lit.exr"), &["blue", "default", "lamp", "ring"]);
    // The room the camera sees has no light of its own: everything arrives through openings,
    // and every named emitter lights some of it.
    for (name, mean) in &means {
        match name.as_str() {
            "default" => assert!(*mean < 1e-6, "default group: {mean}"),
            _ => assert!(*mean > 1e-4, "group {name} brings no light: {mean}"),
        }
    }
    let showcase = shot_with(d, "showcase", |t| {
        group(t, "portal", "back", &["surface", "strands"], "back_ring");
        group(t, "portal", "front", &["surface", "strands"], "front_ring");
    });
    render(d, &showcase, "showcase.exr", &["--spp", "4"]);
    assert_groups_sum_to_beauty(
        &d.join("showcase.exr"),
        &["back_ring", "default", "front_ring"],
    );
}

#[test]
fn groups_merge_from_sample_ranges_and_survive_a_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = lit_through(d);
    render(d, &shot, "whole.exr", &["--spp", "16"]);
    render(d, &shot, "a.exr", &["--samples", "0-5"]);
    render(d, &shot, "b.exr", &["--samples", "5-16"]);
    let m = rift(d, &["merge", "merged.exr", "a.exr", "b.exr"]);
    assert!(m.status.success(), "{}", stderr(&m));
    let worst = largest_difference(&d.join("whole.exr"), &d.join("merged.exr"));
    assert!(worst <= 1e-5, "merged groups differ by {worst:e}");
    // Stopped by SIGTERM, then resumed: the same bits as the whole render.
    let shot_arg = shot.to_str().unwrap();
    let args = [
        "render",
        shot_arg,
        "-o",
        "resumed.exr",
        "--res",
        "64",
        "36",
        "--spp",
        "16",
        "--checkpoint",
        "60",
        "--resume",
    ];
    let mut child = start(d, &args);
    let _rest = wait_for_progress(&mut child);
    signal(&child, "TERM");
    assert_eq!(child.wait().unwrap().code(), Some(143));
    let r = rift(d, &args);
    assert!(r.status.success(), "{}", stderr(&r));
    assert_eq!(
        largest_difference(&d.join("whole.exr"), &d.join("resumed.exr")),
        0.0
    );
}

#[test]
fn bad_group_names_and_too_many_groups_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bad = shot_with(d, "lit_through", |t| group(t, "object", "lamp", &[], "a b"));
    let r = rift(d, &["render", bad.to_str().unwrap(), "-o", "x.exr"]);
    let msg = stderr(&r);
    assert_eq!(r.status.code(), Some(1), "{msg}");
    assert!(
        msg.contains("light_group") && msg.contains("\"a b\""),
        "{msg}"
    );
    let many = shot_with(d, "lit_through", |t| {
        let names = [
            "dark_room",
            "block",
            "lamp_room",
            "lamp",
            "blue_room",
            "blue_lamp",
        ];
        for (k, name) in names.iter().enumerate() {
            group(t, "object", name, &[], &format!("g{k}"));
        }
        group(t, "portal", "door", &["surface", "strands"], "ring");
        group(t, "portal", "window", &["surface", "strands"], "extra");
    });
    let r = rift(d, &["render", many.to_str().unwrap(), "-o", "x.exr"]);
    let msg = stderr(&r);
    assert_eq!(r.status.code(), Some(1), "{msg}");
    assert!(msg.contains("at most 7"), "{msg}");
    assert!(!d.join("x.exr").exists());
}
