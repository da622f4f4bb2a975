//! `radarnav compare`: exploration strategies × sensors × seeds, in parallel; a CSV of
//! coverage against distance, a summary CSV, a table and a PNG plot.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::io::{IsTerminal, Write};
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use radarnav::Scenario;
use radarnav::batch::map_longest_first;
use radarnav::compare::{ExploreJob, ExploreResult, coverage_at, explore, robot_with_sensor};
use radarnav::limits::budget::Budget;
use radarnav::map::{MapConfig, Truth};
use radarnav::nav::{BumperConfig, Strategy};
use radarnav::render::{pixmap_from_rgb, save_png};

/// Distance at which the table compares coverage, m.
const AT_DISTANCE: f64 = 10.0;

/// What `compare` was asked.
pub struct CompareArgs<'a> {
    pub scenario: &'a Scenario,
    pub strategies: &'a [String],
    pub sensors: &'a [String],
    pub seeds: u64,
    pub seed: Option<u64>,
    pub duration: Option<f64>,
    pub safety: Option<f64>,
    pub out: &'a Path,
}

/// `radarnav compare`.
pub fn compare(a: &CompareArgs<'_>) -> Result<()> {
    let s = a.scenario;
    // --seeds, --duration and --safety are range-checked by the argument parser.
    let strategies = a
        .strategies
        .iter()
        .map(|n| {
            Strategy::parse(n).with_context(|| {
                format!("--strategies: unknown strategy `{n}`; known: bounce, wall_follow, spiral, frontier")
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let bumpers = BumperConfig {
        safety: a.safety,
        ..BumperConfig::default()
    };
    bumpers
        .validate()
        .map_err(|m| anyhow::anyhow!("--safety: {m}"))?;
    let mission_robot = s.mission.as_ref().and_then(|m| m.robot.as_deref());
    // One truth raster per scan plane, shared by every run of that sensor.
    let (mut truths, mut rays_per_s) = (BTreeMap::new(), BTreeMap::new());
    for sensor in a.sensors {
        let r = robot_with_sensor(s, mission_robot, sensor).with_context(|| "--sensors")?;
        let z = r.sensors[0].mount.z;
        let c = &r.sensors[0].config;
        let rays = c.azimuth_count() as f64 * c.elevations.len().max(1) as f64 * c.rate_hz;
        rays_per_s.insert(sensor.clone(), rays);
        // The truth raster covers the world's bounds: refuse a world too large for it.
        let bounds = radarnav::render::world_region(&s.world);
        Budget::default().check_maps(["truth"], bounds, MapConfig::default().resolution)?;
        truths.insert(
            sensor.clone(),
            Arc::new(Truth::of_world(
                &s.world,
                MapConfig::default().resolution,
                z,
                r.vehicle,
                &r.start,
            )),
        );
    }
    let base = a.seed.unwrap_or(s.sim.seed);
    let jobs: Vec<ExploreJob> = strategies
        .iter()
        .flat_map(|&strategy| {
            a.sensors.iter().flat_map(move |sensor| {
                (0..a.seeds).map(move |k| ExploreJob {
                    strategy,
                    sensor: sensor.clone(),
                    seed: base + k,
                })
            })
        })
        .collect();
    let bar = if std::io::stderr().is_terminal() {
        ProgressBar::new(jobs.len() as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed_precise}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let started = std::time::Instant::now();
    // A run costs about its sensor's rays: the laser's runs go first, so that no core is
    // left on one of them at the end. A frontier run also keeps the planner's map and plans
    // on it every 2 s: on foliage-wall a radar frontier run took 1.6–3.0 times another radar
    // run, so it counts double.
    let results = map_longest_first(
        &jobs,
        |job| {
            let planning = if job.strategy == Strategy::Frontier {
                2.0
            } else {
                1.0
            };
            rays_per_s[&job.sensor] * planning
        },
        |job| {
            let r = explore(
                s,
                mission_robot,
                job,
                a.duration,
                &bumpers,
                Arc::clone(&truths[&job.sensor]),
            );
            bar.inc(1);
            r
        },
    )
    .into_iter()
    .collect::<Result<Vec<_>, _>>()?;
    bar.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();
    fs::create_dir_all(a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let written = [
        write_samples(a.out, &results)?,
        write_runs(a.out, &results)?,
        plot(a.out, s, &results)?,
    ];
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {} runs ({} strategies x {} sensors x {} seeds) in {:.1} s wall",
        s.name,
        results.len(),
        strategies.len(),
        a.sensors.len(),
        a.seeds,
        wall
    )?;
    out.write_all(table(&results).as_bytes())?;
    for f in written {
        writeln!(out, "  wrote {}", f.display())?;
    }
    Ok(())
}

fn opt(x: Option<f64>) -> String {
    x.map_or_else(String::new, |v| format!("{v:.5}"))
}

fn write_samples(dir: &Path, results: &[ExploreResult]) -> Result<std::path::PathBuf> {
    let mut csv =
        String::from("strategy,sensor,seed,time,distance,free_coverage,hidden_coverage\n");
    for r in results {
        for c in &r.coverage {
            writeln!(
                csv,
                "{},{},{},{:.3},{:.4},{},{}",
                r.job.strategy.as_str(),
                r.job.sensor,
                r.job.seed,
                c.time,
                c.distance,
                opt(c.free),
                opt(c.hidden)
            )?;
        }
    }
    let path = dir.join("compare.csv");
    radarnav::record::write_whole(&path, csv.as_bytes())?;
    Ok(path)
}

fn write_runs(dir: &Path, results: &[ExploreResult]) -> Result<std::path::PathBuf> {
    let mut csv = String::from(
        "strategy,sensor,seed,outcome,duration,distance,bumps,free_coverage,hidden_coverage\n",
    );
    for r in results {
        let last = r.coverage.last();
        writeln!(
            csv,
            "{},{},{},{},{:.2},{:.3},{},{},{}",
            r.job.strategy.as_str(),
            r.job.sensor,
            r.job.seed,
            serde_json::to_value(r.summary.outcome)?
                .as_str()
                .unwrap_or("?"),
            r.summary.duration,
            r.summary.distance,
            r.summary.bumps,
            opt(last.and_then(|c| c.free)),
            opt(last.and_then(|c| c.hidden))
        )?;
    }
    let path = dir.join("compare_runs.csv");
    radarnav::record::write_whole(&path, csv.as_bytes())?;
    Ok(path)
}

/// Runs grouped by (strategy, sensor), in the order asked.
fn groups(results: &[ExploreResult]) -> Vec<(String, Vec<&ExploreResult>)> {
    let mut out: Vec<(String, Vec<&ExploreResult>)> = Vec::new();
    for r in results {
        let key = format!("{} / {}", r.job.strategy.as_str(), r.job.sensor);
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(r),
            None => out.push((key, vec![r])),
        }
    }
    out
}

fn table(results: &[ExploreResult]) -> String {
    let mean = |xs: &[Option<f64>]| {
        let v: Vec<f64> = xs.iter().flatten().copied().collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let pct = |x: Option<f64>| x.map_or_else(|| "-".to_owned(), |v| format!("{:.1}%", 100.0 * v));
    let mut t = format!(
        "{:<22} {:>5} {:>10} {:>7} {:>10} {:>10} {:>13}\n",
        "strategy / sensor",
        "runs",
        "distance",
        "bumps",
        "free cov",
        "hidden cov",
        format!("hidden @{AT_DISTANCE:.0} m")
    );
    for (key, runs) in groups(results) {
        let n = runs.len() as f64;
        let dist = runs.iter().map(|r| r.summary.distance).sum::<f64>() / n;
        let bumps = runs.iter().map(|r| r.summary.bumps as f64).sum::<f64>() / n;
        let last = |hidden: bool| -> Vec<Option<f64>> {
            runs.iter()
                .map(|r| {
                    r.coverage
                        .last()
                        .and_then(|c| if hidden { c.hidden } else { c.free })
                })
                .collect()
        };
        let at: Vec<Option<f64>> = runs
            .iter()
            .map(|r| coverage_at(&r.coverage, AT_DISTANCE, true))
            .collect();
        let reached = at.iter().filter(|x| x.is_some()).count();
        let _ = writeln!(
            t,
            "{key:<22} {:>5} {:>8.1} m {bumps:>7.1} {:>10} {:>10} {:>8} ({reached}/{})",
            runs.len(),
            dist,
            pct(mean(&last(false))),
            pct(mean(&last(true))),
            pct(mean(&at)),
            runs.len()
        );
    }
    t
}

const COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

fn plot(dir: &Path, s: &Scenario, results: &[ExploreResult]) -> Result<std::path::PathBuf> {
    plot_font()?;
    let (w, h) = (1400u32, 620u32);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    let max_d = results
        .iter()
        .map(|r| r.summary.distance)
        .fold(1.0f64, f64::max)
        * 1.02;
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let root = root
            .titled(
                &format!("{}: coverage against distance travelled", s.name),
                ("sans-serif", 26),
            )
            .map_err(draw_err)?;
        let panels = root.split_evenly((1, 2));
        let groups = groups(results);
        // One colour per strategy, in the order asked.
        let mut strategies: Vec<&str> = Vec::new();
        for r in results {
            if !strategies.contains(&r.job.strategy.as_str()) {
                strategies.push(r.job.strategy.as_str());
            }
        }
        for (panel, hidden) in panels.iter().zip([false, true]) {
            let mut chart = ChartBuilder::on(panel)
                .caption(
                    if hidden {
                        "hidden area (behind foliage/smoke) seen"
                    } else {
                        "free area seen"
                    },
                    ("sans-serif", 20),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(55)
                .build_cartesian_2d(0.0..max_d, 0.0..100.0)
                .map_err(draw_err)?;
            chart
                .configure_mesh()
                .x_desc("distance travelled, m")
                .y_desc("coverage, %")
                .label_style(("sans-serif", 15))
                .light_line_style(WHITE)
                .bold_line_style(RGBColor(225, 225, 225))
                .draw()
                .map_err(draw_err)?;
            for (key, runs) in &groups {
                let strategy = runs[0].job.strategy.as_str();
                let k = strategies.iter().position(|x| *x == strategy).unwrap_or(0);
                let colour = COLOURS[k % COLOURS.len()];
                let dashed = runs[0].job.sensor != runs_first_sensor(results);
                let style = if dashed {
                    colour.mix(0.9).stroke_width(1)
                } else {
                    colour.stroke_width(3)
                };
                for (i, r) in runs.iter().enumerate() {
                    let pts: Vec<(f64, f64)> = r
                        .coverage
                        .iter()
                        .filter_map(|c| {
                            let v = if hidden { c.hidden } else { c.free };
                            v.map(|v| (c.distance, 100.0 * v))
                        })
                        .collect();
                    let anno = if dashed {
                        chart.draw_series(DashedLineSeries::new(pts, 8, 5, style))
                    } else {
                        chart.draw_series(LineSeries::new(pts, style))
                    }
                    .map_err(draw_err)?;
                    if i == 0 {
                        anno.label(key.as_str()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], style)
                        });
                    }
                }
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    let pixmap = pixmap_from_rgb(&rgb, w, h)?;
    let path = dir.join("compare.png");
    save_png(&pixmap, &path)?;
    Ok(path)
}

/// The sensor drawn with solid lines: the first one asked for.
fn runs_first_sensor(results: &[ExploreResult]) -> &str {
    results.first().map_or("", |r| r.job.sensor.as_str())
}

/// Registers the plots' font (see [`radarnav::render::register_plot_font`]).
pub fn plot_font() -> Result<()> {
    radarnav::render::register_plot_font()
        .map_err(|_| anyhow::anyhow!("the plot font did not load"))
}

/// A plotting error as an `anyhow` error.
pub fn draw_err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing the plot: {e:?}")
}
