//! The binary scan-log reader: any bytes give scans or an error, never a panic or a huge
//! allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = radarnav::record::read_scan_log(data);
});
