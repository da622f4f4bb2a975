//! `radarnav sweep SPEC [--shard i/N]` and `radarnav sweep merge DIR…`: argument handling
//! around [`radarnav::sweep`].

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use radarnav::sweep::{Shard, Sweep, merge_dirs, run_shard, write_merged};

/// Runs one shard of the sweep at `spec` (the whole sweep without `shard`, then merged into
/// `out`); `true` when a signal cut it short.
pub fn run(spec: &Path, shard: Option<Shard>, out: &Path) -> Result<bool> {
    let sweep = Sweep::load(spec)?;
    let whole = shard.is_none();
    let shard = shard.unwrap_or(Shard::ALL);
    let runs = sweep.shard_runs(shard).len();
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "sweep {}: {} runs ({} scenarios x {} grid points x {} seeds); shard {}/{}: {runs} runs",
        spec.display(),
        sweep.runs(),
        sweep.scenarios.len(),
        sweep.points(),
        sweep.seeds.len(),
        shard.index,
        shard.count
    )?;
    drop(stdout);
    let stop = crate::run_cmd::stop_flag()?;
    let bar = if std::io::stdout().is_terminal() {
        let bar = ProgressBar::new(runs as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs (eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let started = std::time::Instant::now();
    let table = run_shard(&sweep, shard, &stop, &|done, _| {
        bar.set_position(done as u64)
    })?;
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    let path = table.write(out)?;
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "{} of {runs} runs in {seconds:.1} s; wrote {}",
        table.rows.len(),
        path.display()
    )?;
    let interrupted = table.rows.len() < runs;
    if interrupted {
        writeln!(
            stdout,
            "interrupted: the shard file holds the finished runs; run the shard again to complete it"
        )?;
    } else if whole {
        let merged = merge_dirs(&[out.to_owned()])?;
        for p in write_merged(&merged, out)? {
            writeln!(stdout, "wrote {}", p.display())?;
        }
    } else {
        writeln!(
            stdout,
            "when every shard has run: radarnav sweep merge DIR... --out DIR"
        )?;
    }
    Ok(interrupted)
}

/// Merges the shard files in `dirs` into `out`.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let merged = merge_dirs(dirs).context("merging the sweep's shards")?;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{} runs merged", merged.rows.len())?;
    for p in write_merged(&merged, out)? {
        writeln!(stdout, "wrote {}", p.display())?;
    }
    Ok(())
}
