//! χ² distribution: cumulative distribution, upper tail and quantiles, for
//! the integrity test of the aids that are not autonomous (an alarm
//! threshold at a false-alarm probability of 5.6e-10 per fix: 1e-5 per
//! flight hour at 5 Hz) and the consistency
//! tests of the review (normalized innovation squared).
//!
//! The CDF is the regularized lower incomplete gamma function P(k/2, x/2)
//! (series below a + 1, Lentz continued fraction above; Numerical Recipes
//! §6.2); quantiles invert it by bisection. Above 1000 degrees of freedom
//! the Wilson–Hilferty cube-root normal approximation is used instead
//! (relative error below 1e-4 there), so that a mean over millions of
//! updates costs nothing.

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms; relative error ~1e-15).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularized lower and upper incomplete gamma, (P(a, x), Q(a, x)), each
/// computed where it is accurate: the series for P below a + 1, the
/// continued fraction for Q above, the other as one minus it (so a tail of
/// 1e-12 keeps its digits).
fn gamma_pq(a: f64, x: f64) -> (f64, f64) {
    if x <= 0.0 {
        return (0.0, 1.0);
    }
    let ln_pre = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        let (mut ap, mut sum, mut del) = (a, 1.0 / a, 1.0 / a);
        for _ in 0..100_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        let p = (sum.ln() + ln_pre).exp().min(1.0);
        (p, 1.0 - p)
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        let q = (ln_pre + h.ln()).exp().min(1.0);
        ((1.0 - q).max(0.0), q)
    }
}

/// Regularized lower incomplete gamma P(a, x), a > 0, x ≥ 0.
fn gamma_p(a: f64, x: f64) -> f64 {
    gamma_pq(a, x).0
}

/// P(X ≤ x) for X ~ χ²(k).
pub fn cdf(x: f64, k: f64) -> f64 {
    gamma_p(0.5 * k, 0.5 * x)
}

/// The standard normal quantile (Acklam's rational approximation refined by
/// one Halley step on erfc; absolute error below 1e-12).
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    if !(p > 0.0 && p < 1.0) {
        return if p <= 0.0 {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
    }
    let tail = |q: f64| {
        let q = (-2.0 * q.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    let x = if p < 0.02425 {
        tail(p)
    } else if p > 1.0 - 0.02425 {
        -tail(1.0 - p)
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    };
    // Halley refinement with Φ(x) = 1 − P(1/2, x²/2)/2 sign-adjusted.
    let phi = |x: f64| {
        let half = 0.5 * gamma_p(0.5, 0.5 * x * x);
        if x >= 0.0 { 0.5 + half } else { 0.5 - half }
    };
    let e = phi(x) - p;
    let u = e * (2.0 * std::f64::consts::PI).sqrt() * (0.5 * x * x).exp();
    x - u / (1.0 + 0.5 * x * u)
}

/// P(X > x) for X ~ χ²(k): the upper tail, accurate far out (1e-15).
pub fn sf(x: f64, k: f64) -> f64 {
    gamma_pq(0.5 * k, 0.5 * x).1
}

/// The x with P(X > x) = `alpha` for X ~ χ²(k) (0 < alpha < 1), found on
/// the upper tail itself, so that a false-alarm probability of 1e-12
/// keeps its digits (`quantile(1 − alpha)` would lose them).
pub fn quantile_upper(alpha: f64, k: f64) -> f64 {
    if k.is_nan() || k <= 0.0 || alpha.is_nan() || alpha <= 0.0 || alpha >= 1.0 {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (0.0, k.max(1.0));
    while sf(hi, k) > alpha {
        hi *= 2.0;
        if !hi.is_finite() {
            return f64::INFINITY;
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if sf(mid, k) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-12 * hi.max(1e-300) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The quantile of χ²(k) at probability `p` (0 < p < 1).
pub fn quantile(p: f64, k: f64) -> f64 {
    if k.is_nan() || k <= 0.0 || p.is_nan() || p <= 0.0 || p >= 1.0 {
        return f64::NAN;
    }
    if k > 1000.0 {
        // Wilson–Hilferty: (X/k)^(1/3) ≈ N(1 − 2/(9k), 2/(9k)).
        let s = (2.0 / (9.0 * k)).sqrt();
        let z = normal_quantile(p);
        return k * (1.0 - 2.0 / (9.0 * k) + z * s).powi(3);
    }
    let (mut lo, mut hi) = (0.0, k.max(1.0));
    while cdf(hi, k) < p {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid, k) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-12 * hi.max(1e-300) {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the printed table (NIST/SEMATECH e-Handbook 1.3.6.7.4,
    /// critical values of χ², 3 decimals; Abramowitz & Stegun 26.8).
    #[test]
    fn quantiles_match_the_table() {
        let table = [
            (0.025, 1.0, 0.001),
            (0.975, 1.0, 5.024),
            (0.999, 1.0, 10.828),
            (0.999, 2.0, 13.816),
            (0.025, 3.0, 0.216),
            (0.975, 3.0, 9.348),
            (0.999, 3.0, 16.266),
            (0.025, 10.0, 3.247),
            (0.975, 10.0, 20.483),
            (0.025, 100.0, 74.222),
            (0.975, 100.0, 129.561),
        ];
        for (p, k, want) in table {
            let got = quantile(p, k);
            assert!(
                (got - want).abs() < 1.5e-3,
                "χ²({k}) at {p}: {got} vs {want}"
            );
        }
    }

    /// The exact inversion and Wilson–Hilferty agree near the switch-over
    /// (two independent methods), and the CDF of a quantile gives p back.
    #[test]
    fn two_methods_agree_and_cdf_inverts_quantile() {
        for k in [200.0, 500.0, 1000.0] {
            for p in [0.025, 0.5, 0.975] {
                let exact = quantile(p, k);
                let s = (2.0 / (9.0 * k)).sqrt();
                let wh = k * (1.0 - 2.0 / (9.0 * k) + normal_quantile(p) * s).powi(3);
                assert!(
                    (exact - wh).abs() / exact < 2e-4,
                    "k {k} p {p}: {exact} vs {wh}"
                );
                assert!((cdf(exact, k) - p).abs() < 1e-9);
            }
        }
        // χ²(2) has the closed form P = 1 − exp(−x/2).
        for x in [0.1, 1.0, 5.0, 20.0] {
            assert!((cdf(x, 2.0) - (1.0 - (-x / 2.0).exp())).abs() < 1e-12);
        }
    }

    #[test]
    fn normal_quantile_matches_known_values() {
        for (p, z) in [
            (0.975, 1.959_963_984_540_054),
            (0.5, 0.0),
            (0.001, -3.090_232_306_167_813),
        ] {
            assert!((normal_quantile(p) - z).abs() < 1e-9, "{p}");
        }
    }

    /// The upper tail against closed forms: χ²(2) has Q = e^(−x/2),
    /// χ²(6) has Q = e^(−x/2)(1 + x/2 + x²/8); the quantiles of tiny
    /// tails invert them to 1e-9.
    #[test]
    fn the_upper_tail_and_its_quantiles_match_closed_forms() {
        for x in [0.1, 1.0, 5.0, 30.0, 80.0, 200.0] {
            let q2 = (-x / 2.0_f64).exp();
            assert!((sf(x, 2.0) / q2 - 1.0).abs() < 1e-12, "χ²(2) at {x}");
            let q6 = (-x / 2.0_f64).exp() * (1.0 + x / 2.0 + x * x / 8.0);
            assert!((sf(x, 6.0) / q6 - 1.0).abs() < 1e-12, "χ²(6) at {x}");
        }
        for alpha in [1e-3, 1e-7, 1e-12] {
            let x = quantile_upper(alpha, 2.0);
            assert!(
                (x - (-2.0 * f64::ln(alpha))).abs() < 1e-9 * x,
                "{alpha}: {x}"
            );
            let x6 = quantile_upper(alpha, 6.0);
            let q6 = (-x6 / 2.0).exp() * (1.0 + x6 / 2.0 + x6 * x6 / 8.0);
            assert!((q6 / alpha - 1.0).abs() < 1e-9, "{alpha}: {x6}");
        }
        // The lower quantile agrees where both are accurate.
        assert!((quantile_upper(1e-3, 3.0) - quantile(0.999, 3.0)).abs() < 1e-9);
        assert!(quantile_upper(f64::NAN, 3.0).is_nan() && quantile_upper(0.0, 3.0).is_nan());
    }

    #[test]
    fn absurd_arguments_give_nan_not_a_panic() {
        assert!(quantile(0.5, 0.0).is_nan());
        assert!(quantile(f64::NAN, 3.0).is_nan());
        assert!(quantile(1.0, 3.0).is_nan());
        assert!(cdf(-1.0, 3.0).abs() < f64::MIN_POSITIVE);
    }
}
