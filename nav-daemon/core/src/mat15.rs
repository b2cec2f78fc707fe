//! Products of 15×15 matrices for the filter's hot path, with nalgebra's
//! rounding but without its cost.
//!
//! nalgebra multiplies statically sized matrices column by column, each
//! column an `axpy` over the left factor's columns in order: element (i, j)
//! is `((a_i0 b_0j + a_i1 b_1j) + a_i2 b_2j) + … + a_i14 b_14j`, rounded after
//! every product and every sum (no fused multiply-add). [`mul_sparse_b`]
//! computes the same sums in the same order, on plain arrays the compiler
//! vectorizes, and skips the terms whose factor `b_kj` is zero for k ≥ 1.
//! A skipped term is a zero (±0), and adding a zero to a sum changes it only
//! in the sign of an exact zero result, so every non-zero element is the
//! one nalgebra computes, bit for bit (`tests` below check it on dense and
//! on the filter's sparse matrices). The filter's F, FΔt and Φ are sparse
//! (the bias rows are diagonal, the position rows have no attitude or bias
//! terms), so a propagation does about half the multiplications of the
//! dense products, in fewer instructions each.

use crate::error_model::Mat15;

const N: usize = 15;

/// `a * b`, the terms with a zero `b_kj` (k ≥ 1) skipped: nalgebra's
/// product up to the sign of exact zeros (see the module documentation).
pub fn mul_sparse_b(a: &Mat15, b: &Mat15) -> Mat15 {
    // The columns of `a` padded to 16 rows: whole pairs of lanes, so that
    // each axpy is eight two-lane multiplies and adds (a 15-row one made
    // the compiler shuffle lanes about).
    let mut ap = [[0.0f64; 16]; N];
    for (pk, ak) in ap.iter_mut().zip(a.as_slice().chunks_exact(N)) {
        pk[..N].copy_from_slice(ak);
    }
    let mut c = Mat15::zeros();
    for (cj, bj) in c
        .as_mut_slice()
        .chunks_exact_mut(N)
        .zip(b.as_slice().chunks_exact(N))
    {
        // The first term initializes the sum, as nalgebra's does (β = 0).
        let mut acc = [0.0f64; 16];
        let b0 = bj[0];
        for (x, a0) in acc.iter_mut().zip(&ap[0]) {
            *x = a0 * b0;
        }
        for (ak, &bk) in ap.iter().zip(bj).skip(1) {
            if bk == 0.0 {
                continue;
            }
            for (x, aik) in acc.iter_mut().zip(ak) {
                *x += aik * bk;
            }
        }
        cj.copy_from_slice(&acc[..N]);
    }
    c
}

/// `a * p * aᵀ` as nalgebra evaluates `a * p * a.transpose()` (first
/// `a * p`, then that times `aᵀ`), with the terms of a zero entry of `a`
/// skipped in both products: `a * p` is computed as `(pᵀ aᵀ)ᵀ`, whose
/// element sums are the same products in the same order.
pub fn congruence(a: &Mat15, p: &Mat15) -> Mat15 {
    let at = a.transpose();
    let ap = mul_sparse_b(&p.transpose(), &at).transpose();
    mul_sparse_b(&ap, &at)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random matrix with entries of both signs
    /// over many magnitudes, and zeros where `zero(i, j)` says.
    fn matrix(seed: u64, zero: impl Fn(usize, usize) -> bool) -> Mat15 {
        let mut s = seed;
        Mat15::from_fn(|i, j| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            let mag = 10f64.powf(u * 12.0 - 6.0);
            if zero(i, j) {
                0.0
            } else if s & 1 == 0 {
                mag
            } else {
                -mag
            }
        })
    }

    /// The structure of the filter's F: attitude, velocity and position
    /// rows see attitude, velocity and position; attitude and velocity rows
    /// the gyro and accelerometer biases through C; bias rows only
    /// themselves (−1/τ).
    fn f_structure(i: usize, j: usize) -> bool {
        let (bi, bj) = (i / 3, j / 3);
        let nonzero = match bi {
            0 => bj <= 3,
            1 => bj <= 2 || bj == 4,
            2 => bj == 1 || bj == 2,
            _ => i == j,
        };
        !nonzero
    }

    fn same_bits_up_to_zero_signs(x: &Mat15, y: &Mat15) -> bool {
        x.iter()
            .zip(y.iter())
            .all(|(a, b)| a.to_bits() == b.to_bits() || (*a == 0.0 && *b == 0.0))
    }

    #[test]
    fn dense_products_are_nalgebras_bit_for_bit() {
        for seed in 0..20 {
            let a = matrix(seed, |_, _| false);
            let b = matrix(seed + 100, |_, _| false);
            let c = mul_sparse_b(&a, &b);
            let n = a * b;
            assert!(
                c.iter()
                    .zip(n.iter())
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "seed {seed}"
            );
        }
    }

    #[test]
    fn products_of_the_filters_sparse_matrices_are_nalgebras_but_for_zero_signs() {
        for seed in 0..20 {
            let f = matrix(seed, f_structure) * 0.05;
            let p = {
                let l = matrix(seed + 7, |i, j| j > i);
                l * l.transpose()
            };
            let ff = mul_sparse_b(&f, &f);
            assert!(
                same_bits_up_to_zero_signs(&ff, &(f * f)),
                "F F, seed {seed}"
            );
            let phi = Mat15::identity() + f + ff * 0.5;
            let c = congruence(&phi, &p);
            let n = phi * p * phi.transpose();
            assert!(same_bits_up_to_zero_signs(&c, &n), "Φ P Φᵀ, seed {seed}");
            // Not vacuous: the products are non-zero almost everywhere.
            assert!(n.iter().filter(|x| **x != 0.0).count() > 150);
        }
    }

    #[test]
    fn a_non_finite_entry_still_spreads() {
        let mut p = matrix(3, |_, _| false);
        p[(4, 4)] = f64::NAN;
        let phi = Mat15::identity() + matrix(5, f_structure) * 0.01;
        let c = congruence(&phi, &p);
        assert!(c[(4, 4)].is_nan());
        assert!(c.iter().filter(|x| x.is_nan()).count() >= 15);
    }
}
