//! Per-cluster rigid motions solved in closed form from labelled point pairs (eq. 3
//! of the CRF-Clustering paper), the continuous nodes `x^RT` of every model here.
//!
//! [`ClusterMotions`] keeps one [`RigidAlignment`] (O(1) sufficient statistics) per
//! cluster, so moving a point pair from one cluster to another costs O(1) however
//! many points there are, and re-solving every motion costs O(clusters). Models keep
//! it up to date from label changes: CRF-Clustering from its chain solver
//! (`pgm_core::hybrid::chain`), [`RigidMotionNodes`] from the generic
//! [`HybridInference`](pgm_core::hybrid::HybridInference) engine as a
//! [`ContinuousModel`].
//!
//! [`RigidMotionNodes`]: variable `i` labels a point pair `(s_i, g_i)` (current point,
//! its partner in the reference) with a cluster `l`; the local factor of variable `i`
//! is refreshed to `−weight · ‖R_l s_i + T_l − g_i‖²` for every cluster state `l`
//! (eq. 2, the distance feature); extra states beyond the clusters (for example an
//! outlier state) get a fixed log-potential.

use nalgebra::Point2;
use pgm_core::hybrid::{ContinuousModel, DiscreteSummary, VariableState};
use pgm_core::{Error, FactorId, Potentials, Result, TableFactor, VariableId};
use pgm_scan::alignment::RigidAlignment;
use pgm_scan::pose::Pose2;

/// Solves every cluster's motion from its statistics (eq. 3); an empty cluster keeps
/// its motion. Returns the largest change of a motion (metres or radians).
pub fn solve_motions(stats: &[RigidAlignment], motions: &mut [Pose2]) -> f64 {
    let mut change = 0.0f64;
    for (m, stats) in motions.iter_mut().zip(stats) {
        if let Some(a) = stats.solve() {
            change = change
                .max(a.motion.translation_error(m))
                .max(a.motion.rotation_error(m));
            *m = a.motion;
        }
    }
    change
}

/// The rigid motions of `k` clusters and the statistics they are solved from.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterMotions {
    stats: Vec<RigidAlignment>,
    motions: Vec<Pose2>,
}

impl ClusterMotions {
    /// `motions.len()` clusters starting at `motions`, with no pair assigned.
    pub fn new(motions: Vec<Pose2>) -> Self {
        Self {
            stats: vec![RigidAlignment::new(); motions.len()],
            motions,
        }
    }

    /// Number of clusters.
    pub fn len(&self) -> usize {
        self.motions.len()
    }

    /// True without clusters.
    pub fn is_empty(&self) -> bool {
        self.motions.is_empty()
    }

    /// Moves the pair `(s, g)` of weight `weight` from cluster `old` to cluster `new`
    /// (`None`, or an index of no cluster such as an outlier state: not counted).
    pub fn relabel(
        &mut self,
        s: &Point2<f64>,
        g: &Point2<f64>,
        weight: f64,
        old: Option<usize>,
        new: Option<usize>,
    ) {
        if old == new {
            return;
        }
        if let Some(stats) = old.and_then(|l| self.stats.get_mut(l)) {
            stats.remove(s, g, weight);
        }
        if let Some(stats) = new.and_then(|l| self.stats.get_mut(l)) {
            stats.add(s, g, weight);
        }
    }

    /// Re-solves every motion (eq. 3); empty clusters keep theirs. Returns the largest
    /// change (m or rad).
    pub fn solve(&mut self) -> f64 {
        solve_motions(&self.stats, &mut self.motions)
    }

    /// The current motions.
    pub fn motions(&self) -> &[Pose2] {
        &self.motions
    }

    /// The statistics of each cluster.
    pub fn statistics(&self) -> &[RigidAlignment] {
        &self.stats
    }

    /// Number of pairs currently assigned to each cluster.
    pub fn counts(&self) -> Vec<usize> {
        self.stats.iter().map(|s| s.len()).collect()
    }
}

/// Rigid motions of `k` clusters over labelled point pairs.
#[derive(Clone, Debug)]
pub struct RigidMotionNodes {
    pairs: Vec<(Point2<f64>, Point2<f64>)>,
    local_factor: Vec<FactorId>,
    factor_variable: Vec<Option<usize>>,
    dependent: Vec<[FactorId; 1]>,
    motions: ClusterMotions,
    weight: f64,
    extra_states: Vec<f64>,
}

impl RigidMotionNodes {
    /// `pairs[i]` is the pair of variable `i`, `local_factor[i]` its local
    /// [`TableFactor`] (with `motions.len() + extra_states.len()` states), `motions`
    /// the initial motions, `weight > 0` the distance weight, and `extra_states` the
    /// fixed log-potentials of states after the clusters.
    pub fn new(
        pairs: Vec<(Point2<f64>, Point2<f64>)>,
        local_factor: Vec<FactorId>,
        motions: Vec<Pose2>,
        weight: f64,
        extra_states: Vec<f64>,
    ) -> Result<Self> {
        if pairs.len() != local_factor.len() {
            return Err(Error::InvalidParameter {
                name: "local factors",
                value: format!("{} pairs, {} factors", pairs.len(), local_factor.len()),
                expected: "one local factor per point pair",
            });
        }
        if !(weight.is_finite() && weight > 0.0) {
            return Err(Error::InvalidParameter {
                name: "distance weight",
                value: weight.to_string(),
                expected: "a positive finite number",
            });
        }
        if let Some(i) = pairs.iter().position(|(s, g)| {
            !(s.x.is_finite() && s.y.is_finite() && g.x.is_finite() && g.y.is_finite())
        }) {
            return Err(Error::InvalidParameter {
                name: "point pair",
                value: i.to_string(),
                expected: "finite coordinates",
            });
        }
        if let Some(x) = extra_states
            .iter()
            .find(|x| x.is_nan() || **x == f64::INFINITY)
        {
            return Err(Error::InvalidParameter {
                name: "extra state log-potential",
                value: x.to_string(),
                expected: "finite or -inf",
            });
        }
        let max_factor = local_factor.iter().map(|a| a.0 + 1).max().unwrap_or(0);
        let mut factor_variable = vec![None; max_factor];
        for (i, a) in local_factor.iter().enumerate() {
            factor_variable[a.0] = Some(i);
        }
        Ok(Self {
            dependent: local_factor.iter().map(|&a| [a]).collect(),
            pairs,
            local_factor,
            factor_variable,
            motions: ClusterMotions::new(motions),
            weight,
            extra_states,
        })
    }

    /// The current motions.
    pub fn motions(&self) -> &[Pose2] {
        self.motions.motions()
    }

    /// Number of pairs currently labelled with each cluster.
    pub fn counts(&self) -> Vec<usize> {
        self.motions.counts()
    }

    /// The local factor of each variable.
    pub fn local_factors(&self) -> &[FactorId] {
        &self.local_factor
    }

    /// The local log-potentials of variable `i` under the current motions.
    pub fn local_log_potentials(&self, i: usize) -> Vec<f64> {
        let (s, g) = &self.pairs[i];
        let mut t: Vec<f64> = self
            .motions()
            .iter()
            .map(|m| -self.weight * (m.transform_point(s) - g).norm_squared())
            .collect();
        t.extend_from_slice(&self.extra_states);
        t
    }
}

/// The label of a variable's state as [`ContinuousModel::update_variable`] hands it
/// over: `None` without a state or for a state that is not a label.
pub fn state_label(state: Option<VariableState<'_>>) -> Option<usize> {
    match state {
        Some(VariableState::Label(l)) => Some(l),
        _ => None,
    }
}

impl ContinuousModel for RigidMotionNodes {
    fn summary(&self) -> DiscreteSummary {
        DiscreteSummary::MapLabels
    }

    fn update_variable(
        &mut self,
        v: VariableId,
        old: Option<VariableState<'_>>,
        new: VariableState<'_>,
    ) {
        let Some((s, g)) = self.pairs.get(v.0).copied() else {
            return;
        };
        self.motions
            .relabel(&s, &g, 1.0, state_label(old), state_label(Some(new)));
    }

    fn solve(&mut self) -> f64 {
        self.motions.solve()
    }

    fn dependent_factors(&self, v: VariableId) -> &[FactorId] {
        self.dependent.get(v.0).map_or(&[], |d| d.as_slice())
    }

    fn refresh_factor(&self, a: FactorId, potentials: &mut Potentials<'_>) -> Result<()> {
        let Some(Some(i)) = self.factor_variable.get(a.0) else {
            return Ok(());
        };
        let (s, g) = &self.pairs[*i];
        match potentials
            .factor_mut(a)
            .as_any_mut()
            .and_then(|f| f.downcast_mut::<TableFactor>())
        {
            Some(t) if t.table().len() == self.motions.len() + self.extra_states.len() => {
                // Written in place: motions give finite values, extra states were checked.
                let table = t.table_mut();
                for (x, m) in table.iter_mut().zip(self.motions.motions()) {
                    *x = -self.weight * (m.transform_point(s) - g).norm_squared();
                }
                table[self.motions.len()..].copy_from_slice(&self.extra_states);
                Ok(())
            }
            Some(t) => Err(Error::TableSize {
                expected: self.motions.len() + self.extra_states.len(),
                actual: t.table().len(),
            }),
            None => Err(Error::InvalidParameter {
                name: "local factor",
                value: a.0.to_string(),
                expected: "a TableFactor",
            }),
        }
    }
}
