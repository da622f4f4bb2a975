//! `radarnav._core`: the Python module over the radarnav library (DESIGN §8).
//!
//! `PyScenario` loads a scenario (built-in, file or TOML text); `PySim` runs one robot
//! of it driven from Python: `step`/`advance` with a twist or track speeds, `scan` and
//! `ranges` as numpy arrays (moved into numpy, not copied), poses, maps and figures. The
//! sweep functions run and merge shards for the Python Ray driver. The Gymnasium
//! environment and the Ray driver are Python (`python/radarnav`).

use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use glam::DVec2;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyKeyError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use radarnav::map::{MapConfig, Mapper};
use radarnav::mission::Remote;
use radarnav::record::radar_images::{RadarImager, SweepImage};
use radarnav::render::{Figure, save_png};
use radarnav::scenario::{BUILTIN_SCENARIOS, NAV_SUITE};
use radarnav::setup::{Robot, Scenario};
use radarnav::sim::{Observer, RunSettings, ScanEvent, Simulation, Step};
use radarnav::slam::SlamConfig;
use radarnav::sweep::{Shard, Sweep};
use radarnav::vehicle::{DriveCommand, Twist};
use radarnav::{Pose, Scan};

fn value_err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A loaded scenario: a world, its robots and its mission.
#[pyclass(name = "Scenario", module = "radarnav._core", frozen)]
#[derive(Clone)]
struct PyScenario {
    inner: Arc<Scenario>,
}

#[pymethods]
impl PyScenario {
    /// A built-in scenario (`builtins()` lists them) or a TOML file's path.
    #[staticmethod]
    fn load(name_or_path: &str) -> PyResult<Self> {
        use radarnav::scenario::LoadError;
        let s = radarnav::scenario::load(name_or_path).map_err(|e| match e {
            LoadError::Io { .. } => PyOSError::new_err(e.to_string()),
            LoadError::Unknown { .. } => PyKeyError::new_err(e.to_string()),
            LoadError::Scenario(e) => value_err(e),
        })?;
        Ok(Self { inner: Arc::new(s) })
    }

    /// A scenario file; meshes and teleop files it names are looked for beside it.
    #[staticmethod]
    fn from_file(path: &str) -> PyResult<Self> {
        let src = radarnav::limits::read_text(Path::new(path))
            .map_err(|e| PyOSError::new_err(format!("{path}: {e}")))?;
        let stem = Path::new(path)
            .file_stem()
            .map_or("scenario".to_owned(), |s| s.to_string_lossy().into_owned());
        Self::from_toml(&src, &stem, Some(path))
    }

    /// A scenario from TOML text; `file` names it in errors (meshes are looked for beside it).
    #[staticmethod]
    #[pyo3(signature = (text, name = "scenario", file = None))]
    fn from_toml(text: &str, name: &str, file: Option<&str>) -> PyResult<Self> {
        let file = file.map_or_else(|| format!("<{name}>"), str::to_owned);
        let s = Scenario::from_toml(text, &file, name).map_err(value_err)?;
        Ok(Self { inner: Arc::new(s) })
    }

    /// Its name.
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    /// What it is for.
    #[getter]
    fn description(&self) -> String {
        self.inner.description.clone()
    }

    /// Robot names.
    #[getter]
    fn robots(&self) -> Vec<String> {
        self.inner.robots.iter().map(|r| r.name.clone()).collect()
    }

    /// Sensor names of a robot (the first without `robot`).
    #[pyo3(signature = (robot = None))]
    fn sensors(&self, robot: Option<&str>) -> PyResult<Vec<String>> {
        let r = robot_of(&self.inner, robot)?;
        Ok(r.sensors.iter().map(|s| s.name.clone()).collect())
    }

    /// The world's extent on the ground: (xmin, ymin, xmax, ymax), m.
    fn bounds(&self) -> (f64, f64, f64, f64) {
        let (lo, hi) = radarnav::render::world_region(&self.inner.world);
        (lo.x, lo.y, hi.x, hi.y)
    }

    /// The mission's goal (x, y), for Bug missions; `None` otherwise.
    fn goal(&self) -> Option<(f64, f64)> {
        match &self.inner.mission.as_ref()?.kind {
            radarnav::mission::MissionKind::Bug(b) => Some((b.goal.x, b.goal.y)),
            _ => None,
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "Scenario({:?}, {} objects, robots {:?})",
            self.inner.name,
            self.inner.world.objects().len(),
            self.robots()
        )
    }
}

fn robot_of<'s>(s: &'s Scenario, name: Option<&str>) -> PyResult<&'s Robot> {
    s.robot(name).ok_or_else(|| {
        PyKeyError::new_err(format!(
            "scenario `{}` has no robot {}; it has: {}",
            s.name,
            name.map_or("at all".to_owned(), |n| format!("`{n}`")),
            s.robots
                .iter()
                .map(|r| r.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    })
}

/// The values a running simulation borrows: the scenario and the robot as configured.
struct Owned {
    scenario: Arc<Scenario>,
    robot: Robot,
}

/// The simulation and, for imaging radars, the renderer of their rotations.
struct Live<'a> {
    sim: Simulation<'a>,
    imager: Option<RadarImager<'a>>,
}

self_cell::self_cell!(
    struct Running {
        owner: Owned,
        #[not_covariant]
        dependent: Live,
    }
);

/// What a step tells the maps and the imager.
struct StepObserver<'o, 'w> {
    mappers: &'o mut [Mapper],
    imager: Option<&'o mut RadarImager<'w>>,
    images: &'o mut Vec<SweepImage>,
}

impl Observer for StepObserver<'_, '_> {
    type Error = std::convert::Infallible;
    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), Self::Error> {
        if let Some(imager) = self.imager.as_deref_mut() {
            imager.on_scan(event.sensor, event.scan.stamp);
        }
        self.mappers.on_scan(event)
    }
    fn on_step(&mut self, step: &Step) -> Result<(), Self::Error> {
        if let Some(imager) = self.imager.as_deref_mut() {
            self.images.extend(imager.on_step(step));
        }
        self.mappers.on_step(step)
    }
}

/// One robot of a scenario, driven from Python.
#[pyclass(name = "Sim", module = "radarnav._core", unsendable)]
struct PySim {
    scenario: Arc<Scenario>,
    /// The robot as configured (sensors kept, rates set, localiser), before a start pose.
    robot: Robot,
    seed: u64,
    duration: f64,
    map_sensors: Vec<String>,
    command: Rc<Cell<DriveCommand>>,
    running: Running,
    mappers: Vec<Mapper>,
    /// The latest finished rotation of each imaging radar (sensor index, image).
    images: Vec<SweepImage>,
    trail: Vec<DVec2>,
}

fn pose_tuple(p: &Pose) -> (f64, f64, f64) {
    (p.x, p.y, p.yaw)
}

impl PySim {
    fn start(&mut self, seed: u64, start: Option<(f64, f64, f64)>) -> PyResult<()> {
        let mut robot = self.robot.clone();
        if let Some((x, y, yaw)) = start {
            use radarnav::limits::{COORD, YAW};
            let yaw_deg = yaw.to_degrees();
            for (what, v, limit) in [("x", x, &COORD), ("y", y, &COORD), ("yaw", yaw_deg, &YAW)] {
                limit
                    .check(v)
                    .map_err(|m| value_err(format!("start {what}: {m}")))?;
            }
            robot.start = Pose::new(x, y, 0.0, yaw);
        }
        let remote = Remote::new(1.0 / self.scenario.sim.dt);
        let command = remote.command();
        let settings = RunSettings {
            seed,
            duration: self.duration,
            ..RunSettings::of(&self.scenario)
        };
        let owned = Owned {
            scenario: Arc::clone(&self.scenario),
            robot,
        };
        let running = Running::try_new(owned, |o| {
            Ok::<_, radarnav::sim::SimError>(Live {
                sim: Simulation::new(&o.scenario.world, &o.robot, Box::new(remote), settings)?,
                imager: RadarImager::new(&o.scenario.world, &o.robot, seed),
            })
        })
        .map_err(value_err)?;
        let robot = &running.borrow_owner().robot;
        let mappers = self
            .map_sensors
            .iter()
            .map(|name| Mapper::from_spec(name, robot, MapConfig::default()))
            .collect::<Result<Vec<_>, _>>()
            .map_err(value_err)?;
        self.trail = vec![robot.start.xy()];
        self.mappers = mappers;
        self.images.clear();
        self.command = command;
        self.running = running;
        self.seed = seed;
        Ok(())
    }

    fn sensor_index(&self, name: &str) -> PyResult<usize> {
        let robot = &self.running.borrow_owner().robot;
        robot
            .sensors
            .iter()
            .position(|s| s.name == name)
            .ok_or_else(|| {
                PyKeyError::new_err(format!(
                    "robot `{}` has no sensor `{name}`; it has: {}",
                    robot.name,
                    robot
                        .sensors
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
    }

    fn latest(&self, name: &str) -> PyResult<Option<Scan>> {
        let i = self.sensor_index(name)?;
        Ok(self
            .running
            .with_dependent(|_, live| live.sim.latest_scan(i).cloned()))
    }

    /// One step with the command set; `false` once the run is over.
    fn one_step(&mut self) -> bool {
        let Self {
            running,
            mappers,
            images,
            ..
        } = self;
        let mut done = Vec::new();
        let Ok(more) = running.with_dependent_mut(|_, live| {
            live.sim.step(&mut StepObserver {
                mappers: mappers.as_mut_slice(),
                imager: live.imager.as_mut(),
                images: &mut done,
            })
        });
        for image in done {
            images.retain(|i| i.sensor != image.sensor);
            images.push(image);
        }
        let p = self.running.with_dependent(|_, live| live.sim.truth().xy());
        if self.trail.last() != Some(&p) {
            self.trail.push(p);
        }
        more
    }
}

#[pymethods]
impl PySim {
    /// A simulation of `robot` (default: the mission's, else the first) in `scenario`.
    ///
    /// `seed` and `duration` default to the scenario's `[sim]`; `add_sensors` mounts presets
    /// beside the robot's sensors (an imaging radar's rotations come from `image`); `sensors`
    /// keeps only the named sensors; `rate_hz` sets every kept sensor's scan rate; `slam` runs the localiser
    /// on the named sensor; `maps` builds an occupancy grid from each named sensor.
    #[new]
    #[pyo3(signature = (scenario, robot = None, seed = None, duration = None, sensors = None, rate_hz = None, slam = None, maps = None, add_sensors = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        scenario: &Bound<'_, PyAny>,
        robot: Option<&str>,
        seed: Option<u64>,
        duration: Option<f64>,
        sensors: Option<Vec<String>>,
        rate_hz: Option<f64>,
        slam: Option<&str>,
        maps: Option<Vec<String>>,
        add_sensors: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let scenario = match scenario.cast::<PyScenario>() {
            Ok(s) => Arc::clone(&s.get().inner),
            Err(_) => PyScenario::load(&scenario.extract::<String>()?)?.inner,
        };
        let mission_robot = scenario.mission.as_ref().and_then(|m| m.robot.as_deref());
        let mut r = robot_of(&scenario, robot.or(mission_robot))?.clone();
        if let Some(extra) = &add_sensors {
            r = radarnav::run::with_sensors(&r, extra).map_err(value_err)?;
        }
        if let Some(keep) = &sensors {
            for name in keep {
                if r.sensor(name).is_none() {
                    return Err(PyKeyError::new_err(format!(
                        "robot `{}` has no sensor `{name}`",
                        r.name
                    )));
                }
            }
            r.sensors.retain(|s| keep.contains(&s.name));
        }
        if let Some(hz) = rate_hz {
            radarnav::limits::RATE
                .check(hz)
                .map_err(|m| value_err(format!("rate_hz: {m}")))?;
            for s in &mut r.sensors {
                s.config.rate_hz = hz;
            }
        }
        r.slam = match slam {
            None => None,
            Some(name) => {
                let i = (r.sensors.iter().position(|s| s.name == name)).ok_or_else(|| {
                    PyKeyError::new_err(format!("slam: robot `{}` has no sensor `{name}`", r.name))
                })?;
                Some(SlamConfig::for_sensor(i))
            }
        };
        let duration = match duration {
            Some(d) => radarnav::limits::DURATION
                .check(d)
                .map_err(|m| value_err(format!("duration: {m}")))?,
            None => scenario.sim.duration,
        };
        let seed = seed.unwrap_or(scenario.sim.seed);
        let remote = Remote::new(1.0);
        let settings = RunSettings {
            seed,
            duration,
            ..RunSettings::of(&scenario)
        };
        let owned = Owned {
            scenario: Arc::clone(&scenario),
            robot: r.clone(),
        };
        let running = Running::try_new(owned, |o| {
            Ok::<_, radarnav::sim::SimError>(Live {
                sim: Simulation::new(&o.scenario.world, &o.robot, Box::new(remote), settings)?,
                imager: None,
            })
        })
        .map_err(value_err)?;
        let mut sim = Self {
            scenario,
            robot: r,
            seed,
            duration,
            map_sensors: maps.unwrap_or_default(),
            command: Rc::new(Cell::new(DriveCommand::STOP)),
            running,
            mappers: Vec::new(),
            images: Vec::new(),
            trail: Vec::new(),
        };
        sim.start(seed, None)?;
        Ok(sim)
    }

    /// Starts again at time 0: the same seed (or `seed`), the robot's start (or `start`,
    /// (x, y, yaw rad)). Maps and the localiser start empty.
    #[pyo3(signature = (seed = None, start = None))]
    fn reset(&mut self, seed: Option<u64>, start: Option<(f64, f64, f64)>) -> PyResult<()> {
        self.start(seed.unwrap_or(self.seed), start)
    }

    /// One step of `dt` driving at `v` m/s and `omega` rad/s (limited to the vehicle's
    /// reach); `False` once the run is over.
    fn step(&mut self, v: f64, omega: f64) -> bool {
        self.command.set(DriveCommand::Twist(Twist { v, omega }));
        self.one_step()
    }

    /// One step driving the left and right tracks at these surface speeds, m/s.
    fn step_tracks(&mut self, left: f64, right: f64) -> bool {
        self.command.set(DriveCommand::Tracks { left, right });
        self.one_step()
    }

    /// Steps for `seconds` (at least one step) driving at `v`, `omega`; returns whether any
    /// of those steps bumped. Stops early when the run is over.
    fn advance(&mut self, v: f64, omega: f64, seconds: f64) -> bool {
        self.command.set(DriveCommand::Twist(Twist { v, omega }));
        let dt = self
            .running
            .with_dependent(|_, live| live.sim.settings().dt);
        let steps = ((seconds / dt).round() as u64).max(1);
        let mut bumped = false;
        for _ in 0..steps {
            let more = self.one_step();
            bumped |= self.running.with_dependent(|_, live| live.sim.bumped());
            if !more {
                break;
            }
        }
        bumped
    }

    /// Simulation time, s.
    #[getter]
    fn time(&self) -> f64 {
        self.running.with_dependent(|_, live| live.sim.time())
    }

    /// Step, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.scenario.sim.dt
    }

    /// The seed of the run.
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }

    /// Whether time is up.
    #[getter]
    fn done(&self) -> bool {
        self.running.with_dependent(|_, live| live.sim.done())
    }

    /// Whether the last step's move was refused by a collision.
    #[getter]
    fn bumped(&self) -> bool {
        self.running.with_dependent(|_, live| live.sim.bumped())
    }

    /// Refused moves so far.
    #[getter]
    fn bumps(&self) -> usize {
        self.running.with_dependent(|_, live| live.sim.bump_count())
    }

    /// Sensor names, in order.
    #[getter]
    fn sensors(&self) -> Vec<String> {
        self.robot.sensors.iter().map(|s| s.name.clone()).collect()
    }

    /// The vehicle's top speed (m/s) and turn rate (rad/s).
    #[getter]
    fn limits(&self) -> (f64, f64) {
        (
            self.robot.vehicle.max_speed,
            self.robot.vehicle.max_turn_rate,
        )
    }

    /// The scenario.
    #[getter]
    fn scenario(&self) -> PyScenario {
        PyScenario {
            inner: Arc::clone(&self.scenario),
        }
    }

    /// The true pose (x, y, yaw rad).
    fn pose(&self) -> (f64, f64, f64) {
        self.running
            .with_dependent(|_, live| pose_tuple(&live.sim.truth()))
    }

    /// The odometry's estimate (x, y, yaw rad).
    fn odometry(&self) -> (f64, f64, f64) {
        self.running
            .with_dependent(|_, live| pose_tuple(&live.sim.odometry().pose))
    }

    /// The localiser's estimate (x, y, yaw rad); `None` without `slam`.
    fn slam(&self) -> Option<(f64, f64, f64)> {
        self.running
            .with_dependent(|_, live| live.sim.slam().map(|p| pose_tuple(&p)))
    }

    /// Whether the robot could stand at (x, y, yaw) without touching a solid.
    fn is_free(&self, x: f64, y: f64, yaw: f64) -> bool {
        let body = self.robot.vehicle.body(&Pose::new(x, y, 0.0, yaw));
        self.scenario.world.blocking_object(&body).is_none()
    }

    /// The latest ranges of sensor `name` as float32 (inf: no return); `None` before its
    /// first scan.
    fn ranges<'py>(
        &self,
        py: Python<'py>,
        name: &str,
    ) -> PyResult<Option<Bound<'py, PyArray1<f32>>>> {
        Ok(self.latest(name)?.map(|s| PyArray1::from_vec(py, s.ranges)))
    }

    /// The latest scan of sensor `name` as a dict of arrays: `ranges` (float32, m, inf: no
    /// return), `hits` (uint8: 0 solid, 1 budget spent, 2 nothing), `azimuths` (rad, sensor
    /// frame), `stamp` (s), `pose` (sensor x, y, z, yaw in the world), and in `all` return mode
    /// `echo_ranges`, `echo_powers_db` and `echo_start` (ray i's echoes are
    /// `echo_start[i]:echo_start[i+1]`). `None` before its first scan.
    fn scan<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(s) = self.latest(name)? else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        let azimuths: Vec<f64> = (0..s.ranges.len())
            .map(|i| s.angle_min + (i % s.azimuths.max(1)) as f64 * s.angle_increment)
            .collect();
        let hits: Vec<u8> = s
            .hits
            .iter()
            .map(|h| match h {
                radarnav::sensor::HitKind::Solid => 0,
                radarnav::sensor::HitKind::Exhausted => 1,
                radarnav::sensor::HitKind::None => 2,
            })
            .collect();
        d.set_item("stamp", s.stamp)?;
        d.set_item("pose", (s.pose.x, s.pose.y, s.pose.z, s.pose.yaw))?;
        d.set_item("range_max", s.range_max)?;
        d.set_item("azimuths", PyArray1::from_vec(py, azimuths))?;
        d.set_item("hits", PyArray1::from_vec(py, hits))?;
        if !s.echoes.is_empty() {
            let r: Vec<f64> = s.echoes.iter().map(|e| e.range).collect();
            let p: Vec<f64> = s.echoes.iter().map(|e| e.power_db()).collect();
            d.set_item("echo_ranges", PyArray1::from_vec(py, r))?;
            d.set_item("echo_powers_db", PyArray1::from_vec(py, p))?;
            d.set_item("echo_start", PyArray1::from_vec(py, s.echo_start))?;
        }
        d.set_item("ranges", PyArray1::from_vec(py, s.ranges))?;
        Ok(Some(d))
    }

    /// The latest finished rotation of imaging radar `name` (e.g. an added `navtech_cts350x`)
    /// in the Oxford layout: `power` (uint8, azimuths x range bins), `bin_size` (m),
    /// `azimuths` (rad, clockwise from the sensor's x axis), `timestamps_us`, and its
    /// k-strongest `detections` (world x, y, z; range m; azimuth rad; power). `None` before the
    /// first rotation ends.
    fn image<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyDict>>> {
        let i = self.sensor_index(name)?;
        let Some(sweep) = self.images.iter().find(|s| s.sensor == i) else {
            return Ok(None);
        };
        let im = &sweep.image;
        let d = PyDict::new(py);
        d.set_item(
            "power",
            PyArray1::from_vec(py, im.power.clone()).reshape([im.rows(), im.bins])?,
        )?;
        d.set_item("bin_size", im.bin_size)?;
        let az: Vec<f64> = (0..im.rows()).map(|k| im.azimuth(k)).collect();
        d.set_item("azimuths", PyArray1::from_vec(py, az))?;
        d.set_item(
            "timestamps_us",
            PyArray1::from_vec(py, im.timestamps_us.clone()),
        )?;
        let det: Vec<f64> = sweep
            .detections
            .iter()
            .flat_map(|(det, p)| [p.x, p.y, p.z, det.range, det.azimuth, f64::from(det.power)])
            .collect();
        let rows = sweep.detections.len();
        d.set_item(
            "detections",
            PyArray1::from_vec(py, det).reshape([rows, 6])?,
        )?;
        Ok(Some(d))
    }

    /// The occupancy grid of map `name` (a sensor named in `maps`): a dict with `classes`
    /// (uint8 rows x columns, row 0 south: 0 unknown, 1 clear, 2 seen through, 3 obstacle),
    /// `sensed` and `passable` (float32 log-odds), `resolution` (m) and `origin` (x, y of
    /// cell (0, 0)'s corner).
    fn map<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        let m = self.mapper(name)?;
        let g = m.grid();
        let shape = [g.height(), g.width()];
        let d = PyDict::new(py);
        let classes: Vec<u8> = g.classes().into_iter().map(|c| c as u8).collect();
        d.set_item("classes", PyArray1::from_vec(py, classes).reshape(shape)?)?;
        d.set_item(
            "sensed",
            PyArray1::from_vec(py, g.sensed().to_vec()).reshape(shape)?,
        )?;
        d.set_item(
            "passable",
            PyArray1::from_vec(py, g.passable().to_vec()).reshape(shape)?,
        )?;
        d.set_item("resolution", g.resolution())?;
        d.set_item("origin", (g.origin().x, g.origin().y))?;
        Ok(d)
    }

    /// Writes map `name` as `<name>.png`, `.pgm`, `.yaml` (ROS map_server) and `.npy` into
    /// `out`; returns the paths.
    fn save_map(&self, name: &str, out: &str) -> PyResult<Vec<String>> {
        let m = self.mapper(name)?;
        let dir = Path::new(out);
        std::fs::create_dir_all(dir).map_err(|e| PyOSError::new_err(format!("{out}: {e}")))?;
        let overlay = radarnav::map::export::Overlay {
            path: &self.trail,
            ..Default::default()
        };
        let paths = radarnav::map::export::write_all(
            m.grid(),
            dir,
            &format!("map_{name}"),
            &format!("{}: {name} map", self.scenario.name),
            800,
            &overlay,
        )
        .map_err(|e| PyOSError::new_err(e.to_string()))?;
        Ok(paths.iter().map(|p| p.display().to_string()).collect())
    }

    /// Writes a PNG of the world with the path driven so far and the robot where it is.
    #[pyo3(signature = (path, pixels = 800))]
    fn figure(&self, path: &str, pixels: u32) -> PyResult<()> {
        save_png(&self.world_figure(pixels)?, Path::new(path))
            .map_err(|e| PyOSError::new_err(format!("{path}: {e}")))
    }

    /// The same figure as an RGB array (rows x columns x 3, uint8), for `render()`.
    #[pyo3(signature = (pixels = 400))]
    fn render_rgb<'py>(
        &self,
        py: Python<'py>,
        pixels: u32,
    ) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
        let pixmap = self.world_figure(pixels)?;
        let (w, h) = (pixmap.width() as usize, pixmap.height() as usize);
        // The figure is opaque, so its premultiplied RGBA is plain RGB and alpha.
        let rgb: Vec<u8> = pixmap
            .data()
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        PyArray1::from_vec(py, rgb).reshape([h, w, 3])
    }

    /// What the run did so far, as the JSON text of `summary.json`'s run part.
    fn summary_json(&self) -> String {
        let s = self.running.with_dependent(|_, live| live.sim.summary());
        serde_json::to_string(&s).unwrap_or_default()
    }
}

impl PySim {
    /// The world with the path driven so far and the robot where it is, `pixels` on its
    /// longer side (range-checked).
    fn world_figure(&self, pixels: u32) -> PyResult<radarnav::render::Pixmap> {
        let pixels = radarnav::limits::PIXELS
            .check(f64::from(pixels))
            .map_err(|m| value_err(format!("pixels: {m}")))? as u32;
        let mut fig = Figure::of_world(&self.scenario.world, None, pixels).map_err(value_err)?;
        fig.draw_path(&self.trail, [0, 160, 0], 2.0, "path");
        let truth = self.running.with_dependent(|_, live| live.sim.truth());
        fig.draw_robot(&truth, self.robot.vehicle);
        Ok(fig.finish(&self.scenario.name))
    }

    fn mapper(&self, name: &str) -> PyResult<&Mapper> {
        self.mappers
            .iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                PyKeyError::new_err(format!(
                    "no map `{name}`: pass maps=[\"{name}\"] to Sim (maps: {:?})",
                    self.map_sensors
                ))
            })
    }
}

/// What `radarnav run` does: the scenario's mission (or the teleop CSV `teleop`) recorded
/// into `out` (trajectory.csv, TUM files, summary.json, scan logs, maps, figures, MCAP);
/// returns `summary.json`'s text. Same scenario and seed: the same files as the CLI's.
#[pyfunction]
#[pyo3(signature = (scenario, out, seed = None, duration = None, robot = None, teleop = None, mcap = true, ros2_bag = false, maps = Some(Vec::new()), map_pose = "truth", pixels = 800))]
#[allow(clippy::too_many_arguments)]
fn run(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    out: &str,
    seed: Option<u64>,
    duration: Option<f64>,
    robot: Option<&str>,
    teleop: Option<&str>,
    mcap: bool,
    ros2_bag: bool,
    maps: Option<Vec<String>>,
    map_pose: &str,
    pixels: u32,
) -> PyResult<String> {
    let (scenario, base) = match scenario.cast::<PyScenario>() {
        Ok(s) => (Arc::clone(&s.get().inner), None),
        Err(_) => {
            let arg: String = scenario.extract()?;
            let base = Path::new(&arg)
                .is_file()
                .then(|| Path::new(&arg).parent().map(Path::to_owned))
                .flatten();
            (PyScenario::load(&arg)?.inner, base)
        }
    };
    if let Some(d) = duration {
        radarnav::limits::DURATION
            .check(d)
            .map_err(|m| value_err(format!("duration: {m}")))?;
    }
    let pixels = radarnav::limits::PIXELS
        .check(f64::from(pixels))
        .map_err(|m| value_err(format!("pixels: {m}")))? as u32;
    let map_pose = radarnav::map::PoseSource::parse(map_pose).ok_or_else(|| {
        value_err(format!(
            "map_pose `{map_pose}`: expected truth, odometry or slam"
        ))
    })?;
    let stop = AtomicBool::new(false);
    let out = PathBuf::from(out);
    let teleop = teleop.map(PathBuf::from);
    let defaults = radarnav::map::MapConfig::default();
    py.detach(|| {
        radarnav::run::record_run(
            &radarnav::run::RunRequest {
                scenario: &scenario,
                base: base.as_deref(),
                out: &out,
                robot,
                teleop: teleop.as_deref(),
                seed,
                duration,
                mcap,
                ros2_bag,
                pixels,
                maps: maps.as_deref(),
                map_pose,
                map_resolution: defaults.resolution,
                map_max_free_range: defaults.max_free_range,
                add_sensors: &[],
                slam_sensor: None,
                budget: radarnav::limits::budget::Budget::from_gb(None, None),
                stop: &stop,
            },
            &mut |_| {},
        )
    })
    .map_err(value_err)?;
    let summary = out.join("summary.json");
    std::fs::read_to_string(&summary)
        .map_err(|e| PyOSError::new_err(format!("{}: {e}", summary.display())))
}

/// Names of the built-in scenarios.
#[pyfunction]
fn builtins() -> Vec<String> {
    BUILTIN_SCENARIOS
        .iter()
        .chain(NAV_SUITE)
        .map(|(n, _)| (*n).to_owned())
        .collect()
}

/// Loads and checks a sweep spec; returns it as JSON with the scenario texts inside, ready to
/// send to other processes or machines.
#[pyfunction]
fn sweep_load(path: &str) -> PyResult<String> {
    Ok(Sweep::load(Path::new(path)).map_err(value_err)?.to_json())
}

/// Runs in a sweep (its JSON from `sweep_load`).
#[pyfunction]
fn sweep_runs(sweep_json: &str) -> PyResult<usize> {
    Ok(Sweep::from_json(sweep_json).map_err(value_err)?.runs())
}

/// Runs shard `index` of `count` of a sweep on all cores (the GIL released); returns the
/// shard file's JSON text (`shard-i-of-N.json`).
#[pyfunction]
fn sweep_shard(py: Python<'_>, sweep_json: &str, index: usize, count: usize) -> PyResult<String> {
    let shard: Shard = format!("{index}/{count}")
        .parse()
        .map_err(PyValueError::new_err)?;
    let sweep = Sweep::from_json(sweep_json).map_err(value_err)?;
    let table = py
        .detach(|| radarnav::sweep::run_shard(&sweep, shard, &AtomicBool::new(false), &|_, _| {}))
        .map_err(value_err)?;
    Ok(table.to_json())
}

/// Merges the shard files in `dirs` into `sweep.csv`, `sweep_groups.csv` and `sweep.png` in
/// `out`; returns their paths.
#[pyfunction]
fn sweep_merge(dirs: Vec<String>, out: &str) -> PyResult<Vec<String>> {
    let dirs: Vec<PathBuf> = dirs.into_iter().map(PathBuf::from).collect();
    let merged = radarnav::sweep::merge_dirs(&dirs).map_err(value_err)?;
    let paths = radarnav::sweep::write_merged(&merged, Path::new(out)).map_err(value_err)?;
    Ok(paths.iter().map(|p| p.display().to_string()).collect())
}

/// The `radarnav._core` module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScenario>()?;
    m.add_class::<PySim>()?;
    m.add_function(wrap_pyfunction!(builtins, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_load, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_runs, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_shard, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_merge, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
