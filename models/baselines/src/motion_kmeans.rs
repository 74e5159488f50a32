//! Motion K-Means, the modified K-Means baseline of the CRF-Clustering paper (section
//! V-C, eq. 10): the centroids are rigid motions (solved in closed form by eq. 3 from
//! the point pairs assigned to them), and each associated point pair `(s_i, g_i)`
//! joins the cluster `argmin_j ‖g_i − (T_j + R_j s_i)‖²`.
//!
//! Choices the paper leaves open:
//! - **Initialisation** (deterministic, farthest first): the current scan is cut into
//!   segments at gaps larger than [`MotionKMeansParams::segment_gap`]; the first
//!   centroid is the motion of the segment with the most associated points; each next
//!   one is the motion of the segment (with at least 3 associated points) whose points
//!   fit the nearest existing centroid worst (mean squared residual).
//! - **Points without a partner** carry no motion evidence; they are given the
//!   background cluster.
//! - **Background**: the cluster whose motion is nearest to the odometry prior
//!   (Mahalanobis, the same standard deviations as CRF-Clustering's default:
//!   0.3 m, 0.3 m, 0.1 rad), else the largest. It is labelled 0; the other non-empty
//!   clusters `1, 2, …` in order of first appearance. Unlike CRF-Clustering, K-Means
//!   neither merges clusters nor decides which ones move: all `k` are reported.

use crate::{Error, Result};
use nalgebra::Point2;
use pgm_core::param::InvalidParameter;
use pgm_scan::methods::{ClusterWithAssociations, MotionClustering};
use pgm_scan::scan::segment_by_gap;
use pgm_scan::{
    wrap_angle, Association, ClusterMotion, PointAssociations, Pose2, RigidAlignment, ScanPair,
};

/// Parameters of [`MotionKMeans`], unchecked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionKMeansParams {
    /// Number of clusters `k` (the maximum number of objects, background included).
    pub k: usize,
    /// Largest number of assignment/update iterations.
    pub max_iterations: usize,
    /// Gap (m) that separates the segments used for initialisation.
    pub segment_gap: f64,
}

impl Default for MotionKMeansParams {
    fn default() -> Self {
        Self {
            k: 3,
            max_iterations: 100,
            segment_gap: 0.5,
        }
    }
}

impl MotionKMeansParams {
    /// `ParamGuard::check_ref`: checks every value; the error names the first
    /// invalid one.
    fn validate(&self) -> Result<()> {
        if self.k == 0 || self.k > 64 {
            return Err(
                InvalidParameter::new("k", self.k, "a number of clusters in 1..=64").into(),
            );
        }
        if self.max_iterations == 0 {
            return Err(
                InvalidParameter::new("max_iterations", self.max_iterations, "at least 1").into(),
            );
        }
        InvalidParameter::positive(
            "segment_gap",
            self.segment_gap,
            "a positive number of metres",
        )?;
        Ok(())
    }
}

pgm_core::checked_params! {
    /// Motion K-Means with checked parameters (see the module docs); with an association
    /// source it is a [`MotionClusterer`](pgm_scan::MotionClusterer)
    /// ([`pgm_scan::methods::Associated`]).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct MotionKMeans(MotionKMeansParams) -> Error;
}

impl ClusterWithAssociations for MotionKMeans {
    fn name(&self) -> &str {
        "kmeans"
    }

    fn cluster_with(
        &self,
        pair: &ScanPair,
        associations: &PointAssociations,
    ) -> pgm_scan::Result<MotionClustering> {
        let r = self.run(pair, &associations.associations)?;
        Ok(MotionClustering {
            motions: r
                .motions
                .iter()
                .enumerate()
                .map(|(label, m)| ClusterMotion {
                    label: label as u32,
                    motion: *m,
                    kind: if label == 0 { "background" } else { "cluster" }.into(),
                })
                .collect(),
            ego_motion: r.motions.first().copied(),
            labels: r.labels,
            iterations: r.iterations,
            converged: r.converged,
        })
    }
}

/// The result of [`MotionKMeans::run`].
#[derive(Clone, Debug, PartialEq)]
pub struct MotionKMeansResult {
    /// Per beam of the current scan: 0 background, 1, 2, … the other clusters, `None`
    /// for beams without a return.
    pub labels: Vec<Option<u32>>,
    /// The motion of each output label (index = label).
    pub motions: Vec<Pose2>,
    /// Assignment/update iterations performed.
    pub iterations: usize,
    /// True when the assignment stopped changing.
    pub converged: bool,
}

fn fit(stats: &RigidAlignment) -> Option<Pose2> {
    stats.solve().map(|a| a.motion)
}

impl MotionKMeans {
    /// Runs motion K-Means on `pair` with `associations` (one per current beam).
    /// Errors name the pair.
    pub fn run(
        &self,
        pair: &ScanPair,
        associations: &[Option<Association>],
    ) -> Result<MotionKMeansResult> {
        if associations.len() != pair.current.len() {
            return Err(Error::Features(pgm_scan::Error::AssociationCount {
                pair: pair.name.clone(),
                associations: associations.len(),
                beams: pair.current.len(),
            }));
        }
        Ok(kmeans(pair, associations, &self.params))
    }
}

fn kmeans(
    pair: &ScanPair,
    associations: &[Option<Association>],
    params: &MotionKMeansParams,
) -> MotionKMeansResult {
    let (points, beams) = pair.current.points();
    let n = points.len();
    let partners: Vec<Option<Point2<f64>>> = beams
        .iter()
        .map(|&b| match associations[b] {
            Some(Association::Point(r)) if r < pair.reference.len() && pair.reference.valid[r] => {
                Some(pair.reference.beam_point(r))
            }
            _ => None,
        })
        .collect();
    // Segments for the initialisation.
    let segment = segment_by_gap(&points, params.segment_gap);
    let segments = segment.last().map_or(0, |s| s + 1);
    let mut seg_stats = vec![RigidAlignment::new(); segments];
    for i in 0..n {
        if let Some(g) = &partners[i] {
            seg_stats[segment[i]].add(&points[i], g, 1.0);
        }
    }
    let residual_under = |m: &Pose2, s: usize| {
        let mut sum = 0.0;
        let mut count = 0usize;
        for i in 0..n {
            if segment[i] == s {
                if let Some(g) = &partners[i] {
                    sum += (m.transform_point(&points[i]) - g).norm_squared();
                    count += 1;
                }
            }
        }
        if count == 0 {
            0.0
        } else {
            sum / count as f64
        }
    };
    let mut centroids: Vec<Pose2> = Vec::with_capacity(params.k);
    if let Some(first) = (0..segments)
        .filter(|&s| !seg_stats[s].is_empty())
        .max_by_key(|&s| (seg_stats[s].len(), std::cmp::Reverse(s)))
    {
        centroids.extend(fit(&seg_stats[first]));
    }
    if centroids.is_empty() {
        centroids.push(pair.odometry.unwrap_or_default());
    }
    while centroids.len() < params.k {
        let next = (0..segments)
            .filter(|&s| seg_stats[s].len() >= 3)
            .map(|s| {
                let worst = centroids
                    .iter()
                    .map(|m| residual_under(m, s))
                    .fold(f64::INFINITY, f64::min);
                (worst, s)
            })
            .filter(|(r, _)| *r > 0.0)
            .max_by(|a, b| a.0.total_cmp(&b.0));
        match next.and_then(|(_, s)| fit(&seg_stats[s])) {
            Some(m) => centroids.push(m),
            None => break,
        }
    }
    let k = centroids.len();
    let mut assignment = vec![usize::MAX; n];
    let mut iterations = 0;
    let mut converged = false;
    while iterations < params.max_iterations {
        iterations += 1;
        let mut changed = false;
        let mut stats = vec![RigidAlignment::new(); k];
        for i in 0..n {
            let Some(g) = &partners[i] else { continue };
            let best = (0..k)
                .map(|j| {
                    (
                        (centroids[j].transform_point(&points[i]) - g).norm_squared(),
                        j,
                    )
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map_or(0, |(_, j)| j);
            if assignment[i] != best {
                changed = true;
                assignment[i] = best;
            }
            stats[best].add(&points[i], g, 1.0);
        }
        for (c, s) in centroids.iter_mut().zip(&stats) {
            if let Some(m) = fit(s) {
                *c = m;
            }
        }
        if !changed {
            converged = true;
            break;
        }
    }
    let mut count = vec![0usize; k];
    for &a in &assignment {
        if a < k {
            count[a] += 1;
        }
    }
    let background = match pair.odometry {
        Some(odo) => (0..k).filter(|&j| count[j] > 0).min_by(|&a, &b| {
            mahalanobis(&centroids[a], &odo).total_cmp(&mahalanobis(&centroids[b], &odo))
        }),
        None => (0..k).max_by_key(|&j| (count[j], std::cmp::Reverse(j))),
    }
    .unwrap_or(0);
    let mut output = vec![u32::MAX; k];
    output[background] = 0;
    let mut motions = vec![centroids[background]];
    let mut next = 1u32;
    for &a in &assignment {
        if a < k && output[a] == u32::MAX {
            output[a] = next;
            motions.push(centroids[a]);
            next += 1;
        }
    }
    let mut labels = vec![None; pair.current.len()];
    for (i, &b) in beams.iter().enumerate() {
        labels[b] = Some(if assignment[i] < k {
            output[assignment[i]]
        } else {
            0
        });
    }
    MotionKMeansResult {
        labels,
        motions,
        iterations,
        converged,
    }
}

fn mahalanobis(m: &Pose2, odometry: &Pose2) -> f64 {
    ((m.x() - odometry.x()) / 0.3).powi(2)
        + ((m.y() - odometry.y()) / 0.3).powi(2)
        + (wrap_angle(m.theta() - odometry.theta()) / 0.1).powi(2)
}
