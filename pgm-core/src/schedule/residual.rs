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
/// binary heap, and a node's four children share one cache line.
#[derive(Clone, Debug, Default)]
struct IndexedMaxHeap {
    /// (priority, edge) pairs in heap order.
    heap: Vec<(f64, usize)>,
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

    /// Higher priority first; equal priorities: lower edge id first. NaN sorts highest
    /// so that it surfaces instead of hiding.
    fn before(a: (f64, usize), b: (f64, usize)) -> bool {
        if a.0 != b.0 {
            a.0 > b.0 || a.0.is_nan()
        } else {
            a.1 < b.1
        }
    }

    fn top(&self) -> Option<(usize, f64)> {
        self.heap.first().map(|&(p, e)| (e, p))
    }

    fn set(&mut self, edge: usize, priority: f64) {
        let pos = self.positions[edge];
        if pos == usize::MAX {
            self.heap.push((priority, edge));
            let i = self.heap.len() - 1;
            self.positions[edge] = i;
            self.sift_up(i);
        } else {
            let old = self.heap[pos].0;
            self.heap[pos].0 = priority;
            if Self::before((priority, edge), (old, edge)) {
                self.sift_up(pos);
            } else {
                self.sift_down(pos);
            }
        }
    }

    fn swap(&mut self, i: usize, j: usize) {
        self.heap.swap(i, j);
        self.positions[self.heap[i].1] = i;
        self.positions[self.heap[j].1] = j;
    }

    fn sift_up(&mut self, mut i: usize) {
        while i > 0 {
            let parent = (i - 1) / 4;
            if Self::before(self.heap[i], self.heap[parent]) {
                self.swap(i, parent);
                i = parent;
            } else {
                break;
            }
        }
    }

    fn sift_down(&mut self, mut i: usize) {
        let n = self.heap.len();
        loop {
            let first = 4 * i + 1;
            let mut best = i;
            for c in first..(first + 4).min(n) {
                if Self::before(self.heap[c], self.heap[best]) {
                    best = c;
                }
            }
            if best == i {
                break;
            }
            self.swap(i, best);
            i = best;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::IndexedMaxHeap;

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
