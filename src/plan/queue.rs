//! Priority queues for Dijkstra with non-negative f64 keys.
//!
//! `Buckets` is Dinitz's bucket queue: with bucket width δ no larger than the smallest
//! edge cost, every node in the lowest non-empty bucket already has its final distance,
//! so buckets are emptied without comparisons. It needs as many buckets
//! as (largest edge / smallest edge), so `MinQueue::new` falls back to a binary heap when
//! costs span too wide a range.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The most buckets worth allocating before a binary heap is the better queue.
const MAX_BUCKETS: f64 = 65_536.0;

pub enum MinQueue {
    Buckets(Buckets),
    Heap(BinaryHeap<Reverse<(u64, u32)>>),
}

impl MinQueue {
    /// A queue for edge costs in [min_edge, max_edge].
    pub fn new(min_edge: f64, max_edge: f64) -> Self {
        let ratio = max_edge / min_edge;
        if min_edge > 0.0 && ratio.is_finite() && ratio < MAX_BUCKETS {
            // A hair narrower than the smallest edge, so rounding never puts a
            // relaxed node back into the bucket being emptied.
            let width = min_edge * (1.0 - 1e-9);
            // A power of two, so that the slot of a bucket is a mask away.
            let count = ((max_edge / width).ceil() as usize + 2).next_power_of_two();
            MinQueue::Buckets(Buckets {
                inverse_width: 1.0 / width,
                slots: vec![Vec::new(); count],
                mask: count - 1,
                cursor: 0,
                pending: 0,
            })
        } else {
            MinQueue::Heap(BinaryHeap::new())
        }
    }

    #[inline(always)]
    pub fn push(&mut self, key: f64, node: u32) {
        match self {
            MinQueue::Buckets(b) => b.push(key, node),
            // Non-negative f64s order like their bit patterns.
            MinQueue::Heap(h) => h.push(Reverse((key.to_bits(), node))),
        }
    }

    /// Removes a node of smallest key (last in, first out within a bucket, whose nodes
    /// all have final keys; by key then node index in the heap). Stale entries are the
    /// caller's to skip.
    #[inline]
    pub fn pop(&mut self) -> Option<u32> {
        match self {
            MinQueue::Buckets(b) => b.pop(),
            MinQueue::Heap(h) => h.pop().map(|Reverse((_, node))| node),
        }
    }
}

pub struct Buckets {
    inverse_width: f64,
    slots: Vec<Vec<u32>>,
    mask: usize,
    /// Index (not slot) of the bucket being emptied; slots are used circularly.
    cursor: usize,
    pending: usize,
}

impl Buckets {
    #[inline(always)]
    fn push(&mut self, key: f64, node: u32) {
        let bucket = ((key * self.inverse_width) as usize).max(self.cursor);
        self.slots[bucket & self.mask].push(node);
        self.pending += 1;
    }

    fn pop(&mut self) -> Option<u32> {
        if self.pending == 0 {
            return None;
        }
        loop {
            if let Some(node) = self.slots[self.cursor & self.mask].pop() {
                self.pending -= 1;
                return Some(node);
            }
            self.cursor += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_queues_pop_in_key_order_across_buckets() {
        let buckets = MinQueue::new(1.0, 3.0);
        let heap = MinQueue::new(1e-9, 1e9);
        assert!(matches!(buckets, MinQueue::Buckets(_)));
        assert!(matches!(heap, MinQueue::Heap(_)));
        for mut q in [buckets, heap] {
            // As Dijkstra uses it: every key pushed is at most the largest edge (3)
            // above the key last popped.
            q.push(2.5, 1);
            q.push(0.0, 0);
            q.push(1.0, 2);
            assert_eq!(q.pop(), Some(0));
            assert_eq!(q.pop(), Some(2));
            q.push(3.5, 3);
            q.push(1.5, 4);
            let order: Vec<u32> = std::iter::from_fn(|| q.pop()).collect();
            assert_eq!(order, [4, 1, 3]);
        }
    }
}
