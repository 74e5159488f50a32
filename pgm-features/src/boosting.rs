//! AdaBoost over decision stumps (Freund and Schapire 1997), the booster that turns
//! CRF-Matching's shape features into its two boosted local features (data boosting
//! and outlier boosting; section IV-C.1 of van de Ven, Ramos and Tipaldi: "AdaBoost
//! with 50 decision stumps").
//!
//! The CRF needs a *real-valued* score per sample, the boosting margin
//! `F(x) = Σ_t α_t h_t(x)` with `h_t(x) = ±1` a stump on one feature, not a class.
//! linfa-ensemble 0.8's `AdaBoost` (with linfa-trees stumps) was the first choice and
//! is not used, for three reasons read from its source
//! (`algorithms/linfa-ensemble/src/adaboost.rs`): its `predict` returns only the
//! weighted-majority class (the margin is not exposed); it trains each learner on a
//! weighted *resample* of the data with an `f32` weight vector (a random, approximate
//! AdaBoost) rather than on the weights themselves; and its trees are opaque, while
//! CRF-Matching must re-evaluate only the stumps on the motion-dependent feature
//! (registered translation) each time the motion estimate changes
//! ([`Booster::split_by_features`]).
//!
//! Training is exact discrete AdaBoost on weighted samples: each round fits the stump
//! (feature, threshold, polarity) of least weighted error by one sorted sweep per
//! feature, `α = ½ ln((1 − ε) / ε)` (ε clamped to `[1e-10, 1 − 1e-10]`), and samples
//! are reweighted by `exp(−α y h(x))`. The two classes start with equal total weight
//! (matching has far more negatives than positives). Missing feature values (`NaN`,
//! e.g. the fifth neighbour of a point at the end of a scan) always go to the
//! stump's "above" side.
//!
//! ```
//! use pgm_features::boosting::{BoosterParams, TrainingSet};
//! use pgm_scan::ParamGuard;
//!
//! // Positive when x0 < 0.5 or x1 > 2.
//! let mut data = TrainingSet::new(2);
//! for k in 0..200 {
//!     let (x0, x1) = ((k % 20) as f64 / 20.0, (k / 20) as f64 / 3.0);
//!     data.push(&[x0, x1], x0 < 0.5 || x1 > 2.0).unwrap();
//! }
//! let booster = BoosterParams::default().stumps(20).check().unwrap().train(&data).unwrap();
//! assert!(booster.score(&[0.1, 0.0]) > 0.0);
//! assert!(booster.score(&[0.9, 0.5]) < 0.0);
//! ```

use pgm_core::param::InvalidParameter;
use pgm_scan::{Error, Result};
use serde::{Deserialize, Serialize};

/// One decision stump: `+1` when `feature` is below `threshold` (or above, with
/// `below_is_positive` false), `−1` otherwise; `NaN` counts as above.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stump {
    /// Index of the feature tested.
    pub feature: usize,
    /// The threshold.
    pub threshold: f64,
    /// Whether values below the threshold vote `+1`.
    pub below_is_positive: bool,
    /// The stump's weight `α` in the margin.
    pub alpha: f64,
}

impl Stump {
    /// The stump's vote `±1` on `value`.
    #[inline]
    pub fn vote(&self, value: f64) -> f64 {
        let below = value < self.threshold;
        if below == self.below_is_positive {
            1.0
        } else {
            -1.0
        }
    }
}

/// A trained booster: its stumps and the number of features it reads.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Booster {
    /// Number of features of a sample.
    pub features: usize,
    /// The stumps in training order.
    pub stumps: Vec<Stump>,
}

impl Booster {
    /// The margin `F(x) = Σ α_t h_t(x)` of `sample` (`features` values).
    ///
    /// # Panics
    /// If `sample` is shorter than the booster's feature count.
    pub fn score(&self, sample: &[f64]) -> f64 {
        self.stumps
            .iter()
            .map(|s| s.alpha * s.vote(sample[s.feature]))
            .sum()
    }

    /// The margin of the stumps on features other than `features`, and one
    /// [`StepFunction`] per feature of `features` for its stumps: `score(x) = rest(x) +
    /// Σ_k step_k(x[features[k]])`. CRF-Matching re-evaluates only the step functions
    /// when the motion (and with it the registered features) changes.
    pub fn split_by_features(&self, features: &[usize]) -> (Booster, Vec<StepFunction>) {
        let rest = Booster {
            features: self.features,
            stumps: self
                .stumps
                .iter()
                .filter(|s| !features.contains(&s.feature))
                .copied()
                .collect(),
        };
        let steps = features
            .iter()
            .map(|&f| {
                let on: Vec<Stump> = self
                    .stumps
                    .iter()
                    .filter(|s| s.feature == f)
                    .copied()
                    .collect();
                StepFunction::new(&on)
            })
            .collect();
        (rest, steps)
    }

    /// Sum of the stump weights (the largest possible margin).
    pub fn total_alpha(&self) -> f64 {
        self.stumps.iter().map(|s| s.alpha).sum()
    }
}

/// The margin of a set of stumps on one feature, as a step function of that
/// feature's value (evaluated by binary search).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct StepFunction {
    /// Thresholds in increasing order.
    thresholds: Vec<f64>,
    /// `values[k]`: the margin for a value in `[thresholds[k − 1], thresholds[k])`
    /// (`values[0]` below the first threshold, the last one at or above the last and
    /// for `NaN`).
    values: Vec<f64>,
}

impl StepFunction {
    fn new(stumps: &[Stump]) -> Self {
        let mut thresholds: Vec<f64> = stumps.iter().map(|s| s.threshold).collect();
        thresholds.sort_by(f64::total_cmp);
        thresholds.dedup();
        // Evaluate in each interval at a representative value.
        let mut values = Vec::with_capacity(thresholds.len() + 1);
        let eval = |x: f64| stumps.iter().map(|s| s.alpha * s.vote(x)).sum::<f64>();
        for k in 0..=thresholds.len() {
            let x = match k {
                0 => thresholds.first().map_or(0.0, |t| t - 1.0),
                _ => thresholds[k - 1],
            };
            values.push(eval(x));
        }
        Self { thresholds, values }
    }

    /// The margin at `value` (`NaN` counts as above every threshold).
    #[inline]
    pub fn eval(&self, value: f64) -> f64 {
        if value.is_nan() {
            return *self.values.last().unwrap_or(&0.0);
        }
        let k = self.thresholds.partition_point(|&t| t <= value);
        self.values[k]
    }
}

/// Labelled samples for [`AdaBoost::train`]: feature rows and `±1` labels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrainingSet {
    features: usize,
    values: Vec<f64>,
    labels: Vec<bool>,
}

impl TrainingSet {
    /// An empty set of samples with `features` values each.
    pub fn new(features: usize) -> Self {
        Self {
            features,
            values: Vec::new(),
            labels: Vec::new(),
        }
    }

    /// Adds a sample (`positive`: the class the margin scores high).
    ///
    /// # Errors
    /// When `sample` does not have the set's number of features or holds an infinite
    /// value (`NaN` is allowed: a missing value).
    pub fn push(&mut self, sample: &[f64], positive: bool) -> Result<()> {
        if sample.len() != self.features {
            return Err(InvalidParameter::new(
                "sample",
                format!("{} values", sample.len()),
                "one value per feature of the training set",
            )
            .into());
        }
        if let Some(x) = sample.iter().find(|x| x.is_infinite()) {
            return Err(
                InvalidParameter::new("sample", x, "finite values or NaN (missing)").into(),
            );
        }
        self.values.extend_from_slice(sample);
        self.labels.push(positive);
        Ok(())
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    /// True without samples.
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    /// Number of positive samples.
    pub fn positives(&self) -> usize {
        self.labels.iter().filter(|&&l| l).count()
    }

    /// Appends every sample of `other` (same feature count).
    pub fn extend(&mut self, other: &TrainingSet) -> Result<()> {
        if other.features != self.features {
            return Err(InvalidParameter::new(
                "training set",
                format!("{} features, not {}", other.features, self.features),
                "sets with the same features",
            )
            .into());
        }
        self.values.extend_from_slice(&other.values);
        self.labels.extend_from_slice(&other.labels);
        Ok(())
    }

    fn value(&self, sample: usize, feature: usize) -> f64 {
        self.values[sample * self.features + feature]
    }
}

/// Parameters of AdaBoost, unchecked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoosterParams {
    /// Number of stumps (rounds): 50, as the paper.
    pub stumps: usize,
}

impl Default for BoosterParams {
    fn default() -> Self {
        Self { stumps: 50 }
    }
}

impl BoosterParams {
    /// Sets the number of stumps.
    pub fn stumps(mut self, stumps: usize) -> Self {
        self.stumps = stumps;
        self
    }
}

pgm_core::checked_params! {
    /// AdaBoost with checked parameters.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct AdaBoost(BoosterParams) -> Error;
}

impl BoosterParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        if !(1..=10_000).contains(&self.stumps) {
            return Err(InvalidParameter::new("stumps", self.stumps, "1..=10000 stumps").into());
        }
        Ok(())
    }
}

impl AdaBoost {
    /// Trains a booster on `data` (see the module docs).
    ///
    /// # Errors
    /// When `data` lacks positive or negative samples.
    pub fn train(&self, data: &TrainingSet) -> Result<Booster> {
        let n = data.len();
        let positives = data.positives();
        if positives == 0 || positives == n {
            return Err(InvalidParameter::new(
                "training set",
                format!("{n} samples, {positives} positive"),
                "positive and negative samples",
            )
            .into());
        }
        // Equal total weight for the two classes.
        let mut weight: Vec<f64> = data
            .labels
            .iter()
            .map(|&l| {
                if l {
                    0.5 / positives as f64
                } else {
                    0.5 / (n - positives) as f64
                }
            })
            .collect();
        // Sample order by each feature's value (missing values last), once.
        let orders: Vec<Vec<usize>> = (0..data.features)
            .map(|f| {
                let mut order: Vec<usize> = (0..n).collect();
                order.sort_by(|&a, &b| {
                    let (x, y) = (data.value(a, f), data.value(b, f));
                    match (x.is_nan(), y.is_nan()) {
                        (false, false) => x.total_cmp(&y),
                        (a, b) => a.cmp(&b),
                    }
                });
                order
            })
            .collect();
        let mut stumps = Vec::with_capacity(self.params.stumps);
        for _ in 0..self.params.stumps {
            let total: f64 = weight.iter().sum();
            let Some(best) = best_stump(data, &orders, &weight, total) else {
                break;
            };
            let (mut stump, error) = best;
            let e = (error / total).clamp(1e-10, 1.0 - 1e-10);
            if e >= 0.5 {
                break;
            }
            stump.alpha = 0.5 * ((1.0 - e) / e).ln();
            for (s, w) in weight.iter_mut().enumerate() {
                let y = if data.labels[s] { 1.0 } else { -1.0 };
                *w *= (-stump.alpha * y * stump.vote(data.value(s, stump.feature))).exp();
            }
            stumps.push(stump);
        }
        if stumps.is_empty() {
            return Err(InvalidParameter::new(
                "training set",
                format!("{n} samples"),
                "samples some stump separates better than chance",
            )
            .into());
        }
        Ok(Booster {
            features: data.features,
            stumps,
        })
    }
}

/// The stump of least weighted error over every feature and threshold: (stump with
/// α = 0, its weighted error).
fn best_stump(
    data: &TrainingSet,
    orders: &[Vec<usize>],
    weight: &[f64],
    total: f64,
) -> Option<(Stump, f64)> {
    let positive_total: f64 = (0..data.len())
        .filter(|&s| data.labels[s])
        .map(|s| weight[s])
        .sum();
    let mut best: Option<(Stump, f64)> = None;
    for (f, order) in orders.iter().enumerate() {
        // Weight of positives and negatives strictly below the threshold.
        let (mut pos_below, mut neg_below) = (0.0, 0.0);
        let mut consider = |threshold: f64, pos_below: f64, neg_below: f64| {
            let neg_total = total - positive_total;
            // below → +1: errors are negatives below and positives above.
            let below_positive = neg_below + (positive_total - pos_below);
            // below → −1: errors are positives below and negatives above.
            let below_negative = pos_below + (neg_total - neg_below);
            for (error, below_is_positive) in [(below_positive, true), (below_negative, false)] {
                if best.as_ref().is_none_or(|(_, e)| error < *e) {
                    best = Some((
                        Stump {
                            feature: f,
                            threshold,
                            below_is_positive,
                            alpha: 0.0,
                        },
                        error,
                    ));
                }
            }
        };
        let mut k = 0;
        while k < order.len() {
            let x = data.value(order[k], f);
            if x.is_nan() {
                break;
            }
            // Advance over equal values; the threshold sits between distinct values.
            let mut end = k;
            while end < order.len() && data.value(order[end], f) == x {
                let s = order[end];
                if data.labels[s] {
                    pos_below += weight[s];
                } else {
                    neg_below += weight[s];
                }
                end += 1;
            }
            let next = order.get(end).map(|&s| data.value(s, f));
            let threshold = match next {
                Some(y) if !y.is_nan() => 0.5 * (x + y),
                _ => x + 1.0,
            };
            consider(threshold, pos_below, neg_below);
            k = end;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use pgm_core::ParamGuard;

    #[test]
    fn step_function_equals_the_stumps() {
        let stumps = vec![
            Stump {
                feature: 0,
                threshold: 1.0,
                below_is_positive: true,
                alpha: 0.7,
            },
            Stump {
                feature: 0,
                threshold: 3.0,
                below_is_positive: false,
                alpha: 0.2,
            },
            Stump {
                feature: 1,
                threshold: 0.0,
                below_is_positive: true,
                alpha: 0.4,
            },
        ];
        let b = Booster {
            features: 2,
            stumps,
        };
        let (rest, step) = b.split_by_features(&[0]);
        let (none, both) = b.split_by_features(&[0, 1]);
        for x0 in [-5.0, 0.99, 1.0, 2.0, 3.0, 7.0, f64::NAN] {
            for x1 in [-1.0, 1.0] {
                let full = b.score(&[x0, x1]);
                let split = rest.score(&[x0, x1]) + step[0].eval(x0);
                let all = none.score(&[x0, x1]) + both[0].eval(x0) + both[1].eval(x1);
                assert!((full - all).abs() < 1e-12);
                assert!((full - split).abs() < 1e-12, "{x0} {x1}: {full} vs {split}");
            }
        }
    }

    #[test]
    fn refuses_one_class_and_bad_samples() {
        let mut data = TrainingSet::new(1);
        data.push(&[1.0], true).unwrap();
        data.push(&[2.0], true).unwrap();
        let boost = BoosterParams::default().check().unwrap();
        assert!(boost.train(&data).is_err());
        assert!(data.push(&[1.0, 2.0], false).is_err());
        assert!(data.push(&[f64::INFINITY], false).is_err());
        assert!(data.push(&[f64::NAN], false).is_ok());
        assert!(BoosterParams::default().stumps(0).check().is_err());
    }

    #[test]
    fn separates_interval_classes_and_handles_missing_values() {
        // Positive inside [2, 5]; a missing value is negative.
        let mut data = TrainingSet::new(1);
        for k in 0..100 {
            let x = k as f64 / 10.0;
            data.push(&[x], (2.0..=5.0).contains(&x)).unwrap();
        }
        for _ in 0..20 {
            data.push(&[f64::NAN], false).unwrap();
        }
        let b = BoosterParams::default()
            .check()
            .unwrap()
            .train(&data)
            .unwrap();
        assert!(b.score(&[3.5]) > 0.0);
        assert!(b.score(&[0.5]) < 0.0);
        assert!(b.score(&[8.0]) < 0.0);
        assert!(b.score(&[f64::NAN]) < 0.0);
    }
}
