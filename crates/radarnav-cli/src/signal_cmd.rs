//! The radar-signal outputs of `radarnav scan` (DESIGN §7): echoes, the power image in the
//! Oxford Radar RobotCar layout, a Cartesian view and detections.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use radarnav::record::write_whole;
use radarnav::scenario::MountedSensor;
use radarnav::sensor::Tracer;
use radarnav::sensor::cfar::{Detector, detect};
use radarnav::sensor::image::{IMAGE_EPOCH_US, PowerImage, power_image, write_grey_png};
use radarnav::{Pose, Scan, Scenario};
use rand_chacha::ChaCha8Rng;

/// Pixels across the Cartesian view.
const CART_PIXELS: usize = 801;

/// Writes `echoes.csv` for a multi-echo scan and, for a sensor with a power image,
/// `polar.png`, `radar.timestamps`, `cartesian.png` and `detections.csv`. Returns the names
/// written and the image.
pub fn write_signal_outputs(
    s: &Scenario,
    mounted: &MountedSensor,
    sensor_pose: &Pose,
    scan: &Scan,
    materials: &[&str],
    rng: &mut ChaCha8Rng,
    out: &Path,
) -> Result<(Vec<String>, Option<PowerImage>)> {
    let mut written = Vec::new();
    if !scan.echo_start.is_empty() {
        let mut csv = String::from(
            "index,azimuth_deg,elevation_deg,echo,range_m,depth_m,power_db,material,kind,bounces\n",
        );
        for i in 0..scan.len() {
            let (az, el) = scan.angles(i);
            for (k, e) in scan.echoes_of(i).iter().enumerate() {
                writeln!(
                    csv,
                    "{i},{:.4},{:.4},{k},{:.4},{:.4},{:.2},{},{},{}",
                    az.to_degrees(),
                    el.to_degrees(),
                    e.range,
                    e.depth,
                    e.power_db(),
                    materials.get(usize::from(e.material.0)).unwrap_or(&"?"),
                    e.kind.as_str(),
                    e.bounces
                )?;
            }
        }
        write_whole(&out.join("echoes.csv"), csv.as_bytes())?;
        written.push("echoes.csv".to_owned());
    }
    let Some(im) = mounted.config.signal.image else {
        return Ok((written, None));
    };
    let started = Instant::now();
    let img = power_image(
        &mounted.config,
        &s.world,
        0.0,
        IMAGE_EPOCH_US,
        &|_| *sensor_pose,
        rng,
        &mut Tracer::default(),
    )
    .context("the sensor has no range bin for its image")?;
    let ms = started.elapsed().as_secs_f64() * 1e3;
    let mut png = Vec::new();
    img.write_png(&mut png)?;
    write_whole(&out.join("polar.png"), &png)?;
    write_whole(
        &out.join("radar.timestamps"),
        img.timestamps_line().as_bytes(),
    )?;
    // The view spans the world around the sensor (within range), not the whole range.
    let reach = s
        .world
        .objects()
        .iter()
        .map(|o| o.shape.aabb())
        .flat_map(|(lo, hi)| [lo.x, hi.x].map(|x| [lo.y, hi.y].map(|y| (x, y))))
        .flatten()
        .map(|(x, y)| (x - sensor_pose.x).hypot(y - sensor_pose.y))
        .fold(5.0, f64::max);
    let mpp = 2.0 * (1.1 * reach).min(mounted.config.range_max) / CART_PIXELS as f64;
    let mut cart = Vec::new();
    write_grey_png(
        &mut cart,
        CART_PIXELS,
        CART_PIXELS,
        &img.cartesian(CART_PIXELS, mpp),
    )?;
    write_whole(&out.join("cartesian.png"), &cart)?;
    let mut csv = String::from("detector,row,azimuth_deg,bin,range_m,power\n");
    for (name, d) in [
        ("ca_cfar", Detector::CA_CFAR),
        ("k_strongest", Detector::K_STRONGEST),
    ] {
        for det in detect(&img, d, im.display_range_db) {
            writeln!(
                csv,
                "{name},{},{:.4},{},{:.4},{}",
                det.row,
                det.azimuth.to_degrees(),
                det.bin,
                det.range,
                det.power
            )?;
        }
    }
    write_whole(&out.join("detections.csv"), csv.as_bytes())?;
    written.extend(
        [
            "polar.png",
            "radar.timestamps",
            "cartesian.png",
            "detections.csv",
        ]
        .map(str::to_owned),
    );
    eprintln!(
        "power image: {} azimuths x {} bins in {ms:.1} ms; Cartesian view {CART_PIXELS} px at {mpp:.3} m/px",
        img.rows(),
        img.bins
    );
    Ok((written, Some(img)))
}
