//! The wire payloads as the protobuf messages of `polarnav.proto`
//! (`polarnav_proto`): units in every field name, the solution's angles in
//! degrees as in the solution CSV, and each aid's innovation in one
//! physical unit whatever the navigation frame.

use msgs::aids::Unit;
use msgs::{AidKind, AidStatus, PerAid, Solution, Status, StreamCounters, TruthRecord};
use polarnav::earth::{self, Geodetic};
use polarnav_proto as pb;

/// Where an update was made: the navigation frame ([`msgs::WireFrame`] as
/// u8) and the position, which turn a CNS innovation in g (Δlatitude,
/// Δlongitude in rad) into metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateAt {
    /// [`msgs::WireFrame`] as u8.
    pub frame: u8,
    /// Latitude (rad).
    pub lat_rad: f64,
    /// Height (m).
    pub h_m: f64,
}

fn nav_frame(frame: u8) -> i32 {
    i32::from(frame)
}

/// An aid's update in its physical units, from its declaration's
/// components (`msgs::aids`). The innovation is as the wire reports it
/// (`AidStatus::innovation`, its variance the diagonal of S); only a
/// geographic-frame horizontal position component ([`Unit::LatitudeInG`],
/// [`Unit::LongitudeInG`], the CNS innovation in g) is rescaled, from rad
/// to m, with [`earth::metres_per_radian`] at `at`. Each component goes to
/// the pair of fields of its unit (metres, metres per second, radians); a
/// component without a positive finite variance gets a zero or NaN σ.
pub fn aid_update(t_ns: u64, aid: AidKind, a: &AidStatus, at: UpdateAt) -> pb::AidUpdate {
    let geographic = at.frame == msgs::WireFrame::Geographic as u8;
    let mut u = pb::AidUpdate {
        t_ns,
        frame: nav_frame(at.frame),
        test_ratio: a.test_ratio,
        gate_ratio: 1.0,
        fused: a.fused != 0,
        exclusions: a.exclusions,
        ..Default::default()
    };
    for (k, c) in aid.decl().components.iter().enumerate() {
        let Some((v, var)) = a.innovation.get(k).zip(a.innovation_var.get(k)) else {
            break;
        };
        let scale = match c.unit {
            Unit::LatitudeInG if geographic => earth::metres_per_radian(at.lat_rad, at.h_m)[0],
            Unit::LongitudeInG if geographic => earth::metres_per_radian(at.lat_rad, at.h_m)[1],
            _ => 1.0,
        };
        let (values, sigmas) = match c.unit {
            Unit::M | Unit::LatitudeInG | Unit::LongitudeInG => {
                (&mut u.innovation_m, &mut u.innovation_sigma_m)
            }
            Unit::Mps => (&mut u.innovation_mps, &mut u.innovation_sigma_mps),
            Unit::Rad => (&mut u.innovation_rad, &mut u.innovation_sigma_rad),
        };
        values.push(v * scale);
        sigmas.push(var.sqrt() * scale);
    }
    u
}

/// The solution with the CSV's columns and units (angles in degrees).
pub fn solution(s: &Solution) -> pb::Solution {
    pb::Solution::from_wire(s)
}

/// An IMU sample.
pub fn imu(x: &msgs::ImuSample) -> pb::ImuSample {
    pb::ImuSample {
        t_ns: x.t_ns,
        seq: x.seq,
        dt_s: x.dt_s,
        dtheta_x_rad: x.d_theta_rad[0],
        dtheta_y_rad: x.d_theta_rad[1],
        dtheta_z_rad: x.d_theta_rad[2],
        dv_x_mps: x.d_v_mps[0],
        dv_y_mps: x.d_v_mps[1],
        dv_z_mps: x.d_v_mps[2],
    }
}

/// An initial state.
pub fn init(x: &msgs::InitState) -> pb::InitState {
    let [x_m, y_m, z_m] = x.r_e_m;
    let [vx_mps, vy_mps, vz_mps] = x.v_e_mps;
    let [q_b_e_w, q_b_e_x, q_b_e_y, q_b_e_z] = x.q_b_e;
    pb::InitState {
        t_ns: x.t_ns,
        seq: x.seq,
        x_m,
        y_m,
        z_m,
        vx_mps,
        vy_mps,
        vz_mps,
        q_b_e_w,
        q_b_e_x,
        q_b_e_y,
        q_b_e_z,
        sigma_pos_h_m: x.sigma_pos_h_m,
        sigma_pos_v_m: x.sigma_pos_v_m,
        sigma_vel_h_mps: x.sigma_vel_h_mps,
        sigma_vel_v_mps: x.sigma_vel_v_mps,
        sigma_tilt_rad: x.sigma_tilt_rad,
        sigma_heading_rad: x.sigma_heading_rad,
        method: u32::from(x.method),
        heading_aid: u32::from(x.heading_aid),
        method_name: x
            .init_method()
            .map_or_else(|| format!("unknown ({})", x.method), |m| m.to_string()),
    }
}

fn counters(c: &StreamCounters) -> pb::StreamCounters {
    pb::StreamCounters {
        received: c.received,
        accepted: c.accepted,
        rejected_invalid: c.rejected_invalid,
        rejected_time: c.rejected_time,
        rejected_gate: c.rejected_gate,
        not_used: c.not_used,
        seq_gaps: c.seq_gaps,
        last_t_ns: c.last_t_ns,
        refused_publisher: c.refused_publisher,
        rejected_integrity: c.rejected_integrity,
    }
}

/// Aid `kind`'s status in a status record stamped `t_ns`, its last update
/// converted where it was made (`at`). The integrity fields only for an
/// aid that is not autonomous, the refusals only for causes that have some.
fn aid_status(t_ns: u64, kind: AidKind, a: &AidStatus, at: UpdateAt) -> pb::AidStatus {
    let decl = kind.decl();
    let (integrity_ratio, excluded, excluded_since_t_ns, exclusion_cause) = if decl.autonomous {
        (0.0, false, 0, String::new())
    } else {
        (
            a.integrity_ratio,
            a.excluded != 0,
            a.excluded_since_t_ns,
            polarnav::integrity::cause::text(a.exclusion_cause).to_owned(),
        )
    };
    pb::AidStatus {
        last: Some(aid_update(t_ns, kind, a, at)),
        last_fuse_t_ns: a.last_fuse_t_ns,
        fresh: a.fresh != 0,
        integrity_ratio,
        excluded,
        excluded_since_t_ns,
        exclusion_cause,
        integrity_unavailable: !decl.autonomous
            && a.integrity_state == msgs::integrity_state::UNAVAILABLE,
        refused: decl
            .causes
            .iter()
            .zip(a.refused)
            .filter(|(_, n)| *n > 0)
            .map(|(c, n)| pb::RefusedCount {
                cause: (*c).to_owned(),
                count: n,
            })
            .collect(),
    }
}

/// A status record; each aid's last update in its unit, a CNS one in g
/// rescaled where that update was made (`made`; see
/// `FlightChannels::status`). The message's per-aid fields are those of
/// the four aids it was written for (`polarnav.Status`' fields 4 to 11).
pub fn status(st: &Status, made: &PerAid<UpdateAt>) -> pb::Status {
    let aid = |kind: AidKind| aid_status(st.t_ns, kind, st.aid(kind), made[kind]);
    let c = |kind: AidKind| Some(counters(st.aid_counters(kind)));
    pb::Status {
        t_ns: st.t_ns,
        seq: st.seq,
        imu: Some(counters(st.imu())),
        srs: c(AidKind::Srs),
        cns: c(AidKind::Cns),
        baro: c(AidKind::Baro),
        star: c(AidKind::Star),
        srs_aid: Some(aid(AidKind::Srs)),
        cns_aid: Some(aid(AidKind::Cns)),
        baro_aid: Some(aid(AidKind::Baro)),
        star_aid: Some(aid(AidKind::Star)),
        cycles: st.cycles,
        overruns: st.overruns,
        overruns_cpu: st.overruns_cpu,
        cycle_time_mean_ns: st.cycle_time_mean_ns,
        cycle_time_max_ns: st.cycle_time_max_ns,
        last_switch_t_ns: st.last_switch_t_ns,
        imu_gap_count: st.imu_gap_count,
        coasted_ns: st.coasted_ns,
        checkpoints_written: st.checkpoints_written,
        reinit_count: st.reinit_count,
        switch_count: st.switch_count,
        reset_count: st.reset_count,
        flags: st.flags,
        frame: nav_frame(st.frame),
        resumed: st.resumed != 0,
        unavailable: st.unavailable,
        aids: st
            .each_aid()
            .map(|(k, c, _)| pb::NamedAid {
                name: k.name().to_owned(),
                counters: Some(counters(c)),
                status: Some(aid(k)),
            })
            .collect(),
    }
}

/// A truth record with its geodetic position `g`.
pub fn truth(t: &TruthRecord, g: &Geodetic) -> pb::Truth {
    let [x_m, y_m, z_m] = t.r_e_m;
    let [vx_mps, vy_mps, vz_mps] = t.v_e_mps;
    let [qw, qx, qy, qz] = t.q_b_e;
    pb::Truth {
        t_ns: t.t_ns,
        lat_deg: g.lat_rad.to_degrees(),
        lon_deg: g.lon_rad.to_degrees(),
        h_m: g.h_m,
        x_m,
        y_m,
        z_m,
        vx_mps,
        vy_mps,
        vz_mps,
        qw,
        qx,
        qy,
        qz,
    }
}

/// The simulated IMU biases.
pub fn truth_bias(x: &msgs::navlog::TruthBias) -> pb::TruthBias {
    let [bg_x_rps, bg_y_rps, bg_z_rps] = x.gyro_bias_rps;
    let [ba_x_mps2, ba_y_mps2, ba_z_mps2] = x.accel_bias_mps2;
    pb::TruthBias {
        t_ns: x.t_ns,
        bg_x_rps,
        bg_y_rps,
        bg_z_rps,
        ba_x_mps2,
        ba_y_mps2,
        ba_z_mps2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::solution_flags;

    /// A CNS innovation in g, rescaled to metres, is the distance the two
    /// positions (prediction and measurement) are apart on the ellipsoid,
    /// computed independently as the ECEF difference projected on local
    /// north and east.
    #[test]
    fn a_cns_innovation_in_g_in_metres_is_the_ecef_distance_north_and_east() {
        for (lat_deg, h_m) in [
            (10.0, 0.0),
            (70.0, 20_000.0),
            (-85.0, 15_000.0),
            (89.9, 1_000.0),
        ] {
            let lat = f64::to_radians(lat_deg);
            let lon = 0.3;
            let (dlat, dlon) = (2e-7, -3e-7);
            let a = AidStatus {
                innovation: [dlat, dlon, 0.0, 0.0, 0.0, 0.0],
                innovation_var: [1e-14, 4e-14, 0.0, 0.0, 0.0, 0.0],
                ..Default::default()
            };
            let u = aid_update(
                1,
                AidKind::Cns,
                &a,
                UpdateAt {
                    frame: 0,
                    lat_rad: lat,
                    h_m,
                },
            );
            let r0 = earth::geodetic_to_ecef(&Geodetic {
                lat_rad: lat - dlat / 2.0,
                lon_rad: lon - dlon / 2.0,
                h_m,
            });
            let r1 = earth::geodetic_to_ecef(&Geodetic {
                lat_rad: lat + dlat / 2.0,
                lon_rad: lon + dlon / 2.0,
                h_m,
            });
            let d = r1 - r0;
            let (sl, cl, so, co) = (lat.sin(), lat.cos(), lon.sin(), lon.cos());
            let north = -sl * co * d[0] - sl * so * d[1] + cl * d[2];
            let east = -so * d[0] + co * d[1];
            assert!(
                (u.innovation_m[0] - north).abs() < 1e-6,
                "{lat_deg}: {u:?} vs {north}"
            );
            assert!(
                (u.innovation_m[1] - east).abs() < 1e-6,
                "{lat_deg}: {u:?} vs {east}"
            );
            // σ scales like the innovation: the ratio is the unit-free one.
            for k in 0..2 {
                let ratio = u.innovation_m[k] / u.innovation_sigma_m[k];
                let raw = a.innovation[k] / a.innovation_var[k].sqrt();
                assert!((ratio - raw).abs() < 1e-12 * raw.abs().max(1.0));
            }
            assert!(u.innovation_rad.is_empty() && u.innovation_mps.is_empty());
        }
    }

    /// In G a CNS innovation is already metres (grid x, y): unchanged.
    #[test]
    fn a_cns_innovation_in_grid_is_left_in_metres() {
        let a = AidStatus {
            innovation: [3.0, -4.0, 0.0, 0.0, 0.0, 0.0],
            innovation_var: [9.0, 16.0, 0.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        let u = aid_update(
            1,
            AidKind::Cns,
            &a,
            UpdateAt {
                frame: 1,
                lat_rad: 1.5,
                h_m: 0.0,
            },
        );
        assert_eq!(u.innovation_m, [3.0, -4.0]);
        assert_eq!(u.innovation_sigma_m, [3.0, 4.0]);
        assert_eq!(u.frame, 1);
    }

    /// The solution message and back give the wire solution to rounding
    /// (angles go through degrees).
    #[test]
    fn a_solution_round_trips_through_its_message() {
        let s = Solution {
            t_ns: 123_456_789_012,
            seq: 7,
            lat_rad: 1.2,
            lon_rad: -2.9,
            h_m: 15_000.5,
            r_e_m: [1.0, 2.0, 3.0],
            v_e_mps: [4.0, 5.0, 6.0],
            v_enu_mps: [7.0, 8.0, 9.0],
            v_nav_mps: [10.0, 11.0, 12.0],
            grid_angle_rad: 0.4,
            q_b_e: [0.5, 0.5, -0.5, 0.5],
            heading_rad: 0.1,
            grid_heading_rad: 0.2,
            pitch_rad: 0.03,
            roll_rad: -0.04,
            sigma_pos_enu_m: [1.5, 2.5, 3.5],
            sigma_vel_mps: [0.1, 0.2, 0.3],
            sigma_att_rad: [1e-4, 2e-4, 3e-4],
            gyro_bias_rps: [1e-7, 2e-7, 3e-7],
            accel_bias_mps2: [1e-4, 2e-4, 3e-4],
            sigma_gyro_bias_rps: [1e-8; 3],
            sigma_accel_bias_mps2: [1e-5; 3],
            reset_t_ns: 99,
            reset_delta_pos_e_m: [0.1, 0.2, 0.3],
            reset_delta_vel_e_mps: [0.01, 0.02, 0.03],
            reset_delta_heading_rad: 0.001,
            flags: solution_flags::SRS_FRESH | solution_flags::COASTING,
            switch_count: 2,
            reset_count: 1,
            frame: 1,
            ..Default::default()
        };
        let m = solution(&s);
        assert!(m.srs_fresh && m.coasting && !m.cns_fresh);
        assert!((m.lat_deg - 68.754_935_415_698_8).abs() < 1e-9);
        let back = m.to_wire();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * a.abs().max(1e-300);
        assert!(close(back.lat_rad, s.lat_rad) && close(back.lon_rad, s.lon_rad));
        assert!(close(back.sigma_att_rad[2], s.sigma_att_rad[2]));
        assert_eq!(
            (back.r_e_m, back.q_b_e, back.flags, back.frame),
            (s.r_e_m, s.q_b_e, s.flags, s.frame)
        );
        assert_eq!(
            back.sigma_accel_bias_mps2.map(f64::to_bits),
            s.sigma_accel_bias_mps2.map(f64::to_bits)
        );
    }

    mod extremes {
        use super::*;
        use proptest::prelude::*;

        /// A value from the whole range: log-uniform magnitudes from 1e-300
        /// to 1e300 of either sign, zero, NaN and ±∞.
        fn any_value() -> impl Strategy<Value = f64> {
            prop_oneof![
                8 => (-300.0f64..300.0, any::<bool>())
                    .prop_map(|(e, neg)| if neg { -(10f64.powf(e)) } else { 10f64.powf(e) }),
                1 => Just(0.0),
                1 => Just(f64::NAN),
                1 => Just(f64::INFINITY),
                1 => Just(f64::NEG_INFINITY),
            ]
        }

        fn aid() -> impl Strategy<Value = AidKind> {
            proptest::sample::select(AidKind::ALL.to_vec())
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(2000))]

            /// Whatever the wire reports (absurd innovations, variances,
            /// positions, frames), the update has exactly the aid's
            /// components in the aid's one unit field pair and nothing in
            /// the others; from a finite innovation with a positive finite
            /// variance at a real position it is finite with a positive σ,
            /// and its normalized value is the wire's.
            #[test]
            fn an_update_from_any_status_keeps_its_shape_and_sound_values(
                kind in aid(),
                v in proptest::array::uniform6(any_value()),
                var in proptest::array::uniform6(any_value()),
                lat in prop_oneof![4 => -std::f64::consts::FRAC_PI_2..=std::f64::consts::FRAC_PI_2, 1 => any_value()],
                h in prop_oneof![4 => -1e4f64..1e5, 1 => any_value()],
                frame in any::<u8>(),
                ratio in any_value(),
                fused in any::<u8>(),
            ) {
                let a = AidStatus {
                    innovation: v,
                    innovation_var: var,
                    test_ratio: ratio,
                    fused,
                    ..Default::default()
                };
                let u = aid_update(7, kind, &a, UpdateAt { frame, lat_rad: lat, h_m: h });
                // The field pair of each unit; an aid's components fill
                // the pairs of their units in order, and no other.
                let pairs = [
                    (Unit::M, &u.innovation_m, &u.innovation_sigma_m),
                    (Unit::Mps, &u.innovation_mps, &u.innovation_sigma_mps),
                    (Unit::Rad, &u.innovation_rad, &u.innovation_sigma_rad),
                ];
                let shown = |c: Unit| match c {
                    Unit::LatitudeInG | Unit::LongitudeInG => Unit::M,
                    other => other,
                };
                let comps = kind.decl().components;
                let dim = comps.len();
                // The dimensions of the aids the status was written for.
                let written_for = match kind {
                    AidKind::Baro => Some(1),
                    AidKind::Cns => Some(2),
                    AidKind::Srs | AidKind::Star => Some(3),
                    #[allow(unreachable_patterns)]
                    _ => None,
                };
                if let Some(d) = written_for {
                    prop_assert_eq!(dim, d);
                }
                for (unit, values, sigmas) in pairs {
                    let n = comps[..dim].iter().filter(|c| shown(c.unit) == unit).count();
                    prop_assert_eq!(values.len(), n);
                    prop_assert_eq!(sigmas.len(), n);
                }
                // Component k's value and σ, wherever its unit put it.
                let at = |k: usize| {
                    let unit = shown(comps[k].unit);
                    let j = comps[..k].iter().filter(|c| shown(c.unit) == unit).count();
                    let (_, values, sigmas) = pairs.iter().find(|p| p.0 == unit).expect("a pair");
                    (values[j], sigmas[j])
                };
                prop_assert_eq!(u.fused, fused != 0);
                prop_assert_eq!(u.test_ratio.to_bits(), ratio.to_bits());
                prop_assert_eq!(u.t_ns, 7);
                let real_place = lat.abs() < 1.5 && (-1e4..1e5).contains(&h);
                for k in 0..dim {
                    let sound = v[k].is_finite() && v[k].abs() < 1e150
                        && var[k].is_finite() && var[k] > 1e-290 && var[k] < 1e290;
                    if sound && real_place {
                        let (val, sig) = at(k);
                        prop_assert!(val.is_finite(), "{:?}", u);
                        prop_assert!(sig.is_finite() && sig > 0.0, "{:?}", u);
                        let raw = v[k] / var[k].sqrt();
                        let got = val / sig;
                        prop_assert!((got - raw).abs() <= 1e-12 * raw.abs().max(1e-300), "{} vs {}", got, raw);
                    }
                }
            }
        }
    }
}
