//! Writing a map: a PNG in the thesis' palette, ROS `map_server` PGM + YAML, and the raw
//! log-odds as NumPy `.npy`.
//!
//! * `<stem>.png`: one square per cell: unknown blue, sensor-clear white, seen through but
//!   impassable grey, obstacle black (the thesis' figure 15), with a title, legend and scale.
//! * `<stem>.pgm` + `<stem>.yaml`: the passable map for ROS navigation, `mode: trinary`,
//!   `negate: 0`: obstacle and grey cells 0 (occupied), clear cells 254 (free), unknown 205;
//!   the first image row is the highest y (map_server's convention) and `origin` is the
//!   lower-left corner of the lowest row.
//! * `<stem>.npy`: `float32`, shape `(2, rows, columns)`: the log-odds of layer `sensed` and of
//!   layer `passable` (0 = unknown), row 0 the lowest y, cell (0, 0) at the YAML's `origin`.

use std::path::{Path, PathBuf};

use glam::DVec2;

use super::MapError;
use super::grid::{CellClass, Grid};
use crate::pose::Pose;
use crate::render::{Figure, save_png};
use crate::vehicle::VehicleSpec;

/// The files of one map.
pub fn files(dir: &Path, stem: &str) -> [PathBuf; 4] {
    ["png", "pgm", "yaml", "npy"].map(|ext| dir.join(format!("{stem}.{ext}")))
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> MapError + '_ {
    move |cause| MapError::Io {
        path: path.to_owned(),
        cause,
    }
}

/// The smallest rectangle of cells (column and row ranges) holding every known cell, grown
/// by `pad` cells and clipped to the grid; `None` when nothing is known.
pub fn known_extent(grid: &Grid, pad: usize) -> Option<((usize, usize), (usize, usize))> {
    let (w, h) = (grid.width(), grid.height());
    let (mut c0, mut c1, mut r0, mut r1) = (usize::MAX, 0, usize::MAX, 0);
    for k in 0..w * h {
        if grid.sensed()[k] != 0.0 || grid.passable()[k] != 0.0 {
            let (c, r) = (k % w, k / w);
            (c0, c1, r0, r1) = (c0.min(c), c1.max(c), r0.min(r), r1.max(r));
        }
    }
    (c0 <= c1).then(|| {
        (
            (c0.saturating_sub(pad), (c1 + pad).min(w - 1)),
            (r0.saturating_sub(pad), (r1 + pad).min(h - 1)),
        )
    })
}

/// Extra things to draw over a map figure.
#[derive(Clone, Copy, Debug, Default)]
pub struct Overlay<'a> {
    /// The driven path (drawn green).
    pub path: &'a [DVec2],
    /// The robot at its start and end.
    pub robot: Option<(&'static VehicleSpec, Pose, Pose)>,
    /// The area to show (xy min, max); default: the known cells plus 1 m. Maps of one world
    /// drawn over the same area compare side by side.
    pub region: Option<(DVec2, DVec2)>,
    /// Points to mark with a labelled cross (a navigation goal).
    pub marks: Option<(&'a [DVec2], &'a str)>,
    /// Estimated paths drawn over the true one, each with its colour and legend label (the
    /// odometry's, the localiser's).
    pub estimates: &'a [(&'a [DVec2], [u8; 3], &'a str)],
}

/// The map as a figure in the thesis' palette (cells outside the grid are unknown).
pub fn figure(
    grid: &Grid,
    title: &str,
    pixels: u32,
    overlay: &Overlay<'_>,
) -> Result<tiny_skia::Pixmap, MapError> {
    let res = grid.resolution();
    let pad = (1.0 / res).ceil() as usize;
    let region = overlay.region.or_else(|| {
        known_extent(grid, pad).map(|((c0, c1), (r0, r1))| {
            let lo = grid.origin() + DVec2::new(c0 as f64, r0 as f64) * res;
            let hi = grid.origin() + DVec2::new((c1 + 1) as f64, (r1 + 1) as f64) * res;
            (lo, hi)
        })
    });
    let Some((lo, hi)) = region else {
        let fig = Figure::blank((DVec2::splat(-1.0), DVec2::splat(1.0)), pixels)?;
        return Ok(fig.finish(title));
    };
    // The cells that cover the region.
    let (c0, c1) = (grid.cell_of(lo), grid.cell_of(hi - res * 1e-6));
    let (w, h) = ((c1.0 - c0.0 + 1) as usize, (c1.1 - c0.1 + 1) as usize);
    let origin = DVec2::new(c0.0 as f64, c0.1 as f64) * res;
    let mut fig = Figure::blank((lo, hi), pixels)?;
    fig.draw_cells(origin, res, (w, h), |c, r| {
        grid.class((c0.0 + c as i64, c0.1 + r as i64)).rgb()
    })?;
    for class in CellClass::ALL {
        fig.add_legend(class.rgb(), class.label());
    }
    if overlay.path.len() > 1 {
        fig.draw_path(overlay.path, [20, 160, 60], 2.0, "path");
    }
    for &(path, colour, label) in overlay.estimates {
        if path.len() > 1 {
            fig.draw_path(path, colour, 1.5, label);
        }
    }
    if let Some((vehicle, start, end)) = overlay.robot {
        fig.draw_robot(&start, vehicle);
        fig.draw_robot(&end, vehicle);
    }
    if let Some((points, label)) = overlay.marks {
        fig.draw_crosses(points, [220, 30, 30], label);
    }
    Ok(fig.finish(title))
}

/// ROS `map_server` pixel of a class (`negate: 0`, `mode: trinary`).
pub fn pgm_value(class: CellClass) -> u8 {
    match class {
        CellClass::Unknown => 205,
        CellClass::Clear => 254,
        CellClass::SeeThrough | CellClass::Obstacle => 0,
    }
}

/// The PGM (binary `P5`) bytes of the map, highest row first.
pub fn pgm(grid: &Grid) -> Vec<u8> {
    let (w, h) = (grid.width(), grid.height());
    let mut out = format!("P5\n# radarnav occupancy grid\n{w} {h}\n255\n").into_bytes();
    out.reserve(w * h);
    for row in (0..h).rev() {
        out.extend((0..w).map(|c| pgm_value(grid.class_at(row * w + c))));
    }
    out
}

/// The `map_server` YAML naming `image` (a path relative to the YAML file).
pub fn yaml(grid: &Grid, image: &str) -> String {
    let o = grid.origin();
    let occ = grid.occupancy();
    format!(
        "image: {image}\nmode: trinary\nresolution: {}\norigin: [{}, {}, 0.0]\nnegate: 0\noccupied_thresh: {}\nfree_thresh: {}\n",
        grid.resolution(),
        o.x,
        o.y,
        occ.occupied_thresh,
        occ.free_thresh
    )
}

/// NumPy `.npy` (format 1.0) bytes of a little-endian `float32` array of `shape`, C order.
pub fn npy_f32(shape: &[usize], data: impl IntoIterator<Item = f32>) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
    let dims = if dims.len() == 1 {
        format!("{},", dims[0])
    } else {
        dims.join(", ")
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({dims}), }}");
    // Magic (6) + version (2) + length (2) + header + '\n' is a multiple of 64.
    let total = 10 + header.len() + 1;
    header.extend(std::iter::repeat_n(' ', total.next_multiple_of(64) - total));
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend((header.len() as u16).to_le_bytes());
    out.extend(header.bytes());
    for v in data {
        out.extend(v.to_le_bytes());
    }
    out
}

/// The raw grid as `.npy` bytes: shape `(2, rows, columns)`, layers `sensed` then `passable`.
pub fn npy(grid: &Grid) -> Vec<u8> {
    let shape = [2, grid.height(), grid.width()];
    npy_f32(&shape, grid.sensed().iter().chain(grid.passable()).copied())
}

/// Writes `<stem>.png`, `.pgm`, `.yaml` and `.npy` into `dir`; returns their paths.
pub fn write_all(
    grid: &Grid,
    dir: &Path,
    stem: &str,
    title: &str,
    pixels: u32,
    overlay: &Overlay<'_>,
) -> Result<Vec<PathBuf>, MapError> {
    let [png, pgm_path, yaml_path, npy_path] = files(dir, stem);
    save_png(&figure(grid, title, pixels, overlay)?, &png)?;
    let whole = crate::output::write_whole;
    whole(&pgm_path, &pgm(grid)).map_err(io(&pgm_path))?;
    let image = format!("{stem}.pgm");
    whole(&yaml_path, yaml(grid, &image).as_bytes()).map_err(io(&yaml_path))?;
    whole(&npy_path, &npy(grid)).map_err(io(&npy_path))?;
    Ok(vec![png, pgm_path, yaml_path, npy_path])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::grid::{Layers, Occupancy};

    fn small() -> Grid {
        let mut g = Grid::new(0.5, Occupancy::default());
        g.mark_cells([(0, 0)], true, Layers::Both);
        for _ in 0..5 {
            g.mark_cells([(1, 0)], false, Layers::Both);
        }
        g
    }

    #[test]
    fn pgm_and_yaml_read_back() {
        let g = small();
        let bytes = pgm(&g);
        let text = String::from_utf8_lossy(&bytes);
        let mut lines = text.lines().filter(|l| !l.starts_with('#'));
        assert_eq!(lines.next(), Some("P5"));
        let dims = format!("{} {}", g.width(), g.height());
        assert_eq!(lines.next(), Some(dims.as_str()));
        assert_eq!(lines.next(), Some("255"));
        let pixels = &bytes[bytes.len() - g.width() * g.height()..];
        // Cell (0, 0) sits at column -origin.0, row -origin.1 counted from the bottom.
        let (oc, or) = g.origin_cell();
        let at = |i: i64, j: i64| {
            let (c, r) = ((i - oc) as usize, (j - or) as usize);
            pixels[(g.height() - 1 - r) * g.width() + c]
        };
        assert_eq!(at(0, 0), 0);
        assert_eq!(at(1, 0), 254);
        assert_eq!(at(2, 0), 205);
        let y = yaml(&g, "m.pgm");
        let field = |k: &str| {
            y.lines()
                .find_map(|l| l.strip_prefix(&format!("{k}: ")))
                .unwrap()
                .to_owned()
        };
        assert_eq!(field("image"), "m.pgm");
        assert_eq!(field("resolution"), "0.5");
        assert_eq!(field("negate"), "0");
        assert_eq!(field("occupied_thresh"), "0.65");
        assert_eq!(field("free_thresh"), "0.196");
        let o = g.origin();
        assert_eq!(field("origin"), format!("[{}, {}, 0.0]", o.x, o.y));
        assert_eq!(o, DVec2::new(oc as f64, or as f64) * 0.5);
    }

    #[test]
    fn npy_header_and_data() {
        let b = npy_f32(&[2, 3], [1.0, 2.0, 3.0, 4.0, 5.0, -6.5]);
        assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
        let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hl) % 64, 0);
        let header = std::str::from_utf8(&b[10..10 + hl]).unwrap();
        assert!(header.starts_with("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }"));
        assert!(header.ends_with('\n'));
        let data: Vec<f32> = b[10 + hl..]
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(data, [1.0, 2.0, 3.0, 4.0, 5.0, -6.5]);
        let one = npy_f32(&[3], [0.0; 3]);
        assert!(String::from_utf8_lossy(&one).contains("'shape': (3,)"));
        let g = small();
        let raw = npy(&g);
        let hl = u16::from_le_bytes([raw[8], raw[9]]) as usize;
        assert_eq!(raw.len(), 10 + hl + 4 * 2 * g.width() * g.height());
        let header = String::from_utf8_lossy(&raw[..128]);
        assert!(header.contains(&format!("(2, {}, {})", g.height(), g.width())));
    }

    #[test]
    fn figure_uses_the_palette() {
        let g = small();
        let fig = figure(&g, "t", 300, &Overlay::default()).unwrap();
        let count = |rgb: [u8; 3]| {
            fig.pixels()
                .iter()
                .filter(|p| [p.red(), p.green(), p.blue()] == rgb)
                .count()
        };
        // Known cells plus a 1 m margin: 6 × 5 cells of 0.5 m at 100 px/m, so 50 × 50 px
        // per cell; the legend adds a 14 × 14 swatch of each colour.
        assert!(count(CellClass::Obstacle.rgb()) >= 2500);
        assert!(count(CellClass::Unknown.rgb()) >= 28 * 2500);
        assert!(count(CellClass::SeeThrough.rgb()) <= 14 * 14, "legend only");
        // A forced region shows unknown cells around the map.
        let wide = Overlay {
            region: Some((DVec2::splat(-10.0), DVec2::splat(10.0))),
            ..Overlay::default()
        };
        let fig = figure(&g, "t", 300, &wide).unwrap();
        let blue = fig
            .pixels()
            .iter()
            .filter(|p| [p.red(), p.green(), p.blue()] == CellClass::Unknown.rgb())
            .count();
        assert!(blue > 85_000, "{blue}");
    }
}
