//! The solution message and the wire solution, both ways.

use msgs::{Solution, solution_flags};

use crate::polarnav as pb;

impl pb::Solution {
    /// The wire solution with the CSV's columns and units (angles in degrees).
    pub fn from_wire(s: &Solution) -> Self {
        let bit = |b: u32| s.flags & b != 0;
        let [x_m, y_m, z_m] = s.r_e_m;
        let [vx_mps, vy_mps, vz_mps] = s.v_e_mps;
        let [ve_mps, vn_mps, vu_mps] = s.v_enu_mps;
        let [v_nav_x_mps, v_nav_y_mps, v_nav_z_mps] = s.v_nav_mps;
        let [qw, qx, qy, qz] = s.q_b_e;
        let [sig_e_m, sig_n_m, sig_u_m] = s.sigma_pos_enu_m;
        let [sig_vnav_x_mps, sig_vnav_y_mps, sig_vnav_z_mps] = s.sigma_vel_mps;
        let [sig_att_x_deg, sig_att_y_deg, sig_att_z_deg] = s.sigma_att_rad.map(f64::to_degrees);
        let [bg_x_rps, bg_y_rps, bg_z_rps] = s.gyro_bias_rps;
        let [ba_x_mps2, ba_y_mps2, ba_z_mps2] = s.accel_bias_mps2;
        let [sig_bg_x_rps, sig_bg_y_rps, sig_bg_z_rps] = s.sigma_gyro_bias_rps;
        let [sig_ba_x_mps2, sig_ba_y_mps2, sig_ba_z_mps2] = s.sigma_accel_bias_mps2;
        let [reset_dx_m, reset_dy_m, reset_dz_m] = s.reset_delta_pos_e_m;
        let [reset_dvx_mps, reset_dvy_mps, reset_dvz_mps] = s.reset_delta_vel_e_mps;
        Self {
            t_ns: s.t_ns,
            seq: s.seq,
            frame: i32::from(s.frame),
            lat_deg: s.lat_rad.to_degrees(),
            lon_deg: s.lon_rad.to_degrees(),
            h_m: s.h_m,
            x_m,
            y_m,
            z_m,
            vx_mps,
            vy_mps,
            vz_mps,
            ve_mps,
            vn_mps,
            vu_mps,
            v_nav_x_mps,
            v_nav_y_mps,
            v_nav_z_mps,
            grid_angle_deg: s.grid_angle_rad.to_degrees(),
            qw,
            qx,
            qy,
            qz,
            heading_deg: s.heading_rad.to_degrees(),
            grid_heading_deg: s.grid_heading_rad.to_degrees(),
            pitch_deg: s.pitch_rad.to_degrees(),
            roll_deg: s.roll_rad.to_degrees(),
            sig_e_m,
            sig_n_m,
            sig_u_m,
            sig_vnav_x_mps,
            sig_vnav_y_mps,
            sig_vnav_z_mps,
            sig_att_x_deg,
            sig_att_y_deg,
            sig_att_z_deg,
            bg_x_rps,
            bg_y_rps,
            bg_z_rps,
            ba_x_mps2,
            ba_y_mps2,
            ba_z_mps2,
            sig_bg_x_rps,
            sig_bg_y_rps,
            sig_bg_z_rps,
            sig_ba_x_mps2,
            sig_ba_y_mps2,
            sig_ba_z_mps2,
            flags: s.flags,
            srs_fresh: bit(solution_flags::SRS_FRESH),
            cns_fresh: bit(solution_flags::CNS_FRESH),
            baro_fresh: bit(solution_flags::BARO_FRESH),
            imu_lost: bit(solution_flags::IMU_LOST),
            coasting: bit(solution_flags::COASTING),
            switch_count: s.switch_count,
            reset_count: s.reset_count,
            reset_t_ns: s.reset_t_ns,
            reset_dx_m,
            reset_dy_m,
            reset_dz_m,
            reset_dvx_mps,
            reset_dvy_mps,
            reset_dvz_mps,
            reset_dheading_deg: s.reset_delta_heading_rad.to_degrees(),
            star_fresh: bit(solution_flags::STAR_FRESH),
            gnss_fresh: bit(solution_flags::GNSS_FRESH),
            gnss_excluded: bit(solution_flags::GNSS_EXCLUDED),
            baseline_fresh: bit(solution_flags::BASELINE_FRESH),
            mag_fresh: bit(solution_flags::MAG_FRESH),
            gnss_untested: bit(solution_flags::GNSS_UNTESTED),
        }
    }

    /// The wire solution back (angles to radians; the fields the message
    /// does not carry stay default). For readers of MCAP files.
    pub fn to_wire(&self) -> Solution {
        let m = self;
        Solution {
            t_ns: m.t_ns,
            seq: m.seq,
            lat_rad: m.lat_deg.to_radians(),
            lon_rad: m.lon_deg.to_radians(),
            h_m: m.h_m,
            r_e_m: [m.x_m, m.y_m, m.z_m],
            v_e_mps: [m.vx_mps, m.vy_mps, m.vz_mps],
            v_enu_mps: [m.ve_mps, m.vn_mps, m.vu_mps],
            v_nav_mps: [m.v_nav_x_mps, m.v_nav_y_mps, m.v_nav_z_mps],
            grid_angle_rad: m.grid_angle_deg.to_radians(),
            q_b_e: [m.qw, m.qx, m.qy, m.qz],
            heading_rad: m.heading_deg.to_radians(),
            grid_heading_rad: m.grid_heading_deg.to_radians(),
            pitch_rad: m.pitch_deg.to_radians(),
            roll_rad: m.roll_deg.to_radians(),
            sigma_pos_enu_m: [m.sig_e_m, m.sig_n_m, m.sig_u_m],
            sigma_vel_mps: [m.sig_vnav_x_mps, m.sig_vnav_y_mps, m.sig_vnav_z_mps],
            sigma_att_rad: [m.sig_att_x_deg, m.sig_att_y_deg, m.sig_att_z_deg].map(f64::to_radians),
            gyro_bias_rps: [m.bg_x_rps, m.bg_y_rps, m.bg_z_rps],
            accel_bias_mps2: [m.ba_x_mps2, m.ba_y_mps2, m.ba_z_mps2],
            sigma_gyro_bias_rps: [m.sig_bg_x_rps, m.sig_bg_y_rps, m.sig_bg_z_rps],
            sigma_accel_bias_mps2: [m.sig_ba_x_mps2, m.sig_ba_y_mps2, m.sig_ba_z_mps2],
            reset_t_ns: m.reset_t_ns,
            reset_delta_pos_e_m: [m.reset_dx_m, m.reset_dy_m, m.reset_dz_m],
            reset_delta_vel_e_mps: [m.reset_dvx_mps, m.reset_dvy_mps, m.reset_dvz_mps],
            reset_delta_heading_rad: m.reset_dheading_deg.to_radians(),
            flags: m.flags,
            switch_count: m.switch_count,
            reset_count: m.reset_count,
            frame: u8::try_from(m.frame).unwrap_or(u8::MAX),
            ..Default::default()
        }
    }
}
