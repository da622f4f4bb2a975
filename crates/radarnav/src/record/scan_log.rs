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
//! A sensor in `all` return mode (DESIGN §7.3) has `max_echoes` = E > 0 in its header, and each
//! record goes on with its echoes, `n + 16·n·E` more bytes:
//!
//! | bytes | content |
//! |---|---|
//! | n | `u8` echo count of each ray (at most E) |
//! | 16·n·E | E slots per ray, by range: `f32` range (m), `f32` depth (m, 0 for a surface echo), `f32` power (dB), `u16` material, `u8` kind (0 surface, 1 volume), `u8` specular bounces; unused slots are zero |
//!
//! Rays are stored as in [`Scan`]: plane by plane, azimuth by azimuth. In NumPy a record is
//! `np.dtype([("stamp","<f8"),("pose","<f8",4),("ranges","<f4",n),("hit","u1",n),("beam","u1",n),("material","<u2",n)])`,
//! with `("echo_count","u1",n),("echoes",[("range","<f4"),("depth","<f4"),("power_db","<f4"),("material","<u2"),("kind","u1"),("bounces","u1")],(n,E))`
//! appended for an echo log.

use std::io::{self, Write};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::pose::Pose;
use crate::sensor::{Beam, Echo, EchoKind, HitKind, ReturnMode, Scan, SensorKind};
use crate::setup::MountedSensor;
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
    /// Echo slots per ray (`all` return mode); 0 = no echo block.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub max_echoes: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Bytes of one echo slot.
const ECHO_SLOT: usize = 16;

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
            max_echoes: if c.signal.return_mode == ReturnMode::All {
                c.signal.max_echoes
            } else {
                0
            },
        }
    }

    fn rays(&self) -> usize {
        self.azimuths * self.elevations.len()
    }

    /// Bytes of one record.
    fn record_len(&self) -> usize {
        let n = self.rays();
        let echoes = if self.max_echoes > 0 {
            n + ECHO_SLOT * n * self.max_echoes
        } else {
            0
        };
        40 + 8 * n + echoes
    }
}

/// Writes a scan log to any byte sink.
#[derive(Debug)]
pub struct ScanLogWriter<W: Write> {
    out: W,
    rays: usize,
    max_echoes: usize,
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
            max_echoes: header.max_echoes,
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
        let slots = self.max_echoes;
        if slots > 0 {
            let count = |i: usize| scan.echoes_of(i).len().min(slots);
            b.extend((0..self.rays).map(|i| count(i) as u8));
            for i in 0..self.rays {
                let echoes = &scan.echoes_of(i)[..count(i)];
                for e in echoes {
                    b.extend_from_slice(&(e.range as f32).to_le_bytes());
                    b.extend_from_slice(&(e.depth as f32).to_le_bytes());
                    b.extend_from_slice(&(e.power_db() as f32).to_le_bytes());
                    b.extend_from_slice(&e.material.0.to_le_bytes());
                    b.push(match e.kind {
                        EchoKind::Surface => 0,
                        EchoKind::Volume => 1,
                    });
                    b.push(e.bounces);
                }
                b.resize(b.len() + ECHO_SLOT * (slots - echoes.len()), 0);
            }
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
    // A header from another writer (or a damaged one) must not size a record beyond what a
    // sensor can have: the products below would overflow.
    let rays = header.azimuths.checked_mul(header.elevations.len());
    if rays.is_none_or(|r| r > crate::sensor::MAX_RAYS) || header.max_echoes > 64 {
        return Err(ScanLogError::Header(format!(
            "{} azimuths x {} planes x {} echoes is more than a sensor has",
            header.azimuths,
            header.elevations.len(),
            header.max_echoes
        )));
    }
    let n = header.rays();
    let record = header.record_len();
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
        let materials = r[40 + 6 * n..40 + 8 * n]
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
            echoes: Vec::new(),
            echo_start: Vec::new(),
        });
        if header.max_echoes > 0 {
            read_echoes(
                &r[40 + 8 * n..],
                n,
                header.max_echoes,
                k,
                scans.last_mut().expect("pushed"),
            )?;
        }
    }
    Ok((header, scans))
}

/// Reads the echo block of record `k` into `scan`.
fn read_echoes(
    block: &[u8],
    n: usize,
    slots: usize,
    k: usize,
    scan: &mut Scan,
) -> Result<(), ScanLogError> {
    let f32_at = |i: usize| {
        f64::from(f32::from_le_bytes(
            block[i..i + 4].try_into().expect("4 bytes"),
        ))
    };
    for i in 0..n {
        let count = block[i];
        if usize::from(count) > slots {
            return Err(ScanLogError::BadCode {
                scan: k,
                what: "echo count",
                code: count,
            });
        }
        scan.echo_start.push(scan.echoes.len() as u32);
        for j in 0..usize::from(count) {
            let at = n + ECHO_SLOT * (i * slots + j);
            let kind = match block[at + 14] {
                0 => EchoKind::Surface,
                1 => EchoKind::Volume,
                code => {
                    return Err(ScanLogError::BadCode {
                        scan: k,
                        what: "echo kind",
                        code,
                    });
                }
            };
            scan.echoes.push(Echo {
                range: f32_at(at),
                depth: f32_at(at + 4),
                decay_db_per_m: 0.0,
                power: crate::sensor::echo::from_db(f32_at(at + 8)),
                material: MaterialId(u16::from_le_bytes([block[at + 12], block[at + 13]])),
                kind,
                bounces: block[at + 15],
            });
        }
    }
    scan.echo_start.push(scan.echoes.len() as u32);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::Tracer;
    use crate::setup::Scenario;
    use rand::SeedableRng;

    /// A multi-echo scan of foliage-wall's radar written and read back: the same ranges and
    /// the same echoes (to f32), behind a header that says how many echo slots a ray has.
    #[test]
    fn echo_scans_read_back() {
        let src = crate::scenario::builtin_source("foliage-wall").unwrap();
        let src = src.replace(
            "preset = \"radar_thesis\"",
            "preset = \"radar_thesis\"\nreturn = \"all\"\nmax_echoes = 3",
        );
        let s = Scenario::from_toml(&src, "fw.toml", "fw").unwrap();
        let sensor = &s.robots[0].sensors[0];
        let header = ScanLogHeader::new(sensor, s.world.materials());
        assert_eq!(header.max_echoes, 3);
        let pose = s.robots[0].start.compose(&sensor.mount);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let scans: Vec<Scan> = (0..2)
            .map(|k| {
                let stamp = f64::from(k) * 0.25;
                let mut tr = Tracer::default();
                sensor
                    .config
                    .scan(&s.world, &pose, stamp, &mut rng, &mut tr)
            })
            .collect();
        assert!(
            scans[0].echoes.len() > scans[0].len(),
            "several echoes per ray"
        );
        let mut w = ScanLogWriter::new(Vec::new(), &header).unwrap();
        for scan in &scans {
            w.write(scan).unwrap();
        }
        let bytes = w.finish().unwrap();
        let (h, back) = read_scan_log(&bytes).unwrap();
        assert_eq!(h, header);
        for (a, b) in scans.iter().zip(&back) {
            assert_eq!(a.ranges, b.ranges);
            assert_eq!(a.echo_start, b.echo_start);
            for (x, y) in a.echoes.iter().zip(&b.echoes) {
                assert_eq!(
                    (x.range as f32, x.power_db() as f32),
                    (y.range as f32, y.power_db() as f32)
                );
                assert_eq!(
                    (x.material, x.kind, x.bounces),
                    (y.material, y.kind, y.bounces)
                );
            }
        }
    }
}
