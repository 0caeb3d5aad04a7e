//! The arithmetic of the soft passes (`soft_paths`): e^x and the logarithm, the same
//! bits on every machine, and the row kernels the passes spend their time in.
//!
//! The passes work with partition functions rather than soft values: a backward step
//! is then eight products summed per cell and a forward step eight products added to
//! the neighbours, plain loops the compiler runs several cells at a time. Without fused
//! multiply-adds (the target has none unless told) every cell's operations come in the
//! same order whatever the vector width, so a costmap has the same bits on every machine.

const ROUND: f64 = 6_755_399_441_055_744.0; // 1.5 × 2^52: adding it rounds to integers
const STEPS_PER_UNIT: f64 = 92.332_482_616_893_66; // 64 / ln 2
// ln 2 / 64 in two parts; the first has 33 significant bits, so k times it is exact.
const STEP_HI: f64 = 0.010_830_424_696_905_538;
const STEP_LO: f64 = -6.563_929_801_064_195e-13;
// ln 2 in two parts; the first has 32 significant bits, so e times it is exact.
const LN2_HI: f64 = 0.693_147_180_369_123_8;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
const MANTISSA: u64 = (1 << 52) - 1;
const ONE: u64 = 0x3ff0_0000_0000_0000;
/// Keeps a mantissa's first seven bits: c = 1 + j/128.
const TABLE_CUT: u64 = !((1 << 45) - 1);

/// e^x, as the passes need it: within a few ulp of the exact value for x in [−708, 709]
/// and exactly 0 below (a step far dearer than the cheapest way weighs nothing).
///
/// libm's exponential picks an FMA variant or not at run time and may round a last bit
/// differently on another CPU; this one is plain f64 arithmetic, the same bits on every
/// machine, and short: x = (64m + j) ln 2 / 64 + r with |r| ≤ ln 2 / 128, e^x = 2^m ·
/// 2^(j/64) · e^r, the 64 powers 2^(j/64) from a table (correctly rounded) and e^r by
/// its Taylor series to r⁵ (truncation below 4e-17). The integer k = 64m + j comes out
/// of the rounding constant's low mantissa bits, so no float-to-integer conversion.
#[inline(always)]
pub(super) fn exp(x: f64) -> f64 {
    let clamped = x.clamp(-708.0, 709.0);
    let shifted = clamped * STEPS_PER_UNIT + ROUND;
    let k = shifted - ROUND;
    let r = (clamped - k * STEP_HI) - k * STEP_LO;
    let bits = shifted.to_bits();
    let power = f64::from_bits(EXP_POWERS[(bits & 63) as usize]);
    // 2^m, m = ⌊k / 64⌋: the rounded sum's bits end in k (two's complement) above a
    // base divisible by 64, so shifting out j and adding the bias leaves the exponent.
    let two_to_m = f64::from_bits(((bits >> 6).wrapping_add(1023)) << 52);
    let r2 = r * r;
    let series_minus_one = r + r2 * (0.5 + r * (1.0 / 6.0) + r2 * (1.0 / 24.0 + r * (1.0 / 120.0)));
    let result = (power + power * series_minus_one) * two_to_m;
    if x < -708.0 { 0.0 } else { result }
}

/// ln s for a positive normal s. libm's logarithm, like its exponential, may round a
/// last bit differently on another CPU; this one is plain f64 arithmetic, the same bits
/// on every machine: s = 2^e · m, m in [1, 2), c = 1 + j/128 the mantissa's first seven
/// bits, ln s = e ln 2 + ln c + ln(1 + r) with r = (m − c)/c in [0, 2⁻⁷) (m − c is exact;
/// 1/c correctly rounded at compile time), ln c from a table (correctly rounded) and
/// ln(1 + r) by its series to r⁸ (truncation below 2e-18 of r). Exactly 0 at 1.
#[inline(always)]
fn ln(s: f64) -> f64 {
    let bits = s.to_bits();
    // s is positive: its top bits are the biased exponent.
    let e = f64::from((bits >> 52) as u32) - 1023.0;
    let j = ((bits >> 45) & 127) as usize;
    let m_bits = (bits & MANTISSA) | ONE;
    let (m, c) = (f64::from_bits(m_bits), f64::from_bits(m_bits & TABLE_CUT));
    let r = (m - c) * LN_INVERSES[j];
    let r2 = r * r;
    // ln(1 + r) − r.
    let tail = r2
        * (-0.5
            + r * (1.0 / 3.0)
            + r2 * (-0.25 + r * 0.2 + r2 * (-1.0 / 6.0 + r * (1.0 / 7.0) - r2 * 0.125)));
    e * LN2_HI + (f64::from_bits(LN_TABLE[j]) + (e * LN2_LO + (r + tail)))
}

/// ln(z · 2^exponent) for a z > 0, normal or not: the log of a scaled partition function.
pub(super) fn ln_scaled(z: f64, exponent: i32) -> f64 {
    let (z, exponent) = if z < f64::MIN_POSITIVE {
        (z * TWO_64, exponent - 64)
    } else {
        (z, exponent)
    };
    let e = f64::from(exponent);
    e * LN2_HI + (ln(z) + e * LN2_LO)
}

const TWO_64: f64 = 18_446_744_073_709_551_616.0;

/// 2^e as a float: exact for e in [−1074, 1023], 0 below.
pub(super) fn power_of_two(e: i32) -> f64 {
    if e > 1023 {
        f64::INFINITY
    } else if e >= -1022 {
        f64::from_bits(((e + 1023) as u64) << 52)
    } else if e >= -1074 {
        f64::from_bits(1 << (e + 1074))
    } else {
        0.0
    }
}

/// The binary exponent of a positive finite x: x = m · 2^e with m in [1, 2).
pub(super) fn binary_exponent(x: f64) -> i32 {
    if x < f64::MIN_POSITIVE {
        binary_exponent(x * TWO_64) - 64
    } else {
        ((x.to_bits() >> 52) & 0x7ff) as i32 - 1023
    }
}

/// e^−x for each x in place (0 for x = ∞): steps' weights from their excess costs, a
/// plain loop the compiler runs several at a time.
#[inline(always)]
pub(super) fn negated_exp_row(values: &mut [f64]) {
    for value in values {
        *value = exp(-*value);
    }
}

/// One move of a backward step over a row's cells: `out[i]` += `weights[i]` ·
/// `ahead[i]` (a cell's step weight and its neighbour's partition function one step
/// later); a row's moves are added in move order.
#[inline(always)]
pub(super) fn add_products(weights: &[f64], ahead: &[f64], out: &mut [f64]) {
    let len = out.len();
    let (weights, ahead) = (&weights[..len], &ahead[..len]);
    for ((sum, &w), &z) in out.iter_mut().zip(weights).zip(ahead) {
        *sum += w * z;
    }
}

/// One move of a forward step over a row's cells: each source cell's forward partition
/// function `forward[i]` times its step's weight `weights[i]` arrives at the neighbour
/// (`arrived[i]`); that times the neighbour's partition function `ahead[i]` is the
/// weight of the paths taking the step, and `half` (half the step's length times the
/// paths' scale) of it adds to the incidence of both ends: `at_target[i]` and
/// `at_source[i]`.
#[inline(always)]
pub(super) fn flow_row(
    forward: &[f64],
    weights: &[f64],
    ahead: &[f64],
    half: f64,
    arrived: &mut [f64],
    at_target: &mut [f64],
    at_source: &mut [f64],
) {
    let len = forward.len();
    let (weights, ahead) = (&weights[..len], &ahead[..len]);
    let (arrived, at_target, at_source) = (
        &mut arrived[..len],
        &mut at_target[..len],
        &mut at_source[..len],
    );
    for i in 0..len {
        let reaching = forward[i] * weights[i];
        arrived[i] += reaching;
        let flow = reaching * ahead[i] * half;
        at_target[i] += flow;
        at_source[i] += flow;
    }
}

/// Share of the paths (of the start's 1) below which a cell's is dropped rather than
/// moved on: far from the likely routes most cells hold next to nothing, and moving it
/// costs as much as moving real paths. What is dropped, over every cell and step of a
/// long path, stays below 1e-9 of a visit.
pub(super) const NEGLIGIBLE_MASS: f64 = 1e-18;

/// The arrivals of a forward step on a row's cells: each cell's share of the paths,
/// `arrived[i]` · `ahead[i]` · `share`, adds to its visits; a share below
/// `NEGLIGIBLE_MASS` is not moved on (`arrived[i]` set to 0). `largest` keeps the largest
/// value left, four lanes at a time (a maximum over lanes, unlike one over a row,
/// runs several cells at once).
#[inline(always)]
pub(super) fn arrive_row(
    arrived: &mut [f64],
    visits: &mut [f64],
    ahead: &[f64],
    share: f64,
    largest: &mut [f64; 4],
) {
    let len = arrived.len();
    let (visits, ahead) = (&mut visits[..len], &ahead[..len]);
    let arrive = |a: &mut f64, visits: &mut f64, ahead: f64, lane: &mut f64| {
        let mass = *a * ahead * share;
        *visits += mass;
        let kept = if mass < NEGLIGIBLE_MASS { 0.0 } else { *a };
        *a = kept;
        *lane = if kept > *lane { kept } else { *lane };
    };
    let whole = len / 4 * 4;
    let (head, tail) = arrived.split_at_mut(whole);
    let quads = head
        .chunks_exact_mut(4)
        .zip(visits.chunks_exact_mut(4))
        .zip(ahead.chunks_exact(4));
    for ((a, v), z) in quads {
        for j in 0..4 {
            arrive(&mut a[j], &mut v[j], z[j], &mut largest[j]);
        }
    }
    for (j, a) in tail.iter_mut().enumerate() {
        arrive(a, &mut visits[whole + j], ahead[whole + j], &mut largest[j]);
    }
}

/// The largest of `values` (all finite and at least 0), four lanes at a time.
#[inline(always)]
pub(super) fn largest_of(values: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 4];
    let quads = values.chunks_exact(4);
    let tail = quads.remainder();
    for quad in quads {
        for (lane, &v) in lanes.iter_mut().zip(quad) {
            *lane = if v > *lane { v } else { *lane };
        }
    }
    for (lane, &v) in lanes.iter_mut().zip(tail) {
        *lane = if v > *lane { v } else { *lane };
    }
    lanes.into_iter().fold(0.0, f64::max)
}

/// 2^e / z for a positive normal z, finite however large e (capped near the largest
/// float): what turns scaled partition functions into shares of the paths.
pub(super) fn scaled_inverse(e: i32, z: f64) -> f64 {
    let z_exponent = binary_exponent(z);
    let mantissa = z * power_of_two(-z_exponent / 2) * power_of_two(-z_exponent + z_exponent / 2);
    let e = (e - z_exponent).min(1022);
    power_of_two(e / 2) * power_of_two(e - e / 2) / mantissa
}

const EXP_POWERS: [u64; 64] = [
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

const LN_INVERSES: [f64; 128] = {
    let mut inverses = [0.0; 128];
    let mut j = 0;
    while j < 128 {
        inverses[j] = 1.0 / (1.0 + j as f64 / 128.0);
        j += 1;
    }
    inverses
};

const LN_TABLE: [u64; 128] = [
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

#[cfg(test)]
mod tests {
    use super::*;

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
    fn the_inline_logarithm_is_libms_to_an_ulp() {
        let mut worst = 0.0f64;
        let mut check = |s: f64| {
            let (fast, exact) = (ln(s), s.ln());
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
        assert_eq!(ln(1.0), 0.0);
        // Far from 1 the error is ln 2's parts times the exponent: within a few ulp.
        for s in [1e-300, 3.5e-20, 0.001, 123456.0, 1e300] {
            assert!(
                (ln(s) - s.ln()).abs() <= 4.0 * f64::EPSILON * s.ln().abs(),
                "{s}"
            );
        }
    }

    #[test]
    fn scaled_logarithms_and_powers_of_two_cover_subnormals() {
        assert_eq!(power_of_two(0), 1.0);
        assert_eq!(power_of_two(-1074), f64::from_bits(1));
        assert_eq!(power_of_two(-1075), 0.0);
        assert_eq!(power_of_two(1023), 2f64.powi(1023));
        for x in [1.0, 1.5, 3.0, 1e-310, 5e-324, 1e300] {
            let e = binary_exponent(x);
            let m = x * power_of_two(-e / 2) * power_of_two(-e + e / 2);
            assert!((1.0..2.0).contains(&m), "{x}: {e}, {m}");
        }
        for (z, e) in [(1e-310f64, 0), (0.75, 1000), (1.5, -1200)] {
            let exact = z.ln() + f64::from(e) * std::f64::consts::LN_2;
            assert!(
                (ln_scaled(z, e) - exact).abs() <= 1e-12 * exact.abs(),
                "{z} {e}"
            );
        }
    }

    #[test]
    fn row_kernels_sum_in_move_order_and_flow_to_both_ends() {
        let len = 5;
        let weights: [Vec<f64>; 8] =
            std::array::from_fn(|m| (0..len).map(|i| ((m + i) % 3) as f64 * 0.4).collect());
        let ahead: [Vec<f64>; 8] = std::array::from_fn(|m| {
            (0..len)
                .map(|i| {
                    if i == 4 {
                        0.0
                    } else {
                        (m * 7 + i) as f64 + 0.5
                    }
                })
                .collect()
        });
        let mut sums = vec![0.0; len];
        for (weights, ahead) in weights.iter().zip(&ahead) {
            add_products(weights, ahead, &mut sums);
        }
        for i in 0..len {
            let direct: f64 = (0..8).map(|m| weights[m][i] * ahead[m][i]).sum();
            assert_eq!(sums[i], direct);
        }
        let forward = [1.0, 0.0, 2.0, 0.25, 3.0];
        let (mut arrived, mut at_target, mut at_source) = ([1.0; 5], [0.0; 5], [0.5; 5]);
        flow_row(
            &forward,
            &weights[1],
            &ahead[1],
            0.5,
            &mut arrived,
            &mut at_target,
            &mut at_source,
        );
        for i in 0..len {
            let reaching = forward[i] * weights[1][i];
            assert_eq!(arrived[i], 1.0 + reaching);
            assert_eq!(at_target[i], reaching * ahead[1][i] * 0.5);
            assert_eq!(at_source[i], 0.5 + at_target[i]);
        }
    }

    #[test]
    fn scaled_inverses_are_exact_for_powers_of_two_and_stay_finite() {
        assert_eq!(scaled_inverse(3, 2.0), 4.0);
        let exact = 2f64.powi(-550) * (2f64.powi(-550) / 1e-300);
        assert!((scaled_inverse(-1100, 1e-300) / exact - 1.0).abs() < 1e-14);
        assert!((scaled_inverse(10, 3.0) - 1024.0 / 3.0).abs() < 1e-12);
        assert!(scaled_inverse(5000, 1e-310).is_finite());
        assert_eq!(scaled_inverse(-5000, 1.0), 0.0);
    }
}
