//! Steps 3 and 4: inference rounds (section IV-D) and merging by the effective number
//! of clusters (section IV-E, eq. 8).
//!
//! A round runs hybrid inference on the CRF ([`crate::model`]): message passing
//! alternates with closed-form motion solves (eq. 3) until the motions and labels are
//! stable. Messages are max-product (log space, no exponentials in the inner loop:
//! about ten times faster than sum-product here); labels are the MAP assignment and
//! the beliefs used for merging are the max-marginals normalised to sum to one. On
//! the chain the round runs on the core's exact chain solver
//! ([`pgm_core::hybrid::chain`]); with k-nearest-neighbour edges (or
//! [`ClusteringParams::chain_solver`] off) on the generic loopy engine
//! ([`HybridInference`] with the two-pass sequential schedule, exact per sweep on a
//! chain, or variable visits for [`UpdateSchedule::EveryVisit`]).
//!
//! After a round, the effective number of clusters of a point is
//! `N_eff = 1 / Σ_c p_c²` of its normalised max-marginal `p`; a cluster whose points
//! have a mean `N_eff` above [`ClusteringParams::merge_threshold`] (1.7) is removed
//! and its points go to their second-best cluster, then the next round runs. One
//! cluster (the worst) is removed per round; a round that emptied clusters only drops
//! those (an empty twin of a kept cluster would make the kept one look redundant).

use crate::input::ClusteringInput;
use crate::model::{build_edges, ClusteringModel, Edge, MAX_CLUSTERS};
use crate::params::{ClusteringParams, UpdateSchedule};
use crate::Result;
use pgm_core::hybrid::chain::{ChainUpdate, HybridChainParams};
use pgm_core::hybrid::{HybridInference, UpdatePolicy};
use pgm_core::{BpParams, Mode, ParamGuard, Sequential, VariableId};
use pgm_scan::Pose2;

/// The end state of the inference rounds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Inferred {
    /// The label of every point (`0..clusters`, or `clusters` for the outlier state).
    pub labels: Vec<usize>,
    /// The motion of every cluster.
    pub motions: Vec<Pose2>,
    /// Number of clusters left.
    pub clusters: usize,
    /// Sweeps over all rounds.
    pub iterations: usize,
    /// Rounds run.
    pub rounds: usize,
    /// Whether the last round converged.
    pub converged: bool,
}

/// The outcome of one round.
struct Round {
    labels: Vec<usize>,
    /// Normalised max-marginals, `states` per point.
    beliefs: Vec<f64>,
    states: usize,
    motions: Vec<Pose2>,
    sweeps: usize,
    converged: bool,
}

/// Runs rounds from the initial `labels` over `k` clusters, merging between them.
pub(crate) fn infer(
    params: &ClusteringParams,
    input: &ClusteringInput,
    mut labels: Vec<usize>,
    mut k: usize,
) -> Result<Inferred> {
    let edges = build_edges(&input.points, params.knn);
    let outlier = params.outlier_distance.is_some();
    let mut motions = vec![input.odometry.unwrap_or_default(); k];
    let mut iterations = 0;
    let mut rounds = 0;
    loop {
        rounds += 1;
        let round = run_round(params, input, &edges, motions, &labels)?;
        iterations += round.sweeps;
        labels = round.labels;
        motions = round.motions;
        let drop = clusters_to_drop(
            &labels,
            &round.beliefs,
            round.states,
            k,
            params.merge_threshold,
        );
        if !drop.iter().any(|d| *d) || rounds > MAX_CLUSTERS + 1 {
            return Ok(Inferred {
                labels,
                motions,
                clusters: k,
                iterations,
                rounds,
                converged: round.converged,
            });
        }
        k = remove_clusters(
            &mut labels,
            &mut motions,
            &round.beliefs,
            round.states,
            &drop,
            outlier,
        );
    }
}

/// One round of hybrid inference from `labels` and `motions`.
fn run_round(
    params: &ClusteringParams,
    input: &ClusteringInput,
    edges: &[Edge],
    motions: Vec<Pose2>,
    labels: &[usize],
) -> Result<Round> {
    let mut model = ClusteringModel::new(
        &input.points,
        &input.partners,
        &input.variances,
        edges,
        motions,
        &params.weights,
        params.outlier_distance,
    )?;
    let states = model.states();
    let n = input.points.len();
    if params.chain_solver && params.knn == 0 {
        let solver = HybridChainParams::default()
            .max_sweeps(params.max_sweeps)
            .tolerance(params.motion_tolerance)
            .update(match params.update {
                UpdateSchedule::EverySweep => ChainUpdate::EverySweep,
                UpdateSchedule::EveryVisit => ChainUpdate::EveryVisit,
            })
            .check()?;
        let mut r = solver.run(&mut model, &[labels.to_vec()])?;
        return Ok(Round {
            labels: r.labels.swap_remove(0),
            beliefs: r.max_marginals.swap_remove(0),
            states,
            motions: model.motions().to_vec(),
            sweeps: r.sweeps,
            converged: r.converged,
        });
    }
    let mut graph = model.build_graph()?;
    let bp = BpParams::new(Mode::MaxProduct)
        .max_iterations(params.max_sweeps)
        .tolerance(1e-6)
        .check()?;
    let policy = match params.update {
        UpdateSchedule::EverySweep => UpdatePolicy::EverySweep,
        UpdateSchedule::EveryVisit => UpdatePolicy::EveryVisit,
    };
    let hybrid = HybridInference::new(bp, policy).continuous_tolerance(params.motion_tolerance);
    let result = match params.update {
        UpdateSchedule::EverySweep => hybrid.run(
            &mut graph,
            &mut model,
            &mut Sequential::default(),
            Some(labels),
        )?,
        UpdateSchedule::EveryVisit => {
            let order = (0..n).map(VariableId).collect();
            hybrid.run(
                &mut graph,
                &mut model,
                &mut Sequential::variables(order),
                Some(labels),
            )?
        }
    };
    Ok(Round {
        labels: result.discrete.assignment,
        beliefs: result.discrete.beliefs.concat(),
        states,
        motions: model.motions().to_vec(),
        sweeps: result.discrete.iterations,
        converged: result.messages_converged && result.continuous_converged,
    })
}

/// Eq. (8): which of the `k` clusters to drop after a round. Empty clusters are
/// dropped; when none emptied and at least two remain, the cluster with the highest
/// mean effective number of clusters `1 / Σ_c p_c²` over its points, if above
/// `threshold`.
fn clusters_to_drop(
    labels: &[usize],
    beliefs: &[f64],
    states: usize,
    k: usize,
    threshold: f64,
) -> Vec<bool> {
    let mut count = vec![0usize; k];
    let mut neff = vec![0.0f64; k];
    for (i, &l) in labels.iter().enumerate() {
        if l < k {
            let b = &beliefs[i * states..(i + 1) * states];
            let sq: f64 = b.iter().map(|x| x * x).sum();
            count[l] += 1;
            neff[l] += if sq > 0.0 { 1.0 / sq } else { 1.0 };
        }
    }
    let mut drop: Vec<bool> = count.iter().map(|&c| c == 0).collect();
    let nonempty = count.iter().filter(|&&c| c > 0).count();
    // A round that emptied clusters only drops them: an empty cluster whose motion
    // equals a kept one's makes that one look redundant (high N_eff), and merging it
    // too would send its points to a wrong cluster.
    if nonempty >= 2 && nonempty == k {
        let worst = (0..k)
            .filter(|&l| count[l] > 0)
            .map(|l| (neff[l] / count[l] as f64, l))
            .filter(|(m, _)| *m > threshold)
            .max_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((_, l)) = worst {
            drop[l] = true;
        }
    }
    drop
}

/// Removes the dropped clusters: points of a removed cluster go to their best
/// remaining state (the second best overall); the rest are renumbered. Returns the
/// number of clusters left.
fn remove_clusters(
    labels: &mut [usize],
    motions: &mut Vec<Pose2>,
    beliefs: &[f64],
    states: usize,
    drop: &[bool],
    outlier: bool,
) -> usize {
    let k = drop.len();
    let mut map = vec![usize::MAX; k + usize::from(outlier)];
    let mut next = 0;
    for l in 0..k {
        if !drop[l] {
            map[l] = next;
            next += 1;
        }
    }
    if outlier {
        map[k] = next;
    }
    for (i, l) in labels.iter_mut().enumerate() {
        if map[*l] == usize::MAX {
            let b = &beliefs[i * states..(i + 1) * states];
            *l = (0..b.len())
                .filter(|&s| map[s] != usize::MAX)
                .max_by(|&x, &y| b[x].total_cmp(&b[y]))
                .unwrap_or(0);
        }
        *l = map[*l];
    }
    let kept: Vec<Pose2> = (0..k).filter(|&l| !drop[l]).map(|l| motions[l]).collect();
    *motions = kept;
    next
}
