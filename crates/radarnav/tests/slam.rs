//! Localisation on whole scenarios (DESIGN §10): the foliage-wall loop on a drifting odometry,
//! steered and mapped on the radar localiser's pose, against the truth.

use radarnav::Scenario;
use radarnav::accuracy::Meter;
use radarnav::map::{MapConfig, Mapper, PoseSource, score_maps};
use radarnav::pose::Pose;
use radarnav::sim::{Observer, RunSettings, Simulation, Step};

/// The odometry's and the localiser's errors against the truth, step by step.
#[derive(Default)]
struct Errors {
    odometry: Meter,
    slam: Meter,
}

impl Observer for Errors {
    type Error = std::convert::Infallible;
    fn on_step(&mut self, s: &Step) -> Result<(), Self::Error> {
        self.odometry.push(&s.truth, &s.odometry);
        self.slam
            .push(&s.truth, &s.slam.expect("the robot runs a localiser"));
        Ok(())
    }
}

fn scenario(file: &str) -> Scenario {
    let path = format!("{}/../../scenarios/slam/{file}", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(&path).expect("scenario file");
    Scenario::from_toml(&src, &path, file).expect("valid scenario")
}

#[test]
fn the_foliage_wall_loop_holds_on_radar_slam_while_the_odometry_drifts_away() {
    let s = scenario("foliage-wall-loop.toml");
    let robot = &s.robots[0];
    let mission = s.mission.as_ref().expect("mission");
    assert_eq!(mission.pose(), Some(PoseSource::Slam));
    for seed in [1, 2] {
        let maps = [PoseSource::Slam, PoseSource::Truth].map(|pose| {
            let config = MapConfig {
                pose,
                ..MapConfig::default()
            };
            Mapper::new("radar", robot, &["radar"], config).expect("mapper")
        });
        let mut maps = maps;
        let mut errors = Errors::default();
        let settings = RunSettings {
            seed,
            ..RunSettings::of(&s)
        };
        let mut sim = Simulation::new(&s.world, robot, mission.controller(seed).unwrap(), settings)
            .expect("simulation");
        let Ok(summary) = sim.run(&mut (maps.as_mut_slice(), &mut errors));
        assert_eq!(summary.bumps, 0, "seed {seed}: {:?}", summary.bump_events);
        assert!(
            summary.duration >= 239.9,
            "seed {seed}: looped for the whole run"
        );
        let odometry = errors.odometry.result().expect("steps").ate_rmse_m;
        let slam = errors.slam.result().expect("steps").ate_rmse_m;
        assert!(
            odometry >= 0.5,
            "seed {seed}: the odometry drifts (ATE {odometry} m)"
        );
        assert!(slam <= 0.10, "seed {seed}: radar SLAM ATE {slam} m");
        let stats = summary.slam.expect("slam summary");
        assert_eq!(stats.sensor, "radar");
        assert!(stats.stats.registered > 900, "{stats:?}");
        // The map on the localiser's pose scores like the map on the true pose.
        let scores = score_maps(&s.world, robot.vehicle, &robot.start, maps.iter());
        let (on_slam, on_truth) = (&scores[0], &scores[1]);
        let points = |a: Option<f64>, b: Option<f64>| 100.0 * (a.unwrap() - b.unwrap()).abs();
        let coverage = points(on_slam.hidden_coverage, on_truth.hidden_coverage);
        let precision = points(on_slam.obstacle_precision, on_truth.obstacle_precision);
        assert!(
            coverage <= 3.0,
            "seed {seed}: hidden coverage {coverage} points apart"
        );
        assert!(
            precision <= 5.0,
            "seed {seed}: obstacle precision {precision} points apart"
        );
    }
}

#[test]
fn without_a_localiser_slam_poses_are_the_odometry() {
    let s = scenario("smoke-room-drift.toml");
    let mut robot = s.robots[0].clone();
    robot.slam = None;
    let mission = s.mission.as_ref().expect("mission");
    let settings = RunSettings {
        duration: 5.0,
        ..RunSettings::of(&s)
    };
    let mut sim =
        Simulation::new(&s.world, &robot, mission.controller(1).unwrap(), settings).unwrap();
    let Ok(summary) = sim.run(&mut radarnav::sim::NoObserver);
    assert!(summary.slam.is_none());
    assert_eq!(sim.slam(), None::<Pose>);
}
