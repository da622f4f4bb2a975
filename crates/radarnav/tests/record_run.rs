//! A whole recorded run of the foliage-wall mission: every output file, read back.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use foxglove::Decode;
use foxglove::schemas::{Grid, LaserScan, PosesInFrame, SceneUpdate};
use radarnav::Scenario;
use radarnav::map::{MapConfig, Mapper};
use radarnav::record::{RecordOptions, Recorder, files, read_scan_log};
use radarnav::sim::{RunOutcome, RunSettings, RunSummary, Simulation};
use radarnav::stamp::EPOCH_NS;

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Runs the built-in foliage-wall mission for `duration` seconds into `dir`, building a map
/// from each of `maps`.
fn record(dir: &Path, duration: f64, maps: &[&str]) -> RunSummary {
    record_with(dir, duration, maps, RecordOptions::default())
}

/// [`record`] with these options.
fn record_with(dir: &Path, duration: f64, maps: &[&str], options: RecordOptions) -> RunSummary {
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
    let mut rec = Recorder::create(dir, &s.world, robot, options)
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
    // map → odom and odom → base_link at 60 steps, at the 60 laser scans between steps (40 Hz
    // against 20 Hz steps) and at the end; the two sensor mounts once.
    expect("/tf", "foxglove.FrameTransform", 2 * (60 + 60 + 1));
    expect("/tf_static", "foxglove.FrameTransform", 2);
    expect("/p3at/pose", "foxglove.PoseInFrame", 61);
    expect("/p3at/odometry", "foxglove.PoseInFrame", 61);
    // 3 s at 4 Hz and at 40 Hz.
    expect("/p3at/scan/radar", "foxglove.LaserScan", 12);
    expect("/p3at/scan/laser", "foxglove.LaserScan", 120);
    expect("/p3at/path", "foxglove.PosesInFrame", 1);
    // Maps at t = 0, 1 and 2 s, and at the end.
    expect("/p3at/map/radar", "foxglove.Grid", 4);
    expect("/p3at/map/laser", "foxglove.Grid", 4);
    assert_eq!(counts.len(), 11);
    let (t, grid) = grid.unwrap();
    assert_eq!(t, EPOCH_NS + 3_000_000_000);
    assert_eq!(grid.frame_id, "map");
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
    assert_eq!(t, EPOCH_NS + 2_975_000_000);
    assert_eq!(scan.frame_id, "laser");
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
fn the_ros2_bag_has_ros2_schemas_cdr_messages_and_its_metadata() {
    use radarnav::record::ros2::{BAG_DIR, BAG_FILE, METADATA};
    let dir = tmp("record-bag");
    let options = RecordOptions {
        mcap: false,
        ros2_bag: true,
        ..RecordOptions::default()
    };
    let summary = record_with(&dir, 2.0, &["radar"], options);
    assert!(!dir.join(files::MCAP).exists());
    let bag = dir.join(BAG_DIR);
    let bytes = std::fs::read(bag.join(BAG_FILE)).unwrap();
    // The header record follows the magic: opcode 1, length, then the profile string.
    assert_eq!(bytes[8], 1);
    assert_eq!(&bytes[17..25], b"\x04\0\0\0ros2");
    let mut counts: BTreeMap<String, u64> = BTreeMap::new();
    let mut first_clock = None;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "ros2msg");
        assert_eq!(m.channel.message_encoding, "cdr");
        // CDR, little-endian.
        assert_eq!(&m.data[..4], &[0, 1, 0, 0]);
        let qos = &m.channel.metadata["offered_qos_profiles"];
        assert_eq!(
            qos.contains("transient_local"),
            m.channel.topic == "/tf_static"
        );
        if m.channel.topic == "/clock" && first_clock.is_none() {
            first_clock = Some(m.data.to_vec());
        }
        *counts.entry(m.channel.topic.clone()).or_default() += 1;
    }
    // The first clock: 1 700 000 000 s, 0 ns.
    let mut clock = vec![0, 1, 0, 0];
    clock.extend(1_700_000_000i32.to_le_bytes());
    clock.extend(0u32.to_le_bytes());
    assert_eq!(first_clock, Some(clock));
    assert_eq!(counts["/clock"], summary.steps + 1);
    assert_eq!(counts["/odom"], summary.steps + 1);
    assert_eq!(counts["/scan/radar"], 8);
    assert_eq!(counts["/scan/laser"], 80);
    assert_eq!(counts["/tf_static"], 1);
    // metadata.yaml (JSON, which YAML parsers read) agrees with the MCAP.
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(bag.join(METADATA)).unwrap()).unwrap();
    let info = &meta["rosbag2_bagfile_information"];
    assert_eq!(info["version"], 9);
    assert_eq!(info["storage_identifier"], "mcap");
    assert_eq!(info["relative_file_paths"][0], BAG_FILE);
    assert_eq!(info["message_count"], counts.values().sum::<u64>());
    assert_eq!(info["starting_time"]["nanoseconds_since_epoch"], EPOCH_NS);
    let topics = info["topics_with_message_count"].as_array().unwrap();
    assert_eq!(topics.len(), counts.len());
    for t in topics {
        let name = t["topic_metadata"]["name"].as_str().unwrap();
        assert_eq!(t["message_count"], counts[name], "{name}");
    }
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
    // 40 steps and the final state, which is the summary's.
    assert_eq!(rows.len(), 41);
    assert!(rows.iter().all(|r| r.len() == 12 && r[11] == 0.0));
    let end = &rows[40];
    assert_eq!(end[0], summary.duration);
    assert!((end[1] - summary.final_pose.x).abs() < 1e-5);
    assert!((end[4] - summary.final_odometry.x).abs() < 1e-5);
    assert_eq!(&end[7..], &[0.0; 5]);
    // left/right are the twist's track speeds.
    for r in &rows {
        let half = r[8].to_radians() * 0.36 / 2.0;
        assert!((r[9] - (r[7] - half)).abs() < 2e-4 && (r[10] - (r[7] + half)).abs() < 2e-4);
    }

    // The TUM trajectories hold the same poses, and the summary the odometry's errors.
    let tum = |name: &str| -> Vec<Vec<f64>> {
        std::fs::read_to_string(dir.join(name))
            .unwrap()
            .lines()
            .map(|l| l.split(' ').map(|f| f.parse().unwrap()).collect())
            .collect()
    };
    let (truth, odometry) = (tum(files::TRUTH_TUM), tum(files::ODOMETRY_TUM));
    assert_eq!((truth.len(), odometry.len()), (41, 41));
    let mut squares = 0.0;
    for ((t, o), r) in truth.iter().zip(&odometry).zip(&rows) {
        assert_eq!((t.len(), t[0], o[0]), (8, r[0], r[0]));
        assert!((t[1] - r[1]).abs() < 2e-5 && (o[1] - r[4]).abs() < 2e-5);
        // A rotation about z by the yaw.
        let yaw = 2.0 * t[6].atan2(t[7]);
        let d = (yaw - r[3].to_radians()).rem_euclid(std::f64::consts::TAU);
        assert!(d.min(std::f64::consts::TAU - d) < 1e-5, "{t:?} {r:?}");
        assert_eq!((t[4], t[5]), (0.0, 0.0));
        squares += (t[1] - o[1]).powi(2) + (t[2] - o[2]).powi(2);
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(files::SUMMARY)).unwrap()).unwrap();
    let accuracy = &json["accuracy"]["odometry"];
    assert_eq!(accuracy["poses"], 41);
    let ate = accuracy["ate_rmse_m"].as_f64().unwrap();
    assert!(
        ate > 0.0 && (ate - (squares / 41.0).sqrt()).abs() < 1e-5,
        "{ate}"
    );
    // 2 s of driving: under a segment of path.
    assert!(accuracy["rpe"].is_null());
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
                assert_eq!(img.frame_id, "navtech_cts350x");
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
