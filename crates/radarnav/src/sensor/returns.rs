//! Scans in the echo return modes (DESIGN §7.3): every beam ray of an azimuth is walked by
//! the echo model, one ray answers (§7.1 selection), and its echoes give the range.

use rayon::prelude::*;

use super::echo::{Echo, EchoKind};
use super::signal::{BeamRay, ReturnMode, Selection};
use super::{
    Beam, HitKind, PARALLEL_CHUNK, Scan, ScanDraws, SensorConfig, Tracer, beam_ray,
    with_pool_tracer,
};
use crate::pose::Pose;
use crate::world::{Band, MaterialTable, World};

/// One azimuth's answer: its range before noise, how and on what it ended, which side beam
/// answered, and the echoes reported beside it.
struct Answer {
    range: f64,
    kind: HitKind,
    material: Option<crate::world::MaterialId>,
    beam: Beam,
    echoes: Vec<Echo>,
}

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
        let answer = |tracer: &mut Tracer, i: usize| {
            let az = angle_min + (i % azimuths) as f64 * self.resolution;
            let el = self.elevations[i / azimuths];
            let select = draws.1.get(i).copied();
            self.answer(world, pose, az, el, &beam, draws.0[i].0, select, tracer)
        };
        let answers: Vec<Answer> = if n * beam.len() >= parallel_min {
            (0..n)
                .into_par_iter()
                .with_min_len(PARALLEL_CHUNK / beam.len().max(1) + 1)
                .map(|i| with_pool_tracer(|t| answer(t, i)))
                .collect()
        } else {
            (0..n).map(|i| answer(tracer, i)).collect()
        };
        let all = self.signal.return_mode == ReturnMode::All;
        let mut out = self.empty_scan(pose, stamp);
        for (a, (_, noise)) in answers.into_iter().zip(&draws.0) {
            out.ranges.push(self.reported_range(a.range, *noise) as f32);
            out.hits.push(a.kind);
            out.materials.push(a.material);
            out.beams.push(a.beam);
            if all {
                out.echo_start.push(out.echoes.len() as u32);
                out.echoes.extend(a.echoes);
            }
        }
        if all {
            out.echo_start.push(out.echoes.len() as u32);
        }
        out
    }

    /// Walks every beam ray of one azimuth, picks the answering ray and its range.
    #[allow(clippy::too_many_arguments)]
    fn answer(
        &self,
        world: &World,
        pose: &Pose,
        az: f64,
        el: f64,
        beam: &[BeamRay],
        side: Beam,
        select: Option<f64>,
        tracer: &mut Tracer,
    ) -> Answer {
        let sig = &self.signal;
        let model = sig.echo_model();
        let mut echoes: Vec<Echo> = Vec::new();
        // Per beam ray: where its echoes start, and its first incidence cosine.
        let mut spans: Vec<(usize, f64)> = Vec::with_capacity(beam.len() + 1);
        for b in beam {
            let ray = beam_ray(pose, az + b.d_az, (el + b.d_el).sin_cos(), b.lateral);
            let start = echoes.len();
            let cos =
                tracer
                    .echo
                    .echoes(world, &ray, b.weight, self.range_max, &model, &mut echoes);
            // Only echoes a receiver can tell from noise count; each ray's by range.
            let mut k = start;
            for j in start..echoes.len() {
                if echoes[j].power_db >= sig.detection_threshold_db {
                    echoes[k] = echoes[j];
                    k += 1;
                }
            }
            echoes.truncate(k);
            echoes[start..].sort_by(|a, b| a.range.total_cmp(&b.range));
            spans.push((start, cos));
        }
        spans.push((echoes.len(), 0.0));
        let of = |r: usize| &echoes[spans[r].0..spans[r + 1].0];
        let rays = beam.len();
        let chosen = match sig.selection {
            _ if rays == 1 => 0,
            Selection::Uniform => match select {
                Some(u) => ((u * rays as f64) as usize).min(rays - 1),
                None => match side {
                    Beam::Center => 0,
                    Beam::Left => 1,
                    Beam::Right => 2,
                },
            },
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
            Selection::Strongest => (0..rays)
                .filter_map(|r| {
                    of(r)
                        .iter()
                        .map(|e| e.power_db)
                        .max_by(f64::total_cmp)
                        .map(|p| (r, p))
                })
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |x| x.0),
        };
        let mine = of(chosen);
        let pick = match sig.return_mode {
            ReturnMode::Strongest => mine.iter().max_by(|a, b| a.power_db.total_cmp(&b.power_db)),
            ReturnMode::Last => mine.last(),
            _ => mine.first(),
        };
        let materials = world.materials();
        let (range, kind, material) = match pick {
            Some(e) => (e.range, hit_kind(e, materials), Some(e.material)),
            None => (f64::INFINITY, HitKind::None, None),
        };
        let beam_of = |r: usize| match (beam.len(), r) {
            (3, 1) if beam[1].lateral > 0.0 => Beam::Left,
            (3, 2) if beam[2].lateral < 0.0 => Beam::Right,
            _ => Beam::Center,
        };
        let kept = if sig.return_mode == ReturnMode::All {
            mine.iter().take(sig.max_echoes).copied().collect()
        } else {
            Vec::new()
        };
        Answer {
            range,
            kind,
            material,
            beam: beam_of(chosen),
            echoes: kept,
        }
    }
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
