//! Top-down figures: the world coloured by material, scans over it coloured by how each ray
//! ended, a title, a legend and a scale bar (the thesis' figures 7–10 and ground-truth images).

use glam::{DVec2, DVec3};
use thiserror::Error;
pub use tiny_skia::Pixmap;
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Rect, Stroke, Transform};

use crate::pose::Pose;
use crate::sensor::{HitKind, Scan};
use crate::vehicle::VehicleSpec;
use crate::world::{MaterialId, World};

/// A figure could not be made or written.
#[derive(Debug, Error)]
pub enum RenderError {
    /// The requested image has no pixels or is too large.
    #[error("cannot make a {0} × {1} pixel image")]
    Size(u32, u32),
    /// PNG encoding or writing failed.
    #[error("writing {path}: {cause}")]
    Write {
        /// Target file.
        path: String,
        /// Cause.
        cause: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// Colour of a ray that stopped at a solid surface.
pub const SOLID_RGB: [u8; 3] = [215, 35, 35];
/// Colour of a ray whose penetration budget ran out.
pub const EXHAUSTED_RGB: [u8; 3] = [245, 150, 0];
/// Colour of a ray with no return.
pub const NONE_RGB: [u8; 3] = [120, 120, 210];

const LEGEND_W: f64 = 230.0;
const TITLE_H: f64 = 34.0;
const MARGIN: f64 = 16.0;
const BOTTOM_H: f64 = 40.0;

/// The area a figure of `world` shows by default: its bounds plus 0.5 m (xy min, max).
pub fn world_region(world: &World) -> (DVec2, DVec2) {
    match world.bounds() {
        Some((lo, hi)) => (lo.truncate() - 0.5, hi.truncate() + 0.5),
        None => (DVec2::splat(-5.0), DVec2::splat(5.0)),
    }
}

/// A figure being drawn.
pub struct Figure {
    pixmap: Pixmap,
    min: DVec2,
    max: DVec2,
    scale: f64,
    legend: Vec<([u8; 3], String)>,
}

fn paint(rgb: [u8; 3], alpha: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(rgb[0], rgb[1], rgb[2], alpha);
    p.anti_alias = true;
    p
}

fn darker(rgb: [u8; 3]) -> [u8; 3] {
    rgb.map(|c| (f64::from(c) * 0.6) as u8)
}

/// Draw order and opacity: clouds first and see-through, foliage next, solids on top.
/// Height at which figures cut meshes, m: the scan plane of the sensors on the P3AT (and of
/// the thesis' figures).
pub const SECTION_Z: f64 = 0.4;

fn layer(world: &World, id: MaterialId) -> (u8, u8) {
    let m = world.materials().get(id);
    if m.traversable {
        (0, 110)
    } else if m.radar_penetrable() {
        (1, 170)
    } else {
        (2, 255)
    }
}

impl Figure {
    /// A figure showing `region` (xy min, max; the world's bounds plus a margin when `None`)
    /// at about `pixels` pixels along its longer side, with the world's objects drawn.
    pub fn of_world(
        world: &World,
        region: Option<(DVec2, DVec2)>,
        pixels: u32,
    ) -> Result<Self, RenderError> {
        let region = region.unwrap_or_else(|| world_region(world));
        let mut fig = Self::blank(region, pixels)?;
        fig.draw_objects(world);
        Ok(fig)
    }

    /// An empty figure (white, with a 1 m grid) showing `region` (xy min, max) at about
    /// `pixels` pixels along its longer side.
    pub fn blank((min, max): (DVec2, DVec2), pixels: u32) -> Result<Self, RenderError> {
        let span = (max - min).max(DVec2::splat(1e-3));
        let scale = f64::from(pixels.clamp(64, 8192)) / span.x.max(span.y);
        let w = (span.x * scale + 2.0 * MARGIN + LEGEND_W).ceil() as u32;
        let h = (span.y * scale + TITLE_H + BOTTOM_H + MARGIN).ceil() as u32;
        let mut pixmap = Pixmap::new(w, h).ok_or(RenderError::Size(w, h))?;
        pixmap.fill(Color::WHITE);
        let mut fig = Self {
            pixmap,
            min,
            max,
            scale,
            legend: Vec::new(),
        };
        fig.draw_grid();
        Ok(fig)
    }

    /// Draws a raster of `width` × `height` square cells of `cell` metres whose cell (0, 0)
    /// has its lower-left corner at `origin`; `rgb(column, row)` colours each cell (row 0 is
    /// the lowest). Nearest-neighbour: cells stay crisp squares.
    pub fn draw_cells(
        &mut self,
        origin: DVec2,
        cell: f64,
        (width, height): (usize, usize),
        rgb: impl Fn(usize, usize) -> [u8; 3],
    ) -> Result<(), RenderError> {
        let size = (u32::try_from(width), u32::try_from(height));
        let (Ok(w), Ok(h)) = size else {
            return Err(RenderError::Size(u32::MAX, u32::MAX));
        };
        let mut raster = Pixmap::new(w, h).ok_or(RenderError::Size(w, h))?;
        let data = raster.data_mut();
        // Pixmap rows run top-down: the highest map row first.
        for row in 0..height {
            for col in 0..width {
                let k = ((height - 1 - row) * width + col) * 4;
                let [r, g, b] = rgb(col, row);
                data[k..k + 4].copy_from_slice(&[r, g, b, 255]);
            }
        }
        let (x0, y0) = self.px(origin + DVec2::new(0.0, height as f64 * cell));
        let k = (cell * self.scale) as f32;
        let paint = tiny_skia::PixmapPaint {
            quality: tiny_skia::FilterQuality::Nearest,
            ..tiny_skia::PixmapPaint::default()
        };
        self.pixmap.draw_pixmap(
            0,
            0,
            raster.as_ref(),
            &paint,
            Transform::from_row(k, 0.0, 0.0, k, x0, y0),
            None,
        );
        Ok(())
    }

    /// World point to pixel.
    fn px(&self, p: DVec2) -> (f32, f32) {
        (
            (MARGIN + (p.x - self.min.x) * self.scale) as f32,
            (TITLE_H + (self.max.y - p.y) * self.scale) as f32,
        )
    }

    fn draw_grid(&mut self) {
        let span = (self.max - self.min).max_element();
        if !span.is_finite() {
            return;
        }
        // At most about 40 lines whatever the world's extent: the figure costs its pixels.
        let step = if span > 400.0 {
            10f64.powf((span / 40.0).log10().ceil())
        } else if span > 40.0 {
            10.0
        } else if span > 15.0 {
            5.0
        } else {
            1.0
        };
        let stroke = Stroke {
            width: 1.0,
            ..Stroke::default()
        };
        let grid = paint([232, 232, 236], 255);
        let mut pb = PathBuilder::new();
        let mut x = (self.min.x / step).ceil() * step;
        while x <= self.max.x {
            let (a, b) = (
                self.px(DVec2::new(x, self.min.y)),
                self.px(DVec2::new(x, self.max.y)),
            );
            pb.move_to(a.0, a.1);
            pb.line_to(b.0, b.1);
            x += step;
        }
        let mut y = (self.min.y / step).ceil() * step;
        while y <= self.max.y {
            let (a, b) = (
                self.px(DVec2::new(self.min.x, y)),
                self.px(DVec2::new(self.max.x, y)),
            );
            pb.move_to(a.0, a.1);
            pb.line_to(b.0, b.1);
            y += step;
        }
        if let Some(path) = pb.finish() {
            self.pixmap
                .stroke_path(&path, &grid, &stroke, Transform::identity(), None);
        }
    }

    fn polygon(&mut self, pts: &[DVec2], fill: &Paint, outline: Option<&Paint>) {
        let mut pb = PathBuilder::new();
        for (i, p) in pts.iter().enumerate() {
            let (x, y) = self.px(*p);
            if i == 0 {
                pb.move_to(x, y);
            } else {
                pb.line_to(x, y);
            }
        }
        pb.close();
        if let Some(path) = pb.finish() {
            self.pixmap
                .fill_path(&path, fill, FillRule::EvenOdd, Transform::identity(), None);
            if let Some(o) = outline {
                let stroke = Stroke {
                    width: 1.0,
                    ..Stroke::default()
                };
                self.pixmap
                    .stroke_path(&path, o, &stroke, Transform::identity(), None);
            }
        }
    }

    fn draw_objects(&mut self, world: &World) {
        let mut order: Vec<usize> = (0..world.objects().len()).collect();
        order.sort_by_key(|&i| layer(world, world.objects()[i].material).0);
        for i in order {
            let obj = &world.objects()[i];
            let (_, alpha) = layer(world, obj.material);
            let rgb = world.materials().get(obj.material).color;
            let (fill, line) = (paint(rgb, alpha), paint(darker(rgb), alpha));
            match obj.shape.section(SECTION_Z) {
                // A mesh: its outline faint, and solid where a level scan meets it.
                Some(cut) => {
                    for part in obj.shape.footprint() {
                        self.polygon(&part, &paint(rgb, alpha / 4), Some(&line));
                    }
                    for part in cut {
                        self.polygon(&part, &fill, Some(&line));
                    }
                }
                None => {
                    for part in obj.shape.footprint() {
                        self.polygon(&part, &fill, Some(&line));
                    }
                }
            }
        }
        let mut used: Vec<MaterialId> = world.objects().iter().map(|o| o.material).collect();
        used.sort();
        used.dedup();
        for id in used {
            let m = world.materials().get(id);
            self.legend.push((m.color, m.name.clone()));
        }
    }

    /// Draws every ray of `scan` from its origin to its reading (to `range_max`, faint, when
    /// there is none), coloured by hit kind, with a dot at each return.
    pub fn draw_scan(&mut self, scan: &Scan) {
        let stroke = Stroke {
            width: 1.0,
            ..Stroke::default()
        };
        let mut kinds = [false; 3];
        for i in 0..scan.len() {
            let ray = scan.ray(i);
            let r = f64::from(scan.ranges[i]);
            if r == f64::NEG_INFINITY {
                continue;
            }
            let (rgb, alpha) = match scan.hits[i] {
                HitKind::Solid => (SOLID_RGB, 150),
                HitKind::Exhausted => (EXHAUSTED_RGB, 190),
                HitKind::None => (NONE_RGB, 40),
            };
            // A reading of +inf (no return, or noise pushed it past range_max) is drawn to
            // range_max.
            let end = ray.at(if r.is_finite() { r } else { scan.range_max });
            kinds[scan.hits[i] as usize] = true;
            let (a, b) = (self.px(ray.origin.truncate()), self.px(end.truncate()));
            let mut pb = PathBuilder::new();
            pb.move_to(a.0, a.1);
            pb.line_to(b.0, b.1);
            if let Some(path) = pb.finish() {
                self.pixmap.stroke_path(
                    &path,
                    &paint(rgb, alpha),
                    &stroke,
                    Transform::identity(),
                    None,
                );
            }
            if r.is_finite() {
                self.dot(end, 2.0, rgb);
            }
        }
        for (k, label) in [
            (HitKind::Solid, "ray: stopped at surface"),
            (HitKind::Exhausted, "ray: budget ran out"),
            (HitKind::None, "ray: no return"),
        ] {
            let rgb = [SOLID_RGB, EXHAUSTED_RGB, NONE_RGB][k as usize];
            if kinds[k as usize] {
                self.add_legend(rgb, label);
            }
        }
    }

    fn dot(&mut self, p: DVec3, radius: f32, rgb: [u8; 3]) {
        let (x, y) = self.px(p.truncate());
        if let Some(path) = PathBuilder::from_circle(x, y, radius) {
            self.pixmap.fill_path(
                &path,
                &paint(rgb, 255),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }

    /// Draws a polyline through `points` (a driven path), `width` pixels wide, with a legend
    /// entry `label`.
    pub fn draw_path(&mut self, points: &[DVec2], rgb: [u8; 3], width: f32, label: &str) {
        let mut pb = PathBuilder::new();
        for (k, p) in points.iter().enumerate() {
            let (x, y) = self.px(*p);
            if k == 0 {
                pb.move_to(x, y);
            } else {
                pb.line_to(x, y);
            }
        }
        if let Some(path) = pb.finish() {
            let stroke = Stroke {
                width,
                line_join: tiny_skia::LineJoin::Round,
                ..Stroke::default()
            };
            self.pixmap.stroke_path(
                &path,
                &paint(rgb, 230),
                &stroke,
                Transform::identity(),
                None,
            );
        }
        self.add_legend(rgb, label);
    }

    /// Marks each of `points` with a cross (events such as bumps), with a legend entry.
    pub fn draw_crosses(&mut self, points: &[DVec2], rgb: [u8; 3], label: &str) {
        if points.is_empty() {
            return;
        }
        let mut pb = PathBuilder::new();
        for p in points {
            let (x, y) = self.px(*p);
            pb.move_to(x - 5.0, y - 5.0);
            pb.line_to(x + 5.0, y + 5.0);
            pb.move_to(x - 5.0, y + 5.0);
            pb.line_to(x + 5.0, y - 5.0);
        }
        if let Some(path) = pb.finish() {
            let stroke = Stroke {
                width: 2.0,
                ..Stroke::default()
            };
            self.pixmap.stroke_path(
                &path,
                &paint(rgb, 255),
                &stroke,
                Transform::identity(),
                None,
            );
        }
        self.add_legend(rgb, label);
    }

    /// Adds a legend entry (once per label).
    pub fn add_legend(&mut self, rgb: [u8; 3], label: &str) {
        if !self.legend.iter().any(|(_, l)| l == label) {
            self.legend.push((rgb, label.to_owned()));
        }
    }

    /// Draws a vehicle's footprint at `pose` with a heading tick.
    pub fn draw_robot(&mut self, pose: &Pose, vehicle: &VehicleSpec) {
        let (length, width) = (vehicle.length, vehicle.width);
        let (s, c) = pose.yaw.sin_cos();
        let (fwd, left) = (DVec2::new(c, s), DVec2::new(-s, c));
        let m = DVec2::new(pose.x, pose.y);
        let (hl, hw) = (fwd * length / 2.0, left * width / 2.0);
        let body = [m - hl - hw, m + hl - hw, m + hl + hw, m - hl + hw];
        self.polygon(
            &body,
            &paint([30, 60, 200], 220),
            Some(&paint([10, 20, 90], 255)),
        );
        let nose = [
            m + hl * 1.6,
            m + hl * 0.6 + hw * 0.6,
            m + hl * 0.6 - hw * 0.6,
        ];
        self.polygon(&nose, &paint([255, 255, 255], 255), None);
        self.add_legend([30, 60, 200], "robot");
    }

    /// Writes the title, legend and scale bar; call once, last.
    pub fn finish(mut self, title: &str) -> Pixmap {
        self.text(MARGIN as i32, 10, title, [20, 20, 20], 2);
        let x0 = (self.pixmap.width() as f64 - LEGEND_W + 8.0) as i32;
        let legend = std::mem::take(&mut self.legend);
        for (k, (rgb, label)) in legend.iter().enumerate() {
            let y = TITLE_H as i32 + 6 + 20 * k as i32;
            if let Some(r) = Rect::from_xywh(x0 as f32, y as f32, 14.0, 14.0) {
                self.pixmap
                    .fill_rect(r, &paint(*rgb, 255), Transform::identity(), None);
                // A frame, so that a white swatch shows on the white page.
                let frame = PathBuilder::from_rect(r);
                let stroke = Stroke {
                    width: 1.0,
                    ..Stroke::default()
                };
                self.pixmap.stroke_path(
                    &frame,
                    &paint([120, 120, 120], 255),
                    &stroke,
                    Transform::identity(),
                    None,
                );
            }
            self.text(x0 + 20, y + 3, label, [30, 30, 30], 1);
        }
        self.scale_bar();
        self.pixmap
    }

    fn scale_bar(&mut self) {
        let target = 120.0 / self.scale;
        let len = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
            .into_iter()
            .rev()
            .find(|&l| l <= target)
            .unwrap_or(0.5);
        let x0 = MARGIN as f32;
        let y = (self.pixmap.height() as f64 - BOTTOM_H / 2.0) as f32;
        let x1 = x0 + (len * self.scale) as f32;
        let black = paint([0, 0, 0], 255);
        for r in [
            Rect::from_ltrb(x0, y - 1.5, x1, y + 1.5),
            Rect::from_ltrb(x0, y - 6.0, x0 + 2.0, y + 6.0),
            Rect::from_ltrb(x1 - 2.0, y - 6.0, x1, y + 6.0),
        ]
        .into_iter()
        .flatten()
        {
            self.pixmap
                .fill_rect(r, &black, Transform::identity(), None);
        }
        let label = if len < 1.0 {
            format!("{len} m")
        } else {
            format!("{len:.0} m")
        };
        self.text(x1 as i32 + 8, y as i32 - 4, &label, [0, 0, 0], 1);
    }

    /// Draws `text` with the 8×8 bitmap font, each font pixel `scale` image pixels wide.
    fn text(&mut self, x: i32, y: i32, text: &str, rgb: [u8; 3], scale: i32) {
        use font8x8::UnicodeFonts;
        let p = paint(rgb, 255);
        for (k, ch) in text.chars().enumerate() {
            let glyph = font8x8::BASIC_FONTS
                .get(ch)
                .or_else(|| font8x8::LATIN_FONTS.get(ch))
                .unwrap_or([0; 8]);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        let px = x + (k as i32 * 8 + col) * scale;
                        let py = y + row as i32 * scale;
                        if let Some(r) =
                            Rect::from_xywh(px as f32, py as f32, scale as f32, scale as f32)
                        {
                            self.pixmap.fill_rect(r, &p, Transform::identity(), None);
                        }
                    }
                }
            }
        }
    }
}

/// Encodes a finished figure as PNG bytes.
pub fn encode_png(pixmap: &Pixmap) -> Result<Vec<u8>, RenderError> {
    pixmap.encode_png().map_err(|e| RenderError::Write {
        path: "<memory>".to_owned(),
        cause: Box::new(e),
    })
}

/// Writes a finished figure to `path` as PNG, under a temporary name renamed when complete
/// (an interrupted write leaves no half figure).
pub fn save_png(pixmap: &Pixmap, path: &std::path::Path) -> Result<(), RenderError> {
    let bytes = encode_png(pixmap)?;
    crate::output::write_whole(path, &bytes).map_err(|e| RenderError::Write {
        path: path.display().to_string(),
        cause: Box::new(e),
    })
}

/// An opaque image from packed 8-bit RGB rows (as plotting back ends draw), for
/// [`save_png`].
pub fn pixmap_from_rgb(rgb: &[u8], width: u32, height: u32) -> Result<Pixmap, RenderError> {
    let mut pixmap = Pixmap::new(width, height).ok_or(RenderError::Size(width, height))?;
    if rgb.len() != pixmap.data().len() / 4 * 3 {
        return Err(RenderError::Size(width, height));
    }
    for (px, c) in pixmap
        .data_mut()
        .chunks_exact_mut(4)
        .zip(rgb.chunks_exact(3))
    {
        px.copy_from_slice(&[c[0], c[1], c[2], 255]);
    }
    Ok(pixmap)
}

/// Registers the font plotters draws its text with (ab_glyph draws only registered fonts; the
/// font ships in the binary). Call before drawing a plot; calling again is harmless.
pub fn register_plot_font() -> Result<(), String> {
    plotters::style::register_font(
        "sans-serif",
        plotters::style::FontStyle::Normal,
        epaint_default_fonts::UBUNTU_LIGHT,
    )
    .map_err(|_| "the plot font did not load".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::{Tracer, preset};
    use crate::setup::Scenario;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn rgb_at(p: &Pixmap, x: u32, y: u32) -> [u8; 3] {
        let c = p.pixel(x, y).unwrap();
        [c.red(), c.green(), c.blue()]
    }

    #[test]
    fn figure_shows_objects_scan_and_is_deterministic() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let make = || {
            let mut fig = Figure::of_world(&s.world, None, 600).unwrap();
            let pose = Pose::new(3.0, 4.0, 0.4, 0.0);
            let scan = preset("radar_thesis").unwrap().scan(
                &s.world,
                &pose,
                0.0,
                &mut ChaCha8Rng::seed_from_u64(1),
                &mut Tracer::default(),
            );
            fig.draw_scan(&scan);
            fig.draw_robot(&pose, &crate::vehicle::P3AT);
            fig.finish("test")
        };
        let a = make();
        assert_eq!(encode_png(&a).unwrap(), encode_png(&make()).unwrap());
        // The core of a foliage sphere off any ray's path keeps the foliage colour; the robot
        // body is drawn in blue.
        let fig = Figure::of_world(&s.world, None, 600).unwrap();
        let (x, y) = fig.px(DVec2::new(7.0, 0.3));
        let c = rgb_at(&a, x as u32, y as u32);
        assert!(
            c[1] > c[0] && c[1] > c[2],
            "foliage should look green, got {c:?}"
        );
        let (x, y) = fig.px(DVec2::new(2.9, 4.1));
        let c = rgb_at(&a, x as u32, y as u32);
        assert!(
            c[2] > 150 && c[0] < 100,
            "robot should look blue, got {c:?}"
        );
    }
}
