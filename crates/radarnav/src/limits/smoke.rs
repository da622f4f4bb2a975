//! A short run of a scenario as `radarnav run` makes it, without files: what the fuzz
//! target `scenario` drives (see `fuzz/README.md`), so that any input that parses is also
//! built, checked against the [`super::budget`] and stepped.

use crate::Scenario;
use crate::map::{MapConfig, Mapper};
use crate::nav::Idle;
use crate::sim::{Controller, RunSettings, Simulation};

use super::budget::{self, Budget};

/// Parses `src`; if it is a scenario, runs its first robot's mission for `steps` steps with
/// a map per sensor (within the default budget; scoring is left to the mutation test, which
/// runs the whole command). Returns whether it ran.
/// Errors are the point of the input, not of this function: they are swallowed; a panic,
/// an abort or a hang is what a fuzzer looks for.
pub fn parse_and_run(src: &str, steps: u64) -> bool {
    let Ok(s) = Scenario::from_toml(src, "fuzz.toml", "fuzz") else {
        return false;
    };
    let Some(robot) = s.robot(s.mission.as_ref().and_then(|m| m.robot.as_deref())) else {
        return false;
    };
    let controller: Box<dyn Controller> = match s.mission.as_ref().map(|m| m.controller(1)) {
        Some(Ok(c)) => c,
        _ => Box::new(Idle { rate_hz: 10.0 }),
    };
    let config = MapConfig::default();
    let region = budget::map_region(&s.world, robot, config.max_free_range, config.max_range);
    let mut maps: Vec<Mapper> = robot
        .sensors
        .iter()
        .filter_map(|m| Mapper::new(&m.name, robot, &[m.name.as_str()], config).ok())
        .collect();
    let fits = Budget::default()
        .check_maps(maps.iter().map(Mapper::name), region, config.resolution)
        .is_ok();
    if !fits {
        maps.clear();
    }
    for m in &mut maps {
        m.limit_to(region);
    }
    let settings = RunSettings {
        duration: s.sim.dt * steps as f64,
        ..RunSettings::of(&s)
    };
    let Ok(mut sim) = Simulation::new(&s.world, robot, controller, settings) else {
        return false;
    };
    let Ok(_) = sim.run(&mut maps.as_mut_slice());
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::BUILTIN_SCENARIOS;

    #[test]
    fn every_shipped_scenario_runs_a_few_steps() {
        for (name, src) in BUILTIN_SCENARIOS {
            assert!(parse_and_run(src, 3), "{name}");
        }
        assert!(!parse_and_run("[sim]\ndt = 1e-9\n", 3));
    }
}
