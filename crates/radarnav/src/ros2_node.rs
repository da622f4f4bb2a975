//! A live ROS 2 node (DESIGN §8, cargo feature `ros2`): a scenario's robot simulated in real
//! time (or at a set speed), publishing the topics of the rosbag2 recording and driven by
//! `geometry_msgs/Twist` on `/cmd_vel`, so teleop tools and Nav2 drive it. Pure Rust DDS
//! (ros2-client on RustDDS): no ROS installation is needed, and any ROS 2 DDS peer on the
//! same domain sees it.
//!
//! Topics (messages built by [`crate::record::ros2::convert`], as in the bag):
//! `/clock`, `/tf` (every step and every scan between steps), `/tf_static` (transient local),
//! `/odom`, `/scan/<sensor>`, `/echoes/<sensor>` (multi-echo sensors), `/radar/<sensor>/image`
//! and `/radar/<sensor>/points` (imaging radars, each rotation) and, with maps,
//! `/map/<sensor>` every simulated second. `/cmd_vel` sets (v, ω) until the next one; the
//! vehicle's limits apply.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, NodeName, NodeOptions, Publisher, QosProfile, Subscription,
};
use serde::Serialize;
use thiserror::Error;

use crate::map::{MapConfig, MapError, Mapper};
use crate::mission::Remote;
use crate::record::frames;
use crate::record::radar_images::RadarImager;
use crate::record::ros2::{convert, msg};
use crate::setup::{Robot, Scenario};
use crate::sim::{Observer, RunSettings, ScanEvent, SimError, Simulation, Step};
use crate::stamp::unix_ns;
use crate::vehicle::DriveCommand;

/// A node that could not start or run.
#[derive(Debug, Error)]
pub enum NodeError {
    /// The DDS middleware refused (no network interface, a bad name).
    #[error("ROS 2: {0}")]
    Ros(String),
    /// The simulation could not start.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A map could not be made.
    #[error(transparent)]
    Map(#[from] MapError),
}

fn ros<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> NodeError + '_ {
    move |e| NodeError::Ros(format!("{what}: {e:?}"))
}

/// How the node runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveOptions {
    /// Simulated seconds per wall-clock second (1: real time).
    pub speed: f64,
    /// Longest simulated time, s.
    pub duration: f64,
    /// Seed of the run's random draws.
    pub seed: u64,
    /// Build and publish a map per sensor.
    pub maps: bool,
}

/// What the node did.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveReport {
    /// Simulated time, s.
    pub simulated: f64,
    /// Wall-clock time, s.
    pub wall: f64,
    /// The most a step started behind the clock, s.
    pub worst_lag: f64,
    /// `/cmd_vel` messages taken.
    pub commands: u64,
}

/// Seconds between two map messages.
const MAP_PERIOD: f64 = 1.0;

fn qos(latched: bool, depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(if latched {
            Durability::TransientLocal
        } else {
            Durability::Volatile
        })
        .history(History::KeepLast { depth })
}

/// The publishers of the node.
struct Pubs {
    clock: Publisher<msg::Clock>,
    tf: Publisher<msg::TfMessage>,
    odom: Publisher<msg::Odometry>,
    scans: Vec<SensorPubs>,
    maps: Vec<Publisher<msg::OccupancyGrid>>,
}

struct SensorPubs {
    frame: String,
    plane: usize,
    scan_time: f64,
    scan: Publisher<msg::LaserScan>,
    echoes: Option<Publisher<msg::PointCloud2>>,
    /// An imaging radar's image and detections.
    radar: Option<(Publisher<msg::Image>, Publisher<msg::PointCloud2>)>,
}

/// Publishes what the simulation produces.
struct Publish<'a, 'w> {
    pubs: &'a Pubs,
    maps: &'a mut [Mapper],
    images: Option<RadarImager<'w>>,
    last_tf: Option<u64>,
    failed: Option<String>,
}

impl Publish<'_, '_> {
    fn send<M: Serialize + std::fmt::Debug>(&mut self, p: &Publisher<M>, m: M) {
        // A full queue or a vanished peer is the peers' concern: the node goes on, and
        // says once why a message was lost.
        if let Err(e) = p.publish(m) {
            self.failed.get_or_insert_with(|| format!("{e:?}"));
        }
    }

    fn tf(&mut self, ns: u64, truth: &crate::Pose, odometry: &crate::Pose) {
        if self.last_tf.is_some_and(|last| last >= ns) {
            return;
        }
        self.last_tf = Some(ns);
        let m = convert::tf(ns, truth, odometry);
        let p = &self.pubs.tf;
        self.send(p, m);
    }
}

impl Observer for Publish<'_, '_> {
    type Error = std::convert::Infallible;

    fn on_step(&mut self, step: &Step) -> Result<(), Self::Error> {
        let ns = unix_ns(step.time);
        self.send(&self.pubs.clock, convert::clock(ns));
        self.tf(ns, &step.truth, &step.odometry);
        self.send(&self.pubs.odom, convert::odometry(ns, step));
        let Ok(()) = self.maps.on_step(step);
        let sweeps = match &mut self.images {
            Some(imager) => imager.on_step(step),
            None => Vec::new(),
        };
        for sweep in &sweeps {
            let pubs = self.pubs;
            let s = &pubs.scans[sweep.sensor];
            if let Some((image, points)) = &s.radar {
                let (_, i, p) = convert::radar_image(sweep, &s.frame);
                self.send(image, i);
                self.send(points, p);
            }
        }
        Ok(())
    }

    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), Self::Error> {
        let scan = event.scan;
        self.tf(unix_ns(scan.stamp), &event.truth, &event.odometry);
        let s = &self.pubs.scans[event.sensor];
        self.send(
            &s.scan,
            convert::laser_scan(scan, &s.frame, s.plane, s.scan_time),
        );
        if let Some(p) = &s.echoes {
            self.send(p, convert::echoes(scan, &s.frame));
        }
        let Ok(()) = self.maps.on_scan(event);
        if let Some(imager) = &mut self.images {
            imager.on_scan(event.sensor, scan.stamp);
        }
        Ok(())
    }
}

/// Runs `robot` of `scenario` as a ROS 2 node until `stop` is set or `options.duration` has
/// been simulated; `log` hears what the operator should know.
pub fn run(
    scenario: &Scenario,
    robot: &Robot,
    options: LiveOptions,
    stop: &AtomicBool,
    log: &(dyn Fn(String) + Sync),
) -> Result<LiveReport, NodeError> {
    let context = Context::new().map_err(ros("DDS participant"))?;
    let mut node = context
        .new_node(
            NodeName::new("/", "radarnav").map_err(ros("node name"))?,
            NodeOptions::new().enable_rosout(false),
        )
        .map_err(ros("node"))?;
    let name = |ns: &str, base: &str| Name::new(ns, base).map_err(ros("topic name"));
    let topic = |n: Name, pkg: &str, ty: &str, latched: bool, depth: usize| {
        let q = qos(latched, depth);
        node.create_topic(&n, MessageTypeName::new(pkg, ty), &q)
            .map_err(ros("topic"))
    };
    let clock_t = topic(name("/", "clock")?, "rosgraph_msgs", "Clock", false, 10)?;
    let tf_t = topic(name("/", "tf")?, "tf2_msgs", "TFMessage", false, 100)?;
    let tf_static_t = topic(name("/", "tf_static")?, "tf2_msgs", "TFMessage", true, 1)?;
    let odom_t = topic(name("/", "odom")?, "nav_msgs", "Odometry", false, 10)?;
    let cmd_t = topic(name("/", "cmd_vel")?, "geometry_msgs", "Twist", false, 10)?;
    let mut sensor_topics = Vec::new();
    for s in &robot.sensors {
        let token = frames::ros_name(&s.name);
        let scan = topic(
            name("/scan", &token)?,
            "sensor_msgs",
            "LaserScan",
            false,
            10,
        )?;
        let echoes = if s.config.signal.return_mode == crate::sensor::ReturnMode::Thesis {
            None
        } else {
            Some(topic(
                name("/echoes", &token)?,
                "sensor_msgs",
                "PointCloud2",
                false,
                10,
            )?)
        };
        let radar = if s.config.signal.image.is_some() && s.config.range_bin.is_some() {
            Some((
                topic(
                    name(&format!("/radar/{token}"), "image")?,
                    "sensor_msgs",
                    "Image",
                    false,
                    2,
                )?,
                topic(
                    name(&format!("/radar/{token}"), "points")?,
                    "sensor_msgs",
                    "PointCloud2",
                    false,
                    2,
                )?,
            ))
        } else {
            None
        };
        sensor_topics.push((scan, echoes, radar));
    }
    let mut mappers = Vec::new();
    let mut map_topics = Vec::new();
    if options.maps {
        let config = MapConfig::default();
        // As `run`'s maps: the world's bounds grown by the sensors' reach, so a robot driven
        // away for hours cannot grow a map without bound.
        let region = crate::limits::budget::map_region(
            &scenario.world,
            robot,
            config.max_free_range,
            config.max_range,
        );
        for s in &robot.sensors {
            let mut m = Mapper::from_spec(&s.name, robot, config)?;
            m.limit_to(region);
            mappers.push(m);
            let token = frames::ros_name(&s.name);
            map_topics.push(topic(
                name("/map", &token)?,
                "nav_msgs",
                "OccupancyGrid",
                true,
                1,
            )?);
        }
    }
    let pubs = Pubs {
        clock: node
            .create_publisher(&clock_t, None)
            .map_err(ros("publisher"))?,
        tf: node
            .create_publisher(&tf_t, None)
            .map_err(ros("publisher"))?,
        odom: node
            .create_publisher(&odom_t, None)
            .map_err(ros("publisher"))?,
        scans: robot
            .sensors
            .iter()
            .zip(&sensor_topics)
            .map(|(s, (scan, echoes, radar))| {
                Ok(SensorPubs {
                    frame: frames::sensor_frame(&s.name),
                    plane: s.config.horizontal_plane(),
                    scan_time: 1.0 / s.config.rate_hz,
                    scan: node
                        .create_publisher(scan, None)
                        .map_err(ros("publisher"))?,
                    radar: match radar {
                        Some((i, p)) => Some((
                            node.create_publisher(i, None).map_err(ros("publisher"))?,
                            node.create_publisher(p, None).map_err(ros("publisher"))?,
                        )),
                        None => None,
                    },
                    echoes: match echoes {
                        Some(t) => Some(node.create_publisher(t, None).map_err(ros("publisher"))?),
                        None => None,
                    },
                })
            })
            .collect::<Result<_, NodeError>>()?,
        maps: map_topics
            .iter()
            .map(|t| node.create_publisher(t, None).map_err(ros("publisher")))
            .collect::<Result<_, _>>()?,
    };
    let tf_static: Publisher<msg::TfMessage> = node
        .create_publisher(&tf_static_t, None)
        .map_err(ros("publisher"))?;
    let cmd_vel: Subscription<msg::TwistMsg> = node
        .create_subscription(&cmd_t, None)
        .map_err(ros("subscription"))?;
    let spinner = node.spinner().map_err(ros("spinner"))?;

    let remote = Remote::new(1.0 / scenario.sim.dt);
    let command = remote.command();
    let settings = RunSettings {
        dt: scenario.sim.dt,
        duration: options.duration,
        seed: options.seed,
    };
    let mut sim = Simulation::new(&scenario.world, robot, Box::new(remote), settings)?;
    let report = std::thread::scope(|scope| {
        // Discovery, parameters and graph events run on the spinner until the node stops.
        scope.spawn(move || futures::executor::block_on(spinner.spin()));
        let _ = tf_static.publish(convert::tf_static(unix_ns(0.0), robot));
        let mut publish = Publish {
            pubs: &pubs,
            maps: &mut mappers,
            images: RadarImager::new(&scenario.world, robot, options.seed),
            last_tf: None,
            failed: None,
        };
        let epoch = Instant::now();
        let mut worst_lag = Duration::ZERO;
        let mut commands = 0u64;
        let mut next_map = 0.0;
        while !sim.done() && !stop.load(Ordering::Relaxed) {
            while let Ok(Some((t, _))) = cmd_vel.take() {
                command.set(DriveCommand::twist(t.linear.x, t.angular.z));
                commands += 1;
            }
            let due = epoch + Duration::from_secs_f64(sim.time() / options.speed);
            let now = Instant::now();
            if now < due {
                std::thread::sleep((due - now).min(Duration::from_millis(5)));
                continue;
            }
            worst_lag = worst_lag.max(now - due);
            let Ok(_) = sim.step(&mut publish);
            if sim.time() + 1e-9 >= next_map {
                next_map += MAP_PERIOD;
                let ns = unix_ns(sim.time());
                for (m, p) in publish.maps.iter().zip(&pubs.maps) {
                    let _ = p.publish(convert::occupancy_grid(ns, m.grid()));
                }
            }
        }
        node.stop_spinner();
        if let Some(e) = publish.failed {
            log(format!("some messages were not published: {e}"));
        }
        LiveReport {
            simulated: sim.time(),
            wall: epoch.elapsed().as_secs_f64(),
            worst_lag: worst_lag.as_secs_f64(),
            commands,
        }
    });
    Ok(report)
}
