//! The compact binary scan log: every scan of one sensor in one file (`scans/<sensor>.rnscan`).
//!
//! Layout, all little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `RNSCAN` followed by `0x00 0x01` (format version 1) |
//! | 4 | `u32` length `L` of the header |
//! | L | header: UTF-8 JSON [`ScanLogHeader`] (sensor, preset, geometry, material names) |
//! | … | one record per scan, each `40 + 8·n` bytes for `n` rays: |
//! | 40 | `f64` stamp (s), then the sensor pose in the world: `f64` x, y, z (m), yaw (rad) |
//! | 4·n | `f32` ranges (m; `+inf` no return, `-inf` closer than `range_min`) |
//! | n | `u8` hit kind: 0 none, 1 exhausted (radar budget ran out), 2 solid |
//! | n | `u8` beam: 0 centre, 1 left, 2 right |
//! | 2·n | `u16` material index into the header's `materials`; `0xFFFF` none |
//!
//! Rays are stored as in [`Scan`]: plane by plane, azimuth by azimuth. In NumPy a record is
//! `np.dtype([("stamp","<f8"),("pose","<f8",4),("ranges","<f4",n),("hit","u1",n),("beam","u1",n),("material","<u2",n)])`.

use std::io::{self, Write};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::pose::Pose;
use crate::scenario::MountedSensor;
use crate::sensor::{Beam, HitKind, Scan, SensorKind};
use crate::world::{MaterialId, MaterialTable};

/// First eight bytes of a scan log.
pub const MAGIC: [u8; 8] = *b"RNSCAN\x00\x01";

/// The JSON header of a scan log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScanLogHeader {
    /// Sensor name on its robot.
    pub sensor: String,
    /// Preset it was built from.
    pub preset: Option<String>,
    /// Sensor model.
    pub kind: SensorKind,
    /// Rays per plane.
    pub azimuths: usize,
    /// Elevation of each plane, rad.
    pub elevations: Vec<f64>,
    /// Azimuth of the first ray, rad.
    pub angle_min: f64,
    /// Azimuth step, rad.
    pub angle_increment: f64,
    /// m.
    pub range_min: f64,
    /// m.
    pub range_max: f64,
    /// Side-beam offset in use, m.
    pub side_beam_offset: f64,
    /// Scans per second.
    pub rate_hz: f64,
    /// Mount on the robot.
    pub mount: Pose,
    /// Material names by index.
    pub materials: Vec<String>,
}

impl ScanLogHeader {
    /// The header for `sensor`, whose scans name materials of `materials`.
    pub fn new(sensor: &MountedSensor, materials: &MaterialTable) -> Self {
        let c = &sensor.config;
        Self {
            sensor: sensor.name.clone(),
            preset: c.preset.clone(),
            kind: c.kind,
            azimuths: c.azimuth_count(),
            elevations: c.elevations.clone(),
            angle_min: c.angle_min(),
            angle_increment: c.resolution,
            range_min: c.range_min,
            range_max: c.range_max,
            side_beam_offset: if c.kind == SensorKind::GroundTruth {
                0.0
            } else {
                c.side_beam_offset
            },
            rate_hz: c.rate_hz,
            mount: sensor.mount,
            materials: materials.names().iter().map(|n| n.to_string()).collect(),
        }
    }

    fn rays(&self) -> usize {
        self.azimuths * self.elevations.len()
    }
}

/// Writes a scan log to any byte sink.
#[derive(Debug)]
pub struct ScanLogWriter<W: Write> {
    out: W,
    rays: usize,
    buf: Vec<u8>,
}

impl<W: Write> ScanLogWriter<W> {
    /// Writes the magic and header.
    pub fn new(mut out: W, header: &ScanLogHeader) -> io::Result<Self> {
        let json = serde_json::to_vec(header).map_err(io::Error::other)?;
        out.write_all(&MAGIC)?;
        let len = u32::try_from(json.len()).map_err(io::Error::other)?;
        out.write_all(&len.to_le_bytes())?;
        out.write_all(&json)?;
        Ok(Self {
            out,
            rays: header.rays(),
            buf: Vec::new(),
        })
    }

    /// Appends one scan; it must have the header's ray count.
    pub fn write(&mut self, scan: &Scan) -> io::Result<()> {
        if scan.len() != self.rays {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("scan has {} rays, the log {}", scan.len(), self.rays),
            ));
        }
        let b = &mut self.buf;
        b.clear();
        let p = &scan.pose;
        for v in [scan.stamp, p.x, p.y, p.z, p.yaw] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for r in &scan.ranges {
            b.extend_from_slice(&r.to_le_bytes());
        }
        b.extend(scan.hits.iter().map(|h| match h {
            HitKind::None => 0u8,
            HitKind::Exhausted => 1,
            HitKind::Solid => 2,
        }));
        b.extend(scan.beams.iter().map(|h| match h {
            Beam::Center => 0u8,
            Beam::Left => 1,
            Beam::Right => 2,
        }));
        for m in &scan.materials {
            b.extend_from_slice(&m.map_or(u16::MAX, |m| m.0).to_le_bytes());
        }
        self.out.write_all(b)
    }

    /// Flushes and returns the sink.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// A scan log that could not be read.
#[derive(Debug, Error, PartialEq)]
pub enum ScanLogError {
    /// Not a scan log, or another version.
    #[error("not a radarnav scan log (bad magic or version)")]
    Magic,
    /// The header is not valid.
    #[error("bad header: {0}")]
    Header(String),
    /// The file ends inside a record.
    #[error("truncated: {0} bytes left after the last whole scan")]
    Truncated(usize),
    /// A byte that is no hit kind or beam.
    #[error("scan {scan}: bad {what} code {code}")]
    BadCode {
        /// Scan index.
        scan: usize,
        /// Which column.
        what: &'static str,
        /// The value.
        code: u8,
    },
}

/// Reads a whole scan log back: its header and every scan.
pub fn read_scan_log(bytes: &[u8]) -> Result<(ScanLogHeader, Vec<Scan>), ScanLogError> {
    if bytes.len() < 12 || bytes[..8] != MAGIC {
        return Err(ScanLogError::Magic);
    }
    let len = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
    let json = bytes
        .get(12..12 + len)
        .ok_or_else(|| ScanLogError::Header("header runs past the end".into()))?;
    let header: ScanLogHeader =
        serde_json::from_slice(json).map_err(|e| ScanLogError::Header(e.to_string()))?;
    let n = header.rays();
    let record = 40 + 8 * n;
    let body = &bytes[12 + len..];
    if !body.len().is_multiple_of(record) {
        return Err(ScanLogError::Truncated(body.len() % record));
    }
    let f64_at = |b: &[u8], i: usize| f64::from_le_bytes(b[i..i + 8].try_into().expect("8 bytes"));
    let mut scans = Vec::with_capacity(body.len() / record);
    for (k, r) in body.chunks_exact(record).enumerate() {
        let ranges = r[40..40 + 4 * n]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        let hits = r[40 + 4 * n..40 + 5 * n]
            .iter()
            .map(|&c| match c {
                0 => Ok(HitKind::None),
                1 => Ok(HitKind::Exhausted),
                2 => Ok(HitKind::Solid),
                code => Err(ScanLogError::BadCode {
                    scan: k,
                    what: "hit",
                    code,
                }),
            })
            .collect::<Result<_, _>>()?;
        let beams = r[40 + 5 * n..40 + 6 * n]
            .iter()
            .map(|&c| match c {
                0 => Ok(Beam::Center),
                1 => Ok(Beam::Left),
                2 => Ok(Beam::Right),
                code => Err(ScanLogError::BadCode {
                    scan: k,
                    what: "beam",
                    code,
                }),
            })
            .collect::<Result<_, _>>()?;
        let materials = r[40 + 6 * n..]
            .chunks_exact(2)
            .map(|c| {
                let m = u16::from_le_bytes([c[0], c[1]]);
                (m != u16::MAX).then_some(MaterialId(m))
            })
            .collect();
        scans.push(Scan {
            stamp: f64_at(r, 0),
            kind: header.kind,
            pose: Pose::new(f64_at(r, 8), f64_at(r, 16), f64_at(r, 24), f64_at(r, 32)),
            angle_min: header.angle_min,
            angle_increment: header.angle_increment,
            azimuths: header.azimuths,
            elevations: header.elevations.clone(),
            range_min: header.range_min,
            range_max: header.range_max,
            side_beam_offset: header.side_beam_offset,
            ranges,
            hits,
            materials,
            beams,
        });
    }
    Ok((header, scans))
}
