//! The CRF of one scan pair: its features (eqs. 2, 4-6, written once for inference
//! and learning) and its rigid-motion continuous nodes.
//!
//! Variables: the valid points of the current scan in beam order, each with `K`
//! cluster states (plus the optional outlier state, last). Cliques, each `w · f`:
//!
//! - one local clique per point: `f = [d, d / σ_i²]` with `d = ‖T_l + R_l s_i − g_i‖²`
//!   for each cluster `l` (eq. 2 and its normalised form, `σ_i²` the point's
//!   association variance; zero for points without a partner); the outlier state gets
//!   the same with `d = d_out²` for points with a partner and zero otherwise;
//! - one pairwise clique per edge (the chain of consecutive points, plus optional
//!   k-nearest-neighbour edges): the neighbour indicators of eq. (4), the same divided
//!   by the points' distance (eq. 5), and the stiffness of eq. (6) (zero when either
//!   state is the outlier state), each in a "same cluster" and a "different clusters"
//!   weight.
//!
//! [`ClusteringModel`] writes these features through a
//! [`FeatureSink`], the one implementation of
//! the equations: the core's chain solver weighs them into tables
//! ([`HybridChainModel`]), the generic loopy engine refreshes its factors from them
//! ([`ContinuousModel`], for graphs with k-nearest-neighbour edges) and learning
//! records them ([`crate::learning`]). The `K` motions are a
//! [`ClusterMotions`]: O(1) sufficient statistics per cluster and closed-form solves
//! (eq. 3, each pair weighted by `1/σ_i²`).

use crate::weights::{index, ClusteringWeights};
use crate::Result;
use nalgebra::Point2;
use pgm_core::hybrid::chain::{FeatureSink, HybridChainModel, WeightedTable};
use pgm_core::hybrid::{ContinuousModel, DiscreteSummary, VariableState};
use pgm_core::param::InvalidParameter;
use pgm_core::{FactorGraph, FactorId, Potentials, TableFactor, VariableId};
use pgm_features::clustering_features::inverse_neighbour_distance;
use pgm_features::motion_nodes::state_label;
use pgm_features::ClusterMotions;
use pgm_scan::Pose2;

/// Largest number of cluster states the model supports.
pub const MAX_CLUSTERS: usize = 32;

/// One edge of the CRF: two point indices and `1/Δ` of eq. (5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// First point.
    pub i: usize,
    /// Second point.
    pub j: usize,
    /// `1 / max(‖s_i − s_j‖, 1 cm)`.
    pub inverse_distance: f64,
}

/// The edges of the CRF over `points`: the chain of consecutive points (edge `e`
/// joins `e` and `e + 1`), then, when `knn > 0`, each point's `knn` nearest
/// neighbours (Euclidean, in the current scan) that are not already joined.
pub fn build_edges(points: &[Point2<f64>], knn: usize) -> Vec<Edge> {
    let n = points.len();
    let mut pairs: Vec<(usize, usize)> = (1..n).map(|i| (i - 1, i)).collect();
    if knn > 0 && n > 2 {
        let mut extra = Vec::new();
        let mut candidates: Vec<(f64, usize)> = Vec::with_capacity(n);
        for i in 0..n {
            candidates.clear();
            candidates.extend(
                (0..n)
                    .filter(|&j| j != i)
                    .map(|j| ((points[i] - points[j]).norm_squared(), j)),
            );
            let take = knn.min(candidates.len());
            candidates.select_nth_unstable_by(take - 1, |a, b| a.0.total_cmp(&b.0));
            for &(_, j) in &candidates[..take] {
                let (a, b) = if i < j { (i, j) } else { (j, i) };
                if b != a + 1 {
                    extra.push((a, b));
                }
            }
        }
        extra.sort_unstable();
        extra.dedup();
        pairs.extend(extra);
    }
    pairs
        .into_iter()
        .map(|(i, j)| Edge {
            i,
            j,
            inverse_distance: inverse_neighbour_distance(&points[i], &points[j]),
        })
        .collect()
}

/// What a factor of the generic graph is.
#[derive(Clone, Copy, Debug)]
enum Role {
    Local(usize),
    Pair(usize),
}

/// The factor graph bookkeeping of the generic path ([`ClusteringModel::build_graph`]).
#[derive(Clone, Debug, Default)]
struct GraphRoles {
    roles: Vec<Role>,
    dependent: Vec<Vec<FactorId>>,
}

/// The CRF of one pair with its `K` rigid motions (see the module docs).
#[derive(Clone, Debug)]
pub struct ClusteringModel {
    points: Vec<Point2<f64>>,
    partners: Vec<Option<Point2<f64>>>,
    variances: Vec<f64>,
    edges: Vec<Edge>,
    clusters: usize,
    outlier_distance: Option<f64>,
    weights: Vec<f64>,
    motions: ClusterMotions,
    /// Bumped whenever a motion changes: the moved points of `moved` are valid for the
    /// version recorded next to them.
    version: u64,
    /// Each point moved by each cluster's motion (`clusters` per point), computed when
    /// a table first needs them after the motions changed: once per point per sweep
    /// instead of once per table.
    moved: MovedPoints,
    graph: GraphRoles,
}

/// The lazily updated cache of moved points (see [`ClusteringModel`]).
#[derive(Clone, Debug, Default)]
struct MovedPoints {
    points: std::cell::RefCell<Vec<Point2<f64>>>,
    versions: std::cell::RefCell<Vec<u64>>,
}

impl ClusteringModel {
    /// The model over `points` (current scan, beam order) with their `partners` in
    /// the reference scan and association `variances` (m², positive), the `edges`
    /// ([`build_edges`]; the first `n − 1` must be the chain), starting `motions` (one
    /// per cluster, `K = motions.len()` in `1..=`[`MAX_CLUSTERS`]), `weights`, and the
    /// optional outlier state.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] when the arrays disagree in length, an edge names a
    /// missing point, the chain edges are missing, or `K` is out of range.
    pub fn new(
        points: &[Point2<f64>],
        partners: &[Option<Point2<f64>>],
        variances: &[f64],
        edges: &[Edge],
        motions: Vec<Pose2>,
        weights: &ClusteringWeights,
        outlier_distance: Option<f64>,
    ) -> Result<Self> {
        let k = motions.len();
        let n = points.len();
        if k == 0 || k > MAX_CLUSTERS {
            return Err(InvalidParameter::new("clusters", k, "between 1 and 32 clusters").into());
        }
        if partners.len() != n || variances.len() != n {
            return Err(InvalidParameter::new(
                "partners",
                format!(
                    "{} partners and {} variances for {n} points",
                    partners.len(),
                    variances.len()
                ),
                "one (optional) partner and one variance per point",
            )
            .into());
        }
        if edges.iter().any(|e| e.i >= n || e.j >= n)
            || (0..n.saturating_sub(1))
                .any(|e| edges.get(e).is_none_or(|x| (x.i, x.j) != (e, e + 1)))
        {
            return Err(InvalidParameter::new(
                "edges",
                format!("{} edges for {n} points", edges.len()),
                "the chain edges (e, e + 1) first, then edges between existing points",
            )
            .into());
        }
        Ok(Self {
            points: points.to_vec(),
            partners: partners.to_vec(),
            variances: variances.to_vec(),
            edges: edges.to_vec(),
            clusters: k,
            outlier_distance,
            weights: weights.to_vec(),
            motions: ClusterMotions::new(motions),
            version: 1,
            moved: MovedPoints {
                points: std::cell::RefCell::new(vec![Point2::origin(); n * k]),
                versions: std::cell::RefCell::new(vec![0; n]),
            },
            graph: GraphRoles::default(),
        })
    }

    /// The current motions, one per cluster.
    pub fn motions(&self) -> &[Pose2] {
        self.motions.motions()
    }

    /// Number of cluster states (without the outlier state).
    pub fn clusters(&self) -> usize {
        self.clusters
    }

    /// Number of states per variable.
    pub fn states(&self) -> usize {
        self.clusters + usize::from(self.outlier_distance.is_some())
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The edges.
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// Writes the local features of point `i` (entry = state): eq. (2) and its
    /// normalised form for every cluster under its current motion, and for the outlier
    /// state the same at distance `d_out`.
    pub fn write_local_features<S: FeatureSink>(&self, i: usize, sink: &mut S) {
        let Some(g) = &self.partners[i] else {
            return;
        };
        let inverse_variance = 1.0 / self.variances[i];
        self.update_moved(i);
        let k = self.clusters;
        let moved = self.moved.points.borrow();
        // Eq. (2): the point moved by each cluster's motion against its partner.
        for (l, m) in moved[i * k..(i + 1) * k].iter().enumerate() {
            let d = (m - g).norm_squared();
            sink.add(l, index::DISTANCE_SQUARED, d);
            sink.add(l, index::DISTANCE_NORMALISED, d * inverse_variance);
        }
        if let Some(d_out) = self.outlier_distance {
            let d = d_out * d_out;
            sink.add(self.clusters, index::DISTANCE_SQUARED, d);
            sink.add(
                self.clusters,
                index::DISTANCE_NORMALISED,
                d * inverse_variance,
            );
        }
    }

    /// Writes the features of edge `e` (entry `a · states + b`, `a` the state of the
    /// edge's first point): eqs. (4), (5) and (6).
    pub fn write_edge_features<S: FeatureSink>(&self, e: usize, sink: &mut S) {
        let edge = self.edges[e];
        let states = self.states();
        let k = self.clusters;
        let (si, sj) = (&self.points[edge.i], &self.points[edge.j]);
        self.update_moved(edge.i);
        self.update_moved(edge.j);
        let moved = self.moved.points.borrow();
        // Eq. (6) from the moved points.
        let moved_i = &moved[edge.i * k..(edge.i + 1) * k];
        let moved_j = &moved[edge.j * k..(edge.j + 1) * k];
        let before = si - sj;
        // Eqs. (4) and (5): same / different cluster, and the same over the distance.
        sink.add_agreement(
            states,
            index::NEIGHBOUR_SAME,
            index::NEIGHBOUR_DIFFERENT,
            1.0,
        );
        sink.add_agreement(
            states,
            index::WEIGHTED_NEIGHBOUR_SAME,
            index::WEIGHTED_NEIGHBOUR_DIFFERENT,
            edge.inverse_distance,
        );
        // Eq. (6) between cluster states (the outlier state has no motion).
        sink.add_agreement_with(
            (k, k, states),
            index::STIFFNESS_SAME,
            index::STIFFNESS_DIFFERENT,
            |a, b| (before - (moved_i[a] - moved_j[b])).norm_squared(),
        );
    }

    /// Brings point `i`'s moved copies up to date with the current motions.
    fn update_moved(&self, i: usize) {
        let mut versions = self.moved.versions.borrow_mut();
        if versions[i] == self.version {
            return;
        }
        versions[i] = self.version;
        let k = self.clusters;
        let mut moved = self.moved.points.borrow_mut();
        for (out, m) in moved[i * k..(i + 1) * k]
            .iter_mut()
            .zip(self.motions.motions())
        {
            *out = m.transform_point(&self.points[i]);
        }
    }

    /// Moves point `i`'s pair between the statistics of its `old` and `new` state.
    pub fn relabel(&mut self, i: usize, old: Option<usize>, new: Option<usize>) {
        if let Some(g) = self.partners[i] {
            let w = 1.0 / self.variances[i];
            let (s, k) = (self.points[i], self.clusters);
            self.motions
                .relabel(&s, &g, w, old.filter(|&l| l < k), new.filter(|&l| l < k));
        }
    }

    /// Re-solves every cluster's motion (eq. 3); returns the largest change.
    pub fn solve_motions(&mut self) -> f64 {
        let change = self.motions.solve();
        // A motion that changed at all changes a translation or an angle (> 0).
        if change != 0.0 {
            self.version += 1;
        }
        change
    }

    /// The factor graph of the generic path: one table factor per point and per edge,
    /// all zero until refreshed ([`ContinuousModel`]).
    pub fn build_graph(&mut self) -> Result<FactorGraph> {
        let states = self.states();
        let n = self.points.len();
        let mut graph = FactorGraph::with_variables(&vec![states; n])?;
        let mut roles = Vec::with_capacity(n + self.edges.len());
        let mut dependent: Vec<Vec<FactorId>> = vec![Vec::with_capacity(3); n];
        for (i, deps) in dependent.iter_mut().enumerate() {
            let a = graph.add_factor(TableFactor::new(
                vec![VariableId(i)],
                vec![states],
                vec![0.0; states],
            )?)?;
            roles.push(Role::Local(i));
            deps.push(a);
        }
        for (e, edge) in self.edges.iter().enumerate() {
            let a = graph.add_factor(TableFactor::new(
                vec![VariableId(edge.i), VariableId(edge.j)],
                vec![states, states],
                vec![0.0; states * states],
            )?)?;
            roles.push(Role::Pair(e));
            dependent[edge.i].push(a);
            dependent[edge.j].push(a);
        }
        self.graph = GraphRoles { roles, dependent };
        Ok(graph)
    }
}

impl HybridChainModel for ClusteringModel {
    fn weights(&self) -> &[f64] {
        &self.weights
    }

    fn num_chains(&self) -> usize {
        1
    }

    fn chain_len(&self, _chain: usize) -> usize {
        self.points.len()
    }

    fn num_states(&self, _chain: usize, _i: usize) -> usize {
        self.states()
    }

    fn write_local<S: FeatureSink>(&self, _chain: usize, i: usize, sink: &mut S) {
        self.write_local_features(i, sink);
    }

    fn write_pair<S: FeatureSink>(&self, _chain: usize, i: usize, sink: &mut S) {
        // The first n − 1 edges are the chain (checked in `new`).
        self.write_edge_features(i, sink);
    }

    fn set_label(&mut self, _chain: usize, i: usize, old: Option<usize>, new: usize) {
        self.relabel(i, old, Some(new));
    }

    fn solve(&mut self) -> f64 {
        self.solve_motions()
    }
}

impl ContinuousModel for ClusteringModel {
    fn summary(&self) -> DiscreteSummary {
        DiscreteSummary::MapLabels
    }

    fn update_variable(
        &mut self,
        v: VariableId,
        old: Option<VariableState<'_>>,
        new: VariableState<'_>,
    ) {
        if v.0 >= self.points.len() {
            return;
        }
        self.relabel(v.0, state_label(old), state_label(Some(new)));
    }

    fn solve(&mut self) -> f64 {
        self.solve_motions()
    }

    fn dependent_factors(&self, v: VariableId) -> &[FactorId] {
        self.graph.dependent.get(v.0).map_or(&[], |d| d.as_slice())
    }

    fn refresh_factor(&self, a: FactorId, potentials: &mut Potentials<'_>) -> pgm_core::Result<()> {
        let Some(role) = self.graph.roles.get(a.0).copied() else {
            return Ok(());
        };
        let Some(table) = potentials
            .factor_mut(a)
            .as_any_mut()
            .and_then(|f| f.downcast_mut::<TableFactor>())
        else {
            return Err(pgm_core::Error::InvalidParameter {
                name: "clustering factor",
                value: a.0.to_string(),
                expected: "a TableFactor built by ClusteringModel::build_graph",
            });
        };
        let table = table.table_mut();
        table.fill(0.0);
        let mut sink = WeightedTable::new(&self.weights, table);
        match role {
            Role::Local(i) => self.write_local_features(i, &mut sink),
            Role::Pair(e) => self.write_edge_features(e, &mut sink),
        }
        Ok(())
    }

    fn all_dependent_factors(&self, _graph: &FactorGraph) -> Vec<FactorId> {
        (0..self.graph.roles.len()).map(FactorId).collect()
    }
}
