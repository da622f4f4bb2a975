//! `radarnav bench`: rays per second and per CPU-second of a scenario's sensors or a forest,
//! and the two halves of the peers benchmark (`--export`, `--rays`; see bench/peers.py).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use glam::DVec2;
use radarnav::peers::{pose_rays, read_scene, write_ranges, write_scene};
use radarnav::sensor::Tracer;
use radarnav::world::Band;
use radarnav::world::World;
use radarnav::world::forest::{ForestSpec, forest_of, plant_forest_of};
use radarnav::{Pose, Scenario};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Level rays of the exported poses: 360 a pose, 0.4 m above the ground (a radar's mount).
const RAYS_PER_POSE: usize = 360;
const RAY_HEIGHT: f64 = 0.4;
/// The radar of `--rays`: radar_thesis' 3 dB budget.
const RADAR_BUDGET_DB: f64 = 3.0;

/// CPU time of the calling thread, seconds: what a shared machine's other load does not
/// inflate, unlike wall time.
pub fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a pointer to a live local.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc == 0 {
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    } else {
        f64::NAN
    }
}

/// The forest of `--forest N [--side M] [--radius MIN,MAX] [--plants]`.
#[derive(Clone, Copy, Debug)]
pub struct Forest {
    /// Where the spheres (or plants) go; seeded by the scenario.
    pub spec: ForestSpec,
    /// Generated trees and bushes instead of spheres.
    pub plants: bool,
}

impl Forest {
    /// The forest's world with `seed`.
    fn world(&self, seed: u64) -> World {
        let spec = ForestSpec { seed, ..self.spec };
        if self.plants {
            plant_forest_of(&spec)
        } else {
            forest_of(&spec)
        }
    }

    /// What it holds, in words.
    fn about(&self, world: &World) -> String {
        let spec = &self.spec;
        if self.plants {
            let triangles: usize = (world.objects().iter())
                .map(|o| match &o.shape {
                    radarnav::world::Shape::Mesh(m) => m.triangle_count(),
                    _ => 0,
                })
                .sum();
            format!(
                "forest: {} generated trees and bushes ({triangles} triangles) where radii {}-{} m fall, over {} x {} m",
                spec.count, spec.radius.0, spec.radius.1, spec.side, spec.side
            )
        } else {
            format!(
                "forest: {} spheres, radius {}-{} m, centres uniform over {} x {} m",
                spec.count, spec.radius.0, spec.radius.1, spec.side, spec.side
            )
        }
    }
}

/// The forest of `--forest N [--side M] [--radius MIN,MAX] [--plants]`, seeded by the
/// scenario.
pub fn forest_spec(count: usize, side: Option<f64>, radius: &str, plants: bool) -> Result<Forest> {
    let parsed: Vec<f64> = radius
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--radius `{radius}`: expected MIN,MAX in metres"))?;
    let [lo, hi] = parsed[..] else {
        bail!("--radius `{radius}`: expected MIN,MAX in metres");
    };
    let size = &radarnav::limits::FOREST_SIZE;
    if !(size.contains(lo) && size.contains(hi) && lo < hi) {
        bail!(
            "--radius `{radius}`: expected MIN < MAX, each from {}",
            size.range()
        );
    }
    // --forest and --side are range-checked by the argument parser.
    let side = side.unwrap_or(3.0 * (count as f64).sqrt());
    Ok(Forest {
        spec: ForestSpec {
            count,
            side,
            radius: (lo, hi),
            clearing: 2.0,
            seed: 0,
        },
        plants,
    })
}

/// Times `scans` scans of every sensor of the scenario's first robot (in the forest of
/// `forest` instead of its world, at the forest's centre).
pub fn scans(mut s: Scenario, scans: usize, forest: Option<&Forest>) -> Result<()> {
    let mut start = s
        .robot(None)
        .with_context(|| format!("scenario `{}` has no robot", s.name))?
        .start;
    if let Some(forest) = forest {
        s.world = forest.world(s.sim.seed);
        s.name = format!("{}, sensors of {}", forest.about(&s.world), s.name);
        start = Pose::default();
    }
    let r = s.robot(None).context("scenario has no robot")?;
    let mut tracer = Tracer::default();
    let mut rng = ChaCha8Rng::seed_from_u64(s.sim.seed);
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{} ({} objects), {} scans per sensor, one thread:",
        s.name,
        s.world.objects().len(),
        scans
    )?;
    for m in &r.sensors {
        let pose = start.compose(&m.mount);
        let (t0, c0) = (Instant::now(), thread_cpu_seconds());
        let mut rays = 0usize;
        for k in 0..scans.max(1) {
            rays += m
                .config
                .scan(&s.world, &pose, k as f64, &mut rng, &mut tracer)
                .len();
        }
        let (secs, cpu) = (t0.elapsed().as_secs_f64(), thread_cpu_seconds() - c0);
        writeln!(
            out,
            "  {:<10} {:>6.2} M rays/s, {:>6.2} M rays per CPU-s  ({rays} rays in {secs:.3} s)",
            m.name,
            rays as f64 / secs / 1e6,
            rays as f64 / cpu / 1e6
        )?;
    }
    Ok(())
}

/// `--export DIR`: the world (or the forest) and rays from `poses` random free poses.
pub fn export(
    s: &Scenario,
    forest: Option<&Forest>,
    dir: &Path,
    poses: usize,
    range: f64,
) -> Result<()> {
    if !(range > 0.0 && range <= 1e4) {
        bail!("--range {range}: expected 0 < range <= 10000 m");
    }
    if poses == 0 || poses > 100_000 {
        bail!("--poses {poses}: expected 1 to 100000");
    }
    let (world, area, about) = match forest {
        Some(forest) => {
            let spec = ForestSpec {
                clearing: 0.0,
                ..forest.spec
            };
            let forest = Forest { spec, ..*forest };
            let world = forest.world(s.sim.seed);
            let half = DVec2::splat(spec.side / 2.0);
            let about = format!("{}, seed {}", forest.about(&world), s.sim.seed);
            (world, (-half, half), about)
        }
        None => {
            let (lo, hi) = s
                .world
                .bounds()
                .with_context(|| format!("scenario `{}` has no objects", s.name))?;
            let about = format!("scenario {}, seed {}", s.name, s.sim.seed);
            (s.world.clone(), (lo.truncate(), hi.truncate()), about)
        }
    };
    let rays = pose_rays(&world, area, poses, RAYS_PER_POSE, RAY_HEIGHT, s.sim.seed);
    let about = format!(
        "{about}; {} poses x {RAYS_PER_POSE} level rays at {RAY_HEIGHT} m",
        rays.len() / RAYS_PER_POSE
    );
    let skipped = write_scene(dir, &world, &rays, range, &about)?;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "wrote {} ({} objects, {} rays, range {range} m)",
        dir.display(),
        world.objects().len() - skipped,
        rays.len()
    )?;
    if skipped > 0 {
        writeln!(out, "  {skipped} prisms left out: the peers have no prism")?;
    }
    Ok(())
}

/// `--rays DIR`: traces an exported scene's rays as a laser (first hit) and as the thesis
/// radar (3 dB budget), `repeats` times each, one thread; writes `ranges_laser.f64` and
/// `ranges_radar.f64` (little-endian f64 per ray, `inf` for none) and prints the medians of
/// rays per CPU-second.
pub fn trace_rays(dir: &Path, repeats: usize, json: bool) -> Result<()> {
    let (world, rays, range) = read_scene(dir)?;
    if rays.is_empty() {
        bail!("{}: no rays", dir.join("rays.csv").display());
    }
    let mut tracer = Tracer::default();
    let mut result = serde_json::Map::new();
    let mut lines = Vec::new();
    for (name, band, budget) in [
        ("laser", Band::Laser, 0.0),
        ("radar", Band::Radar, RADAR_BUDGET_DB),
    ] {
        let mut ranges = vec![0.0f64; rays.len()];
        let mut rates = Vec::new();
        for _ in 0..repeats.max(1) {
            let c0 = thread_cpu_seconds();
            for (r, ray) in ranges.iter_mut().zip(&rays) {
                *r = tracer.trace(&world, ray, band, budget, range).range;
            }
            rates.push(rays.len() as f64 / (thread_cpu_seconds() - c0));
        }
        rates.sort_by(f64::total_cmp);
        let median = rates[rates.len() / 2];
        write_ranges(dir, name, &ranges)?;
        result.insert(format!("{name}_rays_per_cpu_s"), median.into());
        lines.push(format!(
            "  {name:<6} {:>6.2} M rays per CPU-second (median of {}), {:.3} us per ray",
            median / 1e6,
            rates.len(),
            1e6 / median
        ));
    }
    let mut out = std::io::stdout().lock();
    if json {
        writeln!(out, "{}", serde_json::Value::Object(result))?;
    } else {
        writeln!(
            out,
            "{}: {} objects, {} rays, one thread:",
            dir.display(),
            world.objects().len(),
            rays.len()
        )?;
        for l in lines {
            writeln!(out, "{l}")?;
        }
    }
    Ok(())
}
