//! The statistics of a campaign's report: exact one-sided confidence
//! bounds on a proportion (Clopper–Pearson) and on a rate (Garwood), the
//! two-sided χ² band of an average NEES, and percentiles.
//!
//! Every function checks its arguments and returns [`StatsError`] for one
//! that has no answer (no trials, more successes than trials, a confidence
//! outside (0, 1), a non-positive exposure): never a panic, never a NaN.
//!
//! The binomial bounds invert the regularized incomplete beta function,
//! computed here (Lentz's continued fraction, Numerical Recipes §6.4) rather
//! than taken from a crate: it is forty lines next to the core's incomplete
//! gamma ([`polarnav::chi2`]), it keeps both tails to full relative precision
//! (a crate's `1 − cdf` would lose the digits of a bound of 1e-9 on 1e9 fixes),
//! and it costs no dependency (`statrs` would bring `nalgebra` features and
//! `rand` into the merge). Its tests check it against independent
//! computations: closed forms, direct binomial and Poisson sums, printed
//! tables.

use polarnav::chi2;

/// Why a statistic has no value.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum StatsError {
    #[error("no trials: a bound on a proportion needs n ≥ 1")]
    NoTrials,
    #[error("{x} successes out of {n} trials (more than the trials)")]
    CountOverTrials { x: u64, n: u64 },
    #[error("{n} trials: above 2^53 a count is not exact as a float")]
    TooManyTrials { n: u64 },
    #[error("confidence {0} is not strictly between 0 and 1")]
    Confidence(f64),
    #[error("exposure {0} is not a positive finite number")]
    Exposure(f64),
    #[error("no runs: an average NEES needs N ≥ 1")]
    NoRuns,
    #[error("{0} degrees of freedom: needs at least 1")]
    DegreesOfFreedom(u32),
    #[error("percentile {0} is not within 0..=100")]
    Percentile(f64),
    #[error("no values to take a percentile of")]
    Empty,
    #[error("{0}: the numerical solution did not converge")]
    NoConvergence(&'static str),
}

/// Largest count that a `f64` holds exactly.
const MAX_EXACT: u64 = 1 << 53;

fn check_confidence(c: f64) -> Result<(), StatsError> {
    if c > 0.0 && c < 1.0 {
        Ok(())
    } else {
        Err(StatsError::Confidence(c))
    }
}

fn check_binomial(x: u64, n: u64, c: f64) -> Result<(), StatsError> {
    check_confidence(c)?;
    if n == 0 {
        return Err(StatsError::NoTrials);
    }
    if x > n {
        return Err(StatsError::CountOverTrials { x, n });
    }
    if n > MAX_EXACT {
        return Err(StatsError::TooManyTrials { n });
    }
    Ok(())
}

/// The one-sided Clopper–Pearson upper bound on a proportion p from `x`
/// successes in `n` trials at `confidence` c: the p with
///
/// P(X ≤ x | n, p) = Σ_{k=0}^{x} C(n, k) p^k (1 − p)^(n−k) = 1 − c,
///
/// i.e. p = I⁻¹_c(x + 1, n − x), I the regularized incomplete beta function
/// (P(X ≤ x | p) = 1 − I_p(x + 1, n − x)). With x = 0 it is
/// 1 − (1 − c)^(1/n) (≈ 3/n at 95 %, the "rule of three"); with x = n
/// no p < 1 qualifies and the bound is 1.
///
/// Errors: n = 0, x > n, n > 2^53, c not in (0, 1) (NaN included).
pub fn clopper_pearson_upper(x: u64, n: u64, confidence: f64) -> Result<f64, StatsError> {
    check_binomial(x, n, confidence)?;
    if x == n {
        return Ok(1.0);
    }
    let (a, b) = (x as f64 + 1.0, (n - x) as f64);
    let alpha = 1.0 - confidence;
    // P(X ≤ x | p) = 1 − I_p(a, b): falls from 1 to 0 as p goes 0 → 1.
    solve_p(|p, q| Ok(beta_inc(a, b, p, q)?.1), alpha, false)
}

/// The one-sided Clopper–Pearson lower bound on a proportion p from `x`
/// successes in `n` trials at `confidence` c: the p with
///
/// P(X ≥ x | n, p) = Σ_{k=x}^{n} C(n, k) p^k (1 − p)^(n−k) = 1 − c,
///
/// i.e. p = I⁻¹_{1−c}(x, n − x + 1) (P(X ≥ x | p) = I_p(x, n − x + 1)).
/// With x = n it is (1 − c)^(1/n); with x = 0 every p qualifies and the
/// bound is 0.
///
/// Errors: n = 0, x > n, n > 2^53, c not in (0, 1) (NaN included).
pub fn clopper_pearson_lower(x: u64, n: u64, confidence: f64) -> Result<f64, StatsError> {
    check_binomial(x, n, confidence)?;
    if x == 0 {
        return Ok(0.0);
    }
    let (a, b) = (x as f64, (n - x) as f64 + 1.0);
    let alpha = 1.0 - confidence;
    // P(X ≥ x | p) = I_p(a, b): rises from 0 to 1 as p goes 0 → 1.
    solve_p(|p, q| Ok(beta_inc(a, b, p, q)?.0), alpha, true)
}

/// The exact (Garwood) one-sided upper bound on the rate λ of a Poisson
/// process from `x` events in `exposure` (e.g. flight hours) at
/// `confidence` c: the λ with P(N ≤ x | λ·T) = 1 − c, which is
///
/// λ = χ²_c(2x + 2) / (2 T),
///
/// χ²_c(k) the c quantile of χ² with k degrees of freedom
/// ([`polarnav::chi2::quantile`]: exact below 1000 degrees of freedom,
/// i.e. x < 499; Wilson–Hilferty above, relative error below 1e-4). It is
/// the Poisson analogue of [`clopper_pearson_upper`]; with x = 0 it is
/// −ln(1 − c)/T (≈ 3/T at 95 %).
///
/// Errors: T not positive and finite, c not in (0, 1) (NaN included).
pub fn poisson_upper(x: u64, exposure: f64, confidence: f64) -> Result<f64, StatsError> {
    check_confidence(confidence)?;
    if !(exposure > 0.0 && exposure.is_finite()) {
        return Err(StatsError::Exposure(exposure));
    }
    if x >= MAX_EXACT {
        return Err(StatsError::TooManyTrials { n: x });
    }
    let k = 2.0 * x as f64 + 2.0;
    let q = chi2::quantile(confidence, k);
    if !q.is_finite() {
        return Err(StatsError::NoConvergence("χ² quantile"));
    }
    Ok(q / 2.0 / exposure)
}

/// The two-sided band that the average of `runs` = N independent NEES
/// values, each χ² with `dof` degrees of freedom, falls in with
/// probability `confidence` c when the filter is consistent: N times the
/// average is χ²(dof·N), so the band is
///
/// [χ²_{(1−c)/2}(dof·N) / N, χ²_{(1+c)/2}(dof·N) / N]
///
/// (Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to
/// Tracking and Navigation*, §5.4.2; e.g. 3 degrees of freedom over 30
/// runs at 95 %: [65.647/30, 118.136/30] = [2.188, 3.938]). The quantiles
/// are [`polarnav::chi2::quantile`]'s (Wilson–Hilferty above 1000 degrees
/// of freedom, relative error below 1e-4).
///
/// Errors: N = 0, dof = 0, c not in (0, 1) (NaN included).
pub fn nees_band(runs: u64, dof: u32, confidence: f64) -> Result<(f64, f64), StatsError> {
    check_confidence(confidence)?;
    if runs == 0 {
        return Err(StatsError::NoRuns);
    }
    if dof == 0 {
        return Err(StatsError::DegreesOfFreedom(dof));
    }
    if runs >= MAX_EXACT / u64::from(dof) {
        return Err(StatsError::TooManyTrials { n: runs });
    }
    let k = f64::from(dof) * runs as f64;
    let n = runs as f64;
    let lo = chi2::quantile((1.0 - confidence) / 2.0, k);
    let hi = chi2::quantile((1.0 + confidence) / 2.0, k);
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(StatsError::NoConvergence("χ² quantile"));
    }
    Ok((lo / n, hi / n))
}

/// The `p`-th percentile (0 ≤ p ≤ 100) of `sorted` (ascending; the caller
/// sorts, e.g. with `f64::total_cmp`, and leaves out what is not finite),
/// by the nearest-rank definition: the smallest value with at least p % of
/// the values at or below it, i.e. the value of 1-based rank ⌈p·N/100⌉
/// (rank 1 for p = 0). It is always one of the values (no interpolation):
/// the 50th of [1, 2, 3, 4] is 2, the 95th of 1..=100 is 95, the 100th the
/// maximum.
///
/// Errors: no values; p outside 0..=100 or NaN.
pub fn percentile(sorted: &[f64], p: f64) -> Result<f64, StatsError> {
    if !(0.0..=100.0).contains(&p) {
        return Err(StatsError::Percentile(p));
    }
    if sorted.is_empty() {
        return Err(StatsError::Empty);
    }
    let n = sorted.len();
    // p·N first: exact for an integer p and N below 2^53/100.
    let rank = (p * n as f64 / 100.0).ceil() as usize;
    Ok(sorted[rank.clamp(1, n) - 1])
}

/// The p ∈ (0, 1) where `f(p, 1 − p)`, monotonic in p (rising when
/// `rising`), equals `target` ∈ (0, 1): bisection on the logit
/// u = ln(p/(1 − p)) ∈ [−700, 700], so that the answer has full relative
/// precision whether it is near 0 or near 1 (1 − p is formed from u, not by
/// subtracting p from 1).
fn solve_p(
    f: impl Fn(f64, f64) -> Result<f64, StatsError>,
    target: f64,
    rising: bool,
) -> Result<f64, StatsError> {
    let pq = |u: f64| {
        // p = 1/(1 + e^−u), 1 − p = 1/(1 + e^u), each without cancellation.
        (1.0 / (1.0 + (-u).exp()), 1.0 / (1.0 + u.exp()))
    };
    let (mut lo, mut hi) = (-700.0_f64, 700.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        let (p, q) = pq(mid);
        let v = f(p, q)?;
        if v.is_nan() {
            return Err(StatsError::NoConvergence("incomplete beta"));
        }
        // Below the target on the rising side: the root is above mid.
        if (v < target) == rising {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-13 {
            break;
        }
    }
    let p = pq(0.5 * (lo + hi)).0;
    if p.is_finite() {
        Ok(p)
    } else {
        Err(StatsError::NoConvergence("bound"))
    }
}

/// The remainder of Stirling's series for ln Γ(z), z ≥ 16:
/// ln Γ(z) = (z − ½) ln z − z + ½ ln 2π + corr(z), corr(z) =
/// 1/(12z) − 1/(360z³) + 1/(1260z⁵) − 1/(1680z⁷) + 1/(1188z⁹) − 691/(360360z¹¹)
/// (the next term, 1/(156z¹³), is below 1e-17 there).
fn stirling_corr(z: f64) -> f64 {
    let r = 1.0 / z;
    let r2 = r * r;
    r * (1.0 / 12.0
        - r2 * (1.0 / 360.0
            - r2 * (1.0 / 1260.0
                - r2 * (1.0 / 1680.0 - r2 * (1.0 / 1188.0 - r2 * (691.0 / 360_360.0))))))
}

const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

/// ln Γ(x), x > 0: Stirling's series (see [`stirling_corr`]) after moving
/// the argument to 16 or above with Γ(x + 1) = x Γ(x).
fn ln_gamma(x: f64) -> f64 {
    let (mut z, mut prod) = (x, 1.0);
    while z < 16.0 {
        prod *= z;
        z += 1.0;
    }
    (z - 0.5) * z.ln() - z + LN_SQRT_2PI + stirling_corr(z) - prod.ln()
}

/// ln B(a, b) = ln Γ(a) + ln Γ(b) − ln Γ(a + b), a, b > 0. With the larger
/// argument b ≥ 16, ln Γ(b) − ln Γ(a + b) is taken from Stirling's series
/// in the form −(b − ½)·ln(1 + a/b) − a·ln(a + b) + a + corr(b) − corr(a + b),
/// which keeps its digits when b is 1e9 and a is 1 (the plain difference of
/// two numbers near 2e10 would lose six).
fn ln_beta(a: f64, b: f64) -> f64 {
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    if b < 16.0 {
        return ln_gamma(a) + ln_gamma(b) - ln_gamma(a + b);
    }
    let diff = -(b - 0.5) * (a / b).ln_1p() - a * (a + b).ln() + a + stirling_corr(b)
        - stirling_corr(a + b);
    ln_gamma(a) + diff
}

/// The regularized incomplete beta function and its complement,
/// (I_p(a, b), 1 − I_p(a, b)), for a, b > 0 and p ∈ [0, 1] given with
/// q = 1 − p (formed by the caller without cancellation). Each is computed
/// where it is accurate (Numerical Recipes §6.4): the continued fraction of
/// I_p(a, b) below p = (a + 1)/(a + b + 2), that of I_q(b, a) = 1 − I_p(a, b)
/// above, the other as one minus it; so a tail of 1e-12 keeps its digits.
fn beta_inc(a: f64, b: f64, p: f64, q: f64) -> Result<(f64, f64), StatsError> {
    if p <= 0.0 {
        return Ok((0.0, 1.0));
    }
    if q <= 0.0 {
        return Ok((1.0, 0.0));
    }
    let ln_p = if p < 0.5 { p.ln() } else { (-q).ln_1p() };
    let ln_q = if q < 0.5 { q.ln() } else { (-p).ln_1p() };
    // ln of p^a q^b / B(a, b).
    let ln_front = a * ln_p + b * ln_q - ln_beta(a, b);
    if p < (a + 1.0) / (a + b + 2.0) {
        let t = (ln_front + beta_cf(a, b, p, q)?.ln() - a.ln())
            .exp()
            .min(1.0);
        Ok((t, 1.0 - t))
    } else {
        let t = (ln_front + beta_cf(b, a, q, p)?.ln() - b.ln())
            .exp()
            .min(1.0);
        Ok((1.0 - t, t))
    }
}

/// The continued fraction of the incomplete beta function (Numerical
/// Recipes §6.4, modified Lentz): I_x(a, b) = x^a (1−x)^b / (a B(a, b)) ·
/// 1/(1 + d₁/(1 + d₂/(1 + …))), d_{2m+1} = −(a+m)(a+b+m)x / ((a+2m)(a+2m+1)),
/// d_{2m} = m(b−m)x / ((a+2m−1)(a+2m)). Converges in O(√max(a, b)) terms
/// for x below (a + 1)/(a + b + 2). `y` = 1 − x: the first term,
/// 1 − (a + b)x/(a + 1), is formed as ((a + 1)y − (b − 1)x)/(a + 1), which
/// keeps its digits when x is within 1e-9 of 1.
fn beta_cf(a: f64, b: f64, x: f64, y: f64) -> Result<f64, StatsError> {
    const TINY: f64 = 1e-300;
    const EPS: f64 = 1e-16;
    let max_iter = 10_000 + (50.0 * a.max(b).sqrt()) as usize;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = (qap * y - (b - 1.0) * x) / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=max_iter {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < EPS {
            return Ok(h);
        }
    }
    Err(StatsError::NoConvergence(
        "incomplete beta continued fraction",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ln k! for k = 0..=n by summing logarithms: independent of the
    /// Stirling series and the continued fraction under test.
    fn ln_factorials(n: usize) -> Vec<f64> {
        let mut v = Vec::with_capacity(n + 1);
        let mut s = 0.0;
        v.push(0.0);
        for k in 1..=n {
            s += (k as f64).ln();
            v.push(s);
        }
        v
    }

    /// Σ_{k ∈ ks} C(n, k) p^k (1 − p)^(n−k), summed in log space
    /// (log-sum-exp), with ln(1 − p) from `ln_1p`.
    fn binomial_sum(lf: &[f64], n: usize, p: f64, ks: std::ops::RangeInclusive<usize>) -> f64 {
        let (lp, lq) = (p.ln(), (-p).ln_1p());
        let terms: Vec<f64> = ks
            .map(|k| lf[n] - lf[k] - lf[n - k] + k as f64 * lp + (n - k) as f64 * lq)
            .collect();
        let m = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        m.exp() * terms.iter().map(|t| (t - m).exp()).sum::<f64>()
    }

    fn close(got: f64, want: f64, rel: f64) -> bool {
        (got - want).abs() <= rel * want.abs()
    }

    #[test]
    fn the_closed_forms_at_the_ends() {
        for n in [1u64, 2, 3, 10, 30, 100, 3000, 1_000_000, 1_000_000_000] {
            for c in [0.5_f64, 0.9, 0.95, 0.99, 0.999] {
                // x = 0: 1 − (1 − c)^(1/n), formed without cancellation.
                let want = -((1.0 - c).ln() / n as f64).exp_m1();
                let got = clopper_pearson_upper(0, n, c).expect("upper");
                assert!(
                    close(got, want, 1e-9),
                    "upper(0, {n}, {c}): {got} vs {want}"
                );
                // x = n: (1 − c)^(1/n).
                let want = ((1.0 - c).ln() / n as f64).exp();
                let got = clopper_pearson_lower(n, n, c).expect("lower");
                assert!(
                    close(got, want, 1e-12),
                    "lower({n}, {n}, {c}): {got} vs {want}"
                );
                assert_eq!(clopper_pearson_upper(n, n, c), Ok(1.0));
                assert_eq!(clopper_pearson_lower(0, n, c), Ok(0.0));
            }
        }
        // The rule of three: 3/n at 95 % for large n (−ln 0.05 = 2.9957).
        let u = clopper_pearson_upper(0, 1_000_000, 0.95).expect("upper");
        assert!(close(u * 1e6, 2.995_732, 1e-5), "{u}");
    }

    /// P(X ≤ x | p_upper) = 1 − c and P(X ≥ x | p_lower) = 1 − c by the
    /// direct binomial sum, over a grid of (x, n) up to n = 3000.
    #[test]
    fn the_bounds_solve_the_binomial_sums() {
        let lf = ln_factorials(3000);
        for n in [1usize, 2, 3, 7, 20, 50, 100, 333, 1000, 2500, 3000] {
            let mut xs = vec![
                0,
                1,
                2,
                3,
                n / 10,
                n / 3,
                n / 2,
                n - n / 10,
                n.saturating_sub(2),
            ];
            xs.extend([n - 1, n]);
            xs.retain(|x| *x <= n);
            xs.sort_unstable();
            xs.dedup();
            for x in xs {
                for c in [0.9, 0.95, 0.99] {
                    let alpha = 1.0 - c;
                    let (xu, nu) = (x as u64, n as u64);
                    let pu = clopper_pearson_upper(xu, nu, c).expect("upper");
                    let pl = clopper_pearson_lower(xu, nu, c).expect("lower");
                    assert!(pl <= x as f64 / n as f64 && x as f64 / n as f64 <= pu);
                    if x < n {
                        let s = binomial_sum(&lf, n, pu, 0..=x);
                        assert!(close(s, alpha, 1e-8), "P(X ≤ {x} | {n}, {pu}) = {s}");
                    }
                    if x > 0 {
                        let s = binomial_sum(&lf, n, pl, x..=n);
                        assert!(close(s, alpha, 1e-8), "P(X ≥ {x} | {n}, {pl}) = {s}");
                    }
                }
            }
        }
    }

    /// The textbook two-sided 95 % interval of 5 successes in 20 trials,
    /// [0.0866, 0.4910], is the pair of one-sided bounds at 97.5 %.
    #[test]
    fn a_printed_interval() {
        let lo = clopper_pearson_lower(5, 20, 0.975).expect("lower");
        let hi = clopper_pearson_upper(5, 20, 0.975).expect("upper");
        assert!((lo - 0.0866).abs() < 1e-4, "{lo}");
        assert!((hi - 0.4910).abs() < 1e-4, "{hi}");
    }

    /// At n = 1e9 the bounds are finite and where the normal approximation
    /// puts them (it is excellent there): p̂ ± 1.645·√(p̂(1 − p̂)/n).
    #[test]
    fn a_billion_trials() {
        let n = 1_000_000_000u64;
        for x in [500_000_000u64, 10_000_000, 100_000] {
            let ph = x as f64 / n as f64;
            let s = (ph * (1.0 - ph) / n as f64).sqrt();
            let z = chi2::normal_quantile(0.95);
            let hi = clopper_pearson_upper(x, n, 0.95).expect("upper");
            let lo = clopper_pearson_lower(x, n, 0.95).expect("lower");
            // The exact bounds sit a skew's worth from the normal ones:
            // within 2 % of the half-width.
            assert!(((hi - ph) / (z * s) - 1.0).abs() < 0.02, "x {x}: {hi}");
            assert!(((ph - lo) / (z * s) - 1.0).abs() < 0.02, "x {x}: {lo}");
        }
        // A few events: the Poisson limit (Garwood) with T = n.
        for x in [1u64, 2, 5] {
            let hi = clopper_pearson_upper(x, n, 0.95).expect("upper");
            let poisson = poisson_upper(x, n as f64, 0.95).expect("poisson");
            assert!(close(hi, poisson, 1e-6), "{x}: {hi} vs {poisson}");
        }
    }

    #[test]
    fn absurd_arguments_are_errors() {
        assert_eq!(clopper_pearson_upper(0, 0, 0.95), Err(StatsError::NoTrials));
        assert_eq!(clopper_pearson_lower(0, 0, 0.95), Err(StatsError::NoTrials));
        assert_eq!(
            clopper_pearson_upper(5, 3, 0.95),
            Err(StatsError::CountOverTrials { x: 5, n: 3 })
        );
        assert_eq!(
            clopper_pearson_lower(5, 3, 0.95),
            Err(StatsError::CountOverTrials { x: 5, n: 3 })
        );
        assert!(matches!(
            clopper_pearson_upper(0, u64::MAX, 0.95),
            Err(StatsError::TooManyTrials { .. })
        ));
        for c in [0.0, 1.0, -0.5, 1.5, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                clopper_pearson_upper(1, 10, c),
                Err(StatsError::Confidence(_))
            ));
            assert!(matches!(
                clopper_pearson_lower(1, 10, c),
                Err(StatsError::Confidence(_))
            ));
            assert!(matches!(
                poisson_upper(1, 10.0, c),
                Err(StatsError::Confidence(_))
            ));
            assert!(matches!(
                nees_band(10, 3, c),
                Err(StatsError::Confidence(_))
            ));
        }
        for t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                poisson_upper(0, t, 0.95),
                Err(StatsError::Exposure(_))
            ));
        }
        assert_eq!(nees_band(0, 3, 0.95), Err(StatsError::NoRuns));
        assert_eq!(nees_band(10, 0, 0.95), Err(StatsError::DegreesOfFreedom(0)));
        assert_eq!(percentile(&[], 50.0), Err(StatsError::Empty));
        for p in [-1.0, 100.5, f64::NAN] {
            assert!(matches!(
                percentile(&[1.0], p),
                Err(StatsError::Percentile(_))
            ));
        }
        // Extreme but valid: finite, in [0, 1], no NaN.
        for (x, n, c) in [
            (0u64, 1u64, 1e-12),
            (1, 1, 1.0 - 1e-12),
            (3, 1_000_000_000, 0.999_999),
            (999_999_999, 1_000_000_000, 0.95),
        ] {
            for v in [
                clopper_pearson_upper(x, n, c).expect("upper"),
                clopper_pearson_lower(x, n, c).expect("lower"),
            ] {
                assert!((0.0..=1.0).contains(&v), "({x}, {n}, {c}): {v}");
            }
        }
    }

    /// Σ_{k=0}^{x} e^(−μ) μ^k / k! = 1 − c at μ = λ·T, summed directly; and
    /// the printed one-sided 95 % upper limits for x = 0..5 (Garwood 1936;
    /// e.g. Gehrels 1986, table 1 at 0.95: 3.00, 4.74, 6.30, 7.75, 9.15, 10.51).
    #[test]
    fn the_garwood_bound_solves_the_poisson_sum() {
        let lf = ln_factorials(3000);
        for x in [0usize, 1, 2, 3, 5, 10, 30, 100, 300, 498] {
            for c in [0.9, 0.95, 0.99] {
                let t = 1512.0;
                let mu = poisson_upper(x as u64, t, c).expect("bound") * t;
                let s: f64 = (0..=x)
                    .map(|k| (-mu + k as f64 * mu.ln() - lf[k]).exp())
                    .sum();
                assert!(close(s, 1.0 - c, 1e-8), "x {x} c {c}: {s}");
            }
        }
        // Above 1000 degrees of freedom (Wilson–Hilferty): within 1e-4 of μ.
        for x in [600usize, 1500, 2900] {
            let mu = poisson_upper(x as u64, 1.0, 0.95).expect("bound");
            let s: f64 = (0..=x)
                .map(|k| (-mu + k as f64 * mu.ln() - lf[k]).exp())
                .sum();
            assert!((s - 0.05).abs() < 2e-3, "x {x}: {s}");
        }
        for (x, want) in [
            (0, 3.00),
            (1, 4.74),
            (2, 6.30),
            (3, 7.75),
            (4, 9.15),
            (5, 10.51),
        ] {
            let got = poisson_upper(x, 1.0, 0.95).expect("bound");
            assert!((got - want).abs() < 0.006, "{x}: {got}");
        }
        // x = 0: −ln(1 − c)/T; 0 in 1512 h at 95 %: < 0.00198 /h.
        let got = poisson_upper(0, 1512.0, 0.95).expect("bound");
        assert!(close(got, -(0.05_f64).ln() / 1512.0, 1e-9), "{got}");
        assert!((got - 0.00198).abs() < 5e-6);
    }

    /// Against printed χ² quantiles (NIST/SEMATECH e-Handbook 1.3.6.7.4).
    #[test]
    fn the_nees_band_matches_the_table() {
        let (lo, hi) = nees_band(30, 3, 0.95).expect("band");
        assert!((lo - 65.647 / 30.0).abs() < 1e-3 / 30.0, "{lo}");
        assert!((hi - 118.136 / 30.0).abs() < 1e-3 / 30.0, "{hi}");
        let (lo, hi) = nees_band(100, 1, 0.95).expect("band");
        assert!((lo - 74.222 / 100.0).abs() < 1e-3 / 100.0, "{lo}");
        assert!((hi - 129.561 / 100.0).abs() < 1e-3 / 100.0, "{hi}");
        let (lo, hi) = nees_band(1, 3, 0.95).expect("band");
        assert!((lo - 0.216).abs() < 1e-3 && (hi - 9.348).abs() < 1e-3);
        // Above 1000 degrees of freedom: the band's ends have the χ²
        // distribution's own probabilities (the core's CDF, a series).
        for runs in [400u64, 1000, 5000] {
            let k = 3.0 * runs as f64;
            let (lo, hi) = nees_band(runs, 3, 0.95).expect("band");
            let n = runs as f64;
            assert!((chi2::cdf(lo * n, k) - 0.025).abs() < 1e-4, "{runs}");
            assert!((chi2::cdf(hi * n, k) - 0.975).abs() < 1e-4, "{runs}");
            assert!(lo < 3.0 && 3.0 < hi);
        }
    }

    #[test]
    fn percentiles_are_nearest_rank() {
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        for (p, want) in [
            (0.0, 1.0_f64),
            (10.0, 1.0),
            (10.000_001, 2.0),
            (50.0, 5.0),
            (90.0, 9.0),
            (95.0, 10.0),
            (99.0, 10.0),
            (100.0, 10.0),
        ] {
            assert_eq!(
                percentile(&v, p).map(f64::to_bits),
                Ok(want.to_bits()),
                "{p}"
            );
        }
        let h: Vec<f64> = (1..=100).map(f64::from).collect();
        for p in [1.0, 50.0, 95.0, 99.0] {
            assert_eq!(percentile(&h, p).map(f64::to_bits), Ok(p.to_bits()));
        }
        assert_eq!(percentile(&[1.0, 2.0, 3.0, 4.0], 50.0), Ok(2.0));
        assert_eq!(percentile(&[7.5], 99.0), Ok(7.5));
        // Against the definition itself, by counting, on uneven data.
        let mut data: Vec<f64> = (0..137u32)
            .map(|i| f64::from((i * 7919) % 101) * 0.37)
            .collect();
        data.sort_by(f64::total_cmp);
        for p in [0.5, 12.5, 33.3, 50.0, 66.7, 95.0, 99.0, 99.9] {
            let want = data
                .iter()
                .copied()
                .find(|v| {
                    let at_or_below = data.iter().filter(|w| *w <= v).count();
                    at_or_below as f64 >= p / 100.0 * data.len() as f64
                })
                .expect("some");
            assert_eq!(percentile(&data, p), Ok(want), "{p}");
        }
    }

    /// The Stirling-based ln Γ against exact factorials and Γ(½) = √π.
    #[test]
    fn ln_gamma_matches_factorials() {
        let lf = ln_factorials(3000);
        for k in [1usize, 2, 5, 10, 15, 16, 17, 50, 170, 3000] {
            let got = ln_gamma(k as f64 + 1.0);
            assert!((got - lf[k]).abs() < 1e-12 * lf[k].max(1.0), "{k}");
        }
        let half = ln_gamma(0.5);
        assert!((half - std::f64::consts::PI.sqrt().ln()).abs() < 1e-14);
        // ln B(1, n) = −ln n, to full precision at n = 1e9.
        assert!((ln_beta(1.0, 1e9) + 1e9_f64.ln()).abs() < 1e-13);
    }
}
