//! Issue 13 acceptance: the star tracker's attitude as a fourth aid keeps
//! heading (and tilt) observable in straight, level flight over the pole.
//!
//! - transpolar with `[star]` at 1 Hz and 5″ (config/scenarios/transpolar-star.toml):
//!   heading and tilt RMSE ≤ 0.1′ after the first minute, horizontal
//!   position no worse than the same flight without the star tracker (the
//!   simulator draws the star tracker from a generator of its own, so every
//!   other sample of the two flights is the same);
//! - the same with the star tracker lost for 10 minutes over the pole:
//!   heading σ grows during the outage, the first fix after it moves the
//!   heading by less than 3σ, and σ comes back down;
//! - the simulated stream against the truth, with C_e^i built here.

use msgs::AidKind;
use msgs::navlog::Record;
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use polarnav::navigator::NavigatorConfig;
use polarnav::settings::AidSet;
use polarnav_tests::{ARCMIN, Run, errors, quat, repo, rmse, run, simulate_records};

const ARCSEC: f64 = ARCMIN / 60.0;

/// Heading and tilt RMSE (′) of the epochs after `after_s`.
fn attitude_rmse(r: &Run, after_s: f64) -> (f64, f64) {
    let (mut h, mut t, mut n) = (0.0, 0.0, 0.0);
    for (s, tr) in r.snaps.iter().zip(&r.truth) {
        if (s.t_ns as f64) * 1e-9 < after_s {
            continue;
        }
        let (_, _, a) = errors(s, tr);
        h += a.z * a.z;
        t += a.x * a.x + a.y * a.y;
        n += 1.0;
    }
    ((h / n).sqrt() / ARCMIN, (t / n).sqrt() / ARCMIN)
}

fn scenario(file: &str) -> String {
    std::fs::read_to_string(repo(file)).expect("scenario")
}

fn without_star() -> NavigatorConfig {
    NavigatorConfig {
        aids: AidSet::default().with(AidKind::Star, false),
        ..Default::default()
    }
}

/// Checks the acceptance figures of a flight with the star tracker against
/// the same records without it; returns the run with it.
fn accept(name: &str, records: &[Record]) -> Run {
    let with = run(records, &NavigatorConfig::default(), None);
    let without = run(records, &without_star(), None);
    let (hw, tw) = attitude_rmse(&with, 60.0);
    let (hn, tn) = attitude_rmse(&without, 60.0);
    let (pw, pn) = (rmse(&with), rmse(&without));
    eprintln!(
        "{name}: after the first minute heading RMSE {hw:.4}′ tilt {tw:.4}′ with the star tracker, {hn:.4}′ / {tn:.4}′ without; horizontal RMSE {:.3} m with, {:.3} m without; vertical {:.3} / {:.3} m; velocity {:.4} / {:.4} m/s; aids fused {} / {}, rejected {} / {}",
        pw.0,
        pn.0,
        pw.1,
        pn.1,
        pw.2,
        pn.2,
        with.fused,
        without.fused,
        with.rejected,
        without.rejected
    );
    assert!(hw <= 0.1, "{name}: heading RMSE {hw}′ > 0.1′");
    assert!(tw <= 0.1, "{name}: tilt RMSE {tw}′ > 0.1′");
    assert!(
        pw.0 <= pn.0,
        "{name}: horizontal RMSE {} m with the star tracker, {} m without",
        pw.0,
        pn.0
    );
    // Without it, heading stays near its initial 3′ error (unobservable):
    // the star tracker is what makes the figures above.
    assert!(
        hn > 5.0 * hw,
        "{name}: heading {hn}′ without the star tracker"
    );
    with
}

#[test]
fn transpolar_with_a_star_tracker_holds_heading_and_tilt_within_a_tenth_of_an_arcminute() {
    let records = simulate_records(&scenario("config/scenarios/transpolar-star.toml"), 1);
    let stars = records
        .iter()
        .filter(|r| matches!(r, Record::Aid(a) if a.kind() == AidKind::Star))
        .count();
    assert_eq!(stars, 4480, "1 Hz over 4480 s");
    accept("transpolar-star", &records);
}

/// The pole is crossed at 2240 s; the star tracker is lost from 1940 s to 2540 s.
const OUTAGE: (f64, f64) = (1940.0, 2540.0);

#[test]
fn star_tracker_lost_for_ten_minutes_over_the_pole_recovers_without_a_jump() {
    let text = format!(
        "{}\n[[faults.event]]\nkind = \"outage\"\nstream = \"star\"\nstart_s = {}\nduration_s = {}\n",
        scenario("config/scenarios/transpolar-star.toml"),
        OUTAGE.0,
        OUTAGE.1 - OUTAGE.0
    );
    let records = simulate_records(&text, 1);
    let lost = records
        .iter()
        .filter(|r| matches!(r, Record::Aid(a) if matches!(**a, msgs::AidSample::Star(s) if (s.t_ns as f64 * 1e-9) >= OUTAGE.0 && (s.t_ns as f64 * 1e-9) < OUTAGE.1)))
        .count();
    assert_eq!(lost, 0, "the outage removes the star samples");
    let with = accept("transpolar-star, 10 min outage over the pole", &records);
    // Heading σ and error at each epoch (nav-frame φ_z σ, ′).
    let at = |t_s: f64| {
        let k = with
            .snaps
            .iter()
            .position(|s| s.t_ns as f64 * 1e-9 >= t_s - 1e-6)
            .expect("epoch");
        let (_, _, a) = errors(&with.snaps[k], &with.truth[k]);
        (
            with.snaps[k].cov_att[(2, 2)].sqrt() / ARCMIN,
            a.z / ARCMIN,
            with.snaps[k].t_ns,
        )
    };
    let (s_before, _, _) = at(OUTAGE.0 - 1.0);
    let (s_end, e_end, _) = at(OUTAGE.1 - 0.1);
    // The first fix after the outage is stamped at OUTAGE.1 (1 Hz on whole seconds).
    let (s_fix, e_fix, t_fix) = at(OUTAGE.1);
    assert_eq!(t_fix, (OUTAGE.1 * 1e9) as u64);
    let jump = (e_fix - e_end).abs();
    eprintln!(
        "outage: heading σ {s_before:.4}′ before, {s_end:.4}′ at its end, {s_fix:.4}′ after the first fix; heading error {e_end:.4}′ → {e_fix:.4}′ at the first fix (jump {jump:.4}′ = {:.2}σ)",
        jump / s_end
    );
    assert!(
        s_end > 1.5 * s_before,
        "heading σ did not grow: {s_before} → {s_end}"
    );
    // One fix carries 40″ about the boresight (up), i.e. about heading, so
    // σ comes down over the following fixes, not at once.
    let (s_later, _, _) = at(OUTAGE.1 + 300.0);
    eprintln!("outage: heading σ {s_later:.4}′ five minutes after the first fix");
    assert!(
        s_fix < s_end,
        "the first fix did not shrink σ: {s_end} → {s_fix}"
    );
    assert!(
        s_later < 0.8 * s_end,
        "σ did not recover: {s_end} → {s_later}"
    );
    assert!(jump <= 3.0 * s_end, "jump {jump}′ > 3σ = {}′", 3.0 * s_end);
    assert!(jump > 0.0, "the first fix was not fused");
}

/// The simulated stream is the truth's body→inertial attitude: a perfect
/// flight's samples against C_e^i(t) C_b^e built here; with noise, the
/// errors about the body axes across and about the boresight have the
/// stated σ, and the mounting misalignment is their mean.
#[test]
fn simulated_star_samples_are_the_truth_in_the_inertial_frame() {
    let text = scenario("config/scenarios/transpolar-star.toml")
        .replace("duration_s = 4480.0", "duration_s = 2000.0")
        .replace(
            "boresight_sigma_arcsec = 40.0",
            "boresight_sigma_arcsec = 40.0\nmisalignment_arcsec = [3.0, -2.0, 12.0]",
        );
    let s = polarnav_sim::scenario::Scenario::parse(&text, "t").expect("scenario");
    for perfect in [true, false] {
        let mut buf = Vec::new();
        polarnav_sim::simulate::simulate(
            &s,
            &text,
            polarnav_sim::simulate::SimOptions {
                seed: 7,
                perfect,
                ..Default::default()
            },
            &mut buf,
        )
        .expect("simulate");
        let (records, _) = msgs::navlog::read_all(&buf);
        let truth: std::collections::HashMap<u64, UnitQuaternion<f64>> = records
            .iter()
            .filter_map(|r| match r {
                Record::Truth(t) => Some((t.t_ns, quat(&t.q_b_e))),
                _ => None,
            })
            .collect();
        let mut errs = Vec::new();
        for r in &records {
            let Record::Aid(a) = r else { continue };
            let msgs::AidSample::Star(x) = **a else {
                continue;
            };
            let t = x.t_ns as f64 * 1e-9;
            let c_e_i = Rotation3::from_axis_angle(&Vector3::z_axis(), 7.292_115_146_7e-5 * t);
            let expected = UnitQuaternion::from_rotation_matrix(&c_e_i) * truth[&x.t_ns];
            // Error about body axes: C_b^i,meas = C_b^i R(e).
            errs.push((expected.inverse() * quat(&x.q_b_i)).scaled_axis() / ARCSEC);
            assert!((Vector3::from(x.boresight_b) - Vector3::z()).norm() < 1e-15);
        }
        assert_eq!(errs.len(), 2000);
        let n = errs.len() as f64;
        let mean = errs.iter().sum::<Vector3<f64>>() / n;
        let sd = (errs
            .iter()
            .map(|e| (e - mean).component_mul(&(e - mean)))
            .sum::<Vector3<f64>>()
            / n)
            .map(f64::sqrt);
        eprintln!("perfect {perfect}: error mean {mean:?}″, σ {sd:?}″");
        if perfect {
            assert!(errs.iter().all(|e| e.norm() < 1e-4), "{:?}", errs[0]);
        } else {
            for (i, (want_sd, want_mean)) in [(5.0, 3.0), (5.0, -2.0), (40.0, 12.0)]
                .into_iter()
                .enumerate()
            {
                assert!((sd[i] / want_sd - 1.0).abs() < 0.08, "axis {i} σ {}", sd[i]);
                assert!((mean[i] - want_mean).abs() < 4.0 * want_sd / n.sqrt());
            }
        }
    }
}
