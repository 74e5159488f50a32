//! The parameters of CRF-Clustering, checked once ([`ParamGuard`]).
//!
//! [`ClusteringParams`] holds what the paper's method needs (section IV and V-A of
//! Tipaldi and Ramos): the initial segmentation gap, the number of clusters, the
//! merge threshold of eq. (8), the odometry uncertainty for the background choice,
//! the inference limits and the learned weights. [`DetectionParams`] holds the
//! thresholds this implementation adds to decide which non-background clusters are
//! moving objects (the paper reports every non-background cluster): they are not in
//! the paper, each is documented with what it rejects, and all can be switched off.

use crate::model::MAX_CLUSTERS;
use crate::weights::ClusteringWeights;
use crate::{Clusterer, Error, Result};
use pgm_core::param::{InvalidParameter, ParamGuard};
use serde::Serialize;

/// When the cluster motions are re-solved during message passing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum UpdateSchedule {
    /// After every forward-backward sweep (default: exact MAP of the chain for the
    /// current motions, then the motions for the new labels).
    #[default]
    EverySweep,
    /// After every variable visit (Algorithm 1 of the joint-model paper).
    EveryVisit,
}

/// Thresholds that decide which clusters are moving objects, beyond the paper (see
/// steps 5 and 6 of [`crate::clusterer`]). Each test can be switched off.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DetectionParams {
    /// Fewest associated points of a moving object; smaller pieces join the
    /// background (3).
    pub min_object_points: usize,
    /// Smallest mean displacement (m) of an object's points relative to the background
    /// motion for it to count as moving; also the smallest mean improvement of its
    /// points' partner distances under its own motion over the background motion
    /// (rejects clusters whose own motion merely fits association noise) (0.15; 0: off).
    pub min_object_displacement: f64,
    /// Smallest likelihood-ratio statistic of a moving object: the sum over its
    /// associated points of `(‖M_bg s_i − g_i‖² − ‖M_l s_i − g_i‖²) / σ_i²` (how
    /// much better its own motion `M_l` explains its partners than the background
    /// motion `M_bg` does, in units of the association variance `σ_i²`), about χ² with
    /// 3 degrees of freedom for a cluster that moves with the background. The
    /// threshold is multiplied by the pair's association noise scale (the median of
    /// `‖M_bg s_i − g_i‖² / σ_i²` over the background's points over its expected value
    /// 2 ln 2, at least 1) (0: off, the default).
    pub min_object_chi2: f64,
    /// Smallest fraction of a moving object's points that show it moved by free space
    /// (0.2; 0: off): moved by the ego-motion into the reference frame they lie more
    /// than [`DetectionParams::free_space_margin`] in front of the reference returns at
    /// their bearing (the reference saw through where they are now), or their
    /// partners, moved back into the current frame, lie that far in front of the
    /// current returns (the object left). A static surface merely seen differently
    /// (new view, wrong associations) fails both. Needs the scans
    /// ([`crate::ClusteringInput::scans`]).
    pub min_free_fraction: f64,
    /// Margin (m) of the free-space test (0.3).
    pub free_space_margin: f64,
    /// Largest distance (m) between consecutive points (in beam order) of one moving
    /// object: a moving cluster with a larger jump is split into several objects (4).
    pub object_gap: f64,
    /// Whether points without a partner are checked against the associated points of
    /// their gap segment after inference (true; step 6 of [`crate::clusterer`]).
    pub reassign_unassociated: bool,
}

impl Default for DetectionParams {
    fn default() -> Self {
        Self {
            min_object_points: 3,
            min_object_displacement: 0.15,
            min_object_chi2: 0.0,
            min_free_fraction: 0.2,
            free_space_margin: 0.3,
            object_gap: 4.0,
            reassign_unassociated: true,
        }
    }
}

impl DetectionParams {
    fn check_ref(&self) -> Result<()> {
        InvalidParameter::non_negative(
            "min_object_displacement",
            self.min_object_displacement,
            "a number of metres >= 0",
        )?;
        InvalidParameter::non_negative("min_object_chi2", self.min_object_chi2, "a number >= 0")?;
        InvalidParameter::fraction("min_free_fraction", self.min_free_fraction)?;
        InvalidParameter::non_negative(
            "free_space_margin",
            self.free_space_margin,
            "a number of metres >= 0",
        )?;
        InvalidParameter::positive("object_gap", self.object_gap, "a positive number of metres")?;
        Ok(())
    }
}

/// Parameters of CRF-Clustering, unchecked; [`ParamGuard::check`] turns them into a
/// [`Clusterer`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClusteringParams {
    /// Gap (m) between consecutive points that starts a new initial segment (section
    /// V-A, "a distance heuristic") (0.5).
    pub segment_gap: f64,
    /// Largest number of clusters (initial segments are merged down to it; 8, at most 32).
    pub max_clusters: usize,
    /// Extra edges to each point's `knn` nearest neighbours besides the chain (0; a
    /// graph with such edges runs on the generic loopy engine).
    pub knn: usize,
    /// Adds an outlier state whose local log-potential equals the distance feature of
    /// a partner this far away (m); `None` (default): no outlier state.
    pub outlier_distance: Option<f64>,
    /// Mean effective number of clusters above which a cluster is merged away (eq. 8;
    /// 1.7 as the paper).
    pub merge_threshold: f64,
    /// Largest number of sweeps per inference round (30).
    pub max_sweeps: usize,
    /// Motions count as converged when no parameter changes by more than this (1e-6).
    pub motion_tolerance: f64,
    /// When motions are re-solved.
    pub update: UpdateSchedule,
    /// Standard deviations (x m, y m, θ rad) of the odometry prior for the Mahalanobis
    /// distance that picks the background cluster ([0.3, 0.3, 0.1]).
    pub odometry_sigma: [f64; 3],
    /// Whether the chain CRF runs on the exact chain solver of the core
    /// ([`pgm_core::hybrid::chain`], default) or on the generic loopy engine
    /// ([`pgm_core::hybrid::HybridInference`] with the two-pass sequential schedule,
    /// kept for checking; graphs with `knn > 0` always use it).
    pub chain_solver: bool,
    /// The reported motion of every moving object is solved once more from its
    /// cluster's associations with a prior on its rotation, `θ ~ N(θ_background, σ²)`
    /// (the object's own turn between two scans is small;
    /// [`pgm_scan::RigidAlignment::solve_with_rotation_prior`], closed form), as the
    /// joint model's (`pgm_joint::JointParams::object_rotation_sigma`). `Some(σ)` in
    /// rad (default 0.05: a car turning at 0.5 rad/s seen 0.1 s apart); `None`
    /// reports eq. 3 alone. Labels, the background and its motion are unchanged.
    pub object_rotation_sigma: Option<f64>,
    /// The learned weights (default: the shipped ones).
    pub weights: ClusteringWeights,
    /// The moving-object thresholds beyond the paper.
    pub detection: DetectionParams,
}

impl Default for ClusteringParams {
    fn default() -> Self {
        Self {
            segment_gap: 0.5,
            max_clusters: 8,
            knn: 0,
            outlier_distance: None,
            merge_threshold: 1.7,
            max_sweeps: 30,
            motion_tolerance: 1e-6,
            update: UpdateSchedule::EverySweep,
            odometry_sigma: [0.3, 0.3, 0.1],
            chain_solver: true,
            object_rotation_sigma: Some(0.05),
            weights: ClusteringWeights::default(),
            detection: DetectionParams::default(),
        }
    }
}

impl ParamGuard for ClusteringParams {
    type Checked = Clusterer;
    type Error = Error;

    fn check_ref(&self) -> Result<()> {
        InvalidParameter::positive(
            "segment_gap",
            self.segment_gap,
            "a positive number of metres",
        )?;
        if !(1..=MAX_CLUSTERS).contains(&self.max_clusters) {
            return Err(InvalidParameter::new("max_clusters", self.max_clusters, "1..=32").into());
        }
        if self.knn > 16 {
            return Err(InvalidParameter::new("knn", self.knn, "0..=16").into());
        }
        if let Some(d) = self.outlier_distance {
            InvalidParameter::positive("outlier_distance", d, "a positive number of metres")?;
        }
        if !(self.merge_threshold.is_finite() && self.merge_threshold >= 1.0) {
            return Err(InvalidParameter::new(
                "merge_threshold",
                self.merge_threshold,
                "a number >= 1",
            )
            .into());
        }
        if self.max_sweeps == 0 {
            return Err(InvalidParameter::new("max_sweeps", self.max_sweeps, "at least 1").into());
        }
        InvalidParameter::non_negative("motion_tolerance", self.motion_tolerance, "a number >= 0")?;
        if let Some(sigma) = self.object_rotation_sigma {
            InvalidParameter::positive(
                "object_rotation_sigma",
                sigma,
                "a standard deviation in rad > 0",
            )?;
        }
        if !self
            .odometry_sigma
            .iter()
            .all(|&s| s.is_finite() && s > 0.0)
        {
            return Err(InvalidParameter::new(
                "odometry_sigma",
                self.odometry_sigma,
                "three positive standard deviations",
            )
            .into());
        }
        self.weights.check_ref()?;
        self.detection.check_ref()
    }

    fn check(self) -> Result<Clusterer> {
        self.check_ref()?;
        Ok(Clusterer::from_checked(self))
    }
}
