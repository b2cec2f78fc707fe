//! MAVLink 2 messages from the solution (common dialect, crate `mavlink`):
//! HEARTBEAT, GPS_INPUT, SYSTEM_TIME and ODOMETRY, each a pure function of
//! the solution, the [`Quality`] of the one fix rule and the clock, and
//! [`Encoder`], which frames them (sequence numbers, CRC with the message's
//! CRC_EXTRA, payload truncation) into bytes for the link.

use std::time::Duration;

use mavlink::dialects::common::{
    GPS_INPUT_DATA, GpsFixType, GpsInputIgnoreFlags, HEARTBEAT_DATA, MavAutopilot,
    MavEstimatorType, MavFrame, MavMessage, MavModeFlag, MavState, MavType, ODOMETRY_DATA,
    SYSTEM_TIME_DATA,
};
use mavlink::{MAVLinkV2MessageRaw, MavHeader};
use msgs::Solution;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

use crate::geo;
use crate::health::{Fix, Quality};

/// Seconds from the Unix epoch to the GPS epoch (1980-01-06).
pub const GPS_EPOCH_UNIX_S: u64 = 315_964_800;
/// Seconds in a GPS week.
pub const WEEK_S: u64 = 604_800;

/// GPS week and time of week (ms) of a UTC instant, `leap_s` being
/// GPS − UTC (18 s since 2017).
pub fn gps_time(unix: Duration, leap_s: u32) -> (u16, u32) {
    let ms = unix
        .as_millis()
        .saturating_sub(u128::from(GPS_EPOCH_UNIX_S) * 1000)
        + u128::from(leap_s) * 1000;
    let week_ms = u128::from(WEEK_S) * 1000;
    ((ms / week_ms) as u16, (ms % week_ms) as u32)
}

/// Frames messages as one component: system and component id, and the
/// sequence number that counts up per message.
#[derive(Debug)]
pub struct Encoder {
    header: MavHeader,
    raw: MAVLinkV2MessageRaw,
}

impl Encoder {
    pub fn new(system_id: u8, component_id: u8) -> Self {
        Self {
            header: MavHeader {
                system_id,
                component_id,
                sequence: 0,
            },
            raw: MAVLinkV2MessageRaw::new(),
        }
    }

    /// The MAVLink 2 frame of `msg` (valid until the next call).
    pub fn encode(&mut self, msg: &MavMessage) -> &[u8] {
        self.raw.serialize_message(self.header, msg);
        self.header.sequence = self.header.sequence.wrapping_add(1);
        self.raw.raw_bytes()
    }
}

/// HEARTBEAT of an onboard component of `mav_type`; its `system_status`
/// says the fix: ACTIVE with a 3D fix, CRITICAL degraded (2D), STANDBY
/// without a fix, UNINIT when the daemon is not heard.
pub fn heartbeat(mav_type: MavType, fix: Fix) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: mav_type,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: match fix {
            Fix::Full => MavState::MAV_STATE_ACTIVE,
            Fix::Degraded => MavState::MAV_STATE_CRITICAL,
            Fix::NoFix => MavState::MAV_STATE_STANDBY,
            Fix::NoSource => MavState::MAV_STATE_UNINIT,
        },
        mavlink_version: 3,
    })
}

fn gps_fix_type(fix: Fix) -> GpsFixType {
    match fix {
        Fix::NoSource => GpsFixType::GPS_FIX_TYPE_NO_GPS,
        Fix::NoFix => GpsFixType::GPS_FIX_TYPE_NO_FIX,
        Fix::Degraded => GpsFixType::GPS_FIX_TYPE_2D_FIX,
        Fix::Full => GpsFixType::GPS_FIX_TYPE_3D_FIX,
    }
}

/// The solution's sensor time in µs (GPS_INPUT's and ODOMETRY's
/// `time_usec`): the consumer sees which solution a message carries.
pub fn time_usec(sol: &Solution) -> u64 {
    sol.t_ns / 1000
}

/// GPS_INPUT of the newest solution (or of none).
///
/// - `lat`, `lon`: 1e-7 degrees, rounded to nearest ([`geo::lat_e7`],
///   [`geo::lon_e7`]: longitude on [-180°, 180°)); at the pole, the
///   solution's longitude.
/// - `alt`: above mean sea level, `h − N` with N of EGM96 (`geoid_m`).
/// - `vn`, `ve`, `vd`: the solution's ENU velocity as NED (at the exact
///   pole, on the axes of the solution's longitude, like the position).
/// - accuracies, HDOP/VDOP, satellites: [`Quality`]; HDOP and VDOP are
///   flagged ignored (and `UINT16_MAX`, "unknown") without a usable fix,
///   accuracies flagged ignored (and 0) when unknown (a stale solution).
/// - `yaw`: true heading in cdeg (north = 36000) where [`Quality`] has it,
///   else 0, "not available" (at and near the pole).
/// - `time_week`, `time_week_ms`: GPS time of `unix` (the flight computer's
///   clock when the solution arrived).
/// - With no solution at all, every field is flagged ignored and zero.
pub fn gps_input(
    sol: Option<&Solution>,
    q: &Quality,
    geoid_m: f64,
    gps_id: u8,
    week: (u16, u32),
) -> MavMessage {
    let mut d = GPS_INPUT_DATA {
        time_usec: 0,
        time_week_ms: week.1,
        lat: 0,
        lon: 0,
        alt: 0.0,
        hdop: f32::from(u16::MAX),
        vdop: f32::from(u16::MAX),
        vn: 0.0,
        ve: 0.0,
        vd: 0.0,
        speed_accuracy: 0.0,
        horiz_accuracy: 0.0,
        vert_accuracy: 0.0,
        ignore_flags: GpsInputIgnoreFlags::all(),
        time_week: week.0,
        gps_id,
        fix_type: gps_fix_type(q.fix),
        satellites_visible: q.satellites,
        yaw: 0,
    };
    let Some(s) = sol else {
        return MavMessage::GPS_INPUT(d);
    };
    let mut ignore = GpsInputIgnoreFlags::empty();
    d.time_usec = time_usec(s);
    match (geo::lat_e7(s.lat_rad), geo::lon_e7(s.lon_rad)) {
        (Some(lat), Some(lon)) => {
            d.lat = lat;
            d.lon = lon;
        }
        // A non-finite position is no fix (Quality says so); nothing to send.
        _ => return MavMessage::GPS_INPUT(d),
    }
    d.alt = (s.h_m - geoid_m) as f32;
    let [ve, vn, vu] = s.v_enu_mps;
    (d.vn, d.ve, d.vd) = (vn as f32, ve as f32, -vu as f32);
    // Accuracies unknown (a stale solution: no fix) are flagged, not NaN.
    for (v, field, flag) in [
        (
            q.h_acc_m,
            &mut d.horiz_accuracy,
            GpsInputIgnoreFlags::GPS_INPUT_IGNORE_FLAG_HORIZONTAL_ACCURACY,
        ),
        (
            q.v_acc_m,
            &mut d.vert_accuracy,
            GpsInputIgnoreFlags::GPS_INPUT_IGNORE_FLAG_VERTICAL_ACCURACY,
        ),
        (
            q.speed_acc_mps,
            &mut d.speed_accuracy,
            GpsInputIgnoreFlags::GPS_INPUT_IGNORE_FLAG_SPEED_ACCURACY,
        ),
    ] {
        if v.is_finite() {
            *field = v as f32;
        } else {
            ignore |= flag;
        }
    }
    match (q.hdop, q.vdop) {
        (Some(h), Some(v)) => {
            d.hdop = h as f32;
            d.vdop = v as f32;
        }
        _ => {
            ignore |= GpsInputIgnoreFlags::GPS_INPUT_IGNORE_FLAG_HDOP
                | GpsInputIgnoreFlags::GPS_INPUT_IGNORE_FLAG_VDOP
        }
    }
    d.yaw = q.heading_rad.and_then(geo::heading_cdeg).unwrap_or(0);
    d.ignore_flags = ignore;
    MavMessage::GPS_INPUT(d)
}

/// SYSTEM_TIME: the flight computer's UTC clock and the bridge's uptime.
pub fn system_time(unix: Duration, boot: Duration) -> MavMessage {
    MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
        time_unix_usec: unix.as_micros() as u64,
        time_boot_ms: boot.as_millis() as u32,
    })
}

/// Which MAV_FRAME the ODOMETRY pose is labelled with. Both carry the same
/// numbers (the anchored north-east-down frame of [`Odometry`]); PX4 takes
/// `LOCAL_NED` as north-aligned, ArduPilot wants `LOCAL_FRD`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OdometryFrame {
    LocalNed,
    LocalFrd,
}

/// ODOMETRY in an anchored local frame.
///
/// **The local frame** is the north-east-down tangent frame at an anchor
/// point, fixed to the Earth: the first position sent, and again whenever
/// the aircraft is more than `reanchor_m` from the anchor (each re-anchoring
/// and each reset of the navigator increments `reset_counter`, so the
/// consumer knows the position jumped). Its axes do not follow the
/// aircraft: near the pole, where the north-east-down frame of the
/// *current* position turns with longitude (a half turn across the pole),
/// the anchored frame stays put, so position, velocity and attitude in it
/// are continuous over the pole. The price is curvature: at a distance d
/// from the anchor its "down" is d/R off the local vertical (0.9° at
/// 100 km), bounded by `reanchor_m`.
///
/// Pose: position of the aircraft in the anchored frame (m), attitude
/// body (front-right-down) → anchored frame. Twist: velocity in body
/// front-right-down axes (`child_frame_id` BODY_FRD); angular rates are
/// not in the solution and are sent as NaN (unknown).
/// Covariances: position from the solution's ENU σ rotated into the
/// anchored frame; attitude from the σ of the attitude error
/// (navigation-frame axes, taken as roll, pitch, yaw); velocity as the
/// isotropic equivalent (|σ_v|²/3 per axis); angular rates NaN.
#[derive(Debug, Clone)]
pub struct Odometry {
    pub frame: OdometryFrame,
    pub reanchor_m: f64,
    anchor: Option<Anchor>,
    reanchors: u32,
}

#[derive(Debug, Clone, Copy)]
struct Anchor {
    r_e: Vector3<f64>,
    c_e_n: Matrix3<f64>,
}

/// Front-right-down axes in the solution's body axes (x right, y forward,
/// z up): a vector in FRD → the same vector in body axes.
fn c_frd_b() -> Matrix3<f64> {
    Matrix3::new(
        0.0, 1.0, 0.0, //
        1.0, 0.0, 0.0, //
        0.0, 0.0, -1.0,
    )
}

impl Odometry {
    pub fn new(frame: OdometryFrame, reanchor_m: f64) -> Self {
        Self {
            frame,
            reanchor_m,
            anchor: None,
            reanchors: 0,
        }
    }

    /// Times the anchor moved after the first.
    pub fn reanchors(&self) -> u32 {
        self.reanchors
    }

    /// The anchor's position (ECEF, m), once there is one.
    pub fn anchor_ecef(&self) -> Option<[f64; 3]> {
        self.anchor.map(|a| a.r_e.into())
    }

    /// ODOMETRY of the solution, `None` without a usable fix (nothing is
    /// sent then: GPS_INPUT says why).
    pub fn message(&mut self, sol: &Solution, q: &Quality) -> Option<MavMessage> {
        if !q.fix.usable() {
            return None;
        }
        let r_e = Vector3::from(sol.r_e_m);
        let v_e = Vector3::from(sol.v_e_mps);
        let q_b_e = UnitQuaternion::from_quaternion(Quaternion::new(
            sol.q_b_e[0],
            sol.q_b_e[1],
            sol.q_b_e[2],
            sol.q_b_e[3],
        ));
        if !(r_e.iter().chain(v_e.iter()).all(|x| x.is_finite())
            && q_b_e.coords.iter().all(|x| x.is_finite()))
        {
            return None;
        }
        let far = self
            .anchor
            .is_some_and(|a| (r_e - a.r_e).norm() > self.reanchor_m);
        if far {
            self.reanchors += 1;
        }
        if self.anchor.is_none() || far {
            self.anchor = Some(Anchor {
                r_e,
                c_e_n: geo::c_e_ned(sol.lat_rad, sol.lon_rad),
            });
        }
        let a = self.anchor?;
        let p_n = a.c_e_n * (r_e - a.r_e);
        let c_b_e = q_b_e.to_rotation_matrix().into_inner();
        let c_frd_n = a.c_e_n * c_b_e * c_frd_b();
        // The quaternion with w ≥ 0 of the two that are this rotation.
        let q_out = UnitQuaternion::from_matrix(&c_frd_n).into_inner();
        let q_out = if q_out.w < 0.0 { -q_out } else { q_out };
        let v_frd = c_frd_b().transpose() * c_b_e.transpose() * v_e;
        // Position covariance: ENU → ECEF → anchored NED.
        let c_e_enu = {
            let n = geo::c_e_ned(sol.lat_rad, sol.lon_rad);
            // ENU rows: east, north, up = NED rows 1, 0, −2.
            Matrix3::from_rows(&[n.row(1).into_owned(), n.row(0).into_owned(), -n.row(2)])
        };
        let s = Vector3::from(sol.sigma_pos_enu_m);
        let p_enu = Matrix3::from_diagonal(&s.component_mul(&s));
        let c_enu_n = a.c_e_n * c_e_enu.transpose();
        let p_pos = c_enu_n * p_enu * c_enu_n.transpose();
        let mut pose = [0f32; 21];
        let mut twist = [0f32; 21];
        for i in 0..3 {
            for j in i..3 {
                pose[tri(i, j)] = p_pos[(i, j)] as f32;
            }
            pose[tri(3 + i, 3 + i)] = (sol.sigma_att_rad[i] * sol.sigma_att_rad[i]) as f32;
        }
        let sv2 = sol.sigma_vel_mps.iter().map(|x| x * x).sum::<f64>() / 3.0;
        for i in 0..3 {
            twist[tri(i, i)] = sv2 as f32;
            twist[tri(3 + i, 3 + i)] = f32::NAN;
        }
        // 100 with a 3D fix, 50 degraded (no fix: not sent).
        let quality = if q.fix == Fix::Full { 100 } else { 50 };
        Some(MavMessage::ODOMETRY(ODOMETRY_DATA {
            time_usec: time_usec(sol),
            x: p_n.x as f32,
            y: p_n.y as f32,
            z: p_n.z as f32,
            q: [
                q_out.w as f32,
                q_out.i as f32,
                q_out.j as f32,
                q_out.k as f32,
            ],
            vx: v_frd.x as f32,
            vy: v_frd.y as f32,
            vz: v_frd.z as f32,
            rollspeed: f32::NAN,
            pitchspeed: f32::NAN,
            yawspeed: f32::NAN,
            pose_covariance: pose,
            velocity_covariance: twist,
            frame_id: match self.frame {
                OdometryFrame::LocalNed => MavFrame::MAV_FRAME_LOCAL_NED,
                OdometryFrame::LocalFrd => MavFrame::MAV_FRAME_LOCAL_FRD,
            },
            child_frame_id: MavFrame::MAV_FRAME_BODY_FRD,
            reset_counter: (self.reanchors.wrapping_add(sol.reset_count) & 0xff) as u8,
            estimator_type: MavEstimatorType::MAV_ESTIMATOR_TYPE_GPS_INS,
            quality,
        }))
    }
}

/// Index of element (i, j), i ≤ j, of a 6×6 matrix's upper-right triangle
/// stored row by row (21 values): rows before i hold 6 + 5 + … values.
pub fn tri(i: usize, j: usize) -> usize {
    debug_assert!(i <= j && j < 6);
    6 * i - i * i.saturating_sub(1) / 2 + (j - i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::{HealthSettings, Heard, assess};
    use msgs::solution_flags;

    #[test]
    fn gps_week_of_a_known_date() {
        // 2024-01-01T00:00:00Z: GPS week 2295 began the day before; +18 s.
        assert_eq!(
            gps_time(Duration::from_secs(1_704_067_200), 18),
            (2295, 86_418_000)
        );
    }

    #[test]
    fn covariance_triangle_indices() {
        assert_eq!(tri(0, 0), 0);
        assert_eq!(tri(0, 5), 5);
        assert_eq!(tri(1, 1), 6);
        assert_eq!(tri(2, 2), 11);
        assert_eq!(tri(3, 3), 15);
        assert_eq!(tri(5, 5), 20);
    }

    /// A level aircraft flying east at (45° N, 10° E), body→ECEF built
    /// from its axes (x right, y forward, z up).
    fn flying_east() -> Solution {
        let (lat, lon) = (45f64.to_radians(), 10f64.to_radians());
        let c_e_n = geo::c_e_ned(lat, lon);
        let (north, east, down) = (
            c_e_n.row(0).transpose(),
            c_e_n.row(1).transpose(),
            c_e_n.row(2).transpose(),
        );
        // Forward = east, right = south, up = −down.
        let c_b_e = Matrix3::from_columns(&[-north, east, -down]);
        let q = UnitQuaternion::from_matrix(&c_b_e);
        Solution {
            lat_rad: lat,
            lon_rad: lon,
            h_m: 1000.0,
            r_e_m: geo::geodetic_to_ecef(lat, lon, 1000.0),
            v_e_mps: (east * 50.0).into(),
            v_enu_mps: [50.0, 0.0, 0.0],
            q_b_e: [q.w, q.i, q.j, q.k],
            heading_rad: std::f64::consts::FRAC_PI_2,
            sigma_pos_enu_m: [1.0, 2.0, 3.0],
            sigma_vel_mps: [0.1; 3],
            sigma_att_rad: [1e-3; 3],
            flags: solution_flags::ALIGNED,
            ..Default::default()
        }
    }

    #[test]
    fn odometry_of_an_aircraft_flying_east_is_yaw_90_and_forward_speed() {
        let s = flying_east();
        let q = assess(
            &Heard {
                solution: Some((&s, 0.0)),
                status_age_s: Some(0.0),
                publisher_present: true,
            },
            &HealthSettings::default(),
        );
        let mut o = Odometry::new(OdometryFrame::LocalNed, 100e3);
        let Some(MavMessage::ODOMETRY(d)) = o.message(&s, &q) else {
            panic!("no ODOMETRY");
        };
        // At the anchor: position 0, attitude a yaw of +90° (FRD → NED).
        assert!(d.x.abs() < 1e-3 && d.y.abs() < 1e-3 && d.z.abs() < 1e-3);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        for (got, want) in d.q.iter().zip([h, 0.0, 0.0, h]) {
            assert!((got - want).abs() < 1e-6, "{:?}", d.q);
        }
        // Velocity in body FRD: all forward.
        assert!((d.vx - 50.0).abs() < 1e-4 && d.vy.abs() < 1e-4 && d.vz.abs() < 1e-4);
        // Position variances: north σ² = 4, east σ² = 1, down σ² = 9.
        assert!((d.pose_covariance[tri(0, 0)] - 4.0).abs() < 1e-5);
        assert!((d.pose_covariance[tri(1, 1)] - 1.0).abs() < 1e-5);
        assert!((d.pose_covariance[tri(2, 2)] - 9.0).abs() < 1e-5);
        assert_eq!(d.frame_id, MavFrame::MAV_FRAME_LOCAL_NED);
        assert_eq!(d.child_frame_id, MavFrame::MAV_FRAME_BODY_FRD);
        assert_eq!(d.quality, 100);
        // 150 km on: the anchor moves and reset_counter counts it.
        let mut far = flying_east();
        far.lat_rad += 150e3 / 6.37e6;
        far.r_e_m = geo::geodetic_to_ecef(far.lat_rad, far.lon_rad, 1000.0);
        let Some(MavMessage::ODOMETRY(d)) = o.message(&far, &q) else {
            panic!("no ODOMETRY");
        };
        assert_eq!((d.reset_counter, o.reanchors()), (1, 1));
        assert!(d.x.abs() < 1e-3);
    }

    #[test]
    fn gps_input_at_the_exact_pole_sends_no_yaw_and_exact_latitude() {
        let mut s = flying_east();
        s.lat_rad = std::f64::consts::FRAC_PI_2;
        s.lon_rad = std::f64::consts::PI;
        let q = assess(
            &Heard {
                solution: Some((&s, 0.0)),
                status_age_s: Some(0.0),
                publisher_present: true,
            },
            &HealthSettings::default(),
        );
        let MavMessage::GPS_INPUT(d) = gps_input(Some(&s), &q, 13.61, 0, (0, 0)) else {
            panic!("not GPS_INPUT");
        };
        assert_eq!((d.lat, d.lon, d.yaw), (900_000_000, -1_800_000_000, 0));
        assert_eq!(d.fix_type, GpsFixType::GPS_FIX_TYPE_3D_FIX);
        assert!((d.alt - (1000.0 - 13.61)).abs() < 1e-3);
        assert!(d.ignore_flags.is_empty());
        // Away from the pole the heading goes out in cdeg.
        let s = flying_east();
        let MavMessage::GPS_INPUT(d) = gps_input(Some(&s), &q, 0.0, 0, (0, 0)) else {
            panic!("not GPS_INPUT");
        };
        assert_eq!(d.yaw, 0, "the quality of the pole says no yaw");
        let q = assess(
            &Heard {
                solution: Some((&s, 0.0)),
                status_age_s: Some(0.0),
                publisher_present: true,
            },
            &HealthSettings::default(),
        );
        let MavMessage::GPS_INPUT(d) = gps_input(Some(&s), &q, 0.0, 0, (0, 0)) else {
            panic!("not GPS_INPUT");
        };
        assert_eq!(d.yaw, 9000);
    }
}
