//! `radarnav serve`: the USARSim server over a scenario.

use std::net::TcpListener;

use anyhow::{Context, Result};
use radarnav::Scenario;
use radarnav::usarsim::server::{ServeOptions, serve};

/// Serves `scenario` on `bind:port` until Ctrl-C; every client may place a robot like the
/// scenario's `robot` (default: the first).
pub fn run(
    scenario: &Scenario,
    robot: Option<&str>,
    bind: &str,
    port: u16,
    speed: f64,
) -> Result<()> {
    let template = radarnav::run::robot_of(scenario, robot)?;
    let listener =
        TcpListener::bind((bind, port)).with_context(|| format!("listening on {bind}:{port}"))?;
    let addr = listener.local_addr().context("listening socket")?;
    let sensors: Vec<String> = template
        .sensors
        .iter()
        .map(|s| format!("{} ({:.0} Hz)", s.name, s.config.rate_hz))
        .collect();
    eprintln!(
        "serving {} on {addr} at {speed}x real time: each client may INIT a USARBot.P3AT with \
         RangeScanner {} and GndTruth, Odometer (10 Hz); Ctrl-C stops",
        scenario.name,
        sensors.join(", ")
    );
    let stop = crate::run_cmd::stop_flag()?;
    let log = |line: String| eprintln!("{line}");
    let options = ServeOptions {
        speed,
        seed: scenario.sim.seed,
    };
    serve(&listener, scenario, template, options, &stop, &log)?;
    eprintln!("stopped");
    Ok(())
}
