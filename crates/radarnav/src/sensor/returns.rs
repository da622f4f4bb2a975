//! Scans in the echo return modes (DESIGN §7.3): every beam ray of an azimuth is walked by
//! the echo model, one ray answers (§7.1 selection), and its echoes give the range.

use rayon::prelude::*;

use super::echo::{Echo, EchoKind, EchoModel, EchoTracer};
use super::signal::{BeamRay, ReturnMode, Selection};
use super::{
    Beam, HitKind, PARALLEL_CHUNK, Scan, ScanDraws, SensorConfig, Tracer, beam_ray_toward,
    with_pool_tracer,
};
use crate::pose::Pose;
use crate::world::{Band, Fan, MaterialTable, World};

impl SensorConfig {
    /// [`SensorConfig::trace_scan`] for the echo return modes.
    pub(super) fn trace_echo_scan(
        &self,
        world: &World,
        pose: &Pose,
        stamp: f64,
        draws: &ScanDraws,
        tracer: &mut Tracer,
        parallel_min: usize,
    ) -> Scan {
        let azimuths = self.azimuth_count();
        let n = azimuths * self.elevations.len();
        assert_eq!(draws.0.len(), n, "draws of another sensor");
        let beam = self.signal.beam(self.side_offset());
        let angle_min = self.angle_min();
        // Beam rays that all leave the sensor's origin share one set of candidate lists.
        let mut fan = std::mem::take(&mut tracer.fan);
        let one_origin = beam.iter().all(|b| b.lateral == 0.0);
        let fan_ok = one_origin && self.scan_fan(world, pose, n * beam.len(), &mut fan);
        let fan_ref = fan_ok.then_some(&fan);
        // Per plane, each beam ray's elevation as its sine and cosine.
        let planes: Vec<Vec<(f64, f64)>> = (self.elevations.iter())
            .map(|el| beam.iter().map(|b| (el + b.d_el).sin_cos()).collect())
            .collect();
        // Per beam ray, the world bearings of its azimuths: one table per distinct offset in
        // azimuth, turned by the yaw (four products a ray instead of a sine and a cosine).
        let mut offsets: Vec<f64> = Vec::new();
        let table_of: Vec<usize> = (beam.iter())
            .map(
                |b| match offsets.iter().position(|o| o.to_bits() == b.d_az.to_bits()) {
                    Some(j) => j,
                    None => {
                        offsets.push(b.d_az);
                        offsets.len() - 1
                    }
                },
            )
            .collect();
        let firsts: Vec<f64> = offsets.iter().map(|o| angle_min + o).collect();
        let mut bearings = std::mem::take(&mut tracer.bearings);
        let toward = bearings.turned_from(pose.yaw, &firsts, self.resolution, azimuths);
        let sig = &self.signal;
        // A selection that does not look at the echoes (one ray; `uniform`, drawn before the
        // walk) is made first, and only the answering ray is walked: the others' echoes would
        // be thrown away. The thesis radar's three side beams cost one walk, not three.
        let fixed = beam.len() == 1 || sig.selection == Selection::Uniform;
        let mut model = sig.echo_model();
        // Only echoes a receiver can tell from noise count: the walk drops the others.
        model.min_power_db = sig.detection_threshold_db;
        // With the answering ray fixed, `first` and `all` want only its nearest echoes that
        // count, and its walk may stop once it has them.
        if fixed {
            let threshold = sig.detection_threshold_db;
            model.wanted = match sig.return_mode {
                ReturnMode::First => Some((1, threshold)),
                ReturnMode::All => Some((sig.max_echoes, threshold)),
                _ => None,
            };
        }
        let shared = EchoScan {
            world,
            fan: fan_ref,
            pose,
            beam: &beam,
            model: &model,
            fixed,
            toward,
            table_of: &table_of,
            azimuths,
            range_max: self.range_max,
        };
        // Azimuth `i` is azimuth `k` of plane `plane` (counted, not divided, where serial).
        let answer = |tracer: &mut Tracer, i: usize, plane: usize, k: usize, out: &mut Scan| {
            let az = angle_min + k as f64 * self.resolution;
            let el = &planes[plane];
            let select = draws.1.get(i).copied();
            let (side, noise) = draws.0[i];
            self.answer(&shared, (k, az), el, side, select, noise, tracer, out)
        };
        let mut out = self.empty_scan(pose, stamp);
        let all = self.signal.return_mode == ReturnMode::All;
        if all {
            // Room for two echoes an azimuth up front (a growing buffer was reallocated and
            // copied some twenty times a scan).
            out.echo_start.reserve_exact(n + 1);
            out.echoes.reserve(2 * n);
        }
        // Each answer is filed straight into the scan (a chunk's own when parallel), its
        // echoes into one buffer: an allocation per azimuth cost as much as a sixth of an
        // `all` scan, and an answer returned as a value and then filed was read back eight
        // bytes at a time from small fields just written one by one, which stalls the store
        // buffer once per azimuth.
        if n * beam.len() >= parallel_min {
            let chunk = PARALLEL_CHUNK / beam.len().max(1) + 1;
            let parts: Vec<Scan> = (0..n.div_ceil(chunk))
                .into_par_iter()
                .map(|c| {
                    with_pool_tracer(|t| {
                        let rays = c * chunk..n.min((c + 1) * chunk);
                        let mut part = self.empty_scan_for(pose, stamp, rays.len());
                        for i in rays {
                            answer(t, i, i / azimuths, i % azimuths, &mut part);
                        }
                        part
                    })
                })
                .collect();
            for part in parts {
                let offset = out.echoes.len() as u32;
                out.ranges.extend(part.ranges);
                out.hits.extend(part.hits);
                out.materials.extend(part.materials);
                out.beams.extend(part.beams);
                out.echo_start
                    .extend(part.echo_start.iter().map(|s| s + offset));
                out.echoes.extend(part.echoes);
            }
        } else {
            for plane in 0..self.elevations.len() {
                for k in 0..azimuths {
                    answer(tracer, plane * azimuths + k, plane, k, &mut out);
                }
            }
        }
        tracer.fan = fan;
        tracer.bearings = bearings;
        if all {
            out.echo_start.push(out.echoes.len() as u32);
        }
        out
    }

    /// Walks every beam ray of azimuth `k` (`az` rad off the sensor's axis), picks the
    /// answering ray and files its reading (range with `noise`, hit kind, material, beam) in
    /// `out`; in `all` mode also the echoes it reports.
    #[allow(clippy::too_many_arguments)]
    fn answer(
        &self,
        scan: &EchoScan,
        (k, az): (usize, f64),
        el_sin_cos: &[(f64, f64)],
        side: Beam,
        select: Option<f64>,
        noise: f64,
        tracer: &mut Tracer,
        out: &mut Scan,
    ) {
        let (world, beam) = (scan.world, scan.beam);
        let sig = &self.signal;
        // The tracer's buffers: the echo walk's, and per beam ray where its echoes start in
        // `echoes` and its first incidence cosine.
        let Tracer {
            echo,
            beam_echoes: echoes,
            beam_spans: spans,
            ..
        } = tracer;
        echoes.clear();
        spans.clear();
        let rays = beam.len();
        // The answering ray, where the selection is made before the walk.
        let answering = match select {
            _ if !scan.fixed => None,
            _ if rays == 1 => Some(0),
            Some(u) => Some(((u * rays as f64) as usize).min(rays - 1)),
            None => Some(match side {
                Beam::Center => 0,
                Beam::Left => 1,
                Beam::Right => 2,
            }),
        };
        let all = sig.return_mode == ReturnMode::All;
        // Walks beam ray `r` of this azimuth into `buf` (a plain call: a closure over the
        // scan's dozen fields stored a pointer to each of them per azimuth).
        let mut walk = |r: usize, buf: &mut Vec<Echo>| scan.walk(echo, r, (k, az), el_sin_cos, buf);
        let (chosen, reading, reported) = match answering {
            // Only the answering ray is walked, in `all` mode straight into the scan's buffer.
            Some(chosen) if all => {
                let kept = &mut out.echoes;
                let start = kept.len();
                walk(chosen, kept);
                let reading = self.reading(&kept[start..], world);
                let reported = (kept.len() - start).min(sig.max_echoes);
                kept.truncate(start + reported);
                (chosen, reading, reported)
            }
            Some(chosen) => {
                walk(chosen, echoes);
                (chosen, self.reading(echoes, world), 0)
            }
            None => {
                for r in 0..rays {
                    let start = echoes.len();
                    let cos = walk(r, echoes);
                    spans.push((start, cos));
                }
                spans.push((echoes.len(), 0.0));
                let of = |r: usize| &echoes[spans[r].0..spans[r + 1].0];
                // The selections that look at the echoes (`uniform` was made above).
                let chosen = match sig.selection {
                    Selection::IncidenceWeighted => {
                        let total: f64 = spans[..rays].iter().map(|s| s.1).sum();
                        let u = select.unwrap_or(0.0) * total;
                        let mut acc = 0.0;
                        (0..rays)
                            .find(|&r| {
                                acc += spans[r].1;
                                u < acc
                            })
                            .unwrap_or(rays - 1)
                    }
                    Selection::Nearest => (0..rays)
                        .filter_map(|r| of(r).first().map(|e| (r, e.range)))
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                        .map_or(0, |x| x.0),
                    Selection::Strongest | Selection::Uniform => (0..rays)
                        .filter_map(|r| {
                            of(r)
                                .iter()
                                .map(|e| e.power)
                                .max_by(f64::total_cmp)
                                .map(|p| (r, p))
                        })
                        .max_by(|a, b| a.1.total_cmp(&b.1))
                        .map_or(0, |x| x.0),
                };
                let mine = of(chosen);
                let reported = if all {
                    let mine = &mine[..mine.len().min(sig.max_echoes)];
                    out.echoes.extend_from_slice(mine);
                    mine.len()
                } else {
                    0
                };
                (chosen, self.reading(mine, world), reported)
            }
        };
        let (range, kind, material) = reading;
        let beam = match (beam.len(), chosen) {
            (3, 1) if beam[1].lateral > 0.0 => Beam::Left,
            (3, 2) if beam[2].lateral < 0.0 => Beam::Right,
            _ => Beam::Center,
        };
        out.ranges.push(self.reported_range(range, noise) as f32);
        out.hits.push(kind);
        out.materials.push(material);
        out.beams.push(beam);
        if all {
            out.echo_start.push((out.echoes.len() - reported) as u32);
        }
    }

    /// The reading the return mode takes from the answering ray's echoes (by range, all
    /// above the detection threshold): its range, hit kind and material.
    fn reading(
        &self,
        mine: &[Echo],
        world: &World,
    ) -> (f64, HitKind, Option<crate::world::MaterialId>) {
        let pick = match self.signal.return_mode {
            ReturnMode::Strongest => mine.iter().max_by(|a, b| a.power.total_cmp(&b.power)),
            ReturnMode::Last => mine.last(),
            _ => mine.first(),
        };
        match pick {
            Some(e) => (e.range, hit_kind(e, world.materials()), Some(e.material)),
            None => (f64::INFINITY, HitKind::None, None),
        }
    }
}

impl EchoScan<'_> {
    /// Walks beam ray `r` of azimuth `k` (`az` rad off the sensor's axis; planes' elevations
    /// `el_sin_cos`), appending its echoes to `buf` by range; returns the incidence cosine at
    /// its first surface.
    fn walk(
        &self,
        echo: &mut EchoTracer,
        r: usize,
        (k, az): (usize, f64),
        el_sin_cos: &[(f64, f64)],
        buf: &mut Vec<Echo>,
    ) -> f64 {
        let (b, start) = (&self.beam[r], buf.len());
        let bearing = self.toward[self.table_of[r] * self.azimuths + k];
        let ray = beam_ray_toward(self.pose, bearing, el_sin_cos[r], b.lateral);
        let (w, max, model) = (b.weight, self.range_max, self.model);
        let cos = match self.fan {
            Some(fan) => {
                let heading = self.pose.yaw + az + b.d_az;
                echo.echoes_in_fan(self.world, fan, heading, &ray, w, max, model, buf)
            }
            None => echo.echoes(self.world, &ray, w, max, model, buf),
        };
        // A leg's echoes come in range order, a ghost's after them.
        let mine = &mut buf[start..];
        if !mine.is_sorted_by(|a, b| a.range <= b.range) {
            mine.sort_by(|a, b| a.range.total_cmp(&b.range));
        }
        cos
    }
}

/// What every azimuth of one echo scan shares.
struct EchoScan<'a> {
    world: &'a World,
    /// The scan's candidate lists, where its rays share an origin.
    fan: Option<&'a Fan>,
    pose: &'a Pose,
    beam: &'a [BeamRay],
    /// The echo walk's settings, the same for every ray of the scan.
    model: &'a EchoModel,
    /// Whether the answering ray is chosen before the walk (one ray, or `uniform`).
    fixed: bool,
    /// World bearings (sine, cosine): beam ray `r`'s at azimuth `k` is
    /// `toward[table_of[r] * azimuths + k]`.
    toward: &'a [(f64, f64)],
    /// Per beam ray, its table in `toward`.
    table_of: &'a [usize],
    /// Azimuths per table.
    azimuths: usize,
    /// The sensor's range, m: how far each ray is walked.
    range_max: f64,
}

/// An echo as a hit kind: the surface of a material the radar cannot enter is `solid`, any
/// other echo (foliage, glass, a volume) `exhausted`-like: the ray went on past it.
fn hit_kind(e: &Echo, materials: &MaterialTable) -> HitKind {
    let solid = materials
        .get(e.material)
        .attenuation_db_per_m(Band::Radar)
        .is_infinite();
    if e.kind == EchoKind::Surface && solid {
        HitKind::Solid
    } else {
        HitKind::Exhausted
    }
}

#[cfg(test)]
mod tests {
    use crate::sensor::beam_ray;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::sensor::preset;
    use crate::world::Shape;
    use crate::world::strategies::world_of;

    fn scan(c: &SensorConfig, world: &World, seed: u64) -> Scan {
        let pose = Pose::new(0.0, 0.0, 0.4, 0.3);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        c.scan(world, &pose, 0.0, &mut rng, &mut Tracer::default())
    }

    fn post(x: f64, y: f64, r: f64) -> (Shape, &'static str) {
        let s = Shape::Cylinder {
            center: glam::DVec3::new(x, y, 1.0),
            radius: r,
            half_height: 1.0,
        };
        (s, "concrete")
    }

    /// A first-echo radar beside a metal crate sees the crate's side where its rays graze it
    /// (60–75° off the normal, far outside the mirror lobe) through the metal's diffuse share;
    /// a perfect mirror there reports only what its ghost leg meets, metres beyond.
    #[test]
    fn a_first_echo_radar_sees_a_metal_crates_side_at_grazing_incidence() {
        // The crate's near face is the line y = 0.3 from x = 0.4 to 2.4; a wall at x = 6.
        let crate_box = Shape::cuboid(
            glam::DVec3::new(1.4, 0.8, 0.5),
            glam::DVec3::new(2.0, 1.0, 1.0),
            0.0,
        )
        .unwrap();
        let wall = Shape::cuboid(
            glam::DVec3::new(6.1, 0.0, 1.0),
            glam::DVec3::new(0.2, 40.0, 2.0),
            0.0,
        )
        .unwrap();
        let rough = world_of(&[(crate_box, "metal"), (wall, "concrete")]);
        let mut table = rough.materials().clone();
        let metal = table.id("metal").unwrap();
        table.insert(crate::world::Material {
            radar_diffuse: 0.0,
            ..table.get(metal).clone()
        });
        let mirror = World::new(table, rough.objects().to_vec());
        let mut c = preset("radar_thesis").expect("preset");
        c.signal.return_mode = ReturnMode::First;
        let pose = Pose::new(0.0, 0.0, 0.4, 0.0);
        let take = |w: &World| {
            let mut rng = ChaCha8Rng::seed_from_u64(1);
            c.scan(w, &pose, 0.0, &mut rng, &mut Tracer::default())
        };
        let (seen, ghosted) = (take(&rough), take(&mirror));
        let mut grazing = 0;
        for i in 0..seen.len() {
            let (az, _) = seen.angles(i);
            let deg = az.to_degrees();
            if !(15.0..=30.0).contains(&deg) {
                continue;
            }
            grazing += 1;
            let face = 0.3 / az.sin();
            assert!(
                (f64::from(seen.ranges[i]) - face).abs() < 1e-4,
                "{deg}°: {}",
                seen.ranges[i]
            );
            assert!(
                f64::from(ghosted.ranges[i]) > face + 1.0,
                "{deg}°: {}",
                ghosted.ranges[i]
            );
        }
        assert!(grazing >= 15, "{grazing} rays");
    }

    /// The thesis' side beams are the three-ray beam of §7.1 (in the scan plane, equal
    /// weights, one drawn): in a world of solids, where the thesis range is the first
    /// surface, `first` returns with uniform selection pick the same side beam from the same
    /// draws and report the same range on every ray.
    #[test]
    fn three_in_plane_rays_with_uniform_selection_reproduce_the_thesis_side_beams() {
        // Thin posts that some side beams of an azimuth hit and others miss, in a closed room.
        let mut objects: Vec<(Shape, &str)> = (0..40)
            .map(|k| {
                let a = k as f64 * 0.157;
                let r = 2.0 + (k % 7) as f64 * 0.6;
                post(r * a.cos(), r * a.sin(), 0.06 + 0.02 * (k % 3) as f64)
            })
            .collect();
        let room = Shape::wall(
            [
                (-9.0, -9.0),
                (9.0, -9.0),
                (9.0, 9.0),
                (-9.0, 9.0),
                (-9.0, -9.0),
            ]
            .map(|(x, y)| glam::DVec2::new(x, y))
            .to_vec(),
            0.2,
            2.5,
        )
        .expect("a wall");
        objects.push((room, "concrete"));
        let world = world_of(&objects);
        for name in ["radar_thesis_n50", "radar_thesis_n100"] {
            let thesis = preset(name).expect("preset");
            let mut first = thesis.clone();
            first.signal.return_mode = ReturnMode::First;
            // Every echo counts, however grazing: the thesis reports any surface.
            first.signal.detection_threshold_db = -200.0;
            first.signal.dynamic_range_db = 200.0;
            let (a, b) = (scan(&thesis, &world, 5), scan(&first, &world, 5));
            assert_eq!(a.beams, b.beams, "{name}: side beams differ");
            assert!(a.beams.contains(&Beam::Left));
            assert!(a.beams.contains(&Beam::Right));
            for (i, (ra, rb)) in a.ranges.iter().zip(&b.ranges).enumerate() {
                assert!((ra - rb).abs() < 1e-4, "{name} ray {i}: {ra} vs {rb}");
            }
            assert_eq!(a.hits, b.hits);
            // The side beams matter here: the centre ray alone would report other ranges.
            let mut centre = thesis.clone();
            centre.side_beam_offset = 0.0;
            let c = scan(&centre, &world, 5);
            assert!(
                c.ranges
                    .iter()
                    .zip(&a.ranges)
                    .any(|(x, y)| (x - y).abs() > 0.1)
            );
        }
    }

    /// With side beams and `uniform` selection only the drawn ray is walked: each azimuth of
    /// an `all` scan reports exactly the echoes that ray alone gives (above the threshold, by
    /// range, at most `max_echoes`), whichever side it is.
    #[test]
    fn uniform_selection_reports_the_echoes_of_the_drawn_side_beam() {
        let objects: Vec<(Shape, &str)> = (0..30)
            .map(|k| {
                let a = k as f64 * 0.21;
                let r = 1.5 + (k % 5) as f64 * 0.7;
                post(r * a.cos(), r * a.sin(), 0.05 + 0.03 * (k % 3) as f64)
            })
            .collect();
        let world = world_of(&objects);
        let mut c = preset("radar_thesis_n100").expect("preset");
        c.signal.return_mode = ReturnMode::All;
        c.signal.detection_threshold_db = -70.0;
        let s = scan(&c, &world, 9);
        let model = c.signal.echo_model();
        let mut tracer = super::super::echo::EchoTracer::default();
        let mut sides = std::collections::BTreeSet::new();
        let mut echoes = 0;
        for i in 0..s.len() {
            let (az, el) = s.angles(i);
            let offset = s.beams[i].side() * c.side_beam_offset;
            let ray = beam_ray(&s.pose, az, el.sin_cos(), offset);
            let mut alone = Vec::new();
            tracer.echoes(&world, &ray, 1.0 / 3.0, c.range_max, &model, &mut alone);
            alone.retain(|e| e.power_db() >= c.signal.detection_threshold_db);
            alone.sort_by(|a, b| a.range.total_cmp(&b.range));
            alone.truncate(c.signal.max_echoes);
            // The scan turns a table of its bearings by the yaw, so its ray's direction
            // differs from `beam_ray`'s by a few ulps: the same echoes, to rounding.
            let same = |a: &Echo, b: &Echo| {
                (a.range - b.range).abs() < 1e-9
                    && (a.power_db() - b.power_db()).abs() < 1e-9
                    && (a.material, a.kind, a.bounces) == (b.material, b.kind, b.bounces)
            };
            let got = s.echoes_of(i);
            assert!(
                got.len() == alone.len() && got.iter().zip(&alone).all(|(a, b)| same(a, b)),
                "azimuth {i}: {got:?} against {alone:?}"
            );
            sides.insert(s.beams[i].as_str());
            echoes += alone.len();
        }
        assert_eq!(sides.len(), 3, "every side beam drawn somewhere");
        assert!(echoes > 50, "{echoes} echoes");
    }

    /// A thin pole shows in exactly the azimuths whose beam rays pass within its angular
    /// radius of it: the beam's width, not the azimuth step, sets how wide it looks; and its
    /// echo is strongest in the middle and falls off with the antenna pattern.
    #[test]
    fn a_thin_pole_shows_in_the_azimuths_its_beam_width_predicts() {
        let (range, radius) = (10.0, 0.05);
        let world = world_of(&[post(range, 0.0, radius)]);
        let mut c = preset("radar_thesis").expect("preset");
        c.side_beam_offset = 0.0;
        c.range_noise_std = 0.0;
        c.range_noise_rel = 0.0;
        c.resolution = 0.1f64.to_radians();
        c.signal.return_mode = ReturnMode::All;
        c.signal.selection = Selection::Nearest;
        c.signal.beam_rays_az = 9;
        c.signal.beamwidth_az = 1.8f64.to_radians();
        c.signal.detection_threshold_db = -200.0;
        let pose = Pose::new(0.0, 0.0, 0.4, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let s = c.scan(&world, &pose, 0.0, &mut rng, &mut Tracer::default());
        let beam = c.signal.beam(0.0);
        // The pole's half-width as seen from the sensor (to its axis at `range`).
        let alpha = (radius / range).asin();
        let mut seen = 0;
        let mut power = Vec::new();
        for i in 0..s.len() {
            let (az, _) = s.angles(i);
            let az = crate::pose::wrap_angle(az);
            let pole: Vec<&Echo> = s
                .echoes_of(i)
                .iter()
                .filter(|e| (e.range - (range - radius)).abs() < 0.05)
                .collect();
            // Rays within 2 % of the edge of the pole may go either way.
            let gap = beam
                .iter()
                .map(|b| (az + b.d_az).abs() - alpha)
                .fold(f64::INFINITY, f64::min);
            if gap.abs() < 0.02 * alpha {
                continue;
            }
            assert_eq!(
                !pole.is_empty(),
                gap < 0.0,
                "azimuth {:.2} deg",
                az.to_degrees()
            );
            if let Some(p) = pole.iter().map(|e| e.power_db()).reduce(f64::max) {
                seen += 1;
                power.push((az, p));
            }
        }
        // About ±(1.6 deg outermost ray + 0.29 deg pole) at 0.1 deg steps: 37 or 38 azimuths.
        assert!((36..=39).contains(&seen), "seen in {seen} azimuths");
        let peak = power.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let centre = power
            .iter()
            .min_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
            .expect("seen")
            .1;
        assert!((peak - centre).abs() < 0.5, "peak {peak} centre {centre}");
        let edge = power
            .iter()
            .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
            .expect("seen")
            .1;
        // The outermost ray is 1.6 deg off: exp(-4 ln2 (1.6/1.8)^2) is -9.5 dB.
        assert!(centre - edge > 8.0, "centre {centre} edge {edge}");
    }
}
