//! The USARSim server's line handling: any bytes, split into lines as the server splits them,
//! give replies or error replies from a client's robot, never a panic.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use radarnav::Scenario;
use radarnav::usarsim::protocol::Message;
use radarnav::usarsim::session::{Driving, parse_init, start_poses};

fn scenario() -> &'static Scenario {
    static S: OnceLock<Scenario> = OnceLock::new();
    S.get_or_init(|| Scenario::builtin("foliage-wall").expect("built-in"))
}

fuzz_target!(|data: &[u8]| {
    let s = scenario();
    let mut robot = s.robots[0].clone();
    let text = String::from_utf8_lossy(data);
    let lines: Vec<&str> = text.split(['\r', '\n']).collect();
    // Before INIT: start poses and INIT itself.
    let mut rest = lines.as_slice();
    while let Some((line, tail)) = rest.split_first() {
        rest = tail;
        let Ok(m) = Message::parse(line) else { continue };
        if m.is("GETSTARTPOSES") {
            let _ = start_poses(s);
        }
        if m.is("INIT") {
            if let Ok(init) = parse_init(&m, s, "fuzz") {
                robot.start = init.start;
                break;
            }
        }
    }
    let Ok(mut d) = Driving::new(&s.world, &robot, s.sim.dt, 1, 0.0) else {
        return;
    };
    for line in rest {
        if let Ok(m) = Message::parse(line) {
            let _ = d.handle(&m);
        }
    }
    for _ in 0..2 {
        let _ = d.step();
    }
});
