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
    /// Velocity error in the axes of the row's navigation frame (g: E, N, U;
    /// G: grid east, grid north, up), the axes of its σ columns (m/s).
    pub vel_nav: Vector3<f64>,
    /// Attitude error φ in the axes of the row's navigation frame (rad), the
    /// axes of its σ columns; z (up) is the same axis in g and G.
    pub att_nav: Vector3<f64>,
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
    /// Mean position NEES with the CSV's per-axis σ (diagonal approximation; ideal 3).
    pub position_nees: f64,
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
        let phi_e = -d.scaled_axis();
        let att = c_e_g * phi_e;
        // The nav axes at the true position (the filter's own differ by its
        // position error, metres against the kilometres the axes turn over).
        let c_e_n = if r.frame == 'G' {
            frames::c_e_grid(g.lat_rad, g.lon_rad)
        } else {
            c_e_g
        };
        let dv_e = Vector3::from(r.v_e_mps) - Vector3::from(t.v_e_mps);
        out.push(Epoch {
            t_s: r.t_s,
            pos_enu: dp,
            vel_enu: dv,
            att_enu: att,
            vel_nav: c_e_n * dv_e,
            att_nav: c_e_n * phi_e,
            frame: r.frame,
        });
    }
    out
}

pub fn summarize(rows: &[Row], ep: &[Epoch]) -> Summary {
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    let key = |t_s: f64| (t_s * 1e6).round() as i64;
    let sig: HashMap<i64, [f64; 3]> = rows.iter().map(|r| (key(r.t_s), r.sigma_enu_m)).collect();
    let nees: Vec<f64> = ep
        .iter()
        .filter_map(|e| sig.get(&key(e.t_s)).map(|s| (s, e)))
        .map(|(s, e)| (0..3).map(|i| (e.pos_enu[i] / s[i]).powi(2)).sum::<f64>())
        .filter(|v| v.is_finite())
        .collect();
    Summary {
        position_nees: if nees.is_empty() {
            f64::NAN
        } else {
            nees.iter().sum::<f64>() / nees.len() as f64
        },
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
    m.push_str(&format!(
        "; mean position NEES {:.2} (per-axis σ of the CSV; ideal 3, NaN without a filter)",
        s.position_nees
    ));
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

/// How a frame switch disturbed the solution: maximum deviation of the
/// heading error and of the velocity-error magnitude from their linear trend
/// over the `before_s` preceding the switch, within `after_s` after it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchTransient {
    pub t_s: f64,
    pub from: char,
    pub to: char,
    pub heading_dev_arcmin: f64,
    pub velocity_dev_mps: f64,
    pub horizontal_dev_m: f64,
}

fn linear_fit(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / n, sy / n);
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx) * (p.1 - my), a.1 + (p.0 - mx).powi(2))
    });
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (slope, my - slope * mx)
}

fn max_dev(ep: &[Epoch], t_sw: f64, before_s: f64, after_s: f64, f: impl Fn(&Epoch) -> f64) -> f64 {
    let pre: Vec<(f64, f64)> = ep
        .iter()
        .filter(|e| e.t_s > t_sw - before_s && e.t_s <= t_sw)
        .map(|e| (e.t_s, f(e)))
        .collect();
    if pre.len() < 2 {
        return f64::NAN;
    }
    let (a, b) = linear_fit(&pre);
    ep.iter()
        .filter(|e| e.t_s > t_sw && e.t_s <= t_sw + after_s)
        .map(|e| (f(e) - (a * e.t_s + b)).abs())
        .fold(0.0, f64::max)
}

/// Transients at every frame change in the solution rows.
pub fn switch_transients(
    rows: &[Row],
    ep: &[Epoch],
    before_s: f64,
    after_s: f64,
) -> Vec<SwitchTransient> {
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    rows.windows(2)
        .filter(|w| w[0].frame != w[1].frame)
        .map(|w| {
            let t = w[1].t_s;
            SwitchTransient {
                t_s: t,
                from: w[0].frame,
                to: w[1].frame,
                heading_dev_arcmin: max_dev(ep, t, before_s, after_s, |e| e.att_enu.z * arcmin),
                velocity_dev_mps: max_dev(ep, t, before_s, after_s, |e| e.vel_enu.norm()),
                horizontal_dev_m: max_dev(ep, t, before_s, after_s, |e| e.pos_enu.xy().norm()),
            }
        })
        .collect()
}

/// Markdown table of switch transients.
pub fn transients_markdown(title: &str, t: &[SwitchTransient]) -> String {
    let mut m = format!(
        "### {title}: error drift around each switch (largest deviation of the error from its 60 s pre-switch trend within 200 s after)\n\n\
         This is the filter's own wander over 200 s, not the switch: the switch's transient is the \
         deviation from a run of the same log without that switch, given to `eval --compare` \
         (`nav-daemon batch --force-switch 0`: the grid frame throughout; `--no-switch` where the \
         flight stays away from the pole), in the table after the figures.\n\n"
    );
    if t.is_empty() {
        m.push_str("no frame switch\n");
        return m;
    }
    m.push_str("| t (s) | switch | heading (′) | velocity (m/s) | horizontal (m) |\n|---|---|---|---|---|\n");
    for x in t {
        m.push_str(&format!(
            "| {:.2} | {}→{} | {:.4} | {:.4} | {:.3} |\n",
            x.t_s, x.from, x.to, x.heading_dev_arcmin, x.velocity_dev_mps, x.horizontal_dev_m
        ));
    }
    m
}

/// Deviation of one run from a reference run (e.g. never switching) after
/// each switch of the first: maxima over `after_s` of the attitude
/// difference about the local vertical, the velocity and position differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunDeviation {
    pub t_s: f64,
    pub from: char,
    pub to: char,
    pub heading_arcmin: f64,
    pub tilt_arcmin: f64,
    pub velocity_mps: f64,
    pub position_m: f64,
}

pub fn deviation_after_switches(a: &[Row], b: &[Row], after_s: f64) -> Vec<RunDeviation> {
    let key = |t_s: f64| (t_s * 1e6).round() as i64;
    let by_time: HashMap<i64, &Row> = b.iter().map(|r| (key(r.t_s), r)).collect();
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    a.windows(2)
        .filter(|w| w[0].frame != w[1].frame)
        .map(|w| {
            let t0 = w[1].t_s;
            let mut d = RunDeviation {
                t_s: t0,
                from: w[0].frame,
                to: w[1].frame,
                heading_arcmin: 0.0,
                tilt_arcmin: 0.0,
                velocity_mps: 0.0,
                position_m: 0.0,
            };
            for ra in a.iter().filter(|r| r.t_s >= t0 && r.t_s <= t0 + after_s) {
                let Some(rb) = by_time.get(&key(ra.t_s)) else {
                    continue;
                };
                let r = Vector3::from(rb.r_e_m);
                let g = earth::ecef_to_geodetic(&r);
                let c = frames::c_e_g(g.lat_rad, g.lon_rad);
                let att = c * (quat(&ra.q_b_e) * quat(&rb.q_b_e).inverse()).scaled_axis();
                d.heading_arcmin = d.heading_arcmin.max(att.z.abs() * arcmin);
                d.tilt_arcmin = d.tilt_arcmin.max(att.xy().norm() * arcmin);
                d.velocity_mps = d
                    .velocity_mps
                    .max((Vector3::from(ra.v_e_mps) - Vector3::from(rb.v_e_mps)).norm());
                d.position_m = d.position_m.max((Vector3::from(ra.r_e_m) - r).norm());
            }
            d
        })
        .collect()
}

pub fn deviation_markdown(t: &[RunDeviation], after_s: f64) -> String {
    let mut m = format!(
        "### Switch transients: solution against compare after each switch of solution (max over {after_s:.0} s)\n\n\
         With compare a run of the same log without the switch (grid throughout, or geographic \
         throughout away from the pole), this is what the switch itself changed.\n\n"
    );
    if t.is_empty() {
        m.push_str("no frame switch in solution\n");
        return m;
    }
    m.push_str("| t (s) | switch | heading (′) | tilt (′) | velocity (m/s) | position (m) |\n|---|---|---|---|---|---|\n");
    for x in t {
        m.push_str(&format!(
            "| {:.2} | {}→{} | {:.2e} | {:.2e} | {:.2e} | {:.2e} |\n",
            x.t_s, x.from, x.to, x.heading_arcmin, x.tilt_arcmin, x.velocity_mps, x.position_m
        ));
    }
    m
}
