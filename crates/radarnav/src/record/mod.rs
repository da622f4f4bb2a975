//! Recording a run to a directory (DESIGN §8): `trajectory.csv`, `truth.tum`,
//! `odometry.tum`, one binary scan log per
//! sensor under `scans/`, `summary.json`, `path.png`, `run.mcap`, and for each map built
//! during the run (see [`Recorder::with_maps`]) `map_<name>.png`, `.pgm`, `.yaml` and `.npy`
//! (see [`crate::map::export`]) with its scores in `summary.json`. With
//! [`Recorder::with_radar_images`], each imaging radar's rotations go to
//! `radar/<sensor>/<µs>.png` (the Oxford Radar RobotCar layout) with `radar.timestamps`
//! and `detections.csv` (see [`radar_images`]). With [`RecordOptions::ros2_bag`], a rosbag2
//! directory `ros2_bag/` (see [`ros2`]).
//!
//! `truth.tum` and `odometry.tum` hold the same poses as TUM trajectories, and
//! `summary.json` the odometry's ATE and RPE against the truth (see [`crate::accuracy`]); a
//! robot that runs a localiser ([`crate::slam`]) adds `slam.tum` and the localiser's errors.
//!
//! `trajectory.csv` has one row per step:
//! `time,x,y,yaw_deg,odom_x,odom_y,odom_yaw_deg,v,omega_deg_s,left,right,bumped` — the true
//! pose and the odometry estimate at the start of the step, the command in force during it
//! (after the vehicle's limits; `left`/`right` are the track speeds) and whether its move was
//! refused by a collision (0/1) — and a last row with the state at the end of the run, where
//! no command follows (zeros).

#[cfg(feature = "mcap")]
pub mod frames;
#[cfg(feature = "mcap")]
pub mod mcap_log;
pub mod radar_images;
#[cfg(feature = "mcap")]
pub mod ros2;
pub mod scan_files;
pub mod scan_log;

pub use scan_log::{ScanLogError, ScanLogHeader, ScanLogWriter, read_scan_log};

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::DVec2;
use serde::Serialize;
use thiserror::Error;

use crate::accuracy::{Accuracy, Meter, write_tum_line};
use crate::map::{MapError, MapScores, Mapper, export, score_maps};
use crate::output::Staged;
use crate::pose::Pose;
use crate::render::{Figure, RenderError, save_png, world_region};
use crate::setup::{Robot, Scenario};
use crate::sim::{Observer, RunSummary, ScanEvent, Step};
use crate::vehicle::VehicleSpec;
use crate::world::World;

/// A recording that failed.
#[derive(Debug, Error)]
pub enum RecordError {
    /// A file could not be created or written.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        cause: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("MCAP: {0}")]
    Mcap(String),
    /// The MCAP writer's file could not be written (the recorder names the file).
    #[error("MCAP: {0}")]
    McapIo(std::io::Error),
    /// The path figure failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// A map could not be written.
    #[error(transparent)]
    Map(#[from] MapError),
}

/// Simulated seconds between two map messages in the MCAP recording, at least.
pub const GRID_PERIOD: f64 = 1.0;

/// Most bytes of map messages per [`GRID_PERIOD`] on average: larger maps are logged every
/// few periods, so however large the maps, they add about this much to the MCAP a simulated
/// second.
pub const GRID_BYTES_PER_PERIOD: usize = 1_000_000;

/// What to record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecordOptions {
    /// Write `run.mcap` (needs the `mcap` feature).
    pub mcap: bool,
    /// Write the rosbag2 directory `ros2_bag/` (needs the `mcap` feature).
    pub ros2_bag: bool,
    /// Write the binary scan logs.
    pub scans: bool,
    /// Longer side of `path.png`, pixels.
    pub pixels: u32,
}

impl Default for RecordOptions {
    fn default() -> Self {
        Self {
            mcap: cfg!(feature = "mcap"),
            ros2_bag: false,
            scans: true,
            pixels: 900,
        }
    }
}

/// The file names inside the output directory.
pub mod files {
    /// Per-step log.
    pub const TRAJECTORY: &str = "trajectory.csv";
    /// The true path, TUM format (`t x y z qx qy qz qw`), one pose per step.
    pub const TRUTH_TUM: &str = "truth.tum";
    /// The odometry's path, likewise.
    pub const ODOMETRY_TUM: &str = "odometry.tum";
    /// The localiser's path, TUM format, one pose per step (when the robot runs one).
    pub const SLAM_TUM: &str = "slam.tum";
    /// Run summary.
    pub const SUMMARY: &str = "summary.json";
    /// Top-down figure of the driven path.
    pub const PATH_PNG: &str = "path.png";
    /// The MCAP recording.
    pub const MCAP: &str = "run.mcap";
    /// Directory of the scan logs, one `<sensor>.rnscan` each.
    pub const SCANS: &str = "scans";
    /// Coverage of each map against distance (exploration runs).
    pub const COVERAGE: &str = "coverage.csv";
    /// Directory of the radar images, one `<sensor>/` each.
    pub const RADAR: &str = "radar";
    /// Per imaging sensor, one line "<µs> 1" per image (the Oxford dataset's index).
    pub const RADAR_TIMESTAMPS: &str = "radar.timestamps";
    /// Per imaging sensor, every image's detections.
    pub const RADAR_DETECTIONS: &str = "detections.csv";
}

type Out = BufWriter<File>;

/// A driven path thinned to a pose per centimetre or more, for figures and the MCAP path.
#[derive(Clone, Debug, Default)]
pub struct Trail(Vec<Pose>);

impl Trail {
    /// Adds `pose` if it is at least a centimetre from the last one kept.
    pub fn push(&mut self, pose: &Pose) {
        if self
            .0
            .last()
            .is_none_or(|l| l.xy().distance_squared(pose.xy()) >= 1e-4)
        {
            self.0.push(*pose);
        }
    }

    /// Adds `pose` whatever its distance (the end of a run).
    pub fn end(&mut self, pose: &Pose) {
        self.0.push(*pose);
    }

    /// The poses kept.
    pub fn poses(&self) -> &[Pose] {
        &self.0
    }

    /// Their positions in the plane.
    pub fn points(&self) -> Vec<DVec2> {
        self.0.iter().map(Pose::xy).collect()
    }
}

/// The true and believed paths of a run and where it bumped: an [`Observer`] that draws
/// them over the world (`path.png`, the trial figures).
#[derive(Clone, Debug, Default)]
pub struct PathTrace {
    /// True poses, one per centimetre driven or more.
    pub truth: Trail,
    /// Odometry poses, likewise.
    pub odometry: Trail,
    /// Where moves were refused (at most [`crate::sim::MAX_BUMP_EVENTS`]).
    pub bumps: Vec<DVec2>,
    /// A goal to mark (the trial figures), if any.
    pub goal: Option<DVec2>,
}

impl PathTrace {
    /// Closes both paths with the run's final poses.
    pub fn end(&mut self, summary: &RunSummary) {
        self.truth.end(&summary.final_pose);
        self.odometry.end(&summary.final_odometry);
    }

    /// The figure: `world`, the odometry and true paths, bumps, the goal when set, the robot
    /// at `start` and at the end, titled `title`, `pixels` on its longer side.
    pub fn figure(
        &self,
        world: &World,
        vehicle: &VehicleSpec,
        start: &Pose,
        title: &str,
        pixels: u32,
    ) -> Result<tiny_skia::Pixmap, RenderError> {
        let mut fig = Figure::of_world(world, None, pixels)?;
        fig.draw_path(
            &self.odometry.points(),
            [150, 150, 150],
            2.0,
            "path: odometry",
        );
        fig.draw_path(&self.truth.points(), [20, 120, 40], 3.0, "path: true");
        fig.draw_crosses(&self.bumps, [200, 0, 160], "bump");
        if let Some(goal) = self.goal {
            fig.draw_crosses(&[goal], [220, 30, 30], "goal");
        }
        fig.draw_robot(start, vehicle);
        if let Some(end) = self.truth.poses().last() {
            fig.draw_robot(end, vehicle);
        }
        Ok(fig.finish(title))
    }
}

impl Observer for PathTrace {
    type Error = std::convert::Infallible;

    fn on_step(&mut self, s: &Step) -> Result<(), Self::Error> {
        self.truth.push(&s.truth);
        self.odometry.push(&s.odometry);
        if s.bumped && self.bumps.len() < crate::sim::MAX_BUMP_EVENTS {
            self.bumps.push(s.truth.xy());
        }
        Ok(())
    }
}

/// The image files of one imaging sensor.
struct ImageFiles {
    sensor: usize,
    dir: PathBuf,
    timestamps: String,
    detections: Out,
}

/// Records a run: pass it to [`crate::sim::Simulation::run`], then call [`Recorder::finish`].
pub struct Recorder<'w> {
    dir: PathBuf,
    /// The growing files, under their temporary names until [`Recorder::finish`].
    staged: Staged,
    trajectory: Out,
    /// `truth.tum`, `odometry.tum` and, when the robot runs a localiser, `slam.tum`.
    tum: Vec<(Out, &'static str)>,
    /// The odometry's errors against the truth, step by step.
    odometry_errors: Meter,
    /// The localiser's (when the robot runs one).
    slam_errors: Option<Meter>,
    scan_logs: Vec<(PathBuf, ScanLogWriter<Out>)>,
    #[cfg(feature = "mcap")]
    mcap: Option<mcap_log::McapLog<Out>>,
    #[cfg(feature = "mcap")]
    bag: Option<ros2::Ros2Bag<Out>>,
    /// The paths (for the figure and the MCAP path).
    paths: PathTrace,
    vehicle: &'static VehicleSpec,
    written: Vec<PathBuf>,
    maps: Vec<Mapper>,
    /// Time of the next map message in the MCAP.
    #[cfg_attr(not(feature = "mcap"), allow(dead_code))]
    next_grid: f64,
    images: Option<(radar_images::RadarImager<'w>, Vec<ImageFiles>)>,
}

fn create(staged: &mut Staged, path: &Path) -> Result<Out, RecordError> {
    staged.create(path).map(BufWriter::new).map_err(io_at(path))
}

/// Writes `path` whole or not at all (see [`crate::output::write_whole`]).
pub fn write_whole(path: &Path, bytes: &[u8]) -> Result<(), RecordError> {
    crate::output::write_whole(path, bytes).map_err(io_at(path))
}

/// An MCAP error with its I/O cause tied to the MCAP file.
#[cfg(feature = "mcap")]
fn at_mcap(dir: &Path) -> impl FnOnce(RecordError) -> RecordError + '_ {
    move |e| at_file(&dir.join(files::MCAP))(e)
}

/// A bag error with its I/O cause tied to the bag's MCAP file (the path made only on error).
#[cfg(feature = "mcap")]
fn at_bag(dir: &Path) -> impl FnOnce(RecordError) -> RecordError + '_ {
    move |e| at_file(&bag_path(dir))(e)
}

/// An MCAP error with its I/O cause tied to the file at `path`.
#[cfg(feature = "mcap")]
fn at_file(path: &Path) -> impl FnOnce(RecordError) -> RecordError + '_ {
    move |e| match e {
        RecordError::McapIo(cause) => RecordError::Io {
            path: path.to_owned(),
            cause,
        },
        e => e,
    }
}

fn io_at(path: &Path) -> impl FnOnce(std::io::Error) -> RecordError + '_ {
    move |cause| RecordError::Io {
        path: path.to_owned(),
        cause,
    }
}

impl<'w> Recorder<'w> {
    /// Creates `dir` (and `dir/scans`) and opens every output file.
    pub fn create(
        dir: &Path,
        world: &World,
        robot: &Robot,
        options: RecordOptions,
    ) -> Result<Self, RecordError> {
        std::fs::create_dir_all(dir).map_err(io_at(dir))?;
        let mut staged = Staged::default();
        let tpath = dir.join(files::TRAJECTORY);
        let mut trajectory = create(&mut staged, &tpath)?;
        writeln!(
            trajectory,
            "time,x,y,yaw_deg,odom_x,odom_y,odom_yaw_deg,v,omega_deg_s,left,right,bumped"
        )
        .map_err(io_at(&tpath))?;
        let mut tum = Vec::new();
        for name in [files::TRUTH_TUM, files::ODOMETRY_TUM, files::SLAM_TUM] {
            if name != files::SLAM_TUM || robot.slam.is_some() {
                tum.push((create(&mut staged, &dir.join(name))?, name));
            }
        }
        let mut scan_logs = Vec::new();
        if options.scans && !robot.sensors.is_empty() {
            let sdir = dir.join(files::SCANS);
            std::fs::create_dir_all(&sdir).map_err(io_at(&sdir))?;
            for s in &robot.sensors {
                let path = sdir.join(format!("{}.rnscan", s.name));
                let w = ScanLogWriter::new(
                    create(&mut staged, &path)?,
                    &ScanLogHeader::new(s, world.materials()),
                )
                .map_err(io_at(&path))?;
                scan_logs.push((path, w));
            }
        }
        #[cfg(feature = "mcap")]
        let mcap = if options.mcap {
            let path = dir.join(files::MCAP);
            Some(
                mcap_log::McapLog::new(create(&mut staged, &path)?, world, robot)
                    .map_err(at_mcap(dir))?,
            )
        } else {
            None
        };
        #[cfg(feature = "mcap")]
        let bag = if options.ros2_bag {
            let bag_dir = dir.join(ros2::BAG_DIR);
            std::fs::create_dir_all(&bag_dir).map_err(io_at(&bag_dir))?;
            let path = bag_path(dir);
            Some(ros2::Ros2Bag::new(create(&mut staged, &path)?, robot).map_err(at_file(&path))?)
        } else {
            None
        };
        Ok(Self {
            dir: dir.to_owned(),
            staged,
            trajectory,
            tum,
            odometry_errors: Meter::default(),
            slam_errors: robot.slam.map(|_| Meter::default()),
            scan_logs,
            #[cfg(feature = "mcap")]
            mcap,
            #[cfg(feature = "mcap")]
            bag,
            paths: PathTrace::default(),
            vehicle: robot.vehicle,
            written: Vec::new(),
            maps: Vec::new(),
            next_grid: 0.0,
            images: None,
        })
    }

    /// Renders and writes the power images of the robot's imaging radars (none: nothing
    /// changes), their random draws seeded by `seed` on streams of their own.
    pub fn with_radar_images(
        mut self,
        world: &'w World,
        robot: &Robot,
        seed: u64,
    ) -> Result<Self, RecordError> {
        let Some(imager) = radar_images::RadarImager::new(world, robot, seed) else {
            return Ok(self);
        };
        let mut files = Vec::new();
        for sensor in imager.sensors() {
            let dir = self
                .dir
                .join(files::RADAR)
                .join(&robot.sensors[sensor].name);
            std::fs::create_dir_all(&dir).map_err(io_at(&dir))?;
            let path = dir.join(files::RADAR_DETECTIONS);
            let mut detections = create(&mut self.staged, &path)?;
            writeln!(
                detections,
                "stamp_us,row,azimuth_deg,bin,range_m,power,x,y,z"
            )
            .map_err(io_at(&path))?;
            files.push(ImageFiles {
                sensor,
                dir,
                timestamps: String::new(),
                detections,
            });
        }
        self.images = Some((imager, files));
        Ok(self)
    }

    /// Writes a finished rotation: its PNG, its line of `radar.timestamps`, its detections
    /// and its MCAP messages.
    fn write_sweep(&mut self, sweep: &radar_images::SweepImage) -> Result<(), RecordError> {
        let Some((_, files)) = &mut self.images else {
            return Ok(());
        };
        let Some(f) = files.iter_mut().find(|f| f.sensor == sweep.sensor) else {
            return Ok(());
        };
        let img = &sweep.image;
        let path = f.dir.join(img.file_name());
        let mut png = Vec::new();
        img.write_png(&mut png)
            .map_err(|e| io_at(&path)(std::io::Error::other(e)))?;
        write_whole(&path, &png)?;
        self.written.push(path);
        f.timestamps.push_str(&img.timestamps_line());
        let dpath = f.dir.join(files::RADAR_DETECTIONS);
        for (d, p) in &sweep.detections {
            writeln!(
                f.detections,
                "{},{},{:.4},{},{:.4},{},{:.4},{:.4},{:.4}",
                img.timestamps_us[d.row],
                d.row,
                d.azimuth.to_degrees(),
                d.bin,
                d.range,
                d.power,
                p.x,
                p.y,
                p.z
            )
            .map_err(io_at(&dpath))?;
        }
        #[cfg(feature = "mcap")]
        if let Some(m) = &mut self.mcap {
            m.radar_image(sweep, &png).map_err(at_mcap(&self.dir))?;
        }
        #[cfg(feature = "mcap")]
        if let Some(b) = &mut self.bag {
            b.radar_image(sweep).map_err(at_bag(&self.dir))?;
        }
        Ok(())
    }

    /// Builds these maps during the run (each a [`Mapper`] of the recorded robot); they are
    /// logged to the MCAP as they grow and written, with their scores, by
    /// [`Recorder::finish`].
    pub fn with_maps(mut self, maps: Vec<Mapper>) -> Result<Self, RecordError> {
        #[cfg(feature = "mcap")]
        if let Some(m) = &mut self.mcap {
            for map in &maps {
                m.add_map(map.name()).map_err(at_mcap(&self.dir))?;
            }
        }
        #[cfg(feature = "mcap")]
        if let Some(b) = &mut self.bag {
            for map in &maps {
                b.add_map(map.name()).map_err(at_bag(&self.dir))?;
            }
        }
        self.maps = maps;
        Ok(self)
    }

    /// The maps being built.
    pub fn maps(&self) -> &[Mapper] {
        &self.maps
    }

    /// Logs every map; returns the bytes of cell data written.
    #[cfg(feature = "mcap")]
    fn log_grids(&mut self, t: f64) -> Result<usize, RecordError> {
        let mut bytes = 0;
        if let Some(m) = &mut self.mcap {
            for (i, map) in self.maps.iter().enumerate() {
                bytes += m.grid(i, t, map.grid()).map_err(at_mcap(&self.dir))?;
            }
        }
        if let Some(b) = &mut self.bag {
            for (i, map) in self.maps.iter().enumerate() {
                b.grid(i, t, map.grid()).map_err(at_bag(&self.dir))?;
                bytes += map.grid().width() * map.grid().height();
            }
        }
        Ok(bytes)
    }

    /// Writes the summary, the path figure and the maps, closes every file and says what
    /// was written.
    pub fn finish(
        mut self,
        scenario: &Scenario,
        robot: &Robot,
        summary: &RunSummary,
        pixels: u32,
    ) -> Result<Recorded, RecordError> {
        // The state at the end: no step starts there, so no step logged it.
        self.log_step(&Step {
            time: summary.duration,
            truth: summary.final_pose,
            odometry: summary.final_odometry,
            slam: summary.slam.as_ref().map(|s| s.final_pose),
            command: crate::vehicle::Twist::default(),
            bumped: false,
        })?;
        let tpath = self.dir.join(files::TRAJECTORY);
        self.trajectory.flush().map_err(io_at(&tpath))?;
        for (out, name) in &mut self.tum {
            out.flush().map_err(io_at(&self.dir.join(name)))?;
        }
        #[cfg(feature = "mcap")]
        self.log_grids(summary.duration)?;
        for (path, log) in std::mem::take(&mut self.scan_logs) {
            log.finish().map_err(io_at(&path))?;
        }
        // Rotations still turning at the end are dropped (see `radar_images`).
        if let Some((_, files)) = self.images.take() {
            for mut f in files {
                let path = f.dir.join(files::RADAR_DETECTIONS);
                f.detections.flush().map_err(io_at(&path))?;
                let path = f.dir.join(files::RADAR_TIMESTAMPS);
                write_whole(&path, f.timestamps.as_bytes())?;
                self.written.push(path);
            }
        }
        // The last pose is not in the step log (steps log their start).
        self.paths.end(summary);
        #[cfg(feature = "mcap")]
        if let Some(m) = self.mcap.take() {
            let path = self.dir.join(files::MCAP);
            m.finish(summary.duration, self.paths.truth.poses())
                .map_err(at_mcap(&self.dir))?
                .flush()
                .map_err(io_at(&path))?;
        }
        #[cfg(feature = "mcap")]
        let bag_metadata = match self.bag.take() {
            Some(b) => {
                let path = bag_path(&self.dir);
                let (mut out, metadata) = b.finish().map_err(at_file(&path))?;
                out.flush().map_err(io_at(&path))?;
                Some(metadata)
            }
            None => None,
        };
        // Every growing file is complete: give each its name.
        let committed = self
            .staged
            .commit()
            .map_err(|(path, cause)| RecordError::Io { path, cause })?;
        self.written.extend(committed);
        #[cfg(feature = "mcap")]
        if let Some(metadata) = bag_metadata {
            // Last in the bag: rosbag2 takes a directory with this file as a whole bag.
            let path = self.dir.join(ros2::BAG_DIR).join(ros2::METADATA);
            write_whole(&path, metadata.as_bytes())?;
            self.written.push(path);
        }
        let png = self.dir.join(files::PATH_PNG);
        let fig = self.paths.figure(
            &scenario.world,
            robot.vehicle,
            &robot.start,
            &format!(
                "{} - {} drove {:.1} m in {:.1} s, {} bumps",
                scenario.name, robot.name, summary.distance, summary.duration, summary.bumps
            ),
            pixels,
        )?;
        save_png(&fig, &png)?;
        self.written.push(png);
        for m in &mut self.maps {
            m.finish_coverage(summary.duration);
        }
        if self.maps.iter().any(|m| !m.coverage().is_empty()) {
            let path = self.dir.join(files::COVERAGE);
            let mut csv = String::from("map,time,distance,free_coverage,hidden_coverage\n");
            let opt = |x: Option<f64>| x.map_or_else(String::new, |v| format!("{v:.5}"));
            for m in &self.maps {
                for c in m.coverage() {
                    csv.push_str(&format!(
                        "{},{:.3},{:.4},{},{}\n",
                        m.name(),
                        c.time,
                        c.distance,
                        opt(c.free),
                        opt(c.hidden)
                    ));
                }
            }
            write_whole(&path, csv.as_bytes())?;
            self.written.push(path);
        }
        let scores = score_maps(&scenario.world, robot.vehicle, &robot.start, &self.maps);
        let mut maps = Vec::new();
        for (m, scores) in self.maps.iter().zip(scores) {
            let hidden = scores.hidden_coverage.map_or_else(
                || "no hidden area".to_owned(),
                |c| format!("{:.0}% of the hidden area clear", 100.0 * c),
            );
            let title = format!(
                "{} - map `{}` ({} pose): {hidden}",
                scenario.name,
                m.name(),
                m.config().pose.as_str(),
            );
            let overlay = export::Overlay {
                path: &self.paths.truth.points(),
                robot: Some((robot.vehicle, robot.start, summary.final_pose)),
                region: Some(world_region(&scenario.world)),
                marks: None,
                estimates: &[],
            };
            let stem = format!("map_{}", m.name());
            self.written.extend(export::write_all(
                m.grid(),
                &self.dir,
                &stem,
                &title,
                pixels,
                &overlay,
            )?);
            maps.push(MapReport::new(m, stem, scores));
        }
        let odometry = self.odometry_errors.result();
        let slam = self.slam_errors.as_ref().and_then(Meter::result);
        let report = Report {
            scenario: &scenario.name,
            mission: scenario.mission.as_ref().map(|m| m.kind_name()),
            summary,
            accuracy: odometry.map(|odometry| AccuracyReport { odometry, slam }),
            maps,
        };
        let spath = self.dir.join(files::SUMMARY);
        let mut json = serde_json::to_string_pretty(&report)
            .map_err(|e| io_at(&spath)(std::io::Error::other(e)))?;
        json.push('\n');
        write_whole(&spath, json.as_bytes())?;
        self.written.push(spath);
        Ok(Recorded {
            files: self.written,
            odometry_errors: odometry,
            slam_errors: slam,
            maps: report
                .maps
                .iter()
                .map(|m| (m.name.to_owned(), m.scores))
                .collect(),
        })
    }
}

/// What [`Recorder::finish`] wrote.
#[derive(Clone, Debug)]
pub struct Recorded {
    /// Every file, in the order written.
    pub files: Vec<PathBuf>,
    /// The odometry's errors against the truth (`None`: no step).
    pub odometry_errors: Option<Accuracy>,
    /// The localiser's (`None`: no step, or no localiser).
    pub slam_errors: Option<Accuracy>,
    /// Each map's name and scores.
    pub maps: Vec<(String, MapScores)>,
}

#[derive(Serialize)]
struct Report<'a> {
    scenario: &'a str,
    mission: Option<&'a str>,
    #[serde(flatten)]
    summary: &'a RunSummary,
    #[serde(skip_serializing_if = "Option::is_none")]
    accuracy: Option<AccuracyReport>,
    maps: Vec<MapReport<'a>>,
}

/// The trajectory errors in `summary.json` (ATE and RPE, as `evo` computes them from the TUM
/// files).
#[derive(Serialize)]
struct AccuracyReport {
    odometry: Accuracy,
    #[serde(skip_serializing_if = "Option::is_none")]
    slam: Option<Accuracy>,
}

/// A map's entry in `summary.json`.
#[derive(Serialize)]
struct MapReport<'a> {
    name: &'a str,
    files: String,
    sensors: &'a [String],
    pose: &'static str,
    resolution: f64,
    scans: u64,
    columns: usize,
    rows: usize,
    origin: [f64; 2],
    #[serde(flatten)]
    scores: MapScores,
}

impl<'a> MapReport<'a> {
    fn new(m: &'a Mapper, stem: String, scores: MapScores) -> Self {
        let g = m.grid();
        Self {
            name: m.name(),
            files: format!("{stem}.{{png,pgm,yaml,npy}}"),
            sensors: m.sensor_names(),
            pose: m.config().pose.as_str(),
            resolution: g.resolution(),
            scans: m.scans(),
            columns: g.width(),
            rows: g.height(),
            origin: g.origin().to_array(),
            scores,
        }
    }
}

impl Observer for Recorder<'_> {
    type Error = RecordError;

    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), RecordError> {
        let (sensor, scan) = (event.sensor, event.scan);
        match self.maps.as_mut_slice().on_scan(event) {
            Ok(()) => {}
            Err(never) => match never {},
        }
        if let Some((path, log)) = self.scan_logs.get_mut(sensor) {
            log.write(scan).map_err(io_at(path))?;
        }
        #[cfg(feature = "mcap")]
        if let Some(m) = &mut self.mcap {
            m.scan(event).map_err(at_mcap(&self.dir))?;
        }
        #[cfg(feature = "mcap")]
        if let Some(b) = &mut self.bag {
            b.scan(event).map_err(at_bag(&self.dir))?;
        }
        if let Some((imager, _)) = &mut self.images {
            imager.on_scan(sensor, scan.stamp);
        }
        Ok(())
    }

    fn on_step(&mut self, s: &Step) -> Result<(), RecordError> {
        match self.maps.as_mut_slice().on_step(s) {
            Ok(()) => {}
            Err(never) => match never {},
        }
        #[cfg(feature = "mcap")]
        if s.time >= self.next_grid {
            let bytes = self.log_grids(s.time)?;
            let periods = bytes.div_ceil(GRID_BYTES_PER_PERIOD).max(1);
            self.next_grid += GRID_PERIOD * periods as f64;
        }
        self.log_step(s)?;
        let sweeps = match &mut self.images {
            Some((imager, _)) => imager.on_step(s),
            None => Vec::new(),
        };
        for sweep in &sweeps {
            self.write_sweep(sweep)?;
        }
        let Ok(()) = self.paths.on_step(s);
        Ok(())
    }
}

impl Recorder<'_> {
    /// Writes a step's row of `trajectory.csv` and its MCAP and bag messages.
    fn log_step(&mut self, s: &Step) -> Result<(), RecordError> {
        let (t, o) = (&s.truth, &s.odometry);
        let (left, right) = self.vehicle.tracks(s.command);
        // Straight into the buffered file: no string per step.
        writeln!(
            self.trajectory,
            "{:.3},{:.5},{:.5},{:.4},{:.5},{:.5},{:.4},{:.4},{:.3},{:.4},{:.4},{}",
            s.time,
            t.x,
            t.y,
            t.yaw.to_degrees(),
            o.x,
            o.y,
            o.yaw.to_degrees(),
            s.command.v,
            s.command.omega.to_degrees(),
            left,
            right,
            u8::from(s.bumped)
        )
        .map_err(|cause| RecordError::Io {
            path: self.dir.join(files::TRAJECTORY),
            cause,
        })?;
        // A localiser's estimate exists from the first step on; the odometry stands in for a
        // step that has none (a summary's end state of a run without one).
        let slam = s.slam.unwrap_or(*o);
        for ((out, name), pose) in self.tum.iter_mut().zip([t, o, &slam]) {
            write_tum_line(out, s.time, pose).map_err(io_at(&self.dir.join(*name)))?;
        }
        self.odometry_errors.push(t, o);
        if let Some(m) = &mut self.slam_errors {
            m.push(t, &slam);
        }
        #[cfg(feature = "mcap")]
        if let Some(m) = &mut self.mcap {
            m.step(s).map_err(at_mcap(&self.dir))?;
        }
        #[cfg(feature = "mcap")]
        if let Some(b) = &mut self.bag {
            b.step(s).map_err(at_bag(&self.dir))?;
        }
        Ok(())
    }
}

/// The bag's MCAP file in the output directory `dir`.
#[cfg(feature = "mcap")]
fn bag_path(dir: &Path) -> PathBuf {
    dir.join(ros2::BAG_DIR).join(ros2::BAG_FILE)
}
