//! Materials: how radar and laser rays behave inside an object, and whether a robot may drive
//! through it.
//!
//! Default figures (one-way, mm-wave radar; near-infrared laser). The thesis model only needs
//! them relative to a radar's penetration budget; the values below are the published ones so
//! that the same budgets also make physical sense:
//!
//! | material | radar dB/m | laser | source |
//! |---|---|---|---|
//! | `foliage_light` | 1.55 | opaque | Weissberger 1982 model at 77 GHz for depths < 14 m, in the range 0.75 (bare) – 2.5 (in leaf) dB/m of the measurements collected by Rappaport & Deng, ICC 2015 |
//! | `foliage_dense` | 3.0 | opaque | middle of 2–4 dB/m for dry dense leaves at 38 GHz (same collection; wet leaves reach 6–8 dB/m) |
//! | `smoke` | 0.0 | opaque | mm-wave loss in smoke and fog ≈ 0 (Pierce et al., SPIE 4530) |
//! | `dust` | 0.02 | k = 4.6 /m (20 dB/m) | < 0.02 dB/m at 94 GHz for 3000 mg/m³ (Wikner, ARL-TR-4399, 2008); the laser figure is chosen: a cloud a laser sees about half a metre into |
//! | `fog` | 0.0 | k = 0.078 /m (0.34 dB/m) | mm-wave loss in fog < 1 dB/km (Pierce et al.); laser 170–340 dB/km at 50 m visibility (same source), the upper figure |
//! | `glass` | 500 | 60 dB/m | ≈ 3 dB through a 6 mm pane at 77 GHz; ≈ 8 % loss per pane at 905 nm: a laser sees through windows |
//! | `concrete`, `wood`, `metal`, `absorber` | solid | opaque | stop both rays at the surface |
//! | `ground` | solid | opaque | the plane z = 0 under every world; a ray tilted down ends there |
//!
//! The echo model (DESIGN §7.2) adds, per material, a reflectivity ρ (power fraction returned
//! at entry, normal incidence), a volume backscatter coefficient η (power fraction scattered
//! back per metre inside), the width of a specular material's lobe and the share of its echo
//! scattered diffusely (`radar_diffuse`: a specular surface's echo is (1 − d) of its lobe
//! plus d × the incidence cosine; what it mirrors on is (1 − d) ρ). The thesis model uses none
//! of them.
//!
//! Aerosols (DESIGN §7.6): a material that is not laser-opaque and has a laser extinction
//! coefficient k > 0 (`laser_extinction_per_m`) scatters a laser ray back from its particles:
//! the ray returns from depth d with probability 1 − exp(−k·d) (Beer–Lambert; one-way loss
//! 10·log10(e)·k = 4.343·k dB/m). `smoke` keeps the thesis' opaque laser; its k (1.3 /m, a
//! visibility of 3 m by Koschmieder's 3.912 / V, chosen) applies to a variant with
//! `laser_opaque = false`.
//!
//! | material | ρ | η (1/m) | specular lobe | source |
//! |---|---|---|---|---|
//! | `concrete` | 0.35 | 0 | diffuse | rough value of 60–77 GHz reflection measurements of concrete walls (power reflection ≈ 0.3–0.4) |
//! | `metal` | 1.0 | 0 | 10°, 1 % diffuse | a conductor reflects all; the lobe width and the diffuse share ([`METAL_DIFFUSE`]) are chosen |
//! | `wood` | 0.2 | 0 | diffuse | rough value of mm-wave measurements of wooden boards |
//! | `glass` | 0.25 | 0 | 10° | ≈ 25 % power reflection of a pane at 60–77 GHz; lobe chosen |
//! | `foliage_light` | 0.1 | 0.1 | diffuse | ρ chosen (leaves are a weak, diffuse surface); η chosen so that a metre of hedge glows about as bright as its surface |
//! | `foliage_dense` | 0.1 | 0.2 | diffuse | chosen as above, twice the scatterers |
//! | `smoke` | 0 | 0 | diffuse | no mm-wave echo |
//! | `dust` | 0 | 1e-4 | diffuse | η chosen (a faint haze) |
//! | `absorber` | 0 | 0 | diffuse | by definition: no echo, nothing behind |
//! | `ground` | 0.15 | 0 | diffuse | chosen: a grazing ground echo is weak |
//!
//! "Chosen" marks figures with no published source: they only set how bright an echo is
//! relative to the others, and every one can be overridden in a scenario's `[[material]]`.

use serde::Serialize;

/// Index of a material in a [`MaterialTable`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct MaterialId(pub u16);

/// Which kind of ray is asking about a material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Band {
    /// A radar ray: penetrates by `radar_attenuation_db_per_m`.
    Radar,
    /// A laser ray: stopped by `laser_opaque`, otherwise attenuated.
    Laser,
    /// Ground truth: every object stops the ray at its surface.
    Surface,
}

/// One material's physical behaviour.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Material {
    /// Unique name.
    pub name: String,
    /// One-way radar loss inside, dB/m; infinite for a solid.
    pub radar_attenuation_db_per_m: f64,
    /// Fraction of incident radar power reflected at entry (0 absorber … 1 metal).
    pub radar_reflectivity: f64,
    /// Whether radar rays mirror off it.
    pub specular: bool,
    /// Volume backscatter η inside a penetrable material: power fraction returned per metre
    /// (DESIGN §7.2). 0 for solids.
    pub radar_backscatter_per_m: f64,
    /// Full width (−3 dB) of a specular material's echo lobe around normal incidence, radians.
    pub specular_lobe: f64,
    /// Share of a specular material's reflected power scattered diffusely (as a rough
    /// surface's, ∝ the incidence cosine) rather than mirrored: what lets a radar see a metal
    /// crate's side at any angle and not only its ghost. 0–1; diffuse materials ignore it.
    pub radar_diffuse: f64,
    /// Whether a laser ray stops at its surface.
    pub laser_opaque: bool,
    /// Laser loss inside when not opaque, dB/m.
    pub laser_attenuation_db_per_m: f64,
    /// Extinction coefficient k of an aerosol to a laser, 1/m: a ray inside returns from the
    /// particles at depth d with probability 1 − exp(−k·d) (DESIGN §7.6). 0 for other
    /// materials; ignored while `laser_opaque`.
    pub laser_extinction_per_m: f64,
    /// Whether a robot may drive through it.
    pub traversable: bool,
    /// Colour in figures, RGB.
    pub color: [u8; 3],
}

impl Material {
    /// The loss in dB/m that a ray of `band` suffers inside this material (infinite = solid).
    pub fn attenuation_db_per_m(&self, band: Band) -> f64 {
        match band {
            Band::Radar => self.radar_attenuation_db_per_m,
            Band::Laser if self.laser_opaque => f64::INFINITY,
            Band::Laser => self.laser_attenuation_db_per_m,
            Band::Surface => f64::INFINITY,
        }
    }

    /// Whether the radar sees into it (finite attenuation).
    pub fn radar_penetrable(&self) -> bool {
        self.radar_attenuation_db_per_m.is_finite()
    }

    /// Whether a laser ray inside it may return from its particles (§7.6).
    pub fn laser_aerosol(&self) -> bool {
        !self.laser_opaque && self.laser_extinction_per_m > 0.0
    }
}

#[allow(clippy::too_many_arguments)]
fn builtin(
    name: &str,
    radar: f64,
    reflectivity: f64,
    specular: bool,
    laser: Option<f64>,
    traversable: bool,
    color: [u8; 3],
) -> Material {
    Material {
        name: name.to_owned(),
        radar_attenuation_db_per_m: radar,
        radar_reflectivity: reflectivity,
        specular,
        radar_backscatter_per_m: 0.0,
        specular_lobe: DEFAULT_SPECULAR_LOBE_DEG.to_radians(),
        radar_diffuse: 0.0,
        laser_opaque: laser.is_none(),
        laser_attenuation_db_per_m: laser.unwrap_or(f64::INFINITY),
        laser_extinction_per_m: 0.0,
        traversable,
        color,
    }
}

/// One-way dB per metre of an extinction of 1 /m: 10·log10(e).
pub const DB_PER_UNIT_EXTINCTION: f64 = 10.0 * std::f64::consts::LOG10_E;

/// Default full width of a specular echo lobe, degrees (chosen: a smooth wall or pane).
pub const DEFAULT_SPECULAR_LOBE_DEG: f64 = 10.0;

/// The diffuse share of the built-in `metal` (chosen): painted, dented or riveted faces (crates,
/// cabinets, posts) return about 1 % of their echo at any angle. A perfect mirror would hide a
/// crate's side from a radar at more than about 20° off its normal (only its ghost beyond).
pub const METAL_DIFFUSE: f64 = 0.01;

/// The built-in materials, in a fixed order (their ids in a fresh table).
pub fn builtin_materials() -> Vec<Material> {
    let backscatter = |m: Material, eta: f64| Material {
        radar_backscatter_per_m: eta,
        ..m
    };
    let rough = |m: Material, diffuse: f64| Material {
        radar_diffuse: diffuse,
        ..m
    };
    let aerosol = |m: Material, k: f64| Material {
        laser_extinction_per_m: k,
        ..m
    };
    let inf = f64::INFINITY;
    vec![
        builtin("concrete", inf, 0.35, false, None, false, [150, 150, 150]),
        rough(
            builtin("metal", inf, 1.0, true, None, false, [90, 110, 140]),
            METAL_DIFFUSE,
        ),
        builtin("wood", inf, 0.2, false, None, false, [160, 110, 60]),
        builtin(
            "glass",
            500.0,
            0.25,
            true,
            Some(60.0),
            false,
            [150, 210, 230],
        ),
        backscatter(
            builtin(
                "foliage_light",
                1.55,
                0.1,
                false,
                None,
                false,
                [120, 200, 90],
            ),
            0.1,
        ),
        backscatter(
            builtin("foliage_dense", 3.0, 0.1, false, None, false, [40, 130, 50]),
            0.2,
        ),
        aerosol(
            builtin("smoke", 0.0, 0.0, false, None, true, [175, 170, 185]),
            3.912 / 3.0,
        ),
        aerosol(
            backscatter(
                builtin("dust", 0.02, 0.0, false, Some(20.0), true, [205, 185, 140]),
                1e-4,
            ),
            20.0 / DB_PER_UNIT_EXTINCTION,
        ),
        builtin("absorber", inf, 0.0, false, None, false, [60, 40, 60]),
        builtin("ground", inf, 0.15, false, None, true, [200, 190, 160]),
        aerosol(
            builtin("fog", 0.0, 0.0, false, Some(0.34), true, [215, 220, 225]),
            0.34 / DB_PER_UNIT_EXTINCTION,
        ),
    ]
}

/// The materials of a world, addressed by [`MaterialId`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MaterialTable {
    materials: Vec<Material>,
}

impl Default for MaterialTable {
    fn default() -> Self {
        Self {
            materials: builtin_materials(),
        }
    }
}

impl MaterialTable {
    /// Adds a material, or replaces the one of the same name (a scenario may re-tune a
    /// built-in); returns its id. `None` once 65 535 materials exist.
    pub fn insert(&mut self, m: Material) -> Option<MaterialId> {
        if let Some(id) = self.id(&m.name) {
            self.materials[id.0 as usize] = m;
            return Some(id);
        }
        let id = MaterialId(u16::try_from(self.materials.len()).ok()?);
        self.materials.push(m);
        Some(id)
    }

    /// The id of the material named `name`.
    pub fn id(&self, name: &str) -> Option<MaterialId> {
        self.materials
            .iter()
            .position(|m| m.name == name)
            .map(|i| MaterialId(i as u16))
    }

    /// The material with this id. Ids come from this table, so this cannot miss.
    pub fn get(&self, id: MaterialId) -> &Material {
        &self.materials[id.0 as usize]
    }

    /// All materials in id order.
    pub fn iter(&self) -> impl Iterator<Item = (MaterialId, &Material)> {
        self.materials
            .iter()
            .enumerate()
            .map(|(i, m)| (MaterialId(i as u16), m))
    }

    /// Names of all materials, for error messages.
    pub fn names(&self) -> Vec<&str> {
        self.materials.iter().map(|m| m.name.as_str()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_present_and_consistent() {
        let t = MaterialTable::default();
        for name in [
            "concrete",
            "metal",
            "wood",
            "glass",
            "foliage_light",
            "foliage_dense",
            "smoke",
            "dust",
            "absorber",
            "ground",
            "fog",
        ] {
            assert!(t.id(name).is_some(), "{name}");
        }
        let smoke = t.get(t.id("smoke").unwrap());
        assert!(smoke.traversable && smoke.laser_opaque);
        assert_eq!(smoke.attenuation_db_per_m(Band::Radar), 0.0);
        let foliage = t.get(t.id("foliage_dense").unwrap());
        assert!(foliage.radar_penetrable() && !foliage.traversable);
        assert!(foliage.attenuation_db_per_m(Band::Laser).is_infinite());
        assert!(foliage.attenuation_db_per_m(Band::Surface).is_infinite());
    }

    #[test]
    fn insert_replaces_by_name() {
        let mut t = MaterialTable::default();
        let before = t.iter().count();
        let mut m = t.get(t.id("smoke").unwrap()).clone();
        m.radar_attenuation_db_per_m = 0.5;
        let id = t.insert(m).unwrap();
        assert_eq!(t.iter().count(), before);
        assert_eq!(t.get(id).radar_attenuation_db_per_m, 0.5);
    }
}
