//! Error state and covariance: the 15-state P, the bias estimates fed back
//! into the IMU compensation, the interval accumulated for the next
//! propagation, the conversion of P at a frame switch, the covariance of a
//! coasted gap, and the guard that re-inflates a P that lost finiteness or
//! positive definiteness.

use msgs::InitState;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::aids::{ConsiderShares, Correlated, Measurement};
use crate::earth;
use crate::error_model::{Mat15, idx};
use crate::filter::{self, ProcessNoise, UpdateOutcome};
use crate::frames;
use crate::mech::{AnyNav, FrameKind, Increment, Nominal};
use crate::settings::FilterSettings;
use crate::switch;

use super::INIT_SIGMA_FLOOR;

/// The error covariance, the bias estimates and the propagation interval.
#[derive(Debug, Clone)]
pub(super) struct ErrorState {
    pub(super) p: Mat15,
    pub(super) gyro_bias: Vector3<f64>,
    pub(super) accel_bias: Vector3<f64>,
    /// Time and body Δv accumulated since the last propagation.
    pub(super) acc_dt: f64,
    pub(super) acc_dv_b: Vector3<f64>,
    pub(super) noise: ProcessNoise,
    interval_s: f64,
    bias_sigma: BiasSigma,
    /// Covariance repairs so far.
    pub(super) repairs: u64,
    /// Propagations so far (part of the navigator's work count).
    pub(super) propagations: u64,
    /// The smoother's record of every change of P and every correction,
    /// when one is kept ([`crate::smoother`]; drained by the session).
    pub(super) tape: Option<Vec<u8>>,
    /// Sensor time (ns) of the nominal state as the increments advance it,
    /// set to the IMU stamp after each sample, and that of the last
    /// propagation: the ends of a propagation's interval on the tape.
    pub(super) clock_ns: f64,
    last_propagation_ns: f64,
    /// cov(δx, b) of the magnetometer's persistent error b (the model's
    /// declination error: one error for a flight, not noise), carried as
    /// a consider parameter ([`filter::update_considering`]): propagated
    /// and converted with P, updated by every aid's update, kept by a
    /// checkpoint, zero until the magnetometer is first fused and after a
    /// repair. While it is zero every update is [`filter::update`] itself.
    pub(super) consider: SVector<f64, 15>,
    /// The variance of b that `consider` is the covariance with (0 while
    /// `consider` is zero). The model's σ changes along a flight (it grows
    /// as the horizontal field weakens). A sample of larger σ adds an error
    /// independent of the old one to b (c unchanged, the variance raised);
    /// a sample of smaller σ cannot take error away from b, so it is fused
    /// with the variance b already has (its R raised by the difference):
    /// never more confident than the largest σ met. (Rescaling b with the
    /// σ would tell the filter how the error changes, which it does not
    /// know, and make heading observable from two samples of different σ.)
    pub(super) consider_var: f64,
    /// The init's attitude was aligned from the magnetometer's heading
    /// (its `method` says so): its heading error is the magnetometer's
    /// persistent error, which the first magnetometer sample writes into
    /// `consider` before it is fused.
    pub(super) consider_from_alignment: bool,
    /// cov(δx, b) of the GNSS receiver's correlated position error b (a
    /// Gauss–Markov process in the navigation frame's axes,
    /// [`crate::aids::Correlated`]), carried as three consider parameters
    /// beside the magnetometer's: propagated with Φ and decayed by
    /// e^(−Δt/τ), turned with the axes at a frame switch, updated by every
    /// aid's update, kept by a checkpoint, zero until the first fix that
    /// declares the share and after a repair. While it is zero and no fix
    /// declares one, the updates are those without it.
    pub(super) gnss_c: SMatrix<f64, 15, 3>,
    /// b's stationary variances per axis (m²; 0 while `gnss_c` is zero):
    /// the largest any fix declared (as the magnetometer's).
    pub(super) gnss_b: Vector3<f64>,
    /// b's correlation time (s).
    pub(super) gnss_tau_s: f64,
}

impl ErrorState {
    /// P₀ for a start at `nav_g` (the state in g) in frame `kind` ([`p0_in`]).
    pub(super) fn new(
        nav_g: &AnyNav,
        kind: FrameKind,
        init: &InitState,
        f: &FilterSettings,
    ) -> Self {
        let bias_sigma = BiasSigma::from_settings(f);
        let p = p0_in(kind, nav_g, init, &bias_sigma);
        Self {
            p,
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            acc_dt: 0.0,
            acc_dv_b: Vector3::zeros(),
            noise: f.process_noise(),
            interval_s: f.covariance_interval_s,
            bias_sigma,
            repairs: 0,
            propagations: 0,
            tape: None,
            clock_ns: 0.0,
            last_propagation_ns: 0.0,
            consider: SVector::zeros(),
            consider_var: 0.0,
            consider_from_alignment: init.init_method()
                == Some(msgs::InitMethod::AidHeading(msgs::AidKind::Mag)),
            gnss_c: SMatrix::zeros(),
            gnss_b: Vector3::zeros(),
            gnss_tau_s: f64::INFINITY,
        }
    }

    /// Sets the tape clock to the sensor time `t_ns` (after each IMU
    /// sample, and at a start or re-synchronization, `restart`).
    pub(super) fn set_clock(&mut self, t_ns: u64, restart: bool) {
        self.clock_ns = t_ns as f64;
        if restart {
            self.last_propagation_ns = self.clock_ns;
        }
    }

    /// Records a correction fed back.
    pub(super) fn tape_update(&mut self, dx: &SVector<f64, 15>) {
        if let Some(t) = &mut self.tape {
            super::tape::write::update(t, dx);
        }
    }

    /// Records a break with P as it is now: no information flows back past it.
    pub(super) fn tape_break(&mut self) {
        if let Some(t) = &mut self.tape {
            super::tape::write::brk(t, &self.p);
        }
    }

    /// An increment with the bias estimates removed.
    pub(super) fn compensate(
        &self,
        d_theta: &Vector3<f64>,
        d_v: &Vector3<f64>,
        dt_s: f64,
    ) -> Increment {
        Increment {
            d_theta: d_theta - self.gyro_bias * dt_s,
            d_v: d_v - self.accel_bias * dt_s,
            dt_s,
        }
    }

    /// Adds one increment to the interval; true when a propagation is due.
    pub(super) fn accumulate(&mut self, inc: &Increment) -> bool {
        self.acc_dt += inc.dt_s;
        self.clock_ns += inc.dt_s * 1e9;
        self.acc_dv_b += inc.d_v;
        self.acc_dt >= self.interval_s * (1.0 - 1e-9)
    }

    /// P brought up to the current time with the mean specific force of the
    /// interval; a P that is no longer usable is repaired (true if so).
    pub(super) fn propagate(&mut self, nominal: &Nominal) -> bool {
        if self.acc_dt <= 0.0 {
            return false;
        }
        self.propagations += 1;
        let f_b = self.acc_dv_b / self.acc_dt;
        let mut f = nominal.nav().error_dynamics(&f_b);
        self.noise.add_bias_dynamics(&mut f);
        if let Some(t) = &mut self.tape {
            super::tape::write::propagate(
                t,
                self.last_propagation_ns,
                self.clock_ns,
                self.acc_dt,
                &f_b,
                nominal.nav(),
                &self.noise,
                &self.p,
            );
        }
        self.last_propagation_ns = self.clock_ns;
        let phi = filter::propagate(&mut self.p, &f, &self.noise, self.acc_dt);
        if self.consider != SVector::<f64, 15>::zeros() {
            self.consider = phi * self.consider;
        }
        self.gnss_c = self.propagated_gnss_c(&phi);
        // The bias estimates decay by their Gauss–Markov share between
        // updates; a turn-on part beyond the wander stays
        // ([`ProcessNoise::bias_decay`]; constant biases when τ = ∞).
        let (dg, da) = self.noise.bias_decay(
            self.acc_dt,
            (self.bias_sigma.gyro_rps, self.bias_sigma.accel_mps2),
        );
        self.gyro_bias *= dg;
        self.accel_bias *= da;
        self.acc_dt = 0.0;
        self.acc_dv_b = Vector3::zeros();
        if covariance_usable(&self.p) {
            return false;
        }
        self.repair(nominal);
        true
    }

    /// P and the GNSS receiver's C as a propagation to the current time
    /// would make them, computed on copies: nothing of this error state
    /// changes (the integrity test reads the reference navigator's P
    /// without touching it).
    pub(super) fn current_p(&self, nominal: &Nominal) -> (Mat15, SMatrix<f64, 15, 3>) {
        let mut p = self.p;
        let mut c = self.gnss_c;
        if self.acc_dt > 0.0 {
            let f_b = self.acc_dv_b / self.acc_dt;
            let mut f = nominal.nav().error_dynamics(&f_b);
            self.noise.add_bias_dynamics(&mut f);
            let phi = filter::propagate(&mut p, &f, &self.noise, self.acc_dt);
            c = self.propagated_gnss_c(&phi);
        }
        (p, c)
    }

    /// The receiver's C over the accumulated interval with transition
    /// `phi`: cov(Φ δx, ρ b + w) = Φ C ρ, ρ = e^(−Δt/τ) (the receiver's
    /// error forgets; zero stays zero).
    fn propagated_gnss_c(&self, phi: &Mat15) -> SMatrix<f64, 15, 3> {
        if self.gnss_c == SMatrix::<f64, 15, 3>::zeros() {
            return self.gnss_c;
        }
        phi * self.gnss_c * (-self.acc_dt / self.gnss_tau_s).exp()
    }

    /// Replaces a covariance that lost finiteness or positive definiteness
    /// by the re-inflated one a cold start would have (P₀ from wide σ, in
    /// the current frame) and counts it: a published σ is never a NaN in
    /// disguise.
    pub(super) fn repair(&mut self, nominal: &Nominal) {
        let wide = InitState {
            sigma_pos_h_m: REPAIR_SIGMA.0,
            sigma_pos_v_m: REPAIR_SIGMA.0,
            sigma_vel_h_mps: REPAIR_SIGMA.1,
            sigma_vel_v_mps: REPAIR_SIGMA.1,
            sigma_tilt_rad: REPAIR_SIGMA.2,
            sigma_heading_rad: REPAIR_SIGMA.2,
            ..Default::default()
        };
        let nav_g = nominal.nav().converted(FrameKind::Geographic);
        self.p = p0_in(nominal.kind(), &nav_g, &wide, &self.bias_sigma);
        self.consider = SVector::zeros();
        self.consider_var = 0.0;
        self.consider_from_alignment = false;
        self.gnss_c = SMatrix::zeros();
        self.gnss_b = Vector3::zeros();
        self.tape_break();
        self.repairs += 1;
    }

    /// P = Φ P Φᵀ for a switch from the state `before` to frame `to`.
    pub(super) fn convert(&mut self, to: FrameKind, before: &AnyNav) {
        if let Some(t) = &mut self.tape {
            super::tape::write::convert(t, to, before, &self.p);
        }
        let phi = phi_to(to, before);
        self.p = phi * self.p * phi.transpose();
        filter::symmetrize(&mut self.p);
        self.consider = phi * self.consider;
        if self.gnss_c != SMatrix::<f64, 15, 3>::zeros() {
            // b's axes are the frame's: g and G differ by the grid angle's
            // turn about up, which leaves b's variances (equal
            // horizontally) as they are and turns its covariance with δx.
            let geo = before.geodetic();
            let c_g_grid = frames::c_g_grid(frames::grid_angle(geo.lat_rad, geo.lon_rad));
            let turn = match to {
                FrameKind::Grid => c_g_grid,
                FrameKind::Geographic => c_g_grid.transpose(),
            };
            self.gnss_c = phi * self.gnss_c * turn.transpose();
        }
    }

    /// The covariance of an unknown manoeuvre over a coasted gap of `t` s:
    /// acceleration of 1-σ `sa` (δv = a t, δp = a t²/2 per axis) and turn
    /// rate `sw`.
    pub(super) fn add_coast(&mut self, nominal: &Nominal, sa: f64, sw: f64, t: f64) {
        let var_v = (sa * t).powi(2);
        let var_p = (0.5 * sa * t * t).powi(2);
        let var_phi = (sw * t).powi(2);
        let geo = nominal.geo();
        let m = nominal
            .nav()
            .position_error_to_enu(&frames::c_e_g(geo.lat_rad, geo.lon_rad));
        let m_inv = m.try_inverse().unwrap_or_else(Matrix3::identity);
        let add_p = m_inv * m_inv.transpose() * var_p;
        let before = self.tape.is_some().then_some(self.p);
        for i in 0..3 {
            self.p[(idx::DV + i, idx::DV + i)] += var_v;
            self.p[(idx::PHI + i, idx::PHI + i)] += var_phi;
            for j in 0..3 {
                self.p[(idx::DP + i, idx::DP + j)] += add_p[(i, j)];
            }
        }
        if let (Some(t), Some(before)) = (&mut self.tape, before) {
            super::tape::write::add(t, &before, &self.p);
        }
    }

    /// Gate and Joseph update. An update that would leave P or the
    /// correction non-finite or P not positive definite is undone (`None`).
    ///
    /// `persistent_var` is the share of R that is the magnetometer's
    /// persistent error (0 for every other aid): such a sample is fused
    /// with the consider parameter, and so is every sample while the
    /// parameter is not zero ([`filter::update_considering`]).
    /// `shares.correlated` is the share of a position's R that is the GNSS
    /// receiver's correlated error: while it or its covariance `gnss_c` is
    /// there, every sample is fused with all four consider parameters
    /// ([`filter::update_considering_block`]).
    pub(super) fn update<const M: usize>(
        &mut self,
        m: &Measurement<M>,
        gate: f64,
        shares: &ConsiderShares,
    ) -> Option<UpdateOutcome<M>> {
        let persistent_var = shares.persistent_var;
        let before = (
            self.p,
            self.consider,
            self.consider_var,
            self.consider_from_alignment,
            self.gnss_c,
            self.gnss_b,
            self.gnss_tau_s,
        );
        // A correlated share enters a position's three components.
        let correlated = shares.correlated.as_ref().filter(|_| M >= 3);
        let gnss = correlated.is_some() || self.gnss_c != SMatrix::<f64, 15, 3>::zeros();
        let out = if persistent_var > 0.0 || self.consider != SVector::<f64, 15>::zeros() || gnss {
            let u = SVector::<f64, M>::repeat(if persistent_var > 0.0 { 1.0 } else { 0.0 });
            let mut r = m.r;
            if persistent_var > 0.0 {
                if std::mem::take(&mut self.consider_from_alignment) {
                    self.seed_consider_from_alignment(&m.h, &u, persistent_var);
                }
                let a = self.consider_var.max(persistent_var);
                r += u * u.transpose() * (a - persistent_var);
                self.consider_var = a;
            }
            if gnss {
                self.update_with_gnss_consider(m, &r, &u, correlated, gate)
            } else {
                filter::update_considering(
                    &mut self.p,
                    &mut self.consider,
                    &m.z,
                    &m.h,
                    &r,
                    &u,
                    self.consider_var,
                    gate,
                )
            }
        } else {
            filter::update(&mut self.p, &m.z, &m.h, &m.r, gate)
        }
        .filter(|o| o.dx.iter().all(|x| x.is_finite()) && o.test_ratio.is_finite())
        .filter(|_| {
            covariance_usable(&self.p)
                && self.consider.iter().all(|x| x.is_finite())
                && self.gnss_c.iter().all(|x| x.is_finite())
        });
        if out.is_none() {
            (
                self.p,
                self.consider,
                self.consider_var,
                self.consider_from_alignment,
                self.gnss_c,
                self.gnss_b,
                self.gnss_tau_s,
            ) = before;
        }
        out
    }

    /// The update with the magnetometer's parameter and the receiver's
    /// three together (`u` and `r` as [`Self::update`] made them for the
    /// magnetometer's). A sample that declares a smaller share than b
    /// already has is fused with b's (its R raised by the difference), as
    /// the magnetometer's.
    fn update_with_gnss_consider<const M: usize>(
        &mut self,
        m: &Measurement<M>,
        r: &SMatrix<f64, M, M>,
        u: &SVector<f64, M>,
        correlated: Option<&Correlated>,
        gate: f64,
    ) -> Option<UpdateOutcome<M>> {
        let mut r = *r;
        let mut ug = SMatrix::<f64, M, 3>::zeros();
        if let Some(c) = correlated {
            let b = self.gnss_b.sup(&c.var);
            for i in 0..3 {
                ug[(i, i)] = 1.0;
                r[(i, i)] += b[i] - c.var[i];
            }
            self.gnss_b = b;
            self.gnss_tau_s = c.tau_s;
        }
        let mut cb = SMatrix::<f64, 15, 4>::zeros();
        cb.column_mut(0).copy_from(&self.consider);
        cb.fixed_view_mut::<15, 3>(0, 1).copy_from(&self.gnss_c);
        let mut ub = SMatrix::<f64, M, 4>::zeros();
        ub.column_mut(0).copy_from(u);
        ub.fixed_view_mut::<M, 3>(0, 1).copy_from(&ug);
        let mut ab = SMatrix::<f64, 4, 4>::zeros();
        ab[(0, 0)] = self.consider_var;
        for i in 0..3 {
            ab[(1 + i, 1 + i)] = self.gnss_b[i];
        }
        let out =
            filter::update_considering_block(&mut self.p, &mut cb, &m.z, &m.h, &r, &ub, &ab, gate);
        self.consider = cb.column(0).into_owned();
        self.gnss_c = cb.fixed_view::<15, 3>(0, 1).into_owned();
        out
    }

    /// After an alignment from the magnetometer's heading, the attitude's
    /// error along what the magnetometer measures is its persistent error
    /// b with the sign that cancels it (the aligned attitude and the
    /// magnetometer agree: H δx ≈ −b): c = −P Hᵀ u a / max(H P Hᵀ, a),
    /// the regression of δx on H δx times cov(H δx, b) = −a (bounded so
    /// that [[P, c], [cᵀ, a]] stays positive semi-definite).
    fn seed_consider_from_alignment<const M: usize>(
        &mut self,
        h: &SMatrix<f64, M, 15>,
        u: &SVector<f64, M>,
        a: f64,
    ) {
        if M != 1 {
            return;
        }
        let pht = self.p * h.transpose();
        let var = (h * pht)[(0, 0)];
        if var.is_finite() && var > 0.0 {
            self.consider = -pht.column(0) * (u[0] * a / var.max(a));
            self.consider_var = a;
        }
    }
}

/// Φ of the parameter conversion from `from` (a state in the other frame)
/// to `to` (papers/001 eqs 32–38).
pub(crate) fn phi_to(to: FrameKind, from: &AnyNav) -> Mat15 {
    let geo = from.geodetic();
    let v_grid = match (from, &from.converted(FrameKind::Grid)) {
        (AnyNav::Grid(g), _) | (_, AnyNav::Grid(g)) => g.v_n,
        _ => unreachable!("conversion to grid gives the grid frame"),
    };
    match to {
        FrameKind::Grid => switch::phi_geo_to_grid(&geo, &v_grid),
        FrameKind::Geographic => switch::phi_grid_to_geo(&geo, &v_grid),
    }
}

/// σ of the re-inflated covariance after a repair: position (m), velocity
/// (m/s), attitude (rad).
const REPAIR_SIGMA: (f64, f64, f64) = (1000.0, 10.0, 0.1);

/// A covariance the filter can go on with: every entry finite and every
/// variance positive (and not beyond 1e30: σ of 1e15 m or rad is no
/// information at all, and squaring it again would overflow).
fn covariance_usable(p: &Mat15) -> bool {
    // Over the storage as a slice: nalgebra's element iterator took longer
    // than the factorization below.
    p.as_slice().iter().all(|x| x.is_finite())
        && (0..15).all(|i| p[(i, i)] > 0.0 && p[(i, i)] < 1e30)
        && positive_definite(p)
}

/// Is P positive definite? See [`correlation_pivots`].
fn positive_definite(p: &Mat15) -> bool {
    correlation_pivots(p).is_some()
}

/// The pivots of P's correlation matrix D^-½ P D^-½ (so that states in rad²
/// and m² weigh alike) factored as L·diag(pivots)·Lᵀ by symmetric Gaussian
/// elimination, or `None` when one is not above 1e-12. The pivots are the
/// squares of the Cholesky factor's diagonal, so this is the Cholesky test
/// without a square root and divisions on each column's chain: on the
/// stack, about 1100 flops over the lower triangle, one reciprocal per
/// pivot on the chain, each
/// elimination step a run of independent multiply-adds (the left-looking
/// Cholesky it replaced waited on a square root, a division and a growing
/// dot product per column: 3 % of `batch --every 1` at 45° N, test
/// `pivots_are_the_squared_cholesky_diagonal`).
fn correlation_pivots(p: &Mat15) -> Option<[f64; 15]> {
    const N: usize = 15;
    let mut d = [0.0; N];
    for (i, x) in d.iter_mut().enumerate() {
        *x = 1.0 / p[(i, i)].sqrt();
    }
    // The correlation matrix's lower triangle by columns (`a[k][i]`: row
    // i ≥ k of column k).
    let mut a = [[0.0f64; N]; N];
    let s = p.as_slice();
    for (k, col) in a.iter_mut().enumerate() {
        for i in k..N {
            col[i] = s[k * N + i] * d[i] * d[k];
        }
    }
    let mut pivots = [0.0; N];
    for j in 0..N {
        let pivot = a[j][j];
        // NaN fails too.
        if pivot.partial_cmp(&1e-12) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        pivots[j] = pivot;
        let inv = 1.0 / pivot;
        let (done, rest) = a.split_at_mut(j + 1);
        let cj = &done[j];
        // Column k > j, rows i ≥ k: a_ik −= a_kj a_ij / a_jj.
        for (k, ck) in (j + 1..N).zip(rest.iter_mut()) {
            let f = cj[k] * inv;
            for (x, y) in ck[k..].iter_mut().zip(&cj[k..]) {
                *x -= f * y;
            }
        }
    }
    Some(pivots)
}

/// Initial 1-σ of the biases in SI units (from `[filter]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct BiasSigma {
    gyro_rps: f64,
    accel_mps2: f64,
}

impl BiasSigma {
    fn from_settings(f: &FilterSettings) -> Self {
        let dph = std::f64::consts::PI / 180.0 / 3600.0;
        let ug = 1e-6 * earth::G0;
        Self {
            gyro_rps: f.gyro_bias_dph * dph,
            accel_mps2: f.accel_bias_ug * ug,
        }
    }
}

/// P₀ for a start at `nav_g` (the state in g) in frame `kind`: stated in g
/// and, in G, converted with Φ as a switch would (one initialization path
/// in either frame, papers/001 eqs 26, 32–36: the conversion couples grid
/// heading with position through the grid angle, which a start stated in G
/// would lack, 0.5 m and 0.23′ within 50 s on paper-sim). Within one
/// position σ of the pole, where g's δλ is singular and the converted P
/// loses its east variance (none at all at 90° exactly), P₀ is stated in G
/// directly ([`initial_covariance`]).
fn p0_in(kind: FrameKind, nav_g: &AnyNav, init: &InitState, b: &BiasSigma) -> Mat15 {
    let geo = nav_g.geodetic();
    let (_, rn) = earth::radii(geo.lat_rad);
    let sigma_h = init.sigma_pos_h_m.max(INIT_SIGMA_FLOOR[0]).max(1.0);
    let near_pole = (rn + geo.h_m) * geo.lat_rad.cos().abs() < sigma_h;
    match kind {
        FrameKind::Grid if !near_pole => {
            let p_g = initial_covariance(FrameKind::Geographic, &geo, init, b);
            let phi = phi_to(FrameKind::Grid, nav_g);
            let mut p = phi * p_g * phi.transpose();
            filter::symmetrize(&mut p);
            p
        }
        _ => initial_covariance(kind, &geo, init, b),
    }
}

/// P₀ in frame `kind` at `geo`, from the init record's σ (floored at
/// [`INIT_SIGMA_FLOOR`]) and the configured bias uncertainty: uncorrelated,
/// horizontally isotropic in velocity, tilt and position.
///
/// In G it is stated in G directly (δr^e = C_e^gᵀ [E, N, U] with E, N σ_h
/// and U σ_v; φ and δv diagonal, which a rotation about up leaves as they
/// are): [`p0_in`] uses it within one position σ of the pole, where the
/// g-frame P₀ converted with Φ has no east variance at latitude 90° exactly
/// (found by `adversarial_inputs_keep_the_session_sound`). Away from the
/// pole its position block is the converted one's.
fn initial_covariance(
    kind: FrameKind,
    geo: &earth::Geodetic,
    init: &InitState,
    b: &BiasSigma,
) -> Mat15 {
    let mut p = Mat15::zeros();
    let sq = |x: f64| x * x;
    let f = INIT_SIGMA_FLOOR;
    let init = &InitState {
        sigma_pos_h_m: init.sigma_pos_h_m.max(f[0]),
        sigma_pos_v_m: init.sigma_pos_v_m.max(f[1]),
        sigma_vel_h_mps: init.sigma_vel_h_mps.max(f[2]),
        sigma_vel_v_mps: init.sigma_vel_v_mps.max(f[3]),
        sigma_tilt_rad: init.sigma_tilt_rad.max(f[4]),
        sigma_heading_rad: init.sigma_heading_rad.max(f[5]),
        ..*init
    };
    let mut set_diag = |o: usize, v: [f64; 3]| {
        for (i, x) in v.iter().enumerate() {
            p[(o + i, o + i)] = *x;
        }
    };
    set_diag(
        idx::PHI,
        [
            sq(init.sigma_tilt_rad),
            sq(init.sigma_tilt_rad),
            sq(init.sigma_heading_rad),
        ],
    );
    set_diag(
        idx::DV,
        [
            sq(init.sigma_vel_h_mps),
            sq(init.sigma_vel_h_mps),
            sq(init.sigma_vel_v_mps),
        ],
    );
    set_diag(idx::BG, [sq(b.gyro_rps); 3]);
    set_diag(idx::BA, [sq(b.accel_mps2); 3]);
    let (h, v) = (sq(init.sigma_pos_h_m), sq(init.sigma_pos_v_m));
    let (rm, rn) = earth::radii(geo.lat_rad);
    let pos = match kind {
        FrameKind::Grid => {
            let c = frames::c_e_g(geo.lat_rad, geo.lon_rad);
            c.transpose() * Matrix3::from_diagonal(&Vector3::new(h, h, v)) * c
        }
        FrameKind::Geographic => Matrix3::from_diagonal(&Vector3::new(
            h / sq(rm + geo.h_m),
            // Within one position σ of the pole the longitude is unknown by up
            // to a radian, not more (the parallel's radius is held at least
            // that σ, and 1 m).
            h / sq(((rn + geo.h_m) * geo.lat_rad.cos()).max(init.sigma_pos_h_m.max(1.0))),
            v,
        )),
    };
    p.fixed_view_mut::<3, 3>(idx::DP, idx::DP).copy_from(&pos);
    // Variances of zero (an exact init) would make P singular: floor them.
    for i in 0..15 {
        p[(i, i)] = p[(i, i)].max(1e-30);
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Cholesky factorization of the correlation matrix, row by row with
    /// square roots (the form the check had first): the reference for
    /// [`correlation_pivots`], an independent formulation of the same test.
    /// Its factor when every pivot is above 1e-12, and the deciding pivot:
    /// the smallest, or the first that fails.
    fn row_by_row(p: &Mat15) -> (Option<[[f64; 15]; 15]>, f64) {
        let mut d = [0.0; 15];
        for (i, x) in d.iter_mut().enumerate() {
            *x = 1.0 / p[(i, i)].sqrt();
        }
        let mut l = [[0.0f64; 15]; 15];
        let mut deciding = f64::INFINITY;
        for j in 0..15 {
            let pivot = 1.0 - l[j][..j].iter().map(|x| x * x).sum::<f64>();
            deciding = deciding.min(pivot);
            if pivot.partial_cmp(&1e-12) != Some(std::cmp::Ordering::Greater) {
                return (None, pivot);
            }
            let ljj = pivot.sqrt();
            l[j][j] = ljj;
            for i in j + 1..15 {
                let dot: f64 = l[i][..j].iter().zip(&l[j][..j]).map(|(a, b)| a * b).sum();
                l[i][j] = (p[(i, j)] * d[i] * d[j] - dot) / ljj;
            }
        }
        (Some(l), deciding)
    }

    /// The elimination decides as the row-by-row Cholesky does on
    /// covariances near and past the edge of positive definiteness (a
    /// correlation pushed towards ±1 until a pivot falls under 1e-12), and
    /// its pivots are the squares of the Cholesky diagonal within 1e-13
    /// (absolute, on the correlation scale of 1: two roundings of a sum of
    /// 15 products; the threshold is 1e-12).
    #[test]
    fn pivots_are_the_squared_cholesky_diagonal() {
        let mut s = 7u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut pd, mut not_pd, mut near_edge) = (0, 0, f64::INFINITY);
        for case in 0..400 {
            let a = Mat15::from_fn(|_, _| next());
            let mut p = a * a.transpose() + Mat15::identity() * 1e-3;
            // Scale states to the filter's mix of units.
            for i in 0..15 {
                let scale = 10f64.powi((i as i32 % 5) * 2 - 4);
                p.row_mut(i).scale_mut(scale);
                p.column_mut(i).scale_mut(scale);
            }
            // In half the cases, push one correlation towards ±1: from well
            // inside to past the edge.
            let (i, j) = (case % 15, (case / 15 + 1 + case % 15) % 15);
            if i != j && case >= 200 {
                let r = 1.0 - 10f64.powf(-(case as f64 % 17.0));
                let c = r * (p[(i, i)] * p[(j, j)]).sqrt() * if case % 2 == 0 { 1.0 } else { -1.0 };
                p[(i, j)] = c;
                p[(j, i)] = c;
            }
            let (reference, _) = row_by_row(&p);
            let pivots = correlation_pivots(&p);
            assert_eq!(positive_definite(&p), reference.is_some(), "case {case}");
            assert_eq!(pivots.is_some(), reference.is_some(), "case {case}");
            match (reference, pivots) {
                (Some(l), Some(piv)) => {
                    pd += 1;
                    for k in 0..15 {
                        let want = l[k][k] * l[k][k];
                        assert!(
                            (piv[k] - want).abs() <= 1e-13,
                            "case {case}: pivot {k} {} against {want}",
                            piv[k]
                        );
                        near_edge = near_edge.min(piv[k]);
                    }
                }
                _ => not_pd += 1,
            }
        }
        assert!(
            pd > 150 && not_pd > 50,
            "{pd} positive definite, {not_pd} not, smallest pivot {near_edge:e}"
        );
        // At the edge itself: correlation matrices Q Λ Qᵀ (Q orthonormal
        // from a random matrix's QR) with one eigenvalue λ = ±1e-6 down to
        // ±1e-18, so that the deciding pivot closes in on the threshold
        // from both sides: the decisions agree down to 1e-10 of it.
        let (mut edge_pd, mut edge_not, mut straddle) = (0, 0, 0);
        let mut nearest_fail = f64::NEG_INFINITY;
        for case in 0..300 {
            let q = Mat15::from_fn(|_, _| next()).qr().q();
            let lambda = 10f64.powf(-6.0 - 12.0 * (case as f64 / 299.0))
                * if case % 2 == 0 { 1.0 } else { -1.0 };
            let mut eig = SVector::<f64, 15>::repeat(1.0);
            eig[case % 15] = lambda;
            let c = q * Mat15::from_diagonal(&eig) * q.transpose();
            let scale = SVector::<f64, 15>::from_fn(|i, _| 10f64.powi((i as i32 % 5) * 2 - 4));
            let p = Mat15::from_fn(|i, j| c[(i, j)] * scale[i] * scale[j]);
            let (_, deciding) = row_by_row(&p);
            // Within 1e-10 of zero rounding decides: for a matrix singular
            // to working precision (|λ| ≤ 1e-12 against entries of 1) the
            // deciding pivot is rounding, of either sign (seen: −7e-13 by
            // the reference, above 1e-12 by the elimination, at λ = 3e-17).
            if deciding.abs() <= 1e-10 {
                straddle += 1;
                continue;
            }
            assert_eq!(
                positive_definite(&p),
                deciding > 1e-12,
                "edge case {case}: λ {lambda:e}, deciding pivot {deciding:e}"
            );
            if deciding > 1e-12 {
                edge_pd += 1;
                near_edge = near_edge.min(deciding);
            } else {
                edge_not += 1;
                nearest_fail = nearest_fail.max(deciding);
            }
        }
        assert!(
            edge_pd > 30 && edge_not > 30 && near_edge < 1e-8 && nearest_fail > -1e-8,
            "at the edge: {edge_pd} positive definite (smallest pivot {near_edge:e}), {edge_not} not (largest failing pivot {nearest_fail:e}), {straddle} decided by rounding"
        );
        eprintln!(
            "at the edge: {edge_pd} positive definite (smallest pivot {near_edge:e}), {edge_not} not (largest failing pivot {nearest_fail:e}), {straddle} decided by rounding"
        );
    }

    /// P₀ stated in G directly has the position block of the g-frame P₀
    /// converted with Φ (δr = T3 δp exactly) away from the pole, and at the
    /// pole itself, where g's δλ is singular, σ east = σ north = σ_h.
    #[test]
    fn grid_p0_matches_the_converted_one_off_the_pole_and_stays_full_rank_on_it() {
        let init = InitState {
            sigma_pos_h_m: 30.0,
            sigma_pos_v_m: 5.0,
            sigma_vel_h_mps: 0.5,
            sigma_vel_v_mps: 0.2,
            sigma_tilt_rad: 1e-3,
            sigma_heading_rad: 1e-2,
            ..Default::default()
        };
        let b = BiasSigma {
            gyro_rps: 1e-7,
            accel_mps2: 1e-3,
        };
        for &(lat_deg, lon_deg) in &[(80.0_f64, 30.0_f64), (-86.0, -120.0), (89.0, 179.0)] {
            let geo = earth::Geodetic {
                lat_rad: lat_deg.to_radians(),
                lon_rad: lon_deg.to_radians(),
                h_m: 18_000.0,
            };
            let p_g = initial_covariance(FrameKind::Geographic, &geo, &init, &b);
            let nav = AnyNav::Geographic(crate::mech::Nav {
                q_b_n: nalgebra::UnitQuaternion::identity(),
                v_n: Vector3::new(120.0, -40.0, 1.0),
                pos: geo,
            });
            let phi = phi_to(FrameKind::Grid, &nav);
            let converted = phi * p_g * phi.transpose();
            let direct = initial_covariance(FrameKind::Grid, &geo, &init, &b);
            let a = converted.fixed_view::<3, 3>(idx::DP, idx::DP).into_owned();
            let d = direct.fixed_view::<3, 3>(idx::DP, idx::DP).into_owned();
            assert!((a - d).norm() < 1e-9 * a.norm(), "{lat_deg}: {a} vs {d}");
        }
        let pole = earth::Geodetic {
            lat_rad: std::f64::consts::FRAC_PI_2,
            lon_rad: 0.3,
            h_m: 18_000.0,
        };
        let p = initial_covariance(FrameKind::Grid, &pole, &init, &b);
        let c = frames::c_e_g(pole.lat_rad, pole.lon_rad);
        let enu = c * p.fixed_view::<3, 3>(idx::DP, idx::DP) * c.transpose();
        for (i, want) in [30.0, 30.0, 5.0].iter().enumerate() {
            assert!(
                (enu[(i, i)].sqrt() - want).abs() < 1e-9 * want,
                "axis {i}: {}",
                enu[(i, i)].sqrt()
            );
        }
        assert!(covariance_usable(&p));
    }

    /// The hand-written check agrees with nalgebra's Cholesky (an
    /// independent factorization) on matrices that are clearly positive
    /// definite or clearly not, over variances from 1e-20 to 1e10.
    #[test]
    fn positive_definite_agrees_with_nalgebra_cholesky() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut pd, mut not_pd) = (0, 0);
        for case in 0..400 {
            // A = B Bᵀ + shift·I in correlation form, then scaled by D.
            let b = Mat15::from_fn(|_, _| next());
            let shift = if case % 2 == 0 { 0.5 } else { -3.0 };
            let a = b * b.transpose() / 15.0 + Mat15::identity() * shift;
            let d = Mat15::from_diagonal(&SVector::<f64, 15>::from_fn(|i, _| {
                10f64.powf(-10.0 + 10.0 * (i as f64 / 7.0 + next()).rem_euclid(2.0))
            }));
            let p = d * a * d;
            let reference = p.cholesky().is_some();
            assert_eq!(positive_definite(&p), reference, "case {case}");
            if reference {
                pd += 1;
            } else {
                not_pd += 1;
            }
        }
        assert!(
            pd > 100 && not_pd > 100,
            "{pd} positive definite, {not_pd} not"
        );
        // NaN and a zero variance are refused.
        let mut p = Mat15::identity();
        p[(3, 4)] = f64::NAN;
        p[(4, 3)] = f64::NAN;
        assert!(!covariance_usable(&p));
        let mut p = Mat15::identity();
        p[(7, 7)] = 0.0;
        assert!(!covariance_usable(&p));
    }

    /// A navigator at `lat_deg` that has fused one GNSS fix (near its own
    /// antenna) declaring a correlated share (1.5 m / 3 m, τ 300 s) of its
    /// 2 m / 3.5 m accuracy; the receiver's settings, the fix and its
    /// measurement.
    fn with_gnss_consider(
        lat_deg: f64,
        lon_deg: f64,
    ) -> (
        crate::navigator::Navigator,
        crate::aids::gnss::GnssSettings,
        msgs::GnssFix,
        crate::aids::Measured,
    ) {
        use crate::navigator::{Navigator, NavigatorConfig};
        let geo = earth::Geodetic::from_deg(lat_deg, lon_deg, 18_000.0);
        let c_g_e = frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose();
        let q = frames::quat_from_dcm(&c_g_e).into_inner();
        let init = InitState {
            t_ns: 1_000_000_000,
            r_e_m: earth::geodetic_to_ecef(&geo).into(),
            v_e_mps: (c_g_e * Vector3::new(30.0, 240.0, 1.0)).into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            ..heading_held_init()
        };
        let g = crate::aids::gnss::GnssSettings {
            lever_arm_b_m: [0.3, 1.5, 0.8],
            correlated_sigma_h_m: 1.5,
            correlated_sigma_v_m: 3.0,
            correlated_tau_s: 300.0,
            ..Default::default()
        };
        let mut cfg = NavigatorConfig::default();
        cfg.aid_settings.own.gnss = g.clone();
        let nav = Navigator::new(&init, &cfg);
        let ff = nav.nominal.nav().frame_free();
        let c_b_e = ff.q_b_e.to_rotation_matrix().into_inner();
        let l_b = Vector3::from(g.lever_arm_b_m);
        let omega_eb_b = -c_b_e.transpose() * earth::omega_ie_e();
        let r = ff.r_e + c_b_e * l_b;
        let v = ff.v_e + c_b_e * omega_eb_b.cross(&l_b);
        let fg = earth::ecef_to_geodetic(&r);
        let enu = frames::c_e_g(fg.lat_rad, fg.lon_rad) * v;
        let fix = msgs::GnssFix {
            t_ns: 1_000_000_000,
            lat_rad: fg.lat_rad + 1e-7,
            lon_rad: fg.lon_rad,
            height_m: fg.h_m - 2.0,
            vel_ned_mps: [enu.y, enu.x + 0.05, -enu.z],
            h_acc_m: 2.0,
            v_acc_m: 3.5,
            s_acc_mps: 0.1,
            pdop: 1.5,
            fix_type: msgs::gnss::fix_type::FIX_3D,
            flags: msgs::gnss::fix_flags::FIX_OK,
            num_sv: 12,
            ..Default::default()
        };
        let mut nav = nav;
        let ctx = crate::aids::Context {
            omega_ib_b: Vector3::zeros(),
        };
        let measured = crate::aids::Aid::measure(&fix, nav.nominal.nav(), &ctx, &g).expect("fix");
        let crate::aids::AnyMeasurement::D6(m) = measured.m else {
            panic!("position and velocity")
        };
        assert!(
            nav.err
                .update(&m, f64::INFINITY, &measured.shares)
                .is_some_and(|o| o.fused)
        );
        assert!(nav.err.gnss_c.amax() > 0.0);
        (nav, g, fix, measured)
    }

    /// The innovation covariance of `fix`'s position with the consider
    /// parameters (H P Hᵀ + H C Uᵀ + U Cᵀ Hᵀ + R, R the whole), in the
    /// axes of the navigator's frame.
    fn position_s(
        nav: &crate::navigator::Navigator,
        fix: &msgs::GnssFix,
        g: &crate::aids::gnss::GnssSettings,
    ) -> Matrix3<f64> {
        let m = crate::aids::gnss::measurement(nav.nominal.nav(), fix, &Vector3::zeros(), g)
            .expect("fix");
        let h3 = m.h.fixed_rows::<3>(0).into_owned();
        let hc = h3 * nav.err.gnss_c;
        h3 * nav.err.p * h3.transpose()
            + hc
            + hc.transpose()
            + m.r.fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// At a frame switch the receiver's parameters turn with the axes: the
    /// innovation covariance of the same fix, formed after the switch from
    /// P, C and H in the new frame, is the one formed before it turned by
    /// the grid angle (an independent route: the measurement model of each
    /// frame, not the conversion), G → g and back. Without the turn of C it
    /// is not (the check can fail: at 88° N, 40° E the grid angle is about
    /// 40°).
    #[test]
    fn a_frame_switch_turns_the_receivers_parameters_with_the_axes() {
        let (mut nav, g, fix, _) = with_gnss_consider(88.0, 40.0);
        let geo = nav.nominal.geo();
        let c_g_grid = frames::c_g_grid(frames::grid_angle(geo.lat_rad, geo.lon_rad));
        let first = nav.nominal.nav().kind();
        for to in [
            FrameKind::Geographic,
            FrameKind::Grid,
            FrameKind::Geographic,
            FrameKind::Grid,
        ] {
            let from = nav.nominal.nav().kind();
            if to == from {
                continue;
            }
            let s_from = position_s(&nav, &fix, &g);
            let turn = if to == FrameKind::Grid {
                c_g_grid
            } else {
                c_g_grid.transpose()
            };
            let unturned = {
                let mut n = nav.clone();
                let before = *n.nominal.nav();
                n.nominal.convert(to);
                let phi = phi_to(to, &before);
                n.err.p = phi * n.err.p * phi.transpose();
                n.err.gnss_c = phi * n.err.gnss_c;
                position_s(&n, &fix, &g)
            };
            nav.switch_frame(to, geo.lat_rad);
            assert_eq!(nav.nominal.nav().kind(), to);
            let s_to = position_s(&nav, &fix, &g);
            let expected = turn * s_from * turn.transpose();
            let err = (s_to - expected).amax() / expected.amax();
            let err_unturned = (unturned - expected).amax() / expected.amax();
            println!(
                "{from:?} to {to:?}: S against S before turned: {err:.2e} relative \
                 (without C's turn {err_unturned:.2e})"
            );
            assert!(err < 1e-9, "{err}");
            assert!(err_unturned > 1e-2, "{err_unturned}");
        }
        assert_eq!(nav.nominal.nav().kind(), first);
    }

    /// The integrity test of a fix against a navigator whose errors are
    /// correlated with the receiver's (a reference copied from one that
    /// had fused it): q = νᵀ S⁻¹ ν with S of the augmented state [δx, b]
    /// (H_a = [H, U], P_a = [[P, C], [Cᵀ, B]], R less U B Uᵀ), written out
    /// here, to 1e-9; leaving C out (S = H P Hᵀ + R) gives another q.
    #[test]
    fn the_integrity_test_counts_the_receivers_correlation_with_the_state() {
        let (nav, _, fix, measured) = with_gnss_consider(60.0, 10.0);
        let settings = crate::integrity::IntegritySettings::default();
        let test = nav
            .test_aid(
                &msgs::AidSample::Gnss(fix),
                &settings,
                settings.threshold(6, Some(0.2)),
            )
            .expect("testable");
        let crate::aids::AnyMeasurement::D6(m) = measured.m else {
            panic!("position and velocity")
        };
        let b = nav.err.gnss_b;
        let mut pa = SMatrix::<f64, 18, 18>::zeros();
        pa.fixed_view_mut::<15, 15>(0, 0).copy_from(&nav.err.p);
        pa.fixed_view_mut::<15, 3>(0, 15).copy_from(&nav.err.gnss_c);
        pa.fixed_view_mut::<3, 15>(15, 0)
            .copy_from(&nav.err.gnss_c.transpose());
        pa.fixed_view_mut::<3, 3>(15, 15)
            .copy_from(&Matrix3::from_diagonal(&b));
        let mut ha = SMatrix::<f64, 6, 18>::zeros();
        ha.fixed_view_mut::<6, 15>(0, 0).copy_from(&m.h);
        let mut rw = m.r;
        for i in 0..3 {
            ha[(i, 15 + i)] = 1.0;
            rw[(i, i)] -= b[i];
        }
        let s = ha * pa * ha.transpose() + rw;
        let q = m.z.dot(&s.cholesky().expect("S").solve(&m.z));
        let s_white = m.h * nav.err.p * m.h.transpose() + m.r;
        let q_white = m.z.dot(&s_white.cholesky().expect("S").solve(&m.z));
        println!("q {} (augmented {q}, without C {q_white})", test.q);
        assert!((test.q - q).abs() <= 1e-9 * q, "{} vs {q}", test.q);
        assert!((q_white - q).abs() > 1e-3 * q, "{q_white} vs {q}");
    }

    /// A checkpoint keeps the receiver's parameters: the resumed navigator's
    /// C, B and τ are those it had, bit for bit, and so is what the next
    /// propagation and fix make of them.
    #[test]
    fn a_checkpoint_keeps_the_receivers_parameters() {
        use crate::navigator::{Navigator, NavigatorConfig};
        let (mut nav, _, _, measured) = with_gnss_consider(60.0, 10.0);
        let crate::aids::AnyMeasurement::D6(m) = measured.m else {
            panic!("position and velocity")
        };
        let c = &measured.shares;
        let ckpt = nav.checkpoint();
        ckpt.validate().expect("a valid checkpoint");
        let mut resumed = Navigator::from_checkpoint(&ckpt, &NavigatorConfig::default());
        assert_eq!(resumed.err.gnss_c, nav.err.gnss_c);
        assert_eq!(resumed.err.gnss_b, nav.err.gnss_b);
        assert_eq!(
            resumed.err.gnss_tau_s.to_bits(),
            nav.err.gnss_tau_s.to_bits()
        );
        for n in [&mut nav, &mut resumed] {
            n.err.acc_dt = 0.1;
            n.err.propagate(&n.nominal);
            n.err.update(&m, f64::INFINITY, c).expect("update");
        }
        assert_eq!(resumed.err.p, nav.err.p);
        assert_eq!(resumed.err.gnss_c, nav.err.gnss_c);
    }

    /// The magnetometer's share of R, `a`, and nothing correlated.
    fn persistent(a: f64) -> ConsiderShares {
        ConsiderShares {
            persistent_var: a,
            correlated: None,
        }
    }

    /// The σ of the consider tests' start: metres, decimetres per second,
    /// a milliradian of tilt and 20 mrad of heading.
    fn heading_held_init() -> InitState {
        InitState {
            sigma_pos_h_m: 5.0,
            sigma_pos_v_m: 5.0,
            sigma_vel_h_mps: 0.1,
            sigma_vel_v_mps: 0.1,
            sigma_tilt_rad: 1e-3,
            sigma_heading_rad: 2e-2,
            ..Default::default()
        }
    }

    /// The magnetometer's persistent variance changes along a flight (the
    /// model's declination σ grows as the horizontal field weakens, and
    /// falls again): a hundred scalar heading samples whose a swings
    /// between 1e-4 and 1e-6 rad² (log-uniform) are all fused, the
    /// augmented covariance [[P, c], [cᵀ, a]] stays positive definite
    /// after each (its Cholesky factor exists), b's variance is the
    /// largest a met, and the heading variance never falls below the
    /// smallest a so far (the one error cannot be
    /// averaged away). Rescaling c with √(a_new/a_old) instead kept the
    /// augmented covariance valid but made the heading observable from two
    /// samples of different a: the variance fell below every a by the
    /// second sample.
    #[test]
    fn a_persistent_variance_that_changes_keeps_the_augmented_covariance_valid() {
        use rand::{Rng, SeedableRng};
        let geo = earth::Geodetic {
            lat_rad: 0.8,
            lon_rad: 0.3,
            h_m: 1000.0,
        };
        let nav = AnyNav::Geographic(crate::mech::Nav {
            q_b_n: nalgebra::UnitQuaternion::identity(),
            v_n: Vector3::new(50.0, 0.0, 0.0),
            pos: geo,
        });
        let init = heading_held_init();
        let f = FilterSettings::default();
        let mut e = ErrorState::new(&nav, FrameKind::Geographic, &init, &f);
        let mut h = SMatrix::<f64, 1, 15>::zeros();
        h[idx::PHI + 2] = 1.0;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (mut lowest, mut largest) = (f64::INFINITY, 0.0f64);
        for k in 0..100 {
            let a = 10f64.powf(rng.gen_range(-6.0..-4.0));
            let m = Measurement {
                z: SVector::<f64, 1>::new(rng.gen_range(-1e-3..1e-3)),
                h,
                r: SMatrix::<f64, 1, 1>::new(a + 1e-6),
            };
            let out = e.update(&m, f64::INFINITY, &persistent(a));
            assert!(
                out.is_some_and(|o| o.fused),
                "sample {k} (a = {a:e}) not fused"
            );
            let mut aug = SMatrix::<f64, 16, 16>::zeros();
            aug.fixed_view_mut::<15, 15>(0, 0).copy_from(&e.p);
            aug.fixed_view_mut::<15, 1>(0, 15).copy_from(&e.consider);
            aug.fixed_view_mut::<1, 15>(15, 0)
                .copy_from(&e.consider.transpose());
            aug[(15, 15)] = e.consider_var;
            assert!(
                aug.cholesky().is_some(),
                "sample {k}: augmented covariance not positive definite"
            );
            lowest = lowest.min(a);
            largest = largest.max(a);
            assert_eq!(
                e.consider_var.to_bits(),
                largest.to_bits(),
                "sample {k}: b's variance is not the largest σ² met"
            );
            let var = e.p[(idx::PHI + 2, idx::PHI + 2)];
            assert!(
                var >= lowest * (1.0 - 1e-9),
                "sample {k}: heading variance {var} below every a so far ({lowest})"
            );
        }
    }

    /// A checkpoint keeps the consider parameter: a navigator resumed from
    /// it carries the same cov(δx, b) and variance, bit for bit, and its
    /// next magnetometer update is the one the running navigator would
    /// have made (the same P after it).
    #[test]
    fn a_checkpoint_keeps_the_consider_parameter() {
        use crate::navigator::{Navigator, NavigatorConfig};
        let geo = earth::Geodetic::from_deg(45.0, 7.0, 500.0);
        let q = frames::quat_from_dcm(&frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose())
            .into_inner();
        let init = InitState {
            t_ns: 1_000_000_000,
            r_e_m: earth::geodetic_to_ecef(&geo).into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            ..heading_held_init()
        };
        let cfg = NavigatorConfig::default();
        let mut nav = Navigator::new(&init, &cfg);
        let mut h = SMatrix::<f64, 1, 15>::zeros();
        h[idx::PHI + 2] = 1.0;
        let m = Measurement {
            z: SVector::<f64, 1>::new(1e-3),
            h,
            r: SMatrix::<f64, 1, 1>::new(2e-5),
        };
        assert!(
            nav.err
                .update(&m, f64::INFINITY, &persistent(1e-5))
                .is_some_and(|o| o.fused)
        );
        assert!(nav.err.consider.amax() > 0.0);
        let mut resumed = Navigator::from_checkpoint(&nav.checkpoint(), &cfg);
        assert_eq!(resumed.err.consider, nav.err.consider);
        assert_eq!(
            resumed.err.consider_var.to_bits(),
            nav.err.consider_var.to_bits()
        );
        assert_eq!(resumed.err.p, nav.err.p);
        nav.err
            .update(&m, f64::INFINITY, &persistent(1e-5))
            .expect("update");
        resumed
            .err
            .update(&m, f64::INFINITY, &persistent(1e-5))
            .expect("update");
        assert_eq!(resumed.err.p, nav.err.p);
        assert_eq!(resumed.err.consider, nav.err.consider);
    }
}
