//! Detection in power images (DESIGN §7.5): cell-averaging and ordered-statistic CFAR along
//! range, and CFEAR's k-strongest filter.
//!
//! The CFAR detectors work on linear power, recovered from the image's bytes through its dB
//! mapping; a bin is a detection when its power exceeds α times the noise estimated from the
//! training cells on both sides (guard cells left out). For cell averaging over N training
//! cells of exponential noise, α = N (P_fa^(−1/N) − 1) gives the false-alarm rate P_fa exactly.

use serde::Serialize;

use super::image::PowerImage;

/// A detected target.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Detection {
    /// Range of the bin's centre, m.
    pub range: f64,
    /// Azimuth, radians clockwise from the sensor's x axis (the image's row).
    pub azimuth: f64,
    /// The bin's value, 0–255.
    pub power: u8,
    /// Row.
    pub row: usize,
    /// Bin.
    pub bin: usize,
}

/// How detections are picked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Detector {
    /// Cell-averaging CFAR.
    CaCfar {
        /// Training cells on each side.
        train: usize,
        /// Guard cells on each side.
        guard: usize,
        /// Probability of false alarm.
        p_fa: f64,
    },
    /// Ordered-statistic CFAR: the noise is the k-th smallest training cell.
    OsCfar {
        /// Training cells on each side.
        train: usize,
        /// Guard cells on each side.
        guard: usize,
        /// Rank (1-based) of the training cell taken as the noise level.
        rank: usize,
        /// Threshold factor over that cell.
        alpha: f64,
    },
    /// The k strongest bins of each row at or above `z_min`, beyond `min_range` (CFEAR).
    KStrongest {
        /// Bins per row.
        k: usize,
        /// Lowest value, 0–255.
        z_min: u8,
        /// Nearest range, m.
        min_range: f64,
    },
}

impl Detector {
    /// The CA-CFAR radarnav writes by default: 16 training and 4 guard cells a side,
    /// P_fa = 10⁻³.
    pub const CA_CFAR: Self = Self::CaCfar {
        train: 16,
        guard: 4,
        p_fa: 1e-3,
    };

    /// CFEAR's defaults: k = 12, z_min = 60, 2.5 m.
    pub const K_STRONGEST: Self = Self::KStrongest {
        k: 12,
        z_min: 60,
        min_range: 2.5,
    };
}

/// The CA-CFAR threshold factor for `n` training cells and false-alarm rate `p_fa`.
pub fn ca_alpha(n: usize, p_fa: f64) -> f64 {
    n as f64 * (p_fa.powf(-1.0 / n as f64) - 1.0)
}

/// Detections of `detector` in `img`, whose bytes map linearly onto `display_range_db` dB.
pub fn detect(img: &PowerImage, detector: Detector, display_range_db: f64) -> Vec<Detection> {
    // Byte → linear power relative to the noise floor.
    let lut: Vec<f64> = (0..=255u32)
        .map(|v| 10f64.powf(f64::from(v) / 255.0 * display_range_db / 10.0))
        .collect();
    let mut out = Vec::new();
    let bins = img.bins;
    let mut window: Vec<f64> = Vec::new();
    for row in 0..img.rows() {
        let data = &img.power[row * bins..(row + 1) * bins];
        let mut push = |bin: usize| {
            out.push(Detection {
                range: (bin as f64 + 0.5) * img.bin_size,
                azimuth: img.azimuth(row),
                power: data[bin],
                row,
                bin,
            })
        };
        match detector {
            Detector::CaCfar { train, guard, p_fa } => {
                let alpha = ca_alpha(2 * train, p_fa);
                for j in train + guard..bins.saturating_sub(train + guard) {
                    let sum: f64 = (j - guard - train..j - guard)
                        .chain(j + guard + 1..=j + guard + train)
                        .map(|i| lut[usize::from(data[i])])
                        .sum();
                    if lut[usize::from(data[j])] > alpha * sum / (2 * train) as f64 {
                        push(j);
                    }
                }
            }
            Detector::OsCfar {
                train,
                guard,
                rank,
                alpha,
            } => {
                for j in train + guard..bins.saturating_sub(train + guard) {
                    window.clear();
                    window.extend(
                        (j - guard - train..j - guard)
                            .chain(j + guard + 1..=j + guard + train)
                            .map(|i| lut[usize::from(data[i])]),
                    );
                    let r = rank.clamp(1, window.len()) - 1;
                    let (_, noise, _) = window.select_nth_unstable_by(r, f64::total_cmp);
                    if lut[usize::from(data[j])] > alpha * *noise {
                        push(j);
                    }
                }
            }
            Detector::KStrongest {
                k,
                z_min,
                min_range,
            } => {
                let first = (min_range / img.bin_size).ceil() as usize;
                let mut cand: Vec<usize> = (first.min(bins)..bins)
                    .filter(|&j| data[j] >= z_min)
                    .collect();
                cand.sort_by(|&a, &b| data[b].cmp(&data[a]).then(a.cmp(&b)));
                cand.truncate(k);
                cand.sort_unstable();
                for j in cand {
                    push(j);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::Exp1;

    /// An image of exponential noise alone, written through the same dB mapping as
    /// [`super::super::image::power_image`] with a 0 dB floor, at a quantisation fine enough not
    /// to matter (a 40 dB display range over 255 steps).
    fn noise_image(seed: u64, display: f64) -> PowerImage {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (rows, bins) = (400, 2000);
        let power = (0..rows * bins)
            .map(|_| {
                let p: f64 = rng.sample(Exp1);
                // Offset by 20 dB so that weak noise is not clipped at 0.
                let db = 10.0 * p.log10() + 20.0;
                (db / display * 255.0).clamp(0.0, 255.0).round() as u8
            })
            .collect();
        PowerImage {
            timestamps_us: vec![0; rows],
            encoders: (0..rows as u16).collect(),
            encoder_size: 400,
            bins,
            bin_size: 0.05,
            power,
        }
    }

    #[test]
    fn ca_cfar_false_alarm_rate_on_noise_is_as_designed() {
        let display = 60.0;
        for (p_fa, seed) in [(1e-2, 1), (1e-3, 2)] {
            let img = noise_image(seed, display);
            let (train, guard) = (16, 2);
            let det = detect(&img, Detector::CaCfar { train, guard, p_fa }, display);
            let tested = img.rows() * (img.bins - 2 * (train + guard));
            let rate = det.len() as f64 / tested as f64;
            // 99 % binomial interval (normal approximation, z = 2.576), widened by 10 % of
            // P_fa for the 0.24 dB quantisation of the bytes.
            let sd = (p_fa * (1.0 - p_fa) / tested as f64).sqrt();
            let tol = 2.576 * sd + 0.1 * p_fa;
            assert!(
                (rate - p_fa).abs() <= tol,
                "P_fa {p_fa}: measured {rate} ± {tol}"
            );
        }
    }

    #[test]
    fn k_strongest_keeps_k_per_row_beyond_min_range() {
        let img = noise_image(3, 60.0);
        let det = detect(&img, Detector::K_STRONGEST, 60.0);
        assert!(det.len() <= 12 * img.rows());
        assert!(det.iter().all(|d| d.range >= 2.5 && d.power >= 60));
        let row0: Vec<_> = det.iter().filter(|d| d.row == 0).collect();
        let weakest = row0.iter().map(|d| d.power).min().unwrap();
        let data = &img.power[..img.bins];
        let first = (2.5f64 / 0.05).ceil() as usize;
        let stronger = data[first..].iter().filter(|&&v| v > weakest).count();
        assert!(stronger < 12);
    }

    #[test]
    fn os_cfar_finds_a_target_in_noise() {
        let mut img = noise_image(4, 60.0);
        img.power[1000] = 250;
        let det = detect(
            &img,
            Detector::OsCfar {
                train: 16,
                guard: 2,
                rank: 24,
                alpha: 30.0,
            },
            60.0,
        );
        assert!(det.iter().any(|d| d.row == 0 && d.bin == 1000));
    }
}
