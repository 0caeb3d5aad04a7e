//! The maximum-entropy distribution over grid paths to a goal (Ziebart et al. 2008):
//! P(path) ∝ exp(−cost(path)) over the 8-connected paths (corner cutting allowed, edge
//! cost = step length × mean of the two cells' costs, as the planner) that reach the goal
//! within a horizon of T steps and end there.
//!
//! Why a horizon: over all paths the partition function diverges as soon as cells cost
//! less than about ln 8 per step, because loops then gain weight faster than they pay
//! for it; learned costs near 1 do. With at most T steps it is always finite, and T a
//! small multiple of a demonstration's length keeps the detours that matter.
//!
//! Backward: V_k(x), the soft cost-to-go from x with at most k steps left (V_0 = 0 at the
//! goal, ∞ elsewhere; V_k(goal) = 0 as paths end there), V_k(x) = softmin over moves of
//! edge + V_{k−1}(next). Forward: the start's unit mass follows the policy
//! π_k(a | x) = exp(V_k(x) − edge − V_{k−1}(next)) and is absorbed at the goal. Everything
//! is computed on a window of the map, which keeps each example's cost in proportion to
//! its neighbourhood rather than to the map.

use crate::grid::{Cell, Grid};
use crate::plan::StepLengths;

/// Moves: (row, column) offset, orthogonal first; their lengths come from the map's
/// cells (`StepLengths`), as the planner's.
const MOVES: [(i32, i32); 8] = [
    (-1, 0),
    (0, -1),
    (0, 1),
    (1, 0),
    (-1, -1),
    (-1, 1),
    (1, -1),
    (1, 1),
];

/// A rectangle of a map's cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    pub row0: u32,
    pub col0: u32,
    pub rows: u32,
    pub cols: u32,
}

impl Window {
    /// The bounding box of `cells`, grown by `margin` cells and clipped to the map.
    pub fn around(cells: &[Cell], margin: u32, width: u32, height: u32) -> Self {
        let (mut r0, mut c0, mut r1, mut c1) = (u32::MAX, u32::MAX, 0, 0);
        for c in cells {
            r0 = r0.min(c.row);
            c0 = c0.min(c.col);
            r1 = r1.max(c.row);
            c1 = c1.max(c.col);
        }
        let (r0, c0) = (r0.saturating_sub(margin), c0.saturating_sub(margin));
        let r1 = (r1 + margin).min(height - 1);
        let c1 = (c1 + margin).min(width - 1);
        Window {
            row0: r0,
            col0: c0,
            rows: r1 - r0 + 1,
            cols: c1 - c0 + 1,
        }
    }

    pub fn len(&self) -> usize {
        self.rows as usize * self.cols as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn contains(&self, cell: Cell) -> bool {
        (self.row0..self.row0 + self.rows).contains(&cell.row)
            && (self.col0..self.col0 + self.cols).contains(&cell.col)
    }

    /// Index of a cell inside the window (row-major).
    pub fn index(&self, cell: Cell) -> usize {
        (cell.row - self.row0) as usize * self.cols as usize + (cell.col - self.col0) as usize
    }

    pub fn cell(&self, index: usize) -> Cell {
        let cols = self.cols as usize;
        Cell::new(
            self.row0 + (index / cols) as u32,
            self.col0 + (index % cols) as u32,
        )
    }

    /// The window's neighbour of `index` by move `m`, with the move's length.
    fn step(&self, index: usize, m: usize, lengths: &StepLengths) -> Option<(usize, f64)> {
        let (dr, dc) = MOVES[m];
        let cols = self.cols as i64;
        let (r, c) = (
            (index as i64) / cols + dr as i64,
            (index as i64) % cols + dc as i64,
        );
        (r >= 0 && c >= 0 && r < self.rows as i64 && c < cols).then(|| {
            let next = (r * cols + c) as usize;
            (next, lengths.between(self.cell(index), self.cell(next)))
        })
    }
}

/// Soft values towards one goal on one window.
pub struct SoftGoal {
    window: Window,
    /// For cell x and move m at x * 8 + m: the neighbour (x itself where the move
    /// leaves the window), the step's cost (∞ where blocked or outside) and its length,
    /// so that the passes are straight loops without tests.
    next: Vec<u32>,
    edge: Vec<f64>,
    length: Vec<f64>,
    goal: usize,
    goal_cell: Cell,
    /// The one start the passes are restricted to, if any (see `SoftGoal::between`).
    start: Option<Cell>,
    horizon: usize,
    /// V_k for k = 0..=settled, each on the cells the passes can read (∞ elsewhere).
    values: Vec<Layer>,
    /// The first k from which V_k no longer changes (to 1e-13): V_k = V_settled for
    /// every k above, so the backward pass stops there and the forward pass reuses one
    /// policy. Cheap paths (cells costing less than about ln 8 per step) never settle:
    /// their loops keep gaining weight, and the horizon is what bounds them.
    settled: usize,
}

/// Values on a rectangle of window cells.
struct Layer {
    rect: Rect,
    data: Vec<f64>,
}

/// Window rows r0..r1 and columns c0..c1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Rect {
    r0: u32,
    r1: u32,
    c0: u32,
    c1: u32,
}

impl Rect {
    const EMPTY: Rect = Rect {
        r0: 0,
        r1: 0,
        c0: 0,
        c1: 0,
    };

    /// The window cells within `k` moves (Chebyshev distance) of `center`: only they
    /// can hold finite values after k backward steps, or mass after k forward ones.
    fn ball(window: &Window, center: Cell, k: usize) -> Rect {
        let k = k.min(u32::MAX as usize / 2) as u32;
        let (r, c) = (center.row - window.row0, center.col - window.col0);
        Rect {
            r0: r.saturating_sub(k),
            r1: r.saturating_add(k).saturating_add(1).min(window.rows),
            c0: c.saturating_sub(k),
            c1: c.saturating_add(k).saturating_add(1).min(window.cols),
        }
    }

    fn intersect(self, other: Rect) -> Rect {
        Rect {
            r0: self.r0.max(other.r0),
            r1: self.r1.min(other.r1),
            c0: self.c0.max(other.c0),
            c1: self.c1.min(other.c1),
        }
    }

    fn is_empty(&self) -> bool {
        self.r0 >= self.r1 || self.c0 >= self.c1
    }

    fn len(&self) -> usize {
        if self.is_empty() {
            0
        } else {
            (self.r1 - self.r0) as usize * (self.c1 - self.c0) as usize
        }
    }

    fn covers(&self, other: Rect) -> bool {
        other.is_empty()
            || (self.r0 <= other.r0
                && other.r1 <= self.r1
                && self.c0 <= other.c0
                && other.c1 <= self.c1)
    }

    /// Window indices of the cells, row-major.
    fn indices(self, width: u32) -> impl Iterator<Item = usize> {
        self.rows(width).flatten()
    }

    /// Window indices of each row's cells: what the hot loops walk, two plain loops
    /// rather than one flattened iterator.
    fn rows(self, width: u32) -> impl Iterator<Item = std::ops::Range<usize>> {
        let (c0, c1) = if self.is_empty() {
            (0, 0)
        } else {
            (self.c0 as usize, self.c1 as usize)
        };
        (self.r0..self.r1).map(move |row| {
            let base = row as usize * width as usize;
            base + c0..base + c1
        })
    }

    /// Position of window index `x` in the rectangle's data, if inside.
    fn offset(&self, x: usize, width: u32) -> Option<usize> {
        let (row, col) = ((x / width as usize) as u32, (x % width as usize) as u32);
        ((self.r0..self.r1).contains(&row) && (self.c0..self.c1).contains(&col)).then(|| {
            (row - self.r0) as usize * (self.c1 - self.c0) as usize + (col - self.c0) as usize
        })
    }
}

/// e^x, as the passes need it: within a few ulp of the exact value for x in [−708, 709]
/// and exactly 0 below (a step the goal cannot be reached through weighs nothing).
///
/// The passes spend most of their time in exponentials. This one is plain f64
/// arithmetic, the same bits on every machine (libm picks an FMA variant or not at run
/// time), and short: x = (64m + j) ln 2 / 64 + r with |r| ≤ ln 2 / 128, e^x = 2^m ·
/// 2^(j/64) · e^r, the 64 powers 2^(j/64) from a table (correctly rounded) and e^r by
/// its Taylor series to r⁵ (truncation below 4e-17). The integer k = 64m + j comes out
/// of the rounding constant's low mantissa bits, so no float-to-integer conversion.
#[inline(always)]
fn exp(x: f64) -> f64 {
    const ROUND: f64 = 6_755_399_441_055_744.0; // 1.5 × 2^52: adding it rounds to integers
    const STEPS_PER_UNIT: f64 = 92.332_482_616_893_66; // 64 / ln 2
    // ln 2 / 64 in two parts; the first has 33 significant bits, so k times it is exact.
    const STEP_HI: f64 = 0.010_830_424_696_905_538;
    const STEP_LO: f64 = -6.563_929_801_064_195e-13;
    const POWERS: [u64; 64] = [
        0x3ff0000000000000,
        0x3ff02c9a3e778061,
        0x3ff059b0d3158574,
        0x3ff0874518759bc8,
        0x3ff0b5586cf9890f,
        0x3ff0e3ec32d3d1a2,
        0x3ff11301d0125b51,
        0x3ff1429aaea92de0,
        0x3ff172b83c7d517b,
        0x3ff1a35beb6fcb75,
        0x3ff1d4873168b9aa,
        0x3ff2063b88628cd6,
        0x3ff2387a6e756238,
        0x3ff26b4565e27cdd,
        0x3ff29e9df51fdee1,
        0x3ff2d285a6e4030b,
        0x3ff306fe0a31b715,
        0x3ff33c08b26416ff,
        0x3ff371a7373aa9cb,
        0x3ff3a7db34e59ff7,
        0x3ff3dea64c123422,
        0x3ff4160a21f72e2a,
        0x3ff44e086061892d,
        0x3ff486a2b5c13cd0,
        0x3ff4bfdad5362a27,
        0x3ff4f9b2769d2ca7,
        0x3ff5342b569d4f82,
        0x3ff56f4736b527da,
        0x3ff5ab07dd485429,
        0x3ff5e76f15ad2148,
        0x3ff6247eb03a5585,
        0x3ff6623882552225,
        0x3ff6a09e667f3bcd,
        0x3ff6dfb23c651a2f,
        0x3ff71f75e8ec5f74,
        0x3ff75feb564267c9,
        0x3ff7a11473eb0187,
        0x3ff7e2f336cf4e62,
        0x3ff82589994cce13,
        0x3ff868d99b4492ed,
        0x3ff8ace5422aa0db,
        0x3ff8f1ae99157736,
        0x3ff93737b0cdc5e5,
        0x3ff97d829fde4e50,
        0x3ff9c49182a3f090,
        0x3ffa0c667b5de565,
        0x3ffa5503b23e255d,
        0x3ffa9e6b5579fdbf,
        0x3ffae89f995ad3ad,
        0x3ffb33a2b84f15fb,
        0x3ffb7f76f2fb5e47,
        0x3ffbcc1e904bc1d2,
        0x3ffc199bdd85529c,
        0x3ffc67f12e57d14b,
        0x3ffcb720dcef9069,
        0x3ffd072d4a07897c,
        0x3ffd5818dcfba487,
        0x3ffda9e603db3285,
        0x3ffdfc97337b9b5f,
        0x3ffe502ee78b3ff6,
        0x3ffea4afa2a490da,
        0x3ffefa1bee615a27,
        0x3fff50765b6e4540,
        0x3fffa7c1819e90d8,
    ];
    let clamped = x.clamp(-708.0, 709.0);
    let shifted = clamped * STEPS_PER_UNIT + ROUND;
    let k = shifted - ROUND;
    let r = (clamped - k * STEP_HI) - k * STEP_LO;
    let bits = shifted.to_bits();
    let power = f64::from_bits(POWERS[(bits & 63) as usize]);
    // 2^m, m = ⌊k / 64⌋: the rounded sum's bits end in k (two's complement) above a
    // base divisible by 64, so shifting out j and adding the bias leaves the exponent.
    let two_to_m = f64::from_bits(((bits >> 6).wrapping_add(1023)) << 52);
    let r2 = r * r;
    let series_minus_one = r + r2 * (0.5 + r * (1.0 / 6.0) + r2 * (1.0 / 24.0 + r * (1.0 / 120.0)));
    let result = (power + power * series_minus_one) * two_to_m;
    if x < -708.0 { 0.0 } else { result }
}

/// ln s for s in [1, 8]: the sum of a cell's eight move terms, of which the largest is
/// 1 (`soft_min`). libm's logarithm, like its exponential, picks an FMA variant or not
/// at run time and may round a last bit differently on another CPU; this one is plain
/// f64 arithmetic, the same bits on every machine, and as fast (the passes are bound by
/// the eight exponentials): s = 2^e · m, m in [1, 2), c = 1 + j/128 the mantissa's
/// first seven bits, ln s = e ln 2 + ln c + ln(1 + r) with r = (m − c)/c in [0, 2⁻⁷)
/// (m − c is exact; 1/c correctly rounded at compile time), ln c from a table
/// (correctly rounded) and ln(1 + r) by its series to r⁸ (truncation below 2e-18 of r).
/// Exactly 0 at 1, so a cell with one way to the goal keeps its value.
#[inline(always)]
fn ln_of_sum(s: f64) -> f64 {
    // ln 2 in two parts; the first has 32 significant bits, so e times it is exact.
    const LN2_HI: f64 = 0.693_147_180_369_123_8;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    const INVERSES: [f64; 128] = {
        let mut inverses = [0.0; 128];
        let mut j = 0;
        while j < 128 {
            inverses[j] = 1.0 / (1.0 + j as f64 / 128.0);
            j += 1;
        }
        inverses
    };
    const LOGS: [u64; 128] = [
        0x0000000000000000,
        0x3f7fe02a6b106789,
        0x3f8fc0a8b0fc03e4,
        0x3f97b91b07d5b11b,
        0x3f9f829b0e783300,
        0x3fa39e87b9febd60,
        0x3fa77458f632dcfc,
        0x3fab42dd711971bf,
        0x3faf0a30c01162a6,
        0x3fb16536eea37ae1,
        0x3fb341d7961bd1d1,
        0x3fb51b073f06183f,
        0x3fb6f0d28ae56b4c,
        0x3fb8c345d6319b21,
        0x3fba926d3a4ad563,
        0x3fbc5e548f5bc743,
        0x3fbe27076e2af2e6,
        0x3fbfec9131dbeabb,
        0x3fc0d77e7cd08e59,
        0x3fc1b72ad52f67a0,
        0x3fc29552f81ff523,
        0x3fc371fc201e8f74,
        0x3fc44d2b6ccb7d1e,
        0x3fc526e5e3a1b438,
        0x3fc5ff3070a793d4,
        0x3fc6d60fe719d21d,
        0x3fc7ab890210d909,
        0x3fc87fa06520c911,
        0x3fc9525a9cf456b4,
        0x3fca23bc1fe2b563,
        0x3fcaf3c94e80bff3,
        0x3fcbc286742d8cd6,
        0x3fcc8ff7c79a9a22,
        0x3fcd5c216b4fbb91,
        0x3fce27076e2af2e6,
        0x3fcef0adcbdc5936,
        0x3fcfb9186d5e3e2b,
        0x3fd0402594b4d041,
        0x3fd0a324e27390e3,
        0x3fd1058bf9ae4ad5,
        0x3fd1675cababa60e,
        0x3fd1c898c16999fb,
        0x3fd22941fbcf7966,
        0x3fd2895a13de86a3,
        0x3fd2e8e2bae11d31,
        0x3fd347dd9a987d55,
        0x3fd3a64c556945ea,
        0x3fd404308686a7e4,
        0x3fd4618bc21c5ec2,
        0x3fd4be5f957778a1,
        0x3fd51aad872df82d,
        0x3fd5767717455a6c,
        0x3fd5d1bdbf5809ca,
        0x3fd62c82f2b9c795,
        0x3fd686c81e9b14af,
        0x3fd6e08eaa2ba1e4,
        0x3fd739d7f6bbd007,
        0x3fd792a55fdd47a2,
        0x3fd7eaf83b82afc3,
        0x3fd842d1da1e8b17,
        0x3fd89a3386c1425b,
        0x3fd8f11e873662c7,
        0x3fd947941c2116fb,
        0x3fd99d958117e08b,
        0x3fd9f323ecbf984c,
        0x3fda484090e5bb0a,
        0x3fda9cec9a9a084a,
        0x3fdaf1293247786b,
        0x3fdb44f77bcc8f63,
        0x3fdb9858969310fb,
        0x3fdbeb4d9da71b7c,
        0x3fdc3dd7a7cdad4d,
        0x3fdc8ff7c79a9a22,
        0x3fdce1af0b85f3eb,
        0x3fdd32fe7e00ebd5,
        0x3fdd83e7258a2f3e,
        0x3fddd46a04c1c4a1,
        0x3fde24881a7c6c26,
        0x3fde744261d68788,
        0x3fdec399d2468cc0,
        0x3fdf128f5faf06ed,
        0x3fdf6123fa7028ac,
        0x3fdfaf588f78f31f,
        0x3fdffd2e0857f498,
        0x3fe02552a5a5d0ff,
        0x3fe04bdf9da926d2,
        0x3fe0723e5c1cdf40,
        0x3fe0986f4f573521,
        0x3fe0be72e4252a83,
        0x3fe0e44985d1cc8c,
        0x3fe109f39e2d4c97,
        0x3fe12f719593efbc,
        0x3fe154c3d2f4d5ea,
        0x3fe179eabbd899a1,
        0x3fe19ee6b467c96f,
        0x3fe1c3b81f713c25,
        0x3fe1e85f5e7040d0,
        0x3fe20cdcd192ab6e,
        0x3fe23130d7bebf43,
        0x3fe2555bce98f7cb,
        0x3fe2795e1289b11b,
        0x3fe29d37fec2b08b,
        0x3fe2c0e9ed448e8c,
        0x3fe2e47436e40268,
        0x3fe307d7334f10be,
        0x3fe32b1339121d71,
        0x3fe34e289d9ce1d3,
        0x3fe37117b54747b6,
        0x3fe393e0d3562a1a,
        0x3fe3b68449fffc23,
        0x3fe3d9026a7156fb,
        0x3fe3fb5b84d16f42,
        0x3fe41d8fe84672ae,
        0x3fe43f9fe2f9ce67,
        0x3fe4618bc21c5ec2,
        0x3fe48353d1ea88df,
        0x3fe4a4f85db03ebb,
        0x3fe4c679afccee3a,
        0x3fe4e7d811b75bb1,
        0x3fe50913cc01686b,
        0x3fe52a2d265bc5ab,
        0x3fe54b2467999498,
        0x3fe56bf9d5b3f399,
        0x3fe58cadb5cd7989,
        0x3fe5ad404c359f2d,
        0x3fe5cdb1dc6c1765,
        0x3fe5ee02a9241675,
        0x3fe60e32f44788d9,
    ];
    let bits = s.to_bits();
    let e = ((bits >> 52) as i64 - 1023) as f64;
    let j = ((bits >> 45) & 127) as usize;
    let m = f64::from_bits((bits & ((1 << 52) - 1)) | 0x3ff0_0000_0000_0000);
    let r = (m - (1.0 + j as f64 / 128.0)) * INVERSES[j];
    let r2 = r * r;
    // ln(1 + r) − r.
    let tail = r2
        * (-0.5
            + r * (1.0 / 3.0)
            + r2 * (-0.25 + r * 0.2 + r2 * (-1.0 / 6.0 + r * (1.0 / 7.0) - r2 * 0.125)));
    e * LN2_HI + (f64::from_bits(LOGS[j]) + (e * LN2_LO + (r + tail)))
}

/// −ln Σ exp(−q): the soft minimum over a cell's eight moves, ∞ when none reaches the
/// goal. The exponentials go to an array before they are summed (in move order): the
/// compiler then overlaps them, a quarter faster than summing as they come, same bits.
#[inline(always)]
fn soft_min(q: &[f64; 8]) -> f64 {
    let least = q.iter().copied().fold(f64::INFINITY, f64::min);
    if least == f64::INFINITY {
        return least;
    }
    let mut terms = [0.0; 8];
    for (t, &q) in terms.iter_mut().zip(q) {
        *t = exp(least - q);
    }
    least - ln_of_sum(terms.iter().sum::<f64>())
}

/// A window-sized copy of one layer (∞ outside it), so that the passes look up
/// neighbours by window index without bounds tests.
struct Scratch {
    values: Vec<f64>,
    rect: Rect,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Scratch {
            values: vec![f64::INFINITY; n],
            rect: Rect::EMPTY,
        }
    }

    /// Hold `layer` instead, touching only the two layers' cells.
    fn load(&mut self, layer: &Layer, width: u32) {
        for row in self.rect.rows(width) {
            self.values[row].fill(f64::INFINITY);
        }
        let mut data = layer.data.as_slice();
        for row in layer.rect.rows(width) {
            let (this, rest) = data.split_at(row.len());
            self.values[row].copy_from_slice(this);
            data = rest;
        }
        self.rect = layer.rect;
    }
}

/// What the forward pass found.
pub struct Visitation {
    /// Expected visits of each window cell (the start counts once).
    pub visits: Vec<f64>,
    /// Expected edge incidence: for every step a→b, half its length added to a and to
    /// b, so that Σ incidence(x) · cost(x) is the expected path cost.
    pub incidence: Vec<f64>,
}

/// Relative change below which a soft value counts as settled.
const SETTLED: f64 = 1e-13;

/// Mass (of the start's 1) below which a cell's share is dropped rather than moved on:
/// far from the likely routes most cells hold next to nothing, and moving it costs as
/// much as moving real mass. What is dropped, over every cell and step of a long path,
/// stays below 1e-9 of a visit.
const NEGLIGIBLE_MASS: f64 = 1e-18;

impl SoftGoal {
    /// The backward pass towards `goal` with at most `horizon` steps, for any start in
    /// the window; `goal` must lie in it.
    pub fn new(costs: &Grid<f32>, window: Window, goal: Cell, horizon: usize) -> Self {
        Self::build(costs, window, None, goal, horizon)
    }

    /// The backward pass for paths from `start` only: V_k is kept on the cells that
    /// `start` reaches within horizon − k steps, all that the forward pass from `start`
    /// reads (about half the work on a long path). Other starts read as unreachable.
    pub fn between(
        costs: &Grid<f32>,
        window: Window,
        start: Cell,
        goal: Cell,
        horizon: usize,
    ) -> Self {
        Self::build(costs, window, Some(start), goal, horizon)
    }

    fn build(
        costs: &Grid<f32>,
        window: Window,
        start: Option<Cell>,
        goal_cell: Cell,
        horizon: usize,
    ) -> Self {
        let n = window.len();
        let cell_costs: Vec<f64> = (0..n)
            .map(|i| {
                let c = costs.get(window.cell(i));
                if c.is_finite() && c > 0.0 {
                    f64::from(c)
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        let lengths = StepLengths::of(&costs.geo);
        let mut next = vec![0u32; n * 8];
        let (mut edge, mut length) = (vec![0.0; n * 8], vec![0.0; n * 8]);
        for x in 0..n {
            for m in 0..8 {
                let (y, l) = window.step(x, m, &lengths).unwrap_or((x, 0.0));
                next[x * 8 + m] = y as u32;
                length[x * 8 + m] = l;
                edge[x * 8 + m] = if l == 0.0 {
                    f64::INFINITY
                } else {
                    l * 0.5 * (cell_costs[x] + cell_costs[y])
                };
            }
        }
        let mut soft = SoftGoal {
            window,
            next,
            edge,
            length,
            goal: window.index(goal_cell),
            goal_cell,
            start,
            horizon,
            values: Vec::new(),
            settled: horizon,
        };
        soft.backward();
        soft
    }

    /// The cells whose V_k the passes read: within k moves of the goal and, for one
    /// start, within horizon − k moves of it.
    fn region(&self, k: usize) -> Rect {
        let near_goal = Rect::ball(&self.window, self.goal_cell, k);
        match self.start {
            Some(start) => near_goal.intersect(Rect::ball(&self.window, start, self.horizon - k)),
            None => near_goal,
        }
    }

    /// V_k(x) = softmin over moves of edge + V_{k−1}(next), up to the horizon or until
    /// the values settle.
    fn backward(&mut self) {
        let width = self.window.cols;
        let mut previous = Scratch::new(self.window.len());
        let first = Layer {
            rect: self.region(0),
            data: vec![0.0; self.region(0).len()],
        };
        previous.load(&first, width);
        self.values.push(first);
        for k in 1..=self.horizon {
            let rect = self.region(k);
            let mut changed = false;
            let mut data = Vec::with_capacity(rect.len());
            for row in rect.rows(width) {
                for x in row {
                    let v = if x == self.goal {
                        0.0
                    } else {
                        let mut q = [0.0; 8];
                        for (m, q) in q.iter_mut().enumerate() {
                            let e = x * 8 + m;
                            *q = self.edge[e] + previous.values[self.next[e] as usize];
                        }
                        soft_min(&q)
                    };
                    let old = previous.values[x];
                    changed |= !(v == old || (v - old).abs() <= SETTLED * v.abs().max(1.0));
                    data.push(v);
                }
            }
            let layer = Layer { rect, data };
            previous.load(&layer, width);
            self.values.push(layer);
            // Settled: no value moved, and every cell a later layer could read was
            // already within reach of the goal, so later layers would repeat this one.
            let readable = match self.start {
                Some(start) => Rect::ball(&self.window, start, self.horizon - k + 1),
                None => Rect::ball(&self.window, self.goal_cell, usize::MAX),
            };
            if !changed && Rect::ball(&self.window, self.goal_cell, k - 1).covers(readable) {
                self.settled = k;
                break;
            }
        }
    }

    /// The layer that holds V_k.
    fn layer(&self, k: usize) -> &Layer {
        &self.values[k.min(self.settled)]
    }

    /// Soft cost-to-go from `cell` with the full horizon: −log of the summed
    /// exp(−cost) of the paths from it; ∞ when the goal is out of reach.
    pub fn value(&self, cell: Cell) -> f64 {
        self.value_within(cell, self.horizon)
    }

    /// Soft cost-to-go from `cell` with at most `steps` steps (capped at the horizon).
    pub fn value_within(&self, cell: Cell, steps: usize) -> f64 {
        if !self.window.contains(cell) || self.start.is_some_and(|s| s != cell) {
            return f64::INFINITY;
        }
        let layer = self.layer(steps.min(self.horizon));
        layer
            .rect
            .offset(self.window.index(cell), self.window.cols)
            .map_or(f64::INFINITY, |i| layer.data[i])
    }

    /// Expected visitation of paths from `start` under the distribution.
    pub fn visitation(&self, start: Cell) -> Visitation {
        self.visitation_within(start, self.horizon)
    }

    /// Expected visitation of the paths from `start` of at most `steps` steps (capped
    /// at the horizon).
    pub fn visitation_within(&self, start: Cell, steps: usize) -> Visitation {
        let steps = steps.min(self.horizon);
        let n = self.window.len();
        let width = self.window.cols;
        let mut visits = vec![0.0; n];
        let mut incidence = vec![0.0; n];
        if self.value_within(start, steps) == f64::INFINITY {
            return Visitation { visits, incidence };
        }
        let mut mass = vec![0.0; n];
        mass[self.window.index(start)] = 1.0;
        visits[self.window.index(start)] = 1.0;
        let mut moved = vec![0.0; n];
        // V_left and V_left−1, and which layers they hold: a step's ahead is the next
        // step's here.
        let (mut here, mut ahead) = (Scratch::new(n), Scratch::new(n));
        let (mut here_k, mut ahead_k) = (None, None);
        // While both layers are the settled one the policy does not depend on the
        // steps left: its move probabilities are computed once.
        let mut settled_policy: Option<(Rect, Vec<f64>)> = None;
        for (taken, left) in (1..=steps).rev().enumerate() {
            let stationary = left > self.settled;
            let (want_here, want_ahead) = (left.min(self.settled), (left - 1).min(self.settled));
            if here_k != Some(want_here) {
                if ahead_k == Some(want_here) {
                    std::mem::swap(&mut here, &mut ahead);
                    std::mem::swap(&mut here_k, &mut ahead_k);
                } else {
                    here.load(self.layer(want_here), width);
                    here_k = Some(want_here);
                }
            }
            if ahead_k != Some(want_ahead) {
                ahead.load(self.layer(want_ahead), width);
                ahead_k = Some(want_ahead);
            }
            if stationary && settled_policy.is_none() {
                let rect = self.layer(left).rect;
                let mut p = vec![0.0; rect.len() * 8];
                for (i, x) in rect.indices(width).enumerate() {
                    for m in 0..8 {
                        let e = x * 8 + m;
                        let next = ahead.values[self.next[e] as usize];
                        p[i * 8 + m] = exp(here.values[x] - self.edge[e] - next);
                    }
                }
                settled_policy = Some((rect, p));
            }
            let policy = settled_policy.as_ref().filter(|_| stationary);
            // Mass after `taken` steps lies within `taken` moves of the start, and after
            // this step within one more: only there do `moved` and `visits` change.
            let reach = Rect::ball(&self.window, start, taken + 1);
            for row in reach.rows(width) {
                moved[row].fill(0.0);
            }
            let cells = Rect::ball(&self.window, start, taken).intersect(self.region(left));
            for row in cells.rows(width) {
                for x in row {
                    let m = mass[x];
                    if m < NEGLIGIBLE_MASS || x == self.goal {
                        continue;
                    }
                    let mut p = [0.0; 8];
                    match policy {
                        Some((rect, settled)) => {
                            let i = rect.offset(x, width).expect("mass stays where V is finite");
                            p.copy_from_slice(&settled[i * 8..i * 8 + 8]);
                        }
                        None => {
                            for (mv, p) in p.iter_mut().enumerate() {
                                let e = x * 8 + mv;
                                let y = self.next[e] as usize;
                                *p = exp(here.values[x] - self.edge[e] - ahead.values[y]);
                            }
                        }
                    }
                    // The cell's own half of its steps, summed here and stored once.
                    let mut outgoing = 0.0;
                    for (mv, &p) in p.iter().enumerate() {
                        if p > 0.0 {
                            let e = x * 8 + mv;
                            let flow = m * p;
                            let half = flow * self.length[e] * 0.5;
                            moved[self.next[e] as usize] += flow;
                            outgoing += half;
                            incidence[self.next[e] as usize] += half;
                        }
                    }
                    incidence[x] += outgoing;
                }
            }
            // Arrivals are visits; mass already at the goal rests there uncounted.
            for row in reach.rows(width) {
                for (v, &arrived) in visits[row.clone()].iter_mut().zip(&moved[row]) {
                    *v += arrived;
                }
            }
            moved[self.goal] += mass[self.goal];
            std::mem::swap(&mut mass, &mut moved);
        }
        Visitation { visits, incidence }
    }
}

/// Edge incidence of a path on a window (see `Visitation::incidence`), with the steps
/// of the map's cells.
pub fn path_incidence(window: &Window, path: &[Cell], lengths: &StepLengths) -> Vec<f64> {
    let mut incidence = vec![0.0; window.len()];
    for pair in path.windows(2) {
        let half = lengths.between(pair[0], pair[1]) * 0.5;
        incidence[window.index(pair[0])] += half;
        incidence[window.index(pair[1])] += half;
    }
    incidence
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;
    use crate::plan::path_cost;

    fn grid(width: u32, height: u32, data: Vec<f32>) -> Grid<f32> {
        Grid::from_vec(GeoRef::unit(width, height), data)
    }

    /// Every path of at most `left` steps from `x` that ends at the goal (first arrival).
    fn enumerate(
        costs: &Grid<f32>,
        path: &mut Vec<Cell>,
        goal: Cell,
        left: usize,
        out: &mut Vec<Vec<Cell>>,
    ) {
        let here = *path.last().unwrap();
        if here == goal {
            out.push(path.clone());
            return;
        }
        if left == 0 {
            return;
        }
        for (dr, dc) in MOVES {
            let (r, c) = (here.row as i64 + dr as i64, here.col as i64 + dc as i64);
            let next = Cell::new(r as u32, c as u32);
            if r < 0 || c < 0 || !costs.geo.contains(next) || !costs.get(next).is_finite() {
                continue;
            }
            path.push(next);
            enumerate(costs, path, goal, left - 1, out);
            path.pop();
        }
    }

    #[test]
    fn matches_brute_force_enumeration_of_paths() {
        let costs = grid(
            3,
            3,
            vec![1.0, 2.0, 0.5, 1.5, f32::INFINITY, 1.0, 0.7, 1.2, 3.0],
        );
        let (start, goal, horizon) = (Cell::new(0, 0), Cell::new(2, 2), 5);
        let window = Window::around(&[start, goal], 0, 3, 3);
        let soft = SoftGoal::new(&costs, window, goal, horizon);
        let mut paths = Vec::new();
        enumerate(&costs, &mut vec![start], goal, horizon, &mut paths);
        let weights: Vec<f64> = paths
            .iter()
            .map(|p| (-path_cost(&costs, p)).exp())
            .collect();
        let z: f64 = weights.iter().sum();
        assert!((soft.value(start) + z.ln()).abs() < 1e-9);
        let visitation = soft.visitation(start);
        let mut visits = vec![0.0; window.len()];
        let mut incidence = vec![0.0; window.len()];
        for (p, w) in paths.iter().zip(&weights) {
            for &c in p {
                visits[window.index(c)] += w / z;
            }
            for (i, v) in path_incidence(&window, p, &StepLengths::SQUARE)
                .iter()
                .enumerate()
            {
                incidence[i] += v * w / z;
            }
        }
        for i in 0..window.len() {
            assert!((visitation.visits[i] - visits[i]).abs() < 1e-9, "{i}");
            assert!((visitation.incidence[i] - incidence[i]).abs() < 1e-9, "{i}");
        }
        // The expected cost is Σ incidence · cost.
        let expected: f64 = paths
            .iter()
            .zip(&weights)
            .map(|(p, w)| path_cost(&costs, p) * w / z)
            .sum();
        let by_incidence: f64 = (0..window.len())
            .filter(|&i| visitation.incidence[i] > 0.0)
            .map(|i| visitation.incidence[i] * f64::from(costs.get(window.cell(i))))
            .sum();
        assert!((expected - by_incidence).abs() < 1e-9);
    }

    /// The passes without restriction or settling: every layer on the whole window.
    fn naive(costs: &Grid<f32>, start: Cell, goal: Cell, horizon: usize) -> (f64, Vec<f64>) {
        let (w, h) = (costs.geo.width, costs.geo.height);
        let window = Window::around(&[Cell::new(0, 0), Cell::new(h - 1, w - 1)], 0, w, h);
        let lengths = StepLengths::of(&costs.geo);
        let n = window.len();
        let edge = |x: usize, m: usize| {
            window.step(x, m, &lengths).map(|(y, l)| {
                let (a, b) = (costs.get(window.cell(x)), costs.get(window.cell(y)));
                (y, l, l * 0.5 * (f64::from(a) + f64::from(b)))
            })
        };
        let g = window.index(goal);
        let mut values = vec![vec![f64::INFINITY; n]];
        values[0][g] = 0.0;
        for k in 1..=horizon {
            let layer: Vec<f64> = (0..n)
                .map(|x| {
                    if x == g {
                        return 0.0;
                    }
                    let z: f64 = (0..8)
                        .filter_map(|m| edge(x, m))
                        .map(|(y, _, e)| (-e - values[k - 1][y]).exp())
                        .sum();
                    -z.ln()
                })
                .collect();
            values.push(layer);
        }
        let mut mass = vec![0.0; n];
        let mut visits = vec![0.0; n];
        mass[window.index(start)] = 1.0;
        visits[window.index(start)] = 1.0;
        for left in (1..=horizon).rev() {
            let mut moved = vec![0.0; n];
            moved[g] = mass[g];
            for x in (0..n).filter(|&x| x != g && mass[x] > 0.0) {
                for (y, _, e) in (0..8).filter_map(|m| edge(x, m)) {
                    let p = (values[left][x] - e - values[left - 1][y]).exp();
                    moved[y] += mass[x] * p;
                    visits[y] += mass[x] * p;
                }
            }
            mass = moved;
        }
        (values[horizon][window.index(start)], visits)
    }

    proptest::proptest! {
        /// Restricting the passes to one start and stopping once the values settle
        /// change nothing: against the naive passes, on cheap maps (which never settle)
        /// and dear ones (which do).
        #[test]
        fn restricted_and_settled_passes_match_the_naive_ones(
            width in 2u32..9,
            height in 2u32..9,
            scale in proptest::prop_oneof![0.2f32..1.0, 3.0f32..8.0],
            seed in 0u64..1000,
            extra in 0usize..12,
        ) {
            let data: Vec<f32> = (0..width * height)
                .map(|i| {
                    let r = (u64::from(i) * 2654435761 + seed * 40503) % 1000;
                    scale * (0.5 + r as f32 / 1000.0)
                })
                .collect();
            let costs = grid(width, height, data);
            let start = Cell::new((seed % u64::from(height)) as u32, 0);
            let goal = Cell::new(height - 1, width - 1);
            let horizon = start.chebyshev(goal) as usize + extra;
            let window = Window::around(&[Cell::new(0, 0), goal], 0, width, height);
            let (value, visits) = naive(&costs, start, goal, horizon);
            for soft in [
                SoftGoal::new(&costs, window, goal, horizon),
                SoftGoal::between(&costs, window, start, goal, horizon),
            ] {
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
                proptest::prop_assert!(close(soft.value(start), value), "{} against {value}", soft.value(start));
                let found = soft.visitation(start).visits;
                for (i, (&a, &b)) in found.iter().zip(&visits).enumerate() {
                    proptest::prop_assert!(close(a, b), "cell {i}: {a} against {b}");
                }
            }
        }
    }

    #[test]
    fn the_inline_exponential_is_libms_to_a_few_ulp() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let x = -708.0 + 717.0 * f64::from(i) / 200_000.0;
            let (fast, exact) = (exp(x), x.exp());
            worst = worst.max((fast - exact).abs() / exact);
        }
        assert!(worst < 4.0 * f64::EPSILON, "relative error {worst:e}");
        for x in [0.0, -1e-300, 1e-300, -0.5 * std::f64::consts::LN_2] {
            assert!((exp(x) - x.exp()).abs() <= f64::EPSILON * x.exp(), "{x}");
        }
        assert_eq!(exp(0.0), 1.0);
        for x in [-708.5, -1e6, f64::NEG_INFINITY] {
            assert_eq!(exp(x), 0.0, "{x}");
        }
    }

    #[test]
    fn the_inline_logarithm_is_libms_to_an_ulp_on_sums_of_eight_terms() {
        let mut worst = 0.0f64;
        let mut check = |s: f64| {
            let (fast, exact) = (ln_of_sum(s), s.ln());
            let ulp = f64::EPSILON * exact.abs().max(f64::MIN_POSITIVE);
            worst = worst.max((fast - exact).abs() / ulp);
        };
        for i in 0..=700_000 {
            check(1.0 + 7.0 * f64::from(i) / 700_000.0);
        }
        // Just above 1 and at every table edge, where the series is longest.
        for k in 1..60 {
            check(1.0 + 2f64.powi(-k));
        }
        for j in 0..=384 {
            let edge = 1.0 + f64::from(j) / 128.0;
            check(edge);
            check(f64::from_bits(edge.to_bits() - 1));
        }
        assert!(worst <= 1.0, "error {worst} ulp");
        assert_eq!(ln_of_sum(1.0), 0.0);
    }

    #[test]
    fn dear_maps_settle_before_the_horizon() {
        let costs = grid(6, 6, vec![4.0; 36]);
        let (start, goal) = (Cell::new(0, 0), Cell::new(5, 5));
        let window = Window::around(&[start, goal], 0, 6, 6);
        let soft = SoftGoal::between(&costs, window, start, goal, 200);
        assert!(soft.settled < 60, "settled at {}", soft.settled);
        let cheap = grid(6, 6, vec![0.5; 36]);
        assert_eq!(SoftGoal::new(&cheap, window, goal, 200).settled, 200);
    }

    #[test]
    fn an_unreachable_goal_has_infinite_value_and_no_visits() {
        let costs = grid(3, 1, vec![1.0, f32::INFINITY, 1.0]);
        let window = Window::around(&[Cell::new(0, 0), Cell::new(0, 2)], 1, 3, 1);
        let soft = SoftGoal::new(&costs, window, Cell::new(0, 2), 10);
        assert_eq!(soft.value(Cell::new(0, 0)), f64::INFINITY);
        assert!(
            soft.visitation(Cell::new(0, 0))
                .visits
                .iter()
                .all(|&v| v == 0.0)
        );
    }
}
