//! `radarnav ros2`: a scenario's robot as a live ROS 2 node (cargo feature `ros2`).

use anyhow::Result;
use radarnav::Scenario;

/// What `radarnav ros2` takes (unread in a build without the feature, which only refuses).
#[cfg_attr(not(feature = "ros2"), allow(dead_code))]
pub struct Ros2Args<'a> {
    pub scenario: &'a Scenario,
    pub robot: Option<&'a str>,
    pub speed: f64,
    pub duration: Option<f64>,
    pub maps: bool,
    pub add_sensors: &'a [String],
}

/// Runs the node until Ctrl-C or the duration.
#[cfg(feature = "ros2")]
pub fn run(a: &Ros2Args<'_>) -> Result<()> {
    use radarnav::ros2_node::{LiveOptions, run};
    let s = a.scenario;
    let robot = radarnav::run::robot_of(s, a.robot)?;
    let robot = &radarnav::run::with_sensors(robot, a.add_sensors)?;
    let duration = a.duration.unwrap_or(radarnav::limits::DURATION.max);
    let mut topics = Vec::new();
    for x in &robot.sensors {
        let token = radarnav::record::frames::ros_name(&x.name);
        topics.push(format!("/scan/{token}"));
        if x.config.signal.image.is_some() && x.config.range_bin.is_some() {
            topics.push(format!("/radar/{token}/image /radar/{token}/points"));
        }
    }
    eprintln!(
        "ROS 2 node /radarnav on domain {}: {} at {}x real time; publishing /clock /tf \
         /tf_static /odom {}{}; driven by /cmd_vel (geometry_msgs/Twist); Ctrl-C stops",
        std::env::var("ROS_DOMAIN_ID").unwrap_or_else(|_| "0".into()),
        s.name,
        a.speed,
        topics.join(" "),
        if a.maps { " /map/<sensor>" } else { "" },
    );
    let stop = crate::run_cmd::stop_flag()?;
    let log = |line: String| eprintln!("{line}");
    let options = LiveOptions {
        speed: a.speed,
        duration,
        seed: s.sim.seed,
        maps: a.maps,
    };
    let r = run(s, robot, options, &stop, &log)?;
    eprintln!(
        "stopped after {:.1} s simulated in {:.1} s ({:.2}x real time), {} /cmd_vel messages, \
         worst step {:.1} ms behind the clock",
        r.simulated,
        r.wall,
        r.simulated / r.wall.max(1e-9),
        r.commands,
        r.worst_lag * 1e3
    );
    Ok(())
}

/// Built without the `ros2` feature: says how to build with it.
#[cfg(not(feature = "ros2"))]
pub fn run(_: &Ros2Args<'_>) -> Result<()> {
    anyhow::bail!(
        "this radarnav was built without ROS 2; build it with \
         `cargo build --release -p radarnav-cli --features ros2`"
    )
}
