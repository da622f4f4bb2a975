//! The radar-signal part of `radarnav demo` (DESIGN §7): the foliage-wall power image with
//! the laser's scan over it, an A-scope along one azimuth through the hedge to the crate, and
//! the laser and the radar in `smoke-room` with the smoke's particles returning the laser.

use std::fmt::Write as _;
use std::fs;
use std::io::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use glam::DVec2;
use plotters::prelude::*;
use radarnav::render::{Figure, pixmap_from_rgb, save_png, world_region};
use radarnav::sensor::image::{PowerImage, azimuth_echoes};
use radarnav::sensor::{EchoKind, HitKind, Tracer};
use radarnav::world::{DB_PER_UNIT_EXTINCTION, World};
use radarnav::{Pose, Scenario};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::compare_cmd::{draw_err, plot_font};
use crate::signal_cmd::write_signal_outputs;

macro_rules! say {
    ($($arg:tt)*) => {
        writeln!(std::io::stdout().lock(), $($arg)*)?
    };
}

/// Cell of the power-image raster drawn in the world frame, m.
const RASTER_CELL: f64 = 0.03;

/// Runs the signal demo into `out`; `seed` seeds the image's speckle and noise.
pub fn signal_demo(out: &Path, seed: u64) -> Result<()> {
    let s = Scenario::builtin("foliage-wall").context("built-in scenario")?;
    let robot = s.robot(None).context("foliage-wall has a robot")?;
    let navtech = robot
        .with_preset_mount("navtech_cts350x")
        .context("the CTS350-X preset")?;
    let pose = robot.start.compose(&navtech.mount);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scan = navtech
        .config
        .scan(&s.world, &pose, 0.0, &mut rng, &mut Tracer::default());
    let dir = out.join("foliage_wall_navtech");
    fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let materials = s.world.materials().names();
    let (_, img) = write_signal_outputs(&s, &navtech, &pose, &scan, &materials, &mut rng, &dir)?;
    let img = img.context("the CTS350-X preset makes images")?;
    let laser = robot.sensor("laser").context("foliage-wall has a laser")?;
    let laser_scan = laser.config.scan(
        &s.world,
        &robot.start.compose(&laser.mount),
        0.0,
        &mut ChaCha8Rng::seed_from_u64(seed),
        &mut Tracer::default(),
    );
    let mut fig = Figure::blank(world_region(&s.world), 700)?;
    draw_image(&mut fig, &s.world, &img, &pose)?;
    fig.draw_scan(&laser_scan);
    fig.draw_robot(&robot.start, robot.vehicle);
    let path = out.join("radar_image_laser.png");
    save_png(
        &fig.finish("foliage-wall: radar power image (dark = strong), laser scan"),
        &path,
    )?;
    say!("");
    say!(
        "the radar's signal on foliage-wall: {} (Oxford layout: {} azimuths x {} bins, {} m bins), {}, {}",
        dir.join("polar.png").display(),
        img.rows(),
        img.bins,
        img.bin_size,
        dir.join("cartesian.png").display(),
        path.display()
    );
    ascope(out, &s, &navtech.config, &pose, &img)?;
    smoke(out, seed)
}

/// Draws `img`, taken by a sensor at `pose`, in the world frame: white is the noise floor,
/// black the strongest power.
fn draw_image(fig: &mut Figure, world: &World, img: &PowerImage, pose: &Pose) -> Result<()> {
    let (lo, hi) = world_region(world);
    let cols = ((hi.x - lo.x) / RASTER_CELL).ceil() as usize;
    let rows = ((hi.y - lo.y) / RASTER_CELL).ceil() as usize;
    let (sy, cy) = pose.yaw.sin_cos();
    fig.draw_cells(lo, RASTER_CELL, (cols, rows), |c, r| {
        let p = lo + DVec2::new(c as f64 + 0.5, r as f64 + 0.5) * RASTER_CELL - pose.xy();
        let (forward, left) = (p.x * cy + p.y * sy, -p.x * sy + p.y * cy);
        let g = 255 - img.value_at(forward, -left).unwrap_or(0);
        [g, g, g]
    })?;
    Ok(())
}

/// The A-scope: power against range along the image row that points at the crate behind the
/// hedge, with the noiseless echoes of that azimuth.
fn ascope(
    out: &Path,
    s: &Scenario,
    config: &radarnav::SensorConfig,
    pose: &Pose,
    img: &PowerImage,
) -> Result<()> {
    let target = s
        .world
        .objects()
        .iter()
        .find(|o| o.name.as_deref() == Some("crate"))
        .context("foliage-wall has a crate")?;
    let (a, b) = target.shape.aabb();
    let d = (a + b).truncate() / 2.0 - pose.xy();
    let theta = (pose.yaw - d.y.atan2(d.x)).rem_euclid(std::f64::consts::TAU);
    let k = (theta / (std::f64::consts::TAU / img.rows() as f64)).round() as usize % img.rows();
    let mut echoes = Vec::new();
    azimuth_echoes(
        config,
        &s.world,
        pose,
        img.azimuth(k),
        None,
        &mut Tracer::default(),
        &mut echoes,
    );
    echoes.sort_by(|a, b| a.range.total_cmp(&b.range));
    let im = config.signal.image.as_ref().context("an imaging preset")?;
    let reach = d.length() + 4.0;
    let row: Vec<(f64, f64)> = (0..img.bins)
        .map(|j| {
            let v = f64::from(img.power[k * img.bins + j]);
            (
                (j as f64 + 0.5) * img.bin_size,
                im.noise_floor_db + v / 255.0 * im.display_range_db,
            )
        })
        .take_while(|p| p.0 <= reach)
        .collect();
    let top = echoes
        .iter()
        .map(|e| e.power_db())
        .chain(row.iter().map(|p| p.1))
        .fold(f64::MIN, f64::max)
        + 5.0;
    let bottom = im.noise_floor_db - 5.0;
    plot_font()?;
    let (w, h) = (1100u32, 520u32);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let title = format!(
            "foliage-wall A-scope: azimuth {:.1} deg (row {k}) through the hedge to the crate",
            img.azimuth(k).to_degrees()
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..reach, bottom..top)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("range (m)")
            .y_desc("power (dB re. a unit reflector at 1 m)")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(draw_err)?;
        let grey = RGBColor(90, 90, 140);
        chart
            .draw_series(LineSeries::new(row.iter().copied(), &grey))
            .map_err(draw_err)?
            .label("image row (speckle, noise, point spread)")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], grey));
        let red = RGBColor(200, 30, 30);
        let green = RGBColor(30, 140, 50);
        chart
            .draw_series(
                echoes
                    .iter()
                    .filter(|e| e.kind == EchoKind::Surface)
                    .map(|e| Circle::new((e.range, e.power_db()), 5, red.filled())),
            )
            .map_err(draw_err)?
            .label("surface echo (one beam ray)")
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, red.filled()));
        chart
            .draw_series(
                echoes
                    .iter()
                    .filter(|e| e.kind == EchoKind::Volume)
                    .map(|e| {
                        TriangleMarker::new((e.range + e.depth / 2.0, e.power_db()), 6, green)
                    }),
            )
            .map_err(draw_err)?
            .label("volume echo inside foliage (per piece)")
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 6, green));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    let path = out.join("ascope.png");
    save_png(&pixmap_from_rgb(&rgb, w, h)?, &path)?;
    // One line per material met: how many echoes, over what ranges, the strongest.
    let names = s.world.materials();
    let mut groups: Vec<(u16, usize, f64, f64, f64)> = Vec::new();
    for e in echoes.iter().filter(|e| e.range <= reach) {
        match groups.iter_mut().find(|g| g.0 == e.material.0) {
            Some(g) => {
                g.1 += 1;
                g.3 = g.3.max(e.range + e.depth);
                g.4 = g.4.max(e.power_db());
            }
            None => groups.push((e.material.0, 1, e.range, e.range + e.depth, e.power_db())),
        }
    }
    let mut list = String::new();
    for (m, n, a, b, p) in groups {
        let name = &names.get(radarnav::world::MaterialId(m)).name;
        write!(
            list,
            "\n  {name:<14} {n:>3} echoes {a:.2}..{b:.2} m, strongest {p:.1} dB"
        )?;
    }
    say!(
        "A-scope {} (the {} beam rays of azimuth {:.1} deg):{list}",
        path.display(),
        config.signal.beam(0.0).len(),
        img.azimuth(k).to_degrees()
    );
    Ok(())
}

/// `smoke-room` with its smoke seen by the laser as the aerosol it is (particle returns, §7.6)
/// beside the thesis' opaque smoke and the radar.
fn smoke(out: &Path, seed: u64) -> Result<()> {
    let s = Scenario::builtin("smoke-room").context("built-in scenario")?;
    let robot = s.robot(None).context("smoke-room has a robot")?;
    let mut materials = s.world.materials().clone();
    let id = materials.id("smoke").context("built-in smoke")?;
    let mut aerosol = materials.get(id).clone();
    aerosol.laser_opaque = false;
    aerosol.laser_attenuation_db_per_m = DB_PER_UNIT_EXTINCTION * aerosol.laser_extinction_per_m;
    let k = aerosol.laser_extinction_per_m;
    materials.insert(aerosol);
    let world = World::new(materials, s.world.objects().to_vec());
    say!("");
    say!(
        "smoke-room from the start pose: the laser against smoke as the thesis has it (opaque) and as an aerosol (k = {k:.2}/m)"
    );
    say!(
        "{:<8} {:<10} {:>6} {:>14} {:>14} {:>10} {:>22}",
        "sensor",
        "smoke",
        "rays",
        "end at smoke",
        "beyond x = 5",
        "lost",
        "smoke returns x (m)"
    );
    for (name, w, label) in [
        ("laser", &s.world, "opaque"),
        ("laser", &world, "aerosol"),
        ("radar", &world, "aerosol"),
    ] {
        let sensor = robot
            .sensor(name)
            .with_context(|| format!("smoke-room has a {name}"))?;
        let scan = sensor.config.scan(
            w,
            &robot.start.compose(&sensor.mount),
            0.0,
            &mut ChaCha8Rng::seed_from_u64(seed),
            &mut Tracer::default(),
        );
        let smoke_id = w.materials().id("smoke");
        let mut in_smoke = Vec::new();
        let (mut beyond, mut lost) = (0, 0);
        for i in 0..scan.len() {
            let r = f64::from(scan.ranges[i]);
            let (az, _) = scan.angles(i);
            let x = scan.pose.x + r * (scan.pose.yaw + az).cos();
            if scan.materials[i] == smoke_id && scan.hits[i] == HitKind::Solid {
                in_smoke.push(x);
            } else if r.is_finite() && x > 5.0 {
                beyond += 1;
            }
            // A laser ray lost in the aerosol; every ray of this room ends on a wall.
            lost += usize::from(scan.hits[i] == HitKind::None);
        }
        in_smoke.sort_by(f64::total_cmp);
        let spread = match (in_smoke.first(), in_smoke.last()) {
            (Some(a), Some(b)) => format!(
                "{a:.2} .. {b:.2}, median {:.2}",
                in_smoke[in_smoke.len() / 2]
            ),
            _ => "-".to_owned(),
        };
        say!(
            "{:<8} {:<10} {:>6} {:>14} {:>14} {:>10} {:>22}",
            name,
            label,
            scan.len(),
            in_smoke.len(),
            beyond,
            lost,
            spread
        );
        if label == "aerosol" {
            let mut fig = Figure::of_world(w, None, 700)?;
            fig.draw_scan(&scan);
            fig.draw_robot(&robot.start, robot.vehicle);
            let path = out.join(format!("smoke_{name}.png"));
            let title = match name {
                "laser" => format!("smoke-room: the laser returns from the smoke (k = {k:.2}/m)"),
                _ => "smoke-room: the radar sees through the smoke".to_owned(),
            };
            save_png(&fig.finish(&title), &path)?;
        }
    }
    say!(
        "figures: {}, {}",
        out.join("smoke_laser.png").display(),
        out.join("smoke_radar.png").display()
    );
    Ok(())
}
