//! One USARSim client's robot: the commands it takes and the messages it sends, apart from
//! any socket (the server in [`super::server`] moves the lines).
//!
//! Before `INIT` a client may ask for `GETSTARTPOSES`; `INIT` places a P3AT (by location or
//! by start tag) that then drives by `DRIVE`, answers `GETCONF` and `GETGEO`, resets its
//! odometer on `SET {Type Odometry} … {Opcode RESET}`, and streams `STA` and one `SEN` per
//! sensor scan, ground-truth and odometry report at their rates. A line that is not a command
//! gets an `ERR {Reason …}` reply (USARSim itself stays silent; a client reading only
//! the messages it knows is not disturbed by one more type).

use std::cell::Cell;
use std::rc::Rc;

use super::protocol::{
    Message, float_string, from_usar, parse_vector, usar_position, usar_yaw, vector_string,
};
use crate::mission::Remote;
use crate::pose::Pose;
use crate::sensor::{Scan, SensorConfig};
use crate::setup::{Robot, Scenario};
use crate::sim::{Observer, ScanEvent, Simulation};
use crate::vehicle::DriveCommand;

/// USARSim's class name of the one robot served.
pub const CLASS_NAME: &str = "USARBot.P3AT";
/// P3AT wheel joints' `MaxVelocity`, rad/s: `{Normalized true}` drives scale 100 to it.
pub const MAX_WHEEL_SPIN: f64 = 1.3;
/// Ground truth, odometry and status are sent every 0.1 s (USARSim's `ScanInterval` and
/// `StatusTimer`).
pub const REPORT_PERIOD: f64 = 0.1;
/// Name of the ground-truth sensor (the P3AT's in USARSim's default configuration).
pub const GROUND_TRUTH: &str = "GndTruth";
/// Name of the odometer.
pub const ODOMETER: &str = "Odometer";
/// Battery life reported in `STA`, s: radarnav's robots do not run down.
pub const BATTERY: u32 = 99_999;

/// A number as UnrealScript's `$` writes a float: two decimals.
fn ue(v: f64) -> String {
    let v = if v.is_finite() { v } else { 0.0 };
    // No "-0.00".
    let s = format!("{v:.2}");
    if s == "-0.00" { "0.00".into() } else { s }
}

/// An error reply.
pub fn error(reason: &str) -> String {
    format!(
        "ERR {{Reason {}}}",
        reason.replace(['{', '}', '\r', '\n'], " ")
    )
}

/// The greeting sent on connect.
pub fn greeting(scenario: &Scenario) -> String {
    format!(
        "NFO {{Gametype BotDeathMatch}} {{Level {}}} {{TimeLimit 0}}",
        scenario.name.replace(['{', '}', ' '], "_")
    )
}

/// `NFO {StartPoses N} {tag x,y,z r,p,y …}`: the scenario's robots' starts, named by robot.
pub fn start_poses(scenario: &Scenario) -> String {
    let mut out = format!("NFO {{StartPoses {}}}", scenario.robots.len());
    let poses: Vec<String> = scenario
        .robots
        .iter()
        .map(|r| {
            let [x, y, z] = usar_position(&r.start);
            format!(
                "{} {},{},{} {},{},{}",
                tag(&r.name),
                ue(x),
                ue(y),
                ue(z),
                ue(0.0),
                ue(0.0),
                ue(usar_yaw(r.start.yaw))
            )
        })
        .collect();
    if !poses.is_empty() {
        out.push_str(&format!(" {{{}}}", poses.join(" ")));
    }
    out
}

/// A robot name as a start tag: one word.
fn tag(name: &str) -> String {
    name.replace(|c: char| c.is_whitespace() || c == '{' || c == '}', "_")
}

/// What `INIT` asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct Init {
    /// The robot's name (`{Name}`, else the client's number).
    pub name: String,
    /// Where it starts, radarnav's frame.
    pub start: Pose,
}

/// Reads an `INIT`: `{ClassName USARBot.P3AT}` (or `P3AT`), `{Start tag}` or `{Location
/// x,y,z} [{Rotation r,p,y}]`; `Err` holds the error reply.
pub fn parse_init(m: &Message, scenario: &Scenario, fallback_name: &str) -> Result<Init, String> {
    let class = m.get("ClassName").unwrap_or(CLASS_NAME);
    let short = class.rsplit('.').next().unwrap_or(class);
    if !short.eq_ignore_ascii_case("P3AT") {
        return Err(error(&format!(
            "INIT: ClassName {class} is not served; this server has {CLASS_NAME}"
        )));
    }
    let name = m
        .get("Name")
        .filter(|n| !n.is_empty())
        .unwrap_or(fallback_name)
        .to_owned();
    let start = if let Some(t) = m.get("Start") {
        scenario
            .robots
            .iter()
            .find(|r| tag(&r.name).eq_ignore_ascii_case(t))
            .map(|r| r.start)
            .ok_or_else(|| {
                error(&format!(
                    "INIT: no start pose tagged {t} (see GETSTARTPOSES)"
                ))
            })?
    } else {
        let location = m
            .get("Location")
            .ok_or_else(|| error("INIT: give {Start tag} or {Location x,y,z}"))?;
        let location = parse_vector(location)
            .ok_or_else(|| error(&format!("INIT: Location `{location}` is not x,y,z")))?;
        let rotation = match m.get("Rotation") {
            Some(r) => parse_vector(r)
                .ok_or_else(|| error(&format!("INIT: Rotation `{r}` is not r,p,y")))?,
            None => [0.0; 3],
        };
        let limit = crate::limits::COORD.max;
        if location[..2].iter().any(|v| v.abs() > limit) {
            return Err(error(&format!(
                "INIT: Location outside the world's limit of {limit} m"
            )));
        }
        from_usar(location, rotation)
    };
    Ok(Init { name, start })
}

/// The client's drive command, shared with the simulation's controller.
type Command = Rc<Cell<DriveCommand>>;

/// Collects a `SEN` line per scan.
struct SenLines<'r> {
    robot: &'r Robot,
    time_offset: f64,
    lines: Vec<String>,
}

impl Observer for SenLines<'_> {
    type Error = std::convert::Infallible;

    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), Self::Error> {
        let sensor = &self.robot.sensors[event.sensor];
        self.lines.push(range_scanner(
            &sensor.name,
            &sensor.config,
            event.scan,
            self.time_offset + event.scan.stamp,
        ));
        Ok(())
    }
}

/// `SEN {Time t} {Type RangeScanner} {Name n} {Resolution r} {FOV f} {Range d1,…}`: the
/// plane nearest horizontal, floor(FOV/Res)+1 readings from right to left (the first at
/// FOV/2 clockwise), each truncated to 2 decimals; a ray without return reads the maximum range.
pub fn range_scanner(name: &str, config: &SensorConfig, scan: &Scan, time: f64) -> String {
    let (fov, res) = (config.fov, scan.angle_increment);
    let count = if res > 0.0 {
        (fov / res + 1e-9).floor() as usize + 1
    } else {
        1
    };
    let plane = config.horizontal_plane();
    let mut ranges = String::with_capacity(count * 6);
    for i in 0..count {
        // USARSim's reading i looks FOV/2 - i·Res clockwise: radarnav's -FOV/2 + i·Res.
        let az = -fov / 2.0 + i as f64 * res;
        let k = if scan.azimuths == 0 {
            None
        } else {
            let k = ((az - scan.angle_min) / res).round() as i64;
            Some(k.rem_euclid(scan.azimuths as i64) as usize)
        };
        let r = k
            .and_then(|k| scan.ranges.get(plane * scan.azimuths + k))
            .map(|&r| f64::from(r))
            .filter(|r| r.is_finite())
            .unwrap_or(scan.range_max);
        if i > 0 {
            ranges.push(',');
        }
        ranges.push_str(&float_string(r, 2));
    }
    format!(
        "SEN {{Time {}}} {{Type RangeScanner}} {{Name {name}}} {{Resolution {}}} {{FOV {}}} {{Range {ranges}}}",
        ue(time),
        float_string(res, 4),
        float_string(fov, 4),
    )
}

/// A client's robot in the simulation.
pub struct Driving<'a> {
    robot: &'a Robot,
    sim: Simulation<'a>,
    command: Command,
    /// `{Normalized true}` was the last `Normalized` given.
    normalized: bool,
    /// The odometry estimate at the last reset: the odometer reports relative to it.
    odometry_origin: Pose,
    /// Server time at the robot's start, s: message times are server times.
    time_offset: f64,
    next_report: f64,
}

impl<'a> Driving<'a> {
    /// Starts `robot` (its `start` set by `INIT`) in `world` at server time `time_offset`;
    /// `Err` holds the error reply (a start inside an obstacle).
    pub fn new(
        world: &'a crate::World,
        robot: &'a Robot,
        dt: f64,
        seed: u64,
        time_offset: f64,
    ) -> Result<Self, String> {
        let remote = Remote::new(1.0 / dt);
        let command = remote.command();
        let settings = crate::sim::RunSettings {
            dt,
            duration: crate::limits::DURATION.max,
            seed,
        };
        let sim = Simulation::new(world, robot, Box::new(remote), settings)
            .map_err(|e| error(&format!("INIT: {e}")))?;
        let odometry_origin = sim.odometry().pose;
        Ok(Self {
            robot,
            sim,
            command,
            normalized: false,
            odometry_origin,
            time_offset,
            next_report: 0.0,
        })
    }

    /// Simulation time of the robot, s (0 at `INIT`).
    pub fn time(&self) -> f64 {
        self.sim.time()
    }

    /// Server time at the robot's start, s.
    pub fn start_time(&self) -> f64 {
        self.time_offset
    }

    /// The true pose.
    pub fn truth(&self) -> Pose {
        self.sim.truth()
    }

    /// Takes a command of a robot that is driving; returns the replies.
    pub fn handle(&mut self, m: &Message) -> Vec<String> {
        if m.is("DRIVE") {
            return self.drive(m).err().into_iter().collect();
        }
        if m.is("GETCONF") {
            return self.conf(m).into_iter().collect();
        }
        if m.is("GETGEO") {
            return self.geo(m).into_iter().collect();
        }
        if m.is("SET") {
            return self.set(m).err().into_iter().collect();
        }
        if m.is("INIT") {
            return vec![error("INIT: this connection has its robot already")];
        }
        if m.is("GETSTARTPOSES") {
            return Vec::new(); // answered by the server, which has the scenario
        }
        vec![error(&format!("unknown command {}", m.kind))]
    }

    fn drive(&mut self, m: &Message) -> Result<(), String> {
        if let Some(n) = m.get("Normalized") {
            self.normalized = n.eq_ignore_ascii_case("true");
        }
        // USARSim drives only when both sides are given.
        let (Some(l), Some(r)) = (m.get("Left"), m.get("Right")) else {
            return Ok(());
        };
        let number = |key: &str, text: &str| {
            text.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| error(&format!("DRIVE: {key} `{text}` is not a number")))
        };
        let (mut left, mut right) = (number("Left", l)?, number("Right", r)?);
        if self.normalized {
            left = left.clamp(-100.0, 100.0) * MAX_WHEEL_SPIN / 100.0;
            right = right.clamp(-100.0, 100.0) * MAX_WHEEL_SPIN / 100.0;
        }
        // Wheel spin in rad/s; the vehicle's limits apply in the step.
        self.command
            .set(DriveCommand::usarsim_drive(left, right, self.robot.vehicle));
        Ok(())
    }

    fn set(&mut self, m: &Message) -> Result<(), String> {
        let kind = m.get("Type").unwrap_or_default();
        let name = m.get("Name").unwrap_or_default();
        let opcode = m.get("Opcode").unwrap_or_default();
        let odometer = kind.eq_ignore_ascii_case("Odometry")
            && (name.is_empty() || name.eq_ignore_ascii_case(ODOMETER));
        if odometer && opcode.eq_ignore_ascii_case("RESET") {
            self.odometry_origin = self.sim.odometry().pose;
            return Ok(());
        }
        Err(error(&format!(
            "SET: nothing of Type {kind} Name {name} takes Opcode {opcode}"
        )))
    }

    /// `CONF` of `{Type Robot}`, `RangeScanner`, `GroundTruth` or `Odometry` (`{Name}` picks
    /// one); nothing for other types, as USARSim.
    fn conf(&self, m: &Message) -> Option<String> {
        let kind = m.get("Type").unwrap_or("Robot");
        let name = m.get("Name").unwrap_or_default();
        if kind == "Robot" {
            return Some(format!(
                "CONF {{Name {CLASS_NAME}}} {{Type GroundVehicle}} {{SteeringType SkidSteered}} \
                 {{Mass {}}} {{MaxSpeed {}}} {{MaxTorque {}}} {{MaxFrontSteer 0}} {{MaxRearSteer 0}}",
                float_string(P3AT_MASS, 4),
                float_string(MAX_WHEEL_SPIN, 4),
                float_string(P3AT_MAX_TORQUE, 4),
            ));
        }
        let parts = self.parts(kind, name, |s| {
            let c = &s.config;
            format!(
                "{{Name {}}} {{MaxRange {}}} {{MinRange {}}} {{Resolution {}}} {{Fov {}}} \
                 {{Panning False}} {{Tilting False}}",
                s.name,
                float_string(c.range_max, 4),
                float_string(c.range_min, 4),
                float_string(c.resolution, 4),
                float_string(c.fov, 4),
            )
        });
        let extra = |n: &str| format!("{{Name {n}}} {{ScanInterval {}}}", ue(REPORT_PERIOD));
        let parts = match kind {
            "GroundTruth" if name.is_empty() || name == GROUND_TRUTH => vec![extra(GROUND_TRUTH)],
            "Odometry" if name.is_empty() || name == ODOMETER => vec![extra(ODOMETER)],
            _ => parts,
        };
        (!parts.is_empty()).then(|| format!("CONF {{Type {kind}}} {}", parts.join(" ")))
    }

    /// `GEO` of `{Type Robot}` or `RangeScanner` (`{Name}` picks one).
    fn geo(&self, m: &Message) -> Option<String> {
        let kind = m.get("Type").unwrap_or("Robot");
        let name = m.get("Name").unwrap_or_default();
        let v = self.robot.vehicle;
        if kind == "Robot" {
            return Some(format!(
                "GEO {{Type GroundVehicle}} {{Name {CLASS_NAME}}} {{Dimensions {}}} {{COG {}}} \
                 {{WheelRadius {}}} {{WheelSeparation {}}} {{WheelBase {}}}",
                vector_string([v.wheel_base, v.wheel_separation, 0.0], 4),
                vector_string([0.0; 3], 4),
                float_string(v.wheel_radius, 4),
                float_string(v.wheel_separation, 4),
                float_string(v.wheel_base, 4),
            ));
        }
        let parts = self.parts(kind, name, |s| {
            let [x, y, z] = usar_position(&s.mount);
            format!(
                "{{Name {}}} {{Location {},{},{}}} {{Orientation {},{},{}}}{{Mount {CLASS_NAME}}}",
                s.name,
                ue(x),
                ue(y),
                ue(z),
                ue(0.0),
                ue(0.0),
                ue(usar_yaw(s.mount.yaw)),
            )
        });
        (!parts.is_empty()).then(|| format!("GEO {{Type {kind}}} {}", parts.join(" ")))
    }

    /// The range scanners (every sensor) of type `kind` named `name` (any if empty).
    fn parts(
        &self,
        kind: &str,
        name: &str,
        f: impl Fn(&crate::setup::MountedSensor) -> String,
    ) -> Vec<String> {
        if kind != "RangeScanner" {
            return Vec::new();
        }
        self.robot
            .sensors
            .iter()
            .filter(|s| name.is_empty() || s.name == name)
            .map(f)
            .collect()
    }

    /// Advances one step; returns the messages it produced (`SEN` per scan, and `STA`,
    /// ground truth and odometry when due). Empty once the simulation has ended.
    pub fn step(&mut self) -> Vec<String> {
        let mut sen = SenLines {
            robot: self.robot,
            time_offset: self.time_offset,
            lines: Vec::new(),
        };
        let report = self.sim.time() + 1e-9 >= self.next_report;
        let t = self.time_offset + self.sim.time();
        let mut lines = Vec::new();
        if report {
            self.next_report += REPORT_PERIOD;
            lines.push(format!(
                "STA {{Time {}}} {{Battery {BATTERY}}} {{Type GroundVehicle}} {{LightToggle False}} \
                 {{LightIntensity 100}} {{FrontSteer 0}} {{RearSteer 0}}",
                ue(t)
            ));
            let truth = self.sim.truth();
            lines.push(format!(
                "SEN {{Time {}}} {{Type GroundTruth}} {{Name {GROUND_TRUTH}}} {{Location {}}} {{Orientation {}}}",
                ue(t),
                vector_string(usar_position(&truth), 3),
                vector_string([0.0, 0.0, usar_yaw(truth.yaw)], 3),
            ));
            let rel = self
                .odometry_origin
                .inverse()
                .compose(&self.sim.odometry().pose);
            lines.push(format!(
                "SEN {{Time {}}} {{Type Odometry}} {{Name {ODOMETER}}} {{Pose {},{},{}}}",
                ue(t),
                ue(rel.x),
                ue(-rel.y),
                ue(-rel.yaw),
            ));
        }
        match self.sim.step(&mut sen) {
            Ok(_) => {}
            Err(never) => match never {},
        }
        lines.extend(sen.lines);
        lines
    }

    /// Whether the simulation has run its longest time.
    pub fn done(&self) -> bool {
        self.sim.done()
    }
}

/// P3AT mass reported in `CONF`, kg (Adept MobileRobots datasheet: 12 kg).
const P3AT_MASS: f64 = 12.0;
/// P3AT wheel torque reported in `CONF` (USARSim's default when no joint limits it).
const P3AT_MAX_TORQUE: f64 = 50_000.0;

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario() -> Scenario {
        Scenario::builtin("foliage-wall").expect("built-in")
    }

    #[test]
    fn init_by_location_and_by_start_tag() {
        let s = scenario();
        let m = Message::parse(
            "INIT {ClassName USARBot.P3AT} {Name R1} {Location 4,-2,0} {Rotation 0,0,1.25}",
        )
        .unwrap();
        let init = parse_init(&m, &s, "robot1").unwrap();
        assert_eq!(init.name, "R1");
        assert!((init.start.x - 4.0).abs() < 1e-12 && (init.start.y - 2.0).abs() < 1e-12);
        assert!((init.start.yaw + 1.25).abs() < 1e-12);
        let tagged = format!(
            "INIT {{ClassName USARBot.P3AT}} {{Start {}}}",
            s.robots[0].name
        );
        let init = parse_init(&Message::parse(&tagged).unwrap(), &s, "robot1").unwrap();
        assert_eq!(
            (init.name.as_str(), init.start),
            ("robot1", s.robots[0].start)
        );
        for bad in [
            "INIT {ClassName USARBot.Kenaf} {Location 0,0,0}",
            "INIT {ClassName USARBot.P3AT}",
            "INIT {ClassName USARBot.P3AT} {Location 1,2}",
            "INIT {ClassName USARBot.P3AT} {Start nowhere}",
            "INIT {ClassName USARBot.P3AT} {Location 1e9,0,0}",
        ] {
            let e = parse_init(&Message::parse(bad).unwrap(), &s, "r").unwrap_err();
            assert!(e.starts_with("ERR {Reason INIT: "), "{bad}: {e}");
        }
    }

    #[test]
    fn start_poses_list_every_robot_in_usarsims_frame() {
        let s = scenario();
        let line = start_poses(&s);
        let r = &s.robots[0];
        assert!(line.starts_with(&format!(
            "NFO {{StartPoses {}}} {{{} ",
            s.robots.len(),
            r.name
        )));
        // The poses' brace holds `tag x,y,z r,p,y` per start: its first word is the first tag.
        let m = Message::parse(&line).unwrap();
        assert_eq!(m.get("StartPoses"), Some("1"));
        let (tag, pose) = &m.args[1];
        assert_eq!(tag, &r.name);
        let words: Vec<&str> = pose.split_whitespace().collect();
        let xyz = parse_vector(words[0]).unwrap();
        assert_eq!(
            parse_vector(words[1]).unwrap()[2],
            (usar_yaw(r.start.yaw) * 100.0).round() / 100.0
        );
        assert!((xyz[0] - r.start.x).abs() < 0.01 && (xyz[1] + r.start.y).abs() < 0.01);
    }

    #[test]
    fn a_range_scanner_reads_right_to_left_with_truncated_ranges() {
        let s = scenario();
        let robot = &s.robots[0];
        let laser = robot.sensor("laser").unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        use rand::SeedableRng;
        let pose = robot.start.compose(&laser.mount);
        let scan = laser.config.scan(
            &s.world,
            &pose,
            0.0,
            &mut rng,
            &mut crate::sensor::Tracer::default(),
        );
        let line = range_scanner("laser", &laser.config, &scan, 1.25);
        let m = Message::parse(&line).unwrap();
        assert_eq!(m.get("Time"), Some("1.25"));
        assert_eq!(m.get("Type"), Some("RangeScanner"));
        let ranges: Vec<&str> = m.get("Range").unwrap().split(',').collect();
        let (fov, res) = (laser.config.fov, laser.config.resolution);
        assert_eq!(ranges.len(), (fov / res + 1e-9).floor() as usize + 1);
        assert!(
            ranges
                .iter()
                .all(|r| r.split('.').nth(1).is_some_and(|d| d.len() == 2))
        );
        // First reading: the rightmost ray (radarnav's first), truncated.
        let first = scan.ranges[0];
        let want = if first.is_finite() {
            f64::from(first)
        } else {
            scan.range_max
        };
        assert_eq!(ranges[0], float_string(want, 2));
        let last = scan.ranges[scan.azimuths - 1];
        let want = if last.is_finite() {
            f64::from(last)
        } else {
            scan.range_max
        };
        assert_eq!(*ranges.last().unwrap(), float_string(want, 2));
        assert_eq!(m.get("FOV"), Some(float_string(fov, 4).as_str()));
    }

    #[test]
    fn drive_turns_wheel_spin_into_track_speed_and_odometry_resets() {
        let s = scenario();
        let mut robot = s.robots[0].clone();
        robot.start = Pose::new(5.0, 2.0, 0.0, 0.0);
        let mut d = Driving::new(&s.world, &robot, s.sim.dt, 1, 0.0).unwrap();
        // Right faster than left: a left (counter-clockwise) turn while driving forward.
        assert!(
            d.handle(&Message::parse("DRIVE {Left 1.0} {Right 1.2}").unwrap())
                .is_empty()
        );
        let mut lines = Vec::new();
        for _ in 0..40 {
            lines.extend(d.step());
        }
        let p = d.truth();
        assert!(p.x > 5.05 && p.yaw > 0.0, "{p:?}");
        let odo = lines
            .iter()
            .rev()
            .find(|l| l.contains("{Type Odometry}"))
            .unwrap();
        let pose = parse_vector(Message::parse(odo).unwrap().get("Pose").unwrap()).unwrap();
        // USARSim's odometer: y to the right and yaw clockwise, so a left turn is negative.
        assert!(pose[0] > 0.05 && pose[2] < 0.0, "{odo}");
        assert!(lines.iter().any(|l| l.starts_with("STA {Time ")));
        assert!(
            lines
                .iter()
                .any(|l| l.contains("{Type RangeScanner} {Name laser}"))
        );
        assert!(
            d.handle(
                &Message::parse("SET {Type Odometry} {Name Odometer} {Opcode RESET}").unwrap()
            )
            .is_empty()
        );
        let after = d.step();
        let odo = after.iter().find(|l| l.contains("{Type Odometry}"));
        // The reset takes effect at the next report.
        let odo = odo.cloned().unwrap_or_else(|| {
            (0..3)
                .flat_map(|_| d.step())
                .find(|l| l.contains("{Type Odometry}"))
                .unwrap()
        });
        let pose = parse_vector(Message::parse(&odo).unwrap().get("Pose").unwrap()).unwrap();
        assert!(pose[0].abs() < 0.05 && pose[1].abs() < 0.05, "{odo}");
        // Normalized: 100 is the wheels' top spin, 1.3 rad/s, which stays in force.
        d.handle(&Message::parse("DRIVE {Left 100} {Right 100} {Normalized true}").unwrap());
        assert_eq!(
            d.command.get(),
            DriveCommand::usarsim_drive(1.3, 1.3, robot.vehicle)
        );
        d.handle(&Message::parse("DRIVE {Left -50} {Right 50}").unwrap());
        assert_eq!(
            d.command.get(),
            DriveCommand::usarsim_drive(-0.65, 0.65, robot.vehicle)
        );
        for bad in [
            "DRIVE {Left x} {Right 1}",
            "SET {Type Camera} {Opcode Zoom}",
            "FLY {To moon}",
        ] {
            let r = d.handle(&Message::parse(bad).unwrap());
            assert!(
                r.len() == 1 && r[0].starts_with("ERR {Reason "),
                "{bad}: {r:?}"
            );
        }
        assert!(
            d.conf(&Message::parse("GETCONF {Type RangeScanner} {Name radar}").unwrap())
                .unwrap()
                .starts_with("CONF {Type RangeScanner} {Name radar} {MaxRange ")
        );
        assert!(
            d.geo(&Message::parse("GETGEO {Type Robot}").unwrap())
                .unwrap()
                .contains("{WheelRadius 0.0980}")
        );
        assert_eq!(
            d.geo(&Message::parse("GETGEO {Type Camera}").unwrap()),
            None
        );
    }
}
