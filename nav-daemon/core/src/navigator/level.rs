//! The navigator's flight-state recognition and attitude compensation
//! ([`crate::flight_state`]): one window of IMU increments at a time; at
//! its end the state is judged and, when steady and no aid that makes the
//! tilt observable is fresh, roll and pitch are fused from the
//! accelerometers. Bounded work: one window's sums per sample, one 2-row
//! update per window.

use msgs::AidKind;

use crate::aids::ConsiderShares;
use crate::flight_state::{
    FlightState, FlightStateSettings, LEVEL_GATE, Window, classify, level_measurement,
};
use crate::mech::Increment;

use super::Navigator;

/// A level is not fused while the filter's predicted variance of both
/// level components is below this fraction of the level's own: it would
/// change their σ by less than 0.5 %. A navigation-grade INS holds its
/// tilt to arcseconds (10⁻⁴ of the level's variance), so its flights are
/// not touched; a MEMS tilt of 0.05° after GNSS is lost already is not.
const PRECISE: f64 = 0.01;

/// What the navigator keeps of the flight state.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Level {
    pub(super) settings: FlightStateSettings,
    /// Whether levels are fused: `compensate`, for a gyro of bias σ at
    /// least `min_gyro_bias_dph`.
    pub(super) compensate: bool,
    /// Accelerometer velocity random walk (m/s/√s).
    pub(super) vrw: f64,
    pub(super) window: Window,
    pub(super) state: FlightState,
    /// Time of the last fused level (0: none).
    pub(super) last_fused_ns: u64,
    pub(super) counters: LevelCounters,
}

/// Counts of the compensation, for the log and the tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LevelCounters {
    /// Windows judged, and how many of them in each state.
    pub windows: u64,
    pub ground: u64,
    pub steady: u64,
    pub manoeuvre: u64,
    /// Steady windows in which an aid observing tilt was fresh (no level
    /// taken), level updates fused, refused at the gate, and undone as
    /// numerically invalid.
    pub aided: u64,
    /// Steady windows in which the filter already held both level
    /// components ten times better than the accelerometers give them.
    pub precise: u64,
    pub fused: u64,
    pub rejected: u64,
    pub invalid: u64,
}

impl Level {
    pub(super) fn new(settings: &FlightStateSettings, vrw: f64, gyro_bias_dph: f64) -> Self {
        Self {
            settings: settings.clone(),
            compensate: settings.compensate && gyro_bias_dph >= settings.min_gyro_bias_dph,
            vrw,
            window: Window::default(),
            state: FlightState::Unknown,
            last_fused_ns: 0,
            counters: LevelCounters::default(),
        }
    }
}

impl Navigator {
    /// Adds a compensated increment to the flight-state window; at the
    /// window's end judges the state and, when it may, fuses the level.
    pub(super) fn flight_step(&mut self, inc: &Increment) {
        if !self.level.window.is_open() {
            let v = self.nominal.nav().frame_free().v_e;
            self.level.window.open(&v);
        }
        self.level.window.push(inc);
        if !self.level.window.full(self.level.settings.window_s) {
            return;
        }
        let nav = *self.nominal.nav();
        let ff = nav.frame_free();
        let Some(mean) = self
            .level
            .window
            .finish(self.level.settings.window_s, &ff.v_e)
        else {
            return;
        };
        let state = classify(&mean, &ff.geo, ff.v_e.norm(), &self.level.settings);
        self.level.state = state;
        let c = &mut self.level.counters;
        c.windows += 1;
        match state {
            FlightState::Ground => c.ground += 1,
            FlightState::Steady => c.steady += 1,
            _ => c.manoeuvre += 1,
        }
        if !(state.is_steady() && self.level.compensate) {
            return;
        }
        if self.tilt_aided() {
            self.level.counters.aided += 1;
            return;
        }
        let f_raw = mean.f_b + self.err.accel_bias;
        let Some(m) = level_measurement(
            &nav,
            &f_raw,
            &self.err.accel_bias,
            mean.t_s,
            self.level.vrw,
            &self.level.settings,
        ) else {
            self.level.counters.invalid += 1;
            return;
        };
        self.propagate_covariance();
        let hph = m.h * self.err.p * m.h.transpose();
        if hph[(0, 0)].max(hph[(1, 1)]) < PRECISE * m.r[(0, 0)] {
            self.level.counters.precise += 1;
            return;
        }
        let Some(out) = self.err.update(&m, LEVEL_GATE, &ConsiderShares::default()) else {
            self.level.counters.invalid += 1;
            return;
        };
        if out.fused {
            self.level.counters.fused += 1;
            self.level.last_fused_ns = self.t_ns;
            self.feed_back(self.t_ns, &out.dx);
        } else {
            self.level.counters.rejected += 1;
        }
    }

    /// Whether an aid that makes the tilt observable
    /// ([`crate::aids::Aid::MAKES_TILT_OBSERVABLE`]: GNSS, SRS, the star
    /// tracker, the baseline; not the magnetometer's heading) was fused
    /// within its timeout.
    fn tilt_aided(&self) -> bool {
        AidKind::ALL.into_iter().any(|k| {
            msgs::match_aid_kind!(k, P => <P as crate::aids::Aid>::MAKES_TILT_OBSERVABLE)
                && self.aids.controls[k].fresh(self.t_ns)
        })
    }

    /// The flight state of the last window.
    pub fn flight_state(&self) -> FlightState {
        self.level.state
    }

    /// The compensation's counts.
    pub fn level_counters(&self) -> LevelCounters {
        self.level.counters
    }

    /// Whether a level was fused within the last two windows.
    pub(super) fn level_fresh(&self) -> bool {
        let two = (2.0 * self.level.settings.window_s * 1e9) as u64;
        self.level.last_fused_ns > 0 && self.t_ns.saturating_sub(self.level.last_fused_ns) <= two
    }
}
