//! The CRF of one scan pair as a factor graph with rigid-motion hybrid nodes.
//!
//! Variables: the valid points of the current scan in beam order, each with `K`
//! cluster states (plus the optional outlier state, last). Factors:
//!
//! - one local [`TableFactor`] per point: `(w_sq + w_norm / σ_i²) · ‖T_l + R_l s_i − g_i‖²`
//!   for each cluster `l` (eq. 2 and its normalised form, `σ_i²` the point's
//!   association variance; zero for points without a partner); the outlier state gets
//!   the same with `d_out²` for points with a partner and `0` for points without
//!   (the factor `w_sq + w_norm / σ_i²` is clamped at 0 from above, so a distance never
//!   attracts);
//! - one pairwise [`TableFactor`] per edge (the chain of consecutive points, plus
//!   optional k-nearest-neighbour edges): `w_ng · f_ng + w_wng · f_wng + w_st · f_st`
//!   (eqs. 4-6; stiffness is zero when either state is the outlier state).
//!
//! [`ClusterMotionNodes`] is the [`ContinuousModel`] of the `K` motions: O(1)
//! sufficient statistics per cluster ([`RigidAlignment`]), closed-form solves (eq. 3,
//! each pair weighted by `1/σ_i²`),
//! and refreshes of every factor that depends on the motions (the local factor of a
//! point and its incident pairwise factors, because of the stiffness feature), in
//! place and without allocating.

use crate::weights::ClusteringWeights;
use crate::{Error, Result};
use nalgebra::Point2;
use pgm_core::hybrid::{ContinuousModel, DiscreteSummary, VariableState};
use pgm_core::{FactorGraph, FactorId, Potentials, TableFactor, VariableId};
use pgm_features::clustering::{distance_feature, inverse_neighbour_distance};
use pgm_features::{Pose2, RigidAlignment};

/// Largest number of cluster states the model supports.
pub const MAX_CLUSTERS: usize = 32;

/// What a factor of the graph is.
#[derive(Clone, Copy, Debug)]
enum Role {
    Local(usize),
    Pair(usize),
}

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

/// The edges of the CRF over `points`: the chain of consecutive points plus, when
/// `knn > 0`, each point's `knn` nearest neighbours (Euclidean, in the current scan)
/// that are not already joined.
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

/// The `K` rigid motions of the clusters as observed-continuous nodes (see the module
/// docs).
#[derive(Clone, Debug)]
pub struct ClusterMotionNodes {
    points: Vec<Point2<f64>>,
    partners: Vec<Option<Point2<f64>>>,
    variances: Vec<f64>,
    edges: Vec<Edge>,
    clusters: usize,
    outlier_distance: Option<f64>,
    weights: ClusteringWeights,
    motions: Vec<Pose2>,
    stats: Vec<RigidAlignment>,
    roles: Vec<Role>,
    local: Vec<FactorId>,
    pair_factors: Vec<FactorId>,
    dependent: Vec<Vec<FactorId>>,
}

impl ClusterMotionNodes {
    /// The motion nodes alone, without a factor graph (for the dedicated chain solver
    /// of `crate::chain`); [`ContinuousModel::refresh_factor`] does nothing on them.
    /// Same arguments and checks as [`ClusterMotionNodes::build`].
    pub fn without_graph(
        points: &[Point2<f64>],
        partners: &[Option<Point2<f64>>],
        variances: &[f64],
        edges: &[Edge],
        motions: Vec<Pose2>,
        weights: ClusteringWeights,
        outlier_distance: Option<f64>,
    ) -> Result<Self> {
        let k = motions.len();
        if k == 0 || k > MAX_CLUSTERS {
            return Err(Error::InvalidParameter {
                name: "clusters",
                value: k.to_string(),
                expected: "between 1 and 32 clusters",
            });
        }
        if points.len() != partners.len() || points.len() != variances.len() {
            return Err(Error::InvalidParameter {
                name: "partners",
                value: format!(
                    "{} partners and {} variances for {} points",
                    partners.len(),
                    variances.len(),
                    points.len()
                ),
                expected: "one (optional) partner and one variance per point",
            });
        }
        if edges
            .iter()
            .any(|e| e.i >= points.len() || e.j >= points.len())
        {
            return Err(Error::InvalidParameter {
                name: "edges",
                value: format!("an edge beyond {} points", points.len()),
                expected: "edges between existing points",
            });
        }
        Ok(Self {
            points: points.to_vec(),
            partners: partners.to_vec(),
            variances: variances.to_vec(),
            edges: edges.to_vec(),
            clusters: k,
            outlier_distance,
            weights,
            stats: vec![RigidAlignment::new(); k],
            motions,
            roles: Vec::new(),
            local: Vec::new(),
            pair_factors: Vec::new(),
            dependent: Vec::new(),
        })
    }

    /// Builds the factor graph of the CRF and its motion nodes. `motions` gives the
    /// starting motion of each of the `K = motions.len()` clusters; `outlier_distance`
    /// adds the outlier state.
    pub fn build(
        points: &[Point2<f64>],
        partners: &[Option<Point2<f64>>],
        variances: &[f64],
        edges: &[Edge],
        motions: Vec<Pose2>,
        weights: ClusteringWeights,
        outlier_distance: Option<f64>,
    ) -> Result<(FactorGraph, Self)> {
        let mut nodes = Self::without_graph(
            points,
            partners,
            variances,
            edges,
            motions,
            weights,
            outlier_distance,
        )?;
        let states = nodes.states();
        let n = points.len();
        let mut graph = FactorGraph::with_variables(&vec![states; n])?;
        let mut roles = Vec::with_capacity(n + edges.len());
        let mut local = Vec::with_capacity(n);
        let mut dependent: Vec<Vec<FactorId>> = vec![Vec::with_capacity(3); n];
        for (i, deps) in dependent.iter_mut().enumerate() {
            let a = graph.add_factor(TableFactor::new(
                vec![VariableId(i)],
                vec![states],
                vec![0.0; states],
            )?)?;
            roles.push(Role::Local(i));
            local.push(a);
            deps.push(a);
        }
        let mut pair_factors = Vec::with_capacity(edges.len());
        for (e, edge) in edges.iter().enumerate() {
            let a = graph.add_factor(TableFactor::new(
                vec![VariableId(edge.i), VariableId(edge.j)],
                vec![states, states],
                vec![0.0; states * states],
            )?)?;
            roles.push(Role::Pair(e));
            pair_factors.push(a);
            dependent[edge.i].push(a);
            dependent[edge.j].push(a);
        }
        nodes.roles = roles;
        nodes.local = local;
        nodes.pair_factors = pair_factors;
        nodes.dependent = dependent;
        Ok((graph, nodes))
    }

    /// The current motions, one per cluster.
    pub fn motions(&self) -> &[Pose2] {
        &self.motions
    }

    /// Number of cluster states (without the outlier state).
    pub fn clusters(&self) -> usize {
        self.clusters
    }

    /// Number of states per variable.
    pub fn states(&self) -> usize {
        self.clusters + usize::from(self.outlier_distance.is_some())
    }

    /// Writes the local log-potentials of point `i` into `out` (`states()` entries).
    pub fn write_local(&self, i: usize, out: &mut [f64]) {
        match &self.partners[i] {
            Some(g) => {
                let [w0, w1] = self.weights.distance;
                // Clamped: a far partner never attracts a point to a cluster.
                let scale = (w0 + w1 / self.variances[i]).min(0.0);
                for (l, m) in self.motions.iter().enumerate() {
                    out[l] = scale * distance_feature(m, &self.points[i], g);
                }
                if let Some(d) = self.outlier_distance {
                    out[self.clusters] = scale * d * d;
                }
            }
            None => {
                out[..self.clusters].fill(0.0);
                if self.outlier_distance.is_some() {
                    out[self.clusters] = 0.0;
                }
            }
        }
    }

    /// Writes the pairwise log-potentials of edge `e` into `out` (`states()²`
    /// entries, row-major: state of `i` first).
    pub fn write_pair(&self, e: usize, out: &mut [f64]) {
        let edge = self.edges[e];
        let states = self.states();
        let w = &self.weights;
        let same = w.neighbour[0] + w.weighted_neighbour[0] * edge.inverse_distance;
        let different = w.neighbour[1] + w.weighted_neighbour[1] * edge.inverse_distance;
        let stiff = w.stiffness[0] != 0.0 || w.stiffness[1] != 0.0;
        let (si, sj) = (&self.points[edge.i], &self.points[edge.j]);
        // Eq. (6) from the moved points, each moved once per cluster (no allocation).
        let mut moved_i = [Point2::origin(); MAX_CLUSTERS];
        let mut moved_j = [Point2::origin(); MAX_CLUSTERS];
        if stiff {
            for (l, m) in self.motions.iter().enumerate() {
                moved_i[l] = m.transform_point(si);
                moved_j[l] = m.transform_point(sj);
            }
        }
        let before = si - sj;
        for a in 0..states {
            for b in 0..states {
                let mut v = if a == b { same } else { different };
                if stiff && a < self.clusters && b < self.clusters {
                    let f = (before - (moved_i[a] - moved_j[b])).norm_squared();
                    v += if a == b {
                        w.stiffness[0]
                    } else {
                        w.stiffness[1]
                    } * f;
                }
                out[a * states + b] = v;
            }
        }
    }

    /// Writes the local tables of every point (`states()` entries each) and the
    /// pairwise tables of every edge (`states()²` each, as [`Self::write_pair`]) for
    /// the current motions, moving each point once per cluster (`moved` is scratch).
    /// Same values as [`Self::write_local`] and [`Self::write_pair`].
    pub fn write_tables(&self, moved: &mut Vec<Point2<f64>>, local: &mut [f64], pair: &mut [f64]) {
        let k = self.clusters;
        let states = self.states();
        let n = self.points.len();
        moved.clear();
        for s in &self.points {
            moved.extend(self.motions.iter().map(|m| m.transform_point(s)));
        }
        let [w0, w1] = self.weights.distance;
        for i in 0..n {
            let out = &mut local[i * states..(i + 1) * states];
            match &self.partners[i] {
                Some(g) => {
                    let scale = (w0 + w1 / self.variances[i]).min(0.0);
                    for (o, m) in out.iter_mut().zip(&moved[i * k..(i + 1) * k]) {
                        *o = scale * (m - g).norm_squared();
                    }
                    if let Some(d) = self.outlier_distance {
                        out[k] = scale * d * d;
                    }
                }
                None => out.fill(0.0),
            }
        }
        let w = &self.weights;
        let stiff = w.stiffness[0] != 0.0 || w.stiffness[1] != 0.0;
        for (e, edge) in self.edges.iter().enumerate() {
            let out = &mut pair[e * states * states..(e + 1) * states * states];
            let same = w.neighbour[0] + w.weighted_neighbour[0] * edge.inverse_distance;
            let different = w.neighbour[1] + w.weighted_neighbour[1] * edge.inverse_distance;
            let before = self.points[edge.i] - self.points[edge.j];
            let mi = &moved[edge.i * k..(edge.i + 1) * k];
            let mj = &moved[edge.j * k..(edge.j + 1) * k];
            for a in 0..states {
                let row = &mut out[a * states..(a + 1) * states];
                for (b, v) in row.iter_mut().enumerate() {
                    *v = if a == b { same } else { different };
                    if stiff && a < k && b < k {
                        let f = (before - (mi[a] - mj[b])).norm_squared();
                        *v += if a == b {
                            w.stiffness[0]
                        } else {
                            w.stiffness[1]
                        } * f;
                    }
                }
            }
        }
    }

    /// The local factor ids, by point.
    pub fn local_factors(&self) -> &[FactorId] {
        &self.local
    }

    /// The pairwise factor ids, by edge.
    pub fn pair_factors(&self) -> &[FactorId] {
        &self.pair_factors
    }
}

impl ContinuousModel for ClusterMotionNodes {
    fn summary(&self) -> DiscreteSummary {
        DiscreteSummary::MapLabels
    }

    fn update_variable(
        &mut self,
        v: VariableId,
        old: Option<VariableState<'_>>,
        new: VariableState<'_>,
    ) {
        let Some(Some(g)) = self.partners.get(v.0).copied() else {
            return;
        };
        let s = self.points[v.0];
        let w = 1.0 / self.variances[v.0];
        if let Some(VariableState::Label(l)) = old {
            if l < self.clusters {
                self.stats[l].remove(&s, &g, w);
            }
        }
        if let VariableState::Label(l) = new {
            if l < self.clusters {
                self.stats[l].add(&s, &g, w);
            }
        }
    }

    fn solve(&mut self) -> f64 {
        pgm_features::motion_nodes::solve_motions(&self.stats, &mut self.motions)
    }

    fn dependent_factors(&self, v: VariableId) -> &[FactorId] {
        self.dependent.get(v.0).map_or(&[], |d| d.as_slice())
    }

    fn refresh_factor(&self, a: FactorId, potentials: &mut Potentials<'_>) -> pgm_core::Result<()> {
        let Some(role) = self.roles.get(a.0).copied() else {
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
                expected: "a TableFactor built by ClusterMotionNodes::build",
            });
        };
        match role {
            Role::Local(i) => self.write_local(i, table.table_mut()),
            Role::Pair(e) => self.write_pair(e, table.table_mut()),
        }
        Ok(())
    }

    fn all_dependent_factors(&self, _graph: &FactorGraph) -> Vec<FactorId> {
        (0..self.roles.len()).map(FactorId).collect()
    }
}
