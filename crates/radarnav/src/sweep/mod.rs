//! Sweeps (DESIGN §8): scenario × parameter grid × seed runs, cut into shards that run
//! anywhere (one process, a Slurm array, Ray tasks) and are merged into one table.
//!
//! A spec is a TOML file:
//!
//! ```toml
//! scenarios = ["foliage-wall", "my_map.toml"]   # built-ins, or files beside the spec
//! seeds = [1, 2, 3]                              # or { first = 1, count = 10 }
//! duration = 60.0                                # optional: every run's [sim] duration
//! [grid]                                         # optional: a scenario key = its values
//! "mission.algorithm" = ["bug1", "bug2"]
//! "material.foliage_light.radar_attenuation_db_per_m" = [1.0, 3.0]
//! ```
//!
//! A grid key is a dotted path into the scenario file; a part that meets an array of tables
//! (`[[robot]]`, `[[material]]`, `[[robot.sensor]]`) picks the element by its `name` or by
//! its 0-based index (`robot.p3at.sensor.radar.preset`, `object.0.material`). A key the file
//! does not have is added, so defaults can be swept too.
//!
//! Run `k` (0-based) is scenario-major, then the grid in key order (the last key fastest),
//! then seeds. Shard `i` of `N` holds the runs with `k mod N = i` (Python's `runs[i::N]`), so
//! every shard gets a like mix of scenarios. Each run is independent and deterministic, so
//! the merged table of any sharding equals the one-process table byte for byte.

mod plot;
mod table;

pub use table::{RunRow, ShardTable, merge_dirs, write_merged};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::limits;
use crate::scenario::{ScenarioError, builtin_source};
use crate::setup::Scenario;
use crate::sim::{NoObserver, RunSettings, Simulation};

/// Most runs in one sweep ([`limits::SWEEP_RUNS`]).
pub const MAX_RUNS: usize = limits::SWEEP_RUNS.max as usize;
/// Most shards a sweep is cut into ([`limits::SHARDS`]).
pub const MAX_SHARDS: usize = limits::SHARDS.max as usize;

/// A sweep that cannot be loaded, run or merged.
#[derive(Debug, Error)]
pub enum SweepError {
    /// The spec file is wrong: where and why.
    #[error("{file}: {message}")]
    Spec {
        /// The spec file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A scenario of the sweep, with one grid point applied, is wrong.
    #[error("{file}: scenario `{scenario}`{point}: {error}")]
    Scenario {
        /// The spec file.
        file: String,
        /// The scenario.
        scenario: String,
        /// The grid point applied (` with key = value, ...`), empty without a grid.
        point: String,
        /// The scenario's own error.
        error: Box<ScenarioError>,
    },
    /// A run could not start or finish.
    #[error("run {run} ({scenario}, seed {seed}): {message}")]
    Run {
        /// Run index.
        run: usize,
        /// Scenario.
        scenario: String,
        /// Seed.
        seed: u64,
        /// What went wrong.
        message: String,
    },
    /// Shard outputs that do not fit together.
    #[error("{0}")]
    Merge(String),
    /// A file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
}

/// Shard `index` of `count` (`"i/N"`, 0 ≤ i < N, as `$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`
/// of an array `--array=0-(N-1)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 0-based shard number.
    pub index: usize,
    /// Shards in all.
    pub count: usize,
}

impl Shard {
    /// The whole sweep as one shard.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// The output file stem of this shard: `shard-i-of-N`.
    pub fn stem(&self) -> String {
        format!("shard-{}-of-{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected i/N with 0 <= i < N <= {MAX_SHARDS}, found `{s}`");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || count > MAX_SHARDS || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// One scenario of a sweep, with its source text (so a spec travels whole to other
/// machines: see [`Sweep::to_json`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepScenario {
    /// Name as the spec gives it.
    pub name: String,
    /// Where it was read from (meshes and teleop files are looked for beside it).
    pub file: String,
    /// Its TOML text.
    pub source: String,
}

/// A loaded, checked sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sweep {
    /// The spec file (in error messages and the merged table's metadata).
    pub file: String,
    /// Scenarios in spec order.
    pub scenarios: Vec<SweepScenario>,
    /// Grid keys in order (sorted) and their values.
    pub grid: Vec<(String, Vec<toml::Value>)>,
    /// Seeds in spec order.
    pub seeds: Vec<u64>,
    /// Every run's duration, s (`None`: each scenario's own).
    pub duration: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    scenarios: Vec<String>,
    seeds: SeedsSpec,
    #[serde(default)]
    duration: Option<f64>,
    #[serde(default)]
    grid: BTreeMap<String, Vec<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum SeedsSpec {
    List(Vec<u64>),
    Range { first: u64, count: u64 },
}

/// What one run is: indices into the sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunPoint {
    /// Index of the run.
    pub run: usize,
    /// Index into [`Sweep::scenarios`].
    pub scenario: usize,
    /// Index into the grid's points (0 without a grid).
    pub point: usize,
    /// The seed.
    pub seed: u64,
}

impl Sweep {
    /// Reads and checks the spec at `path`; scenario files are read from beside it.
    pub fn load(path: &Path) -> Result<Sweep, SweepError> {
        let src = limits::read_text(path).map_err(|e| SweepError::Io {
            path: path.to_owned(),
            cause: e,
        })?;
        Self::from_toml(&src, &path.display().to_string())
    }

    /// Parses and checks a spec; `file` names it, and scenario files are looked for beside
    /// it. Every scenario is parsed at every grid point, so a bad value is found before any
    /// run starts.
    pub fn from_toml(src: &str, file: &str) -> Result<Sweep, SweepError> {
        let err = |message: String| SweepError::Spec {
            file: file.to_owned(),
            message,
        };
        let spec: SpecFile = toml::from_str(src).map_err(|e| {
            let at = e.span().map_or(String::new(), |s| {
                let line = src[..s.start.min(src.len())].matches('\n').count() + 1;
                format!("line {line}: ")
            });
            err(format!("{at}{}", e.message()))
        })?;
        let dir = Path::new(file).parent().unwrap_or(Path::new(""));
        if spec.scenarios.is_empty() {
            return Err(err("`scenarios` is empty".into()));
        }
        let scenarios = spec
            .scenarios
            .iter()
            .map(|name| {
                let path = dir.join(name);
                if path.is_file() {
                    let source = limits::read_text(&path).map_err(|e| SweepError::Io {
                        path: path.clone(),
                        cause: e,
                    })?;
                    Ok(SweepScenario {
                        name: name.clone(),
                        file: path.display().to_string(),
                        source,
                    })
                } else if let Some(source) = builtin_source(name) {
                    Ok(SweepScenario {
                        name: name.clone(),
                        file: format!("scenarios/{name}.toml"),
                        source: source.to_owned(),
                    })
                } else {
                    Err(err(format!(
                        "`scenarios`: `{name}` is neither a file beside the spec nor a built-in \
                         (see `radarnav scenarios`)"
                    )))
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let seeds = match spec.seeds {
            SeedsSpec::List(v) => v,
            SeedsSpec::Range { first, count } => {
                if count > limits::SEEDS.max as u64 {
                    return Err(err(format!(
                        "`seeds.count`: expected {}, found {count}",
                        limits::SEEDS.range()
                    )));
                }
                (0..count).map(|k| first.wrapping_add(k)).collect()
            }
        };
        if seeds.is_empty() {
            return Err(err("`seeds` is empty".into()));
        }
        if let Some(d) = spec.duration {
            limits::DURATION
                .check(d)
                .map_err(|m| err(format!("`duration`: {m}")))?;
        }
        for (key, values) in &spec.grid {
            if values.is_empty() {
                return Err(err(format!("`grid.\"{key}\"` has no values")));
            }
        }
        let sweep = Sweep {
            file: file.to_owned(),
            scenarios,
            grid: spec.grid.into_iter().collect(),
            seeds,
            duration: spec.duration,
        };
        let runs = sweep.runs_checked().ok_or_else(|| {
            err(format!(
                "the sweep has more than {MAX_RUNS} runs (scenarios x grid points x seeds)"
            ))
        })?;
        debug_assert!(runs > 0);
        for s in 0..sweep.scenarios.len() {
            for p in 0..sweep.points() {
                sweep.scenario(s, p)?;
            }
        }
        Ok(sweep)
    }

    /// The sweep as JSON, scenario texts included: what a Ray task or another machine needs.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// A sweep from [`Sweep::to_json`]'s text, checked again.
    pub fn from_json(src: &str) -> Result<Sweep, SweepError> {
        let sweep: Sweep = serde_json::from_str(src).map_err(|e| SweepError::Spec {
            file: "<sweep json>".into(),
            message: e.to_string(),
        })?;
        if sweep.runs_checked().is_none() || sweep.scenarios.is_empty() || sweep.seeds.is_empty() {
            return Err(SweepError::Spec {
                file: sweep.file,
                message: "no runs, or too many".into(),
            });
        }
        Ok(sweep)
    }

    /// Grid points (1 without a grid).
    pub fn points(&self) -> usize {
        self.grid.iter().map(|(_, v)| v.len()).product()
    }

    fn runs_checked(&self) -> Option<usize> {
        let n = self
            .scenarios
            .len()
            .checked_mul(self.points())?
            .checked_mul(self.seeds.len())?;
        (n <= MAX_RUNS).then_some(n)
    }

    /// Runs in all.
    pub fn runs(&self) -> usize {
        self.scenarios.len() * self.points() * self.seeds.len()
    }

    /// What run `k` is.
    pub fn run_point(&self, k: usize) -> RunPoint {
        let seeds = self.seeds.len();
        let points = self.points();
        RunPoint {
            run: k,
            scenario: k / (points * seeds),
            point: (k / seeds) % points,
            seed: self.seeds[k % seeds],
        }
    }

    /// The runs of `shard`, in order.
    pub fn shard_runs(&self, shard: Shard) -> Vec<usize> {
        (shard.index..self.runs()).step_by(shard.count).collect()
    }

    /// The grid values of point `p`, in key order.
    pub fn point_values(&self, p: usize) -> Vec<&toml::Value> {
        let mut rest = p;
        let mut out = vec![None; self.grid.len()];
        for (i, (_, values)) in self.grid.iter().enumerate().rev() {
            out[i] = Some(&values[rest % values.len()]);
            rest /= values.len();
        }
        out.into_iter().flatten().collect()
    }

    /// Scenario `s` with grid point `p` applied.
    pub fn scenario(&self, s: usize, p: usize) -> Result<Scenario, SweepError> {
        let sc = &self.scenarios[s];
        let values = self.point_values(p);
        let point: String = self
            .grid
            .iter()
            .zip(&values)
            .map(|((k, _), v)| format!("{k} = {v}"))
            .collect::<Vec<_>>()
            .join(", ");
        let point = if point.is_empty() {
            point
        } else {
            format!(" with {point}")
        };
        let wrap = |e: ScenarioError| SweepError::Scenario {
            file: self.file.clone(),
            scenario: sc.name.clone(),
            point: point.clone(),
            error: Box::new(e),
        };
        let stem = Path::new(&sc.file)
            .file_stem()
            .map_or(sc.name.clone(), |s| s.to_string_lossy().into_owned());
        let mut scenario = if self.grid.is_empty() {
            Scenario::from_toml(&sc.source, &sc.file, &stem).map_err(wrap)?
        } else {
            let mut doc: toml::Table = toml::from_str(&sc.source).map_err(|e| {
                wrap(ScenarioError {
                    file: sc.file.clone(),
                    line: 1,
                    column: 1,
                    key: None,
                    message: e.message().to_owned(),
                })
            })?;
            for ((key, _), value) in self.grid.iter().zip(&values) {
                set_path(&mut doc, key, (*value).clone()).map_err(|m| SweepError::Spec {
                    file: self.file.clone(),
                    message: format!("scenario `{}`: grid key `{key}`: {m}", sc.name),
                })?;
            }
            let text = toml::to_string(&doc).map_err(|e| SweepError::Spec {
                file: self.file.clone(),
                message: format!("scenario `{}`{point}: {e}", sc.name),
            })?;
            // Lines of an error count in the rewritten text, not the file: say so. The
            // message names the key and its range all the same.
            let file = format!("{} (rewritten with the grid point)", sc.file);
            Scenario::from_toml(&text, &file, &stem).map_err(wrap)?
        };
        if let Some(d) = self.duration {
            scenario.sim.duration = d;
        }
        Ok(scenario)
    }
}

/// Sets the value at the dotted `path` of `doc` (see the module doc).
fn set_path(doc: &mut toml::Table, path: &str, value: toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = path.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err("an empty part in the dotted key".into());
    }
    let mut table = doc;
    let mut i = 0;
    loop {
        let part = parts[i];
        if i + 1 == parts.len() {
            table.insert(part.to_owned(), value);
            return Ok(());
        }
        let entry = table
            .entry(part.to_owned())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        table = match entry {
            toml::Value::Table(t) => t,
            toml::Value::Array(items) => {
                i += 1;
                let pick = parts[i];
                let found = match pick.parse::<usize>() {
                    Ok(n) => items.get_mut(n),
                    Err(_) => items
                        .iter_mut()
                        .find(|v| v.get("name").and_then(|n| n.as_str()) == Some(pick)),
                };
                let Some(toml::Value::Table(t)) = found else {
                    return Err(format!(
                        "`{part}` has no element named `{pick}` (pick one by its name or its 0-based index)"
                    ));
                };
                if i + 1 == parts.len() {
                    return Err(format!("`{part}.{pick}` is a table; name a key inside it"));
                }
                t
            }
            _ => return Err(format!("`{part}` is a value, not a table")),
        };
        i += 1;
    }
}

/// Runs scenario `s`'s mission (or standing still) at grid point `p` with `seed`, headless.
/// The localiser runs only when the mission steers on it, as in the other batch runners.
pub fn run_one(sweep: &Sweep, point: RunPoint, stop: &AtomicBool) -> Result<RunRow, SweepError> {
    let fail = |message: String| SweepError::Run {
        run: point.run,
        scenario: sweep.scenarios[point.scenario].name.clone(),
        seed: point.seed,
        message,
    };
    let scenario = sweep.scenario(point.scenario, point.point)?;
    let base = Path::new(&sweep.scenarios[point.scenario].file).parent();
    let plan = crate::run::plan(&scenario, None, None, base, false, point.seed)
        .map_err(|e| fail(e.to_string()))?;
    let robot = crate::run::batch_robot(&plan, &scenario);
    let settings = RunSettings {
        seed: point.seed,
        ..RunSettings::of(&scenario)
    };
    let mut sim = Simulation::new(&scenario.world, &robot, plan.controller, settings)
        .map_err(|e| fail(e.to_string()))?;
    let Ok(summary) = sim.run_until(&mut NoObserver, stop);
    Ok(RunRow::new(sweep, point, &summary))
}

/// Runs the runs of `shard` on all cores, in order of their index. Runs cut short by `stop`
/// (Ctrl-C) are left out of the table, so a merge reports them missing; `done` is called with
/// (runs finished, runs in the shard) as they finish.
pub fn run_shard(
    sweep: &Sweep,
    shard: Shard,
    stop: &AtomicBool,
    done: &(dyn Fn(usize, usize) + Sync),
) -> Result<ShardTable, SweepError> {
    let runs = sweep.shard_runs(shard);
    let total = runs.len();
    let finished = std::sync::atomic::AtomicUsize::new(0);
    let rows = runs
        .par_iter()
        .map(|&k| {
            if stop.load(Ordering::Relaxed) {
                return Ok(None);
            }
            let row = run_one(sweep, sweep.run_point(k), stop)?;
            done(finished.fetch_add(1, Ordering::Relaxed) + 1, total);
            Ok((row.outcome != crate::sim::RunOutcome::Interrupted.as_str()).then_some(row))
        })
        .collect::<Result<Vec<_>, SweepError>>()?;
    Ok(ShardTable::new(
        sweep,
        shard,
        rows.into_iter().flatten().collect(),
    ))
}

#[cfg(test)]
mod tests;
