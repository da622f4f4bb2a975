//! Time stamps of the outputs (recordings, radar images): simulation time 0 is stamped with a
//! fixed UNIX epoch, 2023-11-14T22:13:20Z, never with 0, because ROS tools read a zero stamp
//! as "the latest" (tf2) and Foxglove or pyboreas show stamps as dates.

/// UNIX time of simulation time 0, nanoseconds.
pub const EPOCH_NS: u64 = 1_700_000_000_000_000_000;

/// UNIX time of simulation time 0, microseconds (the radar images' unit).
pub const EPOCH_US: i64 = (EPOCH_NS / 1000) as i64;

/// UNIX nanoseconds of simulation time `t` (s; negative times are taken as 0).
pub fn unix_ns(t: f64) -> u64 {
    EPOCH_NS + (t.max(0.0) * 1e9).round() as u64
}

/// Simulation time, s, of UNIX nanoseconds `ns` (the inverse of [`unix_ns`] to the ns).
pub fn sim_time(ns: u64) -> f64 {
    ns.saturating_sub(EPOCH_NS) as f64 / 1e9
}

/// `ns` as (seconds, nanoseconds), the split of ROS and Foxglove stamps.
pub fn split(ns: u64) -> (u64, u32) {
    (ns / 1_000_000_000, (ns % 1_000_000_000) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_zero_is_the_epoch_and_times_round_trip() {
        assert_eq!(unix_ns(0.0), EPOCH_NS);
        assert_eq!(unix_ns(-1.0), EPOCH_NS);
        assert_eq!(unix_ns(1.25) - EPOCH_NS, 1_250_000_000);
        assert_eq!(sim_time(unix_ns(35.05)), 35.05);
        assert_eq!(split(unix_ns(0.5)), (1_700_000_000, 500_000_000));
        assert_eq!(EPOCH_US, 1_700_000_000_000_000);
    }
}
