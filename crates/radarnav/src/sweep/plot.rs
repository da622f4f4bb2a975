//! `sweep.png`: the share of runs that succeeded, one bar per scenario and grid point.

use plotters::prelude::*;

use super::SweepError;
use super::table::Group;
use crate::render::{encode_png, pixmap_from_rgb};

/// Most bars drawn; the CSV has them all.
const MAX_BARS: usize = 120;

fn draw_err<E: std::fmt::Debug>(e: E) -> SweepError {
    SweepError::Merge(format!("drawing sweep.png: {e:?}"))
}

/// The figure of `groups` as PNG bytes.
pub fn groups_png(spec: &str, groups: &[Group]) -> Result<Vec<u8>, SweepError> {
    crate::render::register_plot_font().map_err(draw_err)?;
    let shown = &groups[..groups.len().min(MAX_BARS)];
    let n = shown.len().max(1);
    let (w, h) = (1100u32, 110 + 26 * n as u32);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let name = std::path::Path::new(spec)
            .file_name()
            .map_or(spec.to_owned(), |s| s.to_string_lossy().into_owned());
        let more = if groups.len() > shown.len() {
            format!(" (first {} of {})", shown.len(), groups.len())
        } else {
            String::new()
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("sweep {name}: runs that succeeded{more}"),
                ("sans-serif", 22),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(10)
            .build_cartesian_2d(0.0..100.0, 0.0..n as f64)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("succeeded, % of seeds")
            .disable_y_mesh()
            .y_labels(0)
            .label_style(("sans-serif", 14))
            .light_line_style(WHITE)
            .bold_line_style(RGBColor(225, 225, 225))
            .draw()
            .map_err(draw_err)?;
        chart
            .draw_series(shown.iter().enumerate().map(|(i, g)| {
                let y = (n - 1 - i) as f64;
                let share = 100.0 * g.succeeded as f64 / g.runs as f64;
                Rectangle::new(
                    [(0.0, y + 0.15), (share, y + 0.85)],
                    RGBColor(158, 202, 225).filled(),
                )
            }))
            .map_err(draw_err)?;
        chart
            .draw_series(shown.iter().enumerate().map(|(i, g)| {
                let y = (n - 1 - i) as f64;
                Text::new(
                    format!(
                        "{}: {}/{}, {:.1} bumps a run",
                        g.label, g.succeeded, g.runs, g.mean_bumps
                    ),
                    (1.0, y + 0.72),
                    ("sans-serif", 13),
                )
            }))
            .map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    let pixmap = pixmap_from_rgb(&rgb, w, h).map_err(draw_err)?;
    encode_png(&pixmap).map_err(draw_err)
}
