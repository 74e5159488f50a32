//! Summary statistics of a set of pairs with ground truth (points per scan, dynamic
//! points, moving objects, outlier share), as reported in the README's dataset table.

use crate::pair::{Association, ScanPair};
use std::collections::BTreeSet;
use std::fmt::Write;

/// Mean, minimum and maximum of one quantity over pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Mean.
    pub mean: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl Summary {
    /// Summary of `values` (all zero when empty).
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Summary::default();
        }
        Summary {
            mean: values.iter().sum::<f64>() / values.len() as f64,
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// Statistics of a data set of pairs. Quantities the pairs' ground truth does not
/// provide count as zero.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DatasetStats {
    /// Number of pairs.
    pub pairs: usize,
    /// Valid returns per scan (reference and current scans together).
    pub points_per_scan: Summary,
    /// Current-scan points on moving objects (label ≠ 0) per pair.
    pub dynamic_points_per_pair: Summary,
    /// Moving objects seen in the current scan per pair.
    pub moving_objects_per_pair: Summary,
    /// Ego travel between the scans in metres.
    pub ego_travel: Summary,
    /// Share of valid current-scan points whose association is an outlier.
    pub outlier_share: f64,
    /// Outlier share among background points only.
    pub background_outlier_share: f64,
    /// Outlier share among moving-object points only.
    pub dynamic_outlier_share: f64,
}

impl DatasetStats {
    /// Computes the statistics of `pairs`.
    pub fn from_pairs(pairs: &[ScanPair]) -> Self {
        let mut points = Vec::new();
        let mut dynamic = Vec::new();
        let mut objects = Vec::new();
        let mut travel = Vec::new();
        // (outliers, points) for background and moving objects.
        let mut background = (0usize, 0usize);
        let mut moving = (0usize, 0usize);
        for pair in pairs {
            points.push(pair.reference.valid_count() as f64);
            points.push(pair.current.valid_count() as f64);
            let Some(truth) = &pair.truth else {
                dynamic.push(0.0);
                objects.push(0.0);
                continue;
            };
            if let Some(ego) = &truth.ego_motion {
                travel.push(ego.translation().norm());
            }
            let labels = truth.labels.as_deref().unwrap_or(&[]);
            let dynamic_labels: BTreeSet<u32> = labels
                .iter()
                .flatten()
                .copied()
                .filter(|&l| l != 0)
                .collect();
            dynamic.push(labels.iter().flatten().filter(|&&l| l != 0).count() as f64);
            objects.push(dynamic_labels.len() as f64);
            if let Some(associations) = &truth.associations {
                for (label, association) in labels.iter().zip(associations) {
                    if let (Some(label), Some(association)) = (label, association) {
                        let counter = if *label == 0 {
                            &mut background
                        } else {
                            &mut moving
                        };
                        counter.1 += 1;
                        if *association == Association::Outlier {
                            counter.0 += 1;
                        }
                    }
                }
            }
        }
        let share = |(o, n): (usize, usize)| if n == 0 { 0.0 } else { o as f64 / n as f64 };
        DatasetStats {
            pairs: pairs.len(),
            points_per_scan: Summary::of(&points),
            dynamic_points_per_pair: Summary::of(&dynamic),
            moving_objects_per_pair: Summary::of(&objects),
            ego_travel: Summary::of(&travel),
            outlier_share: share((background.0 + moving.0, background.1 + moving.1)),
            background_outlier_share: share(background),
            dynamic_outlier_share: share(moving),
        }
    }

    /// The statistics as a Markdown table.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "| statistic ({} pairs) | mean | min | max |", self.pairs);
        let _ = writeln!(s, "|---|---|---|---|");
        // The cells after the name: mean, min and max, or a share in the mean column.
        let counts = |v: Summary| format!("{:.1} | {:.0} | {:.0}", v.mean, v.min, v.max);
        let metres = |v: Summary| format!("{:.2} | {:.2} | {:.2}", v.mean, v.min, v.max);
        let share = |v: f64| format!("{:.1} % | |", 100.0 * v);
        let rows = [
            ("valid points per scan", counts(self.points_per_scan)),
            (
                "dynamic points per pair (current scan)",
                counts(self.dynamic_points_per_pair),
            ),
            (
                "moving objects per pair (current scan)",
                counts(self.moving_objects_per_pair),
            ),
            ("ego travel between scans (m)", metres(self.ego_travel)),
            (
                "outlier share, all current points",
                share(self.outlier_share),
            ),
            (
                "outlier share, background points",
                share(self.background_outlier_share),
            ),
            (
                "outlier share, moving-object points",
                share(self.dynamic_outlier_share),
            ),
        ];
        for (name, cells) in rows {
            let _ = writeln!(s, "| {name} | {cells} |");
        }
        s
    }
}
