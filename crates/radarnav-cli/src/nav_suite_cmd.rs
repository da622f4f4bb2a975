//! `radarnav nav-suite`: Bug missions on maps nobody tuned the navigation to, both algorithms
//! × both sensors × both poses × seeds, each run judged against its map's geometry; prints
//! the pass table and writes every run to nav_suite.csv / nav_suite.json, and a figure of
//! each failed run to failed/.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use radarnav::Scenario;
use radarnav::map::PoseSource;
use radarnav::nav::BugAlgorithm;
use radarnav::record::write_whole;
use radarnav::render::save_png;
use radarnav::scenario::NAV_SUITE;
use radarnav::trials::{
    SensorClass, Trial, TrialMap, failures, grid, pass_table, results_csv, run_all,
};

/// What `nav-suite` was asked.
pub struct SuiteArgs<'a> {
    /// Scenario files or built-in names, or directories of .toml files; none: the built-in
    /// trial maps.
    pub scenarios: &'a [String],
    pub seeds: u64,
    pub algorithms: &'a [String],
    pub sensors: &'a [String],
    pub poses: &'a [String],
    pub out: Option<&'a Path>,
}

/// `radarnav nav-suite`.
pub fn nav_suite(a: &SuiteArgs<'_>, load: impl Fn(&str) -> Result<Scenario>) -> Result<()> {
    let mut scenarios = Vec::new();
    if a.scenarios.is_empty() {
        for (name, _) in NAV_SUITE {
            scenarios.push(load(name)?);
        }
    }
    for arg in a.scenarios {
        let path = Path::new(arg);
        if path.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(path)
                .with_context(|| format!("reading directory {arg}"))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "toml"))
                .collect();
            files.sort();
            if files.is_empty() {
                bail!("{arg}: no .toml scenario files in this directory");
            }
            for f in files {
                scenarios.push(load(&f.to_string_lossy())?);
            }
        } else {
            scenarios.push(load(arg)?);
        }
    }
    let maps = scenarios
        .into_iter()
        .map(|s| TrialMap::new(s).map_err(anyhow::Error::from))
        .collect::<Result<Vec<_>>>()?;
    let algorithms = pick(
        "--algorithms",
        a.algorithms,
        &[("bug1", BugAlgorithm::Bug1), ("bug2", BugAlgorithm::Bug2)],
    )?;
    let sensors = pick(
        "--sensors",
        a.sensors,
        &[("radar", SensorClass::Radar), ("laser", SensorClass::Laser)],
    )?;
    let poses = a
        .poses
        .iter()
        .map(|n| {
            PoseSource::parse(n)
                .with_context(|| format!("--poses: unknown `{n}`; known: truth, odometry"))
        })
        .collect::<Result<Vec<_>>>()?;
    let trials: Vec<Trial> = grid(&algorithms, &sensors, &poses, a.seeds);
    let total = (maps.len() * trials.len()) as u64;
    let bar = if std::io::stderr().is_terminal() {
        ProgressBar::new(total)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} ({eta} left) {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let failed_dir = a.out.map(|d| d.join("failed"));
    if let Some(dir) = &failed_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating output directory {}", dir.display()))?;
    }
    let figure_errors = std::sync::Mutex::new(Vec::new());
    let results = run_all(&maps, &trials, |map, r, paths| {
        bar.inc(1);
        if r.passed() {
            return;
        }
        bar.set_message(format!("last failure: {}", r.map));
        if let Some(dir) = &failed_dir {
            let name = format!("{}.png", r.label().replace(['/', ' '], "_"));
            let path = dir.join(name);
            if let Err(e) = map.figure(r, paths).and_then(|fig| save_png(&fig, &path))
                && let Ok(mut errors) = figure_errors.lock()
            {
                errors.push(e.to_string());
            }
        }
    })?;
    if let Some(e) = figure_errors
        .into_inner()
        .ok()
        .and_then(|e| e.into_iter().next())
    {
        bail!("writing a failed run's figure: {e}");
    }
    bar.finish_and_clear();
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{} maps × {} configurations: {} runs",
        maps.len(),
        trials.len(),
        results.len()
    )?;
    write!(out, "{}", pass_table(&results))?;
    let failed = failures(&results);
    if !failed.is_empty() {
        writeln!(out, "\nfailed runs:")?;
        for f in &failed {
            writeln!(out, "  {f}")?;
        }
    }
    if let Some(dir) = a.out {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating output directory {}", dir.display()))?;
        let csv = results_csv(&results);
        let path = dir.join("nav_suite.csv");
        write_whole(&path, csv.as_bytes())?;
        let json = serde_json::to_vec_pretty(&results)?;
        write_whole(&dir.join("nav_suite.json"), &json)?;
        writeln!(
            out,
            "wrote {} and nav_suite.json; a figure of each failed run in {}",
            path.display(),
            dir.join("failed").display()
        )?;
    }
    Ok(())
}

/// The values `names` stand for among `known` (name, value) pairs; an unknown name is an
/// error naming `flag` and the known names.
fn pick<T: Copy>(flag: &str, names: &[String], known: &[(&str, T)]) -> Result<Vec<T>> {
    names
        .iter()
        .map(|n| match known.iter().find(|(k, _)| k == n) {
            Some(&(_, v)) => Ok(v),
            None => {
                let list: Vec<&str> = known.iter().map(|(k, _)| *k).collect();
                bail!("{flag}: unknown `{n}`; known: {}", list.join(", "))
            }
        })
        .collect()
}
