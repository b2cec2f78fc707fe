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
//! - **self-consistency**: a quadratic in time per component fitted by
//!   least squares leaves a residual χ² per degree of freedom below the
//!   99.9 % quantile of χ²(ν)/ν (Wilson–Hilferty), ν = dof·(n − 3); when
//!   it does not, a cubic (ν = dof·(n − 4)) must. Outliers, spikes and
//!   alternating jumps fail both. The cubic is the short-time INS error: a
//!   position error, a velocity error, a tilt or accelerometer error (t²)
//!   and a gyro bias tilting the platform at a constant rate (g·δω·t³/6),
//!   over times short against the Schuler period. The quadratic leaves out
//!   the last term, which a MEMS gyro makes dominant and a precise aid
//!   resolves: on a real car record (rtklibexplorer's drive_0708, RTK
//!   fixes of 1 cm σ after a 15 s outage while the car pulled away with a
//!   heading 35° off) the quadratic's residual χ²/ν over the first 5 s of
//!   the streak was about 2.7 (bound 1.70, an offline fit) and the cubic's
//!   0.62, and the filter with the default gate never came back to GNSS
//!   (8.7 km RMSE). The quadratic is tried first because the cubic's trend
//!   extrapolates back to the last fused sample far less surely, which
//!   would weaken the continuity test below (a step of about twice the
//!   size would pass from a streak of 6 samples).
//! - A streak is **samples seen in a row**: a gap in the aid's samples
//!   longer than its timeout (an outage) starts a new streak, as at the
//!   start of a run, with no anchor (the last fused sample is then older
//!   than the timeout, see below). Nothing says how the error went while
//!   the aid was not there, and fitting across the gap judges the INS's
//!   free drift during the outage instead of the aid.
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
//! - An aid that observes a position and not the velocity (a GNSS fix
//!   without velocity, CNS, baro) resets the position, and κ alone leaves
//!   the velocity at the wrong model's σ: the reset position then drifts
//!   from the next samples at the velocity error and the streak starts
//!   again (paper 003's aircraft, navigation preset, fixes without
//!   velocity: 18.7 m off at σ 3.8 m 14 s after a reset, and a second
//!   reset). The trend's derivative at the streak's newest sample is the
//!   rate of the innovation, the velocity error as the aid sees it; the
//!   reset widens the velocity's prior to allow it
//!   (`gating::rate_widening`).
//!
//! Fixed-size sums: nothing here allocates.

use nalgebra::{Matrix4, SMatrix, SVector, Vector4};

/// Sums of a streak for one aid.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct Streak {
    /// Time of the first and of the last rejected sample (ns); meaningful
    /// when `n > 0`.
    start_ns: u64,
    last_ns: u64,
    /// Rejected samples in the streak.
    pub(super) n: u32,
    /// Components of the measurement.
    dof: usize,
    /// Whitened innovation of the streak's first sample (the fit is of the
    /// differences from it).
    y0: [f64; 3],
    /// The cubic's least squares as a QR factorization updated by Givens
    /// rotations, one sample at a time: `qr` the upper triangle R of the
    /// design (rows 1, t, t², t³, t in s since `start_ns`) with Qᵀ Δy of
    /// each component beside it (columns 4..7), `rss` each component's
    /// residual sum of squares, which the rotations accumulate directly.
    /// Unlike running sums of tᵏ and Δy tᵏ (the normal equations), nothing
    /// cancels: the residual keeps its precision when the innovations are
    /// 10⁸ times their σ or the streak lasts an hour.
    /// Columns 7..10: Qᵀ Δu of the same innovations whitened by the first
    /// sample's factor L₀ for the whole streak (u = L₀⁻¹ z), whose trend's
    /// derivative, un-whitened by that same L₀, is the innovation's rate:
    /// per-sample whitening would read a change of R along the streak (a
    /// receiver's accuracy growing under jamming) as a rate.
    qr: [[f64; 10]; 4],
    rss: [f64; 3],
    /// L₀ (the leading 3 × 3 of the first sample's R = L Lᵀ factor) and u₀.
    l0: [[f64; 3]; 3],
    u0: [f64; 3],
    /// Σ t^(2k), k = 0..3: each design column's squared norm, against which
    /// R's diagonal says whether the times can fix a cubic.
    col_sq: [f64; 4],
    /// Σ NIS of the rejected samples.
    nis: f64,
    /// Σ (zᵀz − tr(S − H P Hᵀ)) and Σ tr(H P Hᵀ): what the innovations
    /// held beyond the aid's noise (R, and with consider parameters their
    /// covariance with the states), and what P predicted of it.
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
    /// The fit's degree: 2 (a quadratic), or 3 when the quadratic could
    /// not explain the streak.
    pub degree: u8,
    /// Residual χ² per degree of freedom of that fit, and its bound.
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
    /// The fitted trend's rate at the streak's newest sample (None when
    /// it cannot be formed: only a position-only reset uses it).
    pub rate: Option<Rate>,
}

/// The rate of a streak's innovations at its newest sample: per component
/// in the measurement's units per s, and its covariance from the fit
/// (scaled by the fit's residual χ²/ν where that is above 1). For an aid
/// that observes a position and not the velocity, it is the velocity error
/// the reset must allow ([`super::gating`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rate {
    pub z_dot: [f64; 3],
    pub cov: [[f64; 3]; 3],
}

impl StreakVerdict {
    /// The aid is consistent and was not left by a step: reset to it.
    pub fn healthy(&self) -> bool {
        self.consistency <= self.consistency_bound && self.step.is_none_or(|s| s <= self.step_bound)
    }
}

/// A polynomial fit of a streak: its degree, residual χ²/ν and bound, the
/// triangular factor (identity beyond its coefficients) and coefficients.
struct Fit {
    degree: u8,
    consistency: f64,
    bound: f64,
    r: Matrix4<f64>,
    coef: [Vector4<f64>; 3],
    /// The same polynomial of the innovations whitened by L₀ (u).
    coef_u: [Vector4<f64>; 3],
}

/// Upper 99.9 % quantile of χ²(ν)/ν by the Wilson–Hilferty approximation.
pub fn chi2_999_per_dof(nu: f64) -> f64 {
    const Z: f64 = 3.090_232_306; // standard normal 99.9 % quantile
    let a = 2.0 / (9.0 * nu);
    (1.0 - a + Z * a.sqrt()).powi(3)
}

/// Whitens z with R: y = L⁻¹ z (R = L Lᵀ); the first M of 3 components.
fn whiten<const M: usize>(z: &SVector<f64, M>, r: &SMatrix<f64, M, M>) -> Option<[f64; 3]> {
    whitened(z, &r.cholesky()?.l())
}

/// [`whiten`] with R's factor L known.
fn whitened<const M: usize>(z: &SVector<f64, M>, l: &SMatrix<f64, M, M>) -> Option<[f64; 3]> {
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

    /// A sample rejected at the gate, with its NIS, the diagonal of S and
    /// that of H P Hᵀ. A gap longer than `max_gap_ns` since the streak's
    /// last sample (the aid's timeout) starts a new streak without an
    /// anchor.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn rejected<const M: usize>(
        &mut self,
        t_ns: u64,
        z: &SVector<f64, M>,
        r: &SMatrix<f64, M, M>,
        nis: f64,
        s_diag: &SVector<f64, M>,
        state_diag: &SVector<f64, M>,
        max_gap_ns: u64,
    ) {
        let Some(l) = r.cholesky().map(|c| c.l()) else {
            return;
        };
        let Some(y) = whitened(z, &l) else {
            return;
        };
        if self.n > 0 && t_ns.saturating_sub(self.last_ns) > max_gap_ns {
            *self = Streak::default();
        }
        if self.n == 0 {
            self.start_ns = t_ns;
            self.dof = M.min(3);
            self.y0 = y;
            for i in 0..self.dof {
                for j in 0..=i {
                    self.l0[i][j] = l[(i, j)];
                }
            }
        }
        // u = L₀⁻¹ z, forward substitution on the leading block.
        let mut u = [0.0; 3];
        for i in 0..self.dof {
            let dot: f64 = (0..i).map(|j| self.l0[i][j] * u[j]).sum();
            u[i] = (z[i] - dot) / self.l0[i][i];
        }
        if self.n == 0 {
            self.u0 = u;
        }
        self.last_ns = self.last_ns.max(t_ns);
        let t = t_ns.saturating_sub(self.start_ns) as f64 * 1e-9;
        // The new row [1 t t² t³ | Δy | Δu], rotated into R row by row.
        let mut row = [0.0; 10];
        let mut tk = 1.0;
        for (k, c) in row.iter_mut().take(4).enumerate() {
            *c = tk;
            self.col_sq[k] += tk * tk;
            tk *= t;
        }
        for i in 0..self.dof {
            row[4 + i] = y[i] - self.y0[i];
            row[7 + i] = u[i] - self.u0[i];
        }
        for k in 0..4 {
            let (a, b) = (self.qr[k][k], row[k]);
            if b == 0.0 {
                continue;
            }
            let r = a.hypot(b);
            let (c, s) = (a / r, b / r);
            for (rk, x) in self.qr[k].iter_mut().zip(row.iter_mut()).skip(k) {
                let (u, v) = (*rk, *x);
                *rk = c * u + s * v;
                *x = c * v - s * u;
            }
        }
        for i in 0..self.dof {
            self.rss[i] += row[4 + i] * row[4 + i];
        }
        self.nis += nis;
        let state = state_diag.sum();
        self.excess += z.norm_squared() - (s_diag.sum() - state);
        self.predicted += state;
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

    /// The least-squares polynomial of `params` coefficients (3: a
    /// quadratic, 4: a cubic) from the QR factorization: the quadratic's is
    /// the leading 3×3 block of the cubic's (the columns are nested), and
    /// its residual adds the rotated Δy's fourth component. None when the
    /// times cannot fix it (fewer distinct times than coefficients: R's
    /// diagonal, against each column's norm, is then at rounding level) or
    /// a NaN.
    fn fit(&self, params: usize) -> Option<Fit> {
        let r = Matrix4::from_fn(|i, j| {
            if i >= params || j >= params {
                if i == j { 1.0 } else { 0.0 }
            } else if j >= i {
                self.qr[i][j]
            } else {
                0.0
            }
        });
        for k in 0..params {
            // (Written so that a NaN refuses too.)
            let independent = r[(k, k)] * r[(k, k)] > 1e-12 * self.col_sq[k];
            if !independent {
                return None;
            }
        }
        let mut resid = 0.0;
        let mut coef = [Vector4::zeros(); 3];
        let mut coef_u = [Vector4::zeros(); 3];
        for (i, c) in coef_u.iter_mut().enumerate().take(self.dof) {
            let qtu = Vector4::from_fn(|k, _| if k < params { self.qr[k][7 + i] } else { 0.0 });
            *c = r.solve_upper_triangular(&qtu)?;
        }
        for (i, c) in coef.iter_mut().enumerate().take(self.dof) {
            let qty = Vector4::from_fn(|k, _| if k < params { self.qr[k][4 + i] } else { 0.0 });
            *c = r.solve_upper_triangular(&qty)?;
            resid += self.rss[i];
            if params == 3 {
                resid += self.qr[3][4 + i] * self.qr[3][4 + i];
            }
        }
        let nu = (self.dof * (self.n as usize - params)) as f64;
        Some(Fit {
            degree: (params - 1) as u8,
            consistency: resid / nu,
            bound: chi2_999_per_dof(nu),
            r,
            coef,
            coef_u,
        })
    }

    /// The continuity test's χ² of the anchor against `fit`'s trend
    /// extrapolated back to it (None without an anchor within
    /// `anchor_max_ns` of the streak's start).
    fn step(&self, fit: &Fit, anchor_max_ns: u64) -> Option<f64> {
        let (ta, ya) = self.anchor?;
        if self.start_ns.saturating_sub(ta) > anchor_max_ns {
            return None;
        }
        let t = -(self.start_ns.saturating_sub(ta) as f64 * 1e-9);
        let cubic = if fit.degree == 3 { t * t * t } else { 0.0 };
        let basis = Vector4::new(1.0, t, t * t, cubic);
        // bᵀ (RᵀR)⁻¹ b = |R⁻ᵀ b|².
        let var_fit = fit
            .r
            .transpose()
            .solve_lower_triangular(&basis)?
            .norm_squared();
        let chi2: f64 = ya
            .iter()
            .zip(&self.y0)
            .zip(&fit.coef)
            .take(self.dof)
            .map(|((ya, y0), c)| (ya - (y0 + c.dot(&basis))).powi(2))
            .sum();
        Some(chi2 / (1.0 + var_fit))
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
        // The quadratic first; the cubic only when the quadratic cannot
        // explain the streak: its trend extrapolates back to the anchor
        // far less surely (from 6 samples over 5 s, 1 s back: a variance of
        // 13 against 3.2), so it would let a step of twice the size pass.
        let quadratic = self.fit(3)?;
        let fit = if quadratic.consistency <= quadratic.bound {
            quadratic
        } else {
            self.fit(4)?
        };
        let step = self.step(&fit, anchor_max_ns);
        Some(StreakVerdict {
            duration_s: self.duration_ns(now_ns) as f64 * 1e-9,
            samples: self.n,
            degree: fit.degree,
            consistency: fit.consistency,
            consistency_bound: fit.bound,
            step,
            step_bound: gate,
            inflation: (self.nis / (f64::from(self.n) * self.dof as f64)).max(1.0),
            covariance_inflation: if self.predicted > 0.0 {
                (self.excess / self.predicted).max(1.0)
            } else {
                1.0
            },
            rate: self.rate(&fit),
        })
    }

    /// The derivative of the trend of u = L₀⁻¹ z at the newest sample,
    /// un-whitened: ż = L₀ ρ (measurement units per s), and its covariance
    /// L₀ L₀ᵀ bᵀ (RᵀR)⁻¹ b for the derivative's basis b = (0, 1, 2t, 3t²),
    /// scaled by the residual χ²/ν when the fit is looser than its
    /// unit-variance model. None for a NaN.
    fn rate(&self, fit: &Fit) -> Option<Rate> {
        let t = self.last_ns.saturating_sub(self.start_ns) as f64 * 1e-9;
        let cubic = if fit.degree == 3 { 3.0 * t * t } else { 0.0 };
        let basis = Vector4::new(0.0, 1.0, 2.0 * t, cubic);
        let var = fit
            .r
            .transpose()
            .solve_lower_triangular(&basis)?
            .norm_squared()
            * fit.consistency.max(1.0);
        let mut rho = [0.0; 3];
        for (r, c) in rho.iter_mut().zip(&fit.coef_u).take(self.dof) {
            *r = c.dot(&basis);
        }
        let mut rate = [0.0; 3];
        let mut cov = [[0.0; 3]; 3];
        let l0 = &self.l0;
        for (i, (rate_i, cov_i)) in rate.iter_mut().zip(&mut cov).enumerate().take(self.dof) {
            *rate_i = (0..=i).map(|k| l0[i][k] * rho[k]).sum();
            for (j, c) in cov_i.iter_mut().enumerate().take(self.dof) {
                *c = (0..=i.min(j)).map(|k| l0[i][k] * l0[j][k]).sum::<f64>() * var;
            }
        }
        (rate
            .iter()
            .chain(cov.iter().flatten())
            .all(|x| x.is_finite()))
        .then_some(Rate { z_dot: rate, cov })
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
                s.rejected(
                    ns(t),
                    &z,
                    &r,
                    100.0,
                    &SVector::<f64, 2>::new(5.0, 10.0),
                    &SVector::<f64, 2>::new(5.0, 10.0),
                    3_000_000_000,
                );
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

    /// Residual sum of squares of a least-squares polynomial fit of `deg`
    /// to (t, y), by the SVD of the column-normalized design matrix: a
    /// second formulation of the streak's normal equations.
    fn lsq_residual(ts: &[f64], ys: &[f64], deg: usize) -> f64 {
        let x = nalgebra::DMatrix::from_fn(ts.len(), deg + 1, |i, j| ts[i].powi(j as i32));
        let norms: Vec<f64> = x.column_iter().map(|c| c.norm()).collect();
        let xn = nalgebra::DMatrix::from_fn(ts.len(), deg + 1, |i, j| x[(i, j)] / norms[j]);
        let y = nalgebra::DVector::from_column_slice(ys);
        let c = xn.clone().svd(true, true).solve(&y, 1e-14).expect("svd");
        (y - xn * c).norm_squared()
    }

    /// The streak's residual χ²/ν is that of an independent least-squares
    /// cubic (SVD of all the data at once, not Givens rotations of one
    /// sample at a time), to 1e-9, for a 5 s streak at 4 Hz and for an
    /// hour-long one at 0.1 Hz whose innovations reach 10⁵ σ (where the
    /// running sums of the normal equations, Σ Δy² of 10¹² against a
    /// residual of 10³, kept only 1e-7).
    #[test]
    fn the_consistency_residual_is_an_independent_least_squares_fit() {
        let mut rng = rand_chacha::ChaCha20Rng::seed_from_u64(11);
        let r = SMatrix::<f64, 1, 1>::new(0.25);
        for (n, dt) in [(21_u32, 0.25), (360, 10.0)] {
            let mut s = Streak::default();
            let (mut ts, mut ys) = (Vec::new(), Vec::new());
            for k in 0..n {
                let t = f64::from(k) * dt;
                let e: f64 = StandardNormal.sample(&mut rng);
                let z = 4.0 + 0.3 * t - 2e-3 * t * t + 1e-6 * t * t * t + 0.5 * e;
                s.rejected(
                    (t * 1e9) as u64 + 7_000_000_000,
                    &SVector::<f64, 1>::new(z),
                    &r,
                    50.0,
                    &SVector::<f64, 1>::new(1.0),
                    &SVector::<f64, 1>::new(1.0),
                    u64::MAX,
                );
                ts.push(t);
                ys.push(z / 0.5);
            }
            let y0 = ys[0];
            let dy: Vec<f64> = ys.iter().map(|y| y - y0).collect();
            for params in [3, 4] {
                let want = lsq_residual(&ts, &dy, params - 1) / f64::from(n - params as u32);
                let got = s.fit(params).expect("fit").consistency;
                assert!(
                    (got - want).abs() <= 1e-9 * want,
                    "n {n}, {params} coefficients: streak {got} against least squares {want}"
                );
            }
        }
    }

    /// A MEMS gyro bias tilts the platform at a constant rate, so the INS
    /// position error grows as g·δω·t³/6: with an aid of centimetres (a
    /// whitened error of hundreds) a quadratic cannot follow it, the cubic
    /// does. The drift below (whitened units, 4 Hz for 6 s: 2.2 m of error
    /// seen with σ = 1 cm) leaves the quadratic's residual far beyond the
    /// bound in every run (SVD fit), and the cubic passes in ≥ 190 of 200
    /// runs; alternating outliers still fail the cubic.
    #[test]
    fn a_gyro_bias_drift_seen_by_a_precise_aid_passes_the_cubic() {
        let mut rng = rand_chacha::ChaCha20Rng::seed_from_u64(5);
        let r = SMatrix::<f64, 2, 2>::identity();
        let trend = |t: f64| {
            SVector::<f64, 2>::new(
                120.0 + 40.0 * t + 6.0 * t * t + 1.0 * t * t * t,
                -80.0 * t - 2.0 * t * t - 0.6 * t * t * t,
            )
        };
        let run = |outliers: bool, rng: &mut rand_chacha::ChaCha20Rng| {
            let mut s = Streak::default();
            let (mut ts, mut y1) = (Vec::new(), Vec::new());
            for k in 0..25 {
                let t = f64::from(k) * 0.25;
                let mut z = trend(t)
                    + SVector::<f64, 2>::new(
                        StandardNormal.sample(rng),
                        StandardNormal.sample(rng),
                    );
                if outliers && k % 2 == 0 {
                    z[1] += 30.0;
                }
                s.rejected(
                    (t * 1e9) as u64 + 1_000_000_000,
                    &z,
                    &r,
                    1e5,
                    &SVector::<f64, 2>::new(1.0, 1.0),
                    &SVector::<f64, 2>::new(1.0, 1.0),
                    3_000_000_000,
                );
                ts.push(t);
                y1.push(z[0]);
            }
            let dy: Vec<f64> = y1.iter().map(|y| y - y1[0]).collect();
            let quadratic = lsq_residual(&ts, &dy, 2) / f64::from(25 - 3);
            (
                s.verdict(7_000_000_000, 22.458, 3_000_000_000)
                    .expect("verdict"),
                quadratic,
            )
        };
        let mut passed = 0;
        for _ in 0..200 {
            let (v, quadratic) = run(false, &mut rng);
            assert!(v.step.is_none(), "no anchor, no step test");
            // The first component alone, against the bound for its ν.
            assert!(
                quadratic > 5.0 * chi2_999_per_dof(22.0),
                "quadratic residual χ²/ν {quadratic}"
            );
            passed += usize::from(v.healthy());
            assert_eq!(v.degree, 3, "the quadratic explained a cubic drift");
        }
        assert!(passed >= 190, "the cubic drift passed {passed}/200");
        assert!(!run(true, &mut rng).0.healthy());
    }

    /// The continuity test keeps its power on the shortest streak: a CNS
    /// at 1 Hz (2 components), rejected for 5 s (6 samples) after a fused
    /// sample 1 s before, on a quadratic drift. The quadratic explains the
    /// drift, so the trend extrapolates back with its own variance, far
    /// below the cubic's: a step of 10 σ is refused in 181 of 200 runs
    /// (≥ 170 asserted), where the cubic's trend would refuse it in 35
    /// (≤ 100 asserted); the same streak without the step passes in 200
    /// (≥ 190 asserted).
    #[test]
    fn a_short_streak_entered_by_a_10_sigma_step_is_refused() {
        let mut rng = rand_chacha::ChaCha20Rng::seed_from_u64(17);
        let r = SMatrix::<f64, 2, 2>::identity();
        let h = SMatrix::<f64, 2, 15>::zeros();
        let dx = SVector::<f64, 15>::zeros();
        let trend = |t: f64| SVector::<f64, 2>::new(3.0 * t + 0.5 * t * t, -2.0 * t);
        let ns = |t: f64| (t * 1e9) as u64 + 1_000_000_000;
        let mut cubic_refused = 0;
        let mut run = |step: f64, cubic_refused: &mut usize| {
            let noise = |rng: &mut rand_chacha::ChaCha20Rng| {
                SVector::<f64, 2>::new(StandardNormal.sample(rng), StandardNormal.sample(rng))
            };
            let mut s = Streak::default();
            s.fused(ns(0.0), &(trend(0.0) + noise(&mut rng)), &h, &r, &dx);
            for k in 1..=6 {
                let t = f64::from(k);
                let z = trend(t) + noise(&mut rng) + SVector::<f64, 2>::new(step, 0.0);
                s.rejected(
                    ns(t),
                    &z,
                    &r,
                    400.0,
                    &SVector::<f64, 2>::new(2.0, 2.0),
                    &SVector::<f64, 2>::new(2.0, 2.0),
                    3_000_000_000,
                );
            }
            let cubic = s.fit(4).expect("cubic");
            let step_cubic = s.step(&cubic, 3_000_000_000).expect("step");
            *cubic_refused += usize::from(step_cubic > 13.816);
            s.verdict(ns(6.0), 13.816, 3_000_000_000).expect("verdict")
        };
        let (mut refused, mut passed) = (0, 0);
        for _ in 0..200 {
            let v = run(10.0, &mut cubic_refused);
            assert!(v.step.is_some());
            refused += usize::from(!v.healthy());
            let v = run(0.0, &mut 0);
            passed += usize::from(v.healthy());
        }
        eprintln!(
            "a 10 σ step into a 6-sample streak: refused {refused}/200 (the cubic's trend alone: {cubic_refused}/200); the drift alone passed {passed}/200"
        );
        assert!(refused >= 170, "a 10 σ step refused in {refused}/200");
        assert!(
            cubic_refused <= 100,
            "the cubic's trend refused {cubic_refused}/200"
        );
        assert!(passed >= 190, "the drift alone passed {passed}/200");
    }

    /// An outage longer than the aid's timeout starts a new streak: its
    /// duration and samples count from the first sample after the gap, and
    /// the anchor before the outage is too old for the step test.
    #[test]
    fn a_gap_longer_than_the_timeout_starts_a_new_streak() {
        let r = SMatrix::<f64, 1, 1>::identity();
        let h = SMatrix::<f64, 1, 15>::zeros();
        let ns = |t: f64| (t * 1e9) as u64 + 1_000_000_000;
        let mut s = Streak::default();
        s.fused(
            ns(0.0),
            &SVector::<f64, 1>::new(0.1),
            &h,
            &r,
            &SVector::<f64, 15>::zeros(),
        );
        let one = SVector::<f64, 1>::new(1.0);
        for k in 1..=8 {
            s.rejected(
                ns(f64::from(k)),
                &(one * 50.0),
                &r,
                2500.0,
                &one,
                &one,
                3_000_000_000,
            );
        }
        assert_eq!((s.n, s.duration_ns(ns(8.0))), (8, 7_000_000_000));
        // A 3 s gap is within the timeout; 3.5 s after the last is not.
        s.rejected(
            ns(11.0),
            &(one * 50.0),
            &r,
            2500.0,
            &one,
            &one,
            3_000_000_000,
        );
        assert_eq!(s.n, 9);
        for k in 0..8 {
            let t = 14.5 + f64::from(k);
            s.rejected(
                ns(t),
                &(one * (60.0 + f64::from(k))),
                &r,
                3600.0,
                &one,
                &one,
                3_000_000_000,
            );
        }
        assert_eq!((s.n, s.duration_ns(ns(21.5))), (8, 7_000_000_000));
        let v = s.verdict(ns(21.5), 10.8, 3_000_000_000).expect("verdict");
        assert_eq!(v.samples, 8);
        assert!(v.step.is_none(), "the anchor is 14.5 s before the streak");
        assert!(v.healthy(), "{v:?}");
    }

    /// The trend's rate at the streak's newest sample is the innovation's
    /// derivative: a position innovation drifting at 1.2, −0.4, 0.3 m/s
    /// with an acceleration of 0.05 m/s² (fixes at 1 Hz, σ 1.5 m, 10 s),
    /// over 400 streaks of noise: the mean rate (unwhitened) within 4
    /// standard errors of the true derivative at the newest sample, and
    /// the scatter of the rates within −25 %…+10 % of the stated variance
    /// (Monte Carlo of the fit, not the fit's own formula; the stated
    /// variance is scaled up by χ²/ν when that is above 1, so it may be
    /// the larger).
    #[test]
    fn the_streaks_rate_is_the_innovations_derivative() {
        let sigma = 1.5;
        let r = SMatrix::<f64, 3, 3>::identity() * (sigma * sigma);
        let v = [1.2, -0.4, 0.3];
        let a = 0.05;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        let (runs, n) = (400, 11);
        let mut sum = [0.0; 3];
        let mut sq = [0.0; 3];
        let mut stated = 0.0;
        for _ in 0..runs {
            let mut s = Streak::default();
            for k in 0..n {
                let t = k as f64;
                let z = SVector::<f64, 3>::from_fn(|i, _| {
                    5.0 + v[i] * t
                        + 0.5 * a * t * t
                        + sigma * {
                            let x: f64 = StandardNormal.sample(&mut rng);
                            x
                        }
                });
                s.rejected(
                    k * 1_000_000_000,
                    &z,
                    &r,
                    100.0,
                    &SVector::repeat(3.0),
                    &SVector::repeat(3.0),
                    2_000_000_000,
                );
            }
            let verdict = s
                .verdict((n - 1) * 1_000_000_000, 16.0, 2_000_000_000)
                .expect("a verdict");
            for i in 0..3 {
                let rate = verdict.rate.expect("a rate").z_dot[i];
                sum[i] += rate;
                sq[i] += rate * rate;
            }
            stated += verdict.rate.expect("a rate").cov[0][0];
        }
        let m = f64::from(runs);
        let t_end = (n - 1) as f64;
        for i in 0..3 {
            let truth = v[i] + a * t_end;
            let mean = sum[i] / m;
            let var = sq[i] / m - mean * mean;
            println!(
                "component {i}: rate {mean:.4} m/s (true {truth:.4}), scatter var {var:.4}, stated {:.4}",
                stated / m
            );
            let se = (stated / m / m).sqrt();
            assert!(
                (mean - truth).abs() < 4.0 * se,
                "{mean} vs {truth} (se {se})"
            );
            let ratio = var / (stated / m);
            assert!((0.75..=1.25).contains(&ratio), "{var} vs {}", stated / m);
        }
    }

    /// An innovation that does not move while the aid's stated σ grows
    /// from 2 m to 4 m along the streak (a receiver being jammed): its
    /// per-sample whitened values fall, which their own trend would read
    /// as −2.5 σ/s, about −10 m/s; the rate is of the innovations as they
    /// are (whitened by one factor for the whole streak): within 0.05 m/s
    /// of zero. And for a non-diagonal R the rate and its covariance are
    /// in the measurement's units: a drift along (1, 1) of R's correlated
    /// axes comes out as that drift (to 1e-9, no noise).
    #[test]
    fn the_streaks_rate_is_the_innovations_own_when_r_changes_or_is_correlated() {
        let mut s = Streak::default();
        for k in 0..11u64 {
            let sd = 2.0 + 0.2 * k as f64;
            let r = SMatrix::<f64, 3, 3>::identity() * (sd * sd);
            let z = SVector::<f64, 3>::new(100.0, -80.0, 30.0);
            let d = SVector::repeat(3.0);
            s.rejected(k * 1_000_000_000, &z, &r, 3000.0, &d, &d, 2_000_000_000);
        }
        let v = s
            .verdict(10_000_000_000, 16.0, 2_000_000_000)
            .expect("a verdict");
        let rate = v.rate.expect("a rate");
        println!("constant innovation, σ 2 → 4 m: rate {:?} m/s", rate.z_dot);
        assert!(rate.z_dot.iter().all(|r| r.abs() < 0.05), "{rate:?}");
        let r = SMatrix::<f64, 2, 2>::new(4.0, 3.0, 3.0, 9.0);
        let mut s = Streak::default();
        for k in 0..11u64 {
            let t = k as f64;
            let z = SVector::<f64, 2>::new(10.0 + 0.7 * t, -5.0 + 0.7 * t);
            let d = SVector::repeat(3.0);
            s.rejected(k * 1_000_000_000, &z, &r, 300.0, &d, &d, 2_000_000_000);
        }
        let v = s
            .verdict(10_000_000_000, 16.0, 2_000_000_000)
            .expect("a verdict");
        let rate = v.rate.expect("a rate");
        assert!(
            (rate.z_dot[0] - 0.7).abs() < 1e-9 && (rate.z_dot[1] - 0.7).abs() < 1e-9,
            "{:?}",
            v.rate
        );
        // The covariance is R times one variance of the basis.
        let k = rate.cov[0][0] / 4.0;
        assert!(k > 0.0);
        assert!(
            (rate.cov[0][1] - 3.0 * k).abs() < 1e-12 && (rate.cov[1][1] - 9.0 * k).abs() < 1e-12
        );
    }
}
