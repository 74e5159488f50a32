//! Ground truth of a simulated pair: labels, true motions and point associations.
//!
//! Labels: `0` for every static surface; moving objects that the laser sees in
//! either scan are numbered `1, 2, …` in order of first appearance, current scan
//! first (beam order), then reference scan. Objects seen in neither scan get no
//! label and no motion.
//!
//! Associations (current scan → reference scan). For a valid current point of body
//! `b` take its **noise-free** end point `p` and move it with `b`'s true motion into
//! the reference sensor frame, `q = m_b · p` (the same surface point at the reference
//! time). The point is an outlier when
//! 1. `q` lies outside the field of view (padded by half a beam) or beyond the
//!    maximum range, or
//! 2. `q` is hidden: the ray from the reference sensor towards `q` meets a surface more
//!    than 1 µm before `q` (another object, or the object's own front side, so the
//!    back of a car is never associated), or
//! 3. no valid reference point of the same body has its noise-free end point within
//!    the tolerance `τ` of `q` (the surface there was not sampled: dropouts, or `q`
//!    beyond the last beam that hit the object).
//!
//! Otherwise the association is that nearest reference point. The tolerance is one
//! beam spacing on the surface, `τ = r·Δθ / max(cos φ, cos 80°)` ([`association_tolerance`]),
//! with `r = |q|`, `Δθ` the angle between beams and `φ` the angle of incidence of the
//! reference ray on the surface at `q`: with both neighbouring beams valid the
//! nearest one is at most half a spacing away, and one missing neighbour still leaves
//! a partner within one spacing; a longer gap makes the point an outlier. Noise does
//! not enter the choice, so the truth is the same for any noise level.
//!
//! Tracking truth ([`GroundTruth::objects`]): every moving object of the scene (a car,
//! a pedestrian, also one standing still at the moment) with at least one return in
//! the current scan, identified by its body index (object `i` of the scene is body
//! `i + 1`, the same in every pair of a sequence of [`crate::sim::simulate_sequence`]),
//! with its true centre in the current sensor frame (the origin of its body frame: a
//! pedestrian's point midway between the legs, a car's box centre), `moving` when its
//! true speed over the ground at the current scan's time exceeds [`MOVING_SPEED`], and
//! `returns`, its returns in the current scan (the beams labelled with its label).

use super::scene::Scene;
use super::sensor::{beam_spacing, SimulatedScan};
use super::ValidSimConfig;
use crate::pair::{Association, ClusterMotion, GroundTruth, ObjectCentre};
use nalgebra::Point2;
use pgm_scan::Pose2;

/// Speed over the ground (m/s) above which an object counts as moving in the tracking
/// truth ([`ObjectCentre::moving`]): 0.1 m/s, a tenth of a slow walk; a
/// simulated object either stands (0 m/s) or moves at 0.1 m/s and more only while it
/// starts or stops.
pub const MOVING_SPEED: f64 = 0.1;

/// Incidence angles beyond 80° count as 80° in [`association_tolerance`], which keeps
/// the tolerance finite for surfaces seen edge-on.
pub const MAX_INCIDENCE_DEGREES: f64 = 80.0;

/// The association tolerance `τ = r·Δθ / max(cos φ, cos 80°)`: the distance between
/// neighbouring beams' end points on a surface at range `range` (m) hit at incidence
/// `cos φ = incidence_cos`, for beams `beam_spacing` radians apart.
pub fn association_tolerance(range: f64, incidence_cos: f64, beam_spacing: f64) -> f64 {
    let floor = MAX_INCIDENCE_DEGREES.to_radians().cos();
    range * beam_spacing / incidence_cos.abs().max(floor)
}

/// Builds the ground truth of a pair from the two simulated scans; `speeds` holds each
/// body's speed over the ground at the current scan's time (m/s, background first).
pub(crate) fn ground_truth(
    scene: &Scene,
    config: &ValidSimConfig,
    reference: &SimulatedScan,
    current: &SimulatedScan,
    speeds: &[f64],
) -> GroundTruth {
    let bodies = scene.objects.len() + 1;
    // Label of every body, assigned in order of first appearance.
    let mut label_of: Vec<Option<u32>> = vec![None; bodies];
    label_of[0] = Some(0);
    let mut next = 1u32;
    for sim in [current, reference] {
        for (k, t) in sim.truth.iter().enumerate() {
            if let (true, Some(t)) = (sim.scan.valid[k], t) {
                if label_of[t.body].is_none() {
                    label_of[t.body] = Some(next);
                    next += 1;
                }
            }
        }
    }
    let labels_for = |sim: &SimulatedScan| -> Vec<Option<u32>> {
        sim.truth
            .iter()
            .zip(&sim.scan.valid)
            .map(|(t, &v)| match (v, t) {
                (true, Some(t)) => label_of[t.body],
                _ => None,
            })
            .collect()
    };
    let labels = labels_for(current);
    let reference_labels = labels_for(reference);

    let motions_by_body: Vec<Pose2> = (0..bodies).map(|b| scene.body_motion(b)).collect();
    let mut visible: Vec<(u32, usize)> = label_of
        .iter()
        .enumerate()
        .filter_map(|(b, l)| l.map(|l| (l, b)))
        .collect();
    visible.sort_unstable();
    let motions = visible
        .iter()
        .map(|&(label, body)| ClusterMotion {
            label,
            motion: motions_by_body[body],
            kind: if body == 0 {
                "background".to_string()
            } else {
                scene.objects[body - 1].kind.name().to_string()
            },
        })
        .collect();

    let associations = current
        .truth
        .iter()
        .zip(&current.scan.valid)
        .map(|(t, &v)| match (v, t) {
            (true, Some(t)) => Some(associate(
                config,
                reference,
                t.body,
                motions_by_body[t.body].transform_point(&t.point),
            )),
            _ => None,
        })
        .collect();

    GroundTruth {
        ego_motion: Some(motions_by_body[0]),
        labels: Some(labels),
        reference_labels: Some(reference_labels),
        associations: Some(associations),
        motions,
        objects: Some(tracked_objects(scene, current, speeds)),
    }
}

/// The objects of the current scan for tracking (module docs), in body order.
fn tracked_objects(scene: &Scene, current: &SimulatedScan, speeds: &[f64]) -> Vec<ObjectCentre> {
    let mut returns = vec![0usize; scene.objects.len() + 1];
    for (t, &v) in current.truth.iter().zip(&current.scan.valid) {
        if let (true, Some(t)) = (v, t) {
            returns[t.body] += 1;
        }
    }
    let to_sensor = scene.current_sensor().inverse();
    (1..returns.len())
        .filter(|&b| returns[b] > 0)
        .map(|b| {
            let body = scene.body_pose(b, scene.interval);
            let centre = to_sensor.transform_point(&Point2::from(body.translation()));
            ObjectCentre {
                id: b as u64,
                x: centre.x,
                y: centre.y,
                moving: Some(speeds[b] > MOVING_SPEED),
                returns: Some(returns[b]),
            }
        })
        .collect()
}

/// The association of a surface point of `body` that lies at `q` in the reference
/// sensor frame (rules 1-3 of the module docs).
fn associate(
    config: &ValidSimConfig,
    reference: &SimulatedScan,
    body: usize,
    q: nalgebra::Point2<f64>,
) -> Association {
    const OCCLUSION_EPSILON: f64 = 1e-6;
    let c = config.params();
    let spacing = beam_spacing(config);
    let range = q.coords.norm();
    let angle = q.y.atan2(q.x);
    let first_angle = -c.field_of_view / 2.0;
    let half_fov = c.field_of_view / 2.0 + spacing / 2.0;
    if range >= c.max_range || angle.abs() > half_fov {
        return Association::Outlier;
    }
    let incidence_cos = match reference.caster.cast(angle, c.max_range) {
        Some(hit) if hit.range < range - OCCLUSION_EPSILON => return Association::Outlier,
        Some(hit) if hit.body == body && hit.range <= range + OCCLUSION_EPSILON => {
            hit.incidence_cos
        }
        // The ray slips past the surface's edge: q is on the silhouette, seen edge-on.
        _ => 0.0,
    };
    let tolerance = association_tolerance(range, incidence_cos, spacing);
    let window = ((tolerance / range).min(1.0).asin() / spacing).ceil() as usize + 1;
    let n = reference.scan.len();
    let centre = ((angle - first_angle) / spacing)
        .round()
        .clamp(0.0, (n - 1) as f64) as usize;
    let mut best: Option<(f64, usize)> = None;
    for j in centre.saturating_sub(window)..=(centre + window).min(n - 1) {
        if !reference.scan.valid[j] {
            continue;
        }
        if let Some(t) = &reference.truth[j] {
            if t.body != body {
                continue;
            }
            let d = (t.point - q).norm();
            if d <= tolerance && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, j));
            }
        }
    }
    match best {
        Some((_, j)) => Association::Point(j),
        None => Association::Outlier,
    }
}
