//! The library's front door without TOML (DESIGN §9): a world, a robot and a mission built in
//! code, run, and the same run from a scenario file giving the same result.

use glam::{DVec2, DVec3};
use radarnav::mission::{Mission, MissionKind};
use radarnav::nav::{BugAlgorithm, BugMission};
use radarnav::setup::{Robot, Scenario};
use radarnav::sim::{NoObserver, RunOutcome, RunSettings, Simulation};
use radarnav::world::{MaterialTable, Object, Shape, World};
use radarnav::{Pose, sensor::preset, vehicle::vehicle};

fn box_goal_in_code() -> Scenario {
    let materials = MaterialTable::default();
    let concrete = materials.id("concrete").unwrap();
    let wall = |name: &str, c: [f64; 2], size: [f64; 2]| Object {
        name: Some(name.into()),
        shape: Shape::cuboid(
            DVec3::new(c[0], c[1], 1.25),
            DVec3::new(size[0], size[1], 2.5),
            0.0,
        )
        .unwrap(),
        material: concrete,
    };
    let objects = vec![
        wall("south", [9.0, -0.1], [18.4, 0.2]),
        wall("north", [9.0, 12.1], [18.4, 0.2]),
        wall("west", [-0.1, 6.0], [0.2, 12.4]),
        wall("east", [18.1, 6.0], [0.2, 12.4]),
        Object {
            name: Some("box".into()),
            shape: Shape::cuboid(DVec3::new(14.0, 6.0, 0.75), DVec3::new(2.0, 2.0, 1.5), 0.0)
                .unwrap(),
            material: concrete,
        },
    ];
    let robot = Robot::new(
        "p3at",
        vehicle("p3at").unwrap(),
        Pose::new(2.0, 6.0, 0.0, 0.0),
    )
    .with_sensor(
        "radar",
        preset("radar_thesis").unwrap(),
        Pose::new(0.0, 0.0, 0.4, 0.0),
    );
    let mission = Mission::new(MissionKind::Bug(BugMission::new(
        BugAlgorithm::Bug2,
        DVec2::new(12.3, 6.0),
    )));
    Scenario::new("box-goal-in-code", World::new(materials, objects))
        .with_robot(robot)
        .with_mission(mission)
}

fn run(s: &Scenario, seed: u64) -> radarnav::sim::RunSummary {
    let m = s.mission.as_ref().unwrap();
    let settings = RunSettings {
        seed,
        ..RunSettings::of(s)
    };
    let mut sim = Simulation::new(
        &s.world,
        &s.robots[0],
        m.controller(seed).unwrap(),
        settings,
    )
    .unwrap();
    let Ok(summary) = sim.run(&mut NoObserver);
    summary
}

#[test]
fn a_mission_built_in_code_reaches_its_goal() {
    let s = box_goal_in_code();
    let summary = run(&s, 1);
    assert_eq!(summary.outcome, RunOutcome::Reached);
    assert_eq!(summary.bumps, 0);
    // It steers on its odometry: that is at the goal, the truth near it.
    let goal = DVec2::new(12.3, 6.0);
    assert!((summary.final_odometry.xy() - goal).length() < 0.3);
    assert!((summary.final_pose.xy() - goal).length() < 1.0);
}

#[test]
fn code_and_file_defaults_agree() {
    let toml = r#"
[[robot]]
name = "p3at"
start = { x = 2.0, y = 6.0, yaw_deg = 0.0 }
[[robot.sensor]]
name = "radar"
preset = "radar_thesis"
mount = { z = 0.4 }
[mission]
type = "bug2"
goal = [12.3, 6.0]
"#;
    let file = Scenario::from_toml(toml, "t.toml", "t").unwrap();
    let code = box_goal_in_code();
    assert_eq!(file.sim, code.sim);
    assert_eq!(file.mission, code.mission);
    assert_eq!(file.robots[0].sensors, code.robots[0].sensors);
    assert_eq!(file.robots[0].odometry, code.robots[0].odometry);
}
