//! The decision to fuse, apart from the measurement models: χ² gate
//! thresholds, timeouts, counters and the status record every aid reports.

use msgs::aids::{MAX_CAUSES, MAX_COMPONENTS};
use msgs::{AidStatus, StreamCounters, WireFrame};

use crate::filter::UpdateOutcome;

/// Control and health of one aid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AidControl {
    /// χ² threshold on the normalized innovation squared.
    pub gate: f64,
    /// An aid with no fused sample for this long is stale.
    pub timeout_ns: u64,
    pub status: AidStatus,
    pub counters: StreamCounters,
}

impl AidControl {
    pub fn new(gate: f64, timeout_ns: u64) -> Self {
        Self {
            gate,
            timeout_ns,
            status: AidStatus::default(),
            counters: StreamCounters::default(),
        }
    }

    /// A sample arrived (before any check).
    pub fn received(&mut self) {
        self.counters.received += 1;
    }

    /// Rejected before fusion: invalid content.
    pub fn rejected_invalid(&mut self) {
        self.refused(0);
    }

    /// Refused before fusion for cause `cause` of the aid's declaration
    /// (0: invalid content; a cause beyond the record's counts as 0).
    pub fn refused(&mut self, cause: usize) {
        self.counters.rejected_invalid += 1;
        let k = if cause < MAX_CAUSES { cause } else { 0 };
        self.status.refused[k] += 1;
        self.status.fused = 0;
    }

    /// Rejected before fusion: time stamp not usable (backwards, duplicate, too late).
    pub fn rejected_time(&mut self) {
        self.counters.rejected_time += 1;
        self.status.fused = 0;
    }

    /// Records the outcome of a gated update at `t_ns`, made in the
    /// navigation frame `frame`.
    pub fn record<const M: usize>(&mut self, t_ns: u64, out: &UpdateOutcome<M>, frame: WireFrame) {
        let mut innovation = [0.0; MAX_COMPONENTS];
        let mut var = [0.0; MAX_COMPONENTS];
        for i in 0..M.min(MAX_COMPONENTS) {
            innovation[i] = out.innovation[i];
            var[i] = out.innovation_var[i];
        }
        self.status.innovation = innovation;
        self.status.innovation_var = var;
        self.status.test_ratio = out.test_ratio;
        self.status.made_in_frame = AidStatus::made_in_frame_of(frame);
        if out.fused {
            self.counters.accepted += 1;
            self.counters.last_t_ns = t_ns;
            self.status.fused = 1;
            self.status.last_fuse_t_ns = t_ns;
        } else {
            self.counters.rejected_gate += 1;
            self.status.fused = 0;
        }
    }

    /// Fresh: fused within the timeout before `now_ns`.
    pub fn fresh(&self, now_ns: u64) -> bool {
        self.counters.accepted > 0
            && now_ns.saturating_sub(self.status.last_fuse_t_ns) <= self.timeout_ns
    }

    /// The status record with the freshness flag for `now_ns`.
    pub fn status_at(&self, now_ns: u64) -> AidStatus {
        AidStatus {
            fresh: u8::from(self.fresh(now_ns)),
            ..self.status
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SVector;

    #[test]
    fn counters_and_freshness_follow_the_outcomes() {
        let mut c = AidControl::new(13.8, 3_000_000_000);
        let ok = UpdateOutcome::<2> {
            innovation: SVector::<f64, 2>::new(1.0, 2.0),
            innovation_var: SVector::<f64, 2>::new(4.0, 4.0),
            state_var: SVector::<f64, 2>::new(3.0, 3.0),
            nis: 1.25,
            test_ratio: 0.09,
            dx: SVector::zeros(),
            fused: true,
        };
        assert_eq!(c.status_at(0).made_in(), None, "no update yet");
        c.received();
        c.record(10_000_000_000, &ok, WireFrame::Geographic);
        assert_eq!(c.status_at(0).made_in(), Some(WireFrame::Geographic));
        assert!(c.fresh(12_000_000_000) && !c.fresh(13_000_000_001));
        c.received();
        c.record(
            11_000_000_000,
            &UpdateOutcome {
                fused: false,
                test_ratio: 4.0,
                ..ok
            },
            WireFrame::Grid,
        );
        c.received();
        c.rejected_invalid();
        assert_eq!(
            (
                c.counters.received,
                c.counters.accepted,
                c.counters.rejected_gate,
                c.counters.rejected_invalid
            ),
            (3, 1, 1, 1)
        );
        let s = c.status_at(12_000_000_000);
        assert_eq!((s.fused, s.fresh, s.last_fuse_t_ns), (0, 1, 10_000_000_000));
        // The invalid measurement made no innovation: the last one's frame stands.
        assert_eq!(s.made_in(), Some(WireFrame::Grid));
        assert!((s.innovation[1] - 2.0).abs() < 1e-15 && s.innovation[2].abs() < 1e-15);
        assert_eq!(s.refused, [1, 0, 0, 0]);
    }
}
