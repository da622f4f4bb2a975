//! The teleop CSV reader: any bytes give commands or an error naming the line.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(src) = std::str::from_utf8(data) {
        let _ = radarnav::mission::parse_teleop_csv(src, "fuzz.csv");
    }
});
