//! Step 2: the initial clusters (section V-A of the CRF-Clustering paper: "we segment
//! the scan based on a distance heuristic").
//!
//! 1. [`segment_by_gap`]: walking the valid points in beam order, a point farther
//!    than the gap from the previous one starts a new segment.
//! 2. [`initial_clusters`] caps the number of segments at the model's maximum number
//!    of clusters. Segments without any associated point carry no motion evidence and
//!    join the nearest segment (in beam order) that has some. The rest are merged
//!    agglomeratively, cheapest first, where the cost of merging two segments is the
//!    increase of the least-squares residual of eq. (3) when one rigid motion has to
//!    explain both (a Ward-like criterion in motion space, O(1) per pair with
//!    [`RigidAlignment`]'s sufficient statistics). Static segments anywhere in the
//!    scan merge at almost no cost, while a small segment that moved differently
//!    (a walking person) stays apart as long as the cap allows.
//!
//! The cluster ids returned are `0..K` in order of first appearance.

use nalgebra::Point2;
use pgm_scan::scan::segment_by_gap;
use pgm_scan::RigidAlignment;

/// Renames labels `0..` in order of first appearance.
pub fn relabel_by_first_appearance(labels: &mut [usize]) -> usize {
    let max = labels.iter().copied().max().map_or(0, |m| m + 1);
    let mut map = vec![usize::MAX; max];
    let mut next = 0;
    for l in labels.iter_mut() {
        if map[*l] == usize::MAX {
            map[*l] = next;
            next += 1;
        }
        *l = map[*l];
    }
    next
}

fn residual(stats: &RigidAlignment) -> f64 {
    stats.residual().unwrap_or(0.0)
}

/// The initial cluster of every point: segments by `gap`, then capped at
/// `max_clusters` by merging (see the module docs). `points[i]` is a current point,
/// `partners[i]` its associated reference point, if any, and `variances[i]` the
/// expected squared distance to it (the residuals are weighted by its inverse). Returns the labels (`0..K`,
/// first appearance order) and `K`.
pub fn initial_clusters(
    points: &[Point2<f64>],
    partners: &[Option<Point2<f64>>],
    variances: &[f64],
    gap: f64,
    max_clusters: usize,
) -> (Vec<usize>, usize) {
    let n = points.len();
    if n == 0 {
        return (Vec::new(), 0);
    }
    let segments = segment_by_gap(points, gap);
    let count = segments[n - 1] + 1;
    let mut stats = vec![RigidAlignment::new(); count];
    for i in 0..n {
        if let Some(g) = &partners[i] {
            stats[segments[i]].add(&points[i], g, 1.0 / variances[i]);
        }
    }
    // Segments without evidence join the nearest segment with some (beam order; the
    // earlier one on ties).
    let has: Vec<bool> = stats.iter().map(|s| !s.is_empty()).collect();
    if !has.iter().any(|h| *h) {
        return (vec![0; n], 1);
    }
    let mut before = vec![None; count];
    let mut last = None;
    for s in 0..count {
        if has[s] {
            last = Some(s);
        }
        before[s] = last;
    }
    let mut after = vec![None; count];
    let mut last = None;
    for s in (0..count).rev() {
        if has[s] {
            last = Some(s);
        }
        after[s] = last;
    }
    let owner: Vec<usize> = (0..count)
        .map(|s| match (before[s], after[s]) {
            (Some(b), Some(a)) => {
                if s - b <= a - s {
                    b
                } else {
                    a
                }
            }
            (Some(b), None) => b,
            (None, Some(a)) => a,
            (None, None) => s,
        })
        .collect();
    // Agglomerative merging of the segments with evidence.
    let alive_ids: Vec<usize> = (0..count).filter(|&s| has[s]).collect();
    let representative = merge_down(
        alive_ids.iter().map(|&s| stats[s].clone()).collect(),
        max_clusters.max(1),
    );
    let mut segment_cluster = vec![0usize; count];
    for (c, &s) in alive_ids.iter().enumerate() {
        segment_cluster[s] = representative[c];
    }
    let mut labels: Vec<usize> = (0..n)
        .map(|i| segment_cluster[owner[segments[i]]])
        .collect();
    let k = relabel_by_first_appearance(&mut labels);
    (labels, k)
}

/// Above this many segments the full pairwise merge (O(m²) memory) is preceded by
/// merging neighbours in beam order (a long, noisy scan can have tens of thousands of
/// segments); typical scans have far fewer and never reach it.
pub const MAX_FULL_MERGE: usize = 256;

/// The increase of the least-squares residual of eq. (3) when one rigid motion has to
/// explain the pairs of both `a` and `b` (residuals `ra`, `rb` of each alone).
fn merge_cost(a: &RigidAlignment, ra: f64, b: &RigidAlignment, rb: f64) -> f64 {
    let mut both = a.clone();
    both.merge(b);
    residual(&both) - ra - rb
}

/// A merge candidate in the neighbour stage: cost, the two clusters and their versions.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    cost: f64,
    a: usize,
    b: usize,
    versions: (u32, u32),
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // Cheapest first in a max-heap; ties to the earlier pair.
        other
            .cost
            .total_cmp(&self.cost)
            .then_with(|| other.a.cmp(&self.a))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// Merges clusters (given by their statistics, in beam order) cheapest first until at
/// most `cap` remain; returns each input cluster's representative (an input index).
/// Beyond [`MAX_FULL_MERGE`] clusters only neighbours in beam order are merged (a heap
/// of adjacent pairs, O(m log m)) down to that many; then every pair is a candidate
/// (a cost matrix with row minima kept up to date).
fn merge_down(mut stats: Vec<RigidAlignment>, cap: usize) -> Vec<usize> {
    let m = stats.len();
    let mut residuals: Vec<f64> = stats.iter().map(residual).collect();
    let mut alive = vec![true; m];
    let mut parent: Vec<usize> = (0..m).collect();
    let mut remaining = m;
    let mut merge = |stats: &mut Vec<RigidAlignment>,
                     residuals: &mut Vec<f64>,
                     alive: &mut Vec<bool>,
                     a: usize,
                     b: usize| {
        let other = stats[b].clone();
        stats[a].merge(&other);
        residuals[a] = residual(&stats[a]);
        alive[b] = false;
        parent[b] = a;
    };
    if remaining > cap.max(MAX_FULL_MERGE) {
        let mut next: Vec<Option<usize>> = (0..m).map(|a| (a + 1 < m).then_some(a + 1)).collect();
        let mut previous: Vec<Option<usize>> = (0..m).map(|a| a.checked_sub(1)).collect();
        let mut version = vec![0u32; m];
        let candidate =
            |stats: &[RigidAlignment], residuals: &[f64], version: &[u32], a, b| Candidate {
                cost: merge_cost(&stats[a], residuals[a], &stats[b], residuals[b]),
                a,
                b,
                versions: (version[a], version[b]),
            };
        let mut heap: std::collections::BinaryHeap<Candidate> = (0..m.saturating_sub(1))
            .map(|a| candidate(&stats, &residuals, &version, a, a + 1))
            .collect();
        while remaining > cap.max(MAX_FULL_MERGE) {
            let Some(c) = heap.pop() else { break };
            if !alive[c.a] || !alive[c.b] || c.versions != (version[c.a], version[c.b]) {
                continue;
            }
            merge(&mut stats, &mut residuals, &mut alive, c.a, c.b);
            remaining -= 1;
            version[c.a] += 1;
            next[c.a] = next[c.b];
            if let Some(after) = next[c.b] {
                previous[after] = Some(c.a);
            }
            if let Some(before) = previous[c.a] {
                heap.push(candidate(&stats, &residuals, &version, before, c.a));
            }
            if let Some(after) = next[c.a] {
                heap.push(candidate(&stats, &residuals, &version, c.a, after));
            }
        }
    }
    // Every pair of the clusters left.
    let live: Vec<usize> = (0..m).filter(|&a| alive[a]).collect();
    let l = live.len();
    if l > cap {
        let mut cost = vec![f64::INFINITY; l * l];
        for x in 0..l {
            for y in x + 1..l {
                let (a, b) = (live[x], live[y]);
                cost[x * l + y] = merge_cost(&stats[a], residuals[a], &stats[b], residuals[b]);
            }
        }
        // Row minima (over partners with a larger index), kept up to date, so a merge
        // costs O(l) except for the rows whose minimum it invalidates.
        let row_min = |cost: &[f64], alive: &[bool], x: usize| {
            let mut best = (f64::INFINITY, x);
            for y in x + 1..l {
                if alive[live[y]] && cost[x * l + y] < best.0 {
                    best = (cost[x * l + y], y);
                }
            }
            best
        };
        let mut minima: Vec<(f64, usize)> = (0..l).map(|x| row_min(&cost, &alive, x)).collect();
        while remaining > cap {
            let mut best = (f64::INFINITY, 0, 0);
            for x in 0..l {
                if alive[live[x]] && minima[x].0 < best.0 {
                    best = (minima[x].0, x, minima[x].1);
                }
            }
            let (_, x, y) = best;
            if x == y {
                break;
            }
            merge(&mut stats, &mut residuals, &mut alive, live[x], live[y]);
            remaining -= 1;
            let a = live[x];
            for (z, &c) in live.iter().enumerate() {
                if z == x || !alive[c] {
                    continue;
                }
                let value = merge_cost(&stats[a], residuals[a], &stats[c], residuals[c]);
                let (p, q) = if z < x { (z, x) } else { (x, z) };
                cost[p * l + q] = value;
            }
            for z in 0..l {
                if alive[live[z]]
                    && (z == x
                        || minima[z].1 == x
                        || minima[z].1 == y
                        || (z < x && cost[z * l + x] < minima[z].0))
                {
                    minima[z] = row_min(&cost, &alive, z);
                }
            }
        }
    }
    let find = |mut c: usize| {
        while parent[c] != c {
            c = parent[c];
        }
        c
    };
    (0..m).map(find).collect()
}
