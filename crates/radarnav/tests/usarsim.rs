//! USARSim clients on loopback against the server over foliage-wall: the greeting, start poses,
//! INIT by location and by start tag, every message type with its exact field formats, raw
//! and normalised DRIVE, the odometer reset, malformed lines, and four clients at once.

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use radarnav::Scenario;
use radarnav::usarsim::protocol::{Message, parse_vector};
use radarnav::usarsim::server::{ServeOptions, serve};

struct Client {
    reader: BufReader<TcpStream>,
    writer: TcpStream,
}

impl Client {
    fn connect(port: u16) -> Self {
        let s = TcpStream::connect(("127.0.0.1", port)).expect("connect");
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        Self {
            reader: BufReader::new(s.try_clone().unwrap()),
            writer: s,
        }
    }

    fn send(&mut self, line: &str) {
        self.writer.write_all(line.as_bytes()).unwrap();
    }

    /// The next line; every line the server sends ends in CR LF.
    fn line(&mut self) -> String {
        let mut buf = Vec::new();
        if std::env::var("USARSIM_TRACE").is_ok() {
            eprintln!("reading...");
        }
        self.reader.read_until(b'\n', &mut buf).expect("a line");
        assert!(buf.ends_with(b"\r\n"), "line without CR LF: {buf:?}");
        let l = String::from_utf8(buf[..buf.len() - 2].to_vec()).unwrap();
        if std::env::var("USARSIM_TRACE").is_ok() {
            eprintln!("< {}", &l[..l.len().min(100)]);
        }
        l
    }

    /// Reads until a line starting with `prefix` (others are skipped).
    fn until(&mut self, prefix: &str) -> String {
        for _ in 0..100_000 {
            let l = self.line();
            if l.starts_with(prefix) {
                return l;
            }
        }
        panic!("no line starting with {prefix}");
    }
}

fn two_decimals(v: &str) -> bool {
    let (int, frac) = v.split_once('.').unwrap_or((v, ""));
    let int = int.strip_prefix('-').unwrap_or(int);
    !int.is_empty()
        && int.chars().all(|c| c.is_ascii_digit())
        && frac.len() == 2
        && frac.chars().all(|c| c.is_ascii_digit())
}

fn decimals(v: &str) -> usize {
    v.split_once('.').map_or(0, |(_, f)| f.len())
}

#[test]
fn usarsim_clients_drive_and_read_every_message_type() {
    let scenario = Scenario::builtin("foliage-wall").unwrap();
    let template = &scenario.robots[0];
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let stop = AtomicBool::new(false);
    let log = Mutex::new(Vec::<String>::new());
    let log_line = |l: String| log.lock().unwrap().push(l);
    /// Stops the server however the test ends, so a failed check fails instead of hanging.
    struct StopOnDrop<'a>(&'a AtomicBool);
    impl Drop for StopOnDrop<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Relaxed);
        }
    }
    std::thread::scope(|scope| {
        let _stop = StopOnDrop(&stop);
        let server = scope.spawn(|| {
            serve(
                &listener,
                &scenario,
                template,
                ServeOptions {
                    speed: 2.0,
                    seed: 1,
                },
                &stop,
                &log_line,
            )
        });

        // Client A: greeting, start poses, INIT by location.
        let mut a = Client::connect(port);
        assert_eq!(
            a.line(),
            "NFO {Gametype BotDeathMatch} {Level foliage-wall} {TimeLimit 0}"
        );
        a.send("GETSTARTPOSES\r\n");
        let poses = a.line();
        let start = template.start;
        assert!(
            poses.starts_with(&format!("NFO {{StartPoses 1}} {{{} ", template.name)),
            "{poses}"
        );
        // Before INIT nothing else is served.
        a.send("DRIVE {Left 1} {Right 1}\n");
        assert!(a.line().starts_with("ERR {Reason DRIVE: no robot"));
        // USARSim's frame: y right, yaw clockwise.
        a.send(&format!(
            "INIT {{ClassName USARBot.P3AT}} {{Name alpha}} {{Location {},{},0.0}} {{Rotation 0,0,0}}\r\n",
            start.x, -start.y
        ));
        let sta = a.until("STA ");
        let m = Message::parse(&sta).unwrap();
        let keys: Vec<&str> = m.args.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(
            keys,
            [
                "Time",
                "Battery",
                "Type",
                "LightToggle",
                "LightIntensity",
                "FrontSteer",
                "RearSteer"
            ]
        );
        assert!(two_decimals(m.get("Time").unwrap()));
        assert_eq!(m.get("Type"), Some("GroundVehicle"));
        let gt = a.until("SEN {Time ");
        let mut seen = std::collections::BTreeSet::new();
        let mut line = gt;
        let mut first_truth = None;
        for _ in 0..2000 {
            let m = Message::parse(&line).unwrap();
            assert!(two_decimals(m.get("Time").unwrap()), "{line}");
            let kind = m.get("Type").unwrap().to_owned();
            match kind.as_str() {
                "RangeScanner" => {
                    let name = m.get("Name").unwrap();
                    let sensor = template.sensor(name).expect("a sensor of the robot");
                    let c = &sensor.config;
                    assert_eq!(decimals(m.get("Resolution").unwrap()), 4);
                    assert_eq!(decimals(m.get("FOV").unwrap()), 4);
                    let ranges: Vec<&str> = m.get("Range").unwrap().split(',').collect();
                    assert_eq!(
                        ranges.len(),
                        (c.fov / c.resolution + 1e-9).floor() as usize + 1
                    );
                    for r in &ranges {
                        assert!(two_decimals(r), "{r}");
                        let v: f64 = r.parse().unwrap();
                        assert!(v >= 0.0 && v <= c.range_max + 1e-9);
                    }
                    seen.insert(format!("RangeScanner {name}"));
                }
                "GroundTruth" => {
                    assert_eq!(m.get("Name"), Some("GndTruth"));
                    let loc = m.get("Location").unwrap();
                    assert!(loc.split(',').all(|v| decimals(v) == 3), "{loc}");
                    let p = parse_vector(loc).unwrap();
                    first_truth.get_or_insert(p);
                    let o = parse_vector(m.get("Orientation").unwrap()).unwrap();
                    assert!((0.0..std::f64::consts::TAU).contains(&o[2]));
                    seen.insert(kind);
                }
                "Odometry" => {
                    assert_eq!(m.get("Name"), Some("Odometer"));
                    let pose = m.get("Pose").unwrap();
                    assert!(pose.split(',').all(two_decimals), "{pose}");
                    seen.insert(kind);
                }
                other => panic!("unexpected SEN type {other}"),
            }
            if seen.len() == 2 + template.sensors.len() {
                break;
            }
            line = a.until("SEN ");
        }
        assert_eq!(seen.len(), 2 + template.sensors.len(), "{seen:?}");
        let p = first_truth.unwrap();
        assert!(
            (p[0] - start.x).abs() < 0.01 && (p[1] + start.y).abs() < 0.01,
            "{p:?}"
        );

        // Configuration and geometry.
        a.send("GETCONF {Type Robot}\r\n");
        assert!(a.until("CONF ").starts_with(
            "CONF {Name USARBot.P3AT} {Type GroundVehicle} {SteeringType SkidSteered}"
        ));
        a.send("GETGEO {Type RangeScanner} {Name radar}\n");
        let geo = a.until("GEO ");
        assert!(
            geo.starts_with("GEO {Type RangeScanner} {Name radar} {Location "),
            "{geo}"
        );

        // Client B: INIT by start tag, drives forward raw (wheel spin, rad/s).
        let mut b = Client::connect(port);
        b.line();
        b.send(&format!(
            "INIT {{ClassName USARBot.P3AT}} {{Start {}}}\r",
            template.name
        ));
        // The first ground truth at or after server time `t`: (time, location).
        let truth = |c: &mut Client, t: f64| loop {
            let l = c.until("SEN {Time ");
            let m = Message::parse(&l).unwrap();
            let time: f64 = m.get("Time").unwrap().parse().unwrap();
            if m.get("Type") == Some("GroundTruth") && time >= t {
                break (time, parse_vector(m.get("Location").unwrap()).unwrap());
            }
        };
        let (tb, b0) = truth(&mut b, 0.0);
        b.send("DRIVE {Left 1.3} {Right 1.3}\r\n");
        // Client C: a malformed line and an unknown command get error replies, the session goes on.
        let mut c = Client::connect(port);
        c.line();
        c.send("INIT {ClassName USARBot.P3AT} {Name gamma} {Location 3.0,-4.0,0}\n");
        c.until("STA ");
        c.send("DRIVE {Left 1\r\n");
        assert!(
            c.until("ERR ")
                .starts_with("ERR {Reason malformed argument")
        );
        c.send("LAUNCH {Rocket now}\r\n");
        assert_eq!(c.until("ERR "), "ERR {Reason unknown command LAUNCH}");
        c.until("STA ");
        // Client D: normalised drive, then leaves abruptly.
        let mut d = Client::connect(port);
        d.line();
        d.send("INIT {ClassName USARBot.P3AT} {Name delta} {Location 4.0,-4.0,0}\r\n");
        d.send("DRIVE {Left 100} {Right 100} {Normalized true}\r\n");
        d.until("STA ");
        drop(d);

        // A turns left on the spot: its odometer's heading (clockwise) goes negative. Once it
        // has, the reset brings the odometer back to zero, which turning alone would not.
        a.send("DRIVE {Left -1.3} {Right 1.3}\r\n");
        let odometer = |c: &mut Client| loop {
            let l = c.until("SEN {Time ");
            let m = Message::parse(&l).unwrap();
            if m.get("Type") == Some("Odometry") {
                break parse_vector(m.get("Pose").unwrap()).unwrap();
            }
        };
        while odometer(&mut a)[2] > -0.3 {}
        a.send("SET {Type Odometry} {Name Odometer} {Opcode RESET}\r\n");
        a.send("DRIVE {Left 0} {Right 0}\r\n");
        // Stopped at a heading below -0.3 rad, the odometer reads near zero only if reset (it
        // may turn a few hundredths more before the stop is taken).
        let near_zero = |p: [f64; 3]| p[0].abs() < 0.02 && p[1].abs() < 0.02 && p[2].abs() < 0.1;
        let mut p = odometer(&mut a);
        for _ in 0..50 {
            if near_zero(p) {
                break;
            }
            p = odometer(&mut a);
        }
        assert!(near_zero(p), "odometer after the reset: {p:?}");

        // B has moved forward (+x in both frames) at 1.3 rad/s x 0.098 m = 0.127 m/s.
        let (_, b1) = truth(&mut b, tb + 1.5);
        assert!(b1[0] - b0[0] > 0.1, "{b0:?} -> {b1:?}");
        assert!((b1[1] - b0[1]).abs() < 0.02, "{b0:?} -> {b1:?}");
        // C still receives after its errors and D's drop.
        assert!(c.until("SEN ").starts_with("SEN {Time "));

        stop.store(true, Ordering::Relaxed);
        server.join().unwrap().unwrap();
    });
    let log = log.into_inner().unwrap();
    assert_eq!(
        log.iter()
            .filter(|l| l.contains("connected from 127.0.0.1"))
            .count(),
        4
    );
    assert!(
        log.iter()
            .any(|l| l.starts_with("client 4: delta left after")),
        "{log:?}"
    );
}
