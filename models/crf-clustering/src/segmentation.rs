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
use pgm_features::scan::segment_by_gap;
use pgm_features::RigidAlignment;

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
    stats.solve().map_or(0.0, |a| a.residual.max(0.0))
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
    // Segments without evidence join the nearest segment with some (beam order).
    let has: Vec<bool> = stats.iter().map(|s| !s.is_empty()).collect();
    let mut owner: Vec<usize> = (0..count).collect();
    if !has.iter().any(|h| *h) {
        return (vec![0; n], 1);
    }
    for s in 0..count {
        if has[s] {
            continue;
        }
        let before = (0..s).rev().find(|&t| has[t]);
        let after = (s + 1..count).find(|&t| has[t]);
        owner[s] = match (before, after) {
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
        };
    }
    // Agglomerative merging of the segments with evidence.
    let alive_ids: Vec<usize> = (0..count).filter(|&s| has[s]).collect();
    let m = alive_ids.len();
    let mut cluster_stats: Vec<RigidAlignment> =
        alive_ids.iter().map(|&s| stats[s].clone()).collect();
    let mut cluster_residual: Vec<f64> = cluster_stats.iter().map(residual).collect();
    let mut alive = vec![true; m];
    let mut parent: Vec<usize> = (0..m).collect();
    let merge_cost = |a: &RigidAlignment, ra: f64, b: &RigidAlignment, rb: f64| {
        let mut both = a.clone();
        both.merge(b);
        residual(&both) - ra - rb
    };
    let mut remaining = m;
    let cap = max_clusters.max(1);
    if remaining > cap {
        let mut cost = vec![f64::INFINITY; m * m];
        for a in 0..m {
            for b in a + 1..m {
                cost[a * m + b] = merge_cost(
                    &cluster_stats[a],
                    cluster_residual[a],
                    &cluster_stats[b],
                    cluster_residual[b],
                );
            }
        }
        // Row minima (over partners with a larger index), kept up to date, so a merge
        // costs O(m) except for the rows whose minimum it invalidates.
        let row_min = |cost: &[f64], alive: &[bool], a: usize| {
            let mut best = (f64::INFINITY, a);
            for b in a + 1..m {
                if alive[b] && cost[a * m + b] < best.0 {
                    best = (cost[a * m + b], b);
                }
            }
            best
        };
        let mut minima: Vec<(f64, usize)> = (0..m).map(|a| row_min(&cost, &alive, a)).collect();
        while remaining > cap {
            let mut best = (f64::INFINITY, 0, 0);
            for a in 0..m {
                if alive[a] && minima[a].0 < best.0 {
                    best = (minima[a].0, a, minima[a].1);
                }
            }
            let (_, a, b) = best;
            if a == b {
                break;
            }
            let other = cluster_stats[b].clone();
            cluster_stats[a].merge(&other);
            cluster_residual[a] = residual(&cluster_stats[a]);
            alive[b] = false;
            parent[b] = a;
            remaining -= 1;
            for c in 0..m {
                if c == a || !alive[c] {
                    continue;
                }
                let value = merge_cost(
                    &cluster_stats[a],
                    cluster_residual[a],
                    &cluster_stats[c],
                    cluster_residual[c],
                );
                let (x, y) = if c < a { (c, a) } else { (a, c) };
                cost[x * m + y] = value;
            }
            for c in 0..m {
                if alive[c]
                    && (c == a
                        || minima[c].1 == a
                        || minima[c].1 == b
                        || (c < a && cost[c * m + a] < minima[c].0))
                {
                    minima[c] = row_min(&cost, &alive, c);
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
    let mut segment_cluster = vec![0usize; count];
    for (c, &s) in alive_ids.iter().enumerate() {
        segment_cluster[s] = find(c);
    }
    let mut labels: Vec<usize> = (0..n)
        .map(|i| segment_cluster[owner[segments[i]]])
        .collect();
    let k = relabel_by_first_appearance(&mut labels);
    (labels, k)
}
