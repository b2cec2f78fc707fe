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
//! | `gnss_jam`  | GNSS only: over the first `ramp_s` (default half the window) the receiver's error and its accuracy estimates grow together, linearly to `magnitude` times their own; then no fix (fix type 0) to the end of the window |
//! | `gnss_spoof`| GNSS only: the position dragged along `azimuth_deg` (clockwise from north, in the tangent plane) at `magnitude` m/s² from the window's start, ½ a τ², with the velocity consistent with it (a τ), the height kept; plus a sudden offset of `offset_m` along the same azimuth and a lag of `delay_s` (meaconing: the fix is where the aircraft was `delay_s` before, at the rebroadcaster's offset). The accuracy estimates and flags stay those of a good fix |
//!
//! `every = N` applies the fault to every N-th sample of the window only.
//! The jamming noise is drawn from the flight seed's own stream 7, so a
//! jammed flight has every other sample exactly as the clean one.
//! Injection changes nothing else: a flight simulated with `--no-faults` has
//! the same samples everywhere outside the faulted ones, so it is the
//! fault-free reference of the campaign.

use msgs::gnss::fix_type;
use msgs::{AidKind, AidSample, GnssFix, ImuSample, Stream};
use nalgebra::Vector3;
use polarnav::earth::{self, Geodetic};
use polarnav::frames;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use serde::Deserialize;

use crate::aids::Corruption;
use crate::sensors;

/// The stream of the flight's seed the jamming noise is drawn from.
const FAULT_STREAM: u64 = 7;

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
    /// `gnss_jam`: the length of the accuracy ramp before the fix is lost
    /// (s; default half the window).
    #[serde(default)]
    pub ramp_s: Option<f64>,
    /// `gnss_spoof`: the direction of the drag and the offset (deg,
    /// clockwise from north in the tangent plane at the first spoofed fix).
    #[serde(default)]
    pub azimuth_deg: f64,
    /// `gnss_spoof`: a sudden offset (m) and a lag (s) of every spoofed fix.
    #[serde(default)]
    pub offset_m: f64,
    #[serde(default)]
    pub delay_s: f64,
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
    GnssJam,
    GnssSpoof,
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
        let gnss = matches!(self.kind, FaultKind::GnssJam | FaultKind::GnssSpoof);
        if gnss && self.stream != Stream::Aid(AidKind::Gnss) {
            return Err(format!(
                "{key}.stream: a {:?} fault acts on the gnss stream only",
                self.kind
            ));
        }
        let spoof_fields = self.azimuth_deg != 0.0 || self.offset_m != 0.0 || self.delay_s != 0.0;
        if spoof_fields && self.kind != FaultKind::GnssSpoof {
            return Err(format!(
                "{key}: azimuth_deg, offset_m and delay_s belong to a gnss_spoof fault"
            ));
        }
        if self.ramp_s.is_some() && self.kind != FaultKind::GnssJam {
            return Err(format!("{key}.ramp_s: belongs to a gnss_jam fault"));
        }
        match self.kind {
            FaultKind::GnssJam => {
                if !(1.0..=1e4).contains(&self.magnitude) {
                    return Err(format!(
                        "{key}.magnitude: a jamming's accuracy grows by a factor in [1, 1e4], got {}",
                        self.magnitude
                    ));
                }
                if let Some(r) = self.ramp_s
                    && !(r.is_finite() && r >= 0.0 && r <= self.duration_s)
                {
                    return Err(format!(
                        "{key}.ramp_s: expected a time in [0, duration_s], got {r}"
                    ));
                }
            }
            FaultKind::GnssSpoof => {
                for (k, v, max) in [
                    ("magnitude", self.magnitude, 1e3),
                    ("azimuth_deg", self.azimuth_deg, 360.0),
                    ("offset_m", self.offset_m, 1e6),
                    ("delay_s", self.delay_s, 3600.0),
                ] {
                    if !(v.is_finite() && v.abs() <= max) {
                        return Err(format!(
                            "{key}.{k}: expected a finite value of at most {max}, got {v}"
                        ));
                    }
                }
                if self.magnitude < 0.0 || self.delay_s < 0.0 {
                    return Err(format!(
                        "{key}: a spoofer's drag (magnitude) and delay are not negative"
                    ));
                }
                if self.magnitude == 0.0 && self.offset_m == 0.0 && self.delay_s == 0.0 {
                    return Err(format!(
                        "{key}: a gnss_spoof fault needs a drag (magnitude), an offset_m or a delay_s"
                    ));
                }
            }
            _ => {}
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
    /// Per event: a spoofer's direction (ECEF unit vector), fixed at its
    /// first fix.
    directions: Vec<Option<Vector3<f64>>>,
    /// The jamming noise's generator.
    rng: ChaCha20Rng,
}

impl Injector {
    /// `None` or an empty spec injects nothing; `seed` is the flight's.
    pub fn new(spec: Option<&FaultsSpec>, seed: u64) -> Self {
        let events = spec.map(|s| s.events.clone()).unwrap_or_default();
        let mut rng = ChaCha20Rng::seed_from_u64(seed);
        rng.set_stream(FAULT_STREAM);
        Self {
            windows: events.iter().map(FaultEvent::window_ns).collect(),
            seen: vec![0; events.len()],
            injected: vec![0; events.len()],
            directions: vec![None; events.len()],
            rng,
            events,
        }
    }

    pub fn events(&self) -> &[FaultEvent] {
        &self.events
    }

    /// The active events for a sample of `stream` at `t_ns`, counted: `f`
    /// gets the event, the time since its start (s), its spoofing
    /// direction's slot and the jamming generator.
    fn active(
        &mut self,
        stream: Stream,
        t_ns: u64,
        mut f: impl FnMut(&FaultEvent, f64, &mut Option<Vector3<f64>>, &mut ChaCha20Rng),
    ) {
        for (k, e) in self.events.iter().enumerate() {
            let (a, b) = self.windows[k];
            if e.stream != stream || t_ns < a || t_ns >= b {
                continue;
            }
            self.seen[k] += 1;
            if (self.seen[k] - 1).is_multiple_of(u64::from(e.every)) {
                self.injected[k] += 1;
                let since_s = (t_ns - a) as f64 * 1e-9;
                f(e, since_s, &mut self.directions[k], &mut self.rng);
            }
        }
    }

    fn common(e: &FaultEvent, t_ns: &mut u64, times: &mut u32) {
        match e.kind {
            FaultKind::Outage => *times = 0,
            FaultKind::Duplicate => *times = (*times).max(1) * 2,
            FaultKind::TimeJump => *t_ns = t_ns.saturating_sub((e.magnitude * 1e9).round() as u64),
            FaultKind::Outliers | FaultKind::Nan | FaultKind::GnssJam | FaultKind::GnssSpoof => {}
        }
    }

    pub fn imu(&mut self, s: &mut ImuSample) -> u32 {
        let mut times = 1;
        let t = s.t_ns;
        self.active(Stream::Imu, t, |e, _, _, _| {
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
    /// ([`crate::aids::SimAid::corrupt`]), jamming and spoofing.
    pub fn aid(&mut self, s: &mut AidSample) -> u32 {
        let mut times = 1;
        let t = s.t_ns();
        self.active(Stream::Aid(s.kind()), t, |e, since_s, dir, rng| {
            Self::common(e, s.t_ns_mut(), &mut times);
            match (e.kind, &mut *s) {
                (FaultKind::Outliers, s) => {
                    crate::aids::corrupt(s, Corruption::Outlier(e.magnitude))
                }
                (FaultKind::Nan, s) => crate::aids::corrupt(s, Corruption::Nan),
                (FaultKind::GnssJam, AidSample::Gnss(g)) => jam(g, e, since_s, rng),
                (FaultKind::GnssSpoof, AidSample::Gnss(g)) => spoof(g, e, since_s, dir),
                _ => {}
            }
        });
        times
    }
}

/// Jamming, `since_s` into the event: on the ramp the error and the
/// accuracy estimates grow by the factor k (1 at the start, `magnitude`
/// at the ramp's end), the added error drawn with σ √(k² − 1) times the
/// reported one (the total is then k times it); after the ramp, no fix.
fn jam(g: &mut GnssFix, e: &FaultEvent, since_s: f64, rng: &mut ChaCha20Rng) {
    let ramp_s = e.ramp_s.unwrap_or(0.5 * e.duration_s);
    if since_s >= ramp_s {
        g.fix_type = fix_type::NONE;
        g.flags = 0;
        g.num_sv = 0;
        g.h_acc_m = 1e4;
        g.v_acc_m = 1e4;
        g.s_acc_mps = 100.0;
        g.pdop = 99.99;
        return;
    }
    let k = 1.0 + (e.magnitude - 1.0) * since_s / ramp_s.max(1e-9);
    let extra = (k * k - 1.0).max(0.0).sqrt();
    let mut n = || sensors::normal(rng);
    let d_enu = Vector3::new(
        extra * g.h_acc_m * n(),
        extra * g.h_acc_m * n(),
        extra * g.v_acc_m * n(),
    );
    let dv_enu = extra * g.s_acc_mps * Vector3::new(n(), n(), n());
    move_fix(g, &d_enu, &dv_enu);
    g.h_acc_m *= k;
    g.v_acc_m *= k;
    g.s_acc_mps *= k;
    g.num_sv = g
        .num_sv
        .saturating_sub((since_s / ramp_s * 8.0) as u8)
        .max(4);
}

/// Spoofing, `since_s` into the event (see the module documentation).
fn spoof(g: &mut GnssFix, e: &FaultEvent, since_s: f64, dir: &mut Option<Vector3<f64>>) {
    let c_e_g = frames::c_e_g(g.lat_rad, g.lon_rad);
    let up = c_e_g.row(2).transpose();
    let d0 = *dir.get_or_insert_with(|| {
        let (s, c) = e.azimuth_deg.to_radians().sin_cos();
        c_e_g.transpose() * Vector3::new(s, c, 0.0)
    });
    // The direction in the tangent plane where the aircraft is now.
    let d = (d0 - up * up.dot(&d0)).try_normalize(1e-9).unwrap_or(d0);
    let along = 0.5 * e.magnitude * since_s * since_s + e.offset_m;
    let [vn, ve, vd] = g.vel_ned_mps;
    let v_e = c_e_g.transpose() * Vector3::new(ve, vn, -vd);
    let d_enu = c_e_g * (d * along - v_e * e.delay_s);
    let dv_enu = c_e_g * (d * (e.magnitude * since_s));
    // A spoofer keeps the height (a move along the tangent plane would
    // raise it by s²/2R): only the lag moves it.
    let h = g.height_m + d_enu.z;
    move_fix(g, &d_enu, &dv_enu);
    g.height_m = h;
}

/// Moves a fix by `d_enu` (m, local east-north-up) and its velocity by
/// `dv_enu`.
fn move_fix(g: &mut GnssFix, d_enu: &Vector3<f64>, dv_enu: &Vector3<f64>) {
    let c_e_g = frames::c_e_g(g.lat_rad, g.lon_rad);
    let [vn, ve, vd] = g.vel_ned_mps;
    let v_e = c_e_g.transpose() * (Vector3::new(ve, vn, -vd) + dv_enu);
    let r = earth::geodetic_to_ecef(&Geodetic::new(g.lat_rad, g.lon_rad, g.height_m))
        + c_e_g.transpose() * d_enu;
    let fix = earth::ecef_to_geodetic(&r);
    // The receiver's velocity is in the axes of its own fix.
    let v = frames::c_e_g(fix.lat_rad, fix.lon_rad) * v_e;
    g.lat_rad = fix.lat_rad;
    g.lon_rad = fix.lon_rad;
    g.height_m = fix.h_m;
    g.vel_ned_mps = [v.y, v.x, -v.z];
}
