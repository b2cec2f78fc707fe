//! Each aid's simulator model: its scenario section `[NAME]` (optional: a
//! scenario without it has no such stream) and its samples made from the
//! truth. One impl of [`SimAid`] per aid; which aids exist is the
//! declaration's (`msgs::aids`), and [`Streams`] runs every aid of a
//! scenario, in the declared order, at each IMU epoch.

use msgs::{AidKind, AidPayload, AidSample, BaroSample, CnsFix, SrsSample, StarSample};
use polarnav::earth::{self, isa};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use serde::de::DeserializeOwned;

use crate::faults::FaultKind;
use crate::scenario::{BaroSpec, CnsSpec, Scenario, SpecOf, SrsSpec, StarSpec};
use crate::sensors::{self, Body};
use crate::trajectory::TruthSample;

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
    /// An `outliers` fault of `magnitude` (the aid's unit, see
    /// [`crate::faults`]) or a `nan` fault, applied to the sample.
    fn fault(&mut self, kind: FaultKind, magnitude: f64);
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
            spec.bodies.iter().map(Body::from_spec).collect()
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
    fn fault(&mut self, kind: FaultKind, magnitude: f64) {
        let line = &mut self.lines[0];
        match kind {
            FaultKind::Outliers => {
                line.measured_wavelength_m += line.rest_wavelength_m * magnitude / 299_792_458.0
            }
            FaultKind::Nan => line.measured_wavelength_m = f64::NAN,
            _ => {}
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
    fn fault(&mut self, kind: FaultKind, magnitude: f64) {
        match kind {
            FaultKind::Outliers => self.lat_rad += magnitude / earth::A,
            FaultKind::Nan => self.lat_rad = f64::NAN,
            _ => {}
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
    fn fault(&mut self, kind: FaultKind, magnitude: f64) {
        match kind {
            FaultKind::Outliers => {
                let h = isa::pressure_altitude(self.pressure_pa);
                self.pressure_pa = isa::pressure(h + magnitude);
            }
            FaultKind::Nan => self.pressure_pa = f64::NAN,
            _ => {}
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
        sensors::star_sample(rng, t_ns, seq, &truth.q_b_e, spec, noisy)
    }
    /// A rotation of `magnitude` arcsec about body x (stray light), or a
    /// NaN quaternion w.
    fn fault(&mut self, kind: FaultKind, magnitude: f64) {
        match kind {
            FaultKind::Outliers => {
                let [w, x, y, z] = self.q_b_i;
                let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    w, x, y, z,
                ));
                let err = nalgebra::UnitQuaternion::from_scaled_axis(
                    nalgebra::Vector3::x() * (magnitude * polarnav::aids::star::ARCSEC_RAD),
                );
                let q = (q * err).into_inner();
                self.q_b_i = [q.w, q.i, q.j, q.k];
            }
            FaultKind::Nan => self.q_b_i[0] = f64::NAN,
            _ => {}
        }
    }
}

// ---- every aid of a flight -------------------------------------------------

/// A sample made from the truth, and how a fault corrupts it, whatever the aid.
pub fn fault(sample: &mut AidSample, kind: FaultKind, magnitude: f64) {
    msgs::match_aid!(sample, x => SimAid::fault(x, kind, magnitude));
}

/// One aid of a flight: its section, state, schedule and generator.
trait Stream: std::fmt::Debug {
    /// The sample due at or before `t_ns` (once per period), if one is.
    fn step(
        &mut self,
        shared: &mut ChaCha20Rng,
        t_ns: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Option<AidSample>;
}

#[derive(Debug)]
struct Running<A: SimAid> {
    spec: A::Spec,
    state: A::State,
    sched: crate::simulate::Schedule,
    own_rng: Option<ChaCha20Rng>,
}

impl<A: SimAid + SpecOf> Stream for Running<A> {
    fn step(
        &mut self,
        shared: &mut ChaCha20Rng,
        t_ns: u64,
        truth: &TruthSample,
        noisy: bool,
    ) -> Option<AidSample> {
        if !self.sched.due(t_ns) {
            return None;
        }
        let rng = self.own_rng.as_mut().unwrap_or(shared);
        let seq = self.sched.seq - 1;
        let x = A::sample(&self.spec, &mut self.state, rng, t_ns, seq, truth, noisy);
        Some(x.into())
    }
}

/// The aid streams of a scenario, in the declared order.
#[derive(Debug)]
pub struct Streams(Vec<Box<dyn Stream>>);

impl Streams {
    /// Every aid the scenario has a section for, seeded from `seed`.
    pub fn new(s: &Scenario, seed: u64) -> Self {
        let mut v: Vec<Box<dyn Stream>> = Vec::new();
        for k in AidKind::ALL {
            msgs::match_aid_kind!(k, P => {
                if let Some(spec) = P::spec(s) {
                    v.push(Box::new(Running::<P> {
                        spec: spec.clone(),
                        state: P::start(spec),
                        sched: crate::simulate::Schedule::new(P::rate_hz(spec)),
                        own_rng: P::OWN_STREAM.map(|stream| {
                            let mut r = ChaCha20Rng::seed_from_u64(seed);
                            r.set_stream(stream);
                            r
                        }),
                    }));
                }
            });
        }
        Self(v)
    }

    /// The samples due at or before `t_ns`, in the declared order.
    pub fn step(
        &mut self,
        shared: &mut ChaCha20Rng,
        t_ns: u64,
        truth: &TruthSample,
        noisy: bool,
        mut out: impl FnMut(AidSample),
    ) {
        for s in &mut self.0 {
            if let Some(x) = s.step(shared, t_ns, truth, noisy) {
                out(x);
            }
        }
    }
}
