//! Urban 2D laser simulator with complete ground truth.
//!
//! # Big picture
//!
//! The papers evaluate on hand-labelled urban scan pairs taken from a car 2-4 m apart:
//! cars overtaking, crossing an intersection, driving on the opposite lane (section V
//! of Tipaldi & Ramos, "Motion Clustering and Estimation with Conditional Random
//! Fields"). No public log labels which point of one scan is which point of the next,
//! so this module simulates such pairs with every label the papers' tables need:
//!
//! - a street scene ([`scene`]): building walls, parked cars, poles, trees and bushes
//!   (all static, cluster `0`), moving cars (4.2-4.9 × 1.7-1.95 m rectangles) and
//!   pedestrians (rigid leg pairs) on exactly known trajectories, laid out by a
//!   [`Preset`] ([`presets`]);
//! - an ego car carrying a laser modelled on the papers' sensor: 180° field of view,
//!   361 beams (or 181), 80 m maximum range, Gaussian range noise, random missing
//!   returns, no return where a beam hits nothing ([`SimConfig`]);
//! - two scans 2-4 m of ego travel apart; the time between them is that distance over
//!   the ego speed, and every object moves for that time at its own speed
//!   (cars 5-15 m/s, pedestrians 1-1.8 m/s);
//! - ground truth in the [`crate::pair`] format ([`truth`]): labels of both scans,
//!   the association of every current point into the reference scan (or outlier),
//!   the true motion of the ego vehicle and of every visible object;
//! - an odometry prior: the true ego-motion with noise growing with the distance
//!   travelled.
//!
//! One preset leaves the street: `person-following` ([`person_following`]) puts a
//! small robot behind a walking person outdoors, with the scanner of the
//! `leg_tracker` benchmark's person-following logs (10 Hz, 245 beams over 86°, 5.6 m;
//! [`Preset::default_laser`], applied by [`SimConfig::for_preset`]) and no wheel
//! odometry: its pairs and scans carry none ([`Preset::wheel_odometry`]).
//!
//! Everything is a function of the configuration and a seed (ChaCha8, one stream per
//! pair index), so `simulate_pairs(&config, seed, n)` returns byte-identical data for
//! the same seed, and pair `i` does not depend on `n`. (Sines, cosines and arc
//! tangents come from the platform's math library, so a different platform may
//! differ in the last bits.)
//!
//! The ground-truth conventions (labels by first appearance, associations within one
//! beam spacing of the moved surface point, occlusion and field-of-view outliers) are
//! documented in [`truth`]; the scenes and their situations in [`presets`].
//!
//! # Example
//!
//! ```
//! use pgm_datasets::sim::{simulate_pairs, Preset, SimConfig};
//! use pgm_datasets::ParamGuard;
//!
//! let config = SimConfig { preset: Preset::Intersection, ..SimConfig::default() }
//!     .check()
//!     .expect("valid configuration");
//! let pairs = simulate_pairs(&config, 7, 2);
//! let truth = pairs[0].truth.as_ref().unwrap();
//! assert_eq!(pairs[0].current.len(), 361);
//! assert_eq!(truth.motions[0].kind, "background");
//! let travelled = truth.ego_motion.unwrap().translation().norm();
//! assert!((2.0..=4.0).contains(&travelled));
//! ```

pub mod person_following;
pub mod presets;
mod raycast;
pub mod scene;
mod sensor;
pub mod stats;
pub mod truth;

pub use presets::{Preset, PresetLaser};
pub use scene::{
    MovingObject, ObjectKind, Path, Primitive, Scene, Script, ScriptedObject, Trajectory,
};
pub use stats::DatasetStats;
pub use truth::{association_tolerance, MOVING_SPEED};

use crate::pair::ScanPair;
use pgm_scan::Pose2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// Errors of the simulator: a parameter outside its domain, or an unknown preset name.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A configuration value is outside its allowed domain.
    #[error("simulator parameter `{name}` = {value}: expected {expected}")]
    InvalidParameter {
        /// Field name in [`SimConfig`].
        name: &'static str,
        /// The offending value, as written.
        value: String,
        /// What would have been accepted.
        expected: &'static str,
    },
    /// A preset name that is not one of [`Preset::NAMES`].
    #[error("unknown simulator preset `{name}`: expected one of {}", Preset::NAMES.join(", "))]
    UnknownPreset {
        /// The name that was given.
        name: String,
    },
    /// Pairs whose scene failed the pair selection in every one of its
    /// [`SCENE_ATTEMPTS`] draws ([`try_simulate_pairs`]).
    #[error(
        "{} of {requested} pairs do not meet the pair selection (every moving object with at \
         least {min_object_returns} associated returns) in {SCENE_ATTEMPTS} draws; first: {}",
        unmet.len(),
        unmet.first().map_or(String::new(), |u| u.to_string())
    )]
    SelectionUnmet {
        /// Pairs asked for.
        requested: usize,
        /// The selection's minimum.
        min_object_returns: usize,
        /// The pairs that failed it.
        unmet: Vec<UnmetSelection>,
    },
}

/// A pair whose scene failed the pair selection in every draw: the last draw is what
/// [`simulate_pair`] returns.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct UnmetSelection {
    /// The pair's index.
    pub index: u64,
    /// The pair's name.
    pub name: String,
    /// Returns (with a true association) of the least-seen moving object of the last
    /// draw; `None` when no moving object shows at all.
    pub fewest_object_returns: Option<usize>,
}

impl std::fmt::Display for UnmetSelection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.fewest_object_returns {
            Some(n) => write!(
                f,
                "{} (last draw: an object with {n} associated returns)",
                self.name
            ),
            None => write!(f, "{} (last draw: no moving object shows)", self.name),
        }
    }
}

/// Pairs with the pair selection's outcome ([`simulate_pairs_report`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationReport {
    /// The pairs, as [`simulate_pairs`] returns them.
    pub pairs: Vec<ScanPair>,
    /// The pairs that keep a last draw failing the selection.
    pub unmet: Vec<UnmetSelection>,
}

/// Result type of the simulator.
pub type Result<T> = std::result::Result<T, SimError>;

/// Simulator parameters, unchecked; [`check`](pgm_scan::ParamGuard::check) turns them into a
/// [`ValidSimConfig`], the only form the simulator accepts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SimConfig {
    /// Which kind of scene to build (default [`Preset::Mixed`]).
    pub preset: Preset,
    /// Number of beams over the field of view (default 361; the papers' sensor has 181 or 361).
    pub beams: usize,
    /// Field of view in radians, centred on the sensor's x axis (default π, 180°).
    pub field_of_view: f64,
    /// Maximum range in metres; beyond it there is no return (default 80).
    pub max_range: f64,
    /// Standard deviation of the Gaussian range noise in metres (default 0.03).
    pub range_noise: f64,
    /// Probability that a beam with a hit returns nothing (default 0.01).
    pub dropout: f64,
    /// Ego travel between the two scans in metres, `[min, max]` (default `[2, 4]`).
    pub pair_distance: [f64; 2],
    /// Ego speed in m/s, `[min, max]` (default `[6, 12]`); the time between the scans
    /// is the travelled distance over this speed.
    pub ego_speed: [f64; 2],
    /// Standard deviation of the odometry's x and y error per metre travelled (default 0.02).
    pub odometry_translation_noise: f64,
    /// Standard deviation of the odometry's heading error in radians per metre travelled
    /// (default 0.003).
    pub odometry_rotation_noise: f64,
    /// Pair selection: a pair is kept only when every moving object that shows in the
    /// current scan has at least this many current returns with a true association
    /// (the same surface point seen in the reference scan); otherwise the scene is
    /// drawn again ([`simulate_pair`]). Default 3, like the papers' hand-selected
    /// pairs, where every labelled object's motion can be seen: an object hit by one
    /// or two beams, or one that just came into view, has no motion to cluster by.
    /// 0 keeps every pair.
    pub min_object_returns: usize,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            preset: Preset::Mixed,
            beams: 361,
            field_of_view: std::f64::consts::PI,
            max_range: 80.0,
            range_noise: 0.03,
            dropout: 0.01,
            pair_distance: [2.0, 4.0],
            ego_speed: [6.0, 12.0],
            odometry_translation_noise: 0.02,
            odometry_rotation_noise: 0.003,
            min_object_returns: 3,
        }
    }
}

impl SimConfig {
    /// The default configuration of `preset`: [`SimConfig::default`] with that preset,
    /// and with the preset's own laser ([`Preset::default_laser`]: beams, field of
    /// view, maximum range) where it has one. For the urban presets this is
    /// `SimConfig { preset, ..SimConfig::default() }` exactly.
    pub fn for_preset(preset: Preset) -> Self {
        let mut config = SimConfig {
            preset,
            ..SimConfig::default()
        };
        if let Some(laser) = preset.default_laser() {
            config.beams = laser.beams;
            config.field_of_view = laser.field_of_view;
            config.max_range = laser.max_range;
        }
        config
    }
}

pgm_core::checked_params! {
    /// A [`SimConfig`] whose values have been checked.
    #[derive(Clone, Debug, PartialEq)]
    pub struct ValidSimConfig(SimConfig) -> SimError;
}

/// Most pairs one call of the simulator is asked for ([`ValidSimConfig::check_pairs`]):
/// every pair is held in memory.
pub const MAX_PAIRS: usize = 100_000;

/// Most laser beams over all pairs of one call (pairs × beams per scan), about 2 GB of
/// scans, labels and associations held in memory.
pub const MAX_TOTAL_BEAMS: usize = 20_000_000;

impl ValidSimConfig {
    /// Checks a number of pairs to simulate before anything is allocated: at least
    /// one, at most [`MAX_PAIRS`], and at most [`MAX_TOTAL_BEAMS`] beams in all (a
    /// count of 2^64 − 1 overflowed the vector's capacity and panicked).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `pairs`.
    pub fn check_pairs(&self, pairs: usize) -> Result<()> {
        if pairs == 0 || pairs > MAX_PAIRS {
            return Err(invalid("pairs", pairs, "1..=100000 pairs"));
        }
        if pairs.saturating_mul(self.params.beams) > MAX_TOTAL_BEAMS {
            return Err(invalid(
                "pairs",
                (pairs, self.params.beams),
                "at most 20000000 beams in all (pairs × beams per scan)",
            ));
        }
        Ok(())
    }
}

fn invalid(name: &'static str, value: impl std::fmt::Debug, expected: &'static str) -> SimError {
    SimError::InvalidParameter {
        name,
        value: format!("{value:?}"),
        expected,
    }
}

/// `Ok` when `value` is finite and `>= 0`, else [`invalid`].
fn non_negative(name: &'static str, value: f64, expected: &'static str) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(invalid(name, value, expected))
    }
}

/// `Ok` when `[min, max]` is finite with `0 < min <= max <= limit`, else [`invalid`].
fn positive_interval(
    name: &'static str,
    [min, max]: [f64; 2],
    limit: f64,
    expected: &'static str,
) -> Result<()> {
    if min.is_finite() && max.is_finite() && min > 0.0 && min <= max && max <= limit {
        Ok(())
    } else {
        Err(invalid(name, [min, max], expected))
    }
}

impl SimConfig {
    /// Checks every value once; the error names the field and the offending value.
    fn validate(&self) -> Result<()> {
        if !(2..=100_000).contains(&self.beams) {
            return Err(invalid("beams", self.beams, "an integer in 2..=100000"));
        }
        let fov = self.field_of_view;
        if !(fov.is_finite() && fov > 0.0 && fov <= std::f64::consts::TAU) {
            return Err(invalid("field_of_view", fov, "radians in (0, 2π]"));
        }
        if !(self.max_range.is_finite() && self.max_range > 0.0) {
            return Err(invalid(
                "max_range",
                self.max_range,
                "a positive number of metres",
            ));
        }
        non_negative(
            "range_noise",
            self.range_noise,
            "a standard deviation >= 0 in metres",
        )?;
        if !(self.dropout.is_finite() && (0.0..1.0).contains(&self.dropout)) {
            return Err(invalid("dropout", self.dropout, "a probability in [0, 1)"));
        }
        positive_interval(
            "pair_distance",
            self.pair_distance,
            20.0,
            "[min, max] metres with 0 < min <= max <= 20",
        )?;
        positive_interval(
            "ego_speed",
            self.ego_speed,
            50.0,
            "[min, max] m/s with 0 < min <= max <= 50",
        )?;
        non_negative(
            "odometry_translation_noise",
            self.odometry_translation_noise,
            "a standard deviation >= 0 in metres per metre",
        )?;
        non_negative(
            "odometry_rotation_noise",
            self.odometry_rotation_noise,
            "a standard deviation >= 0 in radians per metre",
        )
    }
}

/// Uniform sample in `[lo, hi]` (also for `lo == hi`, where `random_range` would panic).
pub(crate) fn uniform<R: Rng>(rng: &mut R, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// The random stream of pair `index` for `seed`: ChaCha8 seeded with `seed`, stream
/// `index`, so every pair is reproducible on its own.
pub fn pair_rng(seed: u64, index: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index);
    rng
}

/// Simulates `n` pairs of the configured preset: pair `i` is
/// [`simulate_pair`]`(config, seed, i)`.
pub fn simulate_pairs(config: &ValidSimConfig, seed: u64, n: usize) -> Vec<ScanPair> {
    // Reserve no more than a sensible count (see `ValidSimConfig::check_pairs`): the
    // range's size hint would reserve `n` pairs up front.
    let mut pairs = Vec::with_capacity(n.min(MAX_PAIRS));
    for i in 0..n {
        pairs.push(simulate_pair(config, seed, i as u64));
    }
    pairs
}

/// How many scenes [`simulate_pair`] draws at most to get one it keeps.
pub const SCENE_ATTEMPTS: usize = 40;

/// Whether every moving object that shows in the current scan of `pair` has at least
/// `min_returns` current returns with a true association into the reference scan
/// ([`SimConfig::min_object_returns`]).
pub fn objects_observable(pair: &ScanPair, min_returns: usize) -> bool {
    fewest_object_returns(pair).is_none_or(|n| n >= min_returns)
}

/// The smallest number of current returns with a true association over the moving
/// objects that show in the current scan (`None` when none shows or the pair lacks
/// labels or associations).
pub fn fewest_object_returns(pair: &ScanPair) -> Option<usize> {
    let truth = pair.truth.as_ref()?;
    let (Some(labels), Some(associations)) = (&truth.labels, &truth.associations) else {
        return None;
    };
    let mut counts: std::collections::BTreeMap<u32, usize> = Default::default();
    for (label, association) in labels.iter().zip(associations) {
        if let Some(l) = label.filter(|&l| l != 0) {
            let seen = matches!(association, Some(crate::pair::Association::Point(_)));
            *counts.entry(l).or_default() += usize::from(seen);
        }
    }
    counts.values().copied().min()
}

/// Simulates pair number `index` of the configured preset for `seed`; its name is
/// `sim:<preset>:<seed>:<index>`.
///
/// Every preset but [`Preset::Random`] depicts a situation with moving objects, so
/// when all of them happen to be hidden (behind parked cars, say) in the current
/// scan, the scene is drawn again from the same stream. So is a scene that fails the
/// pair selection of [`SimConfig::min_object_returns`] ([`objects_observable`]),
/// `Random` included (which otherwise keeps whatever it draws, empty streets
/// included). After [`SCENE_ATTEMPTS`] draws the last one is kept: use
/// [`simulate_pair_report`], [`simulate_pairs_report`] or [`try_simulate_pairs`] to
/// know whether that happened.
pub fn simulate_pair(config: &ValidSimConfig, seed: u64, index: u64) -> ScanPair {
    simulate_pair_report(config, seed, index).0
}

/// [`simulate_pair`] and, when the selection was not met in any draw, what the last
/// draw kept.
pub fn simulate_pair_report(
    config: &ValidSimConfig,
    seed: u64,
    index: u64,
) -> (ScanPair, Option<UnmetSelection>) {
    let mut rng = pair_rng(seed, index);
    let preset = config.params().preset;
    let name = format!("sim:{}:{seed}:{index}", preset.name());
    let mut attempt = 1;
    loop {
        let scene = preset.scene(config, &mut rng);
        let pair = simulate_scene(&scene, config, &mut rng, name.clone());
        let shows_motion = pair
            .truth
            .as_ref()
            .and_then(|t| t.labels.as_ref())
            .is_some_and(|labels| labels.iter().any(|l| l.is_some_and(|l| l != 0)));
        let selected = objects_observable(&pair, config.params().min_object_returns);
        if selected && (shows_motion || preset == Preset::Random) {
            return (pair, None);
        }
        if attempt >= SCENE_ATTEMPTS {
            let unmet = UnmetSelection {
                index,
                name: pair.name.clone(),
                fewest_object_returns: fewest_object_returns(&pair),
            };
            return (pair, Some(unmet));
        }
        attempt += 1;
    }
}

/// [`simulate_pairs`] with the pairs that failed the selection in every draw listed.
pub fn simulate_pairs_report(config: &ValidSimConfig, seed: u64, n: usize) -> SimulationReport {
    let mut pairs = Vec::with_capacity(n.min(MAX_PAIRS));
    let mut unmet = Vec::new();
    for i in 0..n {
        let (pair, failed) = simulate_pair_report(config, seed, i as u64);
        pairs.push(pair);
        unmet.extend(failed);
    }
    SimulationReport { pairs, unmet }
}

/// [`simulate_pairs`], or [`SimError::SelectionUnmet`] when some pair's scene failed
/// the pair selection in every one of its [`SCENE_ATTEMPTS`] draws.
///
/// # Errors
/// [`SimError::SelectionUnmet`] listing those pairs.
pub fn try_simulate_pairs(config: &ValidSimConfig, seed: u64, n: usize) -> Result<Vec<ScanPair>> {
    let report = simulate_pairs_report(config, seed, n);
    if report.unmet.is_empty() {
        Ok(report.pairs)
    } else {
        Err(SimError::SelectionUnmet {
            requested: n,
            min_object_returns: config.params().min_object_returns,
            unmet: report.unmet,
        })
    }
}

/// A sequence of scans of one scene, as pairs `k` scans apart: `scans` scans taken
/// `scene.interval / k` seconds apart (so that each pair spans the preset's interval,
/// as a pair of [`simulate_pair`] does; `person-following` scans every 0.1 s whatever
/// `k`, [`Preset::scan_period`]), and the pairs `(a, a + k)` for every `a` in
/// `0..scans - k`, each with its complete ground truth. Pairs are named
/// `sim:PRESET:SEED:INDEX:A-B`; their scans carry time stamps `1000 · INDEX + t` (s), so
/// that the sequences of one data set never join (`pgm_tracking` ends a
/// sequence at a gap above 1 s). The scene ([`Preset::script`]) is drawn from stream
/// `index` of `seed` like [`simulate_pair`]'s, without its pair selection; the noise of
/// each pair is drawn after it, pair by pair, so one scan is simulated once per pair it
/// belongs to (with noise of its own each time). An object keeps its tracking-truth id
/// ([`GroundTruth::objects`](crate::GroundTruth::objects), its body index) in every
/// pair of the sequence.
///
/// # Panics
/// If `k` is 0 or not below `scans`.
pub fn simulate_sequence(
    config: &ValidSimConfig,
    seed: u64,
    index: u64,
    scans: usize,
    k: usize,
) -> Vec<ScanPair> {
    assert!(
        k >= 1 && k < scans,
        "pairs k scans apart need 1 <= k < scans"
    );
    let mut rng = pair_rng(seed, index);
    let preset = config.params().preset;
    let script = preset.script(config, &mut rng, scans, k);
    let period = script.period;
    let offset = 1000.0 * index as f64;
    // Surfaces beyond the laser's range (and a metre more) are never hit.
    let reach = config.params().max_range + 1.0;
    (0..scans - k)
        .map(|a| {
            let b = a + k;
            let at = a as f64 * period;
            let interval = k as f64 * period;
            let scene = script.scene_at(at, interval, reach);
            let speeds = script.speeds_before(at + interval);
            let name = format!("sim:{}:{seed}:{index}:{a}-{b}", preset.name());
            let mut pair = scan_scene_pair(&scene, config, &mut rng, name, &speeds);
            pair.reference.timestamp = offset + at;
            pair.current.timestamp = offset + b as f64 * period;
            pair
        })
        .collect()
}

/// Scans a given scene twice (reference at time 0, current at `scene.interval`) and
/// builds the pair with its ground truth and odometry prior. The preset in `config`
/// only says whether there is odometry ([`Preset::wheel_odometry`]); the laser, noise
/// and odometry parameters are used.
///
/// Each scan's [`pgm_scan::Scan::odometry`] is set consistently with the pair's
/// prior: the reference scan carries the true world pose of the ego vehicle, the
/// current scan that pose composed with the noisy odometry. Without wheel odometry
/// the pair's prior and both scans' odometry are `None` (and no odometry noise is
/// drawn).
pub fn simulate_scene<R: Rng>(
    scene: &Scene,
    config: &ValidSimConfig,
    rng: &mut R,
    name: String,
) -> ScanPair {
    scan_scene_pair(scene, config, rng, name, &scene.speeds())
}

/// [`simulate_scene`] with each body's speed over the ground at the current scan's time
/// given (m/s, background first), for the tracking truth's `moving`.
fn scan_scene_pair<R: Rng>(
    scene: &Scene,
    config: &ValidSimConfig,
    rng: &mut R,
    name: String,
    speeds: &[f64],
) -> ScanPair {
    let reference_pose = scene.reference_sensor();
    let current_pose = scene.current_sensor();
    let mut reference = sensor::scan_scene(scene, config, &reference_pose, 0.0, rng);
    let mut current = sensor::scan_scene(scene, config, &current_pose, scene.interval, rng);
    let truth = truth::ground_truth(scene, config, &reference, &current, speeds);
    let odometry = if config.params().preset.wheel_odometry() {
        let ego = truth.ego_motion.unwrap_or_else(|| scene.body_motion(0));
        let odometry = noisy_odometry(config, &ego, rng);
        reference.scan.odometry = Some(reference_pose);
        current.scan.odometry = Some(reference_pose.compose(&odometry));
        Some(odometry)
    } else {
        None
    };
    ScanPair {
        name,
        reference: reference.scan,
        current: current.scan,
        odometry,
        truth: Some(truth),
    }
}

/// The true ego-motion with independent Gaussian errors on x, y (standard deviation
/// `odometry_translation_noise · d`) and heading (`odometry_rotation_noise · d`), where
/// `d` is the distance travelled: the drift of a car's wheel odometry over one pair.
fn noisy_odometry<R: Rng>(config: &ValidSimConfig, ego: &Pose2, rng: &mut R) -> Pose2 {
    let c = config.params();
    let d = ego.translation().norm();
    let ex: f64 = rng.sample(StandardNormal);
    let ey: f64 = rng.sample(StandardNormal);
    let et: f64 = rng.sample(StandardNormal);
    Pose2::new(
        ego.x() + c.odometry_translation_noise * d * ex,
        ego.y() + c.odometry_translation_noise * d * ey,
        ego.theta() + c.odometry_rotation_noise * d * et,
    )
}
