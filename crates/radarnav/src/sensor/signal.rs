//! A radar's signal settings: beam pattern, echo model, return mode and power image
//! (DESIGN §7.1–7.4). The thesis model ignores all of them; `return = "thesis"` is the
//! default of every preset but the FMCW ones.

use serde::{Deserialize, Serialize};

use super::echo::{EchoModel, RangeLaw};

/// Which range a scan reports per azimuth (DESIGN §7.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReturnMode {
    /// The thesis' penetration budget (§3.1), exactly.
    Thesis,
    /// The nearest echo above the detection threshold.
    First,
    /// The strongest echo.
    Strongest,
    /// The farthest echo above the threshold.
    Last,
    /// The first echo as the range, and up to `max_echoes` echoes beside it.
    All,
}

impl ReturnMode {
    /// Every mode's name, for error messages.
    pub const NAMES: &'static str = "thesis, first, strongest, last, all";

    /// The mode named `s`.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "thesis" => Self::Thesis,
            "first" => Self::First,
            "strongest" => Self::Strongest,
            "last" => Self::Last,
            "all" => Self::All,
            _ => return None,
        })
    }
}

/// Which beam ray answers a single-range output (DESIGN §7.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Selection {
    /// Each with equal probability (the thesis' side beams).
    Uniform,
    /// Probability ∝ cosine of the incidence angle at the first surface.
    IncidenceWeighted,
    /// The ray with the nearest echo.
    Nearest,
    /// The ray with the strongest echo.
    Strongest,
}

impl Selection {
    /// Every selection's name, for error messages.
    pub const NAMES: &'static str = "uniform, incidence_weighted, nearest, strongest";

    /// The selection named `s`.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "uniform" => Self::Uniform,
            "incidence_weighted" => Self::IncidenceWeighted,
            "nearest" => Self::Nearest,
            "strongest" => Self::Strongest,
            _ => return None,
        })
    }

    /// Whether it needs a random draw per azimuth.
    pub fn random(self) -> bool {
        matches!(self, Self::Uniform | Self::IncidenceWeighted)
    }
}

/// One ray of an azimuth's beam, relative to the nominal ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamRay {
    /// Azimuth offset, rad.
    pub d_az: f64,
    /// Elevation offset, rad.
    pub d_el: f64,
    /// Origin shift to the ray's left, m (the thesis' side beams).
    pub lateral: f64,
    /// Two-way antenna weight; the weights of a beam sum to 1.
    pub weight: f64,
}

/// An FMCW scanning radar's power image (DESIGN §7.4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImageConfig {
    /// Chirp bandwidth, Hz: the range point-spread is c / (2B) wide.
    pub bandwidth_hz: f64,
    /// Mean receiver noise power, dB (same scale as echo power).
    pub noise_floor_db: f64,
    /// dB above the noise floor that map to 255.
    pub display_range_db: f64,
    /// Whether echoes fluctuate (exponential power, Rayleigh amplitude).
    pub speckle: bool,
    /// Encoder counts per turn written in each row (Navtech: 5600).
    pub encoder_size: u16,
}

/// Every signal setting of a sensor.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SignalConfig {
    /// What the scan's `ranges` report.
    pub return_mode: ReturnMode,
    /// Echo power against range.
    pub range_law: RangeLaw,
    /// Echoes below `−dynamic_range_db` are lost; the walk stops there, dB.
    pub dynamic_range_db: f64,
    /// Echoes weaker than this (dB) do not count for `first`, `strongest`, `last`, `all`.
    pub detection_threshold_db: f64,
    /// Most echoes per azimuth kept by `all`.
    pub max_echoes: usize,
    /// Specular bounces followed per ray.
    pub max_bounces: u8,
    /// Beam rays across azimuth.
    pub beam_rays_az: usize,
    /// Beam rays across elevation.
    pub beam_rays_el: usize,
    /// −3 dB two-way beam width in azimuth, rad.
    pub beamwidth_az: f64,
    /// −3 dB two-way beam width in elevation, rad.
    pub beamwidth_el: f64,
    /// Which beam ray answers a single range.
    pub selection: Selection,
    /// The power image of an FMCW radar.
    pub image: Option<ImageConfig>,
}

impl Default for SignalConfig {
    fn default() -> Self {
        Self {
            return_mode: ReturnMode::Thesis,
            range_law: RangeLaw::R2,
            dynamic_range_db: 80.0,
            detection_threshold_db: -60.0,
            max_echoes: 5,
            max_bounces: 2,
            beam_rays_az: 1,
            beam_rays_el: 1,
            beamwidth_az: 0.0,
            beamwidth_el: 0.0,
            selection: Selection::Uniform,
            image: None,
        }
    }
}

/// Most beam rays per azimuth.
pub const MAX_BEAM_RAYS: usize = 64;

impl SignalConfig {
    /// The echo walk's settings.
    pub fn echo_model(&self) -> EchoModel {
        EchoModel {
            range_law: self.range_law,
            dynamic_range_db: self.dynamic_range_db,
            max_bounces: self.max_bounces,
            min_power_db: f64::NEG_INFINITY,
            wanted: None,
        }
    }

    /// The beam's rays: the thesis' three side beams (centre, left, right: equal weights)
    /// when `side_beam_offset` > 0, else `beam_rays_az × beam_rays_el` rays at the middles of
    /// equal strata of ±one beam width, weighted by the Gaussian two-way pattern
    /// exp(−4 ln 2 (θ/θ₃dB)²) per axis.
    pub fn beam(&self, side_beam_offset: f64) -> Vec<BeamRay> {
        if side_beam_offset > 0.0 {
            return [0.0, side_beam_offset, -side_beam_offset]
                .iter()
                .map(|&lateral| BeamRay {
                    d_az: 0.0,
                    d_el: 0.0,
                    lateral,
                    weight: 1.0 / 3.0,
                })
                .collect();
        }
        let nodes = |n: usize, width: f64| -> Vec<(f64, f64)> {
            (0..n)
                .map(|i| {
                    let x = if n == 1 {
                        0.0
                    } else {
                        ((i as f64 + 0.5) / n as f64 - 0.5) * 2.0 * width
                    };
                    let w = if width > 0.0 {
                        (-4.0 * std::f64::consts::LN_2 * (x / width).powi(2)).exp()
                    } else {
                        1.0
                    };
                    (x, w)
                })
                .collect()
        };
        let (az, el) = (
            nodes(self.beam_rays_az, self.beamwidth_az),
            nodes(self.beam_rays_el, self.beamwidth_el),
        );
        let mut rays: Vec<BeamRay> = el
            .iter()
            .flat_map(|&(d_el, we)| {
                az.iter().map(move |&(d_az, wa)| BeamRay {
                    d_az,
                    d_el,
                    lateral: 0.0,
                    weight: wa * we,
                })
            })
            .collect();
        let total: f64 = rays.iter().map(|r| r.weight).sum();
        for r in &mut rays {
            r.weight /= total;
        }
        rays
    }

    /// Checks the ranges (those of [`crate::limits`]); the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::{
            BANDWIDTH, BEAM_RAYS, BEAMWIDTH, BOUNCES, DYNAMIC_RANGE, ECHOES, Limit, THRESHOLD,
        };
        let check = |key: &str, limit: &Limit, v: f64| {
            limit.check(v).map(|_| ()).map_err(|m| format!("{key} {m}"))
        };
        check("dynamic_range_db", &DYNAMIC_RANGE, self.dynamic_range_db)?;
        check(
            "detection_threshold_db",
            &THRESHOLD,
            self.detection_threshold_db,
        )?;
        check("max_echoes", &ECHOES, self.max_echoes as f64)?;
        check("max_bounces", &BOUNCES, f64::from(self.max_bounces))?;
        check("beam_rays", &BEAM_RAYS, self.beam_rays_az as f64)?;
        check("beam_rays_el", &BEAM_RAYS, self.beam_rays_el as f64)?;
        if self.beam_rays_az * self.beam_rays_el > MAX_BEAM_RAYS {
            return Err(format!(
                "beam_rays x beam_rays_el must be at most {MAX_BEAM_RAYS}"
            ));
        }
        check(
            "beamwidth_az_deg",
            &BEAMWIDTH,
            self.beamwidth_az.to_degrees(),
        )?;
        check(
            "beamwidth_el_deg",
            &BEAMWIDTH,
            self.beamwidth_el.to_degrees(),
        )?;
        if let Some(im) = &self.image {
            check("bandwidth_hz", &BANDWIDTH, im.bandwidth_hz)?;
            check("noise_floor_db", &THRESHOLD, im.noise_floor_db)?;
            check("display_range_db", &DYNAMIC_RANGE, im.display_range_db)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beam_weights_sum_to_one_and_follow_the_pattern() {
        let c = SignalConfig {
            beam_rays_az: 5,
            beam_rays_el: 3,
            beamwidth_az: 1.8f64.to_radians(),
            beamwidth_el: 1.8f64.to_radians(),
            ..SignalConfig::default()
        };
        let b = c.beam(0.0);
        assert_eq!(b.len(), 15);
        assert!((b.iter().map(|r| r.weight).sum::<f64>() - 1.0).abs() < 1e-12);
        // Symmetric, strongest in the middle.
        let mid = b[7];
        assert_eq!((mid.d_az, mid.d_el), (0.0, 0.0));
        assert!(b.iter().all(|r| r.weight <= mid.weight));
        assert!((b[5].d_az + b[9].d_az).abs() < 1e-15);
        // Side beams: three equal parallel rays.
        let s = SignalConfig::default().beam(0.2);
        assert_eq!(
            s.iter().map(|r| r.lateral).collect::<Vec<_>>(),
            [0.0, 0.2, -0.2]
        );
    }
}
