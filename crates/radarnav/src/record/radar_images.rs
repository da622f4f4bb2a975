//! The power images of a run's imaging radars (DESIGN §7.4), each rendered from the poses the
//! robot really had while the antenna turned.
//!
//! A rotation starts at each scan of an imaging sensor and lasts one scan period; azimuth k
//! is measured at t₀ + k / (azimuths · rate). The sim only knows the poses up to its next
//! controller call, so the imager keeps the steps (start pose and the command executed) and
//! renders a rotation once a step at or after its end has arrived: every pose inside it is
//! then the one the robot drove. A rotation still turning when the run ends is dropped, as a
//! recording of a real radar drops its partial scan.

use glam::DVec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::pose::Pose;
use crate::sensor::cfar::{Detection, Detector, detect};
use crate::sensor::image::{IMAGE_EPOCH_US, PowerImage, power_image};
use crate::sensor::{SensorConfig, Tracer, beam_ray};
use crate::setup::Robot;
use crate::sim::Step;
use crate::vehicle::{Twist, integrate};
use crate::world::World;

/// First random stream of the images (sensor i draws from this + i): apart from the
/// odometry's (0) and the scans' (1..=sensors), so images change no other draw of a run.
const IMAGE_STREAM: u64 = 1 << 32;

/// The detector of the run's radar point clouds: CFEAR's k-strongest filter, the input of
/// radar odometry and SLAM on such images.
pub const RUN_DETECTOR: Detector = Detector::K_STRONGEST;

/// One finished rotation.
#[derive(Clone, Debug)]
pub struct SweepImage {
    /// Index of the sensor on the robot.
    pub sensor: usize,
    /// The image in the Oxford layout.
    pub image: PowerImage,
    /// Its [`RUN_DETECTOR`] detections, each with its position in the world frame (from the
    /// sensor's pose when its row was measured).
    pub detections: Vec<(Detection, DVec3)>,
}

struct Imaging {
    sensor: usize,
    config: SensorConfig,
    mount: Pose,
    rng: ChaCha8Rng,
}

/// Renders the rotations of every imaging sensor of a robot as the run goes.
pub struct RadarImager<'w> {
    world: &'w World,
    sensors: Vec<Imaging>,
    /// Steps (start time, start pose, command executed) from before the oldest open rotation.
    steps: Vec<(f64, Pose, Twist)>,
    /// Open rotations: (index into `sensors`, start time).
    open: Vec<(usize, f64)>,
    tracer: Tracer,
}

impl<'w> RadarImager<'w> {
    /// The imager of `robot` in `world`; `None` when none of its sensors makes images.
    pub fn new(world: &'w World, robot: &Robot, seed: u64) -> Option<Self> {
        let sensors: Vec<Imaging> = robot
            .sensors
            .iter()
            .enumerate()
            .filter(|(_, s)| s.config.signal.image.is_some() && s.config.range_bin.is_some())
            .map(|(i, s)| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(IMAGE_STREAM + i as u64);
                Imaging {
                    sensor: i,
                    config: s.config.clone(),
                    mount: s.mount,
                    rng,
                }
            })
            .collect();
        (!sensors.is_empty()).then(|| Self {
            world,
            sensors,
            steps: Vec::new(),
            open: Vec::new(),
            tracer: Tracer::default(),
        })
    }

    /// Indices (on the robot) of the imaging sensors.
    pub fn sensors(&self) -> impl Iterator<Item = usize> + '_ {
        self.sensors.iter().map(|s| s.sensor)
    }

    /// A scan of robot sensor `sensor` at time `stamp` starts a rotation if it images.
    pub fn on_scan(&mut self, sensor: usize, stamp: f64) {
        if let Some(k) = self.sensors.iter().position(|s| s.sensor == sensor) {
            self.open.push((k, stamp));
        }
    }

    /// Takes a step; returns the rotations it completes, in start order.
    pub fn on_step(&mut self, step: &Step) -> Vec<SweepImage> {
        let executed = if step.bumped {
            Twist::default()
        } else {
            step.command
        };
        self.steps.push((step.time, step.truth, executed));
        let mut done = Vec::new();
        let mut k = 0;
        while k < self.open.len() {
            let (s, t0) = self.open[k];
            if t0 + 1.0 / self.sensors[s].config.rate_hz <= step.time {
                self.open.remove(k);
                done.extend(self.render(s, t0));
            } else {
                k += 1;
            }
        }
        // Keep the last step that starts at or before the oldest open rotation.
        let oldest = self.open.iter().map(|o| o.1).fold(step.time, f64::min);
        let keep = self
            .steps
            .partition_point(|s| s.0 <= oldest)
            .saturating_sub(1);
        self.steps.drain(..keep);
        done
    }

    /// The true robot pose at time `t`, from the step that contains it.
    fn robot_pose(steps: &[(f64, Pose, Twist)], t: f64) -> Pose {
        let i = steps.partition_point(|s| s.0 <= t).saturating_sub(1);
        steps
            .get(i)
            .map_or_else(Pose::default, |&(time, pose, cmd)| {
                integrate(&pose, cmd, (t - time).max(0.0))
            })
    }

    fn render(&mut self, s: usize, t0: f64) -> Option<SweepImage> {
        let Imaging {
            sensor,
            config,
            mount,
            rng,
        } = &mut self.sensors[s];
        let steps = &self.steps;
        let pose_at = |t: f64| Self::robot_pose(steps, t).compose(mount);
        let image = power_image(
            config,
            self.world,
            t0,
            IMAGE_EPOCH_US,
            &pose_at,
            rng,
            &mut self.tracer,
        )?;
        let display = config.signal.image.as_ref()?.display_range_db;
        let rows = image.rows().max(1) as f64;
        let el = config.elevations.first().copied().unwrap_or(0.0);
        let detections = detect(&image, RUN_DETECTOR, display)
            .into_iter()
            .map(|d| {
                let p = pose_at(t0 + d.row as f64 / (rows * config.rate_hz));
                (d, beam_ray(&p, -d.azimuth, el.sin_cos(), 0.0).at(d.range))
            })
            .collect();
        Some(SweepImage {
            sensor: *sensor,
            image,
            detections,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::preset;
    use crate::setup::MountedSensor;
    use crate::vehicle::P3AT;
    use crate::world::Shape;
    use crate::world::strategies::world_of;
    use glam::DVec2;

    fn robot(sensor: &str) -> Robot {
        let config = preset(sensor).expect("preset");
        Robot {
            name: "r".into(),
            vehicle: &P3AT,
            start: Pose::default(),
            sensors: vec![MountedSensor {
                name: "nav".into(),
                config,
                mount: Pose::new(0.0, 0.0, 0.5, 0.0),
            }],
            odometry: Default::default(),
            slam: None,
        }
    }

    fn step(time: f64, x: f64, v: f64) -> Step {
        Step {
            time,
            truth: Pose::new(x, 0.0, 0.0, 0.0),
            odometry: Pose::new(x, 0.0, 0.0, 0.0),
            slam: None,
            command: Twist { v, omega: 0.0 },
            bumped: false,
        }
    }

    #[test]
    fn only_imaging_sensors_make_images() {
        let world = world_of(&[]);
        assert!(RadarImager::new(&world, &robot("radar_thesis"), 1).is_none());
        assert!(RadarImager::new(&world, &robot("navtech_cts350x"), 1).is_some());
    }

    #[test]
    fn a_rotation_is_rendered_once_its_last_pose_is_known_with_the_motion_in_its_rows() {
        // A wall across x = 20; the robot drives at it at 4 m/s, so it moves 1 m in one turn.
        let wall = Shape::wall(
            vec![DVec2::new(20.0, -30.0), DVec2::new(20.0, 30.0)],
            0.2,
            3.0,
        );
        let world = world_of(&[(wall.expect("a wall"), "concrete")]);
        let r = robot("navtech_cts350x");
        let mut imager = RadarImager::new(&world, &r, 7).expect("imaging");
        imager.on_scan(0, 0.0);
        let dt = 0.05;
        let mut images = Vec::new();
        for k in 0..=5 {
            let t = k as f64 * dt;
            images.extend(imager.on_step(&step(t, 4.0 * t, 4.0)));
            if k < 5 {
                assert!(images.is_empty(), "rendered before the rotation ended");
            }
        }
        assert_eq!(images.len(), 1);
        let img = &images[0].image;
        assert_eq!(img.rows(), 400);
        // The first row (t = 0, straight ahead) sees the wall 20 m off; the last row (almost a
        // turn later, also nearly straight ahead) sees it about 1 m nearer.
        let peak = |row: usize| {
            let data = &img.power[row * img.bins..(row + 1) * img.bins];
            let (bin, _) = data
                .iter()
                .enumerate()
                .max_by_key(|&(j, v)| (*v, std::cmp::Reverse(j)))
                .expect("bins");
            (bin as f64 + 0.5) * img.bin_size
        };
        let (first, last) = (peak(0), peak(399));
        assert!((first - (20.0 - 0.1)).abs() < 0.2, "first row peak {first}");
        let moved = 4.0 * 399.0 / 400.0 * 0.25;
        assert!(
            (last - (20.0 - 0.1 - moved)).abs() < 0.2,
            "last row peak {last}"
        );
        // Stamps follow the rotation.
        assert_eq!(img.timestamps_us[0], IMAGE_EPOCH_US);
        assert_eq!(img.timestamps_us[399] - img.timestamps_us[0], 249_375);
        // Detections sit on the wall in the world frame, whatever row they came from.
        let dets = &images[0].detections;
        assert!(!dets.is_empty());
        let on_wall = dets
            .iter()
            .filter(|(d, _)| d.azimuth.cos() > 0.99)
            .all(|(_, p)| (p.x - 19.9).abs() < 0.3);
        assert!(on_wall);
    }
}
