//! Each aid's simulator model: its scenario section `[NAME]` (optional: a
//! scenario without it has no such stream) and its samples made from the
//! truth. One impl of [`SimAid`] per aid; which aids exist is the
//! declaration's (`msgs::aids`), and [`Streams`] runs every aid of a
//! scenario, in the declared order, at each IMU epoch.

use msgs::baseline::{baseline_flags, carr_soln};
use msgs::gnss::{fix_flags, fix_type};
use msgs::{
    AidPayload, AidSample, BaroSample, BaselineSample, CnsFix, GnssFix, MagSample, SrsSample,
    StarSample,
};
use nalgebra::Vector3;
use polarnav::earth::{self, isa};
use polarnav::frames;
use rand_chacha::ChaCha20Rng;
use serde::de::DeserializeOwned;

use serde::Deserialize;

use crate::sensors::{self, Body, StarSensor, TruthSample};

/// A gross error applied to a sample (a fault of [`crate::faults`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Corruption {
    /// An outlier of this magnitude, in the aid's unit.
    Outlier(f64),
    /// A NaN in the sample.
    Nan,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CnsSpec {
    pub rate_hz: f64,
    /// Horizontal 1-σ (m).
    pub sigma_m: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaroSpec {
    pub rate_hz: f64,
    /// Altitude 1-σ (m).
    pub sigma_m: f64,
}

/// `[star]`: a star tracker fixed to the body.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StarSpec {
    pub rate_hz: f64,
    /// 1-σ about each axis across the boresight (arcsec).
    pub sigma_arcsec: f64,
    /// 1-σ about the boresight (arcsec); default 8 × `sigma_arcsec`, the
    /// usual ratio of a star tracker's roll to its cross-boresight accuracy.
    pub boresight_sigma_arcsec: Option<f64>,
    /// The boresight in body axes (normalized; default up, [0, 0, 1]).
    #[serde(default = "default_boresight")]
    pub boresight_b: [f64; 3],
    /// A mounting misalignment the sensor's driver does not know: a fixed
    /// small rotation about body x, y, z (arcsec) in every sample.
    #[serde(default)]
    pub misalignment_arcsec: [f64; 3],
}

fn default_boresight() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

impl StarSpec {
    /// The stated σ about the boresight (arcsec).
    pub fn boresight_sigma(&self) -> f64 {
        self.boresight_sigma_arcsec
            .unwrap_or(8.0 * self.sigma_arcsec)
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SrsSpec {
    pub rate_hz: f64,
    /// Radial-velocity 1-σ per line (m/s).
    pub sigma_mps: f64,
    #[serde(default = "default_mask")]
    pub elevation_mask_deg: f64,
    /// Explicit body catalogue; the built-in catalogue when empty.
    #[serde(default, rename = "body")]
    pub bodies: Vec<BodySpec>,
}

fn default_mask() -> f64 {
    10.0
}

/// One celestial body: direction (fixed star) and ephemeris velocity.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub id: u32,
    /// Right ascension and declination of the line of sight (deg), inertial frame.
    pub ra_deg: f64,
    pub dec_deg: f64,
    /// Velocity relative to the Earth's centre, inertial frame (m/s).
    pub vel_i_mps: [f64; 3],
    /// Rest wavelength of the observed line (nm).
    pub rest_wavelength_nm: f64,
}

/// A body of the SRS catalogue from its section.
pub fn body_of(b: &BodySpec) -> Body {
    let (sr, cr) = b.ra_deg.to_radians().sin_cos();
    let (sd, cd) = b.dec_deg.to_radians().sin_cos();
    Body {
        id: b.id,
        los_i: Vector3::new(cd * cr, cd * sr, sd),
        vel_i: Vector3::from(b.vel_i_mps),
        rest_wavelength_m: b.rest_wavelength_nm * 1e-9,
    }
}

/// An aid's simulator model.
pub trait SimAid: AidPayload + std::fmt::Debug {
    /// Its scenario section `[NAME]`.
    type Spec: DeserializeOwned + Clone + std::fmt::Debug;
    /// What the model keeps over a flight (a catalogue, correlated errors).
    type State: std::fmt::Debug;
    /// The generator it draws its noise from: `None`, the flight's own
    /// (the aids that came first keep it, so their flights are what they
    /// were); `Some(k)`, stream `k` of the flight's seed, so that adding
    /// the aid to a scenario leaves every other sample as it was.
    const OWN_STREAM: Option<u64>;
    /// Its sample rate (Hz).
    fn rate_hz(spec: &Self::Spec) -> f64;
    /// Checks the section; `Err((key, message))` names the key (`rate_hz`).
    fn validate(spec: &Self::Spec) -> Result<(), (String, String)>;
    /// The model's state at the start of a flight.
    fn start(spec: &Self::Spec) -> Self::State;
    /// The sample at `t_ns` (publisher sequence `seq`) of the truth `truth`;
    /// error-free when `noisy` is false (its stated σ kept).
    fn sample(
        spec: &Self::Spec,
        state: &mut Self::State,
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self;
    /// A gross error applied to the sample (the `outliers` and `nan`
    /// faults of [`crate::faults`]).
    fn corrupt(&mut self, c: Corruption);
}

/// A positive finite value, or the message that names the key.
pub fn positive(key: &str, v: f64) -> Result<(), (String, String)> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err((
            key.to_owned(),
            format!("must be a positive number, got {v}"),
        ))
    }
}

// ---- SRS ------------------------------------------------------------

impl SimAid for SrsSample {
    type Spec = SrsSpec;
    /// The bodies to observe.
    type State = Vec<Body>;
    const OWN_STREAM: Option<u64> = None;
    fn rate_hz(spec: &SrsSpec) -> f64 {
        spec.rate_hz
    }
    fn validate(s: &SrsSpec) -> Result<(), (String, String)> {
        positive("rate_hz", s.rate_hz)?;
        positive("sigma_mps", s.sigma_mps)?;
        if !(0.0..90.0).contains(&s.elevation_mask_deg) {
            return Err((
                "elevation_mask_deg".into(),
                format!("must be in [0, 90), got {}", s.elevation_mask_deg),
            ));
        }
        for (i, b) in s.bodies.iter().enumerate() {
            if !b.rest_wavelength_nm.is_finite() || b.rest_wavelength_nm <= 0.0 {
                return Err((
                    format!("body[{i}].rest_wavelength_nm"),
                    "must be positive".into(),
                ));
            }
        }
        Ok(())
    }
    fn start(spec: &SrsSpec) -> Vec<Body> {
        if spec.bodies.is_empty() {
            sensors::default_catalogue()
        } else {
            spec.bodies.iter().map(body_of).collect()
        }
    }
    fn sample(
        spec: &SrsSpec,
        catalogue: &mut Vec<Body>,
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self {
        sensors::srs_sample(
            rng,
            t_ns,
            seq,
            &truth.r_e,
            &truth.v_e,
            catalogue,
            spec.elevation_mask_deg.to_radians(),
            spec.sigma_mps,
            noisy,
        )
    }
    /// On the first line: a radial-velocity error of `magnitude` m/s
    /// (λ = λ0 (1 + v_r / c) to first order), or a NaN wavelength.
    fn corrupt(&mut self, c: Corruption) {
        let line = &mut self.lines[0];
        match c {
            Corruption::Outlier(magnitude) => {
                line.measured_wavelength_m += line.rest_wavelength_m * magnitude / 299_792_458.0
            }
            Corruption::Nan => line.measured_wavelength_m = f64::NAN,
        }
    }
}

// ---- CNS ------------------------------------------------------------

impl SimAid for CnsFix {
    type Spec = CnsSpec;
    type State = ();
    const OWN_STREAM: Option<u64> = None;
    fn rate_hz(spec: &CnsSpec) -> f64 {
        spec.rate_hz
    }
    fn validate(s: &CnsSpec) -> Result<(), (String, String)> {
        positive("rate_hz", s.rate_hz)?;
        positive("sigma_m", s.sigma_m)
    }
    fn start(_: &CnsSpec) {}
    fn sample(
        spec: &CnsSpec,
        _: &mut (),
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self {
        sensors::cns_fix(rng, t_ns, seq, &truth.r_e, spec.sigma_m, noisy)
    }
    /// `magnitude` metres north, or a NaN latitude.
    fn corrupt(&mut self, c: Corruption) {
        match c {
            Corruption::Outlier(magnitude) => self.lat_rad += magnitude / earth::A,
            Corruption::Nan => self.lat_rad = f64::NAN,
        }
    }
}

// ---- barometer --------------------------------------------------------

impl SimAid for BaroSample {
    type Spec = BaroSpec;
    type State = ();
    const OWN_STREAM: Option<u64> = None;
    fn rate_hz(spec: &BaroSpec) -> f64 {
        spec.rate_hz
    }
    fn validate(s: &BaroSpec) -> Result<(), (String, String)> {
        positive("rate_hz", s.rate_hz)?;
        positive("sigma_m", s.sigma_m)
    }
    fn start(_: &BaroSpec) {}
    fn sample(
        spec: &BaroSpec,
        _: &mut (),
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self {
        let h = earth::ecef_to_geodetic(&truth.r_e).h_m;
        sensors::baro_sample(rng, t_ns, seq, h, spec.sigma_m, noisy)
    }
    /// `magnitude` metres up, or a NaN pressure.
    fn corrupt(&mut self, c: Corruption) {
        match c {
            Corruption::Outlier(magnitude) => {
                let h = isa::pressure_altitude(self.pressure_pa);
                self.pressure_pa = isa::pressure(h + magnitude);
            }
            Corruption::Nan => self.pressure_pa = f64::NAN,
        }
    }
}

// ---- star tracker -------------------------------------------------------

impl SimAid for StarSample {
    type Spec = StarSpec;
    type State = ();
    /// Stream 5: a scenario with `[star]` has every other sample exactly
    /// as the same scenario without.
    const OWN_STREAM: Option<u64> = Some(5);
    fn rate_hz(spec: &StarSpec) -> f64 {
        spec.rate_hz
    }
    fn validate(st: &StarSpec) -> Result<(), (String, String)> {
        positive("rate_hz", st.rate_hz)?;
        positive("sigma_arcsec", st.sigma_arcsec)?;
        positive("boresight_sigma_arcsec", st.boresight_sigma())?;
        let n = st.boresight_b.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(n.is_finite() && n > 0.0) {
            return Err((
                "boresight_b".into(),
                format!("expected a non-zero direction, got {:?}", st.boresight_b),
            ));
        }
        for (i, m) in st.misalignment_arcsec.iter().enumerate() {
            if !(m.is_finite() && m.abs() <= 3600.0) {
                return Err((
                    format!("misalignment_arcsec[{i}]"),
                    format!("expected a finite angle of at most 3600 arcsec, got {m}"),
                ));
            }
        }
        Ok(())
    }
    fn start(_: &StarSpec) {}
    fn sample(
        spec: &StarSpec,
        _: &mut (),
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self {
        let star = StarSensor {
            boresight_b: spec.boresight_b,
            sigma_cross_arcsec: spec.sigma_arcsec,
            sigma_boresight_arcsec: spec.boresight_sigma(),
            misalignment_arcsec: spec.misalignment_arcsec,
        };
        sensors::star_sample(rng, t_ns, seq, &truth.q_b_e, &star, noisy)
    }
    /// A rotation of `magnitude` arcsec about body x (stray light), or a
    /// NaN quaternion w.
    fn corrupt(&mut self, c: Corruption) {
        match c {
            Corruption::Outlier(magnitude) => {
                let [w, x, y, z] = self.q_b_i;
                let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    w, x, y, z,
                ));
                let err = nalgebra::UnitQuaternion::from_scaled_axis(
                    Vector3::x() * (magnitude * polarnav::aids::star::ARCSEC_RAD),
                );
                let q = (q * err).into_inner();
                self.q_b_i = [q.w, q.i, q.j, q.k];
            }
            Corruption::Nan => self.q_b_i[0] = f64::NAN,
        }
    }
}

// ---- GNSS -------------------------------------------------------------

/// `[gnss]`: a GNSS receiver fixing its antenna's position and velocity.
/// Its position error is white noise plus a first-order Gauss–Markov
/// process per axis (the slowly wandering error of multipath, the
/// atmosphere and the orbits); it reports as its accuracy the σ of their
/// sum, as a receiver's estimate does.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssSpec {
    pub rate_hz: f64,
    /// White position noise, 1-σ per horizontal axis and vertical (m).
    #[serde(default = "gnss_defaults::sigma_h")]
    pub sigma_h_m: f64,
    #[serde(default = "gnss_defaults::sigma_v")]
    pub sigma_v_m: f64,
    /// Gauss–Markov position error: stationary 1-σ per horizontal axis and
    /// vertical (m), and correlation time (s).
    #[serde(default = "gnss_defaults::gm_h")]
    pub gm_sigma_h_m: f64,
    #[serde(default = "gnss_defaults::gm_v")]
    pub gm_sigma_v_m: f64,
    #[serde(default = "gnss_defaults::gm_tau")]
    pub gm_tau_s: f64,
    /// White velocity noise per axis (m/s).
    #[serde(default = "gnss_defaults::sigma_vel")]
    pub sigma_vel_mps: f64,
    /// The antenna's position from the IMU, body axes (m).
    #[serde(default)]
    pub lever_arm_b_m: [f64; 3],
    /// Reported PDOP and satellites used.
    #[serde(default = "gnss_defaults::pdop")]
    pub pdop: f64,
    #[serde(default = "gnss_defaults::num_sv")]
    pub num_sv: u8,
    /// Windows without a fix (the receiver reports fix type 0).
    #[serde(default, rename = "outage")]
    pub outages: Vec<GnssOutage>,
}

/// `[[gnss.outage]]`: a window without a fix.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssOutage {
    pub start_s: f64,
    pub duration_s: f64,
}

mod gnss_defaults {
    pub fn sigma_h() -> f64 {
        1.0
    }
    pub fn sigma_v() -> f64 {
        2.0
    }
    pub fn gm_h() -> f64 {
        1.5
    }
    pub fn gm_v() -> f64 {
        3.0
    }
    pub fn gm_tau() -> f64 {
        300.0
    }
    pub fn sigma_vel() -> f64 {
        0.05
    }
    pub fn pdop() -> f64 {
        1.6
    }
    pub fn num_sv() -> u8 {
        14
    }
}

impl GnssSpec {
    /// The σ the receiver reports: white and Gauss–Markov together.
    pub fn reported(&self) -> (f64, f64, f64) {
        (
            self.sigma_h_m.hypot(self.gm_sigma_h_m),
            self.sigma_v_m.hypot(self.gm_sigma_v_m),
            self.sigma_vel_mps,
        )
    }
}

/// The GNSS model's state: its Gauss–Markov error (local east, north, up,
/// m) and the time it was last drawn at.
#[derive(Debug, Clone, Copy, Default)]
pub struct GnssState {
    gm_enu: Vector3<f64>,
    last_s: Option<f64>,
}

impl SimAid for GnssFix {
    type Spec = GnssSpec;
    type State = GnssState;
    /// Stream 6: a scenario with `[gnss]` has every other sample exactly
    /// as the same scenario without.
    const OWN_STREAM: Option<u64> = Some(6);
    fn rate_hz(spec: &GnssSpec) -> f64 {
        spec.rate_hz
    }
    fn validate(g: &GnssSpec) -> Result<(), (String, String)> {
        positive("rate_hz", g.rate_hz)?;
        for (k, v) in [
            ("sigma_h_m", g.sigma_h_m),
            ("sigma_v_m", g.sigma_v_m),
            ("gm_sigma_h_m", g.gm_sigma_h_m),
            ("gm_sigma_v_m", g.gm_sigma_v_m),
            ("sigma_vel_mps", g.sigma_vel_mps),
        ] {
            if !(v.is_finite() && (0.0..=1e4).contains(&v)) {
                return Err((k.into(), format!("expected a 1-σ in [0, 1e4], got {v}")));
            }
        }
        positive("gm_tau_s", g.gm_tau_s)?;
        if !(g.pdop.is_finite() && g.pdop >= 1.0) {
            return Err((
                "pdop".into(),
                format!("a PDOP is at least 1, got {}", g.pdop),
            ));
        }
        for (i, l) in g.lever_arm_b_m.iter().enumerate() {
            if !(l.is_finite() && l.abs() <= 100.0) {
                return Err((
                    format!("lever_arm_b_m[{i}]"),
                    format!("expected at most 100 m, got {l}"),
                ));
            }
        }
        for (i, o) in g.outages.iter().enumerate() {
            if !(o.start_s.is_finite() && o.start_s >= 0.0) {
                return Err((format!("outage[{i}].start_s"), "expected a time ≥ 0".into()));
            }
            positive(&format!("outage[{i}].duration_s"), o.duration_s)?;
        }
        Ok(())
    }
    fn start(_: &GnssSpec) -> GnssState {
        GnssState::default()
    }
    fn sample(
        g: &GnssSpec,
        state: &mut GnssState,
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self {
        let t_s = t_ns as f64 * 1e-9;
        let c_b_e = truth.q_b_e.to_rotation_matrix().into_inner();
        let l_b = Vector3::from(g.lever_arm_b_m);
        let omega_eb_b = truth.omega_ib_b - c_b_e.transpose() * earth::omega_ie_e();
        let r_ant = truth.r_e + c_b_e * l_b;
        let v_ant = truth.v_e + c_b_e * omega_eb_b.cross(&l_b);
        let geo = earth::ecef_to_geodetic(&r_ant);
        let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
        let mut d_enu = Vector3::zeros();
        let mut dv_enu = Vector3::zeros();
        if noisy {
            // The Gauss–Markov error, exactly discretized over the time since the last draw.
            let dt = state.last_s.map_or(f64::INFINITY, |t0| t_s - t0);
            let phi = (-dt / g.gm_tau_s).exp();
            let sd = [g.gm_sigma_h_m, g.gm_sigma_h_m, g.gm_sigma_v_m];
            for (gm, sd) in state.gm_enu.iter_mut().zip(sd) {
                let w = sd * (1.0 - phi * phi).max(0.0).sqrt();
                *gm = phi * *gm + w * sensors::normal(rng);
            }
            state.last_s = Some(t_s);
            let white = [g.sigma_h_m, g.sigma_h_m, g.sigma_v_m];
            for k in 0..3 {
                d_enu[k] = state.gm_enu[k] + white[k] * sensors::normal(rng);
                dv_enu[k] = g.sigma_vel_mps * sensors::normal(rng);
            }
        }
        let r = r_ant + c_e_g.transpose() * d_enu;
        let fix = earth::ecef_to_geodetic(&r);
        // The receiver's velocity is north-east-down in the axes of its own fix.
        let v_enu = frames::c_e_g(fix.lat_rad, fix.lon_rad) * v_ant + dv_enu;
        let (h_acc, v_acc, s_acc) = g.reported();
        let outage = g
            .outages
            .iter()
            .any(|o| t_s >= o.start_s && t_s < o.start_s + o.duration_s);
        let week_ms = 7 * 86_400_000u64;
        GnssFix {
            t_ns,
            seq,
            lat_rad: fix.lat_rad,
            lon_rad: fix.lon_rad,
            height_m: fix.h_m,
            vel_ned_mps: [v_enu.y, v_enu.x, -v_enu.z],
            h_acc_m: if outage { 1e4 } else { h_acc },
            v_acc_m: if outage { 1e4 } else { v_acc },
            s_acc_mps: if outage { 100.0 } else { s_acc },
            pdop: if outage { 99.99 } else { g.pdop },
            itow_ms: ((t_ns / 1_000_000) % week_ms) as u32,
            fix_type: if outage {
                fix_type::NONE
            } else {
                fix_type::FIX_3D
            },
            num_sv: if outage { 0 } else { g.num_sv },
            flags: if outage { 0 } else { fix_flags::FIX_OK },
            _pad: 0,
        }
    }
    /// `magnitude` metres north, or a NaN latitude. Jamming and
    /// spoofing are [`crate::faults`]' own events.
    fn corrupt(&mut self, c: Corruption) {
        match c {
            Corruption::Outlier(magnitude) => self.lat_rad += magnitude / earth::A,
            Corruption::Nan => self.lat_rad = f64::NAN,
        }
    }
}

// ---- dual-antenna baseline ----------------------------------------------

/// `[baseline]`: a moving-base, dual-antenna receiver measuring the vector
/// between its antennas by carrier phase. With fixed ambiguities its error
/// is white noise of `sigma_carrier_m` per horizontal axis and
/// `sigma_vertical_m` vertically (carrier-phase double differences of a
/// short baseline: a few millimetres, the vertical worse by the geometry),
/// so its heading σ is σ_carrier / L for a level baseline of length L
/// (3 mm over 1 m: 0.17°; over 2.5 m: 0.07°). With probability
/// `float_probability` an epoch has float ambiguities only: the error is
/// then `sigma_float_m` per axis, and the receiver says so (carrSoln 1).
/// It reports its own σ as its accuracies, and its fix's latitude and
/// longitude (the primary antenna's, error-free: the NED axes are those
/// it reports, whatever its position error, so the error would not show).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaselineSpec {
    pub rate_hz: f64,
    /// The primary (moving-base) and secondary antennas, body axes (m).
    #[serde(default = "baseline_defaults::primary")]
    pub primary_antenna_b_m: [f64; 3],
    #[serde(default = "baseline_defaults::secondary")]
    pub secondary_antenna_b_m: [f64; 3],
    /// Fixed solution: 1-σ per horizontal axis and vertical (m).
    #[serde(default = "baseline_defaults::sigma_carrier")]
    pub sigma_carrier_m: f64,
    #[serde(default = "baseline_defaults::sigma_vertical")]
    pub sigma_vertical_m: f64,
    /// Probability of an epoch with float ambiguities, and its 1-σ per axis (m).
    #[serde(default)]
    pub float_probability: f64,
    #[serde(default = "baseline_defaults::sigma_float")]
    pub sigma_float_m: f64,
    /// Windows without a carrier solution (as GNSS's outages).
    #[serde(default, rename = "outage")]
    pub outages: Vec<GnssOutage>,
}

mod baseline_defaults {
    pub fn primary() -> [f64; 3] {
        [0.0, -0.5, 0.0]
    }
    pub fn secondary() -> [f64; 3] {
        [0.0, 0.5, 0.0]
    }
    /// A few millimetres: the carrier-phase σ of a short fixed baseline.
    pub fn sigma_carrier() -> f64 {
        0.003
    }
    pub fn sigma_vertical() -> f64 {
        0.006
    }
    pub fn sigma_float() -> f64 {
        0.3
    }
}

impl BaselineSpec {
    /// The heading σ of a level baseline (rad): σ_carrier / L.
    pub fn heading_sigma_rad(&self) -> f64 {
        let l = (Vector3::from(self.secondary_antenna_b_m)
            - Vector3::from(self.primary_antenna_b_m))
        .norm();
        self.sigma_carrier_m / l
    }
}

impl SimAid for BaselineSample {
    type Spec = BaselineSpec;
    type State = ();
    /// Stream 12 (its navlog record's index; the faults have 7): a
    /// scenario with `[baseline]` has every other sample exactly as the
    /// same scenario without.
    const OWN_STREAM: Option<u64> = Some(12);
    fn rate_hz(spec: &BaselineSpec) -> f64 {
        spec.rate_hz
    }
    fn validate(b: &BaselineSpec) -> Result<(), (String, String)> {
        positive("rate_hz", b.rate_hz)?;
        for (key, a) in [
            ("primary_antenna_b_m", b.primary_antenna_b_m),
            ("secondary_antenna_b_m", b.secondary_antenna_b_m),
        ] {
            for (i, l) in a.iter().enumerate() {
                if !(l.is_finite() && l.abs() <= 100.0) {
                    return Err((
                        format!("{key}[{i}]"),
                        format!("expected at most 100 m, got {l}"),
                    ));
                }
            }
        }
        let l =
            (Vector3::from(b.secondary_antenna_b_m) - Vector3::from(b.primary_antenna_b_m)).norm();
        if l < 0.1 {
            return Err((
                "secondary_antenna_b_m".into(),
                format!("the antennas are {l} m apart: at least 0.1 m"),
            ));
        }
        for (k, v) in [
            ("sigma_carrier_m", b.sigma_carrier_m),
            ("sigma_vertical_m", b.sigma_vertical_m),
            ("sigma_float_m", b.sigma_float_m),
        ] {
            if !(v.is_finite() && (1e-4..=10.0).contains(&v)) {
                return Err((k.into(), format!("expected a 1-σ in [1e-4, 10] m, got {v}")));
            }
        }
        if !(b.float_probability.is_finite() && (0.0..=1.0).contains(&b.float_probability)) {
            return Err((
                "float_probability".into(),
                format!(
                    "expected a probability in [0, 1], got {}",
                    b.float_probability
                ),
            ));
        }
        for (i, o) in b.outages.iter().enumerate() {
            if !(o.start_s.is_finite() && o.start_s >= 0.0) {
                return Err((format!("outage[{i}].start_s"), "expected a time ≥ 0".into()));
            }
            positive(&format!("outage[{i}].duration_s"), o.duration_s)?;
        }
        Ok(())
    }
    fn start(_: &BaselineSpec) {}
    fn sample(
        b: &BaselineSpec,
        _: &mut (),
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self {
        let t_s = t_ns as f64 * 1e-9;
        let c_b_e = truth.q_b_e.to_rotation_matrix().into_inner();
        let a1 = Vector3::from(b.primary_antenna_b_m);
        let a2 = Vector3::from(b.secondary_antenna_b_m);
        let fix = earth::ecef_to_geodetic(&(truth.r_e + c_b_e * a1));
        let mut enu = frames::c_e_g(fix.lat_rad, fix.lon_rad) * (c_b_e * (a2 - a1));
        // Every epoch draws the same numbers, float or not, so that an
        // epoch's noise does not depend on the ones before.
        let u: f64 = rand::Rng::r#gen(rng);
        let w = [
            sensors::normal(rng),
            sensors::normal(rng),
            sensors::normal(rng),
        ];
        let float = u < b.float_probability;
        let sigma = if float {
            [b.sigma_float_m; 3]
        } else {
            [b.sigma_carrier_m, b.sigma_carrier_m, b.sigma_vertical_m]
        };
        if noisy {
            for k in 0..3 {
                enu[k] += sigma[k] * w[k];
            }
        }
        let outage = b
            .outages
            .iter()
            .any(|o| t_s >= o.start_s && t_s < o.start_s + o.duration_s);
        let ned = [enu.y, enu.x, -enu.z];
        let h = enu.x.hypot(enu.y);
        let week_ms = 7 * 86_400_000u64;
        let (carr, flags) = if outage {
            (carr_soln::NO_CARRIER, 0)
        } else {
            (
                if float {
                    carr_soln::FLOAT
                } else {
                    carr_soln::FIXED
                },
                baseline_flags::GNSS_FIX_OK
                    | baseline_flags::DIFF_CORRECTED
                    | baseline_flags::REL_POS_VALID
                    | baseline_flags::IS_MOVING
                    | baseline_flags::HEADING_VALID,
            )
        };
        BaselineSample {
            t_ns,
            seq,
            lat_rad: fix.lat_rad,
            lon_rad: fix.lon_rad,
            rel_pos_ned_m: if outage { [0.0; 3] } else { ned },
            length_m: if outage { 0.0 } else { enu.norm() },
            heading_rad: if outage {
                0.0
            } else {
                enu.x.atan2(enu.y).rem_euclid(std::f64::consts::TAU)
            },
            acc_heading_rad: if outage {
                std::f64::consts::PI
            } else {
                (sigma[0] / h).min(std::f64::consts::PI)
            },
            acc_ned_m: [sigma[1], sigma[0], sigma[2]],
            itow_ms: ((t_ns / 1_000_000) % week_ms) as u32,
            carr_soln: carr,
            flags,
            _pad: 0,
        }
    }
    /// `magnitude` metres north on the baseline (the length keeps the
    /// vector's, as a receiver's wrong ambiguity fix does), or a NaN.
    fn corrupt(&mut self, c: Corruption) {
        match c {
            Corruption::Outlier(magnitude) => {
                self.rel_pos_ned_m[0] += magnitude;
                self.length_m = Vector3::from(self.rel_pos_ned_m).norm();
            }
            Corruption::Nan => self.rel_pos_ned_m[0] = f64::NAN,
        }
    }
}

// ---- magnetometer ---------------------------------------------------------

/// `[mag]`: a three-axis magnetometer. Its truth is the World Magnetic
/// Model (the same crate the navigator uses) at the true position and
/// date, turned into body axes with the true attitude, then distorted by
/// the airframe's iron, b_raw = S b + h with S = W⁻¹ of the calibration
/// `hard_iron_nt`/`soft_iron` (the truth calibration: a scenario gives its
/// navigator the same values under `[navigator] aids.mag`), plus white
/// noise of `sigma_nt` per axis. The date of t_ns = 0 is `epoch_utc`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagSpec {
    pub rate_hz: f64,
    /// White noise per axis (nT), also the σ the sample states.
    #[serde(default = "mag_defaults::sigma")]
    pub sigma_nt: f64,
    /// UTC of t_ns = 0 (RFC 3339); must lie so that the flight is within
    /// the model (2020–2029).
    pub epoch_utc: String,
    /// The airframe's hard iron h (nT, body axes).
    #[serde(default)]
    pub hard_iron_nt: [f64; 3],
    /// The calibration W = S⁻¹ (rows); identity without soft iron.
    #[serde(default = "mag_defaults::identity")]
    pub soft_iron: [[f64; 3]; 3],
    /// The local field's departure from the model (crustal anomaly, the
    /// model's own error): when true, each flight's field is turned about
    /// the local up by an angle drawn once from N(0, σ_D²), σ_D the
    /// model's declination uncertainty at the start (raised to the
    /// navigator's heading floor) — the error the navigator's heading σ
    /// accounts for. False: the field is the model's.
    #[serde(default)]
    pub local_anomaly: bool,
}

mod mag_defaults {
    pub fn sigma() -> f64 {
        100.0
    }
    pub fn identity() -> [[f64; 3]; 3] {
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    }
}

impl MagSpec {
    /// The navigator's calibration settings that match this truth.
    pub fn settings(&self) -> polarnav::aids::mag::MagSettings {
        polarnav::aids::mag::MagSettings {
            hard_iron_nt: self.hard_iron_nt,
            soft_iron: self.soft_iron,
            epoch_utc: self.epoch_utc.clone(),
            ..Default::default()
        }
    }
}

impl SimAid for MagSample {
    type Spec = MagSpec;
    /// The flight's anomaly angle (rad), drawn at its first sample.
    type State = Option<f64>;
    /// Stream 8: a scenario with `[mag]` has every other sample exactly as
    /// the same scenario without.
    const OWN_STREAM: Option<u64> = Some(8);
    fn rate_hz(spec: &MagSpec) -> f64 {
        spec.rate_hz
    }
    fn validate(g: &MagSpec) -> Result<(), (String, String)> {
        use polarnav::aids::OwnSettings;
        positive("rate_hz", g.rate_hz)?;
        positive("sigma_nt", g.sigma_nt)?;
        // The calibration's own bounds (the navigator's), named as here.
        g.settings()
            .validate("scenario", "mag")
            .map_err(|e| (e.key.trim_start_matches("mag.").to_owned(), e.message))
    }
    fn start(_: &MagSpec) -> Option<f64> {
        None
    }
    fn sample(
        g: &MagSpec,
        anomaly: &mut Option<f64>,
        rng: &mut ChaCha20Rng,
        t_ns: u64,
        seq: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Self {
        use polarnav::aids::mag;
        let settings = g.settings();
        let geo = earth::ecef_to_geodetic(&truth.r_e);
        // Outside the model (a date the scenario did not set) the sensor
        // still reads a field; NaN makes it refused as invalid.
        let model = mag::date_of(t_ns, &settings).and_then(|d| mag::model_field(&geo, d));
        if anomaly.is_none() {
            *anomaly = Some(match &model {
                Ok(f) if g.local_anomaly && noisy => {
                    let sigma_d = f
                        .sigma_declination_rad
                        .max(settings.sigma_heading_floor_deg.to_radians());
                    sigma_d * sensors::normal(rng)
                }
                _ => 0.0,
            });
        }
        let d = anomaly.unwrap_or(0.0);
        // The horizontal field turned clockwise by d: the declination grows by d.
        let (sd, cd) = d.sin_cos();
        let b_e = model.map_or(Vector3::repeat(f64::NAN), |f| {
            let b = f.b_enu_nt;
            let turned = Vector3::new(b.x * cd + b.y * sd, -b.x * sd + b.y * cd, b.z);
            frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose() * turned
        });
        let b = truth.q_b_e.inverse() * b_e;
        let s = settings
            .w()
            .try_inverse()
            .unwrap_or_else(nalgebra::Matrix3::identity);
        let mut raw = s * b + Vector3::from(g.hard_iron_nt);
        if noisy {
            for x in raw.iter_mut() {
                *x += g.sigma_nt * sensors::normal(rng);
            }
        }
        MagSample {
            t_ns,
            seq,
            field_b_nt: raw.into(),
            sigma_nt: [g.sigma_nt; 3],
        }
    }
    /// `magnitude` nT added along body x (a disturbance), or a NaN.
    fn corrupt(&mut self, c: Corruption) {
        match c {
            Corruption::Outlier(magnitude) => self.field_b_nt[0] += magnitude,
            Corruption::Nan => self.field_b_nt[0] = f64::NAN,
        }
    }
}

// ---- every aid of a flight -------------------------------------------------

/// A gross error applied to a sample, whatever the aid.
pub fn corrupt(sample: &mut AidSample, c: Corruption) {
    msgs::match_aid!(sample, x => SimAid::corrupt(x, c));
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::AidPayload;
    use polarnav::aids::baseline::{self as model, BaselineSettings, cause};
    use polarnav::aids::{Aid, AidError, Levelled};
    use polarnav::earth::Geodetic;
    use polarnav::mech::{AnyNav, FrameKind};
    use rand::SeedableRng;

    fn spec(float_probability: f64) -> BaselineSpec {
        BaselineSpec {
            rate_hz: 5.0,
            primary_antenna_b_m: [0.1, -1.2, 0.3],
            secondary_antenna_b_m: [0.1, 0.8, 0.3],
            sigma_carrier_m: 0.003,
            sigma_vertical_m: 0.006,
            float_probability,
            sigma_float_m: 0.3,
            outages: vec![GnssOutage {
                start_s: 100.0,
                duration_s: 10.0,
            }],
        }
    }

    /// The core's settings with the simulator's antennas.
    fn settings_of(b: &BaselineSpec) -> BaselineSettings {
        BaselineSettings {
            primary_antenna_b_m: b.primary_antenna_b_m,
            secondary_antenna_b_m: b.secondary_antenna_b_m,
            ..Default::default()
        }
    }

    fn truth_at(lat: f64, lon: f64, heading: f64) -> TruthSample {
        let geo = Geodetic::from_deg(lat, lon, 1_500.0);
        let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
        TruthSample {
            r_e: earth::geodetic_to_ecef(&geo),
            v_e: c_e_g.transpose() * Vector3::new(30.0, 40.0, 0.0),
            q_b_e: frames::quat_from_dcm(
                &(c_e_g.transpose() * frames::c_b_n_from_euler(heading, 0.03, -0.02)),
            ),
            omega_ib_b: Vector3::zeros(),
        }
    }

    /// The simulator's error-free baseline is what the core's model
    /// predicts (z = 0, in g and in G over the exact pole), and the
    /// heading the core aligns to from it is the truth's.
    #[test]
    fn the_core_model_finds_no_innovation_in_an_error_free_simulated_baseline() {
        let b = spec(0.0);
        let g = settings_of(&b);
        let mut rng = ChaCha20Rng::seed_from_u64(1);
        for (kind, lat, lon) in [
            (FrameKind::Geographic, 47.0, 8.0),
            (FrameKind::Grid, 90.0, 0.0),
            (FrameKind::Grid, -90.0, 0.0),
        ] {
            let t = truth_at(lat, lon, 0.7);
            let s = BaselineSample::sample(&b, &mut (), &mut rng, 1_000_000_000, 0, &t, false);
            let nav = AnyNav::from_frame_free(kind, &t.r_e, &t.v_e, &t.q_b_e);
            let m = model::measurement(&nav, &s, &g).expect("a fixed baseline");
            assert!(m.z.amax() < 1e-9, "{kind:?} {lat}: z {}", m.z);
            let geo = Geodetic::from_deg(lat, lon, 1_500.0);
            let c_b_g =
                frames::c_e_g(geo.lat_rad, geo.lon_rad) * t.q_b_e.to_rotation_matrix().into_inner();
            let (_, pitch, roll) = frames::euler_from_c_b_n(&c_b_g);
            let level = Levelled {
                c_b_l: frames::c_b_n_from_euler(0.0, pitch, roll),
                sigma_tilt_rad: 0.0,
                geo,
                t_ns: 1,
            };
            let fix = s
                .align_heading(&level, &g)
                .expect("heading aid")
                .expect("heading");
            assert!((fix.heading_rad - 0.7).abs() < 1e-9, "{}", fix.heading_rad);
        }
    }

    /// Heading σ from the baseline length: over 4000 epochs the spread of
    /// the baseline's azimuth is σ_carrier / L (3 mm over 2 m: 1.5 mrad)
    /// within 5 %, the receiver reports it as its heading accuracy, and the
    /// float epochs come at their probability and are refused by the core.
    #[test]
    fn heading_sigma_is_the_carrier_sigma_over_the_baseline_length() {
        let b = BaselineSpec {
            outages: vec![],
            ..spec(0.2)
        };
        let g = settings_of(&b);
        let t = truth_at(60.0, 20.0, 2.0);
        let want = b.heading_sigma_rad();
        assert!((want - 0.0015).abs() < 1e-12);
        let exact = BaselineSample::sample(
            &b,
            &mut (),
            &mut ChaCha20Rng::seed_from_u64(0),
            0,
            0,
            &t,
            false,
        );
        let az0 = exact.rel_pos_ned_m[1].atan2(exact.rel_pos_ned_m[0]);
        let nav = AnyNav::from_frame_free(FrameKind::Geographic, &t.r_e, &t.v_e, &t.q_b_e);
        let mut rng = ChaCha20Rng::seed_from_u64(30);
        let (mut n_fixed, mut n_float, mut sum2) = (0usize, 0usize, 0.0);
        for k in 0..4000u64 {
            let s = BaselineSample::sample(&b, &mut (), &mut rng, k * 200_000_000, k, &t, true);
            assert_eq!(s.seq(), k);
            if s.carr_soln == carr_soln::FIXED {
                n_fixed += 1;
                let e = s.rel_pos_ned_m[1].atan2(s.rel_pos_ned_m[0]) - az0;
                sum2 += e * e;
                assert!((s.acc_heading_rad / want - 1.0).abs() < 0.01);
                assert!(model::measurement(&nav, &s, &g).is_ok());
            } else {
                n_float += 1;
                assert_eq!(s.carr_soln, carr_soln::FLOAT);
                assert!(matches!(
                    model::measurement(&nav, &s, &g),
                    Err(AidError::Refused {
                        cause: cause::NOT_FIXED,
                        ..
                    })
                ));
            }
        }
        let rms = (sum2 / n_fixed as f64).sqrt();
        let p = n_float as f64 / 4000.0;
        eprintln!(
            "simulated baseline: heading RMS {rms:e} rad for σ_carrier/L {want:e}; float fraction {p}"
        );
        assert!((rms / want - 1.0).abs() < 0.05, "{rms} vs {want}");
        // 0.2 ± 3σ of a binomial fraction over 4000 (σ 0.0063).
        assert!((p - 0.2).abs() < 0.019, "{p}");
    }

    /// An outage is no carrier solution, which the core refuses.
    #[test]
    fn an_outage_has_no_carrier_solution() {
        let b = spec(0.0);
        let t = truth_at(10.0, 0.0, 1.0);
        let nav = AnyNav::from_frame_free(FrameKind::Geographic, &t.r_e, &t.v_e, &t.q_b_e);
        let mut rng = ChaCha20Rng::seed_from_u64(2);
        let s = BaselineSample::sample(&b, &mut (), &mut rng, 105_000_000_000, 0, &t, true);
        assert_eq!(s.carr_soln, carr_soln::NO_CARRIER);
        assert_eq!(s.flags & baseline_flags::REL_POS_VALID, 0);
        let e = model::measurement(&nav, &s, &settings_of(&b)).expect_err("outage");
        assert_eq!(e.cause(), cause::NOT_FIXED, "{e}");
        assert!(BaselineSample::validate(&b).is_ok());
        for (bad, key) in [
            (
                BaselineSpec {
                    float_probability: 1.5,
                    ..spec(0.0)
                },
                "float_probability",
            ),
            (
                BaselineSpec {
                    sigma_carrier_m: 0.0,
                    ..spec(0.0)
                },
                "sigma_carrier_m",
            ),
            (
                BaselineSpec {
                    secondary_antenna_b_m: [0.1, -1.15, 0.3],
                    ..spec(0.0)
                },
                "secondary_antenna_b_m",
            ),
            (
                BaselineSpec {
                    primary_antenna_b_m: [f64::NAN, 0.0, 0.0],
                    ..spec(0.0)
                },
                "primary_antenna_b_m[0]",
            ),
        ] {
            assert_eq!(BaselineSample::validate(&bad).expect_err(key).0, key);
        }
    }
}
