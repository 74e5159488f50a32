//! The simulated laser: beams over the field of view, exact ray casting, Gaussian
//! range noise, random missing returns, and no return beyond the maximum range.

use super::raycast::Raycaster;
use super::scene::Scene;
use super::ValidSimConfig;
use nalgebra::Point2;
use pgm_scan::{Pose2, Scan};
use rand::Rng;
use rand_distr::StandardNormal;

/// What a beam really hit, before noise and dropout.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TrueReturn {
    /// Noise-free range.
    pub range: f64,
    /// Body index (0 = background).
    pub body: usize,
    /// Noise-free end point in the sensor frame.
    pub point: Point2<f64>,
}

/// A simulated scan with the noise-free truth behind every beam.
#[derive(Clone, Debug)]
pub(crate) struct SimulatedScan {
    pub scan: Scan,
    /// Per beam: the true return (also for beams that dropped out), `None` without hit.
    pub truth: Vec<Option<TrueReturn>>,
    /// The scene in this sensor frame at this time, for visibility queries.
    pub caster: Raycaster,
}

/// Beam angles: `beams` equally spaced bearings over the field of view, centred on
/// the x axis (for 180° and 361 beams: −90° to +90° in 0.5° steps).
pub(crate) fn beam_angles(config: &ValidSimConfig) -> Vec<f64> {
    let c = config.params();
    let step = beam_spacing(config);
    (0..c.beams)
        .map(|k| -c.field_of_view / 2.0 + step * k as f64)
        .collect()
}

/// Angle between neighbouring beams (`Δθ`).
pub(crate) fn beam_spacing(config: &ValidSimConfig) -> f64 {
    let c = config.params();
    c.field_of_view / (c.beams - 1) as f64
}

/// Scans the scene at time `t` from world pose `sensor`.
///
/// Every beam draws one standard normal (noise) and one uniform (dropout) in beam
/// order whatever it hits, so the random stream does not depend on the geometry.
/// Beams without a hit report `max_range` and beams that drop out report `0.0`, both
/// with `valid = false`; a noisy range outside `(0, max_range)` is also no return.
pub(crate) fn scan_scene<R: Rng>(
    scene: &Scene,
    config: &ValidSimConfig,
    sensor: &Pose2,
    t: f64,
    rng: &mut R,
) -> SimulatedScan {
    let c = config.params();
    let angles = beam_angles(config);
    let caster = Raycaster::new(scene, sensor, t);
    let n = angles.len();
    let mut ranges = Vec::with_capacity(n);
    let mut valid = Vec::with_capacity(n);
    let mut truth = Vec::with_capacity(n);
    for &angle in &angles {
        let noise: f64 = rng.sample(StandardNormal);
        let dropped = rng.random::<f64>() < c.dropout;
        match caster.cast(angle, c.max_range) {
            Some(hit) => {
                let (s, co) = angle.sin_cos();
                truth.push(Some(TrueReturn {
                    range: hit.range,
                    body: hit.body,
                    point: Point2::new(hit.range * co, hit.range * s),
                }));
                let measured = hit.range + c.range_noise * noise;
                if dropped {
                    ranges.push(0.0);
                    valid.push(false);
                } else if measured > 0.0 && measured < c.max_range {
                    ranges.push(measured);
                    valid.push(true);
                } else {
                    ranges.push(c.max_range);
                    valid.push(false);
                }
            }
            None => {
                truth.push(None);
                ranges.push(c.max_range);
                valid.push(false);
            }
        }
    }
    SimulatedScan {
        scan: Scan {
            timestamp: t,
            angles,
            ranges,
            valid,
            max_range: c.max_range,
            odometry: None,
            laser_offset: Pose2::identity(),
        },
        truth,
        caster,
    }
}
