//! Sensor parameters and the named presets of real and thesis sensors (DESIGN §3.2, §3.2b).

use serde::Serialize;

use super::echo::RangeLaw;
use super::signal::{ImageConfig, ReturnMode, Selection, SignalConfig};
use crate::world::Band;

/// Which model a sensor follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorKind {
    /// Radar, thesis model: penetrates materials with finite radar attenuation.
    Radar,
    /// Laser scanner: stops at laser-opaque materials, is attenuated by the others.
    Laser,
    /// Exact first-surface range of any object (DESIGN §3.3).
    GroundTruth,
}

impl SensorKind {
    /// The band whose material behaviour this sensor sees.
    pub fn band(self) -> Band {
        match self {
            Self::Radar => Band::Radar,
            Self::Laser => Band::Laser,
            Self::GroundTruth => Band::Surface,
        }
    }
}

/// USARSim (UDK) length unit conversion, `C_MeterToUU` in its DefaultUSAR.ini: 250 UU per metre.
pub const UNREAL_UNITS_PER_METRE: f64 = 250.0;

/// All parameters of a scanning range sensor. Angles in radians, lengths in metres.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensorConfig {
    /// The preset this was made from, if any.
    pub preset: Option<String>,
    /// Model.
    pub kind: SensorKind,
    /// Field of view, centred on the sensor's x axis; `2π` for a full circle.
    pub fov: f64,
    /// Angular step between rays.
    pub resolution: f64,
    /// Closer returns are reported as `-inf` (REP-117 "too close").
    pub range_min: f64,
    /// Farther than this there is no return (`+inf`).
    pub range_max: f64,
    /// Scans per second.
    pub rate_hz: f64,
    /// Elevation of each scan plane; one plane at 0 by default.
    pub elevations: Vec<f64>,
    /// Gaussian range noise: σ = max(`range_noise_std`, `range_noise_rel` × range).
    pub range_noise_std: f64,
    /// Range-proportional part of the noise σ.
    pub range_noise_rel: f64,
    /// Penetration budget in dB (radar: the thesis' budget; laser: how much loss in
    /// non-opaque media such as dust it tolerates). Unused by ground truth.
    pub penetration_db: f64,
    /// Side-beam offset N in metres (thesis noise model); 0 disables side beams.
    pub side_beam_offset: f64,
    /// Range bin size of a binned (FMCW) radar; returns are reported at the bin centre.
    pub range_bin: Option<f64>,
    /// Beam, echoes, return mode and power image (DESIGN §7); unused in `thesis` mode.
    pub signal: SignalConfig,
}

/// A named preset with a one-line description.
pub struct Preset {
    /// Name used in scenario files and on the command line.
    pub name: &'static str,
    /// What it models and where the figures come from.
    pub about: &'static str,
    make: fn() -> SensorConfig,
}

impl Preset {
    /// The preset's configuration.
    pub fn config(&self) -> SensorConfig {
        SensorConfig {
            preset: Some(self.name.to_owned()),
            ..(self.make)()
        }
    }
}

/// The radar budget tuned to the `foliage-wall` map: 3 dB = 1 m of `foliage_dense` (3 dB/m)
/// or about 1.9 m of `foliage_light` (1.55 dB/m). The wall's dense spheres are 1.6 m across at
/// scan height, so rays through their cores fade inside, while rays through their thin edges
/// and through the light filler spheres (at most 1 m across) come out on the far side, as in
/// the thesis' figure 8.
pub const THESIS_PENETRATION_DB: f64 = 3.0;

/// Signal margin given to the laser presets for non-opaque media (dust, glass).
pub const LASER_MARGIN_DB: f64 = 10.0;

fn deg(d: f64) -> f64 {
    d.to_radians()
}

fn radar_thesis() -> SensorConfig {
    SensorConfig {
        preset: None,
        kind: SensorKind::Radar,
        fov: deg(360.0),
        resolution: deg(1.0),
        range_min: 0.1,
        range_max: 20.0,
        rate_hz: 4.0,
        elevations: vec![0.0],
        range_noise_std: 0.0,
        range_noise_rel: 0.0,
        penetration_db: THESIS_PENETRATION_DB,
        side_beam_offset: 0.0,
        range_bin: None,
        signal: SignalConfig::default(),
    }
}

/// Navtech's beam: 1.8° in azimuth and elevation (RADIATE's description of the CTS350-X; no
/// beam pattern is published), sampled by 3 × 3 rays.
const NAVTECH_BEAMWIDTH_DEG: f64 = 1.8;

/// A Navtech-like FMCW scanning radar with `bins` range bins of `bin` metres: the whole echo
/// model, `all` returns, range-independent power (its high-pass filter, Jose & Adams 2006) and
/// a power image. The 76–77 GHz sweep gives B = 1 GHz (0.15 m point spread); the noise floor
/// (−50 dB) and display range (50 dB: a concrete wall face-on is about 230 of 255) are chosen.
fn fmcw(resolution_deg: f64, bin: f64, bins: u32) -> SensorConfig {
    SensorConfig {
        resolution: deg(resolution_deg),
        range_min: bin,
        range_max: bin * f64::from(bins),
        range_bin: Some(bin),
        signal: SignalConfig {
            return_mode: ReturnMode::All,
            range_law: RangeLaw::Flat,
            dynamic_range_db: 50.0,
            detection_threshold_db: -40.0,
            beam_rays_az: 3,
            beam_rays_el: 3,
            beamwidth_az: deg(NAVTECH_BEAMWIDTH_DEG),
            beamwidth_el: deg(NAVTECH_BEAMWIDTH_DEG),
            selection: Selection::Strongest,
            image: Some(ImageConfig {
                bandwidth_hz: 1e9,
                noise_floor_db: -50.0,
                display_range_db: 50.0,
                speckle: true,
                encoder_size: 5600,
            }),
            ..SignalConfig::default()
        },
        ..radar_thesis()
    }
}

fn laser(
    fov_deg: f64,
    step_deg: f64,
    range: (f64, f64),
    rate_hz: f64,
    noise: (f64, f64),
) -> SensorConfig {
    SensorConfig {
        preset: None,
        kind: SensorKind::Laser,
        fov: deg(fov_deg),
        resolution: deg(step_deg),
        range_min: range.0,
        range_max: range.1,
        rate_hz,
        elevations: vec![0.0],
        range_noise_std: noise.0,
        range_noise_rel: noise.1,
        penetration_db: LASER_MARGIN_DB,
        side_beam_offset: 0.0,
        range_bin: None,
        signal: SignalConfig::default(),
    }
}

/// Every preset. Noise figures quoted as "± x" by manufacturers are used as σ = x.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "radar_thesis",
        about: "thesis radar model, 360° at 1°, 20 m, 3 dB budget, no side beams",
        make: radar_thesis,
    },
    Preset {
        name: "radar_thesis_n50",
        about: "thesis radar with side beams N = 50 UU = 0.2 m (thesis fig. 9)",
        make: || SensorConfig {
            side_beam_offset: 50.0 / UNREAL_UNITS_PER_METRE,
            ..radar_thesis()
        },
    },
    Preset {
        name: "radar_thesis_n100",
        about: "thesis radar with side beams N = 100 UU = 0.4 m (thesis fig. 10)",
        make: || SensorConfig {
            side_beam_offset: 100.0 / UNREAL_UNITS_PER_METRE,
            ..radar_thesis()
        },
    },
    Preset {
        name: "navtech_cts350x",
        about: "Navtech CTS350-X (Oxford Radar RobotCar): 400 azimuths, 4 Hz, 3768 bins of 0.0438 m",
        make: || fmcw(0.9, 0.0438, 3768),
    },
    Preset {
        name: "navtech_cir204h",
        about: "Navtech CIR204-H (MulRan, Boreas): 400 azimuths, 4 Hz, 3360 bins of 0.0596 m ≈ 200 m",
        make: || fmcw(0.9, 0.0596, 3360),
    },
    Preset {
        name: "fmcw_scanning",
        about: "generic FMCW scanning radar: 1° azimuths, 4 Hz, 1000 bins of 0.05 m (50 m); every figure settable",
        make: || fmcw(1.0, 0.05, 1000),
    },
    Preset {
        name: "hokuyo_urg04lx",
        about: "Hokuyo URG-04LX: 240°, 360/1024° step (683 rays), 0.02-5.6 m, 10 Hz, ±10 mm to 1 m then 1 %",
        make: || laser(240.0, 360.0 / 1024.0, (0.02, 5.6), 10.0, (0.01, 0.01)),
    },
    Preset {
        name: "hokuyo_utm30lx",
        about: "Hokuyo UTM-30LX: 270°, 0.25° (1081 rays), 0.1-30 m, 40 Hz, ±30 mm to 10 m, ±50 mm to 30 m",
        make: || laser(270.0, 0.25, (0.1, 30.0), 40.0, (0.03, 0.05 / 30.0)),
    },
    Preset {
        name: "sick_lms291",
        about: "SICK LMS291: 180°, 1° (override resolution_deg for 0.5 or 0.25), up to 80 m, 75 Hz, σ ≈ 7 mm",
        make: || laser(180.0, 1.0, (0.0, 80.0), 75.0, (0.007, 0.0)),
    },
    Preset {
        name: "usarsim_hokuyo",
        about: "USARSim's Hokuyo model: 4.189 rad FOV, 0.0184 rad step (228 rays), 4 m",
        make: || SensorConfig {
            fov: 4.189,
            resolution: 0.0184,
            ..laser(240.0, 1.0, (0.0, 4.0), 10.0, (0.0, 0.0))
        },
    },
    Preset {
        name: "usarsim_sick",
        about: "USARSim's SICK model: 3.1416 rad FOV, 0.01745 rad step (181 rays), 20 m",
        // USARSim's configured figure, slightly more than π: kept as written.
        #[allow(clippy::approx_constant)]
        make: || SensorConfig {
            fov: 3.1416,
            resolution: 0.01745,
            ..laser(180.0, 1.0, (0.0, 20.0), 10.0, (0.0, 0.0))
        },
    },
    Preset {
        name: "ground_truth",
        about: "exact first-surface range, 360° at 1°, 50 m, no noise",
        make: || SensorConfig {
            kind: SensorKind::GroundTruth,
            range_min: 0.0,
            range_max: 50.0,
            ..radar_thesis()
        },
    },
];

/// The preset named `name`.
pub fn preset(name: &str) -> Option<SensorConfig> {
    PRESETS.iter().find(|p| p.name == name).map(Preset::config)
}

/// Most rays a single scan may have; larger configurations are rejected as mistakes.
pub const MAX_RAYS: usize = 4_000_000;
/// Most range bins of a power image (a Navtech CTS350-X has 3768).
pub const MAX_IMAGE_BINS: f64 = 65_536.0;
/// Most pixels of a power image.
pub const MAX_IMAGE_PIXELS: f64 = 1e8;

impl SensorConfig {
    /// Whether the field of view is a full circle (then the last ray does not repeat the first).
    pub fn full_circle(&self) -> bool {
        self.fov >= std::f64::consts::TAU - 1e-9
    }

    /// Rays per scan plane: `floor(fov / resolution) + 1` as in USARSim, or
    /// `round(2π / resolution)` for a full circle.
    pub fn azimuth_count(&self) -> usize {
        if self.full_circle() {
            (std::f64::consts::TAU / self.resolution).round() as usize
        } else {
            (self.fov / self.resolution + 1e-9).floor() as usize + 1
        }
    }

    /// Angle of the first ray relative to the sensor's x axis.
    pub fn angle_min(&self) -> f64 {
        -self.fov / 2.0
    }

    /// The plane closest to horizontal: the one a planar output (a LaserScan, a USARSim
    /// RangeScanner) carries of a sensor with several.
    pub fn horizontal_plane(&self) -> usize {
        self.elevations
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map_or(0, |(i, _)| i)
    }

    /// Range noise σ at `range`.
    pub fn noise_sigma(&self, range: f64) -> f64 {
        self.range_noise().sigma(range)
    }

    /// The range noise model on its own (what a consumer of the returns needs of it).
    pub fn range_noise(&self) -> RangeNoise {
        RangeNoise {
            std: self.range_noise_std,
            rel: self.range_noise_rel,
        }
    }

    /// Checks cross-field consistency; the message names the offending key.
    pub fn validate(&self) -> Result<(), String> {
        let checks = [
            (
                self.fov > 0.0 && self.fov <= std::f64::consts::TAU + 1e-9,
                "fov_deg",
                "must be in (0, 360]",
            ),
            (
                self.resolution > 0.0 && self.resolution <= self.fov,
                "resolution_deg",
                "must be > 0 and at most fov_deg",
            ),
            (
                self.range_min >= 0.0 && self.range_min < self.range_max,
                "range_min",
                "must be >= 0 and below range_max",
            ),
            (self.range_max.is_finite(), "range_max", "must be finite"),
            (
                self.rate_hz > 0.0 && self.rate_hz.is_finite(),
                "rate_hz",
                "must be > 0",
            ),
            (
                !self.elevations.is_empty()
                    && self
                        .elevations
                        .iter()
                        .all(|e| e.abs() < std::f64::consts::FRAC_PI_2),
                "elevations_deg",
                "must list at least one angle, each strictly between -90 and 90",
            ),
            (
                (0.0..f64::INFINITY).contains(&self.range_noise_std)
                    && (0.0..f64::INFINITY).contains(&self.range_noise_rel),
                "range_noise_std",
                "and range_noise_rel must be finite and >= 0",
            ),
            (self.penetration_db > 0.0, "penetration_db", "must be > 0"),
            (
                self.side_beam_offset >= 0.0 && self.side_beam_offset.is_finite(),
                "side_beam_offset",
                "must be >= 0",
            ),
            (
                self.range_bin.is_none_or(|b| b > 0.0),
                "range_bin",
                "must be > 0",
            ),
        ];
        if let Some((_, key, msg)) = checks.iter().find(|c| !c.0) {
            return Err(format!("{key} {msg}"));
        }
        self.signal.validate()?;
        if self.signal.image.is_some() && self.range_bin.is_none() {
            return Err("range_bin must be set for a sensor with a power image".into());
        }
        if let (Some(_), Some(bin)) = (&self.signal.image, self.range_bin) {
            // The polar image is azimuths x bins bytes, with a few copies while it is drawn.
            let bins = self.range_max / bin;
            let pixels = bins * self.azimuth_count() as f64;
            if bins > MAX_IMAGE_BINS || pixels > MAX_IMAGE_PIXELS {
                return Err(format!(
                    "range_bin gives a power image of {bins:.0} bins x {} azimuths; at most {MAX_IMAGE_BINS} bins and {MAX_IMAGE_PIXELS:e} pixels",
                    self.azimuth_count()
                ));
            }
        }
        let rays = self.azimuth_count().saturating_mul(self.elevations.len());
        if rays > MAX_RAYS {
            return Err(format!(
                "resolution_deg gives {rays} rays per scan, more than the limit of {MAX_RAYS}"
            ));
        }
        Ok(())
    }
}

/// A sensor's Gaussian range noise: σ = max(`std`, `rel` × range).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RangeNoise {
    /// Least σ, m.
    pub std: f64,
    /// σ per metre of range.
    pub rel: f64,
}

impl RangeNoise {
    /// σ at `range` metres.
    pub fn sigma(&self, range: f64) -> f64 {
        self.std.max(self.rel * range)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_counts_match_manufacturer_and_usarsim_figures() {
        let count = |n: &str| preset(n).unwrap().azimuth_count();
        assert_eq!(count("radar_thesis"), 360);
        assert_eq!(count("navtech_cts350x"), 400);
        assert_eq!(count("hokuyo_urg04lx"), 683);
        assert_eq!(count("hokuyo_utm30lx"), 1081);
        assert_eq!(count("sick_lms291"), 181);
        assert_eq!(count("usarsim_hokuyo"), 228);
        assert_eq!(count("usarsim_sick"), 181);
    }

    #[test]
    fn the_planar_output_takes_the_plane_nearest_horizontal() {
        let mut c = preset("hokuyo_utm30lx").expect("preset");
        c.elevations = vec![-0.2, 0.05, 0.3];
        assert_eq!(c.horizontal_plane(), 1);
        c.elevations.clear();
        assert_eq!(c.horizontal_plane(), 0);
    }

    #[test]
    fn presets_are_valid_and_side_beams_convert_units() {
        for p in PRESETS {
            p.config()
                .validate()
                .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        }
        assert!((preset("radar_thesis_n50").unwrap().side_beam_offset - 0.2).abs() < 1e-12);
        assert!((preset("radar_thesis_n100").unwrap().side_beam_offset - 0.4).abs() < 1e-12);
        let cts = preset("navtech_cts350x").unwrap();
        assert!((cts.range_max - 165.0384).abs() < 1e-9);
    }

    #[test]
    fn validate_names_the_key() {
        let mut c = preset("radar_thesis").unwrap();
        c.range_min = 30.0;
        assert!(c.validate().unwrap_err().starts_with("range_min"));
        let mut c = preset("sick_lms291").unwrap();
        c.range_noise_std = f64::INFINITY;
        assert!(c.validate().unwrap_err().starts_with("range_noise_std"));
        let mut c = preset("radar_thesis").unwrap();
        c.resolution = 1e-9;
        assert!(c.validate().unwrap_err().contains("rays per scan"));
    }
}
