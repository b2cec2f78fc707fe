//! Integrity of the aids that are not autonomous (GNSS, issue 29): each of
//! their samples is tested against what the INS and the autonomous aids
//! (SRS, CNS, baro, star tracker) say without them, before the navigator
//! may fuse it.
//!
//! **Why a second filter, and this test.** A spoofer that drags the
//! position slowly, with a velocity consistent with it, passes every χ²
//! gate of a filter that GNSS dominates: that filter follows it, and then
//! rejects the CNS fixes that disagree. What the spoofer cannot move is a
//! solution that never saw GNSS. So the session keeps a *reference*
//! navigator, fed the same IMU samples and autonomous aids as the main one
//! and no GNSS, and tests each GNSS sample against it: the sample's
//! innovation ν with respect to the reference, at the sample's own time
//! and through the aid's own measurement model (lever arm included), has
//! the covariance S = H P_ref Hᵀ + R, and
//!
//! q = νᵀ S⁻¹ ν ~ χ²(m)
//!
//! when the sample and the reference are both right (m = 6 for GNSS). An
//! alarm is raised when q exceeds the χ²(m) quantile of the false-alarm
//! probability α of that test. The settings give the requirement as
//! integrity is judged, a rate per flight hour λ (default 1e-5 /h, the
//! strict end of RAIM's acceptable 1e-5 to 3e-4 /h), and each test spends
//! the share of it that the time since the previous test is of an hour:
//! α = λ·Δt/3600 s, Δt from the samples' stamps, held within
//! [[`MIN_TEST_INTERVAL_S`], [`MAX_TEST_INTERVAL_S`]] (the first test, and
//! the first after a time re-synchronization or a reinitialization, takes
//! the longest). The expected number of false alarms in a flight of T
//! hours is then Σα = λ·(T + 1 s) for fixes up to 1 kHz on increasing
//! stamps, however correlated the tests are (linearity of expectation; the
//! union bound makes it a bound on the probability of any alarm too): a
//! 10 Hz receiver gets the same rate per hour as a 1 Hz one, at a higher
//! threshold per fix (at 5 Hz, α = 5.6e-10, T = 54.6 for m = 6). A gap in
//! the fixes is not banked: a test after an outage spends at most a
//! second's share; a repeated or backward stamp is charged a millisecond.
//! (A probability per test does not say what integrity is judged by: the
//! former default, 1e-7 per fix, was 0.0018 /h at 5 Hz; 1 556 clean
//! flight hours of `integrity-clean` expected 2.8 false exclusions of it,
//! and saw 4.) The former setting `integrity_false_alarm`, a probability
//! per test, is still read, so that a log recorded with it replays as it
//! flew: when given it is used as it is, and the rate is not. The test is
//! a snapshot one on purpose: the reference's error and the receiver's
//! correlated error change slowly, so a window of q's is not χ²(m·N) and its
//! threshold would be a guess, while one sample's q is exact. A drag at a
//! m/s² shows in velocity first: with the reference's velocity σ of a few
//! cm/s and the receiver's of a decimetre, q reaches the alarm when a·t is
//! about 7σ of the velocity difference, that is after t ≈ 70 s at
//! 0.01 m/s² (½ a t² ≈ 25 m of drag) and at the first sample at 10 m/s².
//!
//! **What an alarm does.** The aid is excluded: the main navigator takes
//! the reference's state and covariance (a reset of the solution, flagged
//! and published as one, whose step removes what the spoofer had dragged),
//! and the aid's samples are counted as `rejected_integrity` and not fused.
//! While excluded, each sample goes on being tested against the
//! reference, which keeps running and never takes the aid; the aid is
//! readmitted once its samples have agreed (q below the threshold)
//! continuously for `readmit_after_s` of sensor time, and from then the
//! main navigator fuses it again while the reference goes on without it.
//! Everything is decided on the samples' stamps, so live equals `batch`.
//!
//! **When the test cannot judge.** The test can only tell a spoofed
//! position from the reference's own error while that error is small. Its
//! measure is a protection level, as in RAIM: the smallest horizontal
//! position offset that the test detects with probability at least
//! 1 − [`P_MISSED_DETECTION`] whatever its direction and whatever offsets
//! come with it in the other components (a spoofer chooses the velocity
//! too). With the other components free, the smallest non-centrality an
//! offset δ in the horizontal position can have is δᵀ S_hh⁻¹ δ (S_hh the
//! horizontal position block of S itself: the other components set to
//! their regression on δ), at least |δ|²/λ_max(S_hh); q ≥ (|δ|/σ_h + n)²
//! for a standard normal n, so q passes the threshold T with probability
//! at least 1 − p_md once |δ| ≥ (√T + K_md)·σ_h, σ_h² = λ_max(S_hh), K_md
//! the normal quantile of 1 − p_md: that |δ| is the level. Two levels are
//! formed, each against the alert limit from the settings (default 0.1 NM,
//! 185.2 m, the smallest required navigation performance aviation flies,
//! RNP AR 0.1; the level grows with √T, so a stricter false-alarm rate
//! needs a wider limit for the same availability: on the spoofed flights
//! of `tests/gnss.rs` the reference's level reaches 106 m at 1e-5 /h,
//! 98 m at the former 1e-7 per fix):
//! - **the reference's** (S = H P_ref Hᵀ, the receiver's R left out):
//!   beyond the limit the test is *unavailable* — the reference cannot
//!   judge any fix (regained within 90 % of the limit, so that a level
//!   hovering at it does not flap). q is still computed and reported, but
//!   nothing is decided on it: a fix is fused untested (the solution flag
//!   and the status say so, one log line each time the test is lost or
//!   regained), and an excluded aid stays excluded, its agreement time
//!   starting again. This is the case of an INS without a horizontal
//!   autonomous aid: a MEMS INS with only a barometer and a magnetometer is
//!   kilometres off within minutes, its error no longer small enough for
//!   the linear filter's covariance to describe (mems-aircraft, seed 3,
//!   with the test acting: q rose from 3 to 55 over the first two
//!   minutes, mean χ²(6) being 6, and a false alarm at 85 s made the
//!   solution jump 976 m to the reference). On such an aircraft an
//!   exclusion in those first seconds would be for the rest of the flight:
//!   the test never comes back to readmit the aid.
//! - **the fix's** (S = H P_ref Hᵀ + R, as the test uses it): beyond the
//!   limit while the reference's is within it, the fix's own claimed
//!   accuracy makes it unverifiable, and it is *refused* (counted
//!   `rejected_integrity`): a spoofer claiming a large σ can neither hide
//!   in the test nor switch it off, and a jammed receiver's growing
//!   accuracy estimates hand over to the autonomous aids before its fix is
//!   lost.

use serde::{Deserialize, Serialize};

use crate::bounds::{Bound, SettingsError};

/// The integrity test of a non-autonomous aid (in the aid's own settings).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IntegritySettings {
    /// Test the aid against the autonomous solution (off: the aid is fused
    /// whenever its own gate passes it, as in PX4 or ArduPilot).
    pub integrity: bool,
    /// The false-alarm rate the test is allowed, per flight hour: each
    /// test's probability is its share of it ([`Self::false_alarm`]).
    pub integrity_false_alarm_per_hour: f64,
    /// The former setting, a false-alarm probability per test: when given
    /// (a log recorded before the rate per hour replays as it flew), each
    /// test has it, and the rate per hour is not used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrity_false_alarm: Option<f64>,
    /// The test is available while its horizontal protection level from
    /// the reference's covariance is within this alert limit (m); a fix
    /// whose own claimed accuracy puts the level beyond it is refused.
    pub integrity_alert_limit_m: f64,
    /// An excluded aid is readmitted after its samples have agreed with the
    /// autonomous solution continuously for this long (s).
    pub readmit_after_s: f64,
}

impl Default for IntegritySettings {
    fn default() -> Self {
        Self {
            integrity: true,
            integrity_false_alarm_per_hour: 1e-5,
            integrity_false_alarm: None,
            integrity_alert_limit_m: 185.2,
            readmit_after_s: 60.0,
        }
    }
}

impl IntegritySettings {
    pub fn validate(&self, origin: &str, table: &str) -> Result<(), SettingsError> {
        Bound {
            lo: 1e-8,
            hi: 10.0,
            unit: "/h",
            below: "below 1e-8 per hour a test's probability at 1 kHz nears the range's end the χ² \
                    tail is computed to (1e-15), and the protection level grows without a gain \
                    that any requirement asks for",
            above: "above 10 false alarms per hour the aid would be excluded every few minutes by chance",
        }
        .check(
            origin,
            &format!("{table}.integrity_false_alarm_per_hour"),
            self.integrity_false_alarm_per_hour,
        )?;
        if let Some(per_test) = self.integrity_false_alarm {
            Bound {
                lo: 1e-15,
                hi: 0.01,
                unit: "",
                below: "below 1e-15 the threshold leaves the range the χ² tail is computed in",
                above: "above 1 % per sample the aid would be excluded every few seconds by chance",
            }
            .check(origin, &format!("{table}.integrity_false_alarm"), per_test)?;
        }
        Bound {
            lo: 1.0,
            hi: 1e7,
            unit: "m",
            below: "an alert limit under a metre is within a GNSS fix's own error: the test would never be available",
            above: "beyond ten thousand kilometres every error is within it: the test would always be available, whatever the reference's error",
        }
        .check(
            origin,
            &format!("{table}.integrity_alert_limit_m"),
            self.integrity_alert_limit_m,
        )?;
        Bound {
            lo: 1.0,
            hi: crate::bounds::MAX_FLIGHT_S,
            unit: "s",
            below: "an aid must agree for at least a second before it is trusted again",
            above: "longer than any flight: an excluded aid would never come back",
        }
        .check(
            origin,
            &format!("{table}.readmit_after_s"),
            self.readmit_after_s,
        )
    }

    /// The false-alarm probability of a test `interval_s` after the
    /// previous one (None: the first): α = λ·Δt/3600 s, Δt held within
    /// [[`MIN_TEST_INTERVAL_S`], [`MAX_TEST_INTERVAL_S`]] (a NaN interval
    /// is the longest).
    pub fn false_alarm(&self, interval_s: Option<f64>) -> f64 {
        if let Some(per_test) = self.integrity_false_alarm {
            return per_test;
        }
        let dt = interval_s
            .filter(|d| !d.is_nan())
            .map_or(MAX_TEST_INTERVAL_S, |d| {
                d.clamp(MIN_TEST_INTERVAL_S, MAX_TEST_INTERVAL_S)
            });
        self.integrity_false_alarm_per_hour * dt / 3600.0
    }

    /// The alarm threshold on q for an innovation of `dof` components,
    /// tested `interval_s` after the previous test ([`Self::false_alarm`]).
    pub fn threshold(&self, dof: usize, interval_s: Option<f64>) -> f64 {
        crate::chi2::quantile_upper(self.false_alarm(interval_s), dof as f64)
    }
}

/// The shortest interval a test is charged for (s): a flood of samples
/// closer than this spends no less of the rate each.
pub const MIN_TEST_INTERVAL_S: f64 = 1e-3;
/// The longest interval a test is charged for (s): the budget of a gap in
/// the samples is not banked for the test after it.
pub const MAX_TEST_INTERVAL_S: f64 = 1.0;

/// The protection level (m) of a test of threshold `threshold` whose
/// innovation covariance has the horizontal position block
/// `[[a, b], [b, c]]` (m²): (√T + K_md)·√λ_max (see the module's
/// documentation). Infinite (so beyond any limit) when the block is not
/// finite or not positive semi-definite.
pub fn protection_level(threshold: f64, a: f64, b: f64, c: f64) -> f64 {
    let finite = a.is_finite() && b.is_finite() && c.is_finite();
    // Positive semi-definite, to the rounding of a product.
    let psd = a >= 0.0 && c >= 0.0 && a * c - b * b >= -1e-12 * (a * c).abs();
    if !(finite && psd) {
        return f64::INFINITY;
    }
    let lambda_max = 0.5 * (a + c) + (0.5 * (a - c)).hypot(b);
    (threshold.sqrt() + K_MISSED_DETECTION) * lambda_max.sqrt()
}

/// Probability that the test misses a horizontal offset of its protection
/// level (the RAIM convention, 10⁻³).
pub const P_MISSED_DETECTION: f64 = 1e-3;
/// Its normal quantile: K with P(N(0, 1) < −K) = [`P_MISSED_DETECTION`].
pub const K_MISSED_DETECTION: f64 = 3.090_232_306_167_813_5;

/// Why an aid was excluded ([`Monitor::cause`], `AidStatus::exclusion_cause`).
pub mod cause {
    /// Not excluded.
    pub const NONE: u8 = 0;
    /// Its position disagrees with the autonomous solution (the position
    /// components' own q is the larger share).
    pub const POSITION: u8 = 1;
    /// Its velocity disagrees.
    pub const VELOCITY: u8 = 2;
    /// Its other components disagree (an aid of one kind of component).
    pub const MEASUREMENT: u8 = 3;

    /// What the cause means, for logs.
    pub fn text(c: u8) -> &'static str {
        match c {
            POSITION => "position inconsistent with the autonomous solution",
            VELOCITY => "velocity inconsistent with the autonomous solution",
            MEASUREMENT => "measurement inconsistent with the autonomous solution",
            _ => "none",
        }
    }
}

/// One test of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Test {
    /// νᵀ S⁻¹ ν.
    pub q: f64,
    /// Its alarm threshold.
    pub threshold: f64,
    /// The cause an alarm would have (the block of components with the
    /// larger share of q, each against its own χ² quantile).
    pub cause: u8,
    /// The test's horizontal protection level (m) with the fix's R, the
    /// reference's alone (R left out), and the alert limit both are held
    /// to (see the module's documentation).
    pub protection_m: f64,
    pub reference_protection_m: f64,
    pub alert_limit_m: f64,
}

impl Test {
    /// q over the threshold: above 1 is an alarm.
    pub fn ratio(&self) -> f64 {
        self.q / self.threshold
    }

    pub fn alarm(&self) -> bool {
        self.q.is_nan() || self.q > self.threshold
    }

    /// The reference can judge: its protection level is within the alert
    /// limit (a NaN one is not).
    pub fn available(&self) -> bool {
        self.reference_protection_m <= self.alert_limit_m
    }

    /// This fix can be judged: the level with its own R is within the
    /// limit too.
    pub fn verifiable(&self) -> bool {
        self.protection_m <= self.alert_limit_m
    }
}

/// A lost test is regained once the protection level is back within this
/// share of the alert limit.
pub const REGAIN: f64 = 0.9;

/// What to do with a tested sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The aid is trusted: offer the sample to the navigator.
    Admit,
    /// An alarm: exclude the aid now (the main navigator takes the
    /// reference's state) and refuse the sample.
    Exclude,
    /// The aid stays excluded: refuse the sample.
    Refuse,
    /// The aid has agreed long enough: readmit it and offer the sample.
    Readmit,
    /// The test is unavailable (the reference's protection level is
    /// beyond the alert limit) and the aid is not excluded: offer the
    /// sample untested.
    Untested,
    /// The reference could judge, but not this fix: its own claimed
    /// accuracy puts the level beyond the limit. Refuse the sample; the
    /// aid is not excluded.
    Unverifiable,
}

/// One non-autonomous aid's integrity state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Monitor {
    pub excluded: bool,
    /// Since when the aid is excluded (ns; 0 when it is not).
    pub excluded_since_ns: u64,
    /// Since when its samples agree while it is excluded.
    agreeing_since_ns: Option<u64>,
    /// The cause of the current or last exclusion.
    pub cause: u8,
    /// q over the threshold of the last test (NaN before any).
    pub last_ratio: Option<f64>,
    /// Exclusions so far.
    pub exclusions: u64,
    /// Whether the last test could judge (None before any).
    pub available: Option<bool>,
    /// Stamp of the last test that agreed while the aid is excluded.
    last_agreeing_ns: u64,
    /// Stamp of the newest test (None before any): the next test's
    /// interval, whose share of the rate it spends.
    last_test_ns: Option<u64>,
    /// The last threshold formed, by its probability's bits and its
    /// degrees of freedom: at a steady fix rate every test has the same.
    threshold_memo: Option<(u64, usize, f64)>,
}

impl Monitor {
    /// The sample clock starts again (a time re-synchronization, a
    /// reinitialization): the next test is charged as a first one, and an
    /// excluded aid's agreement starts again (a time on the old base says
    /// nothing of how long it has agreed on the new one).
    pub fn restart_clock(&mut self) {
        self.last_test_ns = None;
        self.agreeing_since_ns = None;
        self.last_agreeing_ns = 0;
    }

    /// The alarm threshold of a test of a sample stamped `t_ns` with `dof`
    /// components: its probability is the share of the rate that the time
    /// since the previous test is of an hour
    /// ([`IntegritySettings::false_alarm`]). The χ² quantile is formed
    /// only when the probability changes.
    pub fn threshold(&mut self, t_ns: u64, settings: &IntegritySettings, dof: usize) -> f64 {
        let interval_s = self
            .last_test_ns
            .map(|last| t_ns.saturating_sub(last) as f64 * 1e-9);
        let alpha = settings.false_alarm(interval_s);
        match self.threshold_memo {
            Some((bits, d, t)) if bits == alpha.to_bits() && d == dof => t,
            _ => {
                let t = crate::chi2::quantile_upper(alpha, dof as f64);
                self.threshold_memo = Some((alpha.to_bits(), dof, t));
                t
            }
        }
    }

    /// A sample of the aid could not be tested (its content refused, its
    /// stamp beyond the state history, or its S not positive definite):
    /// an excluded aid's agreement starts again.
    pub fn untestable(&mut self) {
        self.agreeing_since_ns = None;
    }

    /// Decides on a sample stamped `t_ns` that was tested (`test`), the
    /// readmission time being `readmit_ns`. An excluded aid's agreement
    /// must be continuous: a gap of more than `max_gap_ns` between two
    /// agreeing samples (the aid's timeout: an outage) starts it again.
    pub fn decide(&mut self, t_ns: u64, test: &Test, readmit_ns: u64, max_gap_ns: u64) -> Verdict {
        self.last_ratio = Some(test.ratio());
        self.last_test_ns = Some(self.last_test_ns.map_or(t_ns, |last| last.max(t_ns)));
        // Lost beyond the alert limit, regained within REGAIN of it: a
        // protection level hovering at the limit (it grows between the
        // autonomous aids' updates and drops at each) does not flap.
        let available = if self.available == Some(false) {
            test.reference_protection_m <= REGAIN * test.alert_limit_m
        } else {
            test.available()
        };
        self.available = Some(available);
        if !available {
            // Nothing is judged: an excluded aid stays excluded and must
            // agree for the whole readmission time once the test is back.
            self.agreeing_since_ns = None;
            return if self.excluded {
                Verdict::Refuse
            } else {
                Verdict::Untested
            };
        }
        if !test.verifiable() {
            // This fix cannot be judged: refused, and an excluded aid's
            // agreement starts again.
            self.agreeing_since_ns = None;
            return if self.excluded {
                Verdict::Refuse
            } else {
                Verdict::Unverifiable
            };
        }
        if !self.excluded {
            if test.alarm() {
                self.excluded = true;
                self.excluded_since_ns = t_ns;
                self.agreeing_since_ns = None;
                self.cause = test.cause;
                self.exclusions += 1;
                return Verdict::Exclude;
            }
            return Verdict::Admit;
        }
        if test.alarm() {
            self.agreeing_since_ns = None;
            return Verdict::Refuse;
        }
        if t_ns.saturating_sub(self.last_agreeing_ns) > max_gap_ns {
            self.agreeing_since_ns = None;
        }
        self.last_agreeing_ns = t_ns;
        let since = *self.agreeing_since_ns.get_or_insert(t_ns);
        if t_ns.saturating_sub(since) >= readmit_ns {
            self.excluded = false;
            self.excluded_since_ns = 0;
            self.agreeing_since_ns = None;
            return Verdict::Readmit;
        }
        Verdict::Refuse
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform draws in [0, 1) from a 64-bit LCG seeded with `seed`.
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn test(q: f64) -> Test {
        Test {
            q,
            threshold: 10.0,
            cause: cause::VELOCITY,
            protection_m: 45.0,
            reference_protection_m: 40.0,
            alert_limit_m: 100.0,
        }
    }

    /// The reference's level beyond the limit (so the fix's too).
    fn unavailable(q: f64) -> Test {
        Test {
            protection_m: 101.0,
            reference_protection_m: 100.5,
            ..test(q)
        }
    }

    /// An unavailable test judges nothing: no alarm however large q, the
    /// sample offered untested; an excluded aid stays excluded, and its
    /// readmission time starts again once the test is back. A NaN
    /// protection level is unavailable.
    #[test]
    fn an_unavailable_test_neither_excludes_nor_readmits() {
        let s = 1_000_000_000u64;
        let mut m = Monitor::default();
        assert_eq!(m.available, None);
        assert_eq!(
            m.decide(s, &unavailable(1e9), 60 * s, u64::MAX),
            Verdict::Untested
        );
        assert_eq!(
            (m.excluded, m.exclusions, m.available),
            (false, 0, Some(false))
        );
        assert_eq!(
            m.decide(2 * s, &test(3.0), 60 * s, u64::MAX),
            Verdict::Admit
        );
        assert_eq!(m.available, Some(true));
        assert_eq!(
            m.decide(3 * s, &test(11.0), 60 * s, u64::MAX),
            Verdict::Exclude
        );
        // Agreeing for 50 s, then the test is lost for a sample: the
        // agreement starts again when it is back.
        assert_eq!(
            m.decide(4 * s, &test(1.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(54 * s, &test(1.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(55 * s, &unavailable(1.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(64 * s, &test(1.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(123 * s, &test(1.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(124 * s, &test(1.0), 60 * s, u64::MAX),
            Verdict::Readmit
        );
        let nan = Test {
            reference_protection_m: f64::NAN,
            ..test(1.0)
        };
        assert!(!nan.available() && test(1.0).available() && !unavailable(1.0).available());
        assert_eq!(m.decide(125 * s, &nan, 60 * s, u64::MAX), Verdict::Untested);
        // Regained only within 90 % of the limit: 95 m stays lost, 90 m
        // is back; then lost again only beyond the limit.
        let at = |p: f64| Test {
            reference_protection_m: p,
            protection_m: p,
            ..test(1.0)
        };
        assert_eq!(
            m.decide(126 * s, &at(95.0), 60 * s, u64::MAX),
            Verdict::Untested
        );
        assert_eq!(
            m.decide(127 * s, &at(90.0), 60 * s, u64::MAX),
            Verdict::Admit
        );
        assert_eq!(
            m.decide(128 * s, &at(99.9), 60 * s, u64::MAX),
            Verdict::Admit
        );
        assert_eq!(
            m.decide(129 * s, &at(100.1), 60 * s, u64::MAX),
            Verdict::Untested
        );
        assert_eq!(m.available, Some(false));
    }

    /// The protection level against independent computations: K_md
    /// against the normal quantile; λ_max by nalgebra's symmetric
    /// eigen-decomposition (the closed form must agree whatever the axes);
    /// and a Monte Carlo run of the χ²(6) test itself on random S: the
    /// worst offset of the level's size — along S_hh's widest axis, the
    /// other five components at their regression on it, as a spoofer would
    /// choose them to hide — is detected at least 1 − p_md of the time,
    /// one of 0.8 times the level clearly less often; that offset's
    /// non-centrality is |δ_h|²/λ_max(S_hh), below that of the same
    /// offset with the other components left alone. Non-finite and
    /// indefinite blocks are infinite.
    #[test]
    fn the_protection_level_is_the_offset_the_test_detects() {
        use nalgebra::{SMatrix, SVector};
        let s = IntegritySettings::default();
        assert!(
            (crate::chi2::normal_quantile(1.0 - P_MISSED_DETECTION) - K_MISSED_DETECTION).abs()
                < 1e-9
        );
        let mut u = uniform(3);
        for _ in 0..200 {
            let (l1, l2) = (10f64.powf(u() * 8.0 - 2.0), 10f64.powf(u() * 8.0 - 2.0));
            let th = u() * std::f64::consts::TAU;
            let r = nalgebra::Matrix2::new(th.cos(), -th.sin(), th.sin(), th.cos());
            let c = r * nalgebra::Matrix2::new(l1, 0.0, 0.0, l2) * r.transpose();
            let t5 = s.threshold(6, Some(0.2));
            let got = protection_level(t5, c[(0, 0)], c[(0, 1)], c[(1, 1)]);
            let max = c.symmetric_eigen().eigenvalues.max();
            let want = (t5.sqrt() + K_MISSED_DETECTION) * max.sqrt();
            assert!((got / want - 1.0).abs() < 1e-9, "{got} {want}");
        }
        for bad in [
            [f64::NAN, 0.0, 1.0],
            [1.0, f64::NAN, 1.0],
            [f64::INFINITY, 0.0, 1.0],
            [-1.0, 0.0, -1.0],
            [4.0, 0.0, -4e4],
            [1.0, 2.0, 1.0],
        ] {
            let p = protection_level(s.threshold(6, None), bad[0], bad[1], bad[2]);
            assert!(p.is_infinite(), "{bad:?}: {p}");
        }
        let mut gauss = || {
            let (a, b) = (u().max(1e-300), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        // 1e-3 per test: 3.6 /h, tested every second.
        let loose = IntegritySettings {
            integrity_false_alarm_per_hour: 3.6,
            ..s
        };
        let t = loose.threshold(6, Some(1.0));
        for case in 0..4 {
            let a = SMatrix::<f64, 6, 6>::from_fn(|_, _| gauss());
            let sm = a * a.transpose() + SMatrix::<f64, 6, 6>::identity() * (0.1 + case as f64);
            let hh = sm.fixed_view::<2, 2>(0, 0).into_owned();
            let level = protection_level(t, hh[(0, 0)], hh[(0, 1)], hh[(1, 1)]);
            let e = hh.symmetric_eigen();
            let dir = e.eigenvectors.column(e.eigenvalues.imax()).into_owned();
            let hh_inv = hh.try_inverse().expect("S_hh");
            let sinv = sm.try_inverse().expect("S");
            let chol = sm.cholesky().expect("S").l();
            let offset = |scale: f64, hide: bool| -> SVector<f64, 6> {
                let dh = dir * (level * scale);
                if hide {
                    // The hiding offset: d = S[:, h] S_hh⁻¹ δ_h.
                    sm.fixed_view::<6, 2>(0, 0) * (hh_inv * dh)
                } else {
                    SVector::<f64, 6>::from_fn(|i, _| if i < 2 { dh[i] } else { 0.0 })
                }
            };
            // The hiding offset has the smallest non-centrality of all
            // offsets with this horizontal part: |δ_h|²/λ_max(S_hh).
            let nc = |d: &SVector<f64, 6>| d.dot(&(sinv * d));
            let (hidden, plain) = (nc(&offset(1.0, true)), nc(&offset(1.0, false)));
            let expected = (level / hh.symmetric_eigen().eigenvalues.max().sqrt()).powi(2);
            assert!(
                (hidden / expected - 1.0).abs() < 1e-9,
                "{hidden} {expected}"
            );
            assert!(plain >= hidden, "case {case}: {plain} < {hidden}");
            let mut rate = |scale: f64| {
                let d = offset(scale, true);
                let n = 100_000;
                let hits = (0..n)
                    .filter(|_| {
                        let w = SVector::<f64, 6>::from_fn(|_, _| gauss());
                        let z = d + chol * w;
                        z.dot(&(sinv * z)) > t
                    })
                    .count();
                hits as f64 / n as f64
            };
            let (at, below) = (rate(1.0), rate(0.8));
            // 1 − 1e-3 less 4.5 binomial σ over 100 000 draws.
            assert!(at >= 0.9985, "case {case}: detected {at} at the level");
            assert!(below < 0.99, "case {case}: detected {below} at 0.8 of it");
        }
    }

    /// An alarm excludes at once; readmission needs continuous agreement
    /// for the whole time, and a new alarm restarts it.
    #[test]
    fn exclusion_and_readmission_follow_the_stamps() {
        let s = 1_000_000_000u64;
        let mut m = Monitor::default();
        assert_eq!(m.decide(s, &test(3.0), 60 * s, u64::MAX), Verdict::Admit);
        assert_eq!(
            m.decide(2 * s, &test(11.0), 60 * s, u64::MAX),
            Verdict::Exclude
        );
        assert_eq!(
            (m.excluded, m.cause, m.exclusions),
            (true, cause::VELOCITY, 1)
        );
        assert_eq!(
            m.decide(3 * s, &test(1.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(40 * s, &test(1.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        // A disagreement restarts the time.
        assert_eq!(
            m.decide(50 * s, &test(f64::NAN), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(60 * s, &test(2.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(119 * s, &test(2.0), 60 * s, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(120 * s, &test(2.0), 60 * s, u64::MAX),
            Verdict::Readmit
        );
        assert!(!m.excluded);
        assert_eq!(
            m.decide(121 * s, &test(2.0), 60 * s, u64::MAX),
            Verdict::Admit
        );
        assert!((m.last_ratio.unwrap() - 0.2).abs() < 1e-15);
    }

    /// Agreement must be continuous: an outage longer than the aid's
    /// timeout (here 3 s) or a sample that could not be tested starts the
    /// readmission time again, so an aid is never readmitted on agreement
    /// it was not seen to keep.
    #[test]
    fn an_outage_or_an_untestable_sample_restarts_the_agreement() {
        let s = 1_000_000_000u64;
        let mut m = Monitor::default();
        let decide = |m: &mut Monitor, t: u64, q: f64| m.decide(t * s, &test(q), 60 * s, 3 * s);
        assert_eq!(decide(&mut m, 1, 11.0), Verdict::Exclude);
        assert_eq!(decide(&mut m, 4, 1.0), Verdict::Refuse);
        // Out from 4 s to 64 s: no readmission on the first sample back.
        assert_eq!(decide(&mut m, 64, 1.0), Verdict::Refuse);
        for t in 65..100 {
            assert_eq!(decide(&mut m, t, 1.0), Verdict::Refuse, "{t} s");
        }
        // A second monitor, whose sample at 100 s could not be tested:
        // its agreement starts again at 101 s.
        let mut n = m;
        assert_eq!(decide(&mut m, 100, 1.0), Verdict::Refuse);
        n.untestable();
        for t in 101..124 {
            assert_eq!(decide(&mut m, t, 1.0), Verdict::Refuse, "{t} s");
            assert_eq!(decide(&mut n, t, 1.0), Verdict::Refuse, "{t} s");
        }
        assert_eq!(decide(&mut m, 124, 1.0), Verdict::Readmit);
        for t in 124..161 {
            assert_eq!(decide(&mut n, t, 1.0), Verdict::Refuse, "{t} s");
        }
        assert_eq!(decide(&mut n, 161, 1.0), Verdict::Readmit);
    }

    /// A fix whose own claimed accuracy puts the level beyond the limit
    /// while the reference's is within it is refused, however small its
    /// q: it neither excludes the aid nor counts as agreement; an excluded
    /// aid's agreement starts again.
    #[test]
    fn a_fix_its_own_accuracy_makes_unverifiable_is_refused() {
        let s = 1_000_000_000u64;
        let wide = |q: f64| Test {
            protection_m: 480.0,
            ..test(q)
        };
        assert!(wide(1.0).available() && !wide(1.0).verifiable());
        let mut m = Monitor::default();
        let decide = |m: &mut Monitor, t: u64, x: &Test| m.decide(t * s, x, 60 * s, u64::MAX);
        assert_eq!(decide(&mut m, 1, &wide(1e9)), Verdict::Unverifiable);
        assert_eq!((m.excluded, m.available), (false, Some(true)));
        assert_eq!(decide(&mut m, 2, &test(11.0)), Verdict::Exclude);
        assert_eq!(decide(&mut m, 3, &test(1.0)), Verdict::Refuse);
        assert_eq!(decide(&mut m, 50, &wide(1.0)), Verdict::Refuse);
        assert_eq!(decide(&mut m, 62, &test(1.0)), Verdict::Refuse);
        assert_eq!(decide(&mut m, 110, &test(1.0)), Verdict::Refuse);
        assert_eq!(decide(&mut m, 122, &test(1.0)), Verdict::Readmit);
    }

    #[test]
    fn a_nan_statistic_is_an_alarm() {
        assert!(test(f64::NAN).alarm() && test(f64::INFINITY).alarm() && !test(10.0).alarm());
    }

    /// Against the closed form of χ²(6)'s tail, Q = e^(−x/2) (1 + x/2 +
    /// x²/8), and the 99.9 % table value of χ²(3): the default (1e-5 /h)
    /// at 5 Hz is α = 5.56e-10 per fix; 3.6e-4 /h tested every second is
    /// the former 1e-7 per fix (T = 43.3378).
    #[test]
    fn thresholds_are_the_chi2_quantiles_of_the_false_alarm_probability() {
        let s = IntegritySettings::default();
        let alpha = 1e-5 * 0.2 / 3600.0;
        assert!((s.false_alarm(Some(0.2)) / alpha - 1.0).abs() < 1e-15);
        let x = s.threshold(6, Some(0.2));
        let tail = (-x / 2.0).exp() * (1.0 + x / 2.0 + x * x / 8.0);
        assert!((tail / alpha - 1.0).abs() < 1e-6, "χ²(6) {x}: tail {tail}");
        let former = IntegritySettings {
            integrity_false_alarm_per_hour: 3.6e-4,
            ..s
        };
        let x = former.threshold(6, Some(1.0));
        assert!((x - 43.3378).abs() < 1e-3, "{x}");
        let t = IntegritySettings {
            integrity_false_alarm_per_hour: 3.6,
            ..s
        };
        assert!(
            (t.threshold(3, Some(1.0)) - 16.266).abs() < 1e-3,
            "{}",
            t.threshold(3, Some(1.0))
        );
    }

    /// The rate per hour is the rate per hour whatever the fix rate: the
    /// probabilities a monitor spends over an hour of stamps sum to λ at
    /// 1, 5, 10 and 100 Hz and on jittered stamps (to rounding); a 0.5 Hz
    /// aid spends half of it (a gap is not banked), a 2 kHz flood no more
    /// than 1 kHz's share each; the first test is charged a second.
    #[test]
    #[allow(clippy::float_cmp)] // the clamped intervals give the same product, to the bit
    fn each_test_spends_its_share_of_the_rate_per_hour() {
        let s = IntegritySettings::default();
        let spent = |stamps: &[u64]| {
            let mut last: Option<u64> = None;
            let mut sum = 0.0;
            for &t in stamps {
                sum += s.false_alarm(last.map(|l| (t - l) as f64 * 1e-9));
                last = Some(t);
            }
            sum
        };
        let hour = |hz: u64| -> Vec<u64> {
            // From a test one period before the hour, so that the hour's
            // first test is charged one period.
            (0..=3600 * hz).map(|i| i * 1_000_000_000 / hz).collect()
        };
        for hz in [1u64, 5, 10, 100] {
            let sum = spent(&hour(hz)) - s.false_alarm(None);
            assert!((sum / 1e-5 - 1.0).abs() < 1e-9, "{hz} Hz: {sum}");
        }
        let mut seed = 7u64;
        let jittered: Vec<u64> = (0..=18_000u64)
            .map(|i| {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
                i * 200_000_000 + if i == 0 || i == 18_000 { 0 } else { seed >> 44 }
            })
            .collect();
        let sum = spent(&jittered) - s.false_alarm(None);
        assert!((sum / 1e-5 - 1.0).abs() < 1e-9, "jittered: {sum}");
        let sum = spent(&(0..=1800u64).map(|i| i * 2_000_000_000).collect::<Vec<_>>())
            - s.false_alarm(None);
        assert!((sum / 0.5e-5 - 1.0).abs() < 1e-9, "0.5 Hz: {sum}");
        assert_eq!(s.false_alarm(Some(5e-4)), s.false_alarm(Some(1e-3)));
        assert_eq!(s.false_alarm(None), 1e-5 / 3600.0);
        assert_eq!(s.false_alarm(Some(f64::NAN)), s.false_alarm(None));
        assert_eq!(s.false_alarm(Some(1e6)), s.false_alarm(None));
    }

    /// Monte Carlo of the whole chain: 10 hours of 5 Hz tests of χ²(6)
    /// statistics drawn from six normals (not from the χ² module), each
    /// against the threshold its monitor forms from the stamps, at
    /// λ = 10 /h: the alarms counted are 100 ± 4.5 Poisson σ.
    #[test]
    fn a_monte_carlo_flight_alarms_at_the_rate_per_hour() {
        let s = IntegritySettings {
            integrity_false_alarm_per_hour: 10.0,
            ..IntegritySettings::default()
        };
        let mut m = Monitor::default();
        let mut u = uniform(11);
        let mut alarms = 0;
        for i in 1..=10 * 3600 * 5u64 {
            let t_ns = i * 200_000_000;
            let threshold = m.threshold(t_ns, &s, 6);
            let q: f64 = (0..3)
                .map(|_| {
                    // Two normals (Box–Muller), squared.
                    let (r, b) = (
                        (-2.0 * u().max(1e-300).ln()).sqrt(),
                        std::f64::consts::TAU * u(),
                    );
                    (r * b.cos()).powi(2) + (r * b.sin()).powi(2)
                })
                .sum();
            let test = Test {
                threshold,
                ..test(q)
            };
            if test.alarm() {
                alarms += 1;
            }
            // Its stamps are what the next test is charged from; the
            // decision itself is not under test (an excluded aid would
            // stop counting alarms), so a fresh monitor keeps the clock.
            let last = m.last_test_ns;
            m.decide(t_ns, &test, u64::MAX, u64::MAX);
            assert_eq!(m.last_test_ns, Some(last.map_or(t_ns, |l| l.max(t_ns))));
            m.excluded = false;
        }
        let expected = 10.0 * 10.0;
        let sigma = f64::sqrt(expected);
        assert!(
            (alarms as f64 - expected).abs() < 4.5 * sigma,
            "{alarms} alarms in 10 h at 10 /h"
        );
    }

    /// The former setting, a probability per test, from a log recorded
    /// before the rate per hour: read, used as it is whatever the
    /// interval, held to its own bounds, and never written when not given.
    #[test]
    #[allow(clippy::float_cmp)] // the setting is returned as it is, to the bit
    fn the_former_probability_per_test_replays_as_it_flew() {
        let recorded: IntegritySettings =
            toml::from_str("integrity = true\nintegrity_false_alarm = 1e-7\n").expect("parsed");
        assert_eq!(recorded.integrity_false_alarm, Some(1e-7));
        for dt in [None, Some(1e-9), Some(0.2), Some(5.0)] {
            assert_eq!(recorded.false_alarm(dt), 1e-7);
        }
        assert!((recorded.threshold(6, Some(0.2)) - 43.3378).abs() < 1e-3);
        // GNSS's table of a recorded header, which refuses unknown keys.
        use crate::aids::OwnSettings;
        let gnss: crate::aids::gnss::GnssSettings =
            toml::from_str("integrity_false_alarm = 1e-7\n").expect("a recorded header");
        assert_eq!(
            gnss.integrity().map(|i| i.integrity_false_alarm),
            Some(Some(1e-7))
        );
        assert!(recorded.validate("log", "aids.gnss").is_ok());
        let e = IntegritySettings {
            integrity_false_alarm: Some(0.5),
            ..recorded
        }
        .validate("log", "aids.gnss")
        .expect_err("refused");
        assert!(
            e.to_string().contains("aids.gnss.integrity_false_alarm"),
            "{e}"
        );
        let written = toml::to_string(&IntegritySettings::default()).expect("written");
        assert!(
            written.contains("integrity_false_alarm_per_hour")
                && !written.contains("integrity_false_alarm ="),
            "{written}"
        );
        // A new clock (a resync, a reinitialization): the next test is
        // charged as a first one.
        let s = IntegritySettings::default();
        let mut m = Monitor::default();
        let first = m.threshold(5_000_000_000, &s, 6);
        m.decide(5_000_000_000, &test(1.0), u64::MAX, u64::MAX);
        let next = m.threshold(5_200_000_000, &s, 6);
        assert!(next > first, "{next} {first}");
        m.restart_clock();
        assert_eq!(m.threshold(1_000_000, &s, 6), first);
        // Excluded, agreeing for 50 s, then the clock goes back 100 s: the
        // agreement starts again on the new base (60 s more to readmit).
        let sec = 1_000_000_000u64;
        let mut m = Monitor::default();
        assert_eq!(
            m.decide(200 * sec, &test(11.0), 60 * sec, u64::MAX),
            Verdict::Exclude
        );
        for t in 201..=250 {
            assert_eq!(
                m.decide(t * sec, &test(1.0), 60 * sec, u64::MAX),
                Verdict::Refuse
            );
        }
        m.restart_clock();
        assert_eq!(
            m.decide(150 * sec, &test(1.0), 60 * sec, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(209 * sec, &test(1.0), 60 * sec, u64::MAX),
            Verdict::Refuse
        );
        assert_eq!(
            m.decide(210 * sec, &test(1.0), 60 * sec, u64::MAX),
            Verdict::Readmit
        );
    }

    /// Absurd stamps and rates: thresholds finite and positive from the
    /// bounds' ends over stamps of 0 to 1e18 ns, duplicates and stamps
    /// going back (charged the shortest interval), and the memo equal to
    /// the quantile it stands for.
    #[test]
    #[allow(clippy::float_cmp)] // the memo returns the quantile it stored, to the bit
    fn thresholds_stay_finite_over_absurd_stamps() {
        let mut u = uniform(5);
        for lambda in [1e-8, 1e-5, 3e-4, 10.0] {
            let s = IntegritySettings {
                integrity_false_alarm_per_hour: lambda,
                ..IntegritySettings::default()
            };
            assert!(s.validate("t", "g").is_ok());
            let mut m = Monitor::default();
            for _ in 0..300 {
                // Log-uniform over 1 ns to 1e18 ns, and the ends.
                let t_ns = match (u() * 10.0) as u32 {
                    0 => 0,
                    1 => 1_000_000_000_000_000_000,
                    2 => m.last_test_ns.unwrap_or(0),
                    _ => 10f64.powf(u() * 18.0) as u64,
                };
                let dof = 1 + (u() * 6.0) as usize;
                let interval = m.last_test_ns.map(|l| t_ns.saturating_sub(l) as f64 * 1e-9);
                let t = m.threshold(t_ns, &s, dof);
                assert!(t.is_finite() && t > 0.0, "λ {lambda} at {t_ns}: {t}");
                assert_eq!(t, s.threshold(dof, interval), "memo at {t_ns}");
                m.decide(
                    t_ns,
                    &Test {
                        threshold: t,
                        ..test(1.0)
                    },
                    u64::MAX,
                    u64::MAX,
                );
            }
        }
        for bad in [0.0, 1e-9, 11.0, f64::NAN, f64::INFINITY, -1.0] {
            let s = IntegritySettings {
                integrity_false_alarm_per_hour: bad,
                ..IntegritySettings::default()
            };
            let e = s.validate("nav.toml", "aids.gnss").expect_err("refused");
            assert!(
                e.to_string()
                    .contains("aids.gnss.integrity_false_alarm_per_hour")
                    && e.to_string().contains("nav.toml"),
                "{e}"
            );
        }
    }
}
