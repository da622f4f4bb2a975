//! A sweep's results: one row per run, shard files (`shard-i-of-N.json`) and the merged
//! table (`sweep.csv`, `sweep_groups.csv`, `sweep.png`).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{RunPoint, Shard, Sweep, SweepError};
use crate::sim::RunSummary;

/// What one run did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRow {
    /// Run index in the sweep.
    pub run: usize,
    /// Scenario name as the spec gives it.
    pub scenario: String,
    /// The grid values, in key order, as written in TOML (strings bare).
    pub params: Vec<String>,
    /// Seed.
    pub seed: u64,
    /// `reached`, `completed`, `no_path`, `timeout`.
    pub outcome: String,
    /// Simulated time, s.
    pub time_s: f64,
    /// Distance driven, m.
    pub distance_m: f64,
    /// Refused moves.
    pub bumps: usize,
    /// Odometry's distance from the truth at the end, m.
    pub odometry_error_m: f64,
    /// The localiser's distance from the truth at the end, m (runs that steer on it).
    pub slam_error_m: Option<f64>,
}

impl RunRow {
    /// The row of run `point` that ended with `summary`.
    pub fn new(sweep: &Sweep, point: RunPoint, summary: &RunSummary) -> Self {
        Self {
            run: point.run,
            scenario: sweep.scenarios[point.scenario].name.clone(),
            params: sweep
                .point_values(point.point)
                .into_iter()
                .map(|v| match v {
                    toml::Value::String(s) => s.clone(),
                    other => other.to_string(),
                })
                .collect(),
            seed: point.seed,
            outcome: summary.outcome.as_str().to_owned(),
            time_s: summary.duration,
            distance_m: summary.distance,
            bumps: summary.bumps,
            odometry_error_m: summary.odometry_error,
            slam_error_m: summary.slam.as_ref().map(|s| s.error),
        }
    }

    /// Whether the mission did what it was for.
    pub fn succeeded(&self) -> bool {
        self.outcome == "reached" || self.outcome == "completed"
    }
}

/// What one shard ran: written as `shard-i-of-N.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardTable {
    /// The spec file.
    pub spec: String,
    /// A fingerprint of the whole sweep (spec and scenario texts): shards of different
    /// sweeps are not merged.
    pub fingerprint: String,
    /// Runs in the whole sweep.
    pub runs_total: usize,
    /// Which shard.
    pub shard: Shard,
    /// Grid keys, the columns between `scenario` and `seed`.
    pub keys: Vec<String>,
    /// Rows of the runs that finished, by run index.
    pub rows: Vec<RunRow>,
}

/// FNV-1a, 64 bits: stable across Rust versions and machines, unlike `DefaultHasher`.
fn fingerprint(text: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

impl ShardTable {
    /// The table of `shard` of `sweep` with `rows`.
    pub fn new(sweep: &Sweep, shard: Shard, rows: Vec<RunRow>) -> Self {
        // The spec's own path differs between machines; the sweep is what it holds.
        let sweep_only = Sweep {
            file: String::new(),
            ..sweep.clone()
        };
        Self {
            spec: sweep.file.clone(),
            fingerprint: fingerprint(&sweep_only.to_json()),
            runs_total: sweep.runs(),
            shard,
            keys: sweep.grid.iter().map(|(k, _)| k.clone()).collect(),
            rows,
        }
    }

    /// The file name this shard is written as.
    pub fn file_name(&self) -> String {
        format!("{}.json", self.shard.stem())
    }

    /// The shard as JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Writes the shard into `dir` (created if missing), whole or not at all; returns its path.
    pub fn write(&self, dir: &Path) -> Result<PathBuf, SweepError> {
        std::fs::create_dir_all(dir).map_err(|e| SweepError::Io {
            path: dir.to_owned(),
            cause: e,
        })?;
        let path = dir.join(self.file_name());
        crate::output::write_whole(&path, self.to_json().as_bytes()).map_err(|e| {
            SweepError::Io {
                path: path.clone(),
                cause: e,
            }
        })?;
        Ok(path)
    }
}

/// Shards joined into one table, rows by run index.
#[derive(Clone, Debug, PartialEq)]
pub struct Merged {
    /// The spec file of the first shard.
    pub spec: String,
    /// Grid keys.
    pub keys: Vec<String>,
    /// Every run's row, by run index.
    pub rows: Vec<RunRow>,
}

/// Joins shard tables: they must come from one sweep and hold every run exactly once.
pub fn merge(shards: Vec<(PathBuf, ShardTable)>) -> Result<Merged, SweepError> {
    let Some((first_path, first)) = shards.first() else {
        return Err(SweepError::Merge(
            "no shard files (shard-*-of-*.json) found".into(),
        ));
    };
    let mut rows: Vec<Option<RunRow>> = vec![None; first.runs_total];
    for (path, t) in &shards {
        if t.fingerprint != first.fingerprint || t.runs_total != first.runs_total {
            return Err(SweepError::Merge(format!(
                "{} is from another sweep than {} (spec {} against {})",
                path.display(),
                first_path.display(),
                t.spec,
                first.spec
            )));
        }
        for row in &t.rows {
            let slot = rows.get_mut(row.run).ok_or_else(|| {
                SweepError::Merge(format!(
                    "{}: run {} is beyond the sweep's {} runs",
                    path.display(),
                    row.run,
                    t.runs_total
                ))
            })?;
            match slot {
                Some(other) if other != row => {
                    return Err(SweepError::Merge(format!(
                        "{}: run {} differs from the same run in another shard file",
                        path.display(),
                        row.run
                    )));
                }
                _ => *slot = Some(row.clone()),
            }
        }
    }
    let missing: Vec<usize> = (rows.iter().enumerate())
        .filter(|(_, r)| r.is_none())
        .map(|(k, _)| k)
        .collect();
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(10).map(usize::to_string).collect();
        return Err(SweepError::Merge(format!(
            "{} of {} runs are missing (runs {}{}): a shard was not run, or was interrupted; \
             run it again with its --shard i/N",
            missing.len(),
            first.runs_total,
            shown.join(", "),
            if missing.len() > 10 { ", ..." } else { "" }
        )));
    }
    Ok(Merged {
        spec: first.spec.clone(),
        keys: first.keys.clone(),
        rows: rows.into_iter().flatten().collect(),
    })
}

/// Reads every `shard-*-of-*.json` in `dirs` and merges them.
pub fn merge_dirs(dirs: &[PathBuf]) -> Result<Merged, SweepError> {
    let mut shards = Vec::new();
    for dir in dirs {
        let io = |e| SweepError::Io {
            path: dir.clone(),
            cause: e,
        };
        let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(io)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                    n.starts_with("shard-") && n.contains("-of-") && n.ends_with(".json")
                })
            })
            .collect();
        names.sort();
        for path in names {
            let text = crate::limits::read_text(&path).map_err(|e| SweepError::Io {
                path: path.clone(),
                cause: e,
            })?;
            let table: ShardTable = serde_json::from_str(&text).map_err(|e| {
                SweepError::Merge(format!("{}: not a sweep shard file: {e}", path.display()))
            })?;
            shards.push((path, table));
        }
    }
    merge(shards)
}

/// CSV field: quoted when it holds a comma, a quote or a line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// Appends `,field` for each of `fields`.
fn push_fields(out: &mut String, fields: &[String]) {
    for f in fields {
        out.push(',');
        out.push_str(&field(f));
    }
}

/// One row per run: `sweep.csv`.
pub fn runs_csv(m: &Merged) -> String {
    let mut out = String::from("run,scenario");
    push_fields(&mut out, &m.keys);
    out.push_str(",seed,outcome,time_s,distance_m,bumps,odometry_error_m,slam_error_m\n");
    for r in &m.rows {
        out.push_str(&format!("{},{}", r.run, field(&r.scenario)));
        push_fields(&mut out, &r.params);
        out.push_str(&format!(
            ",{},{},{:.3},{:.3},{},{:.4},{}\n",
            r.seed,
            r.outcome,
            r.time_s,
            r.distance_m,
            r.bumps,
            r.odometry_error_m,
            r.slam_error_m.map_or(String::new(), |e| format!("{e:.4}"))
        ));
    }
    out
}

/// The runs of one scenario at one grid point, over the seeds.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// `scenario` then `key=value` for each grid key.
    pub label: String,
    /// Scenario.
    pub scenario: String,
    /// Grid values.
    pub params: Vec<String>,
    /// Runs.
    pub runs: usize,
    /// Runs that reached their goal or completed their mission.
    pub succeeded: usize,
    /// Runs that proved no path.
    pub no_path: usize,
    /// Mean simulated time, s.
    pub mean_time_s: f64,
    /// Mean distance, m.
    pub mean_distance_m: f64,
    /// Mean bumps.
    pub mean_bumps: f64,
}

/// The groups of `m`, in run order.
pub fn groups(m: &Merged) -> Vec<Group> {
    let mut out: Vec<Group> = Vec::new();
    for r in &m.rows {
        let i = match out
            .iter()
            .position(|g| g.scenario == r.scenario && g.params == r.params)
        {
            Some(i) => i,
            None => {
                let label = std::iter::once(r.scenario.clone())
                    .chain(m.keys.iter().zip(&r.params).map(|(k, v)| {
                        let short = k.rsplit('.').next().unwrap_or(k);
                        format!("{short}={v}")
                    }))
                    .collect::<Vec<_>>()
                    .join(" ");
                out.push(Group {
                    label,
                    scenario: r.scenario.clone(),
                    params: r.params.clone(),
                    runs: 0,
                    succeeded: 0,
                    no_path: 0,
                    mean_time_s: 0.0,
                    mean_distance_m: 0.0,
                    mean_bumps: 0.0,
                });
                out.len() - 1
            }
        };
        let g = &mut out[i];
        g.runs += 1;
        g.succeeded += usize::from(r.succeeded());
        g.no_path += usize::from(r.outcome == "no_path");
        g.mean_time_s += r.time_s;
        g.mean_distance_m += r.distance_m;
        g.mean_bumps += r.bumps as f64;
    }
    for g in &mut out {
        let n = g.runs as f64;
        g.mean_time_s /= n;
        g.mean_distance_m /= n;
        g.mean_bumps /= n;
    }
    out
}

/// One row per scenario and grid point: `sweep_groups.csv`.
pub fn groups_csv(m: &Merged) -> String {
    let mut out = String::from("scenario");
    push_fields(&mut out, &m.keys);
    out.push_str(",runs,succeeded,success_rate,no_path,mean_time_s,mean_distance_m,mean_bumps\n");
    for g in groups(m) {
        out.push_str(&field(&g.scenario));
        push_fields(&mut out, &g.params);
        out.push_str(&format!(
            ",{},{},{:.3},{},{:.3},{:.3},{:.3}\n",
            g.runs,
            g.succeeded,
            g.succeeded as f64 / g.runs as f64,
            g.no_path,
            g.mean_time_s,
            g.mean_distance_m,
            g.mean_bumps
        ));
    }
    out
}

/// Writes `sweep.csv`, `sweep_groups.csv` and `sweep.png` into `dir`; returns their paths.
pub fn write_merged(m: &Merged, dir: &Path) -> Result<Vec<PathBuf>, SweepError> {
    std::fs::create_dir_all(dir).map_err(|e| SweepError::Io {
        path: dir.to_owned(),
        cause: e,
    })?;
    let png = super::plot::groups_png(&m.spec, &groups(m))?;
    let mut written = Vec::new();
    for (name, bytes) in [
        ("sweep.csv", runs_csv(m).into_bytes()),
        ("sweep_groups.csv", groups_csv(m).into_bytes()),
        ("sweep.png", png),
    ] {
        let path = dir.join(name);
        crate::output::write_whole(&path, &bytes).map_err(|e| SweepError::Io {
            path: path.clone(),
            cause: e,
        })?;
        written.push(path);
    }
    Ok(written)
}
