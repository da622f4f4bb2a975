//! `radarnav`: the command line over the radarnav library.

mod bench_cmd;
mod compare_cmd;
mod demo_cmd;
mod nav_suite_cmd;
mod ros2_cmd;
mod run_cmd;
mod scan_cmd;
mod serve_cmd;
mod signal_cmd;
mod signal_demo;
mod sweep_cmd;

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use radarnav::Scenario;
use radarnav::limits::{self, Limit};
use radarnav::render::{Figure, save_png};
use radarnav::scenario::{BUILTIN_SCENARIOS, NAV_SUITE};
use radarnav::sensor::PRESETS;

#[derive(Parser)]
#[command(
    name = "radarnav",
    version,
    about = "Radar navigation workbench: a radar that sees through foliage and smoke, beside a laser that cannot"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The thesis experiment on foliage-wall: figures 7-10, ground truth and a table; then
    /// the mission driven while mapping with the radar and with the laser, and their scores.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Seed of the side-beam draws.
        #[arg(long)]
        seed: Option<u64>,
        /// Extra scans per sensor for the mean share.
        #[arg(long, default_value_t = 100, value_parser = count::<usize>(&limits::REPEATS))]
        repeats: usize,
    },
    /// Serve a scenario to USARSim clients (its TCP text protocol): each client INITs a P3AT
    /// with the scenario robot's sensors (as RangeScanners), drives it with DRIVE and
    /// receives SEN and STA messages in real time.
    Serve {
        /// A built-in name or a path to a .toml file.
        scenario: String,
        /// TCP port (USARSim's is 3000).
        #[arg(long, default_value_t = 3000)]
        port: u16,
        /// Address to listen on (0.0.0.0 for clients on other machines).
        #[arg(long, default_value = "127.0.0.1")]
        bind: String,
        /// Simulated seconds per wall-clock second.
        #[arg(long, default_value_t = 1.0, value_parser = number(&limits::SERVE_SPEED))]
        speed: f64,
        /// The scenario robot whose vehicle and sensors clients get (default: the first).
        #[arg(long)]
        robot: Option<String>,
    },
    /// Run a scenario's robot as a live ROS 2 node (needs the `ros2` build feature): it
    /// publishes /clock, /tf, /tf_static, /odom, /scan/<sensor> and maps, and drives by
    /// geometry_msgs/Twist on /cmd_vel.
    Ros2 {
        /// A built-in name or a path to a .toml file.
        scenario: String,
        /// Simulated seconds per wall-clock second.
        #[arg(long, default_value_t = 1.0, value_parser = number(&limits::SERVE_SPEED))]
        speed: f64,
        /// Stop after this much simulated time, seconds (default: at Ctrl-C).
        #[arg(long, value_parser = number(&limits::DURATION))]
        duration: Option<f64>,
        /// The scenario robot to run (default: the first).
        #[arg(long)]
        robot: Option<String>,
        /// Publish no maps.
        #[arg(long)]
        no_maps: bool,
        /// Sensor presets to mount beside the robot's own, comma-separated (an imaging
        /// radar's images go to /radar/<sensor>/image).
        #[arg(long, value_delimiter = ',')]
        add_sensor: Vec<String>,
    },
    /// List the built-in scenarios.
    Scenarios,
    /// List the sensor presets.
    Presets,
    /// Print the valid range of every numeric input (docs/limits.md) as a Markdown table.
    Limits,
    /// Grow a seeded tree or bush (as `mesh = { generate = ... }` does) and write it as OBJ
    /// with its MTL beside it, for viewers and editors.
    Grow {
        /// `tree` or `bush`.
        plant: String,
        /// Seed: the same seed grows the same plant.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Height, metres (default: tree 5, bush 1.2).
        #[arg(long, value_parser = number(&limits::SIZE))]
        height: Option<f64>,
        /// The OBJ file to write (the MTL gets the same name with `.mtl`).
        #[arg(long, default_value = "plant.obj")]
        out: PathBuf,
    },
    /// Draw a scenario's world, with its robots at their start poses.
    Render {
        /// A built-in name or a path to a .toml file.
        scenario: String,
        /// Output directory (writes SCENARIO.png).
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Longer side of the map area, pixels.
        #[arg(long, default_value_t = 900, value_parser = count::<u32>(&limits::PIXELS))]
        pixels: u32,
    },
    /// One scan: writes scan.png, scan.json and scan.csv; echoes.csv in `all` mode; for an
    /// imaging radar (navtech_cts350x, …) polar.png (Oxford layout), radar.timestamps,
    /// cartesian.png and detections.csv.
    Scan {
        /// A built-in name or a path to a .toml file.
        scenario: String,
        /// A sensor on the robot, or a preset name (mounted like the robot's first sensor).
        #[arg(long)]
        sensor: String,
        /// Robot name (default: the first).
        #[arg(long)]
        robot: Option<String>,
        /// Robot pose `x,y,yaw_deg` (default: its start pose).
        #[arg(long, allow_hyphen_values = true)]
        pose: Option<String>,
        /// Seed (default: the scenario's).
        #[arg(long)]
        seed: Option<u64>,
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Longer side of the map area, pixels.
        #[arg(long, default_value_t = 900, value_parser = count::<u32>(&limits::PIXELS))]
        pixels: u32,
    },
    /// Drive a scenario's mission and record it: trajectory.csv, scans/*.rnscan,
    /// summary.json, path.png, run.mcap (Foxglove/Lichtblick) and, with --ros2-bag, a
    /// rosbag2 directory ros2_bag/.
    Run {
        /// A built-in name or a path to a .toml file.
        scenario: String,
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Robot name (default: the mission's, else the first).
        #[arg(long)]
        robot: Option<String>,
        /// Drive by a teleop CSV (`duration,v,omega_deg_s` or `duration,left,right`) instead
        /// of the scenario's mission.
        #[arg(long)]
        teleop: Option<PathBuf>,
        /// Seed (default: the scenario's).
        #[arg(long)]
        seed: Option<u64>,
        /// Longest simulated time, seconds (default: the scenario's).
        #[arg(long, value_parser = number(&limits::DURATION))]
        duration: Option<f64>,
        /// Do not write run.mcap.
        #[arg(long)]
        no_mcap: bool,
        /// Also write a rosbag2 (MCAP storage, CDR) to ros2_bag/, for `ros2 bag play`.
        #[arg(long)]
        ros2_bag: bool,
        /// Longer side of the map area of path.png and the map figures, pixels.
        #[arg(long, default_value_t = 900, value_parser = count::<u32>(&limits::PIXELS))]
        pixels: u32,
        /// Maps to build, comma-separated; each a sensor name or sensors joined by `+`
        /// (`radar,laser,radar+laser`). Default: one map per sensor of the robot.
        #[arg(long, value_delimiter = ',')]
        maps: Vec<String>,
        /// Build no map.
        #[arg(long, conflicts_with = "maps")]
        no_maps: bool,
        /// Pose that places the scans in the maps: `truth`, `odometry` or `slam` (the robot's
        /// localiser, `[robot.slam]`).
        #[arg(long, default_value = "truth")]
        map_pose: String,
        /// Map cell size, metres.
        #[arg(long, default_value_t = 0.05, value_parser = number(&limits::MAP_RESOLUTION))]
        map_resolution: f64,
        /// A ray with no return frees map cells up to this range, metres.
        #[arg(long, default_value_t = 10.0, value_parser = number(&limits::MAP_FREE_RANGE))]
        map_max_free_range: f64,
        /// Sensor presets to add to the robot, comma-separated, each named after its preset
        /// and mounted like the robot's first sensor (e.g. `navtech_cts350x`: its power
        /// images go to radar/<sensor>/).
        #[arg(long, value_delimiter = ',')]
        add_sensor: Vec<String>,
        /// The sensor the robot's localiser registers (default: `[robot.slam] sensor`, else
        /// its first radar, else its first laser); `none` runs no localiser.
        #[arg(long)]
        slam_sensor: Option<String>,
        /// Memory the run may plan for, GB (default 4): maps over it are refused before
        /// the run starts.
        #[arg(long, value_parser = number(&limits::MAX_MEMORY))]
        max_memory: Option<f64>,
        /// Bytes the run may write, GB (default 10): a run whose outputs are estimated
        /// larger is refused before it starts.
        #[arg(long, value_parser = number(&limits::MAX_OUTPUT))]
        max_output: Option<f64>,
    },
    /// Compare exploration strategies with each sensor over several seeds (in parallel):
    /// writes compare.csv (coverage against distance), compare_runs.csv and compare.png.
    Compare {
        /// A built-in name or a path to a .toml file.
        scenario: String,
        /// Strategies, comma-separated: bounce, wall_follow, spiral, frontier.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "bounce,wall_follow,spiral,frontier"
        )]
        strategies: Vec<String>,
        /// Sensors of the robot, comma-separated; each run keeps only one of them.
        #[arg(long, value_delimiter = ',', default_value = "radar,laser")]
        sensors: Vec<String>,
        /// Runs per strategy and sensor, seeds SEED, SEED+1, ...
        #[arg(long, default_value_t = 5, value_parser = count::<u64>(&limits::SEEDS))]
        seeds: u64,
        /// First seed (default: the scenario's).
        #[arg(long)]
        seed: Option<u64>,
        /// Longest simulated time of a run, seconds (default: the scenario's).
        #[arg(long, value_parser = number(&limits::DURATION))]
        duration: Option<f64>,
        /// Bumper safety distance, metres (default: 2.5 vehicle lengths).
        #[arg(long, value_parser = number(&limits::BUMPER))]
        safety: Option<f64>,
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Navigation trials: each map's Bug mission with both algorithms, both sensors (radar,
    /// laser), both poses (truth, odometry) and several seeds, each run judged against what
    /// the map's geometry implies (outcome, no bump, the classic path bound). Prints the pass
    /// table and the failed runs.
    NavSuite {
        /// Scenario files, built-in names or directories of .toml files (default: the
        /// built-in trial maps, `radarnav scenarios` lists them as nav/...).
        scenarios: Vec<String>,
        /// Seeds 1..=N per configuration.
        #[arg(long, default_value_t = 3, value_parser = count::<u64>(&limits::SEEDS))]
        seeds: u64,
        /// Algorithms, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "bug1,bug2")]
        algorithms: Vec<String>,
        /// Sensors the bumpers read, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "radar,laser")]
        sensors: Vec<String>,
        /// Poses navigation believes, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "truth,odometry")]
        poses: Vec<String>,
        /// Write nav_suite.csv, nav_suite.json and failed/ (a figure of each failed run) here.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// A sweep: scenario x parameter grid x seed runs from a spec file (docs/sweeps.md), on
    /// all cores. With --shard i/N only every N-th run from the i-th (a Slurm array task:
    /// --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT); `sweep merge` joins the shards.
    Sweep(SweepArgs),
    /// Time scans of every sensor of a scenario's first robot; prints rays per second and per
    /// CPU-second. With --sim, time a whole simulated run instead; with --export and --rays,
    /// the scene and rays of the peers benchmark (bench/peers.py).
    Bench {
        /// A built-in name or a path to a .toml file.
        #[arg(default_value = "foliage-wall")]
        scenario: String,
        /// Scans per sensor.
        #[arg(long, default_value_t = 200, value_parser = count::<usize>(&limits::SCANS))]
        scans: usize,
        /// Replace the scenario's objects by a generated forest of this many foliage spheres,
        /// the robot at its centre.
        #[arg(long, value_parser = count::<usize>(&limits::FOREST))]
        forest: Option<usize>,
        /// Side of the forest's square, metres (default 3 m x sqrt(N): one sphere per 9 m2).
        #[arg(long, value_parser = number(&limits::FOREST_SIZE))]
        side: Option<f64>,
        /// Radii of the forest's spheres, `MIN,MAX` metres.
        #[arg(long, default_value = "0.3,1.5")]
        radius: String,
        /// Grow the forest as generated trees and bushes (triangle meshes, about 770 a plant)
        /// where it would have spheres: a tree for a radius above the middle of --radius, else
        /// a bush as high as the sphere.
        #[arg(long, requires = "forest")]
        plants: bool,
        /// Simulate this many seconds of the scenario's mission (waypoints repeat) without
        /// recording, and print simulated time per wall time.
        #[arg(long, value_parser = number(&limits::BENCH_SIM))]
        sim: Option<f64>,
        /// Write the world (the forest with --forest) and level rays from random free poses
        /// to this directory: world.json, rays.csv, meta.json.
        #[arg(long)]
        export: Option<PathBuf>,
        /// Poses of the exported rays; each casts 360 level rays, 0.4 m above the ground.
        #[arg(long, default_value_t = 200, value_parser = count::<usize>(&limits::POSES))]
        poses: usize,
        /// Ray length of the exported scene, metres.
        #[arg(long, default_value_t = 80.0, value_parser = number(&limits::FOREST_SIZE))]
        range: f64,
        /// Trace the rays of an exported scene (laser: first hit; radar: 3 dB budget), write
        /// their ranges beside it and print rays per CPU-second, medians of --repeats runs.
        #[arg(long, conflicts_with_all = ["export", "sim"])]
        rays: Option<PathBuf>,
        /// Runs of --rays.
        #[arg(long, default_value_t = 5, value_parser = count::<usize>(&limits::REPEATS))]
        repeats: usize,
        /// Print the result of --rays as one line of JSON.
        #[arg(long)]
        json: bool,
    },
}

/// `radarnav sweep`.
#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
struct SweepArgs {
    #[command(subcommand)]
    merge: Option<SweepMerge>,
    /// The sweep spec (TOML).
    #[arg(required = true)]
    spec: Option<PathBuf>,
    /// Run only shard i of N (0 <= i < N); writes shard-i-of-N.json. Without it, every run,
    /// merged into sweep.csv, sweep_groups.csv and sweep.png.
    #[arg(long)]
    shard: Option<radarnav::sweep::Shard>,
    /// Output directory.
    #[arg(long, default_value = "out/sweep")]
    out: PathBuf,
}

#[derive(Subcommand)]
enum SweepMerge {
    /// Join the shard files (shard-i-of-N.json) found in DIRS into sweep.csv,
    /// sweep_groups.csv and sweep.png; every run must be there exactly once.
    Merge {
        /// Directories holding shard files.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "out/sweep")]
        out: PathBuf,
    },
}

/// A clap parser of a number in `limit`'s range.
fn number(limit: &'static Limit) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |s| limit.parse(s)
}

/// A clap parser of a whole number in `limit`'s range.
fn count<T: TryFrom<u64>>(limit: &'static Limit) -> impl Fn(&str) -> Result<T, String> + Clone {
    move |s| {
        let v = limit.parse_count(s)?;
        T::try_from(v).map_err(|_| format!("{v} is too large"))
    }
}

/// `println!` that returns an error instead of panicking when stdout is closed.
macro_rules! say {
    ($($arg:tt)*) => {
        writeln!(std::io::stdout().lock(), $($arg)*)?
    };
}

fn main() {
    let cli = Cli::parse();
    // One run's simulation forks a few scans per controller period. With the main thread one
    // of the pool's threads, that fork runs partly here instead of waking the pool and
    // sleeping until it is done (a futex round trip per period): `bench foliage-wall --sim
    // 600` ran about 40 % faster. Only commands that simulate on the main thread: commands
    // that run many runs at once keep rayon's default pool, which shares whole runs better
    // (`compare` took 15 % longer the other way), and a server's clients simulate on their own
    // threads, whose forks must find a pool thread that is not blocked outside rayon.
    if cli.command.simulates_on_main_thread() {
        // If a pool exists already, rayon keeps it.
        let _ = rayon::ThreadPoolBuilder::new()
            .use_current_thread()
            .build_global();
    }
    if let Err(e) = run(cli) {
        // A closed pipe (`radarnav presets | head`) is the reader's choice, not an error.
        let broken_pipe = e
            .chain()
            .filter_map(|c| c.downcast_ref::<std::io::Error>())
            .any(|io| io.kind() == std::io::ErrorKind::BrokenPipe);
        if broken_pipe {
            return;
        }
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

impl Command {
    /// Whether the command runs one simulation (or scan) at a time on the main thread (see
    /// `main`).
    fn simulates_on_main_thread(&self) -> bool {
        matches!(
            self,
            Command::Run { .. } | Command::Bench { .. } | Command::Scan { .. }
        )
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo { out, seed, repeats } => demo_cmd::demo(&out, seed, repeats),
        Command::Scenarios => {
            for (name, _) in BUILTIN_SCENARIOS.iter().chain(NAV_SUITE) {
                let s = Scenario::builtin(name).context("built-in scenario")?;
                say!(
                    "{name:<16} {:>4} objects  {}",
                    s.world.objects().len(),
                    s.description
                );
            }
            Ok(())
        }
        Command::Serve {
            scenario,
            port,
            bind,
            speed,
            robot,
        } => serve_cmd::run(&load(&scenario)?, robot.as_deref(), &bind, port, speed),
        Command::Ros2 {
            scenario,
            speed,
            duration,
            robot,
            no_maps,
            add_sensor,
        } => ros2_cmd::run(&ros2_cmd::Ros2Args {
            scenario: &load(&scenario)?,
            robot: robot.as_deref(),
            speed,
            duration,
            maps: !no_maps,
            add_sensors: &add_sensor,
        }),
        Command::Grow {
            plant,
            seed,
            height,
            out,
        } => {
            use radarnav::world::procedural::{Plant, grow, write_obj};
            let kind = Plant::parse(&plant)
                .with_context(|| format!("unknown plant `{plant}`; known: tree, bush"))?;
            let parts = grow(kind, height.unwrap_or(kind.default_height()), seed);
            write_obj(&out, &parts).with_context(|| format!("writing {}", out.display()))?;
            let triangles: usize = parts.iter().map(|p| p.triangles.len()).sum();
            say!(
                "{plant} (seed {seed}): {triangles} triangles; wrote {}",
                out.display()
            );
            Ok(())
        }
        Command::Limits => {
            say!("{}", limits::markdown_table().trim_end());
            Ok(())
        }
        Command::Presets => {
            for p in PRESETS {
                say!("{:<18} {}", p.name, p.about);
            }
            Ok(())
        }
        Command::Render {
            scenario,
            out,
            pixels,
        } => {
            let s = load(&scenario)?;
            let mut fig = Figure::of_world(&s.world, None, pixels)?;
            for r in &s.robots {
                fig.draw_robot(&r.start, r.vehicle);
            }
            let path = out.join(format!("{}.png", s.name));
            create_dir(&out)?;
            save_png(
                &fig.finish(&format!("{} - {}", s.name, s.description)),
                &path,
            )?;
            say!("wrote {}", path.display());
            Ok(())
        }
        Command::Scan {
            scenario,
            sensor,
            robot,
            pose,
            seed,
            out,
            pixels,
        } => scan_cmd::scan(
            &scenario,
            &sensor,
            robot.as_deref(),
            pose.as_deref(),
            seed,
            &out,
            pixels,
        ),
        Command::Run {
            scenario,
            out,
            robot,
            teleop,
            seed,
            duration,
            no_mcap,
            ros2_bag,
            pixels,
            maps,
            no_maps,
            map_pose,
            map_resolution,
            map_max_free_range,
            add_sensor,
            slam_sensor,
            max_memory,
            max_output,
        } => {
            let s = load(&scenario)?;
            let base = Path::new(&scenario)
                .exists()
                .then(|| Path::new(&scenario).parent().map(Path::to_owned))
                .flatten();
            let stop = run_cmd::stop_flag()?;
            let interrupted = run_cmd::run(&radarnav::run::RunRequest {
                scenario: &s,
                base: base.as_deref(),
                out: &out,
                robot: robot.as_deref(),
                teleop: teleop.as_deref(),
                seed,
                duration,
                mcap: !no_mcap,
                ros2_bag,
                pixels,
                maps: (!no_maps).then_some(maps.as_slice()),
                map_pose: radarnav::map::PoseSource::parse(&map_pose).with_context(|| {
                    format!("--map-pose `{map_pose}`: expected `truth`, `odometry` or `slam`")
                })?,
                map_resolution,
                map_max_free_range,
                add_sensors: &add_sensor,
                slam_sensor: slam_sensor.as_deref(),
                budget: radarnav::limits::budget::Budget::from_gb(max_memory, max_output),
                stop: &stop,
            })?;
            if interrupted {
                // 128 + SIGINT, as shells report a program ended by Ctrl-C.
                std::process::exit(130);
            }
            Ok(())
        }
        Command::Compare {
            scenario,
            strategies,
            sensors,
            seeds,
            seed,
            duration,
            safety,
            out,
        } => {
            let s = load(&scenario)?;
            compare_cmd::compare(&compare_cmd::CompareArgs {
                scenario: &s,
                strategies: &strategies,
                sensors: &sensors,
                seeds,
                seed,
                duration,
                safety,
                out: &out,
            })
        }
        Command::NavSuite {
            scenarios,
            seeds,
            algorithms,
            sensors,
            poses,
            out,
        } => nav_suite_cmd::nav_suite(
            &nav_suite_cmd::SuiteArgs {
                scenarios: &scenarios,
                seeds,
                algorithms: &algorithms,
                sensors: &sensors,
                poses: &poses,
                out: out.as_deref(),
            },
            load,
        ),
        Command::Sweep(SweepArgs {
            merge: Some(SweepMerge::Merge { dirs, out }),
            ..
        }) => sweep_cmd::merge(&dirs, &out),
        Command::Sweep(SweepArgs {
            spec, shard, out, ..
        }) => {
            let spec = spec.context("a sweep spec is needed")?;
            if sweep_cmd::run(&spec, shard, &out)? {
                std::process::exit(130);
            }
            Ok(())
        }
        Command::Bench {
            scenario,
            scans,
            forest,
            side,
            radius,
            plants,
            sim,
            export,
            poses,
            range,
            rays,
            repeats,
            json,
        } => {
            let forest = forest
                .map(|n| bench_cmd::forest_spec(n, side, &radius, plants))
                .transpose()?;
            if let Some(dir) = rays {
                return bench_cmd::trace_rays(&dir, repeats, json);
            }
            if let Some(dir) = export {
                return bench_cmd::export(&load(&scenario)?, forest.as_ref(), &dir, poses, range);
            }
            match (sim, forest) {
                (Some(_), Some(_)) => bail!("--sim and --forest do not go together"),
                (Some(seconds), None) => {
                    run_cmd::bench_sim(&load(&scenario)?, seconds, &*run_cmd::stop_flag()?)
                }
                (None, forest) => bench_cmd::scans(load(&scenario)?, scans, forest.as_ref()),
            }
        }
    }
}

/// A built-in scenario by name, or a TOML file by path.
fn load(arg: &str) -> Result<Scenario> {
    Ok(radarnav::scenario::load(arg)?)
}

/// Creates `dir` and its parents.
pub fn create_dir(dir: &Path) -> Result<()> {
    fs::create_dir_all(dir).with_context(|| format!("creating output directory {}", dir.display()))
}
