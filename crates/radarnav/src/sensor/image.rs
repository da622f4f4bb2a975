//! Polar power images of FMCW scanning radars (DESIGN §7.4), in the layout of the Oxford Radar
//! RobotCar dataset.
//!
//! The sensor turns while it measures: azimuth row k is taken at t₀ + k / (azimuths · rate)
//! from the pose at that instant, so a moving robot's image is distorted as real data is. Row k
//! looks θₖ = k · 2π / azimuths clockwise from the sensor's x axis (the radar's own frame: x
//! forward, y right), which is how the dataset's SDK and pyboreas turn rows into Cartesian
//! images. Every echo of every beam ray is added, in linear power, into range bins through a
//! Gaussian point-spread of full width c / (2B); with speckle, each echo's power is first
//! multiplied by an exponential draw (Rayleigh amplitude). Receiver noise, exponential with
//! mean `noise_floor_db`, is added to every bin; power in dB is then mapped linearly onto
//! 0–255 over `[noise_floor_db, noise_floor_db + display_range_db]`. Bin j holds ranges
//! [j·b, (j+1)·b), its centre at (j + ½)·b as the SDK reads it.

use std::io::Write;

use rand::Rng;
use rand_distr::Exp1;

use super::echo::{Echo, EchoKind};
use super::signal::ImageConfig;
use super::{SensorConfig, Tracer, beam_ray};
use crate::pose::Pose;
use crate::world::{Fan, World};

/// Speed of light, m/s.
const C: f64 = 299_792_458.0;

/// The Oxford row header: 8 bytes timestamp, 2 bytes encoder, 1 byte valid flag.
pub const ROW_HEADER: usize = 11;

/// The UNIX time, µs, that simulation time 0 is stamped with in images (see [`crate::stamp`]).
pub const IMAGE_EPOCH_US: i64 = crate::stamp::EPOCH_US;

/// Writes an 8-bit grey PNG of `width` × `height` pixels, row after row.
pub fn write_grey_png<W: Write>(
    out: W,
    width: usize,
    height: usize,
    data: &[u8],
) -> Result<(), png::EncodingError> {
    let mut enc = png::Encoder::new(out, width as u32, height as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header()?;
    w.write_image_data(data)?;
    w.finish()
}

/// A polar power image: one row per azimuth.
#[derive(Clone, Debug, PartialEq)]
pub struct PowerImage {
    /// UNIX time of each row, µs.
    pub timestamps_us: Vec<i64>,
    /// Encoder count of each row (`encoder_size` per turn).
    pub encoders: Vec<u16>,
    /// Counts per turn.
    pub encoder_size: u16,
    /// Range bins per row.
    pub bins: usize,
    /// Bin size, m.
    pub bin_size: f64,
    /// Power, 0–255, row after row.
    pub power: Vec<u8>,
}

impl PowerImage {
    /// Number of azimuth rows.
    pub fn rows(&self) -> usize {
        self.timestamps_us.len()
    }

    /// Row `k`'s azimuth, radians clockwise from the sensor's x axis.
    pub fn azimuth(&self, k: usize) -> f64 {
        f64::from(self.encoders[k]) * std::f64::consts::TAU / f64::from(self.encoder_size)
    }

    /// The file name of this image in the Oxford layout: the first row's µs stamp.
    pub fn file_name(&self) -> String {
        format!("{}.png", self.timestamps_us.first().copied().unwrap_or(0))
    }

    /// Writes the image as an 8-bit grey PNG in the Oxford Radar RobotCar layout: per row,
    /// bytes 0–7 the `i64` little-endian UNIX µs stamp, 8–9 the `u16` little-endian encoder
    /// count, 10 the valid flag (255), then one byte of power per range bin.
    pub fn write_png<W: Write>(&self, out: W) -> Result<(), png::EncodingError> {
        write_grey_png(
            out,
            ROW_HEADER + self.bins,
            self.rows(),
            &self.oxford_rows(),
        )
    }

    /// The pixels of [`PowerImage::write_png`], row after row ([`ROW_HEADER`] + `bins` bytes
    /// a row).
    pub fn oxford_rows(&self) -> Vec<u8> {
        let width = ROW_HEADER + self.bins;
        let mut data = Vec::with_capacity(width * self.rows());
        for k in 0..self.rows() {
            data.extend_from_slice(&self.timestamps_us[k].to_le_bytes());
            data.extend_from_slice(&self.encoders[k].to_le_bytes());
            data.push(255);
            data.extend_from_slice(&self.power[k * self.bins..(k + 1) * self.bins]);
        }
        data
    }

    /// The `radar.timestamps` line of this image: "<µs> 1" (1 = valid), as the dataset's.
    pub fn timestamps_line(&self) -> String {
        format!("{} 1\n", self.timestamps_us.first().copied().unwrap_or(0))
    }

    /// Reads an image written by [`PowerImage::write_png`] (or any 8-bit grey image in the
    /// Oxford layout) back; `bin_size` and `encoder_size` are not in the file.
    pub fn read_png(bytes: &[u8], bin_size: f64, encoder_size: u16) -> Result<Self, String> {
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = dec.read_info().map_err(|e| e.to_string())?;
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
        if info.color_type != png::ColorType::Grayscale || info.bit_depth != png::BitDepth::Eight {
            return Err("not an 8-bit grey image".into());
        }
        let (width, rows) = (info.width as usize, info.height as usize);
        let bins = width
            .checked_sub(ROW_HEADER)
            .ok_or("narrower than the 11-byte row header")?;
        let mut img = Self {
            timestamps_us: Vec::with_capacity(rows),
            encoders: Vec::with_capacity(rows),
            encoder_size,
            bins,
            bin_size,
            power: Vec::with_capacity(rows * bins),
        };
        for row in buf[..width * rows].chunks_exact(width) {
            img.timestamps_us
                .push(i64::from_le_bytes(row[0..8].try_into().expect("8 bytes")));
            img.encoders.push(u16::from_le_bytes([row[8], row[9]]));
            img.power.extend_from_slice(&row[ROW_HEADER..]);
        }
        Ok(img)
    }

    /// The value at a point `forward` metres ahead of and `right` metres to the right of the
    /// sensor (nearest row and bin); `None` outside the image's range.
    pub fn value_at(&self, forward: f64, right: f64) -> Option<u8> {
        let bin = (forward.hypot(right) / self.bin_size) as usize;
        if bin >= self.bins || self.rows() == 0 {
            return None;
        }
        let step = std::f64::consts::TAU / self.rows() as f64;
        let theta = right.atan2(forward).rem_euclid(std::f64::consts::TAU);
        let k = ((theta / step).round() as usize) % self.rows();
        Some(self.power[k * self.bins + bin])
    }

    /// A Cartesian view for people: `pixels` × `pixels`, `metres_per_pixel`, the sensor in the
    /// middle, its x axis up and its left to the left (nearest row and bin).
    pub fn cartesian(&self, pixels: usize, metres_per_pixel: f64) -> Vec<u8> {
        let mut out = vec![0u8; pixels * pixels];
        let half = pixels as f64 / 2.0;
        for row in 0..pixels {
            for col in 0..pixels {
                let forward = (half - row as f64 - 0.5) * metres_per_pixel;
                let right = (col as f64 + 0.5 - half) * metres_per_pixel;
                if let Some(v) = self.value_at(forward, right) {
                    out[row * pixels + col] = v;
                }
            }
        }
        out
    }
}

/// Appends to `out` the echoes of every beam ray of `sensor` at `theta` radians clockwise from
/// the x axis of the sensor at `pose` (the echoes of one image row, before speckle). A `fan`
/// built at the sensor's position (see [`World::fan`]) speeds the walk up; one built
/// elsewhere is not used.
pub fn azimuth_echoes(
    sensor: &SensorConfig,
    world: &World,
    pose: &Pose,
    theta: f64,
    fan: Option<&Fan>,
    tracer: &mut Tracer,
    out: &mut Vec<Echo>,
) {
    let model = sensor.signal.echo_model();
    let el = sensor.elevations.first().copied().unwrap_or(0.0);
    let fan = fan.filter(|f| f.origin() == pose.position());
    for b in sensor.signal.beam(0.0) {
        // Clockwise in the radar frame is clockwise in the world too: yaw − θ.
        let ray = beam_ray(pose, -theta + b.d_az, (el + b.d_el).sin_cos(), 0.0);
        let (w, max) = (b.weight, sensor.range_max);
        match fan {
            Some(fan) => {
                let heading = pose.yaw - theta + b.d_az;
                let e = &mut tracer.echo;
                e.echoes_in_fan(world, fan, heading, &ray, w, max, &model, out);
            }
            None => {
                tracer.echo.echoes(world, &ray, w, max, &model, out);
            }
        }
    }
}

/// One image from `sensor` (which must have an [`ImageConfig`] and a range bin) starting at
/// simulation time `t0`, the pose of the sensor at time t given by `pose_at`. Row stamps are
/// `epoch_us` plus the simulation time. Speckle and noise come from `rng`, row by row.
pub fn power_image<R: Rng + ?Sized>(
    sensor: &SensorConfig,
    world: &World,
    t0: f64,
    epoch_us: i64,
    pose_at: &dyn Fn(f64) -> Pose,
    rng: &mut R,
    tracer: &mut Tracer,
) -> Option<PowerImage> {
    let im: &ImageConfig = sensor.signal.image.as_ref()?;
    let bin = sensor.range_bin?;
    let rows = (std::f64::consts::TAU / sensor.resolution).round() as usize;
    let bins = (sensor.range_max / bin).round() as usize;
    let noise = 10f64.powf(im.noise_floor_db / 10.0);
    let sigma = C / (2.0 * im.bandwidth_hz) / (8.0 * std::f64::consts::LN_2).sqrt();
    let reach = (3.0 * sigma / bin).ceil() as i64;
    let mut img = PowerImage {
        timestamps_us: Vec::with_capacity(rows),
        encoders: Vec::with_capacity(rows),
        encoder_size: im.encoder_size,
        bins,
        bin_size: bin,
        power: Vec::with_capacity(rows * bins),
    };
    let mut fan = std::mem::take(&mut tracer.fan);
    let mut fan_ok = false;
    let mut acc = vec![0.0f64; bins];
    let noise_bytes = NoiseBytes::new(im.display_range_db);
    let mut parts: Vec<f64> = Vec::with_capacity(2 * reach as usize + 1);
    let mut echoes: Vec<Echo> = Vec::new();
    for k in 0..rows {
        let t = t0 + k as f64 / (rows as f64 * sensor.rate_hz);
        let pose = pose_at(t);
        let theta = k as f64 * std::f64::consts::TAU / rows as f64;
        img.timestamps_us.push(epoch_us + (t * 1e6).round() as i64);
        img.encoders.push(
            ((theta / std::f64::consts::TAU * f64::from(im.encoder_size)).round() as u32
                % u32::from(im.encoder_size)) as u16,
        );
        echoes.clear();
        if k == 0 {
            // Rows taken from where the first was (a sensor standing still) share one fan.
            let rays = rows * sensor.signal.beam(0.0).len();
            fan_ok = sensor.scan_fan(world, &pose, rays, &mut fan);
        }
        let f = fan_ok.then_some(&fan);
        azimuth_echoes(sensor, world, &pose, theta, f, tracer, &mut echoes);
        acc.fill(0.0);
        let mut splat = |range: f64, p: f64| {
            let centre = range / bin - 0.5;
            let j0 = centre.round() as i64;
            let lo = (j0 - reach).max(0);
            let hi = (j0 + reach).min(bins as i64 - 1);
            if hi < lo {
                return;
            }
            parts.clear();
            parts.extend((lo..=hi).map(|j| {
                let d = (j as f64 - centre) * bin / sigma;
                (-0.5 * d * d).exp()
            }));
            let total: f64 = parts.iter().sum();
            if total > 0.0 {
                for (a, part) in acc[lo as usize..=hi as usize].iter_mut().zip(&parts) {
                    *a += p * part / total;
                }
            }
        };
        for e in &echoes {
            let fluct = |rng: &mut R| {
                if im.speckle {
                    rng.sample::<f64, _>(Exp1)
                } else {
                    1.0
                }
            };
            match e.kind {
                EchoKind::Surface => splat(e.range, e.power * fluct(rng)),
                EchoKind::Volume => {
                    // The echo's power spread over its depth by its two-way decay, bin by bin.
                    let pieces = (e.depth / bin).ceil().max(1.0) as usize;
                    let step = e.depth / pieces as f64;
                    let k = e.decay_db_per_m * std::f64::consts::LN_10 / 10.0;
                    let whole = if k > 0.0 {
                        -(-k * e.depth).exp_m1() / k
                    } else {
                        e.depth
                    };
                    let p = e.power;
                    for i in 0..pieces {
                        let s = i as f64 * step;
                        let part = if k > 0.0 {
                            (-k * s).exp() * -(-k * step).exp_m1() / k
                        } else {
                            step
                        };
                        splat(e.range + s + step / 2.0, p * part / whole * fluct(rng));
                    }
                }
            }
        }
        for &a in &acc {
            let r = rng.next_u32();
            if a == 0.0 {
                img.power.push(noise_bytes.byte(r));
            } else {
                let total = a + noise * exp_of(r);
                let db = 10.0 * total.log10();
                let v = (db - im.noise_floor_db) / im.display_range_db * 255.0;
                img.power.push(v.clamp(0.0, 255.0) as u8);
            }
        }
    }
    tracer.fan = fan;
    Some(img)
}

/// The standard exponential draw of the uniform 32-bit draw `r`: −ln(1 − u) with
/// u = (r + ½) / 2³², by inversion.
fn exp_of(r: u32) -> f64 {
    let u = (f64::from(r) + 0.5) / 4_294_967_296.0;
    -(-u).ln_1p()
}

/// The byte of a bin holding receiver noise alone, straight from the uniform draw that
/// [`exp_of`] would turn into the noise: the byte is a step function of the draw, so 255
/// thresholds give it exactly, without a logarithm per bin (most bins of an image hold noise
/// alone). A table over the draw's top bits answers at once where its bucket holds no
/// threshold (all but at most 255 of its buckets), a search over the thresholds elsewhere.
struct NoiseBytes {
    /// `thresholds[b]`: how many draws give a byte ≤ b.
    thresholds: Vec<u64>,
    /// Per bucket of draws (top [`NoiseBytes::BITS`] bits): its byte, or
    /// [`NoiseBytes::SEARCH`] when a threshold falls inside it.
    table: Vec<u16>,
}

impl NoiseBytes {
    /// Bits of the draw that index the table.
    const BITS: u32 = 14;
    /// Marks a bucket that holds a threshold.
    const SEARCH: u16 = 256;

    /// For noise of mean 1 mapped at `display_range_db` dB over 255 steps from its mean.
    fn new(display_range_db: f64) -> Self {
        let thresholds: Vec<u64> = (0..255u32)
            .map(|b| {
                // Byte ≤ b ⟺ 10·log10(E) < (b + 1)·D/255 ⟺ E < e_b ⟺ u < 1 − exp(−e_b).
                let e_b = 10f64.powf(f64::from(b + 1) * display_range_db / 2550.0);
                let c = -(-e_b).exp_m1();
                (c * 4_294_967_296.0 - 0.5)
                    .ceil()
                    .clamp(0.0, 4_294_967_296.0) as u64
            })
            .collect();
        let shift = 32 - Self::BITS;
        let mut b = 0;
        let table = (0..1u64 << Self::BITS)
            .map(|i| {
                let (lo, hi) = (i << shift, ((i + 1) << shift) - 1);
                while b < thresholds.len() && thresholds[b] <= lo {
                    b += 1;
                }
                // Byte of `lo` is b; of `hi` too unless the next threshold lies in between.
                if b < thresholds.len() && thresholds[b] <= hi {
                    Self::SEARCH
                } else {
                    b as u16
                }
            })
            .collect();
        Self { thresholds, table }
    }

    fn byte(&self, r: u32) -> u8 {
        match self.table[(r >> (32 - Self::BITS)) as usize] {
            Self::SEARCH => self.thresholds.partition_point(|&t| t <= u64::from(r)) as u8,
            b => b as u8,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::preset;
    use crate::world::{MaterialTable, Object, Shape};
    use glam::DVec3;
    use rand::SeedableRng;

    #[test]
    fn noise_bytes_from_thresholds_equal_the_direct_mapping() {
        for display in [30.0, 50.0, 65.0] {
            let nb = NoiseBytes::new(display);
            let mut checked = 0;
            for k in 0..200_000u64 {
                let r = (k * 21_474 + k % 7) as u32;
                let v = 10.0 * exp_of(r).log10() / display * 255.0;
                // Draws within rounding of a step are left out.
                if (v - v.round()).abs() < 1e-6 {
                    continue;
                }
                assert_eq!(
                    nb.byte(r),
                    v.clamp(0.0, 255.0) as u8,
                    "r {r} display {display}"
                );
                checked += 1;
            }
            assert!(checked > 199_000);
            assert_eq!(
                nb.byte(u32::MAX),
                (10.0 * exp_of(u32::MAX).log10() / display * 255.0) as u8
            );
        }
    }

    #[test]
    fn oxford_png_round_trips_byte_exactly() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let img = PowerImage {
            timestamps_us: (0..400).map(|k| 1_500_000_000_000_000 + k * 625).collect(),
            encoders: (0..400).map(|k| (k * 14) as u16).collect(),
            encoder_size: 5600,
            bins: 3768,
            bin_size: 0.0438,
            power: (0..400 * 3768).map(|_| rng.random()).collect(),
        };
        let mut bytes = Vec::new();
        img.write_png(&mut bytes).unwrap();
        let back = PowerImage::read_png(&bytes, 0.0438, 5600).unwrap();
        assert_eq!(back, img);
        let mut again = Vec::new();
        back.write_png(&mut again).unwrap();
        assert_eq!(again, bytes);
    }

    #[test]
    fn a_post_ahead_left_shows_in_its_row_and_bin() {
        let materials = MaterialTable::default();
        let metal = materials.id("metal").unwrap();
        // A post 20 m away, 30° to the robot's left.
        let at = DVec3::new(
            20.0 * 30f64.to_radians().cos(),
            20.0 * 30f64.to_radians().sin(),
            1.0,
        );
        let world = World::new(
            materials,
            vec![Object {
                name: None,
                shape: Shape::cylinder(at, 0.3, 2.0).unwrap(),
                material: metal,
            }],
        );
        let cfg = preset("navtech_cts350x").unwrap();
        let pose = Pose::new(0.0, 0.0, 0.5, 0.0);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let img = power_image(
            &cfg,
            &world,
            0.0,
            0,
            &|_| pose,
            &mut rng,
            &mut Tracer::default(),
        )
        .unwrap();
        assert_eq!((img.rows(), img.bins), (400, 3768));
        let (k, j) = (0..img.rows())
            .flat_map(|k| (0..img.bins).map(move |j| (k, j)))
            .max_by_key(|&(k, j)| img.power[k * img.bins + j])
            .unwrap();
        // 30° to the left is 330° clockwise; the post's face is 19.7 m out.
        let az = img.azimuth(k).to_degrees();
        assert!((az - 330.0).abs() <= 1.8, "row {k} at {az}°");
        let r = (j as f64 + 0.5) * img.bin_size;
        assert!((r - 19.7).abs() < 0.2, "{r}");
        // The Cartesian view puts it up and to the left.
        let cart = img.cartesian(201, 0.25);
        let (row, col) = (0..201 * 201)
            .map(|i| (i / 201, i % 201))
            .max_by_key(|&(r, c)| cart[r * 201 + c])
            .unwrap();
        assert!(row < 100 && col < 100, "({row}, {col})");
    }
}
