//! The session's decisions as log lines, for both drivers (`batch` and the
//! live loop), so that the same event reads the same in either log.

use std::time::{Duration, Instant};

use polarnav::integrity::Verdict;
use polarnav::session::{Event, InitSource};

/// A sensor time stamp in seconds, as the logs show times.
pub fn secs(t_ns: u64) -> f64 {
    t_ns as f64 * 1e-9
}

/// One log line for a session event (recurring ones are rate-limited by the caller).
pub fn log_event(log: &str, e: &Event) {
    match e {
        Event::Started {
            source: InitSource::Config,
            t_ns,
        } => tracing::info!(
            t_s = secs(*t_ns),
            "{log}: no init message or record: initializing from the configuration"
        ),
        Event::Started {
            source: InitSource::Checkpoint,
            t_ns,
        } => tracing::info!(
            checkpoint_t_s = secs(*t_ns),
            "{log}: resumed from checkpoint (no re-alignment); the gap to the first IMU sample is coasted"
        ),
        Event::Started {
            source: InitSource::Message,
            t_ns,
        } => tracing::info!(t_s = secs(*t_ns), "{log}: navigation started from the init"),
        Event::AlignmentStarted { t_ns, duration_s } => {
            tracing::info!(
                t_s = secs(*t_ns),
                duration_s,
                "{log}: stationary alignment started"
            )
        }
        Event::Aligned { alignment: a, .. } => tracing::info!(
            heading_deg = a.heading_rad.to_degrees(),
            pitch_deg = a.pitch_rad.to_degrees(),
            roll_deg = a.roll_rad.to_degrees(),
            sigma_tilt_arcmin = a.sigma_tilt_rad.to_degrees() * 60.0,
            sigma_heading_arcmin = a.sigma_heading_rad.to_degrees() * 60.0,
            time_s = a.time_s,
            "{log}: stationary alignment by {}",
            a.method
        ),
        Event::AlignmentFailed(err) => tracing::error!("{log}: alignment failed: {err}"),
        Event::Reinitialized { t_ns } => {
            tracing::info!(t_s = secs(*t_ns), "{log}: new init: re-initialized")
        }
        Event::InitHeld { t_ns, imu_t_ns } => tracing::info!(
            t_s = secs(*t_ns),
            imu_t_s = secs(*imu_t_ns),
            "{log}: init stamped ahead of the IMU: held until the IMU reaches it"
        ),
        Event::InitRejected { t_ns, seq, reason } => {
            tracing::error!(t_s = secs(*t_ns), seq, "{log}: init rejected: {reason}")
        }
        Event::InitSuperseded { t_ns } => {
            tracing::warn!(
                t_s = secs(*t_ns),
                "{log}: init not used (a newer one arrived, or the IMU never reached it)"
            )
        }
        Event::CheckpointNotUsed {
            checkpoint_t_ns,
            first_imu_t_ns,
            newer_init,
        } => tracing::warn!(
            checkpoint_t_s = secs(*checkpoint_t_ns),
            first_imu_t_s = secs(*first_imu_t_ns),
            newer_init,
            "{log}: checkpoint not used (the IMU does not continue from it, or a newer init wins): cold start"
        ),
        Event::Rejected {
            stream,
            t_ns,
            seq,
            reason,
        } => tracing::warn!(
            t_s = secs(*t_ns),
            seq,
            "{log}: {} sample rejected: {reason}",
            stream.name()
        ),
        Event::Switch(sw) => {
            tracing::info!(t_s = secs(sw.t_ns), from = ?sw.from, to = ?sw.to, lat_deg = sw.lat_rad.to_degrees(), count = sw.count, "{log}: frame switch")
        }
        Event::TimeResync { from_t_ns, to_t_ns } => tracing::warn!(
            from_t_s = secs(*from_t_ns),
            to_t_s = secs(*to_t_ns),
            "{log}: IMU time jump confirmed: re-synchronized (covariance grown as for the longest coast)"
        ),
        Event::SequenceGap {
            stream,
            expected,
            seq,
        } => tracing::warn!(
            expected,
            seq,
            "{log}: {} samples lost before they arrived",
            stream.name()
        ),
        Event::CovarianceRepaired { t_ns } => tracing::error!(
            t_s = secs(*t_ns),
            "{log}: covariance lost finiteness or positive variances: re-inflated"
        ),
        // One per gated aid sample: rejections are logged as `Rejected`
        // where the navigator refuses them; the gate's own verdicts are in
        // status, and each one on the MCAP `/aid/*` channels.
        Event::AidUpdate { .. } => {}
        // One per tested sample: only the decisions are logged; every
        // test is in status and on the MCAP `/integrity/*` channels.
        Event::Integrity {
            stream,
            t_ns,
            test,
            verdict: Verdict::Exclude,
            exclusions,
            step,
        } => {
            let norm = |d: &[f64; 3]| d.iter().map(|x| x * x).sum::<f64>().sqrt();
            tracing::error!(
                t_s = secs(*t_ns),
                q = test.q,
                threshold = test.threshold,
                exclusions,
                "{log}: {} excluded: {} (q {:.1} > {:.1}); the solution returns to the autonomous one (|Δr| {:.2} m, |Δv| {:.3} m/s)",
                stream.name(),
                polarnav::integrity::cause::text(test.cause),
                test.q,
                test.threshold,
                step.map_or(0.0, |r| norm(&r.delta_pos_e_m)),
                step.map_or(0.0, |r| norm(&r.delta_vel_e_mps)),
            )
        }
        Event::Integrity {
            stream,
            t_ns,
            verdict: Verdict::Readmit,
            ..
        } => tracing::info!(
            t_s = secs(*t_ns),
            "{log}: {} readmitted: its samples agreed with the autonomous solution for the readmission time",
            stream.name()
        ),
        Event::Integrity { .. } => {}
        Event::IntegrityAvailability {
            stream,
            t_ns,
            available: false,
            protection_m,
            alert_limit_m,
        } => tracing::warn!(
            t_s = secs(*t_ns),
            protection_m,
            alert_limit_m,
            "{log}: {} integrity test unavailable: its horizontal protection level from the reference's covariance, {:.0} m, is beyond the alert limit {:.0} m (the reference cannot tell a spoofed position from its own error); {} fixes are fused untested, or refused while it is excluded",
            stream.name(),
            protection_m,
            alert_limit_m,
            stream.name()
        ),
        Event::IntegrityAvailability {
            stream,
            t_ns,
            available: true,
            protection_m,
            alert_limit_m,
        } => tracing::info!(
            t_s = secs(*t_ns),
            protection_m,
            "{log}: {} integrity test available again: horizontal protection level {:.0} m within the alert limit {:.0} m",
            stream.name(),
            protection_m,
            alert_limit_m
        ),
        Event::AidReset {
            stream,
            reset,
            verdict,
            widened,
        } => {
            let norm = |d: &[f64; 3]| d.iter().map(|x| x * x).sum::<f64>().sqrt();
            tracing::warn!(
                t_ns = reset.t_ns,
                count = reset.count,
                "{log}: {} rejected for {:.1} s ({} samples) while consistent ({} fit's residual χ²/ν {:.2} ≤ {:.2}, step from last fused {}): reset to it, |Δr| {:.2} m, |Δv| {:.3} m/s, Δψ {:.4}°, covariance of the unobserved states ×{:.3e}{}",
                stream.name(),
                verdict.duration_s,
                verdict.samples,
                if verdict.degree == 3 { "cubic" } else { "quadratic" },
                verdict.consistency,
                verdict.consistency_bound,
                verdict.step.map_or("none (stale)".to_owned(), |s| format!(
                    "χ² {s:.2} ≤ {:.2}",
                    verdict.step_bound
                )),
                norm(&reset.delta_pos_e_m),
                norm(&reset.delta_vel_e_mps),
                reset.delta_heading_rad.to_degrees(),
                verdict.covariance_inflation.min(1e8),
                widened.map_or(String::new(), |b| format!(
                    "; bias process noise widened for the rest of the run to gyro {:.1} °/h, τ {:.0} s, accelerometer {:.0} µg, τ {:.0} s",
                    b.gyro_sigma.to_degrees() * 3600.0,
                    b.gyro_tau_s,
                    b.accel_sigma / (1e-6 * polarnav::earth::G0),
                    b.accel_tau_s
                ))
            )
        }
    }
}

/// At most one log line per second for a recurring event; counts the rest.
#[derive(Debug, Default)]
pub struct RateLimit {
    last: Option<Instant>,
    suppressed: u64,
}

impl RateLimit {
    /// `Some(suppressed since the last line)` when a line may be written now.
    pub fn due(&mut self) -> Option<u64> {
        if self
            .last
            .is_some_and(|t| t.elapsed() < Duration::from_secs(1))
        {
            self.suppressed += 1;
            return None;
        }
        self.last = Some(Instant::now());
        Some(std::mem::take(&mut self.suppressed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_limit_allows_one_line_per_second_and_counts_the_rest() {
        let mut r = RateLimit::default();
        assert_eq!(r.due(), Some(0));
        assert_eq!(r.due(), None);
        assert_eq!(r.due(), None);
        // A second later the next line reports the two suppressed.
        r.last = Some(Instant::now() - Duration::from_millis(1001));
        assert_eq!(r.due(), Some(2));
        assert_eq!(r.due(), None);
    }
}
