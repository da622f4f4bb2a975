//! The simulation loop (DESIGN §4): fixed steps, sensors at their own rates, a controller at
//! its own rate, collisions refused, odometry beside the truth.
//!
//! One step from time `t` to `t + dt`:
//! 1. sensors due at `t` scan from the pose at `t`;
//! 2. the controller runs if it is due, seeing the latest scans and the odometry;
//! 3. the command is limited to the vehicle and the move is checked for collisions along its
//!    arc; a move that would collide is refused whole (the robot stays; the bump is counted);
//! 4. sensors due strictly inside the step scan from the exact pose on the arc at their time;
//! 5. the robot and its odometry move.
//!
//! Scan `k` of a sensor with rate `r` is taken at exactly `k / r` seconds, whatever `dt` is.
//! Between two controller calls the command is fixed, so every scan until the next call has a
//! known pose: at each call the loop traces that batch on all cores and hands the scans out
//! in order as the steps reach them (same draws, same scans as one by one). A scan's draws do
//! not depend on its pose, so the next batch's are taken while a batch is traced: the scans
//! and each sensor's draws are one queue of tasks taken longest first
//! ([`crate::batch::map_longest_first`]), as a batch is only a few scans long.
//! A robot with a localiser ([`crate::slam`]) registers each scan of its sensor as the scan is
//! handed out, in time order; observers and controllers see its estimate beside the odometry.
//! Every random draw comes from ChaCha8 streams of the run's seed: stream 0 for the odometry,
//! stream `1 + i` for sensor `i`, so the same scenario and seed give the same run.

mod summary;

pub use summary::{BumpEvent, RunOutcome, RunSummary, SensorCount, SlamSummary};

use std::collections::VecDeque;
use std::sync::Mutex;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use thiserror::Error;

use crate::pose::Pose;
use crate::sensor::{PARALLEL_MIN_RAYS, Scan, ScanDraws, Tracer, with_pool_tracer};
use crate::setup::{MountedSensor, Robot, Scenario};
use crate::slam::Localiser;
use crate::vehicle::{DriveCommand, Odometry, Twist, VehicleSpec, integrate};
use crate::world::World;

/// What a controller sees when it is called.
#[derive(Clone, Copy, Debug)]
pub struct ControlInput<'a> {
    /// Simulation time, s.
    pub time: f64,
    /// The odometry estimate.
    pub odometry: &'a Pose,
    /// The true pose: only for controllers told to navigate on ground truth; the others
    /// must use `odometry`, as a real robot would.
    pub truth: &'a Pose,
    /// Whether the last move was refused by a collision.
    pub bumped: bool,
    /// The latest scan of each sensor, in the robot's sensor order (`None` before the first).
    /// Its `pose` is the true sensor pose at the scan's time.
    pub scans: &'a [Option<Scan>],
    /// The odometry estimate of the robot pose at the time of each latest scan, same order:
    /// where a robot without ground truth believes each scan was taken.
    pub scan_odometry: &'a [Option<Pose>],
    /// The localiser's estimate of the robot pose now (`None` when the robot runs none).
    pub slam: Option<&'a Pose>,
    /// The localiser's estimate of the robot pose at the time of each latest scan, same order.
    pub scan_slam: &'a [Option<Pose>],
    /// The robot's sensors (names, configs, mounts), same order.
    pub sensors: &'a [MountedSensor],
    /// The vehicle being driven.
    pub vehicle: &'static VehicleSpec,
}

/// A controller's answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Decision {
    /// Drive with this command until the next call.
    Drive(DriveCommand),
    /// The mission is over; the run ends here.
    Finished(Ending),
}

/// How a controller ended its mission.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ending {
    /// Done what it was told (teleop commands played, waypoints visited).
    Completed,
    /// A navigation goal was reached.
    Reached,
    /// The controller proved the goal cannot be reached (Bug1/Bug2 failure conditions).
    NoPath,
}

/// Something that drives the robot: called at [`Controller::rate_hz`] with the latest data.
pub trait Controller {
    /// Calls per second.
    fn rate_hz(&self) -> f64;
    /// The command for the coming period.
    fn update(&mut self, input: &ControlInput<'_>) -> Decision;
    /// What the controller did, for `summary.json` (hit points, leave points, ...).
    fn report(&self) -> Option<serde_json::Value> {
        None
    }
}

/// One simulation step as logged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Time at the start of the step, s.
    pub time: f64,
    /// True pose at `time`.
    pub truth: Pose,
    /// Odometry estimate at `time`.
    pub odometry: Pose,
    /// The localiser's estimate at `time` (`None` when the robot runs none).
    pub slam: Option<Pose>,
    /// The command in force during the step, after the vehicle's limits.
    pub command: Twist,
    /// Whether the step's move was refused by a collision.
    pub bumped: bool,
}

/// A scan as observers receive it, with the robot's pose at the scan's time.
#[derive(Clone, Copy, Debug)]
pub struct ScanEvent<'a> {
    /// Index of the sensor in the robot's sensors.
    pub sensor: usize,
    /// The scan; its `pose` is the true sensor pose.
    pub scan: &'a Scan,
    /// True robot pose at the scan's time.
    pub truth: Pose,
    /// Odometry estimate of the robot pose at the scan's time. Inside a step it is the
    /// estimate at the step's start moved by the executed command (the step's noise is drawn
    /// once, at its end).
    pub odometry: Pose,
    /// The localiser's estimate of the robot pose at the scan's time: for its own sensor's
    /// scans, the registered pose; for the others, the last registration moved on by the
    /// odometry (`None` when the robot runs no localiser).
    pub slam: Option<Pose>,
}

/// Receives what happens in a run, in time order (a recorder, a mapper, a progress bar).
pub trait Observer {
    /// Error that ends the run.
    type Error;
    /// A scan was taken.
    fn on_scan(&mut self, _event: &ScanEvent<'_>) -> Result<(), Self::Error> {
        Ok(())
    }
    /// A step was taken.
    fn on_step(&mut self, _step: &Step) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// An observer that ignores everything.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoObserver;

impl Observer for NoObserver {
    type Error = std::convert::Infallible;
}

/// Both observers, first `.0` then `.1`; they share one error type.
impl<A: Observer, B: Observer<Error = A::Error>> Observer for (A, B) {
    type Error = A::Error;
    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), Self::Error> {
        self.0.on_scan(event)?;
        self.1.on_scan(event)
    }
    fn on_step(&mut self, step: &Step) -> Result<(), Self::Error> {
        self.0.on_step(step)?;
        self.1.on_step(step)
    }
}

/// Every observer of the slice, in order.
impl<O: Observer> Observer for [O] {
    type Error = O::Error;
    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), Self::Error> {
        self.iter_mut().try_for_each(|o| o.on_scan(event))
    }
    fn on_step(&mut self, step: &Step) -> Result<(), Self::Error> {
        self.iter_mut().try_for_each(|o| o.on_step(step))
    }
}

impl<O: Observer + ?Sized> Observer for &mut O {
    type Error = O::Error;
    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), Self::Error> {
        (**self).on_scan(event)
    }
    fn on_step(&mut self, step: &Step) -> Result<(), Self::Error> {
        (**self).on_step(step)
    }
}

/// A run that cannot start.
#[derive(Debug, Error, PartialEq)]
pub enum SimError {
    /// The robot's start pose overlaps an object it cannot drive through.
    #[error("robot `{robot}` starts inside `{object}`, which it cannot drive through")]
    StartBlocked {
        /// Robot name.
        robot: String,
        /// Object name (or `object #i`).
        object: String,
    },
    /// Bad run settings.
    #[error("{0}")]
    Settings(String),
}

/// Timing and seed of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunSettings {
    /// Step, s.
    pub dt: f64,
    /// Longest run, s.
    pub duration: f64,
    /// Seed of every random draw.
    pub seed: u64,
}

impl RunSettings {
    /// The scenario's `[sim]` settings.
    pub fn of(scenario: &Scenario) -> Self {
        Self {
            dt: scenario.sim.dt,
            duration: scenario.sim.duration,
            seed: scenario.sim.seed,
        }
    }
}

/// Longest distance (m) and turn (rad) between two collision checks within a step.
const CHECK_STEP: (f64, f64) = (0.02, 0.035);
/// Slack for comparing event times on the step grid, s.
const TIME_EPS: f64 = 1e-9;

/// A run in progress.
pub struct Simulation<'a> {
    world: &'a World,
    robot: &'a Robot,
    controller: Box<dyn Controller + 'a>,
    settings: RunSettings,
    ticks: u64,
    tick: u64,
    truth: Pose,
    odometry: Odometry,
    odo_rng: ChaCha8Rng,
    sensor_rngs: Vec<ChaCha8Rng>,
    /// Per sensor, the draws of its next scans taken ahead of time from its RNG, in stream
    /// order. A scan's draws do not depend on its pose, so they are drawn while other scans
    /// are traced ([`Simulation::prepare_scans`]) rather than in the serial part of a step.
    drawn: Vec<VecDeque<ScanDraws>>,
    tracer: Tracer,
    next_scan: Vec<u64>,
    /// Per sensor, its next scans traced ahead (see the module doc).
    prepared: Vec<VecDeque<Scan>>,
    next_control: u64,
    latest: Vec<Option<Scan>>,
    latest_odometry: Vec<Option<Pose>>,
    /// The localiser, when the robot runs one.
    slam: Option<Localiser>,
    latest_slam: Vec<Option<Pose>>,
    /// The localiser's estimate now (kept beside it for `ControlInput`'s reference).
    slam_now: Option<Pose>,
    command: Twist,
    bumped: bool,
    ending: Option<Ending>,
    distance: f64,
    bumps: Vec<BumpEvent>,
    bump_count: usize,
    /// Stopped from outside before its end ([`Simulation::run_until`]).
    interrupted: bool,
}

/// Most scans traced ahead at one controller call (their memory is bounded by this).
const LOOKAHEAD_SCANS: usize = 64;
/// Fewest rays in a batch worth sharing among threads.
const LOOKAHEAD_MIN_RAYS: usize = 1024;
/// Most rays per sensor whose draws are taken ahead of their scans (about 16 MB of draws).
const DRAWN_MAX_RAYS: usize = 1 << 20;

/// Bumps kept with time and object in the summary; later ones are only counted.
pub const MAX_BUMP_EVENTS: usize = 1000;

impl<'a> Simulation<'a> {
    /// A run of `robot` in `world` driven by `controller`.
    pub fn new(
        world: &'a World,
        robot: &'a Robot,
        controller: Box<dyn Controller + 'a>,
        settings: RunSettings,
    ) -> Result<Self, SimError> {
        if !(settings.dt > 0.0 && settings.dt.is_finite()) {
            return Err(SimError::Settings(format!(
                "dt must be a finite number > 0, found {}",
                settings.dt
            )));
        }
        if !(settings.duration >= 0.0 && settings.duration.is_finite()) {
            return Err(SimError::Settings(format!(
                "duration must be a finite number >= 0, found {}",
                settings.duration
            )));
        }
        let rate = controller.rate_hz();
        if !(rate > 0.0 && rate.is_finite()) {
            return Err(SimError::Settings(format!(
                "controller rate must be a finite number > 0, found {rate}"
            )));
        }
        let start = Pose {
            z: 0.0,
            ..robot.start
        };
        if let Some(i) = world.blocking_object(&robot.vehicle.body(&start)) {
            return Err(SimError::StartBlocked {
                robot: robot.name.clone(),
                object: object_name(world, i),
            });
        }
        let stream = |k: u64| {
            let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
            rng.set_stream(k);
            rng
        };
        let n = robot.sensors.len();
        Ok(Self {
            world,
            robot,
            controller,
            settings,
            ticks: (settings.duration / settings.dt).round() as u64,
            tick: 0,
            truth: start,
            odometry: Odometry::new(start, robot.odometry),
            odo_rng: stream(0),
            sensor_rngs: (1..=n as u64).map(stream).collect(),
            drawn: vec![VecDeque::new(); n],
            tracer: Tracer::default(),
            next_scan: vec![0; n],
            prepared: vec![VecDeque::new(); n],
            next_control: 0,
            latest: vec![None; n],
            latest_odometry: vec![None; n],
            slam: (robot.slam)
                .filter(|c| c.sensor < n)
                .map(|c| Localiser::new(c, robot.sensors[c.sensor].mount, start)),
            latest_slam: vec![None; n],
            slam_now: None,
            command: Twist::default(),
            bumped: false,
            ending: None,
            distance: 0.0,
            bumps: Vec::new(),
            bump_count: 0,
            interrupted: false,
        })
    }

    /// Simulation time now, s.
    pub fn time(&self) -> f64 {
        self.tick as f64 * self.settings.dt
    }

    /// Steps in the whole run (at most).
    pub fn total_steps(&self) -> u64 {
        self.ticks
    }

    /// Whether the run is over (time is up or the mission finished).
    pub fn done(&self) -> bool {
        self.ending.is_some() || self.tick >= self.ticks
    }

    /// True pose now.
    pub fn truth(&self) -> Pose {
        self.truth
    }

    /// Odometry now.
    pub fn odometry(&self) -> &Odometry {
        &self.odometry
    }

    /// The localiser's estimate for the odometry reading `odometry` (`None` without one).
    fn slam_estimate(&self, odometry: &Pose) -> Option<Pose> {
        self.slam.as_ref().map(|l| l.estimate(odometry))
    }

    /// The localiser's estimate now (`None` when the robot runs none).
    pub fn slam(&self) -> Option<Pose> {
        self.slam_estimate(&self.odometry.pose)
    }

    /// Runs to the end.
    pub fn run<O: Observer + ?Sized>(&mut self, observer: &mut O) -> Result<RunSummary, O::Error> {
        self.run_until(observer, &std::sync::atomic::AtomicBool::new(false))
    }

    /// Runs to the end, or until `stop` is set (a signal handler's flag): the step under way
    /// is finished, and the summary says `interrupted`.
    pub fn run_until<O: Observer + ?Sized>(
        &mut self,
        observer: &mut O,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<RunSummary, O::Error> {
        loop {
            if stop.load(std::sync::atomic::Ordering::Relaxed) && !self.done() {
                self.interrupted = true;
                break;
            }
            if !self.step(observer)? {
                break;
            }
        }
        Ok(self.summary())
    }

    /// Whether [`Simulation::run_until`] was stopped.
    pub fn interrupted(&self) -> bool {
        self.interrupted
    }

    /// Takes one step; `false` once the run is over.
    pub fn step<O: Observer + ?Sized>(&mut self, observer: &mut O) -> Result<bool, O::Error> {
        if self.done() {
            return Ok(false);
        }
        let t = self.time();
        let dt = self.settings.dt;
        let start = self.truth;
        let odo_start = self.odometry.pose;
        // 1. Scans due now see the pose at the start of the step.
        self.fire_sensors(t + TIME_EPS, |_| (start, odo_start), observer)?;
        // 2. Controller.
        let rate = self.controller.rate_hz();
        if self.next_control as f64 / rate <= t + TIME_EPS {
            self.slam_now = self.slam();
            let input = ControlInput {
                time: t,
                odometry: &self.odometry.pose,
                truth: &self.truth,
                bumped: self.bumped,
                scans: &self.latest,
                scan_odometry: &self.latest_odometry,
                slam: self.slam_now.as_ref(),
                scan_slam: &self.latest_slam,
                sensors: &self.robot.sensors,
                vehicle: self.robot.vehicle,
            };
            match self.controller.update(&input) {
                Decision::Drive(cmd) => self.command = self.robot.vehicle.limit(cmd),
                Decision::Finished(ending) => {
                    self.ending = Some(ending);
                    self.command = Twist::default();
                    return Ok(false);
                }
            }
            while self.next_control as f64 / rate <= t + TIME_EPS {
                self.next_control += 1;
            }
            self.prepare_scans();
        }
        // 3. Collision check along the arc.
        let cmd = self.command;
        let blocked = self.first_block(&start, cmd, dt);
        self.bumped = blocked.is_some();
        if blocked.is_some() {
            self.bump_count += 1;
        }
        if let Some(object) = blocked.filter(|_| self.bumps.len() < MAX_BUMP_EVENTS) {
            self.bumps.push(BumpEvent {
                time: t,
                object: object_name(self.world, object),
            });
        }
        let executed = if self.bumped { Twist::default() } else { cmd };
        observer.on_step(&Step {
            time: t,
            truth: start,
            odometry: self.odometry.pose,
            slam: self.slam(),
            command: cmd,
            bumped: self.bumped,
        })?;
        // 4. Scans inside the step, on the arc.
        self.fire_sensors(
            t + dt - TIME_EPS,
            |s| {
                let ds = (s - t).max(0.0);
                (
                    integrate(&start, executed, ds),
                    integrate(&odo_start, executed, ds),
                )
            },
            observer,
        )?;
        // 5. Move.
        self.truth = integrate(&start, executed, dt);
        self.distance += executed.v.abs() * dt;
        self.odometry
            .update(self.robot.vehicle, executed, dt, &mut self.odo_rng);
        self.tick += 1;
        Ok(!self.done())
    }

    /// Takes every scan not yet taken whose time is at most `until`, in time order across
    /// sensors (ties: sensor order).
    fn fire_sensors<O: Observer + ?Sized>(
        &mut self,
        until: f64,
        pose_at: impl Fn(f64) -> (Pose, Pose),
        observer: &mut O,
    ) -> Result<(), O::Error> {
        loop {
            // The earliest due scan of any sensor; ties go to the lower index.
            let due = self
                .robot
                .sensors
                .iter()
                .enumerate()
                .map(|(i, s)| (i, self.next_scan[i] as f64 / s.config.rate_hz))
                .filter(|&(_, when)| when <= until)
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            let Some((i, when)) = due else {
                return Ok(());
            };
            let sensor = &self.robot.sensors[i];
            let (truth, odometry) = pose_at(when);
            let scan = match self.prepared[i].pop_front() {
                Some(scan) => {
                    debug_assert!(scan.stamp == when && scan.pose == truth.compose(&sensor.mount));
                    scan
                }
                None => {
                    let draws = self.drawn[i].pop_front().unwrap_or_else(|| {
                        sensor.config.draw(self.world, &mut self.sensor_rngs[i])
                    });
                    let pose = truth.compose(&sensor.mount);
                    (sensor.config).trace_scan(
                        self.world,
                        &pose,
                        when,
                        &draws,
                        &mut self.tracer,
                        PARALLEL_MIN_RAYS,
                    )
                }
            };
            self.next_scan[i] += 1;
            let slam = match self.slam.as_mut() {
                Some(l) if l.config().sensor == i => Some(l.register(&scan, &odometry)),
                Some(l) => Some(l.estimate(&odometry)),
                None => None,
            };
            observer.on_scan(&ScanEvent {
                sensor: i,
                scan: &scan,
                truth,
                odometry,
                slam,
            })?;
            self.latest[i] = Some(scan);
            self.latest_odometry[i] = Some(odometry);
            self.latest_slam[i] = slam;
        }
    }

    /// Traces, on all cores, every scan due from now until the controller's next call: the
    /// command is fixed until then, so the poses are known (the steps ahead are replayed
    /// here, collisions included, exactly as [`Simulation::step`] will take them). Each
    /// sensor's draws are taken in scan order, so the scans are the ones the steps would take.
    fn prepare_scans(&mut self) {
        let sensors = &self.robot.sensors;
        let (dt, rate, cmd) = (self.settings.dt, self.controller.rate_hz(), self.command);
        // After the scans still queued, if any: each scan is drawn once.
        let mut next: Vec<u64> = (self.next_scan.iter().zip(&self.prepared))
            .map(|(n, queued)| n + queued.len() as u64)
            .collect();
        let mut jobs: Vec<(usize, f64, Pose)> = Vec::new();
        let mut rays = 0;
        let mut due = |until: f64, pose_at: &dyn Fn(f64) -> Pose, jobs: &mut Vec<_>| {
            for (i, s) in sensors.iter().enumerate() {
                while next[i] as f64 / s.config.rate_hz <= until && jobs.len() < LOOKAHEAD_SCANS {
                    let when = next[i] as f64 / s.config.rate_hz;
                    jobs.push((i, when, pose_at(when)));
                    rays += s.config.azimuth_count() * s.config.elevations.len();
                    next[i] += 1;
                }
            }
        };
        let (mut tick, mut start) = (self.tick, self.truth);
        while jobs.len() < LOOKAHEAD_SCANS {
            let t = tick as f64 * dt;
            if tick > self.tick {
                if tick >= self.ticks {
                    break;
                }
                due(t + TIME_EPS, &|_| start, &mut jobs);
                if self.next_control as f64 / rate <= t + TIME_EPS {
                    break;
                }
            }
            let executed = match self.first_block(&start, cmd, dt) {
                Some(_) => Twist::default(),
                None => cmd,
            };
            due(
                t + dt - TIME_EPS,
                &|s| integrate(&start, executed, (s - t).max(0.0)),
                &mut jobs,
            );
            start = integrate(&start, executed, dt);
            tick += 1;
        }
        // A batch too small to share is left to the steps.
        if jobs.len() < 2 || rays < LOOKAHEAD_MIN_RAYS {
            return;
        }
        let (world, drawn, rngs) = (self.world, &mut self.drawn, &mut self.sensor_rngs);
        let draws: Vec<ScanDraws> = jobs
            .iter()
            .map(|&(i, _, _)| {
                (drawn[i].pop_front())
                    .unwrap_or_else(|| sensors[i].config.draw(world, &mut rngs[i]))
            })
            .collect();
        // While the batch is traced, the next batch's draws are taken (as many per sensor as
        // this batch used): the draws are the same whenever they are taken, as each sensor's
        // stream is read in scan order.
        let mut per_sensor = vec![0usize; sensors.len()];
        for &(i, _, _) in &jobs {
            per_sensor[i] += 1;
        }
        // Draws held ahead stay small beside the scans themselves: at least one scan's.
        for (want, s) in per_sensor.iter_mut().zip(sensors) {
            let rays = (s.config.azimuth_count() * s.config.elevations.len()).max(1);
            *want = (*want).min((DRAWN_MAX_RAYS / rays).max(1));
        }
        // One queue, longest first: the scans, and each sensor's draws for the next batch (a
        // sensor's own stream: the sensors' refills are independent of each other). Split in
        // rayon's halves instead, a batch of four laser scans, a radar scan and the draws left
        // a core idle at its end: `bench foliage-wall --sim 600` took 6-8 % longer (medians
        // of interleaved pairs). The results come in the tasks' order: the scans first.
        enum Task {
            Trace(usize),
            Refill(usize),
        }
        let rays_of = |i: usize| {
            let c = &sensors[i].config;
            (c.azimuth_count() * c.elevations.len()) as f64
        };
        // Each with its expected cost: a ray's draws cost about a tenth of tracing it.
        let mut tasks: Vec<(Task, f64)> = (jobs.iter().enumerate())
            .map(|(k, &(i, _, _))| (Task::Trace(k), rays_of(i)))
            .collect();
        for (i, &want) in per_sensor.iter().enumerate() {
            if let Some(missing) = want.checked_sub(drawn[i].len()).filter(|&m| m > 0) {
                tasks.push((Task::Refill(i), 0.1 * rays_of(i) * missing as f64));
            }
        }
        let refills: Vec<Mutex<(&mut VecDeque<ScanDraws>, &mut ChaCha8Rng)>> = drawn
            .iter_mut()
            .zip(rngs.iter_mut())
            .map(Mutex::new)
            .collect();
        let done = crate::batch::map_longest_first(
            &tasks,
            |t| t.1,
            |t| {
                match t.0 {
                    Task::Trace(k) => {
                        let (i, when, truth) = jobs[k];
                        let s = &sensors[i];
                        let pose = truth.compose(&s.mount);
                        Some(with_pool_tracer(|tracer| {
                            (s.config).trace_scan(
                                world,
                                &pose,
                                when,
                                &draws[k],
                                tracer,
                                PARALLEL_MIN_RAYS,
                            )
                        }))
                    }
                    Task::Refill(i) => {
                        // Only this task takes sensor `i`'s slot: the lock is never contended.
                        let mut slot = refills[i].lock().unwrap_or_else(|e| e.into_inner());
                        let (queue, rng) = &mut *slot;
                        while queue.len() < per_sensor[i] {
                            queue.push_back(sensors[i].config.draw(world, &mut **rng));
                        }
                        None
                    }
                }
            },
        );
        let scans = done.into_iter().flatten();
        for (&(i, _, _), scan) in jobs.iter().zip(scans) {
            self.prepared[i].push_back(scan);
        }
    }

    /// The first object met when driving `cmd` for `dt` from `start`, checked every few
    /// centimetres and degrees of the arc.
    fn first_block(&self, start: &Pose, cmd: Twist, dt: f64) -> Option<usize> {
        if cmd == Twist::default() {
            return None;
        }
        let n = ((cmd.v.abs() * dt / CHECK_STEP.0).max(cmd.omega.abs() * dt / CHECK_STEP.1))
            .ceil()
            .max(1.0) as u32;
        (1..=n).find_map(|k| {
            let p = integrate(start, cmd, dt * f64::from(k) / f64::from(n));
            self.world.blocking_object(&self.robot.vehicle.body(&p))
        })
    }

    /// How the controller ended the mission (`None` while it runs or when time ran out).
    pub fn ending(&self) -> Option<Ending> {
        self.ending
    }

    /// The controller's report (see [`Controller::report`]).
    pub fn controller_report(&self) -> Option<serde_json::Value> {
        self.controller.report()
    }

    /// The latest scan of sensor `i` of the robot (`None` before its first or for no such
    /// sensor). Its `pose` is the true sensor pose at the scan's time.
    pub fn latest_scan(&self, i: usize) -> Option<&Scan> {
        self.latest.get(i)?.as_ref()
    }

    /// Whether the last step's move was refused by a collision.
    pub fn bumped(&self) -> bool {
        self.bumped
    }

    /// Refused moves so far.
    pub fn bump_count(&self) -> usize {
        self.bump_count
    }

    /// The run's timing and seed.
    pub fn settings(&self) -> RunSettings {
        self.settings
    }

    /// What the run did so far.
    pub fn summary(&self) -> RunSummary {
        RunSummary::new(self)
    }
}

fn object_name(world: &World, i: usize) -> String {
    world.objects()[i]
        .name
        .clone()
        .unwrap_or_else(|| format!("object #{i}"))
}

#[cfg(test)]
mod tests;
