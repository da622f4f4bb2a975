use super::*;

const ROBOT: &str = "[[robot]]\nname = \"r\"\nstart = { x = 1.0, y = 2.0 }\n";

fn parse(src: &str) -> Result<Scenario, ScenarioError> {
    Scenario::from_toml(src, "test.toml", "test")
}

fn err(src: &str) -> ScenarioError {
    match parse(src) {
        Ok(_) => panic!("expected an error for:\n{src}"),
        Err(e) => e,
    }
}

#[test]
fn builtins_parse_and_have_robots_with_radar_and_laser() {
    for (name, _) in BUILTIN_SCENARIOS.iter().chain(NAV_SUITE) {
        let s = Scenario::builtin(name).unwrap();
        assert!(!s.description.is_empty(), "{name}");
        let robot = s.robot(None).unwrap();
        assert!(
            robot.sensor("radar").is_some() && robot.sensor("laser").is_some(),
            "{name}"
        );
        assert!(!s.world.objects().is_empty());
    }
    assert!(Scenario::builtin("nope").is_none());
}

#[test]
fn resting_centres_and_defaults() {
    let s = parse(&format!(
        "[[object]]\nmaterial = \"wood\"\nsphere = {{ center = [1, 2], radius = 0.5 }}\n\
         [[object]]\nmaterial = \"wood\"\nbox = {{ center = [0, 0], size = [1, 1, 2] }}\n\
         [[object]]\nmaterial = \"wood\"\ncylinder = {{ center = [0, 0, 3], radius = 1, height = 2 }}\n{ROBOT}"
    ))
    .unwrap();
    let objs = s.world.objects();
    assert_eq!(objs[0].shape.aabb().0.z, 0.0);
    assert_eq!(objs[1].shape.aabb().0.z, 0.0);
    assert_eq!(objs[2].shape.aabb().0.z, 2.0);
    assert_eq!(s.sim.dt, 0.05);
    assert_eq!(s.robots[0].start, Pose::new(1.0, 2.0, 0.0, 0.0));
    assert_eq!(s.robots[0].vehicle.name, "p3at");
}

#[test]
fn user_material_with_base_and_override() {
    let s = parse(
        "[[material]]\nname = \"wet\"\nbase = \"foliage_dense\"\nradar_attenuation_db_per_m = 7.0\n\
         [[material]]\nname = \"sheer\"\nbase = \"foliage_light\"\nlaser_opaque = false\n\
         [[material]]\nname = \"mine\"\nradar_attenuation_db_per_m = inf\ncolor = \"#102030\"\n\
         [[object]]\nmaterial = \"wet\"\nsphere = { center = [0, 0], radius = 1 }\n",
    )
    .unwrap();
    let t = s.world.materials();
    let wet = t.get(t.id("wet").unwrap());
    assert_eq!(wet.radar_attenuation_db_per_m, 7.0);
    assert!(wet.laser_opaque && !wet.traversable);
    let sheer = t.get(t.id("sheer").unwrap());
    assert!(!sheer.laser_opaque);
    assert_eq!(sheer.attenuation_db_per_m(crate::world::Band::Laser), 0.0);
    let mine = t.get(t.id("mine").unwrap());
    assert!(mine.radar_attenuation_db_per_m.is_infinite());
    assert_eq!(mine.color, [0x10, 0x20, 0x30]);
}

#[test]
fn aerosol_materials_take_their_extinction_and_default_laser_loss() {
    let s = parse(
        "[[material]]\nname = \"thin_smoke\"\nbase = \"smoke\"\nlaser_opaque = false\n\
         [[material]]\nname = \"haze\"\nradar_attenuation_db_per_m = 0\nlaser_opaque = false\n\
         laser_extinction_per_m = 0.5\ntraversable = true\n\
         [[object]]\nmaterial = \"haze\"\nsphere = { center = [0, 0], radius = 1 }\n",
    )
    .unwrap();
    let t = s.world.materials();
    let thin = t.get(t.id("thin_smoke").unwrap());
    let smoke = t.get(t.id("smoke").unwrap());
    assert!(thin.laser_aerosol() && !smoke.laser_aerosol());
    assert_eq!(thin.laser_extinction_per_m, smoke.laser_extinction_per_m);
    let haze = t.get(t.id("haze").unwrap());
    assert_eq!(haze.laser_extinction_per_m, 0.5);
    let loss = haze.attenuation_db_per_m(crate::world::Band::Laser);
    assert!((loss - 0.5 * 10.0 * std::f64::consts::LOG10_E).abs() < 1e-12);
    assert!(s.world.has_laser_aerosols());
    let err = parse("[[material]]\nname = \"x\"\nbase = \"smoke\"\nlaser_extinction_per_m = 101\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("laser_extinction_per_m") && err.contains("0 to 100"),
        "{err}"
    );
}

#[test]
fn sensor_overrides_apply() {
    let s = parse(&format!(
        "{ROBOT}[[robot.sensor]]\nname = \"s\"\npreset = \"sick_lms291\"\nresolution_deg = 0.5\n\
         elevations_deg = [-2, 0, 2]\nmount = {{ x = 0.2, z = 0.5, yaw_deg = 90 }}\n"
    ))
    .unwrap();
    let sensor = s.robots[0].sensor("s").unwrap();
    assert_eq!(sensor.config.azimuth_count(), 361);
    assert_eq!(sensor.config.elevations.len(), 3);
    assert!((sensor.mount.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert_eq!(sensor.mount.z, 0.5);
}

#[test]
fn unknown_key_names_file_line_column_and_key() {
    let e = err("description = \"x\"\n[[object]]\nmaterial = \"wood\"\nradius = 2\n");
    assert_eq!((e.file.as_str(), e.line, e.column), ("test.toml", 4, 1));
    assert_eq!(e.key.as_deref(), Some("radius"));
    assert!(e.message.contains("unknown field"), "{e}");
    let e = err("colour = 1\n");
    assert_eq!((e.line, e.key.as_deref()), (1, Some("colour")));
}

#[test]
fn out_of_range_value_points_at_the_value() {
    let e = err("[[object]]\nmaterial = \"wood\"\nsphere = { center = [0, 0], radius = -1.5 }\n");
    assert_eq!((e.line, e.column), (3, 38), "{e}");
    assert_eq!(e.key.as_deref(), Some("radius"));
    assert_eq!(e.message, "expected 0.001 to 10000 m, found -1.5", "{e}");
    assert_eq!(
        e.to_string(),
        format!("test.toml:3:38: `radius`: {}", e.message)
    );
}

#[test]
fn every_extreme_value_of_the_hostile_tests_is_refused_with_its_range() {
    let cases = [
        ("[sim]\ndt = 1e-9\n", "dt", "0.0001 to 1 s"),
        ("[sim]\nduration = 1e9\n", "duration", "0.001 to 1e6 s"),
        (
            "[[object]]\nmaterial = \"wood\"\nsphere = { center = [1e9, 0], radius = 1 }\n",
            "center",
            "-5000 to 5000 m",
        ),
        (
            &format!(
                "{ROBOT}[[robot.sensor]]\nname = \"s\"\npreset = \"radar_thesis\"\nmount = {{ x = 1e308 }}\n"
            ),
            "x",
            "-10 to 10 m",
        ),
        (
            &format!(
                "{ROBOT}[[robot.sensor]]\nname = \"s\"\npreset = \"radar_thesis\"\nrate_hz = 1e9\n"
            ),
            "rate_hz",
            "0.001 to 1000 Hz",
        ),
        (
            &format!("{ROBOT}[mission]\ntype = \"bug1\"\ngoal = [1, 1]\ncontroller_hz = 1e20\n"),
            "controller_hz",
            "0.01 to 1000 Hz",
        ),
    ];
    for (src, key, range) in cases {
        let e = err(src);
        assert_eq!(e.key.as_deref(), Some(key), "{e}");
        assert!(e.message.contains(range), "{e}");
    }
    let e = err("[[material]]\nname = \"concrete\"\nradar_attenuation_db_per_m = 1.0\n");
    assert!(e.message.contains("built-in"), "{e}");
}

#[test]
fn unknown_material_lists_the_known_ones() {
    let e = err("[[object]]\nmaterial = \"granite\"\nsphere = { center = [0, 0], radius = 1 }\n");
    assert_eq!(
        (e.line, e.column, e.key.as_deref()),
        (2, 12, Some("material"))
    );
    assert!(
        e.message.contains("granite") && e.message.contains("foliage_dense"),
        "{e}"
    );
    let e = err("[[material]]\nname = \"x\"\nbase = \"granite\"\n");
    assert_eq!((e.line, e.key.as_deref()), (3, Some("base")));
}

#[test]
fn shape_count_must_be_one() {
    let e = err("[[object]]\nmaterial = \"wood\"\n");
    assert!(e.message.contains("found 0"), "{e}");
    let e = err(
        "[[object]]\nmaterial = \"wood\"\nsphere = { center = [0, 0], radius = 1 }\n\
         cylinder = { center = [0, 0], radius = 1, height = 1 }\n",
    );
    assert!(e.message.contains("found 2"), "{e}");
}

#[test]
fn geometric_errors_come_from_the_shape_table() {
    let e = err(
        "[[object]]\nmaterial = \"wood\"\nwall = { points = [[0, 0], [0, 0]], thickness = 0.1, height = 1 }\n",
    );
    assert_eq!(e.line, 3);
    assert!(e.message.contains("equal consecutive points"), "{e}");
    let e = err(
        "[[object]]\nmaterial = \"wood\"\nprism = { polygon = [[0, 0], [1, 0], [0, 1]], z_min = 1, z_max = 0.5 }\n",
    );
    assert!(e.message.contains("z_max"), "{e}");
    let e =
        err("[[object]]\nmaterial = \"wood\"\nsphere = { center = [0, 0, 0, 0], radius = 1 }\n");
    assert_eq!(e.key.as_deref(), Some("center"));
    assert!(e.message.contains("found 4 numbers"), "{e}");
}

#[test]
fn syntax_and_type_errors() {
    let e = err("[sim]\ndt = \n");
    assert_eq!(e.line, 2, "{e}");
    let e = err("[sim]\nseed = \"one\"\n");
    assert_eq!((e.line, e.key.as_deref()), (2, Some("seed")), "{e}");
    let e = err("[[object]]\nmaterial = \"wood\"\nsphere = { center = [0, 0] }\n");
    assert!(e.message.contains("missing field `radius`"), "{e}");
}

#[test]
fn sensor_errors() {
    let e = err(&format!(
        "{ROBOT}[[robot.sensor]]\nname = \"s\"\npreset = \"velodyne\"\n"
    ));
    assert_eq!((e.line, e.key.as_deref()), (6, Some("preset")));
    assert!(e.message.contains("hokuyo_urg04lx"), "{e}");
    let e = err(&format!(
        "{ROBOT}[[robot.sensor]]\nname = \"s\"\npreset = \"sick_lms291\"\nrange_min = 100\n"
    ));
    assert_eq!(e.key.as_deref(), Some("range_min"));
    assert!(e.message.contains("below range_max"), "{e}");
    let e = err(&format!(
        "{ROBOT}[[robot.sensor]]\nname = \"s\"\npreset = \"radar_thesis\"\n\
         [[robot.sensor]]\nname = \"s\"\npreset = \"radar_thesis\"\n"
    ));
    assert!(e.message.contains("used twice"), "{e}");
    let e = err(&format!(
        "{ROBOT}[[robot]]\nname = \"r\"\nstart = {{ x = 0, y = 0 }}\n"
    ));
    assert!(e.message.contains("robot name `r` is used twice"), "{e}");
    let e = err("[[robot]]\nname = \"r\"\nvehicle = \"tank\"\nstart = { x = 0, y = 0 }\n");
    assert_eq!((e.line, e.key.as_deref()), (3, Some("vehicle")));
}

#[test]
fn missions_parse() {
    let s = parse(&format!(
        "{ROBOT}[mission]\ntype = \"teleop\"\ncontroller_hz = 20\ncommands = [\n  {{ duration = 2, v = 0.5 }},\n  {{ duration = 1, left = -0.1, right = 0.1 }},\n]\n"
    ))
    .unwrap();
    let m = s.mission.unwrap();
    assert_eq!(m.controller_hz, 20.0);
    let MissionKind::Teleop(TeleopSource::Steps(steps)) = m.kind else {
        panic!("teleop steps expected")
    };
    assert_eq!(steps[0].command, DriveCommand::twist(0.5, 0.0));
    assert_eq!(
        steps[1].command,
        DriveCommand::Tracks {
            left: -0.1,
            right: 0.1
        }
    );
    let s = parse(&format!(
        "{ROBOT}[mission]\ntype = \"waypoints\"\nrobot = \"r\"\npoints = [[1, 1], [2, 3]]\nloop = true\n"
    ))
    .unwrap();
    let m = s.mission.unwrap();
    let MissionKind::Waypoints(w) = m.kind else {
        panic!("waypoints expected")
    };
    assert_eq!(
        (w.points.len(), w.speed, w.tolerance, w.repeat),
        (2, 0.5, 0.15, true)
    );
    let s = parse(&format!(
        "{ROBOT}[mission]\ntype = \"teleop\"\nfile = \"d.csv\"\n"
    ))
    .unwrap();
    assert!(
        s.mission.unwrap().controller(0).is_err(),
        "an unread file cannot drive"
    );
    let odo = parse(&format!(
        "{ROBOT}odometry = {{ speed_noise = 0.1, yaw_drift_deg_s = 1 }}\n"
    ))
    .unwrap();
    let n = odo.robots[0].odometry;
    assert_eq!(n.speed_noise, 0.1);
    assert!((n.yaw_drift - 1f64.to_radians()).abs() < 1e-15);
}

#[test]
fn mission_errors_name_the_key() {
    let e = err(&format!(
        "{ROBOT}[mission]\ntype = \"waypoints\"\nfile = \"x.csv\"\n"
    ));
    assert_eq!(e.key.as_deref(), Some("file"));
    assert!(
        e.message.contains("not a key of a `waypoints` mission"),
        "{e}"
    );
    let e = err(&format!("{ROBOT}[mission]\ntype = \"waypoints\"\n"));
    assert_eq!(e.key.as_deref(), Some("points"));
    let e = err(&format!(
        "{ROBOT}[mission]\ntype = \"teleop\"\nrobot = \"ghost\"\ncommands = [{{ duration = 1 }}]\n"
    ));
    assert_eq!((e.line, e.key.as_deref()), (6, Some("robot")));
    let e = err(&format!(
        "{ROBOT}[mission]\ntype = \"teleop\"\ncommands = [{{ duration = 1, v = 1, left = 1 }}]\n"
    ));
    assert!(e.message.contains("not both"), "{e}");
    assert_eq!(e.line, 6);
    let e = err(&format!(
        "{ROBOT}[mission]\ntype = \"teleop\"\ncommands = [{{ duration = 0 }}]\n"
    ));
    assert_eq!(e.key.as_deref(), Some("duration"));
    let e = err("[mission]\ntype = \"teleop\"\ncommands = [{ duration = 1 }]\n");
    assert!(e.message.contains("needs a `[[robot]]`"), "{e}");
    let e = err(&format!("{ROBOT}odometry = {{ speed_noise = -1 }}\n"));
    assert_eq!(e.key.as_deref(), Some("speed_noise"));
}

#[test]
fn bad_colour_and_duplicate_material() {
    let e = err("[[material]]\nname = \"m\"\nradar_attenuation_db_per_m = 1\ncolor = \"red\"\n");
    assert_eq!((e.line, e.key.as_deref()), (4, Some("color")));
    let e = err(
        "[[material]]\nname = \"m\"\nradar_attenuation_db_per_m = 1\n[[material]]\nname = \"m\"\nradar_attenuation_db_per_m = 1\n",
    );
    assert!(e.message.contains("defined twice"), "{e}");
    let e = err("[[material]]\nname = \"m\"\n");
    assert!(e.message.contains("radar_attenuation_db_per_m"), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(400))]
    /// Any edit of a valid file (characters replaced, inserted or cut, multi-byte ones too)
    /// gives a scenario or an error that points inside the file; never a panic.
    #[test]
    fn mutated_files_never_panic(
        edits in proptest::collection::vec((0usize..4000, 0usize..3, proptest::sample::select(vec![
            "=", "[", "]", "{", "}", ",", "\"", "\n", "-", "0", "1e400", "inf", "nan", "é", "°",
            "radius", "material", "sphere", "#", ".", " ", "[[object]]", "x = 1",
        ])), 1..6),
    ) {
        let mut src = builtin_source("foliage-wall").unwrap().to_owned();
        for (pos, op, text) in edits {
            let mut at = pos % (src.len() + 1);
            while !src.is_char_boundary(at) {
                at -= 1;
            }
            match op {
                0 => src.insert_str(at, text),
                1 => {
                    let mut end = (at + text.len()).min(src.len());
                    while !src.is_char_boundary(end) {
                        end += 1;
                    }
                    src.replace_range(at..end, text);
                }
                _ => {
                    let mut end = (at + 1 + pos % 7).min(src.len());
                    while !src.is_char_boundary(end) {
                        end += 1;
                    }
                    src.replace_range(at..end, "");
                }
            }
        }
        if let Err(e) = parse(&src) {
            let lines = src.lines().count().max(1);
            proptest::prop_assert!(e.line >= 1 && e.line <= lines + 1, "{} (file has {} lines)", e, lines);
            proptest::prop_assert!(!e.message.is_empty());
        }
    }
}

const SENSING: &str = "[[robot]]\nname = \"r\"\nstart = { x = 1.0, y = 2.0 }\n[[robot.sensor]]\nname = \"radar\"\npreset = \"radar_thesis\"\n[[robot.sensor]]\nname = \"laser\"\npreset = \"sick_lms291\"\n";

#[test]
fn bug_and_explore_missions_parse_with_defaults_and_bumpers() {
    use crate::nav::{BugAlgorithm, BumperRule, Side, Strategy};
    let s = parse(&format!(
        "{SENSING}[mission]\ntype = \"bug2\"\ngoal = [5, 6]\n"
    ))
    .unwrap();
    let MissionKind::Bug(b) = s.mission.unwrap().kind else {
        panic!("bug expected")
    };
    assert_eq!(b.algorithm, BugAlgorithm::Bug2);
    assert_eq!(b.goal, DVec2::new(5.0, 6.0));
    assert_eq!(
        (b.tolerance, b.mline_tolerance, b.loop_tolerance, b.speed),
        (0.3, 0.1, 0.75, 0.4)
    );
    assert_eq!((b.follow, b.pose), (Side::Left, PoseSource::Odometry));
    assert_eq!(b.bumpers, BumperConfig::default());
    let s = parse(&format!(
        "{SENSING}[mission]\nexplore = \"frontier\"\nfollow = \"right\"\npose = \"truth\"\n[mission.bumpers]\nsectors = 4\nsafety = 1.6\nband = 0.3\nrule = \"fraction:0.8\"\nsensor = \"laser\"\n"
    ))
    .unwrap();
    let m = s.mission.unwrap();
    assert_eq!(m.kind_name(), "explore");
    let MissionKind::Explore(e) = m.kind else {
        panic!("explore expected")
    };
    assert_eq!(
        (e.strategy, e.follow, e.pose),
        (Strategy::Frontier, Side::Right, PoseSource::Truth)
    );
    assert_eq!(
        e.bumpers,
        BumperConfig {
            sectors: 4,
            safety: Some(1.6),
            band: 0.3,
            rule: BumperRule::Fraction(0.8),
            sensor: Some("laser".into()),
        }
    );
    // `type = "explore"` with the strategy is the same mission.
    let t = parse(&format!(
        "{SENSING}[mission]\ntype = \"explore\"\nexplore = \"spiral\"\n"
    ))
    .unwrap();
    assert_eq!(t.mission.unwrap().kind_name(), "explore");
}

#[test]
fn bug_and_explore_mission_errors_name_the_key() {
    let e = |tail: &str| err(&format!("{SENSING}[mission]\n{tail}"));
    let x = e("type = \"bug1\"\n");
    assert_eq!(x.key.as_deref(), Some("goal"));
    let x = e("type = \"bug1\"\ngoal = [1, 1]\npoints = [[1, 1]]\n");
    assert_eq!(x.key.as_deref(), Some("points"));
    assert!(x.message.contains("not a key of a `bug1` mission"), "{x}");
    let x = e("type = \"bug2\"\ngoal = [1, 1]\nfollow = \"up\"\n");
    assert_eq!((x.line, x.key.as_deref()), (13, Some("follow")));
    let x = e("type = \"bug2\"\ngoal = [1, 1]\npose = \"gps\"\n");
    assert!(x.message.contains("`odometry`, `slam` or `truth`"), "{x}");
    let x = e("explore = \"zigzag\"\n");
    assert_eq!((x.line, x.key.as_deref()), (11, Some("explore")));
    assert!(
        x.message
            .contains("known: bounce, wall_follow, spiral, frontier"),
        "{x}"
    );
    let x = e("explore = \"bounce\"\ngoal = [1, 1]\n");
    assert_eq!(x.key.as_deref(), Some("goal"));
    let x = e("type = \"explore\"\n");
    assert!(x.message.contains("needs `explore"), "{x}");
    let x = e("speed = 1\n");
    assert!(x.message.contains("needs `type`"), "{x}");
    let x = e("explore = \"bounce\"\n[mission.bumpers]\nsectors = 6\n");
    assert_eq!((x.line, x.key.as_deref()), (13, Some("sectors")));
    let x = e("explore = \"bounce\"\n[mission.bumpers]\nrule = \"most\"\n");
    assert_eq!(x.key.as_deref(), Some("rule"));
    let x = e("explore = \"bounce\"\n[mission.bumpers]\nsensor = \"sonar\"\n");
    assert!(
        x.message
            .contains("no sensor `sonar`; sensors: radar, laser"),
        "{x}"
    );
    let x = e("explore = \"bounce\"\n[mission.bumpers]\nbumpers = 3\n");
    assert!(x.message.contains("unknown field"), "{x}");
    let x = err(&format!("{ROBOT}[mission]\nexplore = \"bounce\"\n"));
    assert!(x.message.contains("no sensor to feed the bumpers"), "{x}");
    let x = e("type = \"hover\"\n");
    assert!(
        x.message
            .contains("known: teleop, waypoints, bug1, bug2, explore"),
        "{x}"
    );
}

/// A directory of mesh files for the mesh tests: a trunk cube (`bark`) under a crown cube
/// (`leaves`), each closed, with its MTL; and one open square.
fn mesh_dir() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("radarnav-scenario-mesh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cube = |z: u32| {
        let v: String = (0..8)
            .map(|i| format!("v {} {} {}\n", i & 1, (i >> 1) & 1, z + ((i >> 2) & 1)))
            .collect();
        v
    };
    let faces = |o: u32| {
        [
            [1, 3, 4, 2],
            [5, 6, 8, 7],
            [1, 2, 6, 5],
            [3, 7, 8, 4],
            [1, 5, 7, 3],
            [2, 4, 8, 6],
        ]
        .iter()
        .map(|f| format!("f {} {} {} {}\n", f[0] + o, f[1] + o, f[2] + o, f[3] + o))
        .collect::<String>()
    };
    std::fs::write(
        dir.join("cube.obj"),
        format!(
            "mtllib cube.mtl\n{}{}usemtl bark\n{}usemtl leaves\n{}",
            cube(0),
            cube(1),
            faces(0),
            faces(8)
        ),
    )
    .unwrap();
    std::fs::write(dir.join("cube.mtl"), "newmtl bark\nnewmtl leaves\n").unwrap();
    std::fs::write(dir.join("sheet.obj"), format!("{}f 1 2 6 5\n", cube(0))).unwrap();
    // Two closed cubes, 4 m apart, in one part.
    std::fs::write(
        dir.join("rocks.obj"),
        format!("{}{}{}{}", cube(0), cube(5), faces(0), faces(8)),
    )
    .unwrap();
    dir
}

fn parse_in(dir: &std::path::Path, src: &str) -> Result<Scenario, ScenarioError> {
    let file = dir.join("scene.toml");
    Scenario::from_toml(src, &file.to_string_lossy(), "scene")
}

#[test]
fn a_mesh_is_read_beside_the_scenario_placed_and_split_into_its_parts() {
    let dir = mesh_dir();
    let s = parse_in(
        &dir,
        &format!(
            "[[object]]\nname = \"shrub\"\nmaterial = \"wood\"\n\
             mesh = {{ file = \"cube.obj\", scale = 2.0, center = [5, 1], materials = {{ leaves = \"foliage_dense\" }} }}\n\
             [[object]]\nmaterial = \"concrete\"\nmesh = {{ file = \"sheet.obj\", yaw_deg = 90 }}\n{ROBOT}"
        ),
    )
    .unwrap();
    let objs = s.world.objects();
    let names: Vec<_> = objs.iter().map(|o| o.name.clone()).collect();
    assert_eq!(
        names,
        [
            Some("shrub/bark".to_owned()),
            Some("shrub/leaves".to_owned()),
            None
        ]
    );
    let m = s.world.materials();
    assert_eq!(objs[0].material, m.id("wood").unwrap());
    assert_eq!(objs[1].material, m.id("foliage_dense").unwrap());
    let (lo, hi) = objs[0].shape.aabb();
    assert_eq!(
        (lo, hi),
        (DVec3::new(5.0, 1.0, 0.0), DVec3::new(7.0, 3.0, 2.0))
    );
    // The crown, 2 m up to 4 m, is a volume: a level ray crosses 2 m of it.
    let ray = crate::world::Ray::new(DVec3::new(0.0, 2.0, 3.0), DVec3::X);
    let mut iv = Vec::new();
    objs[1].shape.ray_intervals(&ray, &mut iv);
    assert_eq!(iv, [(5.0, 7.0)]);
    // The sheet turned 90°: it now stands in the y-z plane at x = 0.
    let (lo, hi) = objs[2].shape.aabb();
    assert!(lo.x.abs() < 1e-12 && hi.x.abs() < 1e-12, "{lo} {hi}");
}

#[test]
fn a_files_closed_shells_far_apart_become_objects_of_one_name() {
    let dir = mesh_dir();
    let s = parse_in(
        &dir,
        "[[object]]\nname = \"rocks\"\nmaterial = \"concrete\"\nmesh = { file = \"rocks.obj\" }\n",
    )
    .unwrap();
    let objs = s.world.objects();
    assert_eq!(objs.len(), 2);
    assert!(objs.iter().all(|o| o.name.as_deref() == Some("rocks")));
    let boxes: Vec<_> = objs.iter().map(|o| o.shape.aabb()).collect();
    assert_eq!(boxes[0], (DVec3::ZERO, DVec3::ONE));
    assert_eq!(
        boxes[1],
        (DVec3::new(0.0, 0.0, 5.0), DVec3::new(1.0, 1.0, 6.0))
    );
    // A ray up through both meets each once, where the whole mesh had its two stretches.
    let ray = crate::world::Ray::new(DVec3::new(0.5, 0.5, -1.0), DVec3::Z);
    let mut q = crate::world::RayQuery::default();
    let found: Vec<(f64, f64)> = (s.world.ray_intervals_exhaustive(&ray, 10.0, &mut q).iter())
        .map(|iv| (iv.t_in, iv.t_out))
        .collect();
    assert_eq!(found, [(1.0, 2.0), (6.0, 7.0)]);
}

#[test]
fn mesh_errors_name_the_file_the_part_and_the_key() {
    let dir = mesh_dir();
    let e = parse_in(
        &dir,
        "[[object]]\nmaterial = \"wood\"\nmesh = { file = \"nope.obj\" }\n",
    )
    .unwrap_err();
    assert_eq!((e.line, e.key.as_deref()), (3, Some("file")));
    assert!(e.message.contains("nope.obj"), "{e}");
    // A foliage sheet: a ray could enter it, but it has no inside.
    let e = parse_in(
        &dir,
        "[[object]]\nmaterial = \"foliage_light\"\nmesh = { file = \"sheet.obj\" }\n",
    )
    .unwrap_err();
    assert!(
        e.message.contains("must be closed") && e.message.contains("4 edges"),
        "{e}"
    );
    let e = parse_in(
        &dir,
        "[[object]]\nmaterial = \"wood\"\nmesh = { file = \"cube.obj\", materials = { crown = \"foliage_dense\" } }\n",
    )
    .unwrap_err();
    assert!(
        e.message.contains("no part `crown`") && e.message.contains("bark, leaves"),
        "{e}"
    );
    let e = parse_in(
        &dir,
        "[[object]]\nmaterial = \"wood\"\nmesh = { file = \"cube.obj\", up = \"x\" }\n",
    )
    .unwrap_err();
    assert_eq!(e.key.as_deref(), Some("up"));
    let e = parse_in(
        &dir,
        "[[object]]\nmaterial = \"wood\"\nmesh = { file = \"cube.obj\", scale = 0 }\n",
    )
    .unwrap_err();
    assert!(e.message.contains("0.0001 to 10000"), "{e}");
}

#[test]
fn the_localiser_defaults_to_the_first_radar_and_its_table_is_checked() {
    let s = parse(SENSING).unwrap();
    let c = s.robots[0].slam.expect("a localiser by default");
    assert_eq!((c.sensor, c.resolution, c.loop_closure), (0, 0.05, false));
    let with = |table: &str| parse(&format!("{SENSING}[robot.slam]\n{table}"));
    let c = with("sensor = \"laser\"\nresolution = 0.1\nloop_closure = true\n")
        .unwrap()
        .robots[0]
        .slam
        .unwrap();
    assert_eq!((c.sensor, c.resolution, c.loop_closure), (1, 0.1, true));
    assert_eq!(with("enabled = false\n").unwrap().robots[0].slam, None);
    let e = with("sensor = \"sonar\"\n").unwrap_err();
    assert_eq!(e.key.as_deref(), Some("sensor"));
    assert!(e.message.contains("has no sensor `sonar`"), "{e}");
    let e = with("resolution = 5.0\n").unwrap_err();
    assert!(e.to_string().contains("resolution"), "{e}");
    let e = with("max_range = 0.1\n").unwrap_err();
    assert!(e.to_string().contains("max_range"), "{e}");
    let e = with("keyframes = 3\n").unwrap_err();
    assert!(e.to_string().contains("keyframes"), "{e}");
}
