//! The arithmetic at the heart of grid search: a node's eight tentative step costs and
//! which of them improve on what its neighbours have.
//!
//! Dijkstra and A* spend most of their time here, once per settled cell. On x86-64 the
//! eight candidates are evaluated two at a time with SSE2 (part of every x86-64 CPU, so
//! no feature detection is needed); elsewhere one at a time. Both do the same f64
//! operations in the same order, so they give the same bits, and a test holds them to it.

const SQRT_2: f64 = std::f64::consts::SQRT_2;

/// Marks a settled node in `Node::link`; the other bits hold the parent's index.
pub const CLOSED: u32 = 1 << 31;
pub const NO_PARENT: u32 = CLOSED - 1;

/// Everything a search reads and writes about one cell, side by side so that looking
/// at a neighbour touches one cache line. `repr(C)`: the vector path loads a node as two
/// 8-byte lanes, `dist` then `half` and `link`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Node {
    /// Cost from the sources; ∞ until reached.
    pub dist: f64,
    /// Half the cell's cost (edge cost = length × (half_u + half_v)); ∞ when blocked.
    /// Halving an f32 is exact.
    pub half: f32,
    /// Parent index (or `NO_PARENT`) plus the `CLOSED` bit.
    pub link: u32,
}

impl Node {
    pub const BLOCKED: Node = Node {
        dist: f64::INFINITY,
        half: f32::INFINITY,
        link: NO_PARENT,
    };
}

/// Neighbour `k`'s offset from a node in a grid whose rows are `row` nodes long, in the
/// processing order that breaks ties: the four orthogonal neighbours (up, left, right,
/// down), then the corners (up-left, up-right, down-left, down-right).
#[inline(always)]
pub fn neighbours(u: usize, row: usize) -> [usize; 8] {
    let (up, down) = (u - row, u + row);
    [up, u - 1, u + 1, down, up - 1, up + 1, down - 1, down + 1]
}

/// How long the steps out of one row's cells are, in units of the grid's shortest step
/// (`StepLengths`): along the row, and straight and diagonally to the row before
/// (index − 1) and the row after. 1, 1 and √2 on square cells; rectangles where a
/// raster's cells are not square; and different from row to row in degrees, where a
/// degree of longitude shortens away from the equator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowSteps {
    pub x: f64,
    /// Straight to the row before and the row after.
    pub y: [f64; 2],
    /// Diagonally to the row before and the row after.
    pub diagonal: [f64; 2],
}

impl RowSteps {
    pub const SQUARE: RowSteps = RowSteps {
        x: 1.0,
        y: [1.0; 2],
        diagonal: [SQRT_2; 2],
    };

    /// The steps of cells `metres` = (x, y) on the ground, in units of the shorter side.
    pub fn of_cells(metres: [f64; 2]) -> Self {
        let [mx, my] = metres;
        if (mx - my).abs() <= 1e-9 * mx.max(my) {
            return Self::SQUARE;
        }
        let unit = mx.min(my);
        let (x, y) = (mx / unit, my / unit);
        RowSteps {
            x,
            y: [y; 2],
            diagonal: [x.hypot(y); 2],
        }
    }

    /// Lengths to the neighbours in `neighbours` order.
    pub fn by_neighbour(&self) -> [f64; 8] {
        let (x, [y0, y1], [d0, d1]) = (self.x, self.y, self.diagonal);
        [y0, x, x, y1, d0, d0, d1, d1]
    }
}

/// A node's tentative costs for its eight neighbours (in `neighbours` order), and bit `k`
/// set where neighbour `k`'s cost would go down. Blocked neighbours need no test: their
/// half cost is ∞, so they never improve.
pub struct Candidates {
    pub costs: [f64; 8],
    pub improved: u32,
}

/// Evaluates node `u`'s eight steps.
///
/// # Safety
/// `u` must be an inner cell of a grid of `row`-long rows with at least one row and one
/// column of nodes around it inside `nodes` (the planner's blocked border), so that all
/// its neighbours lie within `nodes`.
#[inline(always)]
pub unsafe fn candidates(nodes: &[Node], row: usize, u: usize, lengths: &RowSteps) -> Candidates {
    debug_assert!(u > row && u + row + 1 < nodes.len());
    #[cfg(target_arch = "x86_64")]
    // SAFETY: as the caller promises.
    unsafe {
        sse2::candidates(nodes, row, u, lengths)
    }
    #[cfg(not(target_arch = "x86_64"))]
    // SAFETY: as the caller promises.
    unsafe {
        candidates_scalar(nodes, row, u, lengths)
    }
}

/// One neighbour at a time: the reference the vector path is tested against, and the
/// path on other architectures.
///
/// # Safety
/// As for `candidates`.
#[inline(always)]
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
pub unsafe fn candidates_scalar(
    nodes: &[Node],
    row: usize,
    u: usize,
    lengths: &RowSteps,
) -> Candidates {
    let lengths = lengths.by_neighbour();
    let du = nodes[u].dist;
    let hu = f64::from(nodes[u].half);
    let mut costs = [0.0f64; 8];
    let mut improved = 0u32;
    for (k, v) in neighbours(u, row).into_iter().enumerate() {
        // SAFETY: the caller promises the neighbours lie within `nodes`.
        let node = unsafe { nodes.get_unchecked(v) };
        costs[k] = du + lengths[k] * (hu + f64::from(node.half));
        improved |= u32::from(costs[k] < node.dist) << k;
    }
    Candidates { costs, improved }
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    use std::arch::x86_64::*;

    use super::{Candidates, Node, RowSteps};

    /// Vector lane of neighbour `k`: lanes run along the row above (up-left, up,
    /// up-right), then left, along the row below, then right, as the loads come.
    const LANE: [usize; 8] = [1, 3, 7, 5, 0, 2, 4, 6];

    /// Lane bit masks reordered into neighbour order, one table lookup per node.
    static LANES_TO_NEIGHBOURS: [u8; 256] = {
        let mut table = [0u8; 256];
        let mut lanes = 0;
        while lanes < 256 {
            let mut k = 0;
            while k < 8 {
                if lanes >> LANE[k] & 1 == 1 {
                    table[lanes] |= 1 << k;
                }
                k += 1;
            }
            lanes += 1;
        }
        table
    };

    /// Costs and halves of nodes `at`, `at + 1` (first pair) and `at + 2`, `side`
    /// (second pair), each pair as two f64 lanes.
    ///
    /// # Safety
    /// The four nodes must lie within the slice `nodes` points into.
    #[inline(always)]
    unsafe fn three_and_one(nodes: *const Node, at: usize, side: usize) -> [(__m128d, __m128d); 2] {
        // SAFETY: in bounds as the caller promises; a Node is 16 bytes, `dist` first
        // (repr(C)), and unaligned loads are allowed.
        unsafe {
            let load = |i: usize| _mm_loadu_pd(nodes.add(i) as *const f64);
            let (n0, n1, n2, ns) = (load(at), load(at + 1), load(at + 2), load(side));
            // The upper lanes hold (half, link) as f32 pairs: keep each `half`.
            let halves = _mm_shuffle_ps::<0b10_00_10_00>(
                _mm_castpd_ps(_mm_unpackhi_pd(n0, n1)),
                _mm_castpd_ps(_mm_unpackhi_pd(n2, ns)),
            );
            [
                (_mm_unpacklo_pd(n0, n1), _mm_cvtps_pd(halves)),
                (
                    _mm_unpacklo_pd(n2, ns),
                    _mm_cvtps_pd(_mm_movehl_ps(halves, halves)),
                ),
            ]
        }
    }

    /// # Safety
    /// As for `super::candidates`.
    #[inline(always)]
    pub unsafe fn candidates(
        nodes: &[Node],
        row: usize,
        u: usize,
        lengths: &RowSteps,
    ) -> Candidates {
        let p = nodes.as_ptr();
        // SAFETY: as the caller promises, every node read lies within `nodes`.
        unsafe {
            let du = _mm_set1_pd((*p.add(u)).dist);
            let hu = _mm_set1_pd(f64::from((*p.add(u)).half));
            // Both pairs of a row are a corner, then an orthogonal neighbour: above and
            // below along y in the first pair, left and right along x in the second.
            let pair_lengths = [0, 1].map(|r| {
                [
                    _mm_setr_pd(lengths.diagonal[r], lengths.y[r]),
                    _mm_setr_pd(lengths.diagonal[r], lengths.x),
                ]
            });
            let (up, down) = (u - row, u + row);
            let rows = [
                three_and_one(p, up - 1, u - 1),
                three_and_one(p, down - 1, u + 1),
            ];
            let mut by_lane = [0.0f64; 8];
            let mut lanes = 0;
            for (r, pairs) in rows.into_iter().enumerate() {
                for (j, (dist, half)) in pairs.into_iter().enumerate() {
                    let lane = 4 * r + 2 * j;
                    // du + length × (hu + half): the scalar path's operations, in order.
                    let length = pair_lengths[r][j];
                    let cost = _mm_add_pd(du, _mm_mul_pd(length, _mm_add_pd(hu, half)));
                    _mm_storeu_pd(by_lane.as_mut_ptr().add(lane), cost);
                    lanes |= _mm_movemask_pd(_mm_cmplt_pd(cost, dist)) << lane;
                }
            }
            // A plain loop: `LANE.map` is left as a call, a fifth of the search's time.
            let mut costs = [0.0f64; 8];
            for (cost, lane) in costs.iter_mut().zip(LANE) {
                *cost = by_lane[lane];
            }
            Candidates {
                costs,
                improved: u32::from(LANES_TO_NEIGHBOURS[lanes as usize]),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn node() -> impl Strategy<Value = Node> {
        let half = prop_oneof![4 => 0.05f32..5.0, 1 => Just(f32::INFINITY)];
        let dist = prop_oneof![3 => 0.0f64..100.0, 1 => Just(f64::INFINITY)];
        (dist, half, any::<u32>()).prop_map(|(dist, half, link)| Node { dist, half, link })
    }

    proptest! {
        #[test]
        fn the_vector_path_gives_the_scalar_paths_bits(
            nodes in prop::collection::vec(node(), 25),
            x in 1.0f64..3.0,
            y in 1.0f64..3.0,
            y_after in 1.0f64..3.0,
        ) {
            // A 5 × 5 block: every inner node has its eight neighbours.
            let uneven = RowSteps {
                x,
                y: [y, y_after],
                diagonal: [x.hypot(y), (0.9 * x).hypot(y_after)],
            };
            for lengths in [RowSteps::SQUARE, RowSteps::of_cells([x, y]), uneven] {
                for u in [6, 7, 8, 11, 12, 13, 16, 17, 18] {
                    // SAFETY: inner nodes of a 5-wide block.
                    let (fast, reference) = unsafe {
                        (
                            candidates(&nodes, 5, u, &lengths),
                            candidates_scalar(&nodes, 5, u, &lengths),
                        )
                    };
                    prop_assert_eq!(fast.improved, reference.improved);
                    prop_assert_eq!(
                        fast.costs.map(f64::to_bits),
                        reference.costs.map(f64::to_bits)
                    );
                }
            }
        }
    }

    #[test]
    fn rectangular_cells_step_in_units_of_the_shorter_side() {
        assert_eq!(RowSteps::of_cells([30.0, 30.0]), RowSteps::SQUARE);
        let steps = RowSteps::of_cells([2.0, 1.0]);
        assert_eq!((steps.x, steps.y), (2.0, [1.0; 2]));
        assert!((steps.diagonal[1] - 5f64.sqrt()).abs() < 1e-15);
        assert_eq!(steps.by_neighbour()[..4], [1.0, 2.0, 2.0, 1.0]);
    }

    #[test]
    fn neighbours_come_orthogonal_first() {
        assert_eq!(neighbours(12, 5), [7, 11, 13, 17, 6, 8, 16, 18]);
    }
}
