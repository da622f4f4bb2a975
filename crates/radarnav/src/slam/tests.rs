use super::*;
use crate::sensor::Tracer;
use crate::setup::Scenario;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Drives the true path `truth` (robot poses, one per scan) through `scenario`'s world with
/// the odometry turning `drift` rad per scan more than the truth and going `scale` times as
/// far; returns the largest position and heading error of the localiser, and its stats.
fn track(
    scenario: &str,
    sensor: &str,
    truth: &[Pose],
    drift: f64,
    scale: f64,
) -> (f64, f64, SlamStats) {
    let sc = Scenario::builtin(scenario).unwrap();
    let robot = &sc.robots[0];
    let i = robot.sensors.iter().position(|s| s.name == sensor).unwrap();
    let mounted = &robot.sensors[i];
    let mut slam = Localiser::new(SlamConfig::for_sensor(i), mounted.mount, truth[0]);
    let (mut rng, mut tracer) = (ChaCha8Rng::seed_from_u64(3), Tracer::default());
    let mut odometry = truth[0];
    let (mut worst_xy, mut worst_yaw) = (0.0f64, 0.0f64);
    for (k, t) in truth.iter().enumerate() {
        if k > 0 {
            let mut step = truth[k - 1].inverse().compose(t);
            step.x *= scale;
            step.y *= scale;
            step.yaw += drift;
            odometry = odometry.compose(&step);
        }
        let scan = (mounted.config).scan(
            &sc.world,
            &t.compose(&mounted.mount),
            k as f64 * 0.25,
            &mut rng,
            &mut tracer,
        );
        let est = slam.register(&scan, &odometry);
        worst_xy = worst_xy.max((est.xy() - t.xy()).length());
        worst_yaw = worst_yaw.max(wrap_angle(est.yaw - t.yaw).abs());
    }
    (worst_xy, worst_yaw, slam.stats())
}

/// A lap of the foliage-wall room's near side: out along x, up, back and down, turning at the
/// corners, 0.1 m per scan (0.4 m/s at 4 Hz).
fn lap() -> Vec<Pose> {
    let corners = [
        (3.0, 4.0),
        (5.0, 4.0),
        (5.0, 6.5),
        (2.5, 6.5),
        (2.5, 2.0),
        (5.0, 2.0),
        (5.0, 4.0),
    ];
    let mut out = vec![Pose::new(3.0, 4.0, 0.0, 0.0)];
    for w in corners.windows(2) {
        let (a, b) = (DVec2::from(w[0]), DVec2::from(w[1]));
        let yaw = (b - a).y.atan2((b - a).x);
        // Turn on the spot in 5° steps, then drive.
        let last = *out.last().unwrap();
        let turn = wrap_angle(yaw - last.yaw);
        let n = (turn.abs() / 5f64.to_radians()).ceil() as usize;
        for k in 1..=n {
            out.push(Pose::new(
                a.x,
                a.y,
                0.0,
                last.yaw + turn * k as f64 / n as f64,
            ));
        }
        let n = ((b - a).length() / 0.1).round() as usize;
        for k in 1..=n {
            let p = a + (b - a) * (k as f64 / n as f64);
            out.push(Pose::new(p.x, p.y, 0.0, yaw));
        }
    }
    out
}

#[test]
fn radar_registration_holds_a_drifting_odometry_to_the_truth() {
    let truth = lap();
    // 0.5° a scan of drift (2°/s at 4 Hz, ten times the issue's) and 3 % of scale error.
    let (drift, scale) = (0.5f64.to_radians(), 1.03);
    let (xy, yaw, stats) = track("foliage-wall", "radar", &truth, drift, scale);
    assert!(
        xy < 0.06 && yaw < 1.5f64.to_radians(),
        "{xy} m, {} deg, {stats:?}",
        yaw.to_degrees()
    );
    assert_eq!(stats.refused, 0, "{stats:?}");
    assert!(stats.keyframes > 20 && stats.mean_score > 0.5, "{stats:?}");
    // The odometry alone is far off by then: the localiser did the work.
    let odo_yaw = drift * (truth.len() - 1) as f64;
    assert!(odo_yaw > 20f64.to_radians());
}

#[test]
fn laser_registration_holds_too() {
    let truth = lap();
    let (xy, yaw, stats) = track("foliage-wall", "laser", &truth, 0.3f64.to_radians(), 0.98);
    assert!(
        xy < 0.06 && yaw < 1.5f64.to_radians(),
        "{xy} m, {} deg, {stats:?}",
        yaw.to_degrees()
    );
}

#[test]
fn a_pose_between_registrations_follows_the_odometry() {
    let sc = Scenario::builtin("foliage-wall").unwrap();
    let mount = sc.robots[0].sensors[0].mount;
    let start = Pose::new(1.0, 2.0, 0.0, 0.3);
    let mut slam = Localiser::new(SlamConfig::for_sensor(0), mount, start);
    // Before any scan the estimate is the odometry.
    let odo = Pose::new(1.5, 2.2, 0.0, 0.4);
    let e = slam.estimate(&odo);
    assert!((e.x - odo.x).abs() < 1e-12 && (e.y - odo.y).abs() < 1e-12);
    // An anchor off by a known transform carries that transform to later odometry.
    slam.anchor = (Pose::new(1.1, 2.0, 0.0, 0.35), start);
    let e = slam.estimate(&start.compose(&Pose::new(1.0, 0.0, 0.0, 0.0)));
    assert!((e.x - (1.1 + 0.35f64.cos())).abs() < 1e-12);
    assert!((e.y - (2.0 + 0.35f64.sin())).abs() < 1e-12);
    assert!((e.yaw - 0.35).abs() < 1e-12);
}

#[test]
fn a_scan_without_returns_is_refused_and_the_odometry_kept() {
    let sc = Scenario::builtin("open-field").unwrap();
    let robot = &sc.robots[0];
    let mounted = &robot.sensors[0];
    let mut slam = Localiser::new(SlamConfig::for_sensor(0), mounted.mount, robot.start);
    let (mut rng, mut tracer) = (ChaCha8Rng::seed_from_u64(1), Tracer::default());
    // Far out of the field, nothing in range.
    let far = Pose::new(-2000.0, -2000.0, 0.0, 0.0);
    let scan = mounted.config.scan(
        &sc.world,
        &far.compose(&mounted.mount),
        0.0,
        &mut rng,
        &mut tracer,
    );
    let odo = Pose::new(0.5, 0.0, 0.0, 0.1);
    let e = slam.register(&scan, &odo);
    assert!((e.xy() - odo.xy()).length() < 1e-12 && (e.yaw - odo.yaw).abs() < 1e-12);
    assert_eq!(slam.stats().refused, 1);
}

#[test]
fn a_loop_closure_undoes_a_jump_that_tracking_refused() {
    // Two laps; at the start of the second the odometry jumps 0.7 m sideways (a wheel slip):
    // more than tracking may correct, so the estimate carries the jump on the odometry's
    // word, until the second lap's keyframes are registered against the first lap's.
    let lap = lap();
    let mut truth = lap.clone();
    truth.extend_from_slice(&lap[1..]);
    let sc = Scenario::builtin("foliage-wall").unwrap();
    let mounted = &sc.robots[0].sensors[0];
    let run = |loop_closure: bool| {
        let config = SlamConfig {
            loop_closure,
            ..SlamConfig::for_sensor(0)
        };
        let mut slam = Localiser::new(config, mounted.mount, truth[0]);
        let (mut rng, mut tracer) = (ChaCha8Rng::seed_from_u64(5), Tracer::default());
        let mut odometry = truth[0];
        let mut last = 0.0;
        for (k, t) in truth.iter().enumerate() {
            if k > 0 {
                odometry = odometry.compose(&truth[k - 1].inverse().compose(t));
            }
            if k == lap.len() {
                odometry = odometry.compose(&Pose::new(0.0, 0.7, 0.0, 0.0));
            }
            let pose = t.compose(&mounted.mount);
            let scan =
                (mounted.config).scan(&sc.world, &pose, k as f64 * 0.25, &mut rng, &mut tracer);
            let est = slam.register(&scan, &odometry);
            last = (est.xy() - t.xy()).length();
        }
        (last, slam.stats())
    };
    let (without, _) = run(false);
    let (with, stats) = run(true);
    assert!(
        without > 0.5,
        "without loop closures the jump stays: {without} m"
    );
    assert!(with < 0.1, "with them it is undone: {with} m, {stats:?}");
    assert!(
        stats.loop_closures > 0 && stats.graph_solves > 0,
        "{stats:?}"
    );
}
