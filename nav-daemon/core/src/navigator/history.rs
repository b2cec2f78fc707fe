//! The state history: nominal states after the last IMU samples, so that an
//! aid that arrives late is fused against the state at its own time.

use nalgebra::{UnitQuaternion, Vector3};

use crate::mech::{AnyNav, FrameKind};

/// Length of the state history: 0.5 s at 1 kHz, 2.5 s at 200 Hz. An aid
/// older than the oldest stored state cannot be fused at its own time.
pub const HISTORY: usize = 512;

/// Nominal states after the last IMU samples (a ring), so that an aid that
/// arrives late is fused against the state at its own time. Stored as they
/// are (a copy per sample); converted only when an aid needs one.
#[derive(Debug, Clone)]
pub(super) struct History {
    t_ns: [u64; HISTORY],
    nav: [AnyNav; HISTORY],
    /// Index of the newest entry.
    head: usize,
    len: usize,
}

impl History {
    pub(super) fn new(nav: AnyNav) -> Self {
        Self {
            t_ns: [0; HISTORY],
            nav: [nav; HISTORY],
            head: HISTORY - 1,
            len: 0,
        }
    }

    pub(super) fn clear(&mut self) {
        self.len = 0;
    }

    pub(super) fn push(&mut self, t_ns: u64, nav: &AnyNav) {
        self.head = (self.head + 1) % HISTORY;
        self.t_ns[self.head] = t_ns;
        self.nav[self.head] = *nav;
        self.len = (self.len + 1).min(HISTORY);
    }

    /// Converts the stored states to the frame `to` (at a frame switch).
    pub(super) fn convert(&mut self, to: FrameKind) {
        for k in 0..self.len {
            let i = (self.head + HISTORY - k) % HISTORY;
            self.nav[i] = self.nav[i].converted(to);
        }
    }

    /// Applies the correction just made to the current state to the stored
    /// states from `oldest_ns` on (older ones can no longer be used and are
    /// dropped). Stored states are in the current frame (the history is
    /// converted at a frame switch), so the same error-state feedback applies;
    /// they differ from the current state by at most the latency limit.
    pub(super) fn correct(
        &mut self,
        oldest_ns: u64,
        phi: &Vector3<f64>,
        dv: &Vector3<f64>,
        dp: &Vector3<f64>,
    ) {
        // One rotation for all: R(φ) is the same for every stored state.
        let rot = UnitQuaternion::from_scaled_axis(*phi);
        for k in 0..self.len {
            let i = (self.head + HISTORY - k) % HISTORY;
            if self.t_ns[i] < oldest_ns {
                self.len = k;
                break;
            }
            self.nav[i].correct_by(&rot, dv, dp);
        }
    }

    /// The frame-free state at `t_ns`, linear between the stored states
    /// around it (attitude by slerp); `None` outside.
    pub(super) fn at(
        &self,
        t_ns: u64,
    ) -> Option<(Vector3<f64>, Vector3<f64>, UnitQuaternion<f64>)> {
        let mut newer = self.head;
        for k in 0..self.len {
            let i = (self.head + HISTORY - k) % HISTORY;
            let t = self.t_ns[i];
            if t == t_ns {
                let ff = self.nav[i].frame_free();
                return Some((ff.r_e, ff.v_e, ff.q_b_e));
            }
            if t < t_ns {
                if k == 0 {
                    return None;
                }
                let w = (t_ns - t) as f64 / (self.t_ns[newer] - t) as f64;
                let (a, b) = (self.nav[i].frame_free(), self.nav[newer].frame_free());
                let q = a.q_b_e.try_slerp(&b.q_b_e, w, 1e-12).unwrap_or(b.q_b_e);
                return Some((a.r_e.lerp(&b.r_e, w), a.v_e.lerp(&b.v_e, w), q));
            }
            newer = i;
        }
        None
    }
}
