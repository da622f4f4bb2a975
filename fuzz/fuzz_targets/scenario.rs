//! The scenario file: parse, build, and a short run with the maps of its robot, as
//! `radarnav run` would do (without writing files).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(src) = std::str::from_utf8(data) {
        radarnav::limits::smoke::parse_and_run(src, 10);
    }
});
