//! Aid gating: whether and when an aid sample is fused (selection, time
//! stamp against the IMU, the state at its own time from the history), the
//! χ² gate and the closed-loop feedback of a fused correction. The
//! measurement models are `crate::aids`.

use msgs::{AidKind, AidSample, PerAid};
use nalgebra::{Matrix3, Matrix6, SVector, Vector3};

use crate::aids::control::AidControl;
use crate::aids::{
    Aid, AidError, AnyMeasurement, ConsiderShares, Context, Measured, Measurement, OwnOf,
};
use crate::error_model::{Mat15, idx};
use crate::filter;
use crate::mech::AnyNav;
use crate::settings::{AidSet, AidSettings, BiasModel, SensorGrade};

use super::recovery::{Rate, Streak, StreakVerdict};
use super::{AidOutcome, InputRejection, Navigator, secs_to_ns};

/// The per-aid fusion controls, which aids are selected, and the latency limit.
#[derive(Debug, Clone)]
pub(super) struct AidGate {
    pub(super) controls: PerAid<AidControl>,
    pub(super) enabled: AidSet,
    pub(super) max_latency_ns: u64,
    /// The last gated innovation was rejected (solution flag).
    pub(super) last_rejected: bool,
    /// Rejection streaks per aid and the time after which a healthy aid's
    /// streak resets the filter to it (0 = never).
    pub(super) streaks: PerAid<Streak>,
    pub(super) reset_after_ns: u64,
    /// Aid resets so far, per aid, and the verdict of the last one.
    pub(super) resets: PerAid<u32>,
    pub(super) last_reset_verdict: Option<StreakVerdict>,
    /// The bias model the last reset widened the process noise to (None if
    /// it was already at least that wide).
    pub(super) last_reset_widened: Option<BiasModel>,
    /// The state was reset to this aid and it has not been fused since.
    pub(super) reset_pending_flag: Option<AidKind>,
    /// Each aid's own settings.
    pub(super) settings: AidSettings,
}

impl AidGate {
    pub(super) fn new(a: &AidSettings, enabled: AidSet) -> Self {
        Self {
            controls: PerAid::from_fn(|k| AidControl::new(a.gate[k], secs_to_ns(a.timeout_s[k]))),
            enabled,
            max_latency_ns: secs_to_ns(a.max_latency_s),
            last_rejected: false,
            streaks: PerAid::default(),
            reset_after_ns: secs_to_ns(a.reset_after_s),
            resets: PerAid::default(),
            last_reset_verdict: None,
            last_reset_widened: None,
            reset_pending_flag: None,
            settings: a.clone(),
        }
    }

    /// Forgets every streak and anchor (frame switch, reset).
    pub(super) fn clear_streaks(&mut self) {
        for (_, s) in self.streaks.iter_mut() {
            s.clear();
        }
    }
}

/// The blocks of states an aid observes.
pub(super) fn observed_blocks(which: AidKind) -> &'static [usize] {
    msgs::match_aid_kind!(which, P => <P as Aid>::OBSERVED)
}

/// The reset's widening of the observed blocks' prior (their 3×3 blocks in
/// order, padded to 6×6): W = X Λ Xᵀ, Λ = 10⁴ (z² + S) per component
/// (S = H P Hᵀ + R), X a right inverse of G, the measurement's H on those
/// blocks (M × 3k): the prior of what the measurement sees grows by Λ
/// (G W Gᵀ = Λ when G has full row rank), in the measurement's units
/// whatever the states' (a GNSS fix in metres of a latitude in radians),
/// so the prior no longer counts; and nothing is added along a direction
/// the measurement cannot see (rotation about a baseline), because X's
/// columns lie in G's row space.
///
/// X = Gᵀ (G Gᵀ)⁺ with G's rows scaled to unit norm first (G = S G_s, X =
/// G_sᵀ (G_s G_sᵀ)⁺ S⁻¹; scaling rows keeps the row space): a latitude
/// row is 6.4·10⁶ times a height row, which a relative eigenvalue
/// threshold would take for rank deficiency. The pseudo-inverse is from
/// the symmetric eigen-decomposition of the M × M (padded to 6 × 6)
/// G_s G_sᵀ, eigenvalues below 10⁻¹² of the largest taken as zero. None
/// when G or Λ is not finite or G is zero.
fn observed_widening<const M: usize>(
    m: &Measurement<M>,
    p: &Mat15,
    observed: &[usize],
) -> Option<Matrix6<f64>> {
    // Rows: the measurement's components (M ≤ 6), padded with zeros.
    let mut g = Matrix6::<f64>::zeros();
    for (b, &o) in observed.iter().enumerate() {
        g.view_mut((0, 3 * b), (M, 3))
            .copy_from(&m.h.fixed_view::<M, 3>(0, o));
    }
    let x = right_inverse(g)?;
    let s = m.h * p * m.h.transpose() + m.r;
    let mut lambda = Matrix6::<f64>::zeros();
    for i in 0..M {
        lambda[(i, i)] = 1e4 * (m.z[i] * m.z[i] + s[(i, i)]);
    }
    let w = x * lambda * x.transpose();
    w.iter().all(|x| x.is_finite()).then_some(w)
}

/// For a reset to an aid that observes a position and not the velocity (a
/// fix without velocity, CNS, baro): the velocity's widening that allows
/// the velocity error the streak measured. The rate of a position's
/// innovation is that of the position error, ż = G_v δv with G_v =
/// H_p F_pv (H_p the measurement's position columns, F_pv the position
/// rate per velocity error); the streak's trend gives ż at its newest
/// sample with its covariance ([`StreakVerdict::rate`]). The velocity's
/// prior grows by X (ż żᵀ + cov ż) Xᵀ, X a right inverse of G_v as for
/// the observed blocks: its second moment along what the aid sees of the
/// velocity is then at least the streak's estimate of it. Without this
/// the velocity keeps the wrong model's σ (scaled by κ only) and the
/// reset position drifts away from the next fixes. Only the streak's
/// first three components are tracked (all of such an aid's). None when
/// not finite.
fn rate_widening<const M: usize>(
    m: &Measurement<M>,
    f_pv: &Matrix3<f64>,
    rate: &Rate,
) -> Option<Matrix3<f64>> {
    let k = M.min(3);
    let mut g = Matrix6::<f64>::zeros();
    let g_v = m.h.fixed_view::<M, 3>(0, idx::DP) * f_pv;
    g.view_mut((0, 0), (k, 3))
        .copy_from(&g_v.view((0, 0), (k, 3)));
    let x = right_inverse(g)?;
    let z_dot = rate.z_dot;
    let mut lambda = Matrix6::<f64>::zeros();
    for i in 0..k {
        for j in 0..k {
            lambda[(i, j)] = z_dot[i] * z_dot[j] + rate.cov[i][j];
        }
    }
    let w = (x * lambda * x.transpose())
        .fixed_view::<3, 3>(0, 0)
        .into_owned();
    w.iter().all(|x| x.is_finite()).then_some(w)
}

/// X = Gᵀ (G Gᵀ)⁺ for the rows of `g` (a measurement's components, padded
/// with zero rows), with G's rows scaled to unit norm first (see
/// [`observed_widening`]). None when G is zero or not finite.
fn right_inverse(mut g: Matrix6<f64>) -> Option<Matrix6<f64>> {
    let mut s_inv = SVector::<f64, 6>::zeros();
    for (i, mut row) in g.row_iter_mut().enumerate() {
        let norm = row.norm();
        if norm > 0.0 {
            row /= norm;
            s_inv[i] = 1.0 / norm;
        }
    }
    let eigen = (g * g.transpose()).symmetric_eigen();
    let largest = eigen.eigenvalues.amax();
    if !(largest.is_finite() && largest > 0.0) {
        return None;
    }
    let mut n_plus = Matrix6::<f64>::zeros();
    for (k, &l) in eigen.eigenvalues.iter().enumerate() {
        if l > 1e-12 * largest {
            let v = eigen.eigenvectors.column(k);
            n_plus += v * v.transpose() / l;
        }
    }
    Some(g.transpose() * n_plus * Matrix6::from_diagonal(&s_inv))
}

impl Navigator {
    /// Checks an aid's time stamp; returns its age behind the IMU (s).
    pub(super) fn aid_age(&self, t_ns: u64) -> Result<f64, InputRejection> {
        if t_ns > self.t_ns {
            return Err(InputRejection::AheadOfImu {
                t_ns,
                imu_ns: self.t_ns,
            });
        }
        let age = self.t_ns - t_ns;
        if age > self.aids.max_latency_ns {
            return Err(InputRejection::TooLate {
                t_ns,
                age_s: age as f64 * 1e-9,
                limit_s: self.aids.max_latency_ns as f64 * 1e-9,
            });
        }
        Ok(age as f64 * 1e-9)
    }

    /// The nominal state at an aid's time `t_ns`, `age_s` behind the newest
    /// IMU sample: interpolated from the state history (kept consistent with
    /// every correction since), so a late aid is fused at its own time. If the
    /// history does not reach back that far (just after a start), the
    /// position is moved back along the velocity instead.
    pub(super) fn state_at(&self, t_ns: u64, age_s: f64) -> AnyNav {
        if age_s == 0.0 {
            return *self.nominal.nav();
        }
        if let Some((r, v, q)) = self.history.at(t_ns) {
            return AnyNav::from_frame_free(self.nominal.nav().kind(), &r, &v, &q);
        }
        let ff = self.nominal.nav().frame_free();
        AnyNav::from_frame_free(
            self.nominal.nav().kind(),
            &(ff.r_e - ff.v_e * age_s),
            &ff.v_e,
            &ff.q_b_e,
        )
    }

    /// Gate, update and feedback for one measurement. An update that would
    /// leave P or the correction non-finite (σ at the edge of the range, a
    /// degenerate geometry) is undone and counted as invalid.
    fn fuse<const M: usize>(
        &mut self,
        which: AidKind,
        t_ns: u64,
        m: &Measurement<M>,
        shares: &ConsiderShares,
    ) -> AidOutcome {
        let gate = self.aids.controls[which].gate;
        let Some(out) = self.err.update(m, gate, shares) else {
            self.aids.controls[which].rejected_invalid();
            return AidOutcome {
                gated: false,
                fused: false,
                test_ratio: f64::NAN,
                excluded_body: None,
            };
        };
        let frame = self.nominal.nav().kind().to_wire();
        self.aids.controls[which].record(t_ns, &out, frame);
        self.aids.last_rejected = !out.fused;
        let k = which;
        if out.fused {
            self.coasting = false;
            self.resumed = false;
            if self.aids.reset_pending_flag == Some(k) {
                self.aids.reset_pending_flag = None;
            }
            self.aids.streaks[k].fused(t_ns, &m.z, &m.h, &m.r, &out.dx);
            self.feed_back(t_ns, &out.dx);
        } else {
            let max_gap_ns = self.aids.controls[k].timeout_ns;
            self.aids.streaks[k].rejected(
                t_ns,
                &m.z,
                &m.r,
                out.nis,
                &out.innovation_var,
                &out.state_var,
                max_gap_ns,
            );
            self.maybe_reset(which, t_ns, m, shares);
        }
        AidOutcome {
            gated: true,
            fused: out.fused,
            test_ratio: out.test_ratio,
            excluded_body: None,
        }
    }

    /// Closed-loop feedback of an estimated error `dx` at `t_ns`.
    pub(super) fn feed_back(&mut self, t_ns: u64, dx: &SVector<f64, 15>) {
        let part = |o: usize| Vector3::new(dx[o], dx[o + 1], dx[o + 2]);
        let (phi, dv, dp) = (part(idx::PHI), part(idx::DV), part(idx::DP));
        self.nominal.correct(&phi, &dv, &dp);
        // Only states an aid may still be fused against (within the latency limit).
        let oldest = t_ns.min(self.t_ns).saturating_sub(self.aids.max_latency_ns);
        self.history.correct(oldest, &phi, &dv, &dp);
        self.err.gyro_bias += part(idx::BG);
        self.err.accel_bias += part(idx::BA);
        self.err.tape_update(dx);
    }

    /// After a rejection: if the aid's streak has lasted `reset_after_s` and
    /// the aid is healthy by [`super::recovery`]'s tests, reset to it.
    fn maybe_reset<const M: usize>(
        &mut self,
        which: AidKind,
        t_ns: u64,
        m: &Measurement<M>,
        shares: &ConsiderShares,
    ) {
        let after = self.aids.reset_after_ns;
        let streak = &self.aids.streaks[which];
        if after == 0 || streak.duration_ns(t_ns) < after {
            return;
        }
        let c = &self.aids.controls[which];
        let Some(verdict) = streak.verdict(t_ns, c.gate, c.timeout_ns) else {
            return;
        };
        if !verdict.healthy() {
            return;
        }
        self.reset_to_aid(which, t_ns, m, &verdict, shares);
    }

    /// Resets the states the aid observes to its measurement `m` with its σ:
    /// the covariance of the other states is scaled by the measured
    /// inflation κ of H P Hᵀ (P ← D P D, D = √κ off the observed block, which keeps P
    /// positive definite), the bias variances are raised to at least the
    /// stationary variance of the widest grade's bias model and the bias
    /// process noise to that model for the rest of the run (see
    /// [`super::recovery`]: κ cannot say how the misfit is shared among the
    /// unobserved states, and a wrong bias model is not a one-time error),
    /// the observed states' is widened along the
    /// measurement, and the measurement is fused without a gate. The step
    /// is published as a reset (count, time, deltas). An update that fails
    /// leaves everything as it was.
    ///
    /// The observed states are those of the aid's observed blocks that this
    /// measurement's H reaches (a GNSS fix without velocity does not observe
    /// the velocity: it is scaled by κ like any unobserved state). Their
    /// prior is widened in the measurement's units by [`observed_widening`]
    /// (before, by Gᵀ Λ G, which is right only where H is the identity: a
    /// GNSS fix in metres of a latitude in radians put the reset 467 km off
    /// on paper 003's aircraft), so the prior no longer counts.
    fn reset_to_aid<const M: usize>(
        &mut self,
        which: AidKind,
        t_ns: u64,
        m: &Measurement<M>,
        verdict: &StreakVerdict,
        shares: &ConsiderShares,
    ) {
        // σ at most 10⁴ times what P said: beyond, the state is unknown anyway.
        const KAPPA_MAX: f64 = 1e8;
        let before = self.err.p;
        let reached = |o: &usize| m.h.fixed_view::<M, 3>(0, *o).iter().any(|x| *x != 0.0);
        let mut observed = [0_usize; 2];
        let mut n_observed = 0;
        for o in observed_blocks(which).iter().filter(|o| reached(o)).take(2) {
            observed[n_observed] = *o;
            n_observed += 1;
        }
        let observed = &observed[..n_observed];
        // The observed blocks' widening, before anything changes: nothing
        // to reset to without it.
        let Some(widening) = observed_widening(m, &before, observed) else {
            return;
        };
        // A position without the velocity: the velocity error the streak saw.
        let velocity_widening = if observed.contains(&idx::DP) && !observed.contains(&idx::DV) {
            let f = self.nominal.nav().error_dynamics(&Vector3::zeros());
            let f_pv = f.fixed_view::<3, 3>(idx::DP, idx::DV).into_owned();
            // No rate, or not finite: the reset goes ahead with κ alone.
            verdict.rate.and_then(|r| rate_widening(m, &f_pv, &r))
        } else {
            None
        };
        // The smoother carries nothing back across a reset.
        self.err.tape_break();
        let old = self.solution();
        let kappa = verdict.covariance_inflation.min(KAPPA_MAX);
        let mut d = SVector::<f64, 15>::repeat(kappa.sqrt());
        for &o in observed {
            for i in o..o + 3 {
                d[i] = 1.0;
            }
        }
        let mut p = self.err.p;
        for i in 0..15 {
            for j in 0..15 {
                p[(i, j)] *= d[i] * d[j];
            }
        }
        // The states' errors scaled by D: so is their covariance with the
        // magnetometer's persistent error (raising a diagonal below keeps
        // the augmented covariance positive semi-definite).
        let consider_before = (self.err.consider, self.err.gnss_c);
        for i in 0..15 {
            self.err.consider[i] *= d[i];
            for j in 0..3 {
                self.err.gnss_c[(i, j)] *= d[i];
            }
        }
        // Raising a diagonal element adds a positive semi-definite matrix:
        // P stays positive definite, and the bias states' correlations with
        // the rest shrink instead of carrying the wrong model's proportions.
        let bound = SensorGrade::widest_bias_model();
        for i in 0..3 {
            let (bg, ba) = (idx::BG + i, idx::BA + i);
            p[(bg, bg)] = p[(bg, bg)].max(bound.gyro_sigma.powi(2));
            p[(ba, ba)] = p[(ba, ba)].max(bound.accel_sigma.powi(2));
        }
        for (a, &oa) in observed.iter().enumerate() {
            for (b, &ob) in observed.iter().enumerate() {
                let mut block = p.fixed_view_mut::<3, 3>(oa, ob);
                block += widening.fixed_view::<3, 3>(3 * a, 3 * b);
            }
        }
        if let Some(w) = velocity_widening {
            let mut block = p.fixed_view_mut::<3, 3>(idx::DV, idx::DV);
            block += w;
        }
        filter::symmetrize(&mut p);
        self.err.p = p;
        let Some(out) = self.err.update(m, f64::INFINITY, shares) else {
            self.err.p = before;
            (self.err.consider, self.err.gnss_c) = consider_before;
            return;
        };
        self.feed_back(t_ns, &out.dx);
        let widened = self.err.noise.widen_biases(&bound);
        self.aids.last_reset_widened = widened.then_some(bound);
        self.aids.resets[which] += 1;
        self.aids.last_reset_verdict = Some(*verdict);
        self.aids.reset_pending_flag = Some(which);
        self.aids.clear_streaks();
        self.record_reset(&old);
    }

    /// The body's rate against inertial space (rad/s, body axes): the
    /// newest IMU increment's, the gyro bias estimate removed (zero before
    /// the second sample).
    pub(super) fn body_rate(&self) -> Vector3<f64> {
        self.prev_inc
            .filter(|i| i.dt_s > 0.0)
            .map_or_else(Vector3::zeros, |i| i.d_theta / i.dt_s)
    }

    /// Offers one aid sample: counters, selection, time check, the aid's
    /// model at its own time, fusion.
    pub fn on_aid(&mut self, sample: &AidSample) -> Result<AidOutcome, InputRejection> {
        msgs::match_aid!(sample, x => self.on_aid_of(x, false))
    }

    /// [`Self::on_aid`] for a sample its integrity test bars from fusion
    /// (its aid is excluded, or the sample could not be tested): checked
    /// and counted as any other (a late or invalid sample is refused for
    /// that), and one that would have reached its gate is counted as
    /// `rejected_integrity` instead.
    pub fn on_barred_aid(&mut self, sample: &AidSample) -> Result<AidOutcome, InputRejection> {
        msgs::match_aid!(sample, x => self.on_aid_of(x, true))
    }

    /// Whether [`Self::on_aid`] would take `sample` to its aid's model:
    /// the aid is selected, the stamp within reach and not a repeat of the
    /// last fused one. What the integrity test is run on.
    pub fn aid_reaches_model(&self, sample: &AidSample) -> bool {
        let which = sample.kind();
        let t_ns = sample.t_ns();
        let c = &self.aids.controls[which];
        self.aids.enabled.has(which)
            && self.aid_age(t_ns).is_ok()
            && !(t_ns <= c.counters.last_t_ns && c.counters.accepted > 0)
    }

    /// [`Self::on_aid`] for one aid's payload.
    fn on_aid_of<A: OwnOf>(&mut self, x: &A, barred: bool) -> Result<AidOutcome, InputRejection> {
        let which = A::KIND;
        let t_ns = x.t_ns();
        self.aids.controls[which].received();
        if !self.aids.enabled.has(which) {
            self.aids.controls[which].counters.not_used += 1;
            return Ok(AidOutcome {
                gated: false,
                fused: false,
                test_ratio: f64::NAN,
                excluded_body: None,
            });
        }
        let age = match self.aid_age(t_ns) {
            Ok(a) => a,
            Err(e) => {
                self.aids.controls[which].rejected_time();
                return Err(e);
            }
        };
        let c = &self.aids.controls[which];
        if t_ns <= c.counters.last_t_ns && c.counters.accepted > 0 {
            let prev_ns = c.counters.last_t_ns;
            self.aids.controls[which].rejected_time();
            return Err(InputRejection::TimeNotIncreasing { t_ns, prev_ns });
        }
        self.propagate_covariance();
        let at = self.state_at(t_ns, age);
        let ctx = Context {
            omega_ib_b: self.body_rate(),
        };
        let measured: Result<Measured, AidError> =
            x.measure(&at, &ctx, A::own(&self.aids.settings.own));
        let Measured {
            m,
            excluded_body,
            shares,
        } = match measured {
            Ok(m) => m,
            Err(e) => {
                self.aids.controls[which].refused(e.cause());
                return Err(e.into());
            }
        };
        if barred {
            let c = &mut self.aids.controls[which];
            c.counters.rejected_integrity += 1;
            c.status.fused = 0;
            return Ok(AidOutcome {
                gated: false,
                fused: false,
                test_ratio: f64::NAN,
                excluded_body: None,
            });
        }
        let mut out = match &m {
            AnyMeasurement::D1(m) => self.fuse(which, t_ns, m, &shares),
            AnyMeasurement::D2(m) => self.fuse(which, t_ns, m, &shares),
            AnyMeasurement::D3(m) => self.fuse(which, t_ns, m, &shares),
            AnyMeasurement::D6(m) => self.fuse(which, t_ns, m, &shares),
        };
        out.excluded_body = excluded_body;
        if excluded_body.is_some() {
            self.aids.controls[which].status.exclusions += 1;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SMatrix;

    /// Every aid observes at most two blocks ([`observed_widening`] is sized
    /// for six states), each the first of a 3-state block.
    #[test]
    fn every_aid_observes_at_most_two_blocks() {
        for k in AidKind::ALL {
            let o = observed_blocks(k);
            assert!(!o.is_empty() && o.len() <= 2, "{}: {o:?}", k.name());
            assert!(
                o.iter().all(|b| b % 3 == 0 && *b < 15),
                "{}: {o:?}",
                k.name()
            );
        }
    }

    /// A position without the velocity (a fix in metres of a latitude and
    /// longitude in radians, in g): the velocity's prior grows so that the
    /// velocity as the aid sees it (G_v = H_p F_pv, here the identity up
    /// to rounding, computed from the frame's own F) has the second
    /// moment the streak measured: G_v W G_vᵀ = ż żᵀ + cov ż, with a
    /// covariance that correlates east and north (1e-9). A baro (one
    /// component, up) widens the vertical velocity only.
    #[test]
    fn a_position_reset_widens_the_velocity_by_the_streaks_rate() {
        use crate::earth::{Geodetic, geodetic_to_ecef};
        use crate::mech::FrameKind;
        let geo = Geodetic::from_deg(45.0, 7.0, 1000.0);
        let nav = AnyNav::from_frame_free(
            FrameKind::Geographic,
            &geodetic_to_ecef(&geo),
            &Vector3::new(10.0, -40.0, 3.0),
            &nalgebra::UnitQuaternion::identity(),
        );
        let f = nav.error_dynamics(&Vector3::zeros());
        let f_pv = f.fixed_view::<3, 3>(idx::DP, idx::DV).into_owned();
        let (rm, rn) = crate::earth::radii(geo.lat_rad);
        let mut h = SMatrix::<f64, 3, 15>::zeros();
        // East, north, up metres of (δL, δλ, δh).
        h.fixed_view_mut::<3, 3>(0, idx::DP)
            .copy_from(&Matrix3::new(
                0.0,
                (rn + geo.h_m) * geo.lat_rad.cos(),
                0.0,
                rm + geo.h_m,
                0.0,
                0.0,
                0.0,
                0.0,
                1.0,
            ));
        let r = SMatrix::<f64, 3, 3>::from_diagonal(&Vector3::new(2.25, 2.25, 9.0));
        let cov = [[0.09, 0.05, 0.0], [0.05, 0.09, 0.01], [0.0, 0.01, 0.36]];
        let rate = Rate {
            z_dot: [1.2, -0.75, 0.3],
            cov,
        };
        let m = Measurement {
            z: SVector::<f64, 3>::new(30.0, -10.0, 5.0),
            h,
            r,
        };
        let w = rate_widening(&m, &f_pv, &rate).expect("widening");
        let g_v = h.fixed_view::<3, 3>(0, idx::DP) * f_pv;
        println!("G_v = {g_v:.6}");
        assert!((g_v - Matrix3::identity()).amax() < 1e-3, "{g_v}");
        let z_dot = Vector3::new(1.2, -0.75, 0.3);
        let want = z_dot * z_dot.transpose() + Matrix3::from_fn(|i, j| cov[i][j]);
        let seen = g_v * w * g_v.transpose();
        assert!(
            (seen - want).amax() <= 1e-9 * want.amax(),
            "{seen} vs {want}"
        );
        // Baro: the vertical velocity only.
        let mut hb = SMatrix::<f64, 1, 15>::zeros();
        hb[(0, idx::DP + 2)] = 1.0;
        let mb = Measurement {
            z: SVector::<f64, 1>::new(20.0),
            h: hb,
            r: SMatrix::<f64, 1, 1>::new(100.0),
        };
        let wb = rate_widening(&mb, &f_pv, &rate).expect("widening");
        // Its one component: the rate's first and its variance.
        let vertical = 1.2f64.powi(2) + 0.09;
        assert!((wb[(2, 2)] - vertical).abs() <= 1e-9 * vertical);
        assert!(wb.fixed_view::<2, 2>(0, 0).amax() <= 1e-9 * vertical);
    }

    /// The widening is the pseudo-inverse's: against the right inverse
    /// Gᵀ(G Gᵀ)⁻¹ for a full-rank G in mixed units (a GNSS-like position
    /// in metres of radians, 6.4·10⁶ m/rad), and for a rank-2 G (a
    /// baseline's skew(b): rotation about b unseen) G W Gᵀ is Λ projected on
    /// G's range and W adds nothing along b, where G Gᵀ has no inverse.
    #[test]
    fn the_widening_is_lambda_in_the_measurements_units() {
        let p = Mat15::identity() * 1e-12;
        // Full rank, position block in rad → m.
        let mut h = SMatrix::<f64, 3, 15>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::DP)
            .copy_from(&Matrix3::new(
                6.37e6, 0.0, 0.0, 0.0, 4.9e6, 0.0, 0.0, 0.0, 1.0,
            ));
        h[(0, idx::PHI + 1)] = 0.3;
        let m = Measurement {
            z: SVector::<f64, 3>::new(31.0, -12.0, 4.0),
            h,
            r: SMatrix::<f64, 3, 3>::identity() * 1e-4,
        };
        let w = observed_widening(&m, &p, &[idx::DP]).expect("widening");
        let g = h.fixed_view::<3, 3>(0, idx::DP).into_owned();
        let right = g.transpose() * (g * g.transpose()).try_inverse().expect("inverse");
        let s = h * p * h.transpose() + m.r;
        let lambda = Matrix3::from_fn(|i, j| {
            if i == j {
                1e4 * (m.z[i] * m.z[i] + s[(i, i)])
            } else {
                0.0
            }
        });
        let want = right * lambda * right.transpose();
        let got = w.fixed_view::<3, 3>(0, 0);
        for (a, b) in got.iter().zip(want.iter()) {
            assert!((a - b).abs() <= 1e-9 * b.abs().max(1e-30), "{a} vs {b}");
        }
        // The measured quantity's prior grows by exactly Λ.
        let seen = g * got * g.transpose();
        assert!((seen - lambda).norm() <= 1e-9 * lambda.norm());
        assert!(w.fixed_view::<3, 3>(3, 3).iter().all(|x| *x == 0.0));

        // Rank 2: a baseline along (1, 2, 2)/3 sees tilts across it only.
        let b = Vector3::new(1.0, 2.0, 2.0) / 3.0 * 0.8;
        let mut h = SMatrix::<f64, 3, 15>::zeros();
        h.fixed_view_mut::<3, 3>(0, idx::PHI)
            .copy_from(&b.cross_matrix());
        let m = Measurement {
            z: SVector::<f64, 3>::new(0.02, -0.01, 0.0),
            h,
            r: SMatrix::<f64, 3, 3>::identity() * 1e-6,
        };
        let w = observed_widening(&m, &p, &[idx::PHI]).expect("widening");
        let w3 = w.fixed_view::<3, 3>(0, 0).into_owned();
        let axis = b.normalize();
        assert!(
            (w3 * axis).norm() <= 1e-9 * w3.norm(),
            "widened along the baseline"
        );
        // What it sees grows along both directions of G's range, here by
        // more than the smallest Λ (0.49 and 3.3 against Λ of 0.01 to 4:
        // with G rank-deficient the row scaling makes G W Gᵀ an oblique
        // projection of Λ rather than Λ itself).
        let g = b.cross_matrix();
        let seen = g * w3 * g.transpose();
        let s = h * p * h.transpose() + m.r;
        let smallest = (0..3)
            .map(|i| 1e4 * (m.z[i] * m.z[i] + s[(i, i)]))
            .fold(f64::INFINITY, f64::min);
        let eig = seen.symmetric_eigen();
        let mut seen_sorted: Vec<f64> = eig.eigenvalues.iter().copied().collect();
        seen_sorted.sort_by(f64::total_cmp);
        assert!(
            seen_sorted[0].abs() <= 1e-9 * seen_sorted[2],
            "{seen_sorted:?}"
        );
        assert!(
            seen_sorted[1] >= smallest,
            "{seen_sorted:?} against {smallest}"
        );
        // G Gᵀ itself is singular here: the right inverse does not exist.
        assert!((g * g.transpose()).determinant().abs() < 1e-12);
    }
}
