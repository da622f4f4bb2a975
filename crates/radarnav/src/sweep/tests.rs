use std::sync::atomic::AtomicBool;

use super::*;

const SPEC: &str = r#"
scenarios = ["nav/box-goal"]
seeds = { first = 1, count = 2 }
duration = 60.0
[grid]
"mission.type" = ["bug1", "bug2"]
"sim.dt" = [0.05]
"#;

fn sweep() -> Sweep {
    Sweep::from_toml(SPEC, "sweeps/test.toml").unwrap()
}

#[test]
fn runs_are_scenario_major_then_grid_then_seed() {
    let s = sweep();
    assert_eq!(s.runs(), 4);
    assert_eq!(s.grid[0].0, "mission.type");
    let p = s.run_point(3);
    assert_eq!((p.scenario, p.point, p.seed), (0, 1, 2));
    assert_eq!(s.point_values(1)[0].as_str(), Some("bug2"));
}

#[test]
fn shards_are_strided_and_cover_every_run_once() {
    let s = sweep();
    let a = s.shard_runs("0/3".parse().unwrap());
    let b = s.shard_runs("1/3".parse().unwrap());
    let c = s.shard_runs("2/3".parse().unwrap());
    assert_eq!(a, vec![0, 3]);
    let mut all: Vec<usize> = a.into_iter().chain(b).chain(c).collect();
    all.sort_unstable();
    assert_eq!(all, (0..4).collect::<Vec<_>>());
}

#[test]
fn shard_syntax_is_checked() {
    for bad in ["3/3", "1", "a/2", "0/0", "-1/2"] {
        assert!(bad.parse::<Shard>().is_err(), "{bad}");
    }
    assert_eq!("2/5".parse::<Shard>(), Ok(Shard { index: 2, count: 5 }));
}

#[test]
fn grid_keys_pick_array_elements_by_name_or_index() {
    let mut doc: toml::Table = toml::from_str(
        "[[robot]]\nname = \"a\"\n[[robot.sensor]]\nname = \"radar\"\npreset = \"x\"\n",
    )
    .unwrap();
    set_path(&mut doc, "robot.a.sensor.radar.preset", "laser".into()).unwrap();
    set_path(&mut doc, "robot.0.sensor.0.rate_hz", 5.0.into()).unwrap();
    let sensor = &doc["robot"][0]["sensor"][0];
    assert_eq!(sensor["preset"].as_str(), Some("laser"));
    assert_eq!(sensor["rate_hz"].as_float(), Some(5.0));
    let e = set_path(&mut doc, "robot.b.start", 1.into()).unwrap_err();
    assert!(e.contains("no element named `b`"), "{e}");
}

#[test]
fn a_bad_grid_value_is_an_error_before_any_run() {
    let spec = SPEC.replace("[0.05]", "[0.05, 5.0]");
    let e = Sweep::from_toml(&spec, "sweeps/test.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("sweeps/test.toml: scenario `nav/box-goal` with"),
        "{e}"
    );
    assert!(e.contains("sim.dt = 5.0") && e.contains("dt"), "{e}");
}

#[test]
fn an_unknown_scenario_names_the_spec() {
    let e = Sweep::from_toml("scenarios = [\"nope\"]\nseeds = [1]\n", "s.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("s.toml") && e.contains("`nope`"), "{e}");
}

#[test]
fn merged_shards_equal_one_process_byte_for_byte() {
    let s = sweep();
    let stop = AtomicBool::new(false);
    let whole = run_shard(&s, Shard::ALL, &stop, &|_, _| {}).unwrap();
    let one = table::merge(vec![("all".into(), whole)]).unwrap();
    let parts: Vec<_> = (0..3)
        .map(|i| {
            let t = run_shard(&s, Shard { index: i, count: 3 }, &stop, &|_, _| {}).unwrap();
            (PathBuf::from(t.file_name()), t)
        })
        .collect();
    let three = table::merge(parts).unwrap();
    assert_eq!(table::runs_csv(&one), table::runs_csv(&three));
    assert_eq!(one.rows.len(), 4);
    assert!(
        one.rows.iter().all(|r| r.outcome == "reached"),
        "{:?}",
        one.rows
    );
}

#[test]
fn a_missing_shard_is_named_in_the_merge_error() {
    let s = sweep();
    let stop = AtomicBool::new(false);
    let t = run_shard(&s, Shard { index: 0, count: 2 }, &stop, &|_, _| {}).unwrap();
    let e = table::merge(vec![("a".into(), t)]).unwrap_err().to_string();
    assert!(e.contains("2 of 4 runs are missing (runs 1, 3)"), "{e}");
}

#[test]
fn a_sweep_travels_as_json() {
    let s = sweep();
    assert_eq!(Sweep::from_json(&s.to_json()).unwrap(), s);
}
