//! The log-log convergence plot of `rift bench convergence`: relMSE against samples per pixel,
//! with the 1/spp line an unbiased Monte Carlo estimator follows, drawn with plotters into
//! memory and written as a PNG. Labels use the DejaVu Sans Mono font shipped in assets/fonts.

use plotters::prelude::*;
use std::path::Path;

const FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSansMono.ttf");
const SIZE: (u32, u32) = (800, 560);

/// Writes the plot of `rows` (spp, relMSE) to `path`.
pub fn convergence_png(path: &Path, title: &str, rows: &[(u32, f64)]) -> anyhow::Result<()> {
    anyhow::ensure!(!rows.is_empty(), "nothing to plot");
    // Registering twice is harmless; plotters keeps the first.
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    let (w, h) = SIZE;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let (spp_lo, spp_hi) = rows.iter().fold((f64::MAX, 0.0f64), |(l, h), r| {
            (l.min(r.0 as f64), h.max(r.0 as f64))
        });
        let (mse_lo, mse_hi) = rows
            .iter()
            .fold((f64::MAX, 0.0f64), |(l, h), r| (l.min(r.1), h.max(r.1)));
        let first = rows[0];
        let ideal = |spp: f64| first.1 * first.0 as f64 / spp;
        let y_lo = mse_lo.min(ideal(spp_hi)) / 2.0;
        let y_hi = mse_hi.max(ideal(spp_lo)) * 2.0;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (spp_lo / 1.5..spp_hi * 1.5).log_scale(),
                (y_lo..y_hi).log_scale(),
            )
            .map_err(draw_error)?;
        chart
            .configure_mesh()
            .x_desc("samples per pixel")
            .y_desc("relMSE")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(draw_error)?;
        chart
            .draw_series(LineSeries::new(
                [spp_lo, spp_hi].map(|s| (s, ideal(s))),
                BLACK.stroke_width(1),
            ))
            .map_err(draw_error)?
            .label("1/spp")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
        let measured: Vec<(f64, f64)> = rows.iter().map(|r| (r.0 as f64, r.1)).collect();
        chart
            .draw_series(LineSeries::new(measured.clone(), RED.stroke_width(2)))
            .map_err(draw_error)?
            .label("measured")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED.stroke_width(2)));
        chart
            .draw_series(measured.iter().map(|&p| Circle::new(p, 4, RED.filled())))
            .map_err(draw_error)?;
        chart
            .configure_series_labels()
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
