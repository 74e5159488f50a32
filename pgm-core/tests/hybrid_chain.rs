//! The hybrid chain solver (`pgm_core::hybrid::chain`) against brute force, against
//! the generic `HybridInference`, and its coordinate-ascent and fixed-point
//! properties on one and two chains with positions of varying state counts, and
//! sparse pairwise tables (`PairPattern`) against the same model written densely.

mod common;

use pgm_core::exact::{brute_force, BruteForceLimit};
use pgm_core::hybrid::chain::{
    chain_instance, ChainUpdate, Convergence, FeatureSink, HybridChainModel, HybridChainParams,
    WeightedTable,
};
use pgm_core::hybrid::PairPattern;
use pgm_core::hybrid::{ClusterMeans, HybridInference, UpdatePolicy};
use pgm_core::learning::{FeatureSet, LabelledInstance};
use pgm_core::{BpParams, FactorGraph, Mode, ParamGuard, Sequential, TableFactor};
use proptest::prelude::*;
use std::sync::Arc;

/// Cluster means over one or two chains of observations. Position `i` of chain `c`
/// has observation `y[c][i]` and `states[c][i]` states (cluster `0..states`); local
/// feature 0 is `−(y − μ_l)²`, feature 2 is 1 when the other chain's label at `i` is
/// the same cluster; pairwise feature 1 is 1 for equal neighbours. The means are the
/// continuous nodes, shared by both chains (empty clusters keep their mean).
#[derive(Clone, Debug)]
struct Means {
    y: Vec<Vec<f64>>,
    states: Vec<Vec<usize>>,
    weights: Vec<f64>,
    means: Vec<f64>,
    sum: Vec<f64>,
    count: Vec<usize>,
    labels: Vec<Vec<Option<usize>>>,
    frozen: bool,
    /// The joint log-score after every solve.
    scores: Vec<f64>,
}

impl Means {
    fn new(y: Vec<Vec<f64>>, states: Vec<Vec<usize>>, means: Vec<f64>, weights: Vec<f64>) -> Self {
        let k = means.len();
        let labels = y.iter().map(|c| vec![None; c.len()]).collect();
        Self {
            y,
            states,
            weights,
            means,
            sum: vec![0.0; k],
            count: vec![0; k],
            labels,
            frozen: false,
            scores: Vec::new(),
        }
    }

    fn other(&self, chain: usize, i: usize) -> Option<usize> {
        if self.y.len() < 2 {
            return None;
        }
        self.labels[1 - chain].get(i).copied().flatten()
    }

    /// The joint log-score of the current labels and means (coupling counted once).
    fn joint_score(&self) -> f64 {
        let w = &self.weights;
        let mut score = 0.0;
        for (c, ys) in self.y.iter().enumerate() {
            for (i, y) in ys.iter().enumerate() {
                let l = self.labels[c][i].unwrap();
                score -= w[0] * (y - self.means[l]).powi(2);
                if i + 1 < ys.len() && self.labels[c][i + 1] == Some(l) {
                    score += w[1];
                }
            }
        }
        if self.y.len() == 2 {
            for i in 0..self.y[0].len() {
                if self.labels[0][i] == self.labels[1][i] {
                    score += w[2];
                }
            }
        }
        score
    }

    /// Chain `c`'s tables for the current means and the other chain's labels, as a
    /// factor graph (for brute force).
    fn chain_graph(&self, c: usize) -> FactorGraph {
        let n = self.y[c].len();
        let s = &self.states[c];
        let mut g = FactorGraph::with_variables(s).unwrap();
        for i in 0..n {
            let mut t = vec![0.0; s[i]];
            self.write_local(c, i, &mut WeightedTable::new(&self.weights, &mut t));
            g.add_factor(TableFactor::new(vec![pgm_core::VariableId(i)], vec![s[i]], t).unwrap())
                .unwrap();
            if i + 1 < n {
                let mut t = vec![0.0; s[i] * s[i + 1]];
                self.write_pair(c, i, &mut WeightedTable::new(&self.weights, &mut t));
                g.add_factor(
                    TableFactor::new(
                        vec![pgm_core::VariableId(i), pgm_core::VariableId(i + 1)],
                        vec![s[i], s[i + 1]],
                        t,
                    )
                    .unwrap(),
                )
                .unwrap();
            }
        }
        g
    }
}

impl HybridChainModel for Means {
    fn weights(&self) -> &[f64] {
        &self.weights
    }
    fn num_chains(&self) -> usize {
        self.y.len()
    }
    fn chain_len(&self, chain: usize) -> usize {
        self.y[chain].len()
    }
    fn num_states(&self, chain: usize, i: usize) -> usize {
        self.states[chain][i]
    }
    fn write_local<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S) {
        let other = self.other(chain, i);
        for l in 0..self.states[chain][i] {
            sink.add(l, 0, -(self.y[chain][i] - self.means[l]).powi(2));
            if other == Some(l) {
                sink.add(l, 2, 1.0);
            }
        }
    }
    fn write_pair<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S) {
        let (s, t) = (self.states[chain][i], self.states[chain][i + 1]);
        for a in 0..s.min(t) {
            sink.add(a * t + a, 1, 1.0);
        }
    }
    fn set_label(&mut self, chain: usize, i: usize, old: Option<usize>, new: usize) {
        assert_eq!(
            self.labels[chain][i], old,
            "the solver reports the old label"
        );
        let y = self.y[chain][i];
        if let Some(o) = old {
            self.sum[o] -= y;
            self.count[o] -= 1;
        }
        self.sum[new] += y;
        self.count[new] += 1;
        self.labels[chain][i] = Some(new);
    }
    fn solve(&mut self) -> f64 {
        let mut change = 0.0f64;
        if !self.frozen {
            for l in 0..self.means.len() {
                if self.count[l] > 0 {
                    let m = self.sum[l] / self.count[l] as f64;
                    change = change.max((m - self.means[l]).abs());
                    self.means[l] = m;
                } else {
                    self.sum[l] = 0.0;
                }
            }
        }
        if self.labels.iter().flatten().all(Option::is_some) {
            self.scores.push(self.joint_score());
        }
        change
    }
}

/// One or two chains of 1-8 observations, 1-3 clusters, varying state counts.
fn problem(max_chains: usize) -> impl Strategy<Value = (Means, Vec<Vec<usize>>)> {
    problem_with(max_chains, 3)
}

/// One or `max_chains` chains of 1-8 observations, 1 to `max_clusters` clusters,
/// varying state counts.
fn problem_with(
    max_chains: usize,
    max_clusters: usize,
) -> impl Strategy<Value = (Means, Vec<Vec<usize>>)> {
    (1usize..=max_chains, 1usize..9, 1usize..=max_clusters).prop_flat_map(|(chains, n, k)| {
        (
            proptest::collection::vec(proptest::collection::vec(-5.0..5.0f64, n), chains),
            proptest::collection::vec(proptest::collection::vec(1usize..=k, n), chains),
            proptest::collection::vec(-5.0..5.0f64, k),
            (0.1..2.0f64, -1.0..2.0f64, -1.0..2.0f64),
            proptest::collection::vec(proptest::collection::vec(0usize..k.max(3), n), chains),
        )
            .prop_map(|(y, states, means, (w0, w1, w2), start)| {
                let initial: Vec<Vec<usize>> = start
                    .iter()
                    .zip(&states)
                    .map(|(s, st)| s.iter().zip(st).map(|(a, b)| a % b).collect())
                    .collect();
                (Means::new(y, states, means, vec![w0, w1, w2]), initial)
            })
    })
}

proptest! {
    #![proptest_config(common::persisted(256, "proptest-regressions/hybrid_chain.txt"))]

    /// With the continuous values frozen, one sweep is the exact MAP of each chain
    /// (brute force), for positions with any number of states.
    #[test]
    fn frozen_sweep_is_exact((mut model, initial) in problem(1)) {
        model.frozen = true;
        let solver = HybridChainParams::default().check().unwrap();
        let r = solver.run(&mut model, &initial).unwrap();
        let exact = brute_force(&model.chain_graph(0), BruteForceLimit::default()).unwrap();
        let g = model.chain_graph(0);
        prop_assert!((g.log_score(&r.labels[0]).unwrap() - exact.map_log_score).abs() < 1e-9);
        prop_assert!(r.converged);
        prop_assert_eq!(r.sweeps, 1);
        for i in 0..model.y[0].len() {
            let mm = r.max_marginal(0, i);
            prop_assert_eq!(mm.len(), model.states[0][i]);
            prop_assert!((mm.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        }
    }

    /// Every sweep is an exact maximisation of one block (a chain, then the means),
    /// so the joint log-score never decreases, on one or two coupled chains.
    #[test]
    fn coordinate_ascent_never_decreases((mut model, initial) in problem(2)) {
        let solver = HybridChainParams::default().max_sweeps(50).check().unwrap();
        solver.run(&mut model, &initial).unwrap();
        let s = &model.scores;
        prop_assert!(!s.is_empty());
        for w in s.windows(2) {
            prop_assert!(w[1] >= w[0] - 1e-9 * (1.0 + w[0].abs()), "score decreased: {s:?}");
        }
    }

    /// At convergence, under both update policies, every chain's labels are an exact
    /// MAP of its tables given the final means and the other chain's labels.
    #[test]
    fn converged_labels_are_a_fixed_point(
        (mut model, initial) in problem(2),
        every_visit in any::<bool>(),
    ) {
        let update = if every_visit { ChainUpdate::EveryVisit } else { ChainUpdate::EverySweep };
        let solver = HybridChainParams::default().max_sweeps(100).tolerance(0.0).update(update).check().unwrap();
        let r = solver.run(&mut model, &initial).unwrap();
        prop_assume!(r.converged);
        for c in 0..model.y.len() {
            let g = model.chain_graph(c);
            let exact = brute_force(&g, BruteForceLimit::default()).unwrap();
            prop_assert!((g.log_score(&r.labels[c]).unwrap() - exact.map_log_score).abs() < 1e-9,
                "chain {c}: {:?} scores {} < {}", r.labels[c], g.log_score(&r.labels[c]).unwrap(), exact.map_log_score);
            let told: Vec<usize> = model.labels[c].iter().map(|l| l.unwrap()).collect();
            prop_assert_eq!(&told, &r.labels[c]);
        }
    }

    /// On one chain with every-sweep updates the solver runs the same algorithm as
    /// `HybridInference` with `UpdatePolicy::EverySweep` and the two-pass sequential
    /// schedule (exact per sweep on a chain): the same labels and means.
    #[test]
    fn agrees_with_hybrid_inference(
        y in proptest::collection::vec(-5.0..5.0f64, 6..30),
        start_means in proptest::collection::vec(-5.0..5.0f64, 2..4),
        weight in 0.2..2.0f64,
        coupling in 0.0..2.0f64,
    ) {
        let k = start_means.len();
        let n = y.len();
        let mut sorted = start_means.clone();
        sorted.sort_by(f64::total_cmp);
        prop_assume!(sorted.windows(2).all(|w| w[1] - w[0] > 1e-3));
        // Start from the nearest starting mean (as CRF-Clustering starts from a
        // segmentation), which keeps the exact ties of one-point clusters away.
        let initial: Vec<usize> = y
            .iter()
            .map(|v| (0..k).min_by(|&a, &b| (v - start_means[a]).abs().total_cmp(&(v - start_means[b]).abs())).unwrap())
            .collect();
        // A one-point cluster has its mean on its point: two such clusters side by side
        // tie exactly (up to rounding) when the coupling merges them, and the two
        // decoders may break the tie differently.
        prop_assume!((0..k).all(|l| initial.iter().filter(|&&x| x == l).count() != 1));
        let (mut graph, mut reference) = ClusterMeans::chain(&y, &start_means, weight, coupling).unwrap();
        let generic = HybridInference::new(BpParams::new(Mode::MaxProduct).max_iterations(200).check_unwrap(), UpdatePolicy::EverySweep)
            .continuous_tolerance(1e-12)
            .run(&mut graph, &mut reference, &mut Sequential::default(), Some(&initial))
            .unwrap();
        let mut model = Means::new(vec![y.clone()], vec![vec![k; n]], start_means.clone(), vec![weight, coupling, 0.0]);
        let solver = HybridChainParams::default().max_sweeps(200).tolerance(1e-12).check().unwrap();
        let ours = solver.run(&mut model, &[initial]).unwrap();
        prop_assume!(generic.continuous_converged && ours.converged);
        // Exact ties (e.g. two equal starting means) may be broken differently by the
        // two decoders; compare where every position has a unique best state.
        let tied = (0..n).any(|i| {
            let mm = ours.max_marginal(0, i);
            let best = mm.iter().cloned().fold(0.0, f64::max);
            mm.iter().filter(|&&p| p > best * (1.0 - 1e-9)).count() > 1
        });
        prop_assume!(!tied);
        prop_assert_eq!(&ours.labels[0], &generic.discrete.assignment);
        for (a, b) in model.means.iter().zip(reference.means()) {
            prop_assert!((a - b).abs() < 1e-9, "means {:?} vs {:?}", model.means, reference.means());
        }
    }

    /// The learning instance holds exactly the features the solver weighs: for any
    /// weights, `w · f(x)` of the instance equals the sum of the weighted tables at `x`.
    #[test]
    fn learning_features_match_the_tables(
        (mut model, labels) in problem(2),
        weights in proptest::collection::vec(-3.0..3.0f64, 3),
    ) {
        for (c, l) in labels.iter().enumerate() {
            for (i, &x) in l.iter().enumerate() {
                model.set_label(c, i, None, x);
            }
        }
        model.solve();
        model.weights = weights.clone();
        let mut features = FeatureSet::new("means", 1);
        features.add_template("distance", &["squared"]).unwrap();
        features.add_template("neighbour", &["same"]).unwrap();
        features.add_template("other_chain", &["same"]).unwrap();
        let instance = chain_instance(&model, &Arc::new(features), &labels).unwrap();
        let totals = instance.model.feature_totals(&instance.labels).unwrap();
        let dot: f64 = totals.iter().zip(&weights).map(|(f, w)| f * w).sum();
        let tables: f64 = (0..model.y.len())
            .map(|c| model.chain_graph(c).log_score(&labels[c]).unwrap())
            .sum();
        prop_assert!((dot - tables).abs() < 1e-9 * (1.0 + tables.abs()), "{dot} vs {tables}");
    }
}

#[test]
fn bad_initial_labels_are_refused() {
    let mut model = Means::new(
        vec![vec![0.0, 1.0]],
        vec![vec![2, 1]],
        vec![0.0, 1.0],
        vec![1.0, 1.0, 0.0],
    );
    let solver = HybridChainParams::default().check().unwrap();
    assert!(solver.run(&mut model, &[vec![0]]).is_err());
    assert!(solver.run(&mut model, &[vec![0, 1]]).is_err());
    assert!(solver.run(&mut model, &[]).is_err());
    assert!(HybridChainParams::default().max_sweeps(0).check().is_err());
    assert!(HybridChainParams::default()
        .tolerance(f64::NAN)
        .check()
        .is_err());
}

/// `chains` chains of one position each: the last one prefers the other state than
/// the continuous value remembers (its last label), so every solve flips the
/// preference, a limit cycle of period two; the others keep state 0. The continuous
/// value moves by `step` at every solve.
struct Flipper {
    value: usize,
    chains: usize,
    step: f64,
}

impl HybridChainModel for Flipper {
    fn weights(&self) -> &[f64] {
        &[1.0]
    }
    fn num_chains(&self) -> usize {
        self.chains
    }
    fn chain_len(&self, _chain: usize) -> usize {
        1
    }
    fn num_states(&self, _chain: usize, _i: usize) -> usize {
        2
    }
    fn write_local<S: FeatureSink>(&self, chain: usize, _i: usize, sink: &mut S) {
        let flips = chain + 1 == self.chains;
        sink.add(if flips { 1 - self.value } else { 0 }, 0, 1.0);
    }
    fn write_pair<S: FeatureSink>(&self, _chain: usize, _i: usize, _sink: &mut S) {}
    fn set_label(&mut self, chain: usize, _i: usize, _old: Option<usize>, new: usize) {
        if chain + 1 == self.chains {
            self.value = new;
        }
    }
    fn solve(&mut self) -> f64 {
        self.step
    }
}

#[test]
fn limit_cycles_stop_early_and_are_reported() {
    let run = |stop: bool| {
        HybridChainParams::default()
            .stop_on_cycle(stop)
            .max_sweeps(20)
            .check()
            .unwrap()
            .run(
                &mut Flipper {
                    value: 0,
                    chains: 1,
                    step: 1.0,
                },
                &[vec![0]],
            )
            .unwrap()
    };
    let cycled = run(true);
    assert!(cycled.cycled && !cycled.converged);
    // Start 0, sweep 1 → 1, sweep 2 → 0 (the start again).
    assert_eq!(cycled.sweeps, 2);
    let endless = run(false);
    assert!(!endless.cycled && !endless.converged);
    assert_eq!(endless.sweeps, 20);
}

#[test]
fn convergence_on_the_continuous_values_alone_ignores_flipping_labels() {
    let run = |convergence: Convergence| {
        HybridChainParams::default()
            .convergence(convergence)
            .stop_on_cycle(false)
            .max_sweeps(10)
            .check()
            .unwrap()
            .run(
                // Chain 1 flips, and the continuous value never moves.
                &mut Flipper {
                    value: 0,
                    chains: 2,
                    step: 0.0,
                },
                &[vec![0], vec![0]],
            )
            .unwrap()
    };
    // Two chains: by default a label that keeps changing keeps the run going.
    for strict in [Convergence::Auto, Convergence::ContinuousAndLabels] {
        let r = run(strict);
        assert!(!r.converged);
        assert_eq!(r.sweeps, 10);
    }
    let r = run(Convergence::Continuous);
    assert!(r.converged);
    assert_eq!(r.sweeps, 1);
}

/// [`Means`] with a fourth weight and a banded pairwise feature, like the association
/// chain of CRF-Matching: besides feature 1 on equal neighbours (as `Means`), feature 3
/// is −0.5 on the band `|a − b| = 1`, 0.25 on the last row and column (an "outlier"
/// state) and 1 everywhere else (the far pairs). Written densely, or (`sparse`) over
/// the pattern listing the diagonal, the band and the last row and column, with the
/// far pairs as the default entry.
#[derive(Clone, Debug)]
struct Banded {
    inner: Means,
    weights: Vec<f64>,
    sparse: bool,
}

impl Banded {
    fn listed(a: usize, b: usize, s: usize, t: usize) -> bool {
        a.abs_diff(b) <= 1 || a + 1 == s || b + 1 == t
    }

    /// The features of the pair `(a, b)` of an `s × t` table.
    fn features(a: usize, b: usize, s: usize, t: usize) -> Vec<(usize, f64)> {
        if a == b {
            vec![(1, 1.0)]
        } else if a.abs_diff(b) == 1 {
            vec![(3, -0.5)]
        } else if a + 1 == s || b + 1 == t {
            vec![(3, 0.25)]
        } else {
            vec![(3, 1.0)]
        }
    }

    fn shape(&self, chain: usize, i: usize) -> (usize, usize) {
        let s = &self.inner.states[chain];
        (s[i], s[i + 1])
    }
}

impl HybridChainModel for Banded {
    fn weights(&self) -> &[f64] {
        &self.weights
    }
    fn num_chains(&self) -> usize {
        self.inner.num_chains()
    }
    fn chain_len(&self, chain: usize) -> usize {
        self.inner.chain_len(chain)
    }
    fn num_states(&self, chain: usize, i: usize) -> usize {
        self.inner.num_states(chain, i)
    }
    fn write_local<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S) {
        self.inner.write_local(chain, i, sink);
    }
    fn write_pair<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S) {
        let (s, t) = self.shape(chain, i);
        match self.pair_pattern(chain, i) {
            None => {
                for a in 0..s {
                    for b in 0..t {
                        for (f, v) in Self::features(a, b, s, t) {
                            sink.add(a * t + b, f, v);
                        }
                    }
                }
            }
            Some(pattern) => {
                for (p, (a, b)) in pattern.entries().enumerate() {
                    for (f, v) in Self::features(a, b, s, t) {
                        sink.add(p, f, v);
                    }
                }
                sink.add(pattern.default_entry(), 3, 1.0);
            }
        }
    }
    fn pair_pattern(&self, chain: usize, i: usize) -> Option<Arc<PairPattern>> {
        let (s, t) = self.shape(chain, i);
        self.sparse
            .then(|| Arc::new(PairPattern::from_fn(s, t, |a, b| Self::listed(a, b, s, t))))
    }
    fn set_label(&mut self, chain: usize, i: usize, old: Option<usize>, new: usize) {
        self.inner.set_label(chain, i, old, new);
    }
    fn solve(&mut self) -> f64 {
        self.inner.solve()
    }
}

/// The two instances hold the same variables, labels and cliques with the same
/// features at every joint state.
fn same_instance(a: &LabelledInstance, b: &LabelledInstance) -> Result<(), TestCaseError> {
    prop_assert_eq!(&a.labels, &b.labels);
    let (a, b) = (&a.model, &b.model);
    prop_assert_eq!(a.cardinalities(), b.cardinalities());
    prop_assert_eq!(a.num_cliques(), b.num_cliques());
    for c in 0..a.num_cliques() {
        prop_assert_eq!(a.clique_template(c), b.clique_template(c));
        let width = a
            .feature_set()
            .template(a.clique_template(c).unwrap())
            .unwrap()
            .width();
        let (x, y) = (a.clique(c).unwrap(), b.clique(c).unwrap());
        prop_assert_eq!(x.scope(), y.scope());
        prop_assert_eq!(x.shape(), y.shape());
        let shape = x.shape();
        let joint: usize = shape.iter().product();
        for e in 0..joint {
            let mut states = vec![0; shape.len()];
            let mut rest = e;
            for (k, &n) in shape.iter().enumerate().rev() {
                states[k] = rest % n;
                rest /= n;
            }
            let (mut fx, mut fy) = (vec![0.0; width], vec![0.0; width]);
            x.features(&states, &mut fx);
            y.features(&states, &mut fy);
            prop_assert_eq!(fx, fy, "clique {} at {:?}", c, states);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(common::persisted(256, "proptest-regressions/hybrid_chain.txt"))]

    /// A model declaring sparse pairs runs exactly as the same model written densely
    /// (labels, max-marginals, sweeps, solves, under both update policies, on one or
    /// two chains) and gives the same learning instance.
    #[test]
    fn sparse_pairs_agree_with_dense(
        (means, initial) in problem_with(2, 6),
        far in -1.0..2.0f64,
        every_visit in any::<bool>(),
    ) {
        let mut weights = means.weights.clone();
        weights.push(far);
        let mut dense = Banded { inner: means, weights, sparse: false };
        let mut sparse = Banded { sparse: true, ..dense.clone() };
        let update = if every_visit { ChainUpdate::EveryVisit } else { ChainUpdate::EverySweep };
        let solver = HybridChainParams::default().max_sweeps(50).update(update).check().unwrap();
        let ours = solver.run(&mut sparse, &initial).unwrap();
        let theirs = solver.run(&mut dense, &initial).unwrap();
        prop_assert_eq!(&ours, &theirs);
        prop_assert_eq!(&sparse.inner.means, &dense.inner.means);

        // The learning instance at the final labels and means.
        let mut features = FeatureSet::new("banded means", 1);
        features.add_template("distance", &["squared"]).unwrap();
        features.add_template("neighbour", &["same"]).unwrap();
        features.add_template("other_chain", &["same"]).unwrap();
        features.add_template("band", &["far"]).unwrap();
        let features = Arc::new(features);
        let a = chain_instance(&sparse, &features, &ours.labels).unwrap();
        let b = chain_instance(&dense, &features, &ours.labels).unwrap();
        same_instance(&a, &b)?;
    }
}

#[test]
fn patterns_of_the_wrong_shape_are_refused() {
    /// Declares a 2 × 2 pattern for every pair, whatever the states.
    struct Wrong(Means);
    impl HybridChainModel for Wrong {
        fn weights(&self) -> &[f64] {
            self.0.weights()
        }
        fn num_chains(&self) -> usize {
            1
        }
        fn chain_len(&self, chain: usize) -> usize {
            self.0.chain_len(chain)
        }
        fn num_states(&self, chain: usize, i: usize) -> usize {
            self.0.num_states(chain, i)
        }
        fn write_local<S: FeatureSink>(&self, chain: usize, i: usize, sink: &mut S) {
            self.0.write_local(chain, i, sink);
        }
        fn write_pair<S: FeatureSink>(&self, _chain: usize, _i: usize, _sink: &mut S) {}
        fn pair_pattern(&self, _chain: usize, _i: usize) -> Option<Arc<PairPattern>> {
            Some(Arc::new(PairPattern::from_fn(2, 2, |a, b| a == b)))
        }
        fn set_label(&mut self, chain: usize, i: usize, old: Option<usize>, new: usize) {
            self.0.set_label(chain, i, old, new);
        }
        fn solve(&mut self) -> f64 {
            self.0.solve()
        }
    }
    let means = Means::new(
        vec![vec![0.0, 1.0]],
        vec![vec![2, 3]],
        vec![0.0, 1.0, 2.0],
        vec![1.0, 1.0, 0.0],
    );
    let mut model = Wrong(means);
    let solver = HybridChainParams::default().check().unwrap();
    let error = solver.run(&mut model, &[vec![0, 0]]).unwrap_err();
    assert!(error.to_string().contains("2 x 2 pattern"), "{error}");
    let mut features = FeatureSet::new("means", 1);
    features.add_template("distance", &["squared"]).unwrap();
    features.add_template("neighbour", &["same"]).unwrap();
    features.add_template("other_chain", &["same"]).unwrap();
    assert!(chain_instance(&model, &Arc::new(features), &[vec![0, 0]]).is_err());
}
