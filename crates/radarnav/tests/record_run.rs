//! A whole recorded run of the foliage-wall mission: every output file, read back.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use foxglove::Decode;
use foxglove::schemas::{Grid, LaserScan, PosesInFrame, SceneUpdate};
use radarnav::Scenario;
use radarnav::map::{MapConfig, Mapper};
use radarnav::record::{RecordOptions, Recorder, files, read_scan_log};
use radarnav::sim::{RunOutcome, RunSettings, RunSummary, Simulation};

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Runs the built-in foliage-wall mission for `duration` seconds into `dir`, building a map
/// from each of `maps`.
fn record(dir: &Path, duration: f64, maps: &[&str]) -> RunSummary {
    let s = Scenario::builtin("foliage-wall").unwrap();
    let robot = &s.robots[0];
    let controller = s.mission.as_ref().unwrap().controller(0).unwrap();
    let settings = RunSettings {
        duration,
        ..RunSettings::of(&s)
    };
    let mut sim = Simulation::new(&s.world, robot, controller, settings).unwrap();
    let maps = maps
        .iter()
        .map(|m| Mapper::from_spec(m, robot, MapConfig::default()).unwrap())
        .collect();
    let mut rec = Recorder::create(dir, &s.world, robot, RecordOptions::default())
        .unwrap()
        .with_maps(maps)
        .unwrap();
    let summary = sim.run(&mut rec).unwrap();
    rec.finish(&s, robot, &summary, 400).unwrap();
    summary
}

#[test]
fn mcap_reads_back_with_the_expected_channels_and_counts() {
    let dir = tmp("record-mcap");
    let summary = record(&dir, 3.0, &["radar", "laser"]);
    assert_eq!(summary.outcome, RunOutcome::Timeout);
    assert_eq!(summary.steps, 60);
    let bytes = std::fs::read(dir.join(files::MCAP)).unwrap();
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut schemas: BTreeMap<String, String> = BTreeMap::new();
    let mut last_scan = None;
    let mut world = None;
    let mut path = None;
    let mut grid = None;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let topic = m.channel.topic.clone();
        *counts.entry(topic.clone()).or_default() += 1;
        let schema = m.channel.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "protobuf");
        assert_eq!(m.channel.message_encoding, "protobuf");
        schemas.insert(topic.clone(), schema.name.clone());
        if topic == "/p3at/scan/laser" {
            last_scan = Some((m.log_time, LaserScan::decode(m.data.as_ref()).unwrap()));
        }
        if topic == "/p3at/path" {
            path = Some(PosesInFrame::decode(m.data.as_ref()).unwrap());
        }
        if topic == "/world" {
            world = Some(SceneUpdate::decode(m.data.as_ref()).unwrap());
        }
        if topic == "/p3at/map/radar" {
            grid = Some((m.log_time, Grid::decode(m.data.as_ref()).unwrap()));
        }
    }
    let expect = |topic: &str, schema: &str, n: usize| {
        assert_eq!(
            schemas.get(topic).map(String::as_str),
            Some(schema),
            "{topic}"
        );
        assert_eq!(counts.get(topic).copied(), Some(n), "{topic}");
    };
    expect("/world", "foxglove.SceneUpdate", 1);
    expect("/p3at/body", "foxglove.SceneUpdate", 1);
    // 60 steps of the robot plus the two sensor mounts at t = 0.
    expect("/tf", "foxglove.FrameTransform", 60 + 2);
    expect("/p3at/pose", "foxglove.PoseInFrame", 60);
    expect("/p3at/odometry", "foxglove.PoseInFrame", 60);
    // 3 s at 4 Hz and at 40 Hz.
    expect("/p3at/scan/radar", "foxglove.LaserScan", 12);
    expect("/p3at/scan/laser", "foxglove.LaserScan", 120);
    expect("/p3at/path", "foxglove.PosesInFrame", 1);
    // Maps at t = 0, 1 and 2 s, and at the end.
    expect("/p3at/map/radar", "foxglove.Grid", 4);
    expect("/p3at/map/laser", "foxglove.Grid", 4);
    assert_eq!(counts.len(), 10);
    let (t, grid) = grid.unwrap();
    assert_eq!(t, 3_000_000_000);
    assert_eq!(grid.frame_id, "world");
    assert_eq!(grid.cell_stride, 5);
    assert_eq!(grid.row_stride, 5 * grid.column_count);
    assert_eq!(grid.data.len() % grid.row_stride as usize, 0);
    let names: Vec<&str> = grid.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["red", "green", "blue", "alpha", "class"]);
    assert_eq!(grid.cell_size.unwrap().x, 0.05);
    // The room (12 × 8 m) and more is known; every class code is 0..=3 and the radar map has
    // clear, see-through and obstacle cells.
    let rows = grid.data.len() / grid.row_stride as usize;
    assert!(grid.column_count as f64 * 0.05 > 11.0 && rows as f64 * 0.05 > 7.5);
    let classes: std::collections::BTreeSet<u8> = grid.data.chunks(5).map(|c| c[4]).collect();
    assert!(classes.is_subset(&[0, 1, 2, 3].into()));
    assert!(classes.is_superset(&[1, 2, 3].into()), "{classes:?}");
    // The last laser scan: 1081 ranges over 270°, stamped 119/40 s.
    let (t, scan) = last_scan.unwrap();
    assert_eq!(t, 2_975_000_000);
    assert_eq!(scan.ranges.len(), 1081);
    assert!((scan.end_angle - scan.start_angle - 270f64.to_radians()).abs() < 1e-9);
    assert!(scan.ranges.iter().any(|r| r.is_finite()));
    // The path ends at the final pose, after 3 s at up to 0.5 m/s.
    let path = path.unwrap();
    let end = path.poses.last().unwrap().position.unwrap();
    assert!(path.poses.len() > 50);
    assert_eq!((end.x, end.y), (summary.final_pose.x, summary.final_pose.y));
    let world = world.unwrap();
    assert_eq!(world.entities.len(), 13);
    assert_eq!(world.entities[1].spheres.len(), 1);
}

#[test]
fn scan_logs_trajectory_and_summary_read_back() {
    let dir = tmp("record-files");
    let summary = record(&dir, 2.0, &["radar"]);
    let (header, scans) =
        read_scan_log(&std::fs::read(dir.join("scans/radar.rnscan")).unwrap()).unwrap();
    assert_eq!(header.sensor, "radar");
    assert_eq!(header.azimuths, 360);
    assert_eq!(scans.len(), 8);
    assert_eq!(scans[3].stamp, 0.75);
    // The first scan is taken at the start pose, sensor 0.4 m up.
    assert_eq!(
        (scans[0].pose.x, scans[0].pose.y, scans[0].pose.z),
        (3.0, 4.0, 0.4)
    );
    assert!(scans.iter().all(|s| s.len() == 360));
    let (lh, laser) =
        read_scan_log(&std::fs::read(dir.join("scans/laser.rnscan")).unwrap()).unwrap();
    assert_eq!((lh.azimuths, laser.len()), (1081, 80));

    let csv = std::fs::read_to_string(dir.join(files::TRAJECTORY)).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time,x,y,yaw_deg,odom_x,odom_y,odom_yaw_deg,v,omega_deg_s,left,right,bumped"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 40);
    assert!(rows.iter().all(|r| r.len() == 12 && r[11] == 0.0));
    // left/right are the twist's track speeds.
    for r in &rows {
        let half = r[8].to_radians() * 0.36 / 2.0;
        assert!((r[9] - (r[7] - half)).abs() < 2e-4 && (r[10] - (r[7] + half)).abs() < 2e-4);
    }

    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(files::SUMMARY)).unwrap()).unwrap();
    assert_eq!(json["scenario"], "foliage-wall");
    assert_eq!(json["mission"], "waypoints");
    assert_eq!(json["bumps"], 0);
    assert_eq!(json["sensors"][1]["scans"], 80);
    assert!((json["distance"].as_f64().unwrap() - summary.distance).abs() < 1e-12);
    let png = std::fs::read(dir.join(files::PATH_PNG)).unwrap();
    assert_eq!(&png[1..4], b"PNG");

    // The radar map: its entry in the summary and its four files.
    let map = &json["maps"][0];
    assert_eq!(map["name"], "radar");
    assert_eq!(map["pose"], "truth");
    assert_eq!(map["scans"], 8);
    assert_eq!(map["resolution"], 0.05);
    assert!(map["hidden_coverage"].as_f64().unwrap() > 0.0);
    assert!(map["hidden_area_m2"].as_f64().unwrap() > 25.0);
    let png = std::fs::read(dir.join("map_radar.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let (cols, rows) = (
        map["columns"].as_u64().unwrap(),
        map["rows"].as_u64().unwrap(),
    );
    let pgm = std::fs::read(dir.join("map_radar.pgm")).unwrap();
    let header = format!("P5\n# radarnav occupancy grid\n{cols} {rows}\n255\n");
    assert!(pgm.starts_with(header.as_bytes()));
    assert_eq!(pgm.len(), header.len() + (cols * rows) as usize);
    assert!(
        pgm[header.len()..]
            .iter()
            .all(|p| [0, 205, 254].contains(p))
    );
    let yaml = std::fs::read_to_string(dir.join("map_radar.yaml")).unwrap();
    assert!(yaml.contains("image: map_radar.pgm\n"));
    assert!(yaml.contains("resolution: 0.05\n"));
    let o = &map["origin"];
    assert!(yaml.contains(&format!("origin: [{}, {}, 0.0]", o[0], o[1])));
    let npy = std::fs::read(dir.join("map_radar.npy")).unwrap();
    assert!(npy.starts_with(b"\x93NUMPY"));
    let hl = u16::from_le_bytes([npy[8], npy[9]]) as usize;
    assert_eq!(npy.len(), 10 + hl + 2 * 4 * (cols * rows) as usize);
}

#[test]
fn truncated_scan_log_is_an_error_not_a_panic() {
    let dir = tmp("record-truncated");
    record(&dir, 0.5, &[]);
    let bytes = std::fs::read(dir.join("scans/radar.rnscan")).unwrap();
    let e = read_scan_log(&bytes[..bytes.len() - 3]).unwrap_err();
    assert!(e.to_string().starts_with("truncated"), "{e}");
    assert_eq!(
        read_scan_log(b"not a log at all").unwrap_err().to_string(),
        "not a radarnav scan log (bad magic or version)"
    );
}

/// A run with an imaging radar and a multi-echo radar added: images on disk in the Oxford
/// layout, one per finished rotation, and images, detections and echoes in the MCAP.
#[test]
fn imaging_and_multi_echo_radars_are_recorded() {
    use foxglove::schemas::{CompressedImage, PointCloud};
    use radarnav::sensor::ReturnMode;
    use radarnav::sensor::image::{IMAGE_EPOCH_US, PowerImage};

    let dir = tmp("record-images");
    let s = Scenario::builtin("foliage-wall").unwrap();
    let mut robot = s.robots[0].clone();
    robot
        .sensors
        .push(robot.with_preset_mount("navtech_cts350x").unwrap());
    let mut echo = robot.with_preset_mount("radar_thesis").unwrap();
    echo.name = "echo".into();
    echo.config.signal.return_mode = ReturnMode::All;
    robot.sensors.push(echo);
    let controller = s.mission.as_ref().unwrap().controller(0).unwrap();
    let settings = RunSettings {
        duration: 1.0,
        ..RunSettings::of(&s)
    };
    let mut sim = Simulation::new(&s.world, &robot, controller, settings).unwrap();
    let mut rec = Recorder::create(&dir, &s.world, &robot, RecordOptions::default())
        .unwrap()
        .with_radar_images(&s.world, &robot, settings.seed)
        .unwrap();
    let summary = sim.run(&mut rec).unwrap();
    rec.finish(&s, &robot, &summary, 300).unwrap();

    // Rotations start at 0, 0.25, 0.5 and 0.75 s; the last ends with the run and is dropped.
    let idir = dir.join(files::RADAR).join("navtech_cts350x");
    let index = std::fs::read_to_string(idir.join(files::RADAR_TIMESTAMPS)).unwrap();
    let stamps: Vec<i64> = index
        .lines()
        .map(|l| l.split(' ').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(
        stamps,
        [0, 250_000, 500_000].map(|us| IMAGE_EPOCH_US + us).to_vec()
    );
    for t in &stamps {
        let png = std::fs::read(idir.join(format!("{t}.png"))).unwrap();
        let img = PowerImage::read_png(&png, 0.0438, 5600).unwrap();
        assert_eq!((img.rows(), img.bins), (400, 3768));
        assert_eq!(img.timestamps_us[0], *t);
    }
    let detections = std::fs::read_to_string(idir.join(files::RADAR_DETECTIONS)).unwrap();
    assert!(detections.lines().count() > 100);

    let bytes = std::fs::read(dir.join(files::MCAP)).unwrap();
    let mut images = 0;
    let mut points = 0;
    let mut echo_clouds = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        match m.channel.topic.as_str() {
            "/p3at/radar/navtech_cts350x/image" => {
                let img = CompressedImage::decode(m.data.as_ref()).unwrap();
                assert_eq!(img.format, "png");
                assert_eq!(img.frame_id, "p3at/navtech_cts350x");
                assert_eq!(
                    img.data.as_ref(),
                    std::fs::read(idir.join(format!("{}.png", stamps[images])))
                        .unwrap()
                        .as_slice()
                );
                images += 1;
            }
            "/p3at/radar/navtech_cts350x/points" => {
                let cloud = PointCloud::decode(m.data.as_ref()).unwrap();
                assert_eq!(cloud.point_stride, 13);
                assert!(!cloud.data.is_empty());
                // Detections lie inside the room (x in 0..12, y in 0..8, walls 0.2 m), but for
                // the ghosts of specular bounces (the metal pole), placed beyond the walls.
                let inside = cloud
                    .data
                    .chunks_exact(13)
                    .filter(|p| {
                        let f = |k: usize| f32::from_le_bytes(p[k..k + 4].try_into().unwrap());
                        (-0.5..12.5).contains(&f(0)) && (-0.5..8.5).contains(&f(4))
                    })
                    .count();
                assert!(inside as f64 > 0.95 * (cloud.data.len() / 13) as f64);
                points += 1;
            }
            "/p3at/echoes/echo" => {
                let cloud = PointCloud::decode(m.data.as_ref()).unwrap();
                assert_eq!(cloud.point_stride, 18);
                assert!(cloud.data.len() >= 360 * 18);
                echo_clouds += 1;
            }
            "/p3at/echoes/radar" => panic!("a thesis-mode radar has no echo channel"),
            _ => {}
        }
    }
    assert_eq!((images, points), (3, 3));
    assert_eq!(echo_clouds, 4);
}
