//! The `radarnav` binary end to end: files written, same seed same bytes, clear errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn radarnav(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_radarnav"))
        .args(args)
        .output()
        .expect("run radarnav")
}

/// Runs radarnav and asserts it succeeded, showing its stderr if not.
fn radarnav_ok(args: &[&str]) -> Output {
    let out = radarnav(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn read(dir: &Path, file: &str) -> Vec<u8> {
    std::fs::read(dir.join(file)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(file).display()))
}

#[test]
fn scan_writes_files_and_same_seed_gives_same_bytes() {
    let (a, b, c) = (tmp("scan-a"), tmp("scan-b"), tmp("scan-c"));
    for (dir, seed) in [(&a, "5"), (&b, "5"), (&c, "6")] {
        radarnav_ok(&[
            "scan",
            "foliage-wall",
            "--sensor",
            "radar_thesis_n100",
            "--seed",
            seed,
            "--pose",
            "2.5,3,10",
            "--out",
            dir.to_str().unwrap(),
        ]);
    }
    for f in ["scan.json", "scan.csv", "scan.png"] {
        assert_eq!(read(&a, f), read(&b, f), "{f} differs for the same seed");
    }
    assert_ne!(
        read(&a, "scan.json"),
        read(&c, "scan.json"),
        "a new seed draws new side beams"
    );
    let json: serde_json::Value = serde_json::from_slice(&read(&a, "scan.json")).unwrap();
    assert_eq!(json["scan"]["ranges"].as_array().unwrap().len(), 360);
    assert_eq!(json["config"]["side_beam_offset"].as_f64(), Some(0.4));
    let csv = String::from_utf8(read(&a, "scan.csv")).unwrap();
    assert_eq!(csv.lines().count(), 361);
    assert!(csv.starts_with("index,azimuth_deg,elevation_deg,range_m,hit,material,beam\n"));
}

#[test]
fn demo_writes_the_four_figures_and_the_table() {
    let dir = tmp("demo");
    let out = radarnav_ok(&["demo", "--out", dir.to_str().unwrap(), "--repeats", "3"]);
    for f in [
        "fig7_laser",
        "fig8_radar",
        "fig9_radar_n50",
        "fig10_radar_n100",
        "ground_truth",
    ] {
        assert!(
            read(&dir, &format!("{f}.png")).starts_with(b"\x89PNG"),
            "{f}"
        );
    }
    let table = String::from_utf8(out.stdout).unwrap();
    let share = |fig: &str| -> f64 {
        let line = table
            .lines()
            .find(|l| l.starts_with(fig))
            .unwrap_or_else(|| panic!("{table}"));
        line.split_whitespace()
            .last()
            .unwrap()
            .trim_end_matches('%')
            .parse()
            .unwrap()
    };
    assert_eq!(share("fig7_laser"), 0.0);
    assert!(
        share("fig8_radar") > 0.0 && share("fig10_radar_n100") > 0.0,
        "{table}"
    );
    // The mapping half: a row per map; the radar reveals much of the hidden area, the laser
    // none of it.
    let hidden = |map: &str, pose: &str| -> f64 {
        let line = table
            .lines()
            .find(|l| l.split_whitespace().take(2).eq([map, pose]))
            .unwrap_or_else(|| panic!("{table}"));
        let open = line.find('(').unwrap();
        let close = line.find("%)").unwrap();
        line[open + 1..close].parse().unwrap()
    };
    assert_eq!(hidden("laser", "truth"), 0.0);
    assert!(hidden("radar", "truth") > 50.0, "{table}");
    assert!(hidden("radar", "odometry") > 50.0, "{table}");
    for stem in [
        "map_radar",
        "map_laser",
        "map_radar_odometry",
        "map_laser_odometry",
    ] {
        assert!(read(&dir, &format!("{stem}.png")).starts_with(b"\x89PNG"));
        assert!(read(&dir, &format!("{stem}.pgm")).starts_with(b"P5\n"));
        let yaml = String::from_utf8(read(&dir, &format!("{stem}.yaml"))).unwrap();
        assert!(yaml.contains(&format!("image: {stem}.pgm")), "{yaml}");
        assert!(read(&dir, &format!("{stem}.npy")).starts_with(b"\x93NUMPY"));
    }
    // The Bug half: both reach the goal behind the hedge with the radar, without a bump.
    for algo in ["bug1", "bug2"] {
        let line = table
            .lines()
            .find(|l| l.starts_with(algo))
            .unwrap_or_else(|| panic!("{table}"));
        let cols: Vec<&str> = line.split_whitespace().collect();
        assert_eq!((cols[1], cols[6]), ("reached", "0"), "{line}");
        assert!(read(&dir, &format!("{algo}_radar.png")).starts_with(b"\x89PNG"));
    }
}

#[test]
fn run_a_bug_mission_reports_its_navigation() {
    let dir = tmp("bug");
    let out = radarnav_ok(&[
        "run",
        "bug1-enclosed",
        "--out",
        dir.to_str().unwrap(),
        "--no-mcap",
        "--no-maps",
    ]);
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("navigation: bug1:"), "{stdout}");
    let v: serde_json::Value = serde_json::from_slice(&read(&dir, "summary.json")).unwrap();
    assert_eq!(v["outcome"], "no_path");
    assert_eq!(v["mission"], "bug1");
    assert_eq!(v["bumps"], 0);
    let nav = &v["navigation"];
    assert_eq!(nav["algorithm"], "bug1");
    // One hit per attempt: the first, then each standoff retry before `no_path` is believed.
    let retries = nav["retries"].as_array().unwrap().len();
    assert!(retries >= 1, "{nav}");
    assert_eq!(nav["hit_points"].as_array().unwrap().len(), 1 + retries);
    assert!(nav["safety"].as_f64().unwrap() < 1.27, "{nav}");
    // The last retry keeps the floor standoff and follows the other side; the ones before
    // keep the mission's side.
    let r = nav["retries"].as_array().unwrap();
    let follow = |i: usize| r[i]["follow"].as_str().unwrap();
    assert!(retries >= 2, "{nav}");
    assert!((0..retries - 1).all(|i| follow(i) == follow(0)), "{nav}");
    assert_ne!(follow(retries - 1), follow(0), "{nav}");
    assert_eq!(r[retries - 1]["safety"], r[retries - 2]["safety"], "{nav}");
    assert!(nav["boundary_distance"].as_f64().unwrap() > 20.0, "{nav}");
}

#[test]
fn run_an_exploration_records_coverage_against_distance() {
    let dir = tmp("explore");
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/foliage-wall.toml"
    ))
    .unwrap();
    let cut = src.find("[mission]").unwrap();
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("explore.toml");
    std::fs::write(
        &file,
        format!("{}[mission]\nexplore = \"wall_follow\"\n", &src[..cut]),
    )
    .unwrap();
    radarnav_ok(&[
        "run",
        file.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
        "--no-mcap",
        "--duration",
        "30",
    ]);
    let csv = String::from_utf8(read(&dir, "coverage.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("map,time,distance,free_coverage,hidden_coverage")
    );
    let radar: Vec<Vec<f64>> = lines
        .filter(|l| l.starts_with("radar,"))
        .map(|l| l.split(',').skip(1).map(|x| x.parse().unwrap()).collect())
        .collect();
    // One sample a second, 0 to 30 s; distance and coverage never decrease much.
    assert_eq!(radar.len(), 31, "{csv}");
    assert!(radar.windows(2).all(|w| w[1][1] >= w[0][1]), "{csv}");
    let last = radar.last().unwrap();
    assert!(
        last[1] > 5.0 && last[3] > 0.3,
        "radar sees behind the hedge: {last:?}"
    );
    assert!(
        csv.lines()
            .filter(|l| l.starts_with("laser,"))
            .all(|l| l.ends_with(",0.00000")),
        "{csv}"
    );
}

#[test]
fn compare_writes_the_csvs_the_plot_and_a_table_and_rejects_bad_input() {
    let dir = tmp("compare");
    let out = radarnav_ok(&[
        "compare",
        "foliage-wall",
        "--strategies",
        "bounce,frontier",
        "--sensors",
        "radar,laser",
        "--seeds",
        "2",
        "--duration",
        "20",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let table = String::from_utf8(out.stdout).unwrap();
    for key in [
        "bounce / radar",
        "bounce / laser",
        "frontier / radar",
        "frontier / laser",
    ] {
        assert!(table.lines().any(|l| l.starts_with(key)), "{table}");
    }
    let runs = String::from_utf8(read(&dir, "compare_runs.csv")).unwrap();
    assert_eq!(runs.lines().count(), 1 + 2 * 2 * 2, "{runs}");
    let samples = String::from_utf8(read(&dir, "compare.csv")).unwrap();
    assert!(
        samples.starts_with("strategy,sensor,seed,time,distance,free_coverage,hidden_coverage\n")
    );
    assert!(
        samples
            .lines()
            .filter(|l| l.starts_with("bounce,radar,2,"))
            .count()
            >= 21,
        "{samples}"
    );
    assert!(read(&dir, "compare.png").starts_with(b"\x89PNG"));
    // Same seeds, same numbers.
    let again = tmp("compare-again");
    radarnav_ok(&[
        "compare",
        "foliage-wall",
        "--strategies",
        "bounce,frontier",
        "--seeds",
        "2",
        "--duration",
        "20",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert_eq!(read(&again, "compare.csv"), read(&dir, "compare.csv"));
    for (args, want) in [
        (
            &["compare", "foliage-wall", "--strategies", "zigzag"][..],
            "unknown strategy `zigzag`",
        ),
        (
            &["compare", "foliage-wall", "--sensors", "sonar"][..],
            "no sensor `sonar`",
        ),
        (
            &["compare", "foliage-wall", "--seeds", "0"][..],
            "invalid value '0' for '--seeds <SEEDS>': expected 1 to 10000, found 0",
        ),
        (
            &["compare", "foliage-wall", "--safety", "0"][..],
            "--safety",
        ),
    ] {
        let o = radarnav(args);
        assert!(!o.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(want), "{args:?}: {err}");
    }
}

#[test]
fn errors_are_reported_with_location_and_exit_code_one() {
    let dir = tmp("errors");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[object]]\nmaterial = \"wood\"\nsphere = { center = [1, 2], radius = 0 }\n",
    )
    .unwrap();
    let out = radarnav(&[
        "render",
        bad.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        err.contains("bad.toml:3:38: `radius`: expected 0.001 to 10000 m, found 0"),
        "{err}"
    );
    for args in [
        &["scan", "no-such-scenario", "--sensor", "radar"][..],
        &["scan", "foliage-wall", "--sensor", "velodyne"],
        &["scan", "foliage-wall", "--sensor", "radar", "--pose", "1,2"],
        &["render", dir.join("missing.toml").to_str().unwrap()],
    ] {
        let out = radarnav(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.starts_with("error: ") && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn listings() {
    let out = radarnav(&["scenarios"]);
    let text = String::from_utf8(out.stdout).unwrap();
    for name in ["foliage-wall", "smoke-room", "open-field"] {
        assert!(text.contains(name), "{text}");
    }
    let out = radarnav(&["presets"]);
    assert!(
        String::from_utf8(out.stdout)
            .unwrap()
            .contains("radar_thesis_n50")
    );
}

/// Every file of a run directory, by relative path.
fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn run_writes_every_file_and_is_deterministic() {
    let (a, b, c) = (tmp("run-a"), tmp("run-b"), tmp("run-c"));
    for (dir, seed) in [(&a, "3"), (&b, "3"), (&c, "4")] {
        let out = radarnav_ok(&[
            "run",
            "foliage-wall",
            "--duration",
            "4",
            "--seed",
            seed,
            "--out",
            dir.to_str().unwrap(),
        ]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("mission waypoints"), "{text}");
    }
    let (ta, tb, tc) = (tree(&a), tree(&b), tree(&c));
    let names: Vec<&str> = ta.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "map_laser.npy",
            "map_laser.pgm",
            "map_laser.png",
            "map_laser.yaml",
            "map_radar.npy",
            "map_radar.pgm",
            "map_radar.png",
            "map_radar.yaml",
            "odometry.tum",
            "path.png",
            "run.mcap",
            "scans/laser.rnscan",
            "scans/radar.rnscan",
            "slam.tum",
            "summary.json",
            "trajectory.csv",
            "truth.tum"
        ]
    );
    assert!(ta == tb, "same seed, different bytes");
    // Another seed changes the odometry noise and side beams, not the world.
    let differs = |name: &str| {
        let f = |t: &[(String, Vec<u8>)]| t.iter().find(|(n, _)| n == name).unwrap().1.clone();
        f(&ta) != f(&tc)
    };
    assert!(differs("trajectory.csv") && differs("scans/radar.rnscan"));
}

#[test]
fn run_with_a_teleop_csv_and_clear_errors() {
    let dir = tmp("run-teleop");
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("drive.csv");
    std::fs::write(&csv, "duration,left,right\n1.0,0.3,0.3\n0.5,-0.2,0.2\n").unwrap();
    radarnav_ok(&[
        "run",
        "foliage-wall",
        "--teleop",
        csv.to_str().unwrap(),
        "--no-mcap",
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let summary: serde_json::Value =
        serde_json::from_slice(&read(&dir.join("out"), "summary.json")).unwrap();
    assert_eq!(summary["outcome"], "completed");
    assert!((summary["duration"].as_f64().unwrap() - 1.5).abs() < 1e-9);
    assert!((summary["distance"].as_f64().unwrap() - 0.3).abs() < 1e-9);
    assert!(!dir.join("out/run.mcap").exists());
    // --maps picks the maps; --map-pose the pose.
    radarnav_ok(&[
        "run",
        "foliage-wall",
        "--teleop",
        csv.to_str().unwrap(),
        "--no-mcap",
        "--maps",
        "radar+laser",
        "--map-pose",
        "odometry",
        "--out",
        dir.join("fused").to_str().unwrap(),
    ]);
    let summary: serde_json::Value =
        serde_json::from_slice(&read(&dir.join("fused"), "summary.json")).unwrap();
    assert_eq!(summary["maps"].as_array().unwrap().len(), 1);
    assert_eq!(summary["maps"][0]["name"], "radar+laser");
    assert_eq!(summary["maps"][0]["pose"], "odometry");
    assert!(dir.join("fused/map_radar+laser.pgm").exists());
    for (args, want) in [
        (
            &["--maps", "radar,sonar"][..],
            "robot `p3at` has no sensor `sonar` (it has: radar, laser)",
        ),
        (&["--maps", "radar,radar"], "names the map `radar` twice"),
        (
            &["--map-pose", "gps"],
            "--map-pose `gps`: expected `truth`, `odometry` or `slam`",
        ),
        (&["--maps", "radar+radar"], "names the sensor `radar` twice"),
    ] {
        let mut all = vec![
            "run",
            "foliage-wall",
            "--duration",
            "0.5",
            "--no-mcap",
            "--out",
        ];
        let o = dir.join("bad-map");
        all.push(o.to_str().unwrap());
        all.extend_from_slice(args);
        let out = radarnav(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
    // Out-of-range flags are usage errors (exit 2), refused before anything is written.
    for (args, want) in [
        (
            &["--map-resolution", "0"][..],
            "expected 0.005 to 10 m, found 0",
        ),
        (
            &["--map-resolution", "1e308"],
            "expected 0.005 to 10 m, found 1e308",
        ),
        (
            &["--map-resolution", "1e-6"],
            "expected 0.005 to 10 m, found 1e-6",
        ),
        (&["--duration", "1e9"], "expected 0.001 to 1e6 s, found 1e9"),
        (
            &["--pixels", "100000"],
            "expected 16 to 8192 px, found 100000",
        ),
    ] {
        let o = dir.join("bad-flag");
        let mut all = vec!["run", "foliage-wall", "--out", o.to_str().unwrap()];
        all.extend_from_slice(args);
        let out = radarnav(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!o.exists(), "{args:?} wrote {}", o.display());
    }

    std::fs::write(&csv, "duration,left,right\n1.0,0.3,0.3\n1.0,0.3\n").unwrap();
    let out = radarnav(&["run", "foliage-wall", "--teleop", csv.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("drive.csv:3: expected 3 fields, found 2"),
        "{err}"
    );

    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[robot]]\nname = \"r\"\nstart = { x = 1, y = 1 }\n[mission]\ntype = \"dance\"\n",
    )
    .unwrap();
    let out = radarnav(&["run", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.toml:5:8: `type`: unknown mission type `dance`"),
        "{err}"
    );
}

#[test]
fn bench_exports_a_scene_and_traces_its_rays_for_the_peers() {
    let dir = tmp("peers-scene");
    let d = dir.to_str().unwrap();
    let args = [
        "bench", "--export", d, "--forest", "300", "--side", "40", "--radius", "0.3,1.0",
        "--poses", "5", "--range", "30",
    ];
    radarnav_ok(&args);
    let meta: serde_json::Value = serde_json::from_slice(&read(&dir, "meta.json")).unwrap();
    assert_eq!(meta["rays"], 1800);
    assert_eq!(meta["objects"], 300);
    // The same command writes the same bytes.
    let rays = read(&dir, "rays.csv");
    radarnav_ok(&args);
    assert_eq!(read(&dir, "rays.csv"), rays);
    let out = radarnav_ok(&["bench", "--rays", d, "--repeats", "2", "--json"]);
    let result: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["laser_rays_per_cpu_s", "radar_rays_per_cpu_s"] {
        assert!(result[key].as_f64().unwrap() > 0.0, "{result}");
    }
    // One f64 per ray; the laser stops no later than the radar, which sees through foliage.
    let ranges = |name: &str| -> Vec<f64> {
        read(&dir, name)
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
            .collect()
    };
    let (laser, radar) = (ranges("ranges_laser.f64"), ranges("ranges_radar.f64"));
    assert_eq!((laser.len(), radar.len()), (1800, 1800));
    assert!(laser.iter().zip(&radar).all(|(l, r)| l <= r));
    assert!(laser.iter().zip(&radar).any(|(l, r)| l < r));
    // Bad input names the problem.
    let e = radarnav(&[
        "bench", "--export", d, "--forest", "10", "--radius", "1,0.5",
    ]);
    assert_eq!(e.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&e.stderr).contains("--radius"));
    let e = radarnav(&["bench", "--rays", "/nonexistent-radarnav-scene"]);
    assert!(String::from_utf8_lossy(&e.stderr).contains("meta.json"));
}

/// `radarnav serve` on an ephemeral loopback port: it names its address, greets a USARSim
/// client, answers GETSTARTPOSES, and stops cleanly on SIGTERM.
#[test]
fn serve_greets_a_usarsim_client_and_stops_on_sigterm() {
    use std::io::{BufRead, BufReader, Write};
    let mut child = Command::new(env!("CARGO_BIN_EXE_radarnav"))
        .args(["serve", "bug-spiral", "--port", "0"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("serve");
    let mut err = BufReader::new(child.stderr.take().expect("stderr"));
    let mut first = String::new();
    err.read_line(&mut first).expect("the serving line");
    let addr = first
        .split(" on ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .unwrap_or_else(|| panic!("no address in {first:?}"));
    assert!(addr.starts_with("127.0.0.1:"), "{first}");
    let stream = std::net::TcpStream::connect(addr).expect("connect");
    stream
        .set_read_timeout(Some(std::time::Duration::from_secs(20)))
        .unwrap();
    let mut lines = BufReader::new(stream.try_clone().unwrap());
    let mut line = String::new();
    lines.read_line(&mut line).unwrap();
    assert_eq!(
        line,
        "NFO {Gametype BotDeathMatch} {Level bug-spiral} {TimeLimit 0}\r\n"
    );
    (&stream).write_all(b"GETSTARTPOSES\r\n").unwrap();
    line.clear();
    lines.read_line(&mut line).unwrap();
    assert!(line.starts_with("NFO {StartPoses 1} {"), "{line}");
    // SAFETY: kill(2) on our own child's pid.
    let pid = i32::try_from(child.id()).expect("pid");
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
    let status = child.wait().expect("wait");
    let mut rest = String::new();
    let _ = std::io::Read::read_to_string(&mut err, &mut rest);
    assert!(status.success(), "{status:?}: {rest}");
    assert!(rest.contains("stopped"), "{rest}");
}

/// A grown tree written as OBJ is a mesh file a scenario reads: the laser stops on its trunk,
/// and the run is the same as with the same tree generated in place.
#[test]
fn a_grown_tree_is_a_mesh_file_a_scenario_reads_like_the_generated_one() {
    let dir = tmp("grow");
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("tree.obj");
    radarnav_ok(&[
        "grow",
        "tree",
        "--seed",
        "4",
        "--height",
        "5",
        "--out",
        obj.to_str().unwrap(),
    ]);
    assert!(dir.join("tree.mtl").is_file());
    let scene = |mesh: &str| {
        format!(
            "[[object]]\nname = \"t\"\nmaterial = \"foliage_dense\"\nmesh = {{ {mesh}, center = [3.0, 0.0] }}\n\
             [[robot]]\nname = \"r\"\nstart = {{ x = 0.0, y = 0.0 }}\n\
             [[robot.sensor]]\nname = \"laser\"\npreset = \"hokuyo_utm30lx\"\nmount = {{ z = 0.4 }}\n"
        )
    };
    let from_file = dir.join("file.toml");
    std::fs::write(
        &from_file,
        scene("file = \"tree.obj\", materials = { bark = \"wood\" }"),
    )
    .unwrap();
    let generated = dir.join("gen.toml");
    std::fs::write(
        &generated,
        scene("generate = \"tree\", seed = 4, height = 5.0"),
    )
    .unwrap();
    let mut scans = Vec::new();
    for (toml, out) in [(&from_file, "scan-file"), (&generated, "scan-gen")] {
        let out = dir.join(out);
        radarnav_ok(&[
            "scan",
            toml.to_str().unwrap(),
            "--sensor",
            "laser",
            "--out",
            out.to_str().unwrap(),
        ]);
        scans.push(read(&out, "scan.csv"));
    }
    assert_eq!(scans[0], scans[1]);
    let csv = String::from_utf8_lossy(&scans[0]);
    assert!(csv.contains(",wood,"), "the laser meets the trunk");
    let bad = radarnav(&["grow", "shrub"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("known: tree, bush"));
}
