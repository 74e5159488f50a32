//! Residual belief propagation (Elidan, McGraw and Koller, 2006): always commit the
//! message whose recomputation would change it most.
//!
//! With damping a commit moves a message only part of the way to its candidate, so
//! the committed edge keeps the rest of its residual in the queue
//! ([`MessagePasser::commit_candidate_pending`]): damping changes the path to the
//! fixed point, never the fixed point, and a damped run cannot stop half-way.

use super::{MessagePasser, Schedule};
use crate::graph::{EdgeId, FactorId};

/// Residual BP. Each iteration commits up to as many messages as the graph has edges,
/// largest residual first; after a commit, the messages that read the changed one are
/// recomputed and re-queued. An iteration ends early when the largest pending residual
/// is within the engine's tolerance, and reports that residual as the fixed-point
/// residual. Ties go to the lowest edge id, so runs are deterministic.
#[derive(Clone, Debug, Default)]
pub struct Residual {
    heap: IndexedMaxHeap,
    initialised: bool,
}

impl Schedule for Residual {
    fn name(&self) -> &str {
        "residual"
    }

    fn prepare(&mut self, graph: &crate::FactorGraph) -> crate::Result<()> {
        self.heap = IndexedMaxHeap::new(graph.num_edges());
        self.initialised = false;
        Ok(())
    }

    fn iteration(&mut self, passer: &mut dyn MessagePasser) -> Option<f64> {
        let num_edges = passer.graph().num_edges();
        if self.heap.positions.len() != num_edges {
            self.heap = IndexedMaxHeap::new(num_edges);
            self.initialised = false;
        }
        if !self.initialised {
            for e in 0..num_edges {
                let r = passer.compute_candidate(EdgeId(e));
                self.heap.set(e, r);
            }
            self.initialised = true;
        }
        let tolerance = passer.tolerance();
        let mut affected: Vec<EdgeId> = Vec::new();
        for step in 0..num_edges {
            let Some((e, r)) = self.heap.top() else { break };
            if r <= tolerance {
                break;
            }
            if step % 1024 == 1023 && passer.out_of_time() {
                break;
            }
            let e = EdgeId(e);
            let pending = passer.commit_candidate_pending(e);
            self.heap.set(e.0, pending);
            // Messages that read the changed message: every other factor of the target
            // variable, towards that factor's other variables.
            affected.clear();
            {
                let graph = passer.graph();
                let v = graph.edge_variable(e);
                let a = graph.edge_factor(e);
                for &e2 in graph.variable_edges(v) {
                    let b: FactorId = graph.edge_factor(e2);
                    if b == a {
                        continue;
                    }
                    affected.extend(graph.factor_edges(b).map(EdgeId).filter(|&e3| e3 != e2));
                }
            }
            for &e3 in &affected {
                let r3 = passer.compute_candidate(e3);
                self.heap.set(e3.0, r3);
            }
        }
        Some(self.heap.top().map_or(0.0, |(_, r)| r))
    }
}

/// A 4-ary max-heap over edge ids with updatable priorities: half the depth of a
/// binary heap, and a node's four children share one cache line. Priorities are
/// stored as the bits of their absolute value, which order like the numbers for
/// non-negative values (+∞ above every number, NaN above +∞, so that a NaN surfaces
/// instead of hiding); sifts move a hole instead of swapping.
#[derive(Clone, Debug, Default)]
struct IndexedMaxHeap {
    /// (priority key, edge) pairs in heap order.
    heap: Vec<(u64, usize)>,
    /// Heap position of each edge, `usize::MAX` when absent.
    positions: Vec<usize>,
}

impl IndexedMaxHeap {
    fn new(n: usize) -> Self {
        Self {
            heap: Vec::with_capacity(n),
            positions: vec![usize::MAX; n],
        }
    }

    /// The order key of a priority (residuals are never negative; a negative value
    /// counts as its absolute value).
    #[inline]
    fn key(priority: f64) -> u64 {
        priority.abs().to_bits()
    }

    #[inline]
    fn priority(key: u64) -> f64 {
        f64::from_bits(key)
    }

    /// Higher priority first; equal priorities: lower edge id first.
    #[inline]
    fn before(a: (u64, usize), b: (u64, usize)) -> bool {
        a.0 > b.0 || (a.0 == b.0 && a.1 < b.1)
    }

    fn top(&self) -> Option<(usize, f64)> {
        self.heap.first().map(|&(k, e)| (e, Self::priority(k)))
    }

    /// Sets an edge's priority; a priority of 0 takes the edge out of the heap (such an
    /// edge is never committed, and a smaller heap is cheaper to sift).
    fn set(&mut self, edge: usize, priority: f64) {
        let item = (Self::key(priority), edge);
        if item.0 == 0 {
            self.remove(edge);
            return;
        }
        let pos = self.positions[edge];
        if pos == usize::MAX {
            self.heap.push(item);
            self.sift_up(self.heap.len() - 1, item);
        } else {
            let old = self.heap[pos];
            if Self::before(item, old) {
                self.sift_up(pos, item);
            } else {
                self.sift_down(pos, item);
            }
        }
    }

    fn remove(&mut self, edge: usize) {
        let pos = self.positions[edge];
        if pos == usize::MAX {
            return;
        }
        self.positions[edge] = usize::MAX;
        let Some(last) = self.heap.pop() else { return };
        if pos == self.heap.len() {
            return;
        }
        // The last element fills the hole, moving up or down from there.
        if pos > 0 && Self::before(last, self.heap[(pos - 1) / 4]) {
            self.sift_up(pos, last);
        } else {
            self.sift_down(pos, last);
        }
    }

    /// Puts `item` in slot `i` and records its position.
    #[inline]
    fn place(&mut self, i: usize, item: (u64, usize)) {
        self.heap[i] = item;
        self.positions[item.1] = i;
    }

    /// Places `item` at the hole `i` or above it.
    #[inline]
    fn sift_up(&mut self, mut i: usize, item: (u64, usize)) {
        while i > 0 {
            let parent = (i - 1) / 4;
            let p = self.heap[parent];
            if !Self::before(item, p) {
                break;
            }
            self.place(i, p);
            i = parent;
        }
        self.place(i, item);
    }

    /// Places `item` at the hole `i` or below it.
    #[inline]
    fn sift_down(&mut self, mut i: usize, item: (u64, usize)) {
        let n = self.heap.len();
        loop {
            let first = 4 * i + 1;
            if first >= n {
                break;
            }
            let last = (first + 4).min(n);
            let mut best = first;
            let mut best_item = self.heap[first];
            for c in first + 1..last {
                let candidate = self.heap[c];
                if Self::before(candidate, best_item) {
                    best = c;
                    best_item = candidate;
                }
            }
            if !Self::before(best_item, item) {
                break;
            }
            self.place(i, best_item);
            i = best;
        }
        self.place(i, item);
    }
}

#[cfg(test)]
mod tests {
    use super::IndexedMaxHeap;

    #[test]
    fn heap_orders_like_a_sort() {
        // Random priorities (with ties, zeros, +∞) and updates: the top is always the
        // largest priority, lowest edge id among ties.
        let mut h = IndexedMaxHeap::new(200);
        let mut current = vec![None; 200];
        let mut state = 12345u64;
        for step in 0..5000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let edge = (state >> 33) as usize % 200;
            let priority = match (state >> 20) % 7 {
                0 => 0.0,
                1 => f64::INFINITY,
                2 => 1.5,
                _ => ((state >> 40) % 1000) as f64 / 7.0,
            };
            h.set(edge, priority);
            current[edge] = Some(priority);
            let expected = current
                .iter()
                .enumerate()
                .filter_map(|(e, p)| p.filter(|&p| p > 0.0).map(|p| (e, p)))
                .fold(None, |best: Option<(usize, f64)>, (e, p)| match best {
                    Some((_, q)) if q >= p => best,
                    _ => Some((e, p)),
                });
            assert_eq!(h.top(), expected, "step {step}");
        }
    }

    #[test]
    fn heap_orders_and_updates() {
        let mut h = IndexedMaxHeap::new(5);
        for (e, p) in [(0, 1.0), (1, 5.0), (2, 3.0), (3, 5.0), (4, 0.5)] {
            h.set(e, p);
        }
        assert_eq!(h.top(), Some((1, 5.0)));
        h.set(1, 0.0);
        assert_eq!(h.top(), Some((3, 5.0)));
        h.set(3, 0.0);
        h.set(4, 9.0);
        assert_eq!(h.top(), Some((4, 9.0)));
    }
}
