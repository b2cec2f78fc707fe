//! `sensor-replay simulate`: a scenario → a navlog of IMU, aids, init and truth.

use std::io::Write;

use msgs::navlog::{Header, NavlogWriter, Record, RecordSink, TruthBias, WriteError};
use msgs::{AidKind, AidSample, ImuSample, InitState, PerAid, TruthRecord};
use nalgebra::{UnitQuaternion, Vector3};
use polarnav::earth;
use polarnav::frames;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

use crate::aids::SimAid;
use crate::scenario::{Scenario, SpecOf};
use crate::sensors::{self, ImuErrorModel};
use crate::trajectory::{Flight, TruthSample};

/// Options of one simulation run.
#[derive(Debug, Clone, Copy)]
pub struct SimOptions {
    pub seed: u64,
    /// Error-free sensors and initial state (aid σ still reported as configured).
    pub perfect: bool,
    /// RK4 steps per IMU interval: one by default, whose increments differ
    /// from eight's by 1e-6 of the IMU noise of one sample (test
    /// `one_rk4_step_per_sample_is_the_truth_of_eight`); two cost a third
    /// of a campaign's run more.
    pub substeps: usize,
    /// Inject the scenario's `[faults]` (off: the fault-free reference flight).
    pub faults: bool,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            perfect: false,
            faults: true,
            substeps: 1,
        }
    }
}

/// Counts of what was written.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SimSummary {
    pub imu: u64,
    /// Samples of each aid.
    pub aids: PerAid<u64>,
    pub truth: u64,
    pub duration_ns: u64,
    /// Samples affected by each `[[faults.event]]`, in order.
    pub injected: Vec<u64>,
}

/// Converts a truth sample to its record.
pub fn truth_record(t_ns: u64, t: &TruthSample) -> TruthRecord {
    let q = t.q_b_e.into_inner();
    TruthRecord {
        t_ns,
        r_e_m: t.r_e.into(),
        v_e_mps: t.v_e.into(),
        q_b_e: [q.w, q.i, q.j, q.k],
    }
}

/// The true IMU bias record at `t_ns` (zero for error-free sensors).
pub fn truth_bias_record(t_ns: u64, imu: &ImuErrorModel, perfect: bool) -> TruthBias {
    let (g, a) = if perfect {
        (Vector3::zeros(), Vector3::zeros())
    } else {
        imu.bias()
    };
    TruthBias {
        t_ns,
        gyro_bias_rps: g.into(),
        accel_bias_mps2: a.into(),
    }
}

/// Initial errors drawn per axis in the local level frame.
#[derive(Debug, Clone, Copy)]
pub struct InitErrors {
    pub pos_h_m: f64,
    pub pos_v_m: f64,
    pub vel_h_mps: f64,
    pub vel_v_mps: f64,
    pub tilt_rad: f64,
    pub heading_rad: f64,
}

/// The init record: truth plus errors drawn from σ (zero errors when `rng` is None).
pub fn init_record(
    t_ns: u64,
    truth: &TruthSample,
    sig: &InitErrors,
    rng: Option<&mut ChaCha20Rng>,
) -> InitState {
    let geo = earth::ecef_to_geodetic(&truth.r_e);
    let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let (dp, dv, phi) = match rng {
        Some(rng) => {
            let mut n = || sensors::normal(rng);
            (
                Vector3::new(sig.pos_h_m * n(), sig.pos_h_m * n(), sig.pos_v_m * n()),
                Vector3::new(
                    sig.vel_h_mps * n(),
                    sig.vel_h_mps * n(),
                    sig.vel_v_mps * n(),
                ),
                Vector3::new(
                    sig.tilt_rad * n(),
                    sig.tilt_rad * n(),
                    sig.heading_rad * n(),
                ),
            )
        }
        None => (Vector3::zeros(), Vector3::zeros(), Vector3::zeros()),
    };
    let c_g_e = c_e_g.transpose();
    let r = truth.r_e + c_g_e * dp;
    let v = truth.v_e + c_g_e * dv;
    // Computed attitude C_b^c = (I − φ×) C_b^n, φ in g, applied as an exact rotation.
    let q_err = UnitQuaternion::from_scaled_axis(c_g_e * -phi);
    let q = (q_err * truth.q_b_e).into_inner();
    InitState {
        t_ns,
        seq: 0,
        r_e_m: r.into(),
        v_e_mps: v.into(),
        q_b_e: [q.w, q.i, q.j, q.k],
        sigma_pos_h_m: sig.pos_h_m,
        sigma_pos_v_m: sig.pos_v_m,
        sigma_vel_h_mps: sig.vel_h_mps,
        sigma_vel_v_mps: sig.vel_v_mps,
        sigma_tilt_rad: sig.tilt_rad,
        sigma_heading_rad: sig.heading_rad,
        ..Default::default()
    }
}

fn period_ns(rate_hz: f64) -> u64 {
    (1e9 / rate_hz).round() as u64
}

/// A periodic stream stamped at the first IMU time at or after each nominal time.
#[derive(Debug)]
pub(crate) struct Schedule {
    period_ns: u64,
    next_ns: u64,
    pub(crate) seq: u64,
}

impl Schedule {
    pub(crate) fn new(rate_hz: f64) -> Self {
        let p = period_ns(rate_hz);
        Self {
            period_ns: p,
            next_ns: p,
            seq: 0,
        }
    }
    /// True (once) when a sample is due at or before `t_ns`.
    pub(crate) fn due(&mut self, t_ns: u64) -> bool {
        if t_ns >= self.next_ns {
            while self.next_ns <= t_ns {
                self.next_ns += self.period_ns;
            }
            self.seq += 1;
            true
        } else {
            false
        }
    }
}

/// One aid of a flight: its section, state, schedule and generator.
trait Stream: std::fmt::Debug {
    /// The sample due at or before `t_ns` (once per period), if one is;
    /// `truth` is asked for only when one is.
    fn step(
        &mut self,
        shared: &mut ChaCha20Rng,
        t_ns: u64,
        truth: &mut dyn FnMut() -> TruthSample,
        noisy: bool,
    ) -> Option<AidSample>;
}

#[derive(Debug)]
struct Running<A: SimAid> {
    spec: A::Spec,
    state: A::State,
    sched: Schedule,
    own_rng: Option<ChaCha20Rng>,
}

impl<A: SimAid + SpecOf> Stream for Running<A> {
    fn step(
        &mut self,
        shared: &mut ChaCha20Rng,
        t_ns: u64,
        truth: &mut dyn FnMut() -> TruthSample,
        noisy: bool,
    ) -> Option<AidSample> {
        if !self.sched.due(t_ns) {
            return None;
        }
        let truth = truth();
        let rng = self.own_rng.as_mut().unwrap_or(shared);
        let seq = self.sched.seq - 1;
        let x = A::sample(&self.spec, &mut self.state, rng, t_ns, seq, &truth, noisy);
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
                        sched: Schedule::new(P::rate_hz(spec)),
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

    /// The samples due at or before `t_ns`, in the declared order; `truth`
    /// is asked for only when one is due.
    pub fn step(
        &mut self,
        shared: &mut ChaCha20Rng,
        t_ns: u64,
        truth: &mut dyn FnMut() -> TruthSample,
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

/// The seed as a TOML value of the header's `[generated]` table: an
/// integer, or above TOML's integer range (i64) a string of its digits.
/// Written as a bare integer, a seed of 2⁶³ or more made the whole header
/// invalid TOML, and `batch` then navigated without the scenario's
/// `[navigator]` settings (its GNSS lever arm and correlated error among
/// them): half of a campaign's derived seeds did.
pub fn toml_seed(seed: u64) -> String {
    if i64::try_from(seed).is_ok() {
        seed.to_string()
    } else {
        format!("\"{seed}\"")
    }
}

/// Runs the scenario and writes the navlog.
pub fn simulate<W: Write>(
    s: &Scenario,
    scenario_text: &str,
    opts: SimOptions,
    out: W,
) -> Result<SimSummary, WriteError> {
    let (sum, w) = simulate_into(s, scenario_text, opts, |h| NavlogWriter::new(out, h))?;
    w.finish()?;
    Ok(sum)
}

/// Runs the scenario into the sink that `start` makes from the navlog's
/// header (a [`NavlogWriter`], or a [`msgs::navlog::RecordVec`] for a
/// process that navigates the flight itself); the records are those
/// [`simulate`] writes, in the same order.
pub fn simulate_into<S: RecordSink>(
    s: &Scenario,
    scenario_text: &str,
    opts: SimOptions,
    start: impl FnOnce(Header) -> Result<S, WriteError>,
) -> Result<(SimSummary, S), WriteError> {
    let mut rng = ChaCha20Rng::seed_from_u64(opts.seed);
    let mut imu_err = ImuErrorModel::new(&s.imu, &mut rng);
    let metadata = format!(
        "{scenario_text}\n\n# written by sensor-replay simulate\n[generated]\nseed = {}\nperfect = {}\ngyro_bias_rps = [{:e}, {:e}, {:e}]\naccel_bias_mps2 = [{:e}, {:e}, {:e}]\n",
        toml_seed(opts.seed),
        opts.perfect,
        imu_err.drawn.gyro_bias_rps.x,
        imu_err.drawn.gyro_bias_rps.y,
        imu_err.drawn.gyro_bias_rps.z,
        imu_err.drawn.accel_bias_mps2.x,
        imu_err.drawn.accel_bias_mps2.y,
        imu_err.drawn.accel_bias_mps2.z,
    );
    let header = Header::new(
        concat!("sensor-replay ", env!("CARGO_PKG_VERSION"), " simulate"),
        &s.name,
        opts.seed,
        &metadata,
    );
    let mut w = start(header)?;

    let mut flight = Flight::new(s, opts.substeps);
    let truth0 = flight.truth();
    let ie = &s.init_error;
    let sig = InitErrors {
        pos_h_m: ie.pos_h_m,
        pos_v_m: ie.pos_v_m,
        vel_h_mps: ie.vel_h_mps,
        vel_v_mps: ie.vel_v_mps,
        tilt_rad: (ie.tilt_arcmin / 60.0).to_radians(),
        heading_rad: (ie.heading_arcmin / 60.0).to_radians(),
    };
    let init = init_record(0, &truth0, &sig, (!opts.perfect).then_some(&mut rng));
    w.put(Record::Init(init))?;
    w.put(Record::Truth(truth_record(0, &truth0)))?;
    w.put(Record::TruthBias(truth_bias_record(
        0,
        &imu_err,
        opts.perfect,
    )))?;

    let dt_ns = period_ns(s.imu.rate_hz);
    let n = (s.duration_s() * 1e9 / dt_ns as f64).floor() as u64;
    let mut truth_sched = Schedule::new(s.truth.rate_hz);
    let mut aids = Streams::new(s, opts.seed);
    let mut sum = SimSummary::default();
    let noisy = !opts.perfect;
    let mut inject =
        crate::faults::Injector::new(s.faults.as_ref().filter(|_| opts.faults), opts.seed);
    // Written records count as published; a faulted sample may be written 0, 1 or 2 times.
    let put = |w: &mut S, r: Record, times: u32| -> Result<u64, WriteError> {
        if times > 0 {
            for _ in 1..times {
                w.put(r.clone())?;
            }
            w.put(r)?;
        }
        Ok(u64::from(times))
    };

    for k in 1..=n {
        let t_ns = k * dt_ns;
        let dt = dt_ns as f64 * 1e-9;
        let (d_theta, d_v) = flight.advance_to(t_ns as f64 * 1e-9);
        let (d_theta, d_v) = if noisy {
            imu_err.corrupt(&mut rng, d_theta, d_v, dt)
        } else {
            (d_theta, d_v)
        };
        let mut imu = ImuSample {
            t_ns,
            seq: k - 1,
            dt_s: dt,
            d_theta_rad: d_theta.into(),
            d_v_mps: d_v.into(),
        };
        let times = inject.imu(&mut imu);
        sum.imu += put(&mut w, Record::Imu(imu), times)?;

        // The truth at this sample, formed only when an aid or the truth
        // record needs it (at their rates, not the IMU's: a ninth of the
        // simulator's kinematics at 200 Hz).
        let mut truth_now: Option<TruthSample> = None;
        let mut truth = || *truth_now.get_or_insert_with(|| flight.truth());
        let mut written = Ok(());
        aids.step(&mut rng, t_ns, &mut truth, noisy, |mut x| {
            let times = inject.aid(&mut x);
            let kind = x.kind();
            match put(&mut w, Record::aid(x), times) {
                Ok(n) => sum.aids[kind] += n,
                Err(e) => written = Err(e),
            }
        });
        written?;
        if truth_sched.due(t_ns) || k == n {
            w.put(Record::Truth(truth_record(t_ns, &truth())))?;
            w.put(Record::TruthBias(truth_bias_record(
                t_ns,
                &imu_err,
                opts.perfect,
            )))?;
            sum.truth += 1;
        }
        sum.duration_ns = t_ns;
    }
    sum.injected = inject.injected;
    Ok((sum, w))
}

#[cfg(test)]
mod seed_tests {
    use super::*;

    /// The records a campaign's run navigates ([`simulate_into`] with a
    /// [`msgs::navlog::RecordVec`]) are those a reader of the navlog that
    /// [`simulate`] writes returns, record for record, with every stream,
    /// a sample written twice, one dropped and one sent back in time.
    #[test]
    fn a_run_navigates_the_records_a_navlog_would_hold() {
        let text = "name = \"x\"\n[start]\nlat_deg = 89.9\nlon_deg = 10.0\nh_m = 18000.0\nheading_deg = 0.0\nspeed_mps = 250.0\n\
            [imu]\nrate_hz = 200.0\ngyro_bias_dph = 0.01\naccel_bias_ug = 100.0\narw_dpsh = 0.001\nvrw_ug_psqhz = 10.0\n\
            [srs]\nrate_hz = 1.0\nsigma_mps = 0.5\nelevation_mask_deg = 10.0\n[cns]\nrate_hz = 1.0\nsigma_m = 20.0\n\
            [baro]\nrate_hz = 10.0\nsigma_m = 10.0\n[star]\nrate_hz = 1.0\nsigma_arcsec = 5.0\n\
            [gnss]\nrate_hz = 5.0\nsigma_h_m = 1.0\nsigma_v_m = 2.0\n\
            [[segment]]\nkind = \"cruise\"\nduration_s = 12.0\n\
            [[faults.event]]\nkind = \"duplicate\"\nstream = \"imu\"\nstart_s = 2.0\nduration_s = 0.1\n\
            [[faults.event]]\nkind = \"outage\"\nstream = \"baro\"\nstart_s = 3.0\nduration_s = 1.0\n\
            [[faults.event]]\nkind = \"time_jump\"\nstream = \"imu\"\nstart_s = 5.0\nduration_s = 0.2\nmagnitude = 0.5\n";
        let s = Scenario::parse(text, "x").expect("scenario");
        let opts = SimOptions {
            seed: 3,
            faults: true,
            ..Default::default()
        };
        let mut log = Vec::new();
        let written = simulate(&s, text, opts, &mut log).expect("simulate");
        let (read, report) = msgs::navlog::read_all(&log);
        assert!(report.is_clean(), "{report}");
        let (kept, msgs::navlog::RecordVec(records)) =
            simulate_into(&s, text, opts, |h| Ok(msgs::navlog::RecordVec::new(h)))
                .expect("simulate_into");
        assert_eq!(written, kept);
        assert!(
            written.injected.len() == 3 && written.injected.iter().all(|&n| n > 0),
            "{written:?}"
        );
        for kind in AidKind::ALL {
            if kind != AidKind::Baseline && kind != AidKind::Mag {
                assert!(written.aids[kind] > 0, "no {kind:?} in {written:?}");
            }
        }
        assert_eq!(read.len(), records.len());
        for (i, (a, b)) in read.iter().zip(&records).enumerate() {
            assert_eq!(a, b, "record {i}");
        }
    }

    /// A header written with any seed, 2⁶³ and above included, is TOML
    /// whose `[navigator]` settings `batch` applies (before, a seed of 2⁶³
    /// or more dropped them silently: the GNSS lever arm and the
    /// receiver's correlated error of half a campaign's flights).
    #[test]
    fn a_header_keeps_its_navigator_settings_for_every_seed() {
        let text = "name = \"x\"\n[start]\nlat_deg = 85.0\nlon_deg = 0.0\nh_m = 18000.0\nheading_deg = 0.0\nspeed_mps = 250.0\n[navigator]\nswitch_enter_deg = 88.0\n[[segment]]\nkind = \"cruise\"\nduration_s = 1.0\n";
        let s = Scenario::parse(text, "x").expect("scenario");
        for seed in [
            0,
            1,
            i64::MAX as u64,
            1 << 63,
            12_836_938_113_049_135_532,
            u64::MAX,
        ] {
            let mut log = Vec::new();
            simulate(
                &s,
                text,
                SimOptions {
                    seed,
                    ..Default::default()
                },
                &mut log,
            )
            .expect("simulate");
            let (records, report) = msgs::navlog::read_all(&log);
            assert!(report.is_clean());
            let meta = msgs::navlog::header_metadata(&records).expect("header");
            let table: toml::Table = meta
                .parse()
                .unwrap_or_else(|e| panic!("seed {seed}: header is not TOML: {e}"));
            let written = &table["generated"]["seed"];
            let back: u64 = match written {
                toml::Value::Integer(i) => u64::try_from(*i).expect("non-negative"),
                toml::Value::String(s) => s.parse().expect("digits"),
                v => panic!("seed {seed} written as {v}"),
            };
            assert_eq!(back, seed);
            let o = polarnav_config::ScenarioOverrides::from_metadata(meta)
                .expect("valid")
                .unwrap_or_else(|| panic!("seed {seed}: the header's [navigator] was dropped"));
            assert!(
                o.assignments()
                    .iter()
                    .any(|(k, _)| k == "frame.switch_enter_deg"),
                "seed {seed}"
            );
        }
    }
}
