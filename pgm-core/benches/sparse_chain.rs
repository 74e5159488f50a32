//! One exact max-product pass (forward messages with back-pointers, backward messages,
//! decoding: [`FlatChain::viterbi`]) on the association chain of CRF-Matching over the
//! full state space: 361 positions (one per laser beam), each with 362 states (361
//! reference points plus the outlier state). Dense pairwise tables (`362²` entries per
//! pair, 378 MB for the chain, `O(s²)` per message) against sparse ones over the
//! pattern CRF-Matching's potential has: the band `|b − a − 1| ≤ 8` and the outlier
//! row and column listed, one default (the `sequence.far` weight) everywhere else
//! (about 21 entries per row, `O(s log s + nnz)` per message). Both compute the same
//! messages; the tables hold random values with the default below most listed ones.

use criterion::{criterion_group, criterion_main, Criterion};
use pgm_core::hybrid::{FlatChain, PairPattern};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::sync::Arc;

const POSITIONS: usize = 361;
const REFERENCE_POINTS: usize = 361;
const STATES: usize = REFERENCE_POINTS + 1;
const BAND: usize = 8;

/// The CRF-Matching pattern: the band around the next beam and the outlier row and
/// column.
fn pattern() -> PairPattern {
    let outlier = REFERENCE_POINTS;
    PairPattern::from_fn(STATES, STATES, |a, b| {
        a == outlier || b == outlier || (b as isize - a as isize - 1).unsigned_abs() <= BAND
    })
}

fn sparse_chain(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let pattern = Arc::new(pattern());
    let far = -3.0;
    let states = vec![STATES; POSITIONS];
    let local: Vec<f64> = (0..POSITIONS * STATES)
        .map(|_| rng.random_range(-4.0..0.0))
        .collect();
    let mut sparse =
        FlatChain::with_patterns(&states, vec![Some(Arc::clone(&pattern)); POSITIONS - 1]).unwrap();
    let mut sparse_pair = Vec::with_capacity(sparse.pair_len());
    for _ in 0..POSITIONS - 1 {
        sparse_pair.extend((0..pattern.len()).map(|_| rng.random_range(-4.0..2.0)));
        sparse_pair.push(far);
    }
    let mut dense = FlatChain::with_states(&states);
    let mut dense_pair = vec![0.0; dense.pair_len()];
    for i in 0..POSITIONS - 1 {
        let o = dense.pair_offset(i);
        sparse.dense_pair(&sparse_pair, i, &mut dense_pair[o..o + STATES * STATES]);
    }
    let (mut sparse_labels, mut dense_labels) = (vec![0; POSITIONS], vec![0; POSITIONS]);
    sparse.viterbi(&local, &sparse_pair, &mut sparse_labels);
    dense.viterbi(&local, &dense_pair, &mut dense_labels);
    assert_eq!(sparse_labels, dense_labels, "the two chains decode alike");
    eprintln!(
        "{POSITIONS} positions x {STATES} states: {} listed entries per pair ({:.1} %), pairwise tables {:.1} MB dense, {:.2} MB sparse",
        pattern.len(),
        100.0 * pattern.len() as f64 / (STATES * STATES) as f64,
        (dense_pair.len() * 8) as f64 / 1e6,
        (sparse_pair.len() * 8) as f64 / 1e6,
    );

    let mut group = c.benchmark_group("flat_chain_361x362");
    group.sample_size(10);
    group.bench_function("dense", |b| {
        b.iter(|| dense.viterbi(black_box(&local), black_box(&dense_pair), &mut dense_labels))
    });
    group.bench_function("sparse_band8_outlier", |b| {
        b.iter(|| {
            sparse.viterbi(
                black_box(&local),
                black_box(&sparse_pair),
                &mut sparse_labels,
            )
        })
    });
    group.finish();
}

criterion_group!(benches, sparse_chain);
criterion_main!(benches);
