//! Aid gating: whether and when an aid sample is fused (selection, time
//! stamp against the IMU, the state at its own time from the history), the
//! χ² gate and the closed-loop feedback of a fused correction. The
//! measurement models are `crate::aids`.

use msgs::{BaroSample, CnsFix, SrsSample};
use nalgebra::Vector3;

use crate::aids::control::AidControl;
use crate::aids::{self, AidError, Measurement};
use crate::error_model::idx;
use crate::mech::AnyNav;
use crate::settings::{AidSet, AidSettings};

use super::{AidOutcome, InputRejection, Navigator, secs_to_ns};

/// The per-aid fusion controls, which aids are selected, and the latency limit.
#[derive(Debug, Clone)]
pub(super) struct AidGate {
    pub(super) srs: AidControl,
    pub(super) cns: AidControl,
    pub(super) baro: AidControl,
    pub(super) enabled: AidSet,
    pub(super) max_latency_ns: u64,
    /// The last gated innovation was rejected (solution flag).
    pub(super) last_rejected: bool,
}

impl AidGate {
    pub(super) fn new(a: &AidSettings, enabled: AidSet) -> Self {
        Self {
            srs: AidControl::new(a.srs_gate, secs_to_ns(a.srs_timeout_s)),
            cns: AidControl::new(a.cns_gate, secs_to_ns(a.cns_timeout_s)),
            baro: AidControl::new(a.baro_gate, secs_to_ns(a.baro_timeout_s)),
            enabled,
            max_latency_ns: secs_to_ns(a.max_latency_s),
            last_rejected: false,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum AidKind {
    Srs,
    Cns,
    Baro,
}

impl Navigator {
    /// Checks an aid's time stamp; returns its age behind the IMU (s).
    fn aid_age(&self, t_ns: u64) -> Result<f64, InputRejection> {
        if t_ns > self.t_ns {
            return Err(InputRejection::AheadOfImu {
                t_ns,
                imu_ns: self.t_ns,
            });
        }
        let age = self.t_ns - t_ns;
        if age > self.aids.max_latency_ns {
            return Err(InputRejection::TooLate {
                t_ns,
                age_s: age as f64 * 1e-9,
                limit_s: self.aids.max_latency_ns as f64 * 1e-9,
            });
        }
        Ok(age as f64 * 1e-9)
    }

    /// The nominal state at an aid's time `t_ns`, `age_s` behind the newest
    /// IMU sample: interpolated from the state history (kept consistent with
    /// every correction since), so a late aid is fused at its own time. If the
    /// history does not reach back that far (just after a start), the
    /// position is moved back along the velocity instead.
    fn state_at(&self, t_ns: u64, age_s: f64) -> AnyNav {
        if age_s == 0.0 {
            return *self.nominal.nav();
        }
        if let Some((r, v, q)) = self.history.at(t_ns) {
            return AnyNav::from_frame_free(self.nominal.nav().kind(), &r, &v, &q);
        }
        let ff = self.nominal.nav().frame_free();
        AnyNav::from_frame_free(
            self.nominal.nav().kind(),
            &(ff.r_e - ff.v_e * age_s),
            &ff.v_e,
            &ff.q_b_e,
        )
    }

    /// Gate, update and feedback for one measurement. An update that would
    /// leave P or the correction non-finite (σ at the edge of the range, a
    /// degenerate geometry) is undone and counted as invalid.
    fn fuse<const M: usize>(
        &mut self,
        which: AidKind,
        t_ns: u64,
        m: &Measurement<M>,
    ) -> AidOutcome {
        let gate = self.control(which).gate;
        let Some(out) = self.err.update(m, gate) else {
            self.control_mut(which).rejected_invalid();
            return AidOutcome {
                fused: false,
                test_ratio: f64::NAN,
                excluded_body: None,
            };
        };
        self.control_mut(which).record(t_ns, &out);
        self.aids.last_rejected = !out.fused;
        if out.fused {
            self.coasting = false;
            self.resumed = false;
            let dx = out.dx;
            let part = |o: usize| Vector3::new(dx[o], dx[o + 1], dx[o + 2]);
            let (phi, dv, dp) = (part(idx::PHI), part(idx::DV), part(idx::DP));
            self.nominal.correct(&phi, &dv, &dp);
            // Only states an aid may still be fused against (within the latency limit).
            let oldest = t_ns.min(self.t_ns).saturating_sub(self.aids.max_latency_ns);
            self.history.correct(oldest, &phi, &dv, &dp);
            self.err.gyro_bias += part(idx::BG);
            self.err.accel_bias += part(idx::BA);
        }
        AidOutcome {
            fused: out.fused,
            test_ratio: out.test_ratio,
            excluded_body: None,
        }
    }

    fn control(&self, which: AidKind) -> &AidControl {
        match which {
            AidKind::Srs => &self.aids.srs,
            AidKind::Cns => &self.aids.cns,
            AidKind::Baro => &self.aids.baro,
        }
    }
    fn control_mut(&mut self, which: AidKind) -> &mut AidControl {
        match which {
            AidKind::Srs => &mut self.aids.srs,
            AidKind::Cns => &mut self.aids.cns,
            AidKind::Baro => &mut self.aids.baro,
        }
    }

    /// Common path of every aid: counters, time check, model, fusion.
    fn on_aid<const M: usize>(
        &mut self,
        which: AidKind,
        t_ns: u64,
        model: impl FnOnce(&AnyNav) -> Result<(Measurement<M>, Option<u32>), AidError>,
    ) -> Result<AidOutcome, InputRejection> {
        self.control_mut(which).received();
        let enabled = match which {
            AidKind::Srs => self.aids.enabled.srs,
            AidKind::Cns => self.aids.enabled.cns,
            AidKind::Baro => self.aids.enabled.baro,
        };
        if !enabled {
            self.control_mut(which).counters.not_used += 1;
            return Ok(AidOutcome {
                fused: false,
                test_ratio: f64::NAN,
                excluded_body: None,
            });
        }
        let age = match self.aid_age(t_ns) {
            Ok(a) => a,
            Err(e) => {
                self.control_mut(which).rejected_time();
                return Err(e);
            }
        };
        if t_ns <= self.control(which).counters.last_t_ns
            && self.control(which).counters.accepted > 0
        {
            self.control_mut(which).rejected_time();
            return Err(InputRejection::TimeNotIncreasing {
                t_ns,
                prev_ns: self.control(which).counters.last_t_ns,
            });
        }
        self.propagate_covariance();
        let at = self.state_at(t_ns, age);
        let (m, excluded) = match model(&at) {
            Ok(x) => x,
            Err(e) => {
                self.control_mut(which).rejected_invalid();
                return Err(e.into());
            }
        };
        let mut out = self.fuse(which, t_ns, &m);
        out.excluded_body = excluded;
        if excluded.is_some() {
            self.control_mut(which).status.exclusions += 1;
        }
        Ok(out)
    }

    pub fn on_srs(&mut self, s: &SrsSample) -> Result<AidOutcome, InputRejection> {
        self.on_aid(AidKind::Srs, s.t_ns, |n| {
            aids::srs::measurement(n, s).map(|(m, sol)| (m, sol.excluded_body))
        })
    }
    pub fn on_cns(&mut self, c: &CnsFix) -> Result<AidOutcome, InputRejection> {
        self.on_aid(AidKind::Cns, c.t_ns, |n| {
            aids::cns::measurement(n, c).map(|m| (m, None))
        })
    }
    pub fn on_baro(&mut self, b: &BaroSample) -> Result<AidOutcome, InputRejection> {
        self.on_aid(AidKind::Baro, b.t_ns, |n| {
            aids::baro::measurement(n, b).map(|m| (m, None))
        })
    }
}
