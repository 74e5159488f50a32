//! Proptest strategies for random factor graphs, in one place so every crate's tests
//! draw from the same distributions (enable the `proptest-strategies` feature).
//!
//! A [`GraphSpec`] is a plain description (cardinalities and factor tables) that
//! builds into a [`FactorGraph`], so failing cases shrink and print readably.

use crate::factor::{PottsFactor, TableFactor};
use crate::graph::{FactorGraph, VariableId};
use proptest::prelude::*;

/// One factor of a [`GraphSpec`].
#[derive(Clone, Debug)]
pub enum FactorSpec {
    /// A dense table over `scope` (row-major log-table).
    Table {
        /// Scope.
        scope: Vec<usize>,
        /// Log-table.
        log_table: Vec<f64>,
    },
    /// A Potts factor.
    Potts {
        /// First variable.
        a: usize,
        /// Second variable.
        b: usize,
        /// Log-potential for equal states.
        same: f64,
        /// Log-potential for different states.
        different: f64,
    },
}

/// A random factor graph description.
#[derive(Clone, Debug)]
pub struct GraphSpec {
    /// Cardinality of each variable.
    pub cardinalities: Vec<usize>,
    /// Factors.
    pub factors: Vec<FactorSpec>,
}

impl GraphSpec {
    /// Builds the graph (panics only if the strategy itself is wrong).
    pub fn build(&self) -> FactorGraph {
        let mut g = FactorGraph::with_variables(&self.cardinalities).expect("valid cardinalities");
        for f in &self.factors {
            match f {
                FactorSpec::Table { scope, log_table } => {
                    let shape = scope.iter().map(|&v| self.cardinalities[v]).collect();
                    let scope = scope.iter().map(|&v| VariableId(v)).collect();
                    g.add_factor(
                        TableFactor::new(scope, shape, log_table.clone()).expect("valid table"),
                    )
                    .expect("valid factor");
                }
                FactorSpec::Potts {
                    a,
                    b,
                    same,
                    different,
                } => {
                    let k = self.cardinalities[*a];
                    g.add_factor(
                        PottsFactor::new(VariableId(*a), VariableId(*b), k, *same, *different)
                            .expect("valid"),
                    )
                    .expect("valid factor");
                }
            }
        }
        g
    }

    /// Number of joint states.
    pub fn joint_states(&self) -> u64 {
        self.cardinalities.iter().map(|&k| k as u64).product()
    }
}

/// The graphs of `specs` with at most `max_states` joint states: small enough for
/// [`brute_force`](crate::exact::brute_force) to enumerate.
pub fn enumerable(
    specs: impl Strategy<Value = GraphSpec>,
    max_states: u64,
) -> impl Strategy<Value = GraphSpec> {
    specs.prop_filter("small enough to enumerate", move |s| {
        s.joint_states() <= max_states
    })
}

/// Log-potentials in `[-range, range]`, with probability `hard_zero` of −∞.
pub fn log_potential(range: f64, hard_zero: f64) -> impl Strategy<Value = f64> {
    (0.0..1.0f64, -range..=range)
        .prop_map(move |(u, x)| if u < hard_zero { f64::NEG_INFINITY } else { x })
}

/// A log-table of `size` entries; at least one entry is kept finite so that the table
/// alone is not a contradiction.
pub fn log_table(size: usize, range: f64, hard_zero: f64) -> impl Strategy<Value = Vec<f64>> {
    (
        proptest::collection::vec(log_potential(range, hard_zero), size),
        0..size.max(1),
        -range..=range,
    )
        .prop_map(|(mut t, keep, value)| {
            if t.iter().all(|x| *x == f64::NEG_INFINITY) && !t.is_empty() {
                t[keep] = value;
            }
            t
        })
}

fn table_factor(
    scope: Vec<usize>,
    cards: &[usize],
    range: f64,
    hard_zero: f64,
) -> BoxedStrategy<FactorSpec> {
    let size: usize = scope.iter().map(|&v| cards[v]).product();
    log_table(size, range, hard_zero)
        .prop_map(move |log_table| FactorSpec::Table {
            scope: scope.clone(),
            log_table,
        })
        .boxed()
}

/// Unary factors on every variable plus pairwise factors on the given edges (scope
/// order randomised by `flip`).
fn with_factors(
    cards: Vec<usize>,
    edges: Vec<(usize, usize)>,
    range: f64,
    hard_zero: f64,
) -> BoxedStrategy<GraphSpec> {
    let mut parts: Vec<BoxedStrategy<FactorSpec>> = Vec::new();
    for v in 0..cards.len() {
        parts.push(table_factor(vec![v], &cards, range, hard_zero));
    }
    for &(a, b) in &edges {
        parts.push(table_factor(vec![a, b], &cards, range, hard_zero));
    }
    parts
        .prop_map(move |factors| GraphSpec {
            cardinalities: cards.clone(),
            factors,
        })
        .boxed()
}

/// Random trees: 1..=`max_vars` variables of cardinality 1..=`max_card`, each variable
/// after the first attached to a random earlier one (scope order random), unary
/// factors everywhere, log-potentials in `[-range, range]` with some −∞.
pub fn tree(
    max_vars: usize,
    max_card: usize,
    range: f64,
    hard_zero: f64,
) -> BoxedStrategy<GraphSpec> {
    let attach = (any::<prop::sample::Index>(), any::<bool>());
    linked(max_vars, max_card, attach, range, hard_zero, |attach| {
        attach
            .iter()
            .enumerate()
            .map(|(i, (idx, flip))| {
                let child = i + 1;
                let parent = idx.index(child);
                if *flip {
                    (child, parent)
                } else {
                    (parent, child)
                }
            })
            .collect()
    })
}

/// Random chains in variable order (scope order random).
pub fn chain(
    max_vars: usize,
    max_card: usize,
    range: f64,
    hard_zero: f64,
) -> BoxedStrategy<GraphSpec> {
    linked(
        max_vars,
        max_card,
        any::<bool>(),
        range,
        hard_zero,
        |flips| {
            flips
                .iter()
                .enumerate()
                .map(|(i, &f)| if f { (i + 1, i) } else { (i, i + 1) })
                .collect()
        },
    )
}

/// The edge list (pairs of variable indices) [`linked`] builds from one draw per link.
type EdgeBuilder<T> = fn(&[T]) -> Vec<(usize, usize)>;

/// Graphs of 1..=`max_vars` variables of cardinality 1..=`max_card` whose edges
/// `edges` makes of one `link` draw per variable after the first, with the factors of
/// [`with_factors`].
fn linked<L>(
    max_vars: usize,
    max_card: usize,
    link: L,
    range: f64,
    hard_zero: f64,
    edges: EdgeBuilder<L::Value>,
) -> BoxedStrategy<GraphSpec>
where
    L: Strategy + Clone + 'static,
{
    (1..=max_vars)
        .prop_flat_map(move |n| {
            (
                proptest::collection::vec(1..=max_card, n),
                proptest::collection::vec(link.clone(), n.saturating_sub(1)),
            )
        })
        .prop_flat_map(move |(cards, links)| with_factors(cards, edges(&links), range, hard_zero))
        .boxed()
}

/// Random loopy graphs: a random tree plus `extra` random extra edges and optionally
/// one ternary factor; log-potentials in `[-range, range]` with some −∞.
pub fn loopy(
    max_vars: usize,
    max_card: usize,
    extra: usize,
    range: f64,
    hard_zero: f64,
) -> BoxedStrategy<GraphSpec> {
    (3..=max_vars.max(3))
        .prop_flat_map(move |n| {
            (
                proptest::collection::vec(1..=max_card, n),
                proptest::collection::vec(any::<prop::sample::Index>(), n - 1),
                proptest::collection::vec(
                    (any::<prop::sample::Index>(), any::<prop::sample::Index>()),
                    extra,
                ),
                any::<bool>(),
            )
        })
        .prop_flat_map(move |(cards, attach, extras, ternary)| {
            let n = cards.len();
            let mut edges: Vec<(usize, usize)> = attach
                .iter()
                .enumerate()
                .map(|(i, idx)| (idx.index(i + 1), i + 1))
                .collect();
            for (x, y) in extras {
                let (a, b) = (x.index(n), y.index(n));
                if a != b {
                    edges.push((a, b));
                }
            }
            let cards2 = cards.clone();
            with_factors(cards, edges, range, hard_zero).prop_flat_map(move |spec| {
                let cards = cards2.clone();
                let triple = if ternary {
                    vec![0usize, n / 2, n - 1]
                } else {
                    Vec::new()
                };
                let extra_factor: BoxedStrategy<Option<FactorSpec>> =
                    if triple.len() == 3 && triple[1] != 0 && triple[1] != n - 1 {
                        table_factor(triple, &cards, range, hard_zero)
                            .prop_map(Some)
                            .boxed()
                    } else {
                        Just(None).boxed()
                    };
                (Just(spec), extra_factor).prop_map(|(mut spec, f)| {
                    if let Some(f) = f {
                        spec.factors.push(f);
                    }
                    spec
                })
            })
        })
        .boxed()
}

/// Random Potts grids `rows × cols` with `k` labels: unary tables in `[-range, range]`
/// and Potts couplings in `[-range, range]` (attractive or repulsive).
pub fn potts_grid(max_side: usize, max_k: usize, range: f64) -> BoxedStrategy<GraphSpec> {
    (1..=max_side, 1..=max_side, 1..=max_k)
        .prop_flat_map(move |(rows, cols, k)| {
            let n = rows * cols;
            let mut edges = Vec::new();
            for r in 0..rows {
                for c in 0..cols {
                    let v = r * cols + c;
                    if c + 1 < cols {
                        edges.push((v, v + 1));
                    }
                    if r + 1 < rows {
                        edges.push((v, v + cols));
                    }
                }
            }
            (
                proptest::collection::vec(proptest::collection::vec(-range..=range, k), n),
                proptest::collection::vec((-range..=range, -range..=range), edges.len()),
            )
                .prop_map(move |(unaries, couplings)| {
                    let mut factors: Vec<FactorSpec> = unaries
                        .into_iter()
                        .enumerate()
                        .map(|(v, t)| FactorSpec::Table {
                            scope: vec![v],
                            log_table: t,
                        })
                        .collect();
                    for (&(a, b), &(same, different)) in edges.iter().zip(&couplings) {
                        factors.push(FactorSpec::Potts {
                            a,
                            b,
                            same,
                            different,
                        });
                    }
                    GraphSpec {
                        cardinalities: vec![k; n],
                        factors,
                    }
                })
        })
        .boxed()
}
