//! Report building: the solution and status records, and the covariance
//! mapped out of the filter's frame into local east/north/up.

use msgs::{AidKind, AidStatus, Solution, Status, Stream, solution_flags};
use nalgebra::{Matrix3, Vector3};

use crate::error_model::Mat15;
use crate::error_model::idx;
use crate::frames;
use crate::mech::{AnyNav, Nominal};

use super::Navigator;

impl Navigator {
    /// Covariances of position (m²), velocity (m²/s²) and attitude error (rad²),
    /// all in local east/north/up axes: the filter's P mapped out of its frame.
    pub fn covariances_enu(&self) -> (Matrix3<f64>, Matrix3<f64>, Matrix3<f64>) {
        let geo = self.nominal.geo();
        self.covariances_enu_at(
            &self.nominal.nav().c_e_n_at(&geo),
            &frames::c_e_g(geo.lat_rad, geo.lon_rad),
        )
    }

    fn block_in(&self, o: usize, m: &Matrix3<f64>) -> Matrix3<f64> {
        block_in(&self.err.p, o, m)
    }

    fn covariances_enu_at(
        &self,
        c_e_n: &Matrix3<f64>,
        c_e_g: &Matrix3<f64>,
    ) -> (Matrix3<f64>, Matrix3<f64>, Matrix3<f64>) {
        let nav_to_enu = match &self.nominal.nav() {
            AnyNav::Geographic(_) => Matrix3::identity(),
            AnyNav::Grid(_) => c_e_g * c_e_n.transpose(),
        };
        (
            self.block_in(idx::DP, &self.nominal.nav().position_error_to_enu(c_e_g)),
            self.block_in(idx::DV, &nav_to_enu),
            self.block_in(idx::PHI, &nav_to_enu),
        )
    }

    /// 1-σ of position in local east/north/up (m).
    pub fn sigma_pos_enu(&self) -> Vector3<f64> {
        self.covariances_enu()
            .0
            .diagonal()
            .map(|v| v.max(0.0).sqrt())
    }

    fn flags(&self) -> u32 {
        let mut f = solution_flags::ALIGNED;
        for (k, c) in self.aids.controls.iter() {
            if c.fresh(self.t_ns) {
                f |= k.decl().fresh_flag;
            }
        }
        if self.aids.last_rejected {
            f |= solution_flags::LAST_INNOVATION_REJECTED;
        }
        if self.coasting {
            f |= solution_flags::COASTING;
        }
        if self.resumed {
            f |= solution_flags::RESUMED;
        }
        if self.aids.reset_pending_flag.is_some() {
            f |= solution_flags::AID_RESET;
        }
        f |= self.flight_state().flags();
        if self.level_fresh() {
            f |= solution_flags::LEVEL_FUSED;
        }
        f
    }

    /// The current solution. The geometry of the position (its geodetic
    /// coordinates, their sines and the local axes) is the nominal state's
    /// cached one: no conversion or trigonometry of the position here.
    pub fn solution(&self) -> Solution {
        let mut s = navigation_solution(
            &self.nominal,
            &self.err.p,
            &self.err.gyro_bias,
            &self.err.accel_bias,
        );
        s.t_ns = self.t_ns;
        s.seq = self.seq;
        s.reset_t_ns = self.reset.t_ns;
        s.reset_delta_pos_e_m = self.reset.delta_pos_e_m;
        s.reset_delta_vel_e_mps = self.reset.delta_vel_e_mps;
        s.reset_delta_heading_rad = self.reset.delta_heading_rad;
        s.flags = self.flags();
        s.switch_count = self.switch_count;
        s.reset_count = self.reset.count;
        s
    }

    /// Aid `k`'s status record, as [`Self::status`] carries it, without
    /// building the rest of the status.
    pub fn aid_status(&self, k: AidKind) -> AidStatus {
        self.aids.controls[k].status_at(self.t_ns)
    }

    /// Health record (loop timing is filled in by the live driver).
    pub fn status(&self) -> Status {
        let mut s = Status {
            t_ns: self.t_ns,
            last_switch_t_ns: self.last_switch_t_ns,
            switch_count: self.switch_count,
            imu_gap_count: self.imu_gap_count,
            coasted_ns: self.coasted_ns,
            reset_count: self.reset.count,
            resumed: u8::from(self.resumed),
            flags: self.flags(),
            frame: self.nominal.nav().kind().to_wire() as u8,
            ..Default::default()
        };
        *s.counters_mut(Stream::Imu) = self.imu;
        for (k, c) in self.aids.controls.iter() {
            *s.counters_mut(Stream::Aid(k)) = c.counters;
            s.aids[k as usize] = c.status_at(self.t_ns);
        }
        s
    }
}

/// The fields of a solution that follow from a nominal state, its error
/// covariance `p` (in the nominal's frame) and the bias estimates: position,
/// velocity, attitude, grid angle, σ, biases and frame. Time, sequence,
/// reset record, flags and counts are left zero for the caller. The
/// navigator's solutions and the smoother's come from this one function.
pub(crate) fn navigation_solution(
    nominal: &Nominal,
    p: &Mat15,
    gyro_bias: &Vector3<f64>,
    accel_bias: &Vector3<f64>,
) -> Solution {
    let l = nominal.local();
    let geo = l.geo;
    let c_e_g = l.c_e_g();
    let c_e_n = match nominal.nav() {
        AnyNav::Geographic(_) => c_e_g,
        AnyNav::Grid(_) => l.c_e_grid(),
    };
    let ff = nominal.nav().frame_free_at(&geo, &c_e_n);
    let c_b_e = ff.q_b_e.to_rotation_matrix().into_inner();
    let c_b_g = c_e_g * c_b_e;
    let (heading, pitch, roll) = frames::euler_from_c_b_n(&c_b_g);
    // σ from grid north's components on the local east and north axes.
    let grid_north = match nominal.nav() {
        AnyNav::Grid(_) => c_e_n.row(1).transpose(),
        AnyNav::Geographic(_) => l.grid_axes()[1],
    };
    let sigma = grid_north.dot(&l.east).atan2(grid_north.dot(&l.north));
    // Only the position block is needed here (this runs every IMU sample).
    let cov_pos = block_in(p, idx::DP, &nominal.nav().position_error_to_enu(&c_e_g));
    let grid_heading = (heading - sigma).rem_euclid(std::f64::consts::TAU);
    let q = ff.q_b_e.into_inner();
    let diag_sqrt = |o: usize| {
        Vector3::new(p[(o, o)], p[(o + 1, o + 1)], p[(o + 2, o + 2)]).map(|v| v.max(0.0).sqrt())
    };
    Solution {
        lat_rad: geo.lat_rad,
        lon_rad: geo.lon_rad,
        h_m: geo.h_m,
        r_e_m: ff.r_e.into(),
        v_e_mps: ff.v_e.into(),
        v_enu_mps: (c_e_g * ff.v_e).into(),
        v_nav_mps: nominal.nav().v_n().into(),
        grid_angle_rad: sigma,
        q_b_e: [q.w, q.i, q.j, q.k],
        heading_rad: heading,
        grid_heading_rad: grid_heading,
        pitch_rad: pitch,
        roll_rad: roll,
        sigma_pos_enu_m: cov_pos.diagonal().map(|v| v.max(0.0).sqrt()).into(),
        sigma_vel_mps: diag_sqrt(idx::DV).into(),
        sigma_att_rad: diag_sqrt(idx::PHI).into(),
        sigma_gyro_bias_rps: diag_sqrt(idx::BG).into(),
        sigma_accel_bias_mps2: diag_sqrt(idx::BA).into(),
        gyro_bias_rps: (*gyro_bias).into(),
        accel_bias_mps2: (*accel_bias).into(),
        frame: nominal.nav().kind().to_wire() as u8,
        ..Default::default()
    }
}

/// M P_oo Mᵀ for the 3×3 block of `p` at `o`.
fn block_in(p: &Mat15, o: usize, m: &Matrix3<f64>) -> Matrix3<f64> {
    m * p.fixed_view::<3, 3>(o, o) * m.transpose()
}
