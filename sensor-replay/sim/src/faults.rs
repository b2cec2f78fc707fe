//! Fault injection for simulated flights: the `[faults]` section of a
//! scenario. Each `[[faults.event]]` acts on one stream over a window of
//! sensor time:
//!
//! | kind        | effect on each sample in the window |
//! |---|---|
//! | `outage`    | not written (an IMU outage is a dropout: a gap in time) |
//! | `outliers`  | gross error of `magnitude`: IMU m/s² on the z accelerometer, CNS metres north, baro metres up, SRS m/s on the first line's radial velocity, star arcsec about the body x axis (stray light) |
//! | `nan`       | a NaN in the sample (IMU Δv x, CNS latitude, baro pressure, first SRS line's wavelength, star quaternion w) |
//! | `time_jump` | time stamp moved back by `magnitude` seconds |
//! | `duplicate` | written twice |
//!
//! `every = N` applies the fault to every N-th sample of the window only.
//! Injection changes nothing else: a flight simulated with `--no-faults` has
//! the same samples everywhere outside the faulted ones, so it is the
//! fault-free reference of the campaign.

use msgs::{AidKind, AidSample, ImuSample, Stream};
use serde::Deserialize;

use crate::aids::Corruption;

/// `[faults]`.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FaultsSpec {
    #[serde(rename = "event", default)]
    pub events: Vec<FaultEvent>,
}

/// One `[[faults.event]]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FaultEvent {
    pub kind: FaultKind,
    /// `imu` or an aid's name.
    #[serde(deserialize_with = "stream_by_name")]
    pub stream: Stream,
    pub start_s: f64,
    pub duration_s: f64,
    #[serde(default)]
    pub magnitude: f64,
    #[serde(default = "one")]
    pub every: u32,
}

fn one() -> u32 {
    1
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    Outage,
    Outliers,
    Nan,
    TimeJump,
    Duplicate,
}

/// A stream by its name: `imu` or an aid's.
fn stream_by_name<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Stream, D::Error> {
    let name = String::deserialize(d)?;
    if name == "imu" {
        return Ok(Stream::Imu);
    }
    AidKind::from_name(&name).map(Stream::Aid).ok_or_else(|| {
        serde::de::Error::custom(format!(
            "unknown stream {name:?}: expected imu or one of {}",
            AidKind::names()
        ))
    })
}

impl FaultEvent {
    /// The window in ns, `[start, end)`.
    pub fn window_ns(&self) -> (u64, u64) {
        let s = (self.start_s * 1e9).round() as u64;
        (s, s + (self.duration_s * 1e9).round() as u64)
    }

    /// Checks the values; `key` names the event in errors (`faults.event[2]`).
    pub fn validate(&self, key: &str) -> Result<(), String> {
        if !(self.start_s.is_finite() && self.start_s >= 0.0) {
            return Err(format!(
                "{key}.start_s: expected a time ≥ 0 s, got {}",
                self.start_s
            ));
        }
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return Err(format!(
                "{key}.duration_s: expected a positive duration, got {}",
                self.duration_s
            ));
        }
        if !self.magnitude.is_finite() {
            return Err(format!("{key}.magnitude: expected a finite number"));
        }
        if self.every == 0 {
            return Err(format!("{key}.every: expected at least 1"));
        }
        let needs_magnitude = matches!(self.kind, FaultKind::Outliers | FaultKind::TimeJump);
        if needs_magnitude && self.magnitude == 0.0 {
            return Err(format!(
                "{key}.magnitude: a {:?} fault needs a non-zero magnitude",
                self.kind
            ));
        }
        if self.kind == FaultKind::TimeJump && self.magnitude < 0.0 {
            return Err(format!(
                "{key}.magnitude: a time jump goes back by a positive number of seconds"
            ));
        }
        Ok(())
    }
}

/// Applies the events of a scenario to the generated samples and counts
/// what it did per event. Each method modifies the sample in place and
/// returns how many times to write it (0: dropped).
#[derive(Debug, Clone)]
pub struct Injector {
    events: Vec<FaultEvent>,
    windows: Vec<(u64, u64)>,
    seen: Vec<u64>,
    /// Samples affected, per event.
    pub injected: Vec<u64>,
}

impl Injector {
    /// `None` or an empty spec injects nothing.
    pub fn new(spec: Option<&FaultsSpec>) -> Self {
        let events = spec.map(|s| s.events.clone()).unwrap_or_default();
        Self {
            windows: events.iter().map(FaultEvent::window_ns).collect(),
            seen: vec![0; events.len()],
            injected: vec![0; events.len()],
            events,
        }
    }

    pub fn events(&self) -> &[FaultEvent] {
        &self.events
    }

    /// The active events for a sample of `stream` at `t_ns`, counted.
    fn active(&mut self, stream: Stream, t_ns: u64, mut f: impl FnMut(&FaultEvent)) {
        for (k, e) in self.events.iter().enumerate() {
            let (a, b) = self.windows[k];
            if e.stream != stream || t_ns < a || t_ns >= b {
                continue;
            }
            self.seen[k] += 1;
            if (self.seen[k] - 1).is_multiple_of(u64::from(e.every)) {
                self.injected[k] += 1;
                f(e);
            }
        }
    }

    fn common(e: &FaultEvent, t_ns: &mut u64, times: &mut u32) {
        match e.kind {
            FaultKind::Outage => *times = 0,
            FaultKind::Duplicate => *times = (*times).max(1) * 2,
            FaultKind::TimeJump => *t_ns = t_ns.saturating_sub((e.magnitude * 1e9).round() as u64),
            FaultKind::Outliers | FaultKind::Nan => {}
        }
    }

    pub fn imu(&mut self, s: &mut ImuSample) -> u32 {
        let mut times = 1;
        let t = s.t_ns;
        self.active(Stream::Imu, t, |e| {
            Self::common(e, &mut s.t_ns, &mut times);
            match e.kind {
                FaultKind::Outliers => s.d_v_mps[2] += e.magnitude * s.dt_s,
                FaultKind::Nan => s.d_v_mps[0] = f64::NAN,
                _ => {}
            }
        });
        times
    }

    /// An aid's sample: the common faults, then the aid's own
    /// ([`crate::aids::SimAid::fault`]).
    pub fn aid(&mut self, s: &mut AidSample) -> u32 {
        let mut times = 1;
        let t = s.t_ns();
        self.active(Stream::Aid(s.kind()), t, |e| {
            Self::common(e, s.t_ns_mut(), &mut times);
            match e.kind {
                FaultKind::Outliers => crate::aids::corrupt(s, Corruption::Outlier(e.magnitude)),
                FaultKind::Nan => crate::aids::corrupt(s, Corruption::Nan),
                _ => {}
            }
        });
        times
    }
}
