//! The valid range of every numeric input (DESIGN §12), in one table.
//!
//! Scenario keys are checked against these while the file is read (an error names the file,
//! line, key and range), command-line flags while they are parsed, and `docs/limits.md` is
//! this table printed by [`markdown_table`] (a test keeps the two the same). The ranges keep
//! every run bounded: no input can make a step loop forever, a grid or image outgrow memory,
//! or a run write without end before the size estimates of [`budget`] refuse it.

pub mod budget;
pub mod smoke;

/// A closed range `min..=max` of one input, with its unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit {
    /// The key or flag as the user writes it.
    pub key: &'static str,
    /// Where it is written: a scenario table or a command.
    pub place: &'static str,
    /// Smallest valid value.
    pub min: f64,
    /// Largest valid value (`inf` where infinity means something, e.g. a solid's attenuation).
    pub max: f64,
    /// Unit, as printed after the numbers (empty for plain counts and ratios).
    pub unit: &'static str,
    /// Why the bounds are where they are.
    pub why: &'static str,
}

impl Limit {
    /// Whether `v` is in range (NaN never is).
    pub fn contains(&self, v: f64) -> bool {
        v >= self.min && v <= self.max
    }

    /// The range in words: "0.0001 to 1 s".
    pub fn range(&self) -> String {
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        format!("{} to {}{unit}", num(self.min), num(self.max))
    }

    /// `v`, or a message naming the range.
    pub fn check(&self, v: f64) -> Result<f64, String> {
        if self.contains(v) {
            Ok(v)
        } else {
            Err(format!("expected {}, found {}", self.range(), num(v)))
        }
    }

    /// A command-line value: parsed, then checked.
    pub fn parse(&self, s: &str) -> Result<f64, String> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("expected a number from {}, found `{s}`", self.range()))?;
        self.check(v)
    }

    /// A command-line count: parsed as an integer, then checked.
    pub fn parse_count(&self, s: &str) -> Result<u64, String> {
        let v: u64 = s
            .trim()
            .parse()
            .map_err(|_| format!("expected a whole number from {}, found `{s}`", self.range()))?;
        self.check(v as f64).map(|_| v)
    }
}

/// A number as people write it: `0.0001`, `1e6`, `inf`.
fn num(v: f64) -> String {
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    if v != 0.0 && (v.abs() >= 1e6 || v.abs() < 1e-4) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

macro_rules! limits {
    ($($(#[$doc:meta])* $name:ident = $key:literal in $place:literal: $min:expr, $max:expr, $unit:literal, $why:literal;)*) => {
        $($(#[$doc])* pub const $name: Limit = Limit {
            key: $key, place: $place, min: $min, max: $max, unit: $unit, why: $why,
        };)*
        /// Every limit, in the order of the documentation table.
        pub const ALL: &[Limit] = &[$($name),*];
    };
}

limits! {
    /// `[sim] dt`.
    DT = "dt" in "[sim]": 1e-4, 1.0, "s", "a step shorter than 0.1 ms only multiplies the output";
    /// `[sim] duration`, `--duration`.
    DURATION = "duration, --duration" in "[sim], run, compare": 1e-3, 1e6, "s", "11.6 days; the output estimate bounds it further";
    /// `--sim` of `bench`.
    BENCH_SIM = "--sim" in "bench": 1e-3, 1e6, "s", "as duration";
    /// `--speed` of `serve` and `ros2`: simulated seconds per wall-clock second.
    SERVE_SPEED = "--speed" in "serve, ros2": 0.01, 100.0, "x real time", "1: real time, as USARSim";
    /// Any coordinate: object centres, wall and prism points, start poses, goals, waypoints.
    COORD = "x, y, z, center, points, polygon, goal" in "object, robot, mission": -5e3, 5e3, "m", "a world at most 10 km across";
    /// Object sizes: sphere and cylinder radius, box size, wall thickness and height.
    SIZE = "radius, size, height, thickness" in "object": 1e-3, 1e4, "m", "1 mm to 10 km";
    /// Points of a wall polyline or a prism polygon.
    POINTS = "points, polygon (count)" in "object": 2.0, 1e4, "", "polygon needs 3";
    /// Scale of a mesh file's units to metres.
    MESH_SCALE = "mesh scale" in "object": 1e-4, 1e4, "", "0.1 mm to 10 km per file unit";
    /// Triangles of one mesh part, and of a whole glTF scene.
    MESH_TRIANGLES = "mesh triangles (count)" in "object": 1.0, 5e6, "", "per part and per glTF scene; about 200 bytes a triangle while it is built";
    /// Size of a mesh file (and of each `.bin` or `.mtl` it names).
    MESH_FILE = "mesh file (size)" in "object": 0.0, 256.0, "MiB", "read in whole; a glTF's buffers together too";
    /// Objects in a scenario.
    OBJECTS = "[[object]] (count)" in "scenario": 0.0, 1e6, "", "the ray-query benchmarks use 100 000";
    /// Any angle given in degrees as a heading.
    YAW = "yaw_deg" in "object, robot, mount": -3600.0, 3600.0, "deg", "ten turns either way";
    /// Sensor mount offsets on the robot.
    MOUNT = "mount x, y, z" in "robot.sensor": -10.0, 10.0, "m", "a sensor is on the robot, not 1e308 m away";
    /// One-way radar attenuation of a material.
    ATTENUATION = "radar_attenuation_db_per_m, laser_attenuation_db_per_m" in "material": 0.0, f64::INFINITY, "dB/m", "inf: a solid";
    /// Fraction of radar power reflected.
    REFLECTIVITY = "radar_reflectivity" in "material": 0.0, 1.0, "", "absorber to metal";
    /// Volume backscatter.
    BACKSCATTER = "radar_backscatter_per_m" in "material": 0.0, 10.0, "1/m", "";
    /// Aerosol extinction to a laser.
    EXTINCTION = "laser_extinction_per_m" in "material": 0.0, 100.0, "1/m", "mean free path 1 cm";
    /// Specular lobe width.
    LOBE = "specular_lobe_deg" in "material": 0.1, 90.0, "deg", "";
    /// Diffuse share of a specular echo.
    DIFFUSE = "radar_diffuse" in "material": 0.0, 1.0, "", "share of a specular echo scattered at any angle";
    /// Odometry speed noise.
    SPEED_NOISE = "speed_noise" in "robot.odometry": 0.0, 1.0, "", "relative standard deviation";
    /// Odometry yaw drift and noise.
    YAW_RATE_NOISE = "yaw_drift_deg_s, yaw_noise_deg_s" in "robot.odometry": -90.0, 90.0, "deg/s", "noise must be >= 0";
    /// Cell size of the localiser's finest likelihood level.
    SLAM_RESOLUTION = "resolution" in "robot.slam": 0.01, 1.0, "m", "Hector SLAM: 0.05";
    /// Farthest return the localiser registers.
    SLAM_RANGE = "max_range" in "robot.slam": 1.0, 1000.0, "m", "beyond the sensor's range it changes nothing";
    /// Field of view.
    FOV = "fov_deg" in "robot.sensor": 1e-3, 360.0, "deg", "";
    /// Angular step.
    RESOLUTION = "resolution_deg" in "robot.sensor": 1e-3, 360.0, "deg", "at most fov_deg; at most 4 000 000 rays a scan";
    /// Minimum and maximum range.
    RANGE = "range_min, range_max" in "robot.sensor": 0.0, 1e4, "m", "range_max > range_min";
    /// Scan rate.
    RATE = "rate_hz" in "robot.sensor": 1e-3, 1e3, "Hz", "1 kHz; the output estimate bounds rays x rate";
    /// Scan planes.
    ELEVATION = "elevations_deg" in "robot.sensor": -89.9, 89.9, "deg", "1 to 1024 planes";
    /// Absolute range noise.
    RANGE_NOISE = "range_noise_std" in "robot.sensor": 0.0, 100.0, "m", "";
    /// Relative range noise.
    RANGE_NOISE_REL = "range_noise_rel" in "robot.sensor": 0.0, 1.0, "", "";
    /// Penetration budget.
    PENETRATION = "penetration_db" in "robot.sensor": 1e-3, 1e3, "dB", "";
    /// Side-beam offset.
    SIDE_BEAM = "side_beam_offset" in "robot.sensor": 0.0, 10.0, "m", "";
    /// Range bin.
    RANGE_BIN = "range_bin" in "robot.sensor": 1e-3, 100.0, "m", "a power image has at most 65 536 bins and 1e8 pixels";
    /// Dynamic range.
    DYNAMIC_RANGE = "dynamic_range_db, display_range_db" in "robot.sensor": 1.0, 200.0, "dB", "";
    /// Detection threshold and noise floor.
    THRESHOLD = "detection_threshold_db, noise_floor_db" in "robot.sensor": -200.0, 0.0, "dB", "";
    /// Echoes per azimuth.
    ECHOES = "max_echoes" in "robot.sensor": 1.0, 64.0, "", "";
    /// Specular bounces.
    BOUNCES = "max_bounces" in "robot.sensor": 0.0, 8.0, "", "";
    /// Beam rays.
    BEAM_RAYS = "beam_rays, beam_rays_el" in "robot.sensor": 1.0, 64.0, "", "64 in all";
    /// Beam widths.
    BEAMWIDTH = "beamwidth_az_deg, beamwidth_el_deg" in "robot.sensor": 0.0, 28.6, "deg", "0.5 rad";
    /// Chirp bandwidth.
    BANDWIDTH = "bandwidth_hz" in "robot.sensor": 1e6, 1e11, "Hz", "";
    /// Cruise speed.
    SPEED = "speed" in "mission": 1e-3, 10.0, "m/s", "the vehicle's own limit applies after";
    /// Reach and loop tolerances.
    TOLERANCE = "tolerance, mline_tolerance, loop_tolerance" in "mission": 1e-3, 100.0, "m", "";
    /// Controller rate.
    CONTROLLER_HZ = "controller_hz" in "mission": 1e-2, 1e3, "Hz", "1 kHz, as sensors";
    /// Bumper distances.
    BUMPER = "safety, band, --safety" in "mission.bumpers, compare": 1e-2, 100.0, "m", "";
    /// Teleop step duration.
    TELEOP_DURATION = "duration (teleop step)" in "mission.commands, teleop CSV": 1e-3, 1e6, "s", "";
    /// Teleop speeds.
    TELEOP_SPEED = "v, left, right" in "mission.commands, teleop CSV": -10.0, 10.0, "m/s", "";
    /// Teleop turn rate.
    TELEOP_TURN = "omega_deg_s" in "mission.commands, teleop CSV": -3600.0, 3600.0, "deg/s", "";
    /// Waypoints and teleop commands.
    STEPS = "points, commands (count)" in "mission": 1.0, 1e5, "", "";
    /// Figure size.
    PIXELS = "--pixels" in "render, scan, run": 16.0, 8192.0, "px", "longer side of the map area";
    /// Map cell size.
    MAP_RESOLUTION = "--map-resolution" in "run": 5e-3, 10.0, "m", "the cell estimate bounds it further";
    /// Free-space reach of a ray with no return.
    MAP_FREE_RANGE = "--map-max-free-range" in "run": 0.0, 1e3, "m", "";
    /// Memory a run may plan for.
    MAX_MEMORY = "--max-memory" in "run": 0.01, 1024.0, "GB", "default 4 GB";
    /// Bytes a run may write.
    MAX_OUTPUT = "--max-output" in "run": 1e-3, 1e4, "GB", "default 10 GB";
    /// Seeds of a batch.
    SEEDS = "--seeds, seeds.count" in "compare, nav-suite, sweep spec": 1.0, 1e4, "", "";
    /// Runs of a sweep (scenarios x grid points x seeds).
    SWEEP_RUNS = "runs (count)" in "sweep spec": 1.0, 1e6, "", "cut it into shards; each shard file holds its rows";
    /// Shards of a sweep.
    SHARDS = "--shard i/N" in "sweep": 1.0, 1e5, "", "0 <= i < N";
    /// Extra scans of the demo.
    REPEATS = "--repeats" in "demo, bench": 0.0, 1e5, "", "";
    /// Scans of a benchmark.
    SCANS = "--scans" in "bench": 1.0, 1e6, "", "";
    /// Spheres of a benchmark forest.
    FOREST = "--forest" in "bench": 1.0, 1e7, "", "";
    /// Side of a benchmark forest, its sphere radii and the exported rays' length.
    FOREST_SIZE = "--side, --radius, --range" in "bench": 1e-2, 1e5, "m", "radius MIN < MAX";
    /// Poses of an exported benchmark scene.
    POSES = "--poses" in "bench": 1.0, 1e5, "", "";
    /// Input files.
    FILE_SIZE = "scenario, teleop CSV, scan log header" in "files": 0.0, 64.0, "MiB", "read with this limit; /dev/zero is refused";
}

/// Largest input file read, bytes ([`FILE_SIZE`]).
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// Reads a text file of at most [`MAX_FILE_BYTES`], without reading more than that from
/// a file that never ends (`/dev/zero`) or a pipe.
pub fn read_text(path: &std::path::Path) -> std::io::Result<String> {
    use std::io::Read;
    let file = std::fs::File::open(path)?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than the limit of {} MiB", MAX_FILE_BYTES >> 20),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8: {e}"))
    })
}

/// The table of `docs/limits.md`.
pub fn markdown_table() -> String {
    let mut s = String::from("| key or flag | where | valid range | note |\n|---|---|---|---|\n");
    for l in ALL {
        s.push_str(&format!(
            "| `{}` | {} | {} | {} |\n",
            l.key,
            l.place,
            l.range(),
            l.why
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_range_holds_its_ends_and_refuses_nan_and_outside() {
        assert!(DT.contains(1e-4) && DT.contains(1.0));
        assert!(!DT.contains(1e-9) && !DT.contains(f64::NAN) && !DT.contains(1.5));
        assert!(ATTENUATION.contains(f64::INFINITY));
        assert_eq!(
            DT.check(1e-9).unwrap_err(),
            "expected 0.0001 to 1 s, found 1e-9"
        );
        assert_eq!(
            DURATION.parse("1e9").unwrap_err(),
            "expected 0.001 to 1e6 s, found 1e9"
        );
        assert!(DURATION.parse("abc").unwrap_err().contains("`abc`"));
        assert_eq!(SEEDS.parse_count("3"), Ok(3));
        assert!(SEEDS.parse_count("0").is_err());
    }

    #[test]
    fn the_documentation_holds_this_table() {
        let doc = include_str!("../../../docs/limits.md");
        assert!(
            doc.contains(&markdown_table()),
            "docs/limits.md is out of date: print the table with `radarnav limits` and paste it"
        );
    }

    #[test]
    fn every_limit_is_ordered_and_keys_are_unique() {
        for (i, l) in ALL.iter().enumerate() {
            assert!(l.min <= l.max, "{}", l.key);
            assert!(ALL[..i].iter().all(|o| o.key != l.key), "{}", l.key);
        }
    }

    #[test]
    fn an_endless_file_is_refused_after_the_limit() {
        let e = read_text(std::path::Path::new("/dev/zero")).unwrap_err();
        assert!(e.to_string().contains("64 MiB"), "{e}");
    }
}
