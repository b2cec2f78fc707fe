//! GNSS, the fifth aid (issue 29): consistent at the exact pole, caught
//! when it is spoofed, dropped without a transient when it is jammed, and
//! never excluded by chance.
//!
//! The spoofing flights are `config/scenarios/gnss/spoof-*.toml`: 1200 s
//! over the North Pole with every autonomous aid and GNSS, the spoofer on
//! from 300 s to 900 s. Each is flown three times on the same records:
//! with the integrity test (the default), with it switched off, and
//! without GNSS.

use msgs::navlog::Record;
use msgs::{AidKind, solution_flags};
use polarnav::integrity::Verdict;

/// The upper quantile of χ²(6) at `alpha`, by bisection on the tail's
/// closed form Q(x) = e^(−x/2) (1 + x/2 + x²/8).
fn chi2_6_upper_quantile(alpha: f64) -> f64 {
    let q = |x: f64| (-x / 2.0).exp() * (1.0 + x / 2.0 + x * x / 8.0);
    let (mut lo, mut hi) = (0.0f64, 400.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if q(mid) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
use polarnav::navigator::NavigatorConfig;
use polarnav_config::{CliOverrides, ConfigFile, effective};
use polarnav_tests::{Run, errors, nees, repo, run, simulate_records};

fn scenario(name: &str) -> String {
    std::fs::read_to_string(repo(&format!("config/scenarios/gnss/{name}.toml"))).expect("scenario")
}

/// The settings `batch` takes for a log simulated from `scenario`: the
/// shipped defaults and the scenario's `[navigator]` table (the antenna's
/// lever arm). Every aid, GNSS tested for integrity.
fn with_integrity(scenario: &str) -> NavigatorConfig {
    effective(
        &ConfigFile::defaults(),
        Some(scenario),
        &CliOverrides::default(),
    )
    .expect("settings")
    .config
    .navigator()
}

/// GNSS fused whenever its own gate passes it; the autonomous aids still
/// fused, and an aid rejected for `reset_after_s` while consistent still
/// resets the state to itself.
fn without_integrity(scenario: &str) -> NavigatorConfig {
    let mut c = with_integrity(scenario);
    c.aid_settings.own.gnss.integrity = false;
    c
}

/// GNSS/INS as the peers build it (PX4's EKF2, ArduPilot, KF-GINS): the
/// receiver and the barometer, GNSS gated by its own innovations only,
/// its error taken as white (no consider parameters), and the state
/// reset to it when it has been rejected for a while.
fn as_the_peers(scenario: &str) -> NavigatorConfig {
    let mut c = without_integrity(scenario);
    let g = &mut c.aid_settings.own.gnss;
    g.correlated_sigma_h_m = 0.0;
    g.correlated_sigma_v_m = 0.0;
    NavigatorConfig {
        aids: polarnav::settings::AidSet::NONE
            .with(AidKind::Gnss, true)
            .with(AidKind::Baro, true),
        ..c
    }
}

/// The autonomous aids only.
fn without_gnss(scenario: &str) -> NavigatorConfig {
    let c = with_integrity(scenario);
    NavigatorConfig {
        aids: c.aids.with(AidKind::Gnss, false),
        ..c
    }
}

/// Horizontal error (m) at each truth epoch: (t_s, error).
fn horizontal(r: &Run) -> Vec<(f64, f64)> {
    r.snaps
        .iter()
        .zip(&r.truth)
        .map(|(s, t)| (s.t_ns as f64 * 1e-9, errors(s, t).0.xy().norm()))
        .collect()
}

fn max_in(v: &[(f64, f64)], from_s: f64, to_s: f64) -> f64 {
    v.iter()
        .filter(|(t, _)| *t >= from_s && *t < to_s)
        .map(|(_, e)| *e)
        .fold(0.0, f64::max)
}

const SPOOF_START_S: f64 = 300.0;
const SPOOF_END_S: f64 = 900.0;

/// One drag: excluded before the horizontal error reaches 100 m; from the
/// exclusion to the readmission the solution is, bit for bit, that of the
/// same flight without GNSS (the main navigator took the reference's
/// state, and both then had the same inputs); readmitted once the true
/// signals are back and have agreed for the readmission time. Without the
/// test, GNSS/INS as the peers build it follows the spoofer beyond 1 km;
/// polarnav with the test switched off is printed beside it (its χ² gate
/// and its reset to an aid rejected while consistent, CNS, hold a slow drag
/// to tens of metres, but a fast one wins: see the note).
fn spoofed_at(drag: &str) {
    let text = scenario(&format!("spoof-drag-{drag}"));
    let records = simulate_records(&text, 1);
    let (on, off, peers, none) = std::thread::scope(|s| {
        let on = s.spawn(|| run(&records, &with_integrity(&text), None));
        let off = s.spawn(|| run(&records, &without_integrity(&text), None));
        let peers = run(&records, &as_the_peers(&text), None);
        let none = run(&records, &without_gnss(&text), None);
        (
            on.join().expect("run"),
            off.join().expect("run"),
            peers,
            none,
        )
    });
    let excluded = on.decisions(Verdict::Exclude);
    let readmitted = on.decisions(Verdict::Readmit);
    assert_eq!(
        excluded.len(),
        1,
        "drag {drag} m/s²: exclusions at {excluded:?}"
    );
    let t_x = excluded[0] as f64 * 1e-9;
    assert!(
        (SPOOF_START_S..SPOOF_END_S).contains(&t_x),
        "drag {drag} m/s²: excluded at {t_x} s"
    );
    let (h_on, h_off, h_none) = (horizontal(&on), horizontal(&off), horizontal(&none));
    let before = max_in(&h_on, SPOOF_START_S, t_x);
    // From the exclusion (the first truth epoch after it) to the readmission.
    let t_r = readmitted
        .first()
        .map_or(f64::INFINITY, |t| *t as f64 * 1e-9);
    let mut identical = 0;
    for (a, b) in on.snaps.iter().zip(&none.snaps) {
        let t = a.t_ns as f64 * 1e-9;
        if t > t_x && t < t_r {
            assert_eq!(
                a.r_e.map(f64::to_bits),
                b.r_e.map(f64::to_bits),
                "drag {drag} m/s², t {t} s: the excluded solution is not the autonomous one"
            );
            assert!(a.flags & solution_flags::GNSS_EXCLUDED != 0, "t {t} s");
            identical += 1;
        }
    }
    let after = max_in(&h_on, t_x, t_r.min(SPOOF_END_S));
    let autonomous = max_in(&h_none, t_x, t_r.min(SPOOF_END_S));
    let off_max = max_in(&h_off, SPOOF_START_S, SPOOF_END_S);
    let followed = max_in(&horizontal(&peers), SPOOF_START_S, SPOOF_END_S);
    let end = h_on.last().map_or(f64::NAN, |e| e.1);
    eprintln!(
        "drag {drag:>5} m/s²: excluded {:6.1} s after the spoofer started (q/threshold {:.1}), \
         horizontal error before it {before:5.1} m; excluded until {t_r:.1} s ({identical} epochs \
         bit for bit the autonomous solution, worst error {after:.1} m, without GNSS {autonomous:.1} m); \
         without the test: {off_max:.0} m, GNSS/INS as the peers build it {followed:.0} m; \
         at the end {end:.1} m",
        t_x - SPOOF_START_S,
        on.integrity
            .iter()
            .find(|(_, _, v)| *v == Verdict::Exclude)
            .map_or(f64::NAN, |(_, t, _)| t.ratio()),
    );
    assert!(
        before < 100.0,
        "drag {drag} m/s²: {before} m of error before the exclusion"
    );
    assert!(identical > 0, "drag {drag} m/s²: no epoch excluded");
    assert!(
        after <= autonomous,
        "drag {drag} m/s²: {after} m after the exclusion, {autonomous} m without GNSS"
    );
    assert!(
        followed > 1000.0,
        "drag {drag} m/s²: the peers' GNSS/INS followed the spoofer only {followed} m"
    );
    // The true signals are back at 900 s and agree: readmitted after the
    // readmission time (60 s), and GNSS brings the error back down.
    assert_eq!(readmitted.len(), 1, "drag {drag} m/s²: {readmitted:?}");
    assert!(
        (SPOOF_END_S + 60.0..SPOOF_END_S + 70.0).contains(&t_r),
        "drag {drag} m/s²: readmitted at {t_r} s"
    );
    assert!(end < 10.0, "drag {drag} m/s²: {end} m at the end");
    let g = on.status.aid(AidKind::Gnss);
    assert_eq!((g.excluded, g.exclusions), (0, 1));
    assert!(on.status.aid_counters(AidKind::Gnss).rejected_integrity > 0);
    // The autonomous aids hold the reference: the test could judge every
    // fix (its protection level within the 185 m alert limit), also while
    // GNSS was excluded.
    let unavailable: Vec<f64> = on
        .integrity
        .iter()
        .filter(|(_, t, _)| !t.available())
        .map(|(_, t, _)| t.protection_m)
        .collect();
    assert!(
        unavailable.is_empty() && on.availability.is_empty(),
        "drag {drag} m/s²: the test unavailable at {} fixes (levels {unavailable:?})",
        unavailable.len()
    );
    assert_eq!(g.integrity_state, msgs::integrity_state::TESTED);
}

#[test]
fn spoofing_dragging_at_0_01_m_s2_is_excluded_before_100_m() {
    spoofed_at("0.01");
}

#[test]
fn spoofing_dragging_at_0_1_m_s2_is_excluded_before_100_m() {
    spoofed_at("0.1");
}

#[test]
fn spoofing_dragging_at_1_m_s2_is_excluded_before_100_m() {
    spoofed_at("1");
}

#[test]
fn spoofing_dragging_at_10_m_s2_is_excluded_before_100_m() {
    spoofed_at("10");
}

/// A meaconer 500 m away: excluded at the first fix it sends.
#[test]
fn meaconing_is_excluded_at_its_first_epoch() {
    let text = scenario("spoof-meaconing");
    let records = simulate_records(&text, 1);
    let first = records
        .iter()
        .find_map(|r| match r {
            Record::Aid(a) if a.kind() == AidKind::Gnss && a.t_ns() >= 300_000_000_000 => {
                Some(a.t_ns())
            }
            _ => None,
        })
        .expect("a fix in the window");
    let on = run(&records, &with_integrity(&text), None);
    let excluded = on.decisions(Verdict::Exclude);
    let ratio = on
        .integrity
        .iter()
        .find(|(_, _, v)| *v == Verdict::Exclude)
        .map_or(f64::NAN, |(_, t, _)| t.ratio());
    eprintln!(
        "meaconing 500 m: excluded at {:?} s (first spoofed fix {} s), q/threshold {ratio:.0}",
        excluded
            .iter()
            .map(|t| *t as f64 * 1e-9)
            .collect::<Vec<_>>(),
        first as f64 * 1e-9
    );
    assert_eq!(excluded.first(), Some(&first));
    let worst = max_in(&horizontal(&on), 290.0, 600.0);
    assert!(worst < 100.0, "{worst} m");
}

/// 600 s through the exact North Pole with GNSS (5 Hz, white errors of
/// 1 m / 2 m and 0.05 m/s, lever arm 1.5 m ahead and 0.8 m up, and a
/// Gauss–Markov error of `gm_h` / `gm_v` m, 300 s) and no CNS: the pole
/// window of tests/consistency.rs, seeds 700 + `seeds`.
fn pole_gnss_runs(gm_h: f64, gm_v: f64, cfg: &NavigatorConfig, seeds: u64) -> Vec<Run> {
    let text = format!(
        r#"
name = "pole-gnss"
description = "600 s through the exact North Pole with GNSS and no CNS"
[start]
lat_deg = 89.0
lon_deg = 40.0
h_m = 18000.0
heading_deg = 0.0
speed_mps = 250.0
[imu]
rate_hz = 200.0
gyro_bias_dph = 0.01
accel_bias_ug = 100.0
arw_dpsh = 0.001
vrw_ug_psqhz = 10.0
[truth]
rate_hz = 1.0
[srs]
rate_hz = 1.0
sigma_mps = 0.5
[baro]
rate_hz = 10.0
sigma_m = 10.0
[gnss]
rate_hz = 5.0
sigma_h_m = 1.0
sigma_v_m = 2.0
gm_sigma_h_m = {gm_h:?}
gm_sigma_v_m = {gm_v:?}
gm_tau_s = 300.0
sigma_vel_mps = 0.05
lever_arm_b_m = [0.0, 1.5, 0.8]
[init_error]
pos_h_m = 10.0
pos_v_m = 10.0
vel_h_mps = 0.1
vel_v_mps = 0.1
tilt_arcmin = 1.0
heading_arcmin = 3.0
[[segment]]
kind = "cruise"
duration_s = 600.0
"#
    );
    let text = &text;
    let runs: Vec<Run> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..2u64)
            .map(|k| {
                scope.spawn(move || {
                    (0..seeds)
                        .filter(|s| s % 2 == k)
                        .map(|seed| run(&simulate_records(text, 700 + seed), cfg, None))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("thread"))
            .collect()
    });
    // Through the exact pole: the closest epoch is within a few km of it.
    let closest = runs[0]
        .truth
        .iter()
        .map(|t| {
            polarnav::earth::ecef_to_geodetic(&nalgebra::Vector3::from(t.r_e_m))
                .lat_rad
                .to_degrees()
        })
        .fold(0.0, f64::max);
    assert!(closest > 89.99, "closest {closest}°");
    let (mut h, mut n) = (0.0, 0usize);
    for r in &runs {
        for (s, t) in r.snaps.iter().zip(&r.truth) {
            h += errors(s, t).0.xy().norm_squared();
            n += 1;
        }
    }
    eprintln!(
        "GNSS (Gauss–Markov {gm_h} m / {gm_v} m), no CNS, over the exact pole ({closest:.4}°): \
         horizontal RMSE {:.2} m over {seeds} seeds",
        (h / n as f64).sqrt()
    );
    runs
}

/// The average over seeds and epochs of the position, velocity and
/// attitude NEES.
fn average_nees(runs: &[Run]) -> [f64; 3] {
    let per_seed: Vec<Vec<[f64; 3]>> = runs.iter().map(nees).collect();
    let epochs = per_seed[0].len();
    let mut out = [0.0; 3];
    for (i, o) in out.iter_mut().enumerate() {
        *o = (0..epochs)
            .map(|k| per_seed.iter().map(|r| r[k][i]).sum::<f64>() / runs.len() as f64)
            .sum::<f64>()
            / epochs as f64;
    }
    out
}

/// The 95 % band of the average NEES of 3 states over 30 seeds.
const NEES_BAND_30: (f64, f64) = (65.647 / 30.0, 118.136 / 30.0);

fn assert_in_band(what: &str, mean: [f64; 3]) {
    let (lo, hi) = NEES_BAND_30;
    for (i, name) in ["position", "velocity", "attitude"].iter().enumerate() {
        eprintln!(
            "{what}: {name} average NEES {:.3} (band [{lo:.3}, {hi:.3}])",
            mean[i]
        );
        assert!(
            (lo..=hi).contains(&mean[i]),
            "{what}: {name} average NEES {} outside [{lo}, {hi}]",
            mean[i]
        );
    }
}

/// With white receiver errors, 30 seeds: the average NEES of position,
/// velocity and attitude inside the 95 % χ² band.
#[test]
fn thirty_seed_average_nees_with_gnss_and_no_cns_over_the_exact_pole() {
    // The receiver's white error is its own floor: R is what it is.
    let mut cfg = NavigatorConfig::default();
    cfg.aid_settings.own.gnss.lever_arm_b_m = [0.0, 1.5, 0.8];
    cfg.aid_settings.own.gnss.sigma_floor_h_m = 1.0;
    cfg.aid_settings.own.gnss.sigma_floor_v_m = 2.0;
    let runs = pole_gnss_runs(0.0, 0.0, &cfg, 30);
    assert_in_band("GNSS, no CNS", average_nees(&runs));
    for r in &runs {
        assert!(r.decisions(Verdict::Exclude).is_empty());
    }
}

/// The receiver as a real one is: a Gauss–Markov error of 1.5 m / 3 m
/// (300 s) beside the white one, its accuracy estimates their sum. With
/// the navigator told of the correlated share (`correlated_sigma_h_m`,
/// `_v_m`, `_tau_s`: consider parameters), 30 seeds: the average NEES
/// inside the 95 % band. Told nothing (R white, as every peer fuses a
/// receiver), 10 of the same seeds: the position's average NEES far above
/// the band, printed beside (the test can fail). The velocity's NEES also
/// checks the parameters' decay: without e^(−Δt/τ) in the propagation it
/// was 87.6.
#[test]
fn thirty_seed_average_nees_with_a_correlated_receiver_error_over_the_exact_pole() {
    let mut cfg = NavigatorConfig::default();
    let g = &mut cfg.aid_settings.own.gnss;
    g.lever_arm_b_m = [0.0, 1.5, 0.8];
    g.sigma_floor_h_m = 1.0;
    g.sigma_floor_v_m = 2.0;
    let white = cfg.clone();
    let g = &mut cfg.aid_settings.own.gnss;
    g.correlated_sigma_h_m = 1.5;
    g.correlated_sigma_v_m = 3.0;
    g.correlated_tau_s = 300.0;
    let runs = pole_gnss_runs(1.5, 3.0, &cfg, 30);
    let considered = average_nees(&runs);
    for r in &runs {
        assert!(r.decisions(Verdict::Exclude).is_empty());
    }
    // R white: the receiver's estimate, hypot(1, 1.5) m, above the floor.
    let told_nothing = average_nees(&pole_gnss_runs(1.5, 3.0, &white, 10));
    eprintln!(
        "correlated receiver error: position average NEES {:.3} with the consider parameters, \
         {:.3} fused as white (10 seeds)",
        considered[0], told_nothing[0]
    );
    assert_in_band("GNSS with a Gauss–Markov error, considered", considered);
    assert!(
        told_nothing[0] > 2.0 * NEES_BAND_30.1,
        "fused as white: position NEES {}",
        told_nothing[0]
    );
}

/// Jamming for 30 min over the pole (`jam-pole`): the receiver's accuracy
/// grows 30-fold over 2 min, then it has no fix. GNSS is not excluded (it
/// says it is bad, and it is as bad as it says). No transient: at no epoch
/// of the jamming and the two minutes around it does the solution step (its
/// error's change between two 10 Hz epochs) by more than 3σ; once the fix
/// is lost, the autonomous solution's error stays inside its 3σ bound; the
/// fix that returns moves the solution by less than 3σ. The flags and the
/// status say which aids navigated.
///
/// While GNSS navigates, the error is not held to the filter's σ: the
/// receiver's Gauss–Markov error (1.5 m, 300 s) is correlated, and the
/// filter, as every loosely coupled filter without states for it (KF-GINS,
/// papers 002 and 003), takes each fix's error as white. The ratio is
/// printed.
#[test]
fn jamming_over_the_pole_falls_back_without_a_transient() {
    let text = scenario("jam-pole");
    let records = simulate_records(&text, 1);
    let r = run(&records, &with_integrity(&text), None);
    let (start, ramp, end) = (1340.0, 120.0, 1340.0 + 1800.0);
    // 2D Mahalanobis distance over χ²(2) at 3σ (99.73 %): 11.83.
    let bound = |s: &polarnav_tests::Snapshot, e: &nalgebra::Vector3<f64>| {
        let p = s.cov_pos.fixed_view::<2, 2>(0, 0).into_owned();
        (e.xy().dot(&(p.try_inverse().expect("P") * e.xy())) / 11.83).sqrt()
    };
    let (mut aided, mut autonomous, mut worst_step) = (0.0f64, 0.0f64, 0.0f64);
    let mut prev: Option<nalgebra::Vector3<f64>> = None;
    let mut lost_flag_at = None;
    let mut back_flag_at = None;
    let mut back_step = (0.0, 0.0);
    for (s, t) in r.snaps.iter().zip(&r.truth) {
        let ts = s.t_ns as f64 * 1e-9;
        let (e, _, _) = errors(s, t);
        let fresh = s.flags & solution_flags::GNSS_FRESH != 0;
        if ts >= start + ramp && lost_flag_at.is_none() && !fresh {
            lost_flag_at = Some(ts);
        }
        if ts >= end && back_flag_at.is_none() && fresh {
            back_flag_at = Some(ts);
            if let Some(p) = prev {
                let sigma = s.cov_pos[(0, 0)].max(s.cov_pos[(1, 1)]).sqrt();
                back_step = ((e - p).xy().norm(), sigma);
            }
        }
        if ts < start {
            aided = aided.max(bound(s, &e));
        }
        if lost_flag_at.is_some() && back_flag_at.is_none() {
            autonomous = autonomous.max(bound(s, &e));
        }
        if (start - 60.0..end + 120.0).contains(&ts)
            && let Some(p0) = prev
        {
            let sigma = s.cov_pos[(0, 0)].min(s.cov_pos[(1, 1)]).sqrt();
            worst_step = worst_step.max((e - p0).xy().norm() / sigma);
        }
        prev = Some(e);
    }
    let g = r.status.aid(AidKind::Gnss);
    let c = r.status.aid_counters(AidKind::Gnss);
    eprintln!(
        "jamming: largest step between epochs {worst_step:.3}σ; without a fix the error within \
         {autonomous:.2} of its 3σ bound at worst (with clean GNSS before the jamming, {aided:.2}: the \
         receiver's correlated error); GNSS stale from {lost_flag_at:?} s, fresh again from \
         {back_flag_at:?} s (fix back at {end} s, step {:.2} m at σ {:.2} m); {} fixes refused as \
         below 3D, {} exclusions; {} fixes refused by the integrity test as unverifiable (their \
         accuracy estimates beyond what it can check), the first at {:?} s",
        back_step.0,
        back_step.1,
        g.refused[1],
        g.exclusions,
        r.decisions(Verdict::Unverifiable).len(),
        r.decisions(Verdict::Unverifiable)
            .first()
            .map(|t| *t as f64 * 1e-9)
    );
    assert!(worst_step <= 3.0, "a step of {worst_step}σ");
    assert!(
        autonomous <= 1.0,
        "error outside its 3σ bound ×{autonomous}"
    );
    assert!(
        r.decisions(Verdict::Exclude).is_empty(),
        "jamming is not spoofing"
    );
    // The growing accuracy estimates hand over to the autonomous aids before
    // the fix is lost: fixes the test cannot verify are refused (counted as
    // rejected by the integrity test), only within the ramp.
    let unverifiable = r.decisions(Verdict::Unverifiable);
    assert!(
        !unverifiable.is_empty()
            && unverifiable
                .iter()
                .all(|&t| (start..=start + ramp).contains(&(t as f64 * 1e-9))),
        "unverifiable fixes at {unverifiable:?}"
    );
    assert_eq!(c.rejected_integrity, unverifiable.len() as u64);
    // No fix from the end of the ramp: stale within the timeout (3 s).
    let lost = lost_flag_at.expect("GNSS never stale");
    assert!(lost <= start + ramp + 3.2, "stale only at {lost} s");
    let back = back_flag_at.expect("GNSS never fresh again");
    assert!(back <= end + 1.0, "fresh again only at {back} s");
    assert!(back_step.0 <= 3.0 * back_step.1, "{back_step:?}");
    // Every fix after the ramp refused as below 3D (5 Hz over 1680 s).
    assert_eq!(g.refused[1], 5 * 1680);
    assert!(c.accepted > 0);
}

/// No false alarm: the transpolar soak flight (`polar-long`, 7.46 h, every
/// autonomous aid) with clean GNSS, three seeds: over 22 flight hours and
/// 400 000 tests, GNSS is never excluded. The IMU runs at 100 Hz to keep
/// the test short (the integrity test sees only the fixes and the two
/// navigators' covariances).
#[test]
fn no_false_alarm_over_22_flight_hours_of_clean_gnss() {
    let base = std::fs::read_to_string(repo("config/scenarios/polar-long.toml")).expect("scenario");
    let gnss =
        std::fs::read_to_string(repo("config/scenarios/transpolar-gnss.toml")).expect("scenario");
    let section =
        &gnss[gnss.find("[gnss]").expect("[gnss]")..gnss.find("[init_error]").expect("init")];
    let text = base
        .replace("rate_hz = 200.0", "rate_hz = 100.0")
        .replace("[truth]\nrate_hz = 10.0", "[truth]\nrate_hz = 0.1")
        .replace("[init_error]", &format!("{section}[init_error]"));
    assert!(text.contains("[gnss]") && text.contains("rate_hz = 100.0"));
    let runs: Vec<(u64, Run)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..3u64)
            .map(|seed| {
                let text = &text;
                scope.spawn(move || {
                    (
                        seed,
                        run(
                            &simulate_records(text, 900 + seed),
                            &with_integrity(text),
                            None,
                        ),
                    )
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("thread"))
            .collect()
    });
    let (mut tests, mut hours, mut worst) = (0usize, 0.0, 0.0f64);
    for (seed, r) in &runs {
        let n = r.integrity.len();
        let top = r
            .integrity
            .iter()
            .map(|(_, t, _)| t.ratio())
            .fold(0.0, f64::max);
        let mean_q = r.integrity.iter().map(|(_, t, _)| t.q).sum::<f64>() / n.max(1) as f64;
        let h = r.truth.last().map_or(0.0, |t| t.t_ns as f64 / 3.6e12);
        eprintln!(
            "seed {seed}: {h:.2} h, {n} tests, mean q {mean_q:.2} (χ²(6): 6), largest q/threshold {top:.3}, exclusions {}",
            r.decisions(Verdict::Exclude).len()
        );
        tests += n;
        hours += h;
        worst = worst.max(top);
        // Each test is charged its share of the rate per hour: the time
        // since the previous test (1 ms to 1 s; the first, a second), its
        // threshold the χ²(6) quantile of λ·Δt/3600 s from the tail's
        // closed form (not the χ² module).
        let lambda =
            polarnav::integrity::IntegritySettings::default().integrity_false_alarm_per_hour;
        let mut last: Option<u64> = None;
        for (t_ns, test, _) in &r.integrity {
            let dt = last.map_or(1.0, |l| {
                (t_ns.saturating_sub(l) as f64 * 1e-9).clamp(1e-3, 1.0)
            });
            let want = chi2_6_upper_quantile(lambda * dt / 3600.0);
            assert!(
                (test.threshold / want - 1.0).abs() < 1e-9,
                "seed {seed} at {t_ns} ns (Δt {dt} s): threshold {} against {want}",
                test.threshold
            );
            last = Some(last.map_or(*t_ns, |l| l.max(*t_ns)));
        }
        assert!(
            r.decisions(Verdict::Exclude).is_empty(),
            "seed {seed}: a false alarm"
        );
        assert!(
            r.integrity.iter().all(|(_, t, _)| t.available()) && r.availability.is_empty(),
            "seed {seed}: the test unavailable"
        );
    }
    eprintln!(
        "no false alarm: {hours:.1} flight hours, {tests} tests, largest q/threshold {worst:.3}"
    );
    assert!(
        hours >= 20.0 && tests >= 350_000,
        "{hours} h, {tests} tests"
    );
}
