//! Log-log plots for the benchmarks, drawn with plotters into memory and written as PNGs: the
//! convergence plot of `rift bench convergence` (relMSE against samples per pixel, with the
//! 1/spp line an unbiased Monte Carlo estimator follows) and the scaling plot of `rift bench
//! scaling` (cost against scene size per axis). Labels use the DejaVu Sans Mono font shipped
//! in assets/fonts.

use plotters::prelude::*;
use std::path::Path;

const FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSansMono.ttf");
const SIZE: (u32, u32) = (800, 560);

/// One line of a plot.
struct Line<'a> {
    label: &'a str,
    points: Vec<(f64, f64)>,
    color: RGBColor,
    /// Drawn thick with a dot at each point (a measurement), or thin (a guide).
    measured: bool,
}

/// Writes the plot of `rows` (spp, relMSE) to `path`.
pub fn convergence_png(path: &Path, title: &str, rows: &[(u32, f64)]) -> anyhow::Result<()> {
    anyhow::ensure!(!rows.is_empty(), "nothing to plot");
    let first = rows[0];
    let last = rows[rows.len() - 1];
    let ideal = |spp: u32| (spp as f64, first.1 * first.0 as f64 / spp as f64);
    let lines = [
        Line {
            label: "1/spp",
            points: vec![ideal(first.0), ideal(last.0)],
            color: BLACK,
            measured: false,
        },
        Line {
            label: "measured",
            points: rows.iter().map(|r| (r.0 as f64, r.1)).collect(),
            color: RED,
            measured: true,
        },
    ];
    // The error falls from the upper left: the legend goes in the corner it leaves free.
    let legend = SeriesLabelPosition::UpperRight;
    log_log(path, title, ("samples per pixel", "relMSE"), &lines, legend)
}

/// Writes the scaling plot of `series` (axis name, (size, cost relative to the smallest)) to
/// `path`.
pub fn scaling_png(path: &Path, series: &[(&str, Vec<(f64, f64)>)]) -> anyhow::Result<()> {
    anyhow::ensure!(series.iter().all(|s| !s.1.is_empty()), "nothing to plot");
    let colors = [RED, BLUE, GREEN, MAGENTA, CYAN];
    let lines: Vec<Line> = series
        .iter()
        .enumerate()
        .map(|(k, (label, points))| Line {
            label,
            points: points.clone(),
            color: colors[k % colors.len()],
            measured: true,
        })
        .collect();
    // Costs rise to the right, the largest sizes' points there: the legend goes in the upper
    // left, where in the upper right it hid the 10⁷-triangle point.
    log_log(
        path,
        "cost against scene size (relative to the smallest)",
        ("size", "relative cost"),
        &lines,
        SeriesLabelPosition::UpperLeft,
    )
}

/// The values 1, 2 and 5 times a power of ten from `lo` to `hi`: the y axis's lines and labels
/// (the library's own choice for a log axis drew two lines at 10 and a band of faint ones
/// between them).
fn one_two_five(lo: f64, hi: f64) -> Vec<f64> {
    // A range touching zero (a relMSE of exactly 0) gets none, rather than 2³¹ decades.
    if !(lo > 0.0 && lo < hi && hi.is_finite()) {
        return Vec::new();
    }
    let first = lo.log10().floor() as i32;
    let last = hi.log10().ceil() as i32;
    (first..=last)
        .flat_map(|e| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(e)))
        .filter(|v| (lo..=hi).contains(v))
        .collect()
}

/// Draws `lines` on log-log axes titled `title` with axis labels `axes` into `path`, the
/// legend at `legend`.
fn log_log(
    path: &Path,
    title: &str,
    axes: (&str, &str),
    lines: &[Line],
    legend: SeriesLabelPosition,
) -> anyhow::Result<()> {
    // Registering twice is harmless; plotters keeps the first.
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    let points = lines.iter().flat_map(|l| l.points.iter());
    let (x_lo, x_hi, y_lo, y_hi) = points
        .fold((f64::MAX, 0.0f64, f64::MAX, 0.0f64), |(a, b, c, d), p| {
            (a.min(p.0), b.max(p.0), c.min(p.1), d.max(p.1))
        });
    let (w, h) = SIZE;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (x_lo / 1.5..x_hi * 1.5).log_scale(),
                (y_lo / 2.0..y_hi * 2.0)
                    .log_scale()
                    .with_key_points(one_two_five(y_lo / 2.0, y_hi * 2.0)),
            )
            .map_err(draw_error)?;
        chart
            .configure_mesh()
            .x_desc(axes.0)
            .y_desc(axes.1)
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(draw_error)?;
        for line in lines {
            let color = line.color;
            let width = if line.measured { 2 } else { 1 };
            chart
                .draw_series(LineSeries::new(
                    line.points.clone(),
                    color.stroke_width(width),
                ))
                .map_err(draw_error)?
                .label(line.label)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(width))
                });
            if line.measured {
                chart
                    .draw_series(
                        line.points
                            .iter()
                            .map(|&p| Circle::new(p, 4, color.filled())),
                    )
                    .map_err(draw_error)?;
            }
        }
        chart
            .configure_series_labels()
            .position(legend)
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()
            .map_err(draw_error)?;
        root.present().map_err(draw_error)?;
    }
    let mut encoded = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut encoded, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.write_header()?.write_image_data(&rgb)?;
    }
    rift_fx::export::atomic::write(path, |out| out.write_all(&encoded))?;
    Ok(())
}

fn draw_error<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing the plot: {e}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_y_axis_gets_one_two_five_steps_within_its_range() {
        let close = |got: Vec<f64>, want: &[f64]| {
            assert_eq!(got.len(), want.len(), "{got:?}");
            for (g, w) in got.iter().zip(want) {
                assert!((g / w - 1.0).abs() < 1e-12, "{got:?}");
            }
        };
        close(one_two_five(0.45, 29.4), &[0.5, 1.0, 2.0, 5.0, 10.0, 20.0]);
        close(
            one_two_five(5e-5, 2e-2),
            &[5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2],
        );
        assert!(one_two_five(0.0, 1.0).is_empty());
    }

    #[test]
    fn the_scaling_plot_is_written_as_a_png() {
        // (The convergence plot is checked through `rift bench convergence`: tests/cornell.rs.)
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scaling.png");
        let rising = vec![(1e3, 1.0), (1e5, 1.8), (1e7, 3.6)];
        scaling_png(&path, &[("triangles", rising)]).unwrap();
        assert!(std::fs::read(&path).unwrap().starts_with(b"\x89PNG"));
    }
}
