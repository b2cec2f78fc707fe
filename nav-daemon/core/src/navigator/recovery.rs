//! Recovery from a filter that has lost an aid: the evidence that an aid
//! rejected at the gate for a long time is healthy and the filter is wrong
//! (a wrong noise model, a long outage), and the statistics that keep a real
//! aid fault from looking like it.
//!
//! Per aid, a rejection streak keeps running sums of its whitened
//! innovations (y = L⁻¹ z with R = L Lᵀ, so each component is N(0, 1) about
//! the INS error if the aid is right) against time since the streak
//! started. Two tests decide, once the streak has lasted `reset_after_s`:
//!
//! - **self-consistency**: a quadratic in time per component (an INS error
//!   over tens of seconds is smooth) fitted by least squares leaves a
//!   residual χ² per degree of freedom below the 99.9 % quantile of
//!   χ²(ν)/ν (Wilson–Hilferty), ν = dof·(n − 3). Outliers, spikes and
//!   alternating jumps fail it.
//! - **continuity with the last fused sample**: the post-fit residual of the
//!   aid's last fused sample (relative to the state the streak's innovations
//!   are also relative to) must lie on the streak's fitted trend extrapolated
//!   back to it, within the aid's gate (χ² of dof degrees of freedom, its
//!   variance the sample's plus the fit's). A drifting filter leaves the
//!   gate continuously; an aid fault (a CNS jump, a faulty SRS line) steps
//!   out of it, and the step is this test's statistic. Without a fused
//!   sample within the aid's timeout before the streak (a long outage, or a
//!   start without one) there is nothing to step from and only the first
//!   test applies.
//!
//! The measured inflation of the test ratio (mean NIS / dof of the streak)
//! says how far the innovation covariance S = H P Hᵀ + R under-states the
//! innovations; since R is the aid's and right, the filter's own part
//! H P Hᵀ is under-stated by κ = Σ (zᵀz − tr R) / Σ tr(H P Hᵀ), which can
//! be far larger. The reset scales the covariance of the states the aid
//! does not observe by κ.
//!
//! κ alone does not recover a filter whose noise model is wrong, for two
//! reasons, and the reset does two more things about them:
//!
//! - κ is one number for the aggregate of H P Hᵀ, which for a velocity aid
//!   is mostly the velocity block itself; it cannot say how the misfit is
//!   shared among attitude, gyro bias and accelerometer bias, and a
//!   uniform scale keeps the wrong model's proportions. A navigation-grade
//!   preset on a MEMS IMU under-states the gyro bias σ by 5000× (0.01 °/h
//!   against 50 °/h) but the heading σ by far less: after a κ of 10–300 the
//!   filter explained the tilt drift of the uncompensated gyro bias with
//!   the heading, which it drove 1.2 rad off in cruise (seed 3 of the MEMS
//!   flight; the first turn then made that a 15 m/s velocity error). So the
//!   bias variances are raised to at least the stationary variance of the
//!   widest bias model of any sensor grade
//!   ([`crate::settings::SensorGrade::widest_bias_model`]): a bound that
//!   does not depend on the preset that was just proven wrong.
//! - A wrong bias model is not a one-time error. With the preset's bias
//!   process noise P collapses again within a minute while the true bias
//!   keeps wandering, and the filter leaves the gate again (5–7 resets per
//!   900 s flight before). So the reset also raises the bias Gauss–Markov
//!   processes of the process noise to that widest model, for the rest of
//!   the run (a re-initialization or a restart, also one resumed from a
//!   checkpoint, goes back to the configured model). The reset's evidence
//!   is what justifies it: a consistent aid rejected for `reset_after_s`.
//!   The filter with the right preset does not reset on the MEMS flight
//!   or in the consistency runs, and no fault of the fault campaign resets
//!   (all tested), so none of them gets the wider model. A spurious reset
//!   of a filter whose model was right would cost it a more cautious bias
//!   model, not divergence.
//!
//! Fixed-size sums: nothing here allocates.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Sums of a streak for one aid.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct Streak {
    /// Time of the first rejected sample (ns); meaningful when `n > 0`.
    start_ns: u64,
    /// Rejected samples in the streak.
    pub(super) n: u32,
    /// Components of the measurement.
    dof: usize,
    /// Whitened innovation of the streak's first sample (the fit is of the
    /// differences from it, which keeps the sums small).
    y0: [f64; 3],
    /// Σ tᵏ, k = 0..4 (t in s since `start_ns`).
    st: [f64; 5],
    /// Per component: Σ Δy tᵏ, k = 0..2, and Σ Δy².
    sy: [[f64; 3]; 3],
    syy: [f64; 3],
    /// Σ NIS of the rejected samples.
    nis: f64,
    /// Σ (zᵀz − tr R) and Σ tr(H P Hᵀ) = Σ (tr S − tr R): what the
    /// innovations held beyond the aid's noise, and what P predicted of it.
    excess: f64,
    predicted: f64,
    /// The last fused sample: time and whitened post-fit residual.
    anchor: Option<(u64, [f64; 3])>,
}

/// What the tests found about a streak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreakVerdict {
    /// Duration (s) and rejected samples.
    pub duration_s: f64,
    pub samples: u32,
    /// Residual χ² per degree of freedom of the quadratic fit, and its bound.
    pub consistency: f64,
    pub consistency_bound: f64,
    /// χ² of the step from the last fused sample to the trend (None without
    /// an anchor), and its bound (the gate).
    pub step: Option<f64>,
    pub step_bound: f64,
    /// Mean NIS / dof over the streak: the inflation of the test ratio.
    pub inflation: f64,
    /// Σ (zᵀz − tr R) / Σ tr(H P Hᵀ) over the streak (at least 1): how many
    /// times the filter's own part of the innovation covariance was too
    /// small. The reset scales the unobserved states' covariance by it.
    pub covariance_inflation: f64,
}

impl StreakVerdict {
    /// The aid is consistent and was not left by a step: reset to it.
    pub fn healthy(&self) -> bool {
        self.consistency <= self.consistency_bound && self.step.is_none_or(|s| s <= self.step_bound)
    }
}

/// Upper 99.9 % quantile of χ²(ν)/ν by the Wilson–Hilferty approximation.
pub fn chi2_999_per_dof(nu: f64) -> f64 {
    const Z: f64 = 3.090_232_306; // standard normal 99.9 % quantile
    let a = 2.0 / (9.0 * nu);
    (1.0 - a + Z * a.sqrt()).powi(3)
}

/// Whitens z with R: y = L⁻¹ z (R = L Lᵀ); the first M of 3 components.
fn whiten<const M: usize>(z: &SVector<f64, M>, r: &SMatrix<f64, M, M>) -> Option<[f64; 3]> {
    let l = r.cholesky()?.l();
    let y = l.solve_lower_triangular(z)?;
    let mut out = [0.0; 3];
    for i in 0..M.min(3) {
        out[i] = y[i];
    }
    Some(out)
}

impl Streak {
    /// Clears the streak and forgets the anchor (a frame switch changes the
    /// innovations' axes; a reset moves the state they are relative to).
    pub(super) fn clear(&mut self) {
        *self = Streak::default();
    }

    /// A fused sample: it ends any streak and becomes the anchor.
    pub(super) fn fused<const M: usize>(
        &mut self,
        t_ns: u64,
        z: &SVector<f64, M>,
        h: &SMatrix<f64, M, 15>,
        r: &SMatrix<f64, M, M>,
        dx: &SVector<f64, 15>,
    ) {
        let post = z - h * dx;
        *self = Streak {
            anchor: whiten(&post, r).map(|y| (t_ns, y)),
            ..Streak::default()
        };
    }

    /// A sample rejected at the gate, with its NIS and the diagonal of S.
    pub(super) fn rejected<const M: usize>(
        &mut self,
        t_ns: u64,
        z: &SVector<f64, M>,
        r: &SMatrix<f64, M, M>,
        nis: f64,
        s_diag: &SVector<f64, M>,
    ) {
        let Some(y) = whiten(z, r) else {
            return;
        };
        if self.n == 0 {
            self.start_ns = t_ns;
            self.dof = M.min(3);
            self.y0 = y;
        }
        let t = t_ns.saturating_sub(self.start_ns) as f64 * 1e-9;
        let mut tk = 1.0;
        for s in &mut self.st {
            *s += tk;
            tk *= t;
        }
        let dof = self.dof;
        for (((yi, y0), sy), syy) in y
            .iter()
            .zip(&self.y0)
            .zip(&mut self.sy)
            .zip(&mut self.syy)
            .take(dof)
        {
            let d = yi - y0;
            sy[0] += d;
            sy[1] += d * t;
            sy[2] += d * t * t;
            *syy += d * d;
        }
        self.nis += nis;
        self.excess += z.norm_squared() - r.trace();
        self.predicted += s_diag.sum() - r.trace();
        self.n += 1;
    }

    /// Time since the streak's first sample (ns).
    pub(super) fn duration_ns(&self, now_ns: u64) -> u64 {
        if self.n == 0 {
            0
        } else {
            now_ns.saturating_sub(self.start_ns)
        }
    }

    /// The tests of the module documentation, for a streak that has lasted
    /// until `now_ns`; `gate` is the aid's χ² gate and `anchor_max_ns` the
    /// longest time from the anchor to the streak's start that still counts
    /// as continuous (the aid's timeout). None with fewer than 6 samples.
    pub(super) fn verdict(
        &self,
        now_ns: u64,
        gate: f64,
        anchor_max_ns: u64,
    ) -> Option<StreakVerdict> {
        if self.n < 6 || self.dof == 0 {
            return None;
        }
        let s = &self.st;
        let a = Matrix3::new(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
        let a_inv = a.try_inverse()?;
        let mut resid = 0.0;
        let mut coef = [Vector3::zeros(); 3];
        for ((sy, syy), c) in self.sy.iter().zip(&self.syy).zip(&mut coef).take(self.dof) {
            let b = Vector3::from(*sy);
            *c = a_inv * b;
            resid += (syy - b.dot(c)).max(0.0);
        }
        let nu = (self.dof * (self.n as usize - 3)) as f64;
        let step = self.anchor.and_then(|(ta, ya)| {
            if self.start_ns.saturating_sub(ta) > anchor_max_ns {
                return None;
            }
            let t = -(self.start_ns.saturating_sub(ta) as f64 * 1e-9);
            let basis = Vector3::new(1.0, t, t * t);
            let var_fit = basis.dot(&(a_inv * basis));
            let mut chi2 = 0.0;
            for i in 0..self.dof {
                let trend = self.y0[i] + coef[i].dot(&basis);
                chi2 += (ya[i] - trend).powi(2);
            }
            Some(chi2 / (1.0 + var_fit))
        });
        Some(StreakVerdict {
            duration_s: self.duration_ns(now_ns) as f64 * 1e-9,
            samples: self.n,
            consistency: resid / nu,
            consistency_bound: chi2_999_per_dof(nu),
            step,
            step_bound: gate,
            inflation: (self.nis / (f64::from(self.n) * self.dof as f64)).max(1.0),
            covariance_inflation: if self.predicted > 0.0 {
                (self.excess / self.predicted).max(1.0)
            } else {
                1.0
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Wilson–Hilferty against exact χ² quantiles (tables): ν = 20, 60, 200.
    #[test]
    fn wilson_hilferty_matches_tabulated_quantiles() {
        for (nu, q) in [(20.0, 45.315), (60.0, 99.607), (200.0, 267.54)] {
            let got = chi2_999_per_dof(nu) * nu;
            assert!((got - q).abs() < 0.01 * q, "ν = {nu}: {got} vs {q}");
        }
    }

    fn r2() -> SMatrix<f64, 2, 2> {
        SMatrix::<f64, 2, 2>::new(4.0, 1.0, 1.0, 9.0)
    }

    /// A drifting filter: the innovation follows a smooth trend plus white
    /// noise of covariance R, leaving the gate from a fused sample on the
    /// same trend. Consistent, continuous, and the fit's residual per dof is
    /// near 1; the same streak entered by a step of 8 σ is refused, and one
    /// with alternating outliers is inconsistent.
    #[test]
    fn a_drift_passes_and_a_step_or_outliers_do_not() {
        let mut rng = rand_chacha::ChaCha20Rng::seed_from_u64(3);
        let r = r2();
        let l = r.cholesky().expect("R").l();
        let trend = |t: f64| SVector::<f64, 2>::new(2.0 * t + 0.02 * t * t, -1.5 * t);
        let noise = |rng: &mut rand_chacha::ChaCha20Rng| {
            l * SVector::<f64, 2>::new(StandardNormal.sample(rng), StandardNormal.sample(rng))
        };
        let h = SMatrix::<f64, 2, 15>::zeros();
        let dx = SVector::<f64, 15>::zeros();
        let ns = |t: f64| (t * 1e9) as u64 + 1_000_000_000_000;
        let run = |step: f64, outliers: bool, rng: &mut rand_chacha::ChaCha20Rng| {
            let mut s = Streak::default();
            let z0 = trend(0.0) + noise(rng);
            s.fused(ns(0.0), &z0, &h, &r, &dx);
            for k in 1..=30 {
                let t = f64::from(k);
                let mut z = trend(t) + noise(rng) + SVector::<f64, 2>::new(step, 0.0);
                if outliers && k % 2 == 0 {
                    z[1] += 60.0;
                }
                s.rejected(ns(t), &z, &r, 100.0, &SVector::<f64, 2>::new(5.0, 10.0));
            }
            s.verdict(ns(30.0), 13.816, 3_000_000_000).expect("verdict")
        };
        let mut consistency = Vec::new();
        for _ in 0..200 {
            let v = run(0.0, false, &mut rng);
            consistency.push(v.consistency);
            assert!(v.step.is_some());
        }
        let mean = consistency.iter().sum::<f64>() / 200.0;
        // E[χ²(ν)/ν] = 1 for the exact residual of a correct model.
        assert!((mean - 1.0).abs() < 0.05, "mean residual χ²/ν {mean}");
        let passed = (0..200)
            .filter(|_| run(0.0, false, &mut rng).healthy())
            .count();
        assert!(passed >= 190, "a healthy drift passed {passed}/200");
        // 8 σ of the first component (σ = 2) is a step of 16.
        let stepped = (0..200)
            .filter(|_| run(16.0, false, &mut rng).healthy())
            .count();
        assert!(stepped <= 2, "a step fault passed {stepped}/200");
        assert!(!run(0.0, true, &mut rng).healthy());
        let v = run(0.0, false, &mut rng);
        assert!((v.inflation - 50.0).abs() < 1e-9, "{}", v.inflation);
    }
}
