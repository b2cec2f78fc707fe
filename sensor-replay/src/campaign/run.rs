//! One run of a campaign, in process: the variation's scenario simulated
//! with the run's seed into memory, navigated by the same session as
//! `nav-daemon batch` (the default settings, the header's, the variation's
//! command-line ones), and evaluated against the flight's truth as it
//! streams out: one [`Metrics`] row, and what it cost.
//!
//! Nothing of the flight is kept but its truth records (10 Hz) and one
//! horizontal error per compared epoch; the solutions wanted are only those
//! at the truth's times (the session builds no other).

use std::collections::HashMap;
use std::time::Instant;

use msgs::navlog::{Record, RecordVec};
use msgs::{AidKind, Solution, Stream, TruthRecord};
use polarnav::integrity::Verdict;
use polarnav::session::{Event, Input, Session, Sink};
use polarnav::smoother::{FileStore, Smoother};
use polarnav::solution_csv::Row;
use polarnav_config::{ConfigFile, effective};
use polarnav_eval::eval;
use polarnav_sim::faults::FaultKind;
use polarnav_sim::simulate::{SimOptions, simulate_into};

use super::plan::{Group, Plan, RunId, RunKind, Variation};
use super::row::{Cost, Metrics, Outcome};

const ARCMIN_PER_RAD: f64 = 60.0 * 180.0 / std::f64::consts::PI;

/// CPU seconds of this thread.
fn thread_cpu_s() -> f64 {
    cpu_time::ThreadTime::try_now().map_or(0.0, |t| t.as_duration().as_secs_f64())
}

/// CPU seconds of this process.
pub fn process_cpu_s() -> f64 {
    cpu_time::ProcessTime::try_now().map_or(0.0, |t| t.as_duration().as_secs_f64())
}

/// The peak resident memory of this process (MiB; `VmHWM`).
pub fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

/// A GNSS fault window: `[start, end + allowance)` (s of flight).
#[derive(Debug, Clone, Copy)]
struct FaultWindow {
    start_s: f64,
    end_s: f64,
}

/// The name of an injected fault kind, as the `fault` column gives it.
fn fault_name(k: FaultKind) -> &'static str {
    match k {
        FaultKind::GnssSpoof => "spoof",
        FaultKind::GnssJam => "jam",
        FaultKind::Outage => "outage",
        FaultKind::Outliers => "outliers",
        FaultKind::Nan => "nan",
        FaultKind::TimeJump => "time_jump",
        FaultKind::Duplicate => "duplicate",
    }
}

/// The session's outputs, evaluated as they come.
struct Evaluate {
    truth: HashMap<i64, TruthRecord>,
    /// With `smooth`: the forward pass's tape.
    smoother: Option<Smoother<FileStore>>,
    acc: Acc,
    resets_aid: u32,
    resets_integrity: u32,
    /// Resets per cause (the stream whose reset it was).
    causes: std::collections::BTreeMap<&'static str, u32>,
    gnss_tested: u64,
    gnss_untested: u64,
    gnss_readmissions: u64,
    /// Exclusion times (s).
    exclusions_s: Vec<f64>,
    max_q_ratio: Option<f64>,
}

/// Error statistics of the compared epochs.
#[derive(Default)]
struct Acc {
    n: u64,
    non_finite: u64,
    h: (f64, f64),
    v: (f64, f64),
    vel: (f64, f64),
    att: (f64, f64),
    nees: [f64; 3],
    /// (t s, horizontal error m) of every compared epoch, in time order.
    h_track: Vec<(f64, f64)>,
}

impl Acc {
    fn push(&mut self, s: &Solution, t: &TruthRecord) {
        let row = Row::from_solution(s);
        let e = eval::epoch_of(&row, t);
        let deg = std::f64::consts::PI / 180.0;
        let nees = |x: &nalgebra::Vector3<f64>, sig: [f64; 3]| -> f64 {
            (0..3).map(|i| (x[i] / sig[i]).powi(2)).sum()
        };
        let n = [
            nees(&e.pos_enu, row.sigma_enu_m),
            nees(&e.vel_nav, row.sigma_vel_nav_mps),
            nees(&e.att_nav, row.sigma_att_deg.map(|d| d * deg)),
        ];
        let h = e.pos_enu.xy().norm();
        let v = e.pos_enu.z.abs();
        let vel = e.vel_enu.norm();
        let att = e.att_enu.norm() * ARCMIN_PER_RAD;
        if !([h, v, vel, att].iter().chain(&n).all(|x| x.is_finite())) {
            self.non_finite += 1;
            return;
        }
        self.n += 1;
        for (acc, x) in [
            (&mut self.h, h),
            (&mut self.v, v),
            (&mut self.vel, vel),
            (&mut self.att, att),
        ] {
            acc.0 += x * x;
            acc.1 = acc.1.max(x);
        }
        for (a, x) in self.nees.iter_mut().zip(n) {
            *a += x;
        }
        self.h_track.push((s.t_ns as f64 * 1e-9, h));
    }

    fn rms(&self, a: (f64, f64)) -> Option<f64> {
        (self.n > 0).then(|| (a.0 / self.n as f64).sqrt())
    }
    fn max(&self, a: (f64, f64)) -> Option<f64> {
        (self.n > 0).then_some(a.1)
    }

    /// The horizontal error at the last compared epoch at or before `t_s`.
    fn h_at(&self, t_s: f64) -> Option<f64> {
        let i = self.h_track.partition_point(|(t, _)| *t <= t_s);
        (i > 0).then(|| self.h_track[i - 1].1)
    }
}

impl Evaluate {
    fn take(&mut self, s: &Solution) {
        if let Some(t) = self.truth.get(&eval::time_key(s.t_ns as f64 * 1e-9)) {
            let t = *t;
            self.acc.push(s, &t);
        }
    }
}

impl Sink for Evaluate {
    fn wants_solution(&mut self, t_ns: u64, _must: bool) -> bool {
        self.truth.contains_key(&eval::time_key(t_ns as f64 * 1e-9))
    }

    fn solution(&mut self, s: &Solution) {
        if self.smoother.is_none() {
            self.take(s);
        }
    }

    fn tape(&mut self, records: &[u8]) {
        if let Some(sm) = &mut self.smoother {
            sm.records(records);
        }
    }

    fn event(&mut self, e: &Event) {
        match e {
            Event::AidReset { stream, .. } => {
                self.resets_aid += 1;
                *self.causes.entry(stream.name()).or_default() += 1;
            }
            Event::Integrity {
                stream,
                t_ns,
                test,
                verdict,
                step,
                ..
            } if *stream == Stream::Aid(AidKind::Gnss) => {
                match verdict {
                    Verdict::Admit | Verdict::Exclude | Verdict::Refuse | Verdict::Readmit => {
                        self.gnss_tested += 1;
                        let r = test.ratio();
                        if r.is_finite() {
                            self.max_q_ratio = Some(self.max_q_ratio.map_or(r, |m| m.max(r)));
                        }
                    }
                    Verdict::Untested | Verdict::Unverifiable => self.gnss_untested += 1,
                }
                match verdict {
                    Verdict::Exclude => {
                        self.exclusions_s.push(*t_ns as f64 * 1e-9);
                        if step.is_some() {
                            self.resets_integrity += 1;
                            *self.causes.entry("gnss exclusion").or_default() += 1;
                        }
                    }
                    Verdict::Readmit => self.gnss_readmissions += 1,
                    _ => {}
                }
            }
            _ => {}
        }
    }
}

/// Everything of a run but its cost.
#[derive(Debug)]
pub struct Outcomes {
    pub metrics: Metrics,
    pub simulate_cpu_s: f64,
    pub navigate_cpu_s: f64,
    pub evaluate_cpu_s: f64,
}

impl Outcomes {
    /// The outcome of a run that produced no metrics, with why.
    pub fn failed(plan: &Plan, id: RunId, reason: String) -> Self {
        let v = &plan.variations[id.variation];
        Outcomes {
            metrics: Metrics::failed(
                id.index,
                id.variation as u32,
                &v.label,
                &v.scenario.name,
                id.seed,
                reason,
            ),
            simulate_cpu_s: 0.0,
            navigate_cpu_s: 0.0,
            evaluate_cpu_s: 0.0,
        }
    }
}

/// Runs run `id` of `plan` and returns its row. Errors (a scenario that
/// cannot be simulated, a log that cannot be navigated) become a failure
/// row; a panic is the caller's to catch ([`run_caught`]).
pub fn run(plan: &Plan, id: RunId) -> Outcomes {
    let v = &plan.variations[id.variation];
    let failed = |reason: String| Outcomes::failed(plan, id, reason);
    let cpu0 = thread_cpu_s();
    // The records themselves, not a navlog's bytes: framing them and
    // decoding them again cost a tenth of a run, and give the same values
    // (test `a_run_navigates_the_records_a_navlog_would_hold`).
    let (sim, RecordVec(records)) = match simulate_into(
        &v.scenario,
        &v.text,
        SimOptions {
            seed: id.seed,
            faults: true,
            ..Default::default()
        },
        |h| Ok(RecordVec::new(h)),
    ) {
        Ok(s) => s,
        Err(e) => return failed(format!("simulation failed: {e}")),
    };
    let cpu_sim = thread_cpu_s() - cpu0;
    let mut o = match navigate(plan, v, id, &records, sim.duration_ns) {
        Ok(o) => o,
        Err(e) => return failed(e),
    };
    o.simulate_cpu_s = cpu_sim;
    if plan.run.kind == RunKind::FaultJudge {
        let cpu1 = thread_cpu_s();
        match super::faults::run_scenario_text(&v.scenario, &v.text, id.seed) {
            Ok(r) => {
                o.metrics.judgement_pass = Some(r.ok());
                o.metrics.judgement_failures = Some(r.failures().join("; "));
            }
            Err(e) => return failed(format!("the fault-free twin: {e}")),
        }
        o.navigate_cpu_s += thread_cpu_s() - cpu1;
    }
    o
}

/// [`run`], with a panic turned into a failure row that carries its message.
pub fn run_caught(plan: &Plan, id: RunId) -> Outcomes {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(plan, id))) {
        Ok(o) => o,
        Err(p) => {
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic without a message".into());
            Outcomes::failed(plan, id, format!("panicked: {msg}"))
        }
    }
}

fn navigate(
    plan: &Plan,
    v: &Variation,
    id: RunId,
    records: &[Record],
    duration_ns: u64,
) -> Result<Outcomes, String> {
    let cpu0 = thread_cpu_s();
    let metadata = msgs::navlog::header_metadata(records);
    let eff =
        effective(&ConfigFile::defaults(), metadata, &v.overrides).map_err(|e| e.to_string())?;
    // The truth compared with: every record, or the first of every `every_s`.
    let every_ns = (plan.run.every_s * 1e9).round() as u64;
    let mut truth = HashMap::new();
    let mut next_ns = 0u64;
    for r in records {
        if let Record::Truth(t) = r
            && t.t_ns >= next_ns
        {
            truth.insert(eval::truth_key(t), *t);
            if every_ns > 0 {
                next_ns = t.t_ns.saturating_add(every_ns);
            }
        }
    }
    let mut sink = Evaluate {
        truth,
        smoother: match plan.run.smooth {
            true => Some(Smoother::new(
                FileStore::new_in(&std::env::temp_dir())
                    .map_err(|e| format!("the smoother's temporary file: {e}"))?,
            )),
            false => None,
        },
        acc: Acc::default(),
        resets_aid: 0,
        resets_integrity: 0,
        causes: Default::default(),
        gnss_tested: 0,
        gnss_untested: 0,
        gnss_readmissions: 0,
        exclusions_s: Vec::new(),
        max_q_ratio: None,
    };
    let mut session = Session::new(eff.session());
    if plan.run.smooth {
        session.keep_smoother_tape();
    }
    for r in records {
        if let Some(input) = Input::from_record(r) {
            session.push(input, &mut sink);
        }
    }
    session.finish(&mut sink);
    let status = session.status();
    let covariance_repairs = session.navigator().map(|n| n.covariance_repairs());
    let cpu_nav = thread_cpu_s() - cpu0;
    let cpu1 = thread_cpu_s();
    if let Some(sm) = sink.smoother.take() {
        let mut smoothed = Vec::new();
        sm.finish(|s| {
            smoothed.push(*s);
            Ok(())
        })
        .map_err(|e| format!("smoothing failed: {e}"))?;
        for s in &smoothed {
            sink.take(s);
        }
    }
    if covariance_repairs.is_none() {
        return Err("the navigator never started (no init in the log)".into());
    }

    let s = &v.scenario;
    let windows: Vec<(FaultKind, FaultWindow)> = s
        .faults
        .iter()
        .flat_map(|f| &f.events)
        .map(|e| {
            (
                e.kind,
                FaultWindow {
                    start_s: e.start_s,
                    end_s: e.start_s + e.duration_s + super::faults::RECOVERY_S,
                },
            )
        })
        .collect();
    let gnss_windows: Vec<FaultWindow> = windows
        .iter()
        .filter(|(k, _)| matches!(k, FaultKind::GnssSpoof | FaultKind::GnssJam))
        .map(|(_, w)| *w)
        .collect();
    let mut kinds: Vec<&str> = windows.iter().map(|(k, _)| fault_name(*k)).collect();
    kinds.dedup();
    let fault = (!kinds.is_empty()).then(|| kinds.join("+"));
    let active = |t: f64| gnss_windows.iter().any(|w| t >= w.start_s && t < w.end_s);
    let false_exclusions = sink.exclusions_s.iter().filter(|t| !active(**t)).count() as u64;
    let first_spoof = windows
        .iter()
        .find(|(k, _)| *k == FaultKind::GnssSpoof)
        .map(|(_, w)| *w);
    let detection = first_spoof.map(|w| {
        sink.exclusions_s
            .iter()
            .find(|t| **t >= w.start_s && **t < w.end_s)
            .map(|t| (t - w.start_s, sink.acc.h_at(*t)))
    });

    let a = &sink.acc;
    let keep = |g: Group| plan.keeps(g);
    let gnss = *status.counters(Stream::Aid(AidKind::Gnss));
    let gnss_status = status.aid(AidKind::Gnss);
    let mut causes = String::new();
    for (k, n) in &sink.causes {
        if !causes.is_empty() {
            causes.push(' ');
        }
        causes += &format!("{}:{n}", k.replace(' ', "_"));
    }
    let metrics = Metrics {
        index: id.index,
        variation: id.variation as u32,
        variation_label: v.label.clone(),
        scenario: s.name.clone(),
        seed: id.seed,
        outcome: Outcome::Ok,
        reason: String::new(),
        flight_h: Some(duration_ns as f64 * 1e-9 / 3600.0),
        epochs: Some(a.n),
        non_finite_epochs: Some(a.non_finite),
        horizontal_rmse_m: a.rms(a.h).filter(|_| keep(Group::Accuracy)),
        horizontal_max_m: a.max(a.h).filter(|_| keep(Group::Accuracy)),
        vertical_rmse_m: a.rms(a.v).filter(|_| keep(Group::Accuracy)),
        vertical_max_m: a.max(a.v).filter(|_| keep(Group::Accuracy)),
        velocity_rmse_mps: a.rms(a.vel).filter(|_| keep(Group::Accuracy)),
        velocity_max_mps: a.max(a.vel).filter(|_| keep(Group::Accuracy)),
        attitude_rmse_arcmin: a.rms(a.att).filter(|_| keep(Group::Accuracy)),
        attitude_max_arcmin: a.max(a.att).filter(|_| keep(Group::Accuracy)),
        nees_position: (a.n > 0 && keep(Group::Nees)).then(|| a.nees[0] / a.n as f64),
        nees_velocity: (a.n > 0 && keep(Group::Nees)).then(|| a.nees[1] / a.n as f64),
        nees_attitude: (a.n > 0 && keep(Group::Nees)).then(|| a.nees[2] / a.n as f64),
        switches: keep(Group::Events).then_some(status.switch_count),
        resets: keep(Group::Events).then_some(status.reset_count),
        resets_aid: keep(Group::Events).then_some(sink.resets_aid),
        resets_integrity: keep(Group::Events).then_some(sink.resets_integrity),
        reset_causes: keep(Group::Events).then_some(causes),
        reinits: keep(Group::Events).then_some(status.reinit_count),
        covariance_repairs: covariance_repairs.filter(|_| keep(Group::Events)),
        gnss_fixes: keep(Group::Integrity).then_some(gnss.received),
        gnss_tested: keep(Group::Integrity).then_some(sink.gnss_tested),
        gnss_untested: keep(Group::Integrity).then_some(sink.gnss_untested),
        gnss_exclusions: keep(Group::Integrity).then_some(gnss_status.exclusions),
        gnss_readmissions: keep(Group::Integrity).then_some(sink.gnss_readmissions),
        gnss_false_exclusions: keep(Group::Integrity).then_some(false_exclusions),
        max_q_ratio: sink.max_q_ratio.filter(|_| keep(Group::Integrity)),
        fault: fault.filter(|_| keep(Group::Faults)),
        fault_start_s: first_spoof
            .or_else(|| windows.first().map(|(_, w)| *w))
            .map(|w| w.start_s)
            .filter(|_| keep(Group::Faults)),
        fault_detected: detection
            .map(|d| d.is_some())
            .filter(|_| keep(Group::Faults)),
        time_to_exclusion_s: detection
            .flatten()
            .map(|d| d.0)
            .filter(|_| keep(Group::Faults)),
        error_at_exclusion_m: detection
            .flatten()
            .and_then(|d| d.1)
            .filter(|_| keep(Group::Faults)),
        judgement_pass: None,
        judgement_failures: None,
    };
    Ok(Outcomes {
        metrics,
        simulate_cpu_s: 0.0,
        navigate_cpu_s: cpu_nav,
        evaluate_cpu_s: thread_cpu_s() - cpu1,
    })
}

/// The build's version and commit, for the cost row.
pub fn version_and_commit() -> (String, String) {
    (
        env!("CARGO_PKG_VERSION").to_owned(),
        polarnav_config::build_info::COMMIT.to_owned(),
    )
}

/// A run's cost row from its outcomes and what the process measured.
pub fn cost(o: &Outcomes, index: u64, cpu_s: f64, wall: Instant, executor: &str) -> Cost {
    let (version, commit) = version_and_commit();
    Cost {
        index,
        flight_h: o.metrics.flight_h.unwrap_or(0.0),
        cpu_s,
        simulate_cpu_s: o.simulate_cpu_s,
        navigate_cpu_s: o.navigate_cpu_s,
        evaluate_cpu_s: o.evaluate_cpu_s,
        wall_s: wall.elapsed().as_secs_f64(),
        peak_rss_mib: peak_rss_mib(),
        host: super::store::hostname(),
        executor: executor.to_owned(),
        version,
        commit,
    }
}
