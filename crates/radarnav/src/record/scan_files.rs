//! One scan as files (`radarnav scan`): `scan.json` (the sensor's config and the whole scan)
//! and `scan.csv` (one line a ray: azimuth, elevation, range, how it ended, material, beam).

use std::path::{Path, PathBuf};

use super::{RecordError, write_whole};
use crate::Scan;
use crate::setup::MountedSensor;

/// The scan as CSV text; `materials` are the world's material names by id.
pub fn scan_csv(scan: &Scan, materials: &[&str]) -> String {
    let mut w = String::from("index,azimuth_deg,elevation_deg,range_m,hit,material,beam\n");
    for i in 0..scan.len() {
        let (az, el) = scan.angles(i);
        let material = scan.materials[i].map_or("", |m| materials[m.0 as usize]);
        w.push_str(&format!(
            "{i},{:.6},{:.6},{},{},{material},{}\n",
            az.to_degrees(),
            el.to_degrees(),
            scan.ranges[i],
            scan.hits[i].as_str(),
            scan.beams[i].as_str()
        ));
    }
    w
}

/// Writes `scan.json` and `scan.csv` of `scan`, taken by `sensor` on `robot` in `scenario`,
/// into `dir`; returns their paths.
pub fn write_scan_files(
    dir: &Path,
    scenario: &str,
    robot: &str,
    sensor: &MountedSensor,
    scan: &Scan,
    materials: &[&str],
) -> Result<Vec<PathBuf>, RecordError> {
    let json = serde_json::json!({
        "scenario": scenario,
        "robot": robot,
        "sensor": sensor.name,
        "config": sensor.config,
        "materials": materials,
        "scan": scan,
    });
    let json_path = dir.join("scan.json");
    // A scan serialises (numbers, strings, nulls for non-finite ranges); never fails.
    write_whole(
        &json_path,
        &serde_json::to_vec_pretty(&json).unwrap_or_default(),
    )?;
    let csv_path = dir.join("scan.csv");
    write_whole(&csv_path, scan_csv(scan, materials).as_bytes())?;
    Ok(vec![json_path, csv_path])
}
