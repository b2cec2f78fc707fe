//! What the bridges tell the aircraft about the solution's quality: the
//! one fix rule that both MAVLink and NMEA use, so an autopilot and a
//! payload never disagree about whether polarnav has a fix.
//!
//! polarnav is not a GNSS receiver: it has no satellites and no dilution of
//! precision. The fields that GNSS messages carry for them are derived from
//! the solution's own 1-σ and flags, as documented on each field of
//! [`Quality`], so that an autopilot's GPS checks (which read fix type,
//! accuracy, HDOP and satellite count) see a degradation when there is one.

use msgs::{Solution, solution_flags};

use crate::geo;

/// Why the fix is what it is, best last.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Fix {
    /// Neither solution nor status heard within their timeouts, or the
    /// daemon's publisher is gone: MAVLink `GPS_FIX_TYPE_NO_GPS` (0), NMEA
    /// quality 0 / status V.
    NoSource,
    /// The daemon is heard but gives no usable position: not aligned, IMU
    /// lost, a solution older than `silent_after_s`, a non-finite value, or
    /// horizontal accuracy beyond `fix_max_h_acc_m`: `GPS_FIX_TYPE_NO_FIX`
    /// (1), NMEA quality 0 / status V.
    NoFix,
    /// Degraded: coasting over an IMU gap, or accuracy beyond the 3D
    /// bounds: `GPS_FIX_TYPE_2D_FIX` (2), NMEA quality 6 (estimated) / mode E.
    Degraded,
    /// Navigating within the 3D bounds: `GPS_FIX_TYPE_3D_FIX` (3), NMEA
    /// quality 1 / mode A.
    Full,
}

impl Fix {
    /// MAVLink `GPS_FIX_TYPE` value.
    pub fn mavlink_fix_type(self) -> u8 {
        match self {
            Fix::NoSource => 0,
            Fix::NoFix => 1,
            Fix::Degraded => 2,
            Fix::Full => 3,
        }
    }

    /// Whether the position may be used (a 2D or 3D fix).
    pub fn usable(self) -> bool {
        self >= Fix::Degraded
    }

    /// A word for logs and STATUS=.
    pub fn name(self) -> &'static str {
        match self {
            Fix::NoSource => "no source (daemon silent)",
            Fix::NoFix => "no fix",
            Fix::Degraded => "degraded (2D)",
            Fix::Full => "3D",
        }
    }
}

/// The thresholds of the fix rule (`[health]` of both settings files).
#[derive(Debug, Clone, PartialEq)]
pub struct HealthSettings {
    /// A solution older than this (s) is no fix; with no status either, no source.
    pub silent_after_s: f64,
    /// A status older than this (s), with no fresh solution, is no source.
    pub status_silent_after_s: f64,
    /// Largest horizontal / vertical 1-σ (m) of a 3D fix.
    pub fix3d_max_h_acc_m: f64,
    pub fix3d_max_v_acc_m: f64,
    /// Largest horizontal 1-σ (m) of any fix.
    pub fix_max_h_acc_m: f64,
    /// The user range error that turns accuracies into pseudo-DOPs (m).
    pub dop_uere_m: f64,
    /// Largest 1-σ of true heading (°) with which a heading is sent.
    pub yaw_max_sigma_deg: f64,
}

impl Default for HealthSettings {
    fn default() -> Self {
        Self {
            silent_after_s: 0.5,
            status_silent_after_s: 2.5,
            fix3d_max_h_acc_m: 50.0,
            fix3d_max_v_acc_m: 50.0,
            fix_max_h_acc_m: 2000.0,
            dop_uere_m: 5.0,
            yaw_max_sigma_deg: 2.0,
        }
    }
}

/// What the daemon is heard to say at one instant.
#[derive(Debug, Clone, Copy)]
pub struct Heard<'a> {
    /// The newest solution and its age (s) on the bridge's clock.
    pub solution: Option<(&'a Solution, f64)>,
    /// Age (s) of the newest status, if any.
    pub status_age_s: Option<f64>,
    /// Whether the solution service still has a publisher (a daemon that
    /// stopped cleanly has none: no need to wait for a timeout).
    pub publisher_present: bool,
}

/// The fix and the quality fields derived from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quality {
    pub fix: Fix,
    /// Horizontal accuracy (m): √(σ_E² + σ_N²), the 1-σ radial error (DRMS).
    pub h_acc_m: f64,
    /// Vertical accuracy (m): σ_U.
    pub v_acc_m: f64,
    /// Speed accuracy (m/s): √(σ_vx² + σ_vy² + σ_vz²) of the velocity.
    pub speed_acc_mps: f64,
    /// Pseudo-DOPs: accuracy / `dop_uere_m`; `None` with no usable fix.
    pub hdop: Option<f64>,
    pub vdop: Option<f64>,
    /// A satellite count for GNSS consumers' checks, not a count of
    /// anything: 0 without a usable fix, 4 with a degraded one (under
    /// ArduPilot's and PX4's minimum of 6, so they see the degradation),
    /// 6 to 12 with a 3D one, from 12 at zero horizontal σ down to 6 at
    /// `fix3d_max_h_acc_m`.
    pub satellites: u8,
    /// True heading (rad) when it is defined to `yaw_max_sigma_deg`: the
    /// heading's own σ and the turn of true north that the position's σ
    /// makes near the pole ([`geo::meridian_convergence_sigma_rad`]),
    /// root-sum-squared. `None` otherwise (so at the exact pole, and within
    /// σ_h / tan(yaw_max_sigma) of it).
    pub heading_rad: Option<f64>,
}

impl Quality {
    const NONE: Quality = Quality {
        fix: Fix::NoSource,
        h_acc_m: f64::NAN,
        v_acc_m: f64::NAN,
        speed_acc_mps: f64::NAN,
        hdop: None,
        vdop: None,
        satellites: 0,
        heading_rad: None,
    };
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The fix rule. See [`Fix`] for each outcome.
pub fn assess(heard: &Heard<'_>, s: &HealthSettings) -> Quality {
    let status_fresh = heard
        .status_age_s
        .is_some_and(|a| a <= s.status_silent_after_s);
    let fresh = heard
        .solution
        .filter(|(_, age)| heard.publisher_present && *age <= s.silent_after_s);
    let Some((sol, _)) = fresh else {
        let fix = if heard.publisher_present && status_fresh {
            Fix::NoFix
        } else {
            Fix::NoSource
        };
        return Quality {
            fix,
            ..Quality::NONE
        };
    };
    let h_acc_m = norm(&sol.sigma_pos_enu_m[..2]);
    let v_acc_m = sol.sigma_pos_enu_m[2];
    let speed_acc_mps = norm(&sol.sigma_vel_mps);
    let finite = [sol.lat_rad, sol.lon_rad, sol.h_m, h_acc_m, v_acc_m]
        .iter()
        .chain(&sol.v_enu_mps)
        .all(|x| x.is_finite());
    let flags = sol.flags;
    let fix = if !finite
        || flags & solution_flags::ALIGNED == 0
        || flags & solution_flags::IMU_LOST != 0
        || h_acc_m > s.fix_max_h_acc_m
    {
        Fix::NoFix
    } else if flags & solution_flags::COASTING != 0
        || h_acc_m > s.fix3d_max_h_acc_m
        || v_acc_m > s.fix3d_max_v_acc_m
    {
        Fix::Degraded
    } else {
        Fix::Full
    };
    let satellites = match fix {
        Fix::NoSource | Fix::NoFix => 0,
        Fix::Degraded => 4,
        Fix::Full => {
            let spare = (1.0 - h_acc_m / s.fix3d_max_h_acc_m).clamp(0.0, 1.0);
            6 + (6.0 * spare).round() as u8
        }
    };
    let heading_sigma = norm(&[
        sol.sigma_att_rad[2],
        geo::meridian_convergence_sigma_rad(sol.lat_rad, h_acc_m),
    ]);
    let heading_rad = (fix.usable()
        && sol.heading_rad.is_finite()
        && heading_sigma <= s.yaw_max_sigma_deg.to_radians())
    .then_some(sol.heading_rad);
    Quality {
        fix,
        h_acc_m,
        v_acc_m,
        speed_acc_mps,
        hdop: fix.usable().then(|| h_acc_m / s.dop_uere_m),
        vdop: fix.usable().then(|| v_acc_m / s.dop_uere_m),
        satellites,
        heading_rad,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sol(flags: u32, sigma_h: f64) -> Solution {
        Solution {
            lat_rad: 1.2,
            flags,
            sigma_pos_enu_m: [sigma_h, sigma_h, 5.0],
            sigma_vel_mps: [0.1; 3],
            sigma_att_rad: [1e-3; 3],
            heading_rad: 0.3,
            ..Default::default()
        }
    }

    fn heard(s: &Solution, age: f64) -> Heard<'_> {
        Heard {
            solution: Some((s, age)),
            status_age_s: Some(0.1),
            publisher_present: true,
        }
    }

    #[test]
    fn fix_follows_alignment_sigma_and_coasting() {
        let h = HealthSettings::default();
        let a = solution_flags::ALIGNED;
        let q = |s: &Solution| assess(&heard(s, 0.01), &h);
        assert_eq!(q(&sol(a, 5.0)).fix, Fix::Full);
        assert_eq!(q(&sol(a, 5.0)).satellites, 11);
        assert_eq!(q(&sol(0, 5.0)).fix, Fix::NoFix);
        assert_eq!(
            q(&sol(a | solution_flags::COASTING, 5.0)).fix,
            Fix::Degraded
        );
        assert_eq!(q(&sol(a | solution_flags::IMU_LOST, 5.0)).fix, Fix::NoFix);
        assert_eq!(q(&sol(a, 100.0)).fix, Fix::Degraded);
        assert_eq!(q(&sol(a, 100.0)).satellites, 4);
        assert_eq!(q(&sol(a, 2000.0)).fix, Fix::NoFix);
        let mut bad = sol(a, 5.0);
        bad.h_m = f64::NAN;
        assert_eq!(q(&bad).fix, Fix::NoFix);
        assert_eq!(q(&bad).hdop, None);
    }

    #[test]
    fn a_silent_daemon_is_no_source_and_a_stale_solution_no_fix() {
        let h = HealthSettings::default();
        let s = sol(solution_flags::ALIGNED, 5.0);
        assert_eq!(assess(&heard(&s, 0.6), &h).fix, Fix::NoFix);
        let gone = Heard {
            publisher_present: false,
            ..heard(&s, 0.0)
        };
        assert_eq!(assess(&gone, &h).fix, Fix::NoSource);
        let quiet = Heard {
            status_age_s: Some(3.0),
            ..heard(&s, 0.6)
        };
        assert_eq!(assess(&quiet, &h).fix, Fix::NoSource);
        let never = Heard {
            solution: None,
            status_age_s: None,
            publisher_present: false,
        };
        assert_eq!(assess(&never, &h).fix, Fix::NoSource);
    }

    #[test]
    fn heading_is_withheld_at_and_near_the_pole() {
        let h = HealthSettings::default();
        let mut s = sol(solution_flags::ALIGNED, 10.0);
        s.lat_rad = std::f64::consts::FRAC_PI_2;
        assert_eq!(assess(&heard(&s, 0.0), &h).heading_rad, None);
        // 14.14 m of horizontal σ turns north by 2° at about 405 m from the pole.
        s.lat_rad = (90.0f64 - 500.0 / 111_694.0).to_radians();
        assert!(assess(&heard(&s, 0.0), &h).heading_rad.is_some());
        s.lat_rad = (90.0f64 - 300.0 / 111_694.0).to_radians();
        assert_eq!(assess(&heard(&s, 0.0), &h).heading_rad, None);
        // A poorly known heading is withheld anywhere.
        let mut s = sol(solution_flags::ALIGNED, 10.0);
        s.sigma_att_rad[2] = 3f64.to_radians();
        assert_eq!(assess(&heard(&s, 0.0), &h).heading_rad, None);
    }
}
