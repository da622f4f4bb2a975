use super::*;
use crate::mission::{TeleopStep, WaypointMission};
use crate::nav::{Idle, TeleopController, WaypointController};
use crate::vehicle::OdometryNoise;
use glam::DVec2;
use proptest::prelude::*;

/// A 10 × 10 m walled room with a wooden box, a foliage bush and a smoke cloud.
const ROOM: &str = r#"
[sim]
dt = 0.05
duration = 10.0
seed = 7

[[object]]
name = "room"
material = "concrete"
wall = { points = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], thickness = 0.2, height = 2 }

[[object]]
name = "crate"
material = "wood"
box = { center = [7.0, 2.0], size = [1.0, 1.0, 1.0], yaw_deg = 30 }

[[object]]
name = "bush"
material = "foliage_dense"
sphere = { center = [3.0, 7.0], radius = 0.8 }

[[object]]
name = "cloud"
material = "smoke"
sphere = { center = [7.0, 7.0, 1.0], radius = 1.2 }

[[robot]]
name = "bot"
start = { x = 2.0, y = 2.0, yaw_deg = 0 }
odometry = { speed_noise = 0.0, yaw_drift_deg_s = 0.0, yaw_noise_deg_s = 0.0 }

[[robot.sensor]]
name = "radar"
preset = "radar_thesis"

[[robot.sensor]]
name = "laser"
preset = "hokuyo_utm30lx"

[[robot.sensor]]
name = "odd"
preset = "hokuyo_urg04lx"
rate_hz = 7.0
"#;

fn room() -> Scenario {
    Scenario::from_toml(ROOM, "room.toml", "room").unwrap()
}

fn teleop(steps: &[(f64, f64, f64)]) -> Box<dyn Controller> {
    Box::new(TeleopController::new(
        steps
            .iter()
            .map(|&(duration, v, w)| TeleopStep {
                duration,
                command: DriveCommand::twist(v, w),
            })
            .collect(),
        10.0,
    ))
}

fn settings(s: &Scenario, duration: f64) -> RunSettings {
    RunSettings {
        duration,
        ..RunSettings::of(s)
    }
}

#[derive(Default)]
struct Log {
    scans: Vec<(usize, f64, Pose)>,
    /// (truth, odometry) of the robot at each scan.
    odometry: Vec<(Pose, Pose)>,
    steps: Vec<Step>,
    /// Every scan, whole, with its sensor.
    taken: Vec<(usize, Scan)>,
}

impl Observer for Log {
    type Error = std::convert::Infallible;
    fn on_scan(&mut self, e: &ScanEvent<'_>) -> Result<(), Self::Error> {
        self.scans.push((e.sensor, e.scan.stamp, e.scan.pose));
        self.odometry.push((e.truth, e.odometry));
        self.taken.push((e.sensor, e.scan.clone()));
        Ok(())
    }
    fn on_step(&mut self, s: &Step) -> Result<(), Self::Error> {
        self.steps.push(*s);
        Ok(())
    }
}

#[test]
fn sensor_rates_are_honoured() {
    let s = room();
    let robot = &s.robots[0];
    let mut sim = Simulation::new(
        &s.world,
        robot,
        teleop(&[(10.0, 0.3, 0.2)]),
        settings(&s, 10.0),
    )
    .unwrap();
    let mut log = Log::default();
    let summary = sim.run(&mut log).unwrap();
    let counts: Vec<u64> = summary.sensors.iter().map(|c| c.scans).collect();
    // 4 Hz, 40 Hz (faster than the 20 Hz step) and 7 Hz (not a multiple of it) over 10 s.
    assert_eq!(counts, vec![40, 400, 70]);
    for (i, rate) in [(0usize, 4.0), (1, 40.0), (2, 7.0)] {
        let stamps: Vec<f64> = log.scans.iter().filter(|x| x.0 == i).map(|x| x.1).collect();
        for (k, t) in stamps.iter().enumerate() {
            assert_eq!(*t, k as f64 / rate, "sensor {i} scan {k}");
        }
    }
    // Scans are delivered in time order.
    assert!(log.scans.windows(2).all(|w| w[0].1 <= w[1].1));
    // A scan inside a step is taken on the arc: the 40 Hz scan at 0.025 s sits between the
    // poses at 0 and 0.05 s, at the exact pose of the arc.
    let mid = log.scans.iter().find(|x| x.0 == 1 && x.1 == 0.025).unwrap();
    let cmd = robot.vehicle.limit(DriveCommand::twist(0.3, 0.2));
    let expect = integrate(&robot.start, cmd, 0.025).compose(&robot.sensors[1].mount);
    assert!((mid.2.x - expect.x).abs() < 1e-12 && (mid.2.yaw - expect.yaw).abs() < 1e-12);
    // Each event carries the robot pose at the scan's time; the room's odometry is noiseless,
    // so its estimate is the truth there too.
    for ((i, _, pose), (truth, odo)) in log.scans.iter().zip(&log.odometry) {
        let p = truth.compose(&robot.sensors[*i].mount);
        assert!((p.x - pose.x).abs() < 1e-12 && (p.y - pose.y).abs() < 1e-12);
        assert!((odo.x - truth.x).abs() < 1e-9 && (odo.yaw - truth.yaw).abs() < 1e-9);
    }
}

#[test]
fn teleop_plays_its_slots() {
    let s = room();
    let mut sim = Simulation::new(
        &s.world,
        &s.robots[0],
        teleop(&[(2.0, 0.5, 0.0), (1.0, 0.0, 0.5)]),
        settings(&s, 10.0),
    )
    .unwrap();
    let summary = sim.run(&mut NoObserver).unwrap();
    assert_eq!(summary.outcome, RunOutcome::Completed);
    assert!((summary.duration - 3.0).abs() < 1e-9);
    // 2 s at 0.5 m/s along +x, then 1 s turning in place at 0.5 rad/s.
    assert!((summary.final_pose.x - 3.0).abs() < 1e-9);
    assert!((summary.final_pose.y - 2.0).abs() < 1e-9);
    assert!((summary.final_pose.yaw - 0.5).abs() < 1e-9);
    assert!((summary.distance - 1.0).abs() < 1e-9);
    assert_eq!(summary.bumps, 0);
    // Noiseless odometry follows the truth exactly.
    assert!(summary.odometry_error < 1e-12);
}

#[test]
fn walls_and_foliage_stop_the_robot_smoke_does_not() {
    let s = room();
    let robot = &s.robots[0];
    let drive_from = |start: Pose, secs: f64| {
        let r = Robot {
            start,
            ..robot.clone()
        };
        let mut sim = Simulation::new(
            &s.world,
            &r,
            teleop(&[(secs, 0.7, 0.0)]),
            settings(&s, 20.0),
        )
        .unwrap();
        sim.run(&mut NoObserver).unwrap()
    };
    // Into the crate at (7, 2): stops with its front face short of the crate's corner.
    let a = drive_from(Pose::new(2.0, 2.0, 0.0, 0.0), 12.0);
    assert!(a.bumps > 0 && a.bump_events[0].object == "crate");
    assert!(
        a.final_pose.x < 7.0 - 0.5 && a.final_pose.x > 5.5,
        "{:?}",
        a.final_pose
    );
    // Into the foliage bush at (3, 7).
    let b = drive_from(Pose::new(0.8, 7.0, 0.0, 0.0), 5.0);
    assert!(b.bumps > 0 && b.bump_events[0].object == "bush");
    assert!(b.final_pose.x < 3.0 - 0.25);
    // Through the smoke cloud at (7, 7) and on to the room wall.
    let c = drive_from(Pose::new(4.5, 7.0, 0.0, 0.0), 7.0);
    assert!(c.final_pose.x > 9.0, "{:?}", c.final_pose);
    assert!(c.bump_events.iter().all(|e| e.object == "room"));
}

#[test]
fn start_inside_an_obstacle_is_an_error() {
    let s = room();
    let r = Robot {
        start: Pose::new(7.0, 2.0, 0.0, 0.0),
        ..s.robots[0].clone()
    };
    let e = Simulation::new(&s.world, &r, teleop(&[(1.0, 0.0, 0.0)]), settings(&s, 1.0))
        .err()
        .unwrap();
    assert_eq!(
        e.to_string(),
        "robot `bot` starts inside `crate`, which it cannot drive through"
    );
}

#[test]
fn waypoints_are_reached() {
    let s = room();
    let mission = WaypointMission {
        // Around the bush at (3, 7), which it cannot pass through.
        points: vec![
            DVec2::new(4.0, 4.0),
            DVec2::new(2.0, 5.0),
            DVec2::new(5.0, 5.0),
            DVec2::new(5.0, 8.5),
        ],
        speed: 0.5,
        tolerance: 0.1,
        pose: crate::map::PoseSource::Odometry,
        repeat: false,
    };
    let ctl = Box::new(WaypointController::new(mission, 10.0));
    let mut sim = Simulation::new(&s.world, &s.robots[0], ctl, settings(&s, 60.0)).unwrap();
    let summary = sim.run(&mut NoObserver).unwrap();
    assert_eq!(summary.outcome, RunOutcome::Completed);
    let end = summary.final_pose;
    assert!((end.x - 5.0).hypot(end.y - 8.5) <= 0.1 + 0.05, "{end:?}");
    assert_eq!(summary.bumps, 0);
}

#[test]
fn same_seed_same_run_other_seed_other_noise() {
    let s = room();
    let r = Robot {
        odometry: OdometryNoise::default(),
        ..s.robots[0].clone()
    };
    let run = |seed| {
        let mut sim = Simulation::new(
            &s.world,
            &r,
            teleop(&[(3.0, 0.4, 0.3)]),
            RunSettings {
                seed,
                ..settings(&s, 3.0)
            },
        )
        .unwrap();
        let mut log = Log::default();
        let summary = sim.run(&mut log).unwrap();
        (summary, log.steps)
    };
    let (a, sa) = run(1);
    let (b, sb) = run(1);
    let (c, _) = run(2);
    assert_eq!(a, b);
    assert_eq!(sa, sb);
    assert_ne!(a.final_odometry, c.final_odometry);
    assert_eq!(a.final_pose, c.final_pose);
}

#[test]
fn idle_robot_scans_and_stays() {
    let s = room();
    let mut sim = Simulation::new(
        &s.world,
        &s.robots[0],
        Box::new(Idle { rate_hz: 10.0 }),
        settings(&s, 1.0),
    )
    .unwrap();
    let summary = sim.run(&mut NoObserver).unwrap();
    assert_eq!(summary.outcome, RunOutcome::Timeout);
    assert_eq!(summary.final_pose, s.robots[0].start);
    assert_eq!(summary.sensors[0].scans, 4);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Whatever the commands, the robot never ends a step overlapping anything it cannot
    /// drive through.
    #[test]
    fn never_inside_an_obstacle(
        cmds in prop::collection::vec((0.2..3.0f64, -1.0..1.0f64, -3.0..3.0f64), 1..12),
        x in 1.0..9.0f64, y in 1.0..9.0f64, yaw in -3.1..3.1f64,
    ) {
        let s = room();
        let start = Pose::new(x, y, 0.0, yaw);
        let r = Robot { start, sensors: Vec::new(), ..s.robots[0].clone() };
        prop_assume!(s.world.blocking_object(&r.vehicle.body(&start)).is_none());
        let total: f64 = cmds.iter().map(|c| c.0).sum();
        let mut sim = Simulation::new(&s.world, &r, teleop(&cmds), settings(&s, total + 1.0)).unwrap();
        let mut log = Log::default();
        let summary = sim.run(&mut log).unwrap();
        for st in log.steps.iter().chain(std::iter::once(&Step {
            time: summary.duration, truth: summary.final_pose, odometry: summary.final_odometry,
            slam: None, command: Twist::default(), bumped: false,
        })) {
            prop_assert!(s.world.blocking_object(&r.vehicle.body(&st.truth)).is_none(),
                "inside an obstacle at t = {}: {:?}", st.time, st.truth);
        }
        prop_assert_eq!(summary.bumps, log.steps.iter().filter(|s| s.bumped).count());
    }
}

/// Every scan of a run (traced ahead in batches on all cores, its draws taken while the
/// previous batch was traced) is the scan the sensor takes alone at that pose and time with
/// its own random stream read in scan order.
#[test]
fn scans_traced_ahead_are_the_scans_taken_one_by_one() {
    let s = room();
    let robot = &s.robots[0];
    let run = settings(&s, 6.0);
    let controller = teleop(&[(2.0, 0.4, 0.0), (2.0, 0.2, 0.6), (2.0, 0.0, -0.5)]);
    let mut sim = Simulation::new(&s.world, robot, controller, run).unwrap();
    let mut log = Log::default();
    sim.run(&mut log).unwrap();
    let mut rngs: Vec<ChaCha8Rng> = (1..=robot.sensors.len() as u64)
        .map(|k| {
            let mut rng = ChaCha8Rng::seed_from_u64(run.seed);
            rng.set_stream(k);
            rng
        })
        .collect();
    let mut tracer = Tracer::default();
    assert!(log.taken.len() > 200, "{} scans", log.taken.len());
    for (k, (i, scan)) in log.taken.iter().enumerate() {
        let config = &robot.sensors[*i].config;
        let alone = config.scan(&s.world, &scan.pose, scan.stamp, &mut rngs[*i], &mut tracer);
        assert!(alone == *scan, "scan {k} of sensor {i} at {} s", scan.stamp);
    }
}
