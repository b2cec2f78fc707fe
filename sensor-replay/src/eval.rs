//! Accuracy of a solution against the truth of its log. All errors are
//! computed frame-free (ECEF differences and body→ECEF quaternions, projected
//! on the local ENU axes of the truth), so they stay meaningful at the pole.

use std::collections::HashMap;

use msgs::TruthRecord;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use polarnav::earth;
use polarnav::frames;
use polarnav::solution_csv::Row;

/// Error of one solution row against the truth at the same time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch {
    pub t_s: f64,
    /// Position error east/north/up (m).
    pub pos_enu: Vector3<f64>,
    /// Velocity error east/north/up (m/s).
    pub vel_enu: Vector3<f64>,
    /// Attitude error angles about east/north/up (rad): tilt = (E, N), heading = U.
    pub att_enu: Vector3<f64>,
    pub frame: char,
}

/// RMSE and maximum of one error quantity.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stat {
    pub rmse: f64,
    pub max: f64,
}

impl Stat {
    fn of(values: impl Iterator<Item = f64>) -> Self {
        let (mut n, mut sq, mut mx) = (0usize, 0.0, 0.0f64);
        for v in values {
            n += 1;
            sq += v * v;
            mx = mx.max(v.abs());
        }
        if n == 0 {
            Stat {
                rmse: f64::NAN,
                max: f64::NAN,
            }
        } else {
            Stat {
                rmse: (sq / n as f64).sqrt(),
                max: mx,
            }
        }
    }
}

/// The accuracy summary.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Summary {
    pub epochs: usize,
    pub horizontal_m: Stat,
    pub vertical_m: Stat,
    pub velocity_mps: Stat,
    pub tilt_arcmin: Stat,
    pub heading_arcmin: Stat,
    pub non_finite_rows: usize,
}

fn quat(q: &[f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// Errors at every truth epoch that has a solution row at the same time (to 1 µs).
pub fn epochs(rows: &[Row], truth: &[TruthRecord]) -> Vec<Epoch> {
    let key = |t_s: f64| (t_s * 1e6).round() as i64;
    let by_time: HashMap<i64, &Row> = rows.iter().map(|r| (key(r.t_s), r)).collect();
    let mut out = Vec::new();
    for t in truth {
        let Some(r) = by_time.get(&key(t.t_ns as f64 * 1e-9)) else {
            continue;
        };
        let r_true = Vector3::from(t.r_e_m);
        let g = earth::ecef_to_geodetic(&r_true);
        let c_e_g = frames::c_e_g(g.lat_rad, g.lon_rad);
        let dp = c_e_g * (Vector3::from(r.r_e_m) - r_true);
        let dv = c_e_g * (Vector3::from(r.v_e_mps) - Vector3::from(t.v_e_mps));
        // C_b^c = (I − φ×) C_b^n  ⇒  φ = −rotvec(q_sol · q_trueᶜ).
        let d = quat(&r.q_b_e) * quat(&t.q_b_e).inverse();
        let att = c_e_g * (-d.scaled_axis());
        out.push(Epoch {
            t_s: r.t_s,
            pos_enu: dp,
            vel_enu: dv,
            att_enu: att,
            frame: r.frame,
        });
    }
    out
}

pub fn summarize(rows: &[Row], ep: &[Epoch]) -> Summary {
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    Summary {
        epochs: ep.len(),
        horizontal_m: Stat::of(ep.iter().map(|e| e.pos_enu.xy().norm())),
        vertical_m: Stat::of(ep.iter().map(|e| e.pos_enu.z)),
        velocity_mps: Stat::of(ep.iter().map(|e| e.vel_enu.norm())),
        tilt_arcmin: Stat::of(ep.iter().map(|e| e.att_enu.xy().norm() * arcmin)),
        heading_arcmin: Stat::of(ep.iter().map(|e| e.att_enu.z * arcmin)),
        non_finite_rows: rows
            .iter()
            .filter(|r| {
                !(r.r_e_m
                    .iter()
                    .chain(&r.v_e_mps)
                    .chain(&r.q_b_e)
                    .all(|x| x.is_finite()))
            })
            .count(),
    }
}

/// Markdown table of a summary.
pub fn markdown(title: &str, s: &Summary) -> String {
    let mut m = format!("## {title}\n\n{} epochs compared with truth", s.epochs);
    if s.non_finite_rows > 0 {
        m.push_str(&format!(
            ", **{} rows with non-finite values**",
            s.non_finite_rows
        ));
    }
    m.push_str("\n\n| quantity | RMSE | max |\n|---|---|---|\n");
    for (name, st, unit) in [
        ("horizontal position", s.horizontal_m, "m"),
        ("vertical position", s.vertical_m, "m"),
        ("velocity", s.velocity_mps, "m/s"),
        ("tilt", s.tilt_arcmin, "′"),
        ("heading", s.heading_arcmin, "′"),
    ] {
        m.push_str(&format!(
            "| {name} | {:.4} {unit} | {:.4} {unit} |\n",
            st.rmse, st.max
        ));
    }
    m
}
