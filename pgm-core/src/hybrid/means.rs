//! A reference continuous model: one-dimensional cluster means.

use super::{ContinuousModel, DiscreteSummary, VariableState};
use crate::error::{Error, Result};
use crate::factor::{PottsFactor, TableFactor};
use crate::graph::{FactorGraph, FactorId, VariableId};
use crate::hook::Potentials;

/// Variable `i` with observation `y_i` chooses a cluster `l`; its local log-potential
/// is `−w (y_i − μ_l)²`, and each cluster mean `μ_l` is a continuous node solved in
/// closed form as the (belief-)weighted mean of the observations assigned to it. The
/// sufficient statistics (`Σ weight`, `Σ weight·y` per cluster) change in O(number of
/// clusters) per variable update, independent of the number of variables.
///
/// It is the smallest model with the structure of CRF-Clustering (where the nodes are
/// rigid motions instead of means) and is used by the hybrid tests and docs.
#[derive(Clone, Debug)]
pub struct ClusterMeans {
    observations: Vec<f64>,
    weight: f64,
    means: Vec<f64>,
    sum_weight: Vec<f64>,
    sum_weighted: Vec<f64>,
    /// The local factor of each variable.
    dependent: Vec<Vec<FactorId>>,
    /// Which variable each local factor belongs to, by factor id.
    factor_variable: Vec<Option<usize>>,
    summary: DiscreteSummary,
}

impl ClusterMeans {
    /// A chain CRF over the observations (in order) with one local factor per variable
    /// (refreshed from the means) and Potts factors of log-potential `coupling` for equal
    /// neighbours, plus the means model starting at `initial_means`. `weight` must be
    /// positive and finite.
    pub fn chain(
        observations: &[f64],
        initial_means: &[f64],
        weight: f64,
        coupling: f64,
    ) -> Result<(FactorGraph, Self)> {
        let k = initial_means.len();
        if k == 0 {
            return Err(Error::InvalidParameter {
                name: "initial_means",
                value: "[]".into(),
                expected: "at least one cluster",
            });
        }
        if !(weight.is_finite() && weight > 0.0) {
            return Err(Error::InvalidParameter {
                name: "weight",
                value: weight.to_string(),
                expected: "a positive finite number",
            });
        }
        if let Some(i) = observations
            .iter()
            .chain(initial_means)
            .position(|y| !y.is_finite())
        {
            return Err(Error::InvalidParameter {
                name: "observation or initial mean",
                value: format!("entry {i} is not finite"),
                expected: "finite numbers",
            });
        }
        let n = observations.len();
        let mut graph = FactorGraph::with_variables(&vec![k; n])?;
        let mut dependent = Vec::with_capacity(n);
        let mut factor_variable = Vec::new();
        for i in 0..n {
            let a = graph.add_factor(TableFactor::new(
                vec![VariableId(i)],
                vec![k],
                vec![0.0; k],
            )?)?;
            dependent.push(vec![a]);
            factor_variable.resize(a.0 + 1, None);
            factor_variable[a.0] = Some(i);
        }
        for i in 1..n {
            graph.add_factor(PottsFactor::new(
                VariableId(i - 1),
                VariableId(i),
                k,
                coupling,
                0.0,
            )?)?;
        }
        let model = Self {
            observations: observations.to_vec(),
            weight,
            means: initial_means.to_vec(),
            sum_weight: vec![0.0; k],
            sum_weighted: vec![0.0; k],
            dependent,
            factor_variable,
            summary: DiscreteSummary::MapLabels,
        };
        Ok((graph, model))
    }

    /// Uses beliefs instead of MAP labels (soft, EM-like updates).
    pub fn with_summary(mut self, summary: DiscreteSummary) -> Self {
        self.summary = summary;
        self
    }

    /// The current cluster means.
    pub fn means(&self) -> &[f64] {
        &self.means
    }

    fn accumulate(&mut self, y: f64, state: VariableState<'_>, sign: f64) {
        match state {
            VariableState::Label(l) => {
                if l < self.means.len() {
                    self.sum_weight[l] += sign;
                    self.sum_weighted[l] += sign * y;
                }
            }
            VariableState::Belief(b) => {
                for (l, &p) in b.iter().enumerate().take(self.means.len()) {
                    self.sum_weight[l] += sign * p;
                    self.sum_weighted[l] += sign * p * y;
                }
            }
        }
    }
}

impl ContinuousModel for ClusterMeans {
    fn summary(&self) -> DiscreteSummary {
        self.summary
    }

    fn update_variable(
        &mut self,
        v: VariableId,
        old: Option<VariableState<'_>>,
        new: VariableState<'_>,
    ) {
        let Some(&y) = self.observations.get(v.0) else {
            return;
        };
        if let Some(old) = old {
            self.accumulate(y, old, -1.0);
        }
        self.accumulate(y, new, 1.0);
    }

    fn solve(&mut self) -> f64 {
        let mut change = 0.0f64;
        for l in 0..self.means.len() {
            // Incremental sums drift by rounding: treat tiny weights as an empty cluster,
            // which keeps its previous mean.
            if self.sum_weight[l] > 1e-9 {
                let m = self.sum_weighted[l] / self.sum_weight[l];
                change = change.max((m - self.means[l]).abs());
                self.means[l] = m;
            }
        }
        change
    }

    fn dependent_factors(&self, v: VariableId) -> &[FactorId] {
        self.dependent.get(v.0).map_or(&[], |d| d.as_slice())
    }

    fn refresh_factor(&self, a: FactorId, potentials: &mut Potentials<'_>) -> Result<()> {
        let Some(Some(i)) = self.factor_variable.get(a.0) else {
            return Ok(());
        };
        let y = self.observations[*i];
        let table: Vec<f64> = self
            .means
            .iter()
            .map(|m| -self.weight * (y - m) * (y - m))
            .collect();
        match potentials
            .factor_mut(a)
            .as_any_mut()
            .and_then(|f| f.downcast_mut::<TableFactor>())
        {
            Some(t) => t.set_table(table),
            None => Err(Error::InvalidParameter {
                name: "dependent factor",
                value: a.0.to_string(),
                expected: "the TableFactor created by ClusterMeans::chain",
            }),
        }
    }
}
