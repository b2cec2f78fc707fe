//! The fault campaign's judgement (`sensor-replay campaign run
//! config/campaigns/faults.toml`, whose runs are of kind `fault-judge`): every scenario with a `[faults]` section is simulated
//! with and without its faults (same seed, so the flights differ only in the
//! faulted samples) and navigated; the faulted run is judged against the
//! fault-free one.
//!
//! Per scenario it reports what was injected, what the navigator detected
//! (its counters), the horizontal error during and after the faults, and the
//! accounting of every stream (published = received = accepted + rejected +
//! not used). The acceptance rule: outside injected outages (each extended
//! by a 60 s recovery allowance) the horizontal error stays within 3× the
//! fault-free RMSE, and after each outage it is back within that bound by
//! the end of the allowance.

use std::path::Path;

use msgs::navlog::Record;
use msgs::{AidKind, PerStream, Status, Stream, StreamCounters, TruthRecord};
use polarnav::session;
use polarnav::solution_csv::Row;
use polarnav_config::{CliOverrides, ConfigFile, effective};

use polarnav_eval::eval;
use polarnav_sim::faults::FaultKind;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

/// Recovery allowance after an outage (s).
pub const RECOVERY_S: f64 = 60.0;
/// Bound on the horizontal error outside outages, in fault-free RMSEs.
pub const ERROR_FACTOR: f64 = 3.0;
/// The initial convergence (from the 10 m initial error) is not judged: the
/// fault-free run itself starts at several times its RMSE.
pub const CONVERGENCE_S: f64 = 120.0;

/// The scenario files (`*.toml`) of a directory, sorted.
pub fn scenario_files(dir: &Path) -> std::io::Result<Vec<std::path::PathBuf>> {
    let mut files: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    Ok(files)
}

/// One line per stream: published, received, sequence gaps and where every
/// received sample went.
pub fn accounting_lines(published: &PerStream<u64>, status: &Status) -> String {
    let mut out = String::new();
    for (stream, p) in published.iter() {
        let name = stream.name();
        let c = status.counters(stream);
        out += &format!(
            "   {name:<4} published {p:>7}, received {:>7}, sequence gaps {}; received = accepted {:>7} + invalid {} + time {} + gate {} + not used {}\n",
            c.received,
            c.seq_gaps,
            c.accepted,
            c.rejected_invalid,
            c.rejected_time,
            c.rejected_gate,
            c.not_used
        );
    }
    out
}

/// Records per stream in a log.
pub fn published(records: &[Record]) -> PerStream<u64> {
    let mut n = PerStream::<u64>::default();
    for r in records {
        match r {
            Record::Imu(_) => n[Stream::Imu] += 1,
            Record::Aid(a) => n[Stream::Aid(a.kind())] += 1,
            _ => {}
        }
    }
    n
}

/// The stream counters of a status, in the order of [`published`].
pub fn streams(s: &Status) -> PerStream<StreamCounters> {
    PerStream(s.streams)
}

/// `received = accepted + rejected + not used` for every stream, and what
/// was published arrived: through `batch` (no sequence numbers tracked)
/// `received = published`; live, `received + sequence gaps = published +
/// upstream` where `upstream` are the samples the source never sent (an
/// outage skips their sequence numbers). `Err` names the first mismatch.
pub fn check_accounting(
    published: PerStream<u64>,
    upstream: Option<PerStream<u64>>,
    status: &Status,
) -> Result<(), String> {
    for (stream, p) in published.iter() {
        let name = stream.name();
        let c = status.counters(stream);
        let sum = c.decided();
        if sum != c.received {
            return Err(format!(
                "{name}: received {} but accepted {} + rejected {}/{}/{} + not used {} = {sum}",
                c.received,
                c.accepted,
                c.rejected_invalid,
                c.rejected_time,
                c.rejected_gate,
                c.not_used
            ));
        }
        let never_sent = upstream.map_or(0, |u| u[stream]);
        if c.received + c.seq_gaps != *p + never_sent {
            return Err(format!(
                "{name}: published {p} (+ {never_sent} never sent) but received {} + sequence gaps {}",
                c.received, c.seq_gaps
            ));
        }
    }
    Ok(())
}

/// One injected fault and what the navigator made of it.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultLine {
    pub what: String,
    pub injected: u64,
    /// The counter that detects it and its value (`None`: an outage, not an error to detect).
    pub detected: Option<(String, u64)>,
    pub ok: bool,
}

/// Horizontal-error judgement of a faulted run against its fault-free twin.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ErrorJudgement {
    pub rmse_fault_free_m: f64,
    pub rmse_faulted_m: f64,
    /// RMS and maximum horizontal error within the fault windows.
    pub during: eval::Stat,
    /// After the last fault window (plus the recovery allowance for outages).
    pub after: eval::Stat,
    /// Largest horizontal error outside outages + recovery allowance (after
    /// the initial convergence), in fault-free RMSEs; and the same for the
    /// fault-free run, for comparison.
    pub worst_outside_ratio: f64,
    pub fault_free_worst_ratio: f64,
    /// Longest time after the end of an outage until the error was last above the bound (s).
    pub recovery_s: f64,
    /// Epochs that had a solution (IMU dropouts have none).
    pub epochs: usize,
    /// Largest correction step of the solution (position change between
    /// consecutive rows beyond the velocity's prediction) within the recovery
    /// allowance after an outage, and in the fault-free run after the initial
    /// convergence (m).
    pub reacquisition_step_m: f64,
    pub fault_free_step_m: f64,
    /// The largest step after an outage in units of the position σ (3-D) just
    /// before it: an aid taken back corrects within what the covariance allows.
    pub reacquisition_step_sigma: f64,
}

/// Position steps between consecutive rows not explained by the velocity:
/// (t, step m, step in position σ of the row before).
fn steps(rows: &[Row]) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
    rows.windows(2).map(|w| {
        let dt = w[1].t_s - w[0].t_s;
        let d: f64 = (0..3)
            .map(|i| {
                let predicted = 0.5 * (w[0].v_e_mps[i] + w[1].v_e_mps[i]) * dt;
                (w[1].r_e_m[i] - w[0].r_e_m[i] - predicted).powi(2)
            })
            .sum::<f64>()
            .sqrt();
        let sigma = w[0].sigma_enu_m.iter().map(|x| x * x).sum::<f64>().sqrt();
        (w[1].t_s, d, d / sigma)
    })
}

impl ErrorJudgement {
    pub fn ok(&self) -> bool {
        self.worst_outside_ratio <= ERROR_FACTOR
            && self.recovery_s <= RECOVERY_S
            && self.reacquisition_step_sigma <= 3.0
    }
}

/// A fault window: `[start, end)` (s) and whether it takes information away (outage).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    pub start_s: f64,
    pub end_s: f64,
    pub outage: bool,
}

/// Samples per stream (IMU, SRS, CNS, baro) that the source never sent.
pub fn upstream_missing(s: &Scenario, injected: &[u64]) -> PerStream<u64> {
    let mut n = PerStream::<u64>::default();
    for (e, k) in s.faults.iter().flat_map(|f| &f.events).zip(injected) {
        if e.kind == FaultKind::Outage {
            n[e.stream] += k;
        }
    }
    n
}

/// The windows of a scenario's faults. Outages, IMU time jumps (whose
/// samples are rejected or leave a gap), jamming and spoofing (GNSS lost or
/// excluded) take information away.
pub fn windows(s: &Scenario) -> Vec<Window> {
    s.faults
        .iter()
        .flat_map(|f| &f.events)
        .map(|e| Window {
            start_s: e.start_s,
            end_s: e.start_s + e.duration_s,
            outage: matches!(
                e.kind,
                FaultKind::Outage | FaultKind::GnssJam | FaultKind::GnssSpoof
            ) || (e.kind == FaultKind::TimeJump && e.stream == Stream::Imu),
        })
        .collect()
}

/// Judges the horizontal error of `faulted` against `fault_free` (both solution rows).
pub fn judge(
    truth: &[TruthRecord],
    fault_free: &[Row],
    faulted: &[Row],
    windows: &[Window],
) -> ErrorJudgement {
    let h = |rows: &[Row]| -> Vec<(f64, f64)> {
        eval::epochs(rows, truth)
            .iter()
            .map(|e| (e.t_s, e.pos_enu.xy().norm()))
            .collect()
    };
    let rms = |v: &[(f64, f64)]| {
        (v.iter().fold(0.0, |a, (_, e)| a + e * e) / v.len().max(1) as f64).sqrt()
    };
    let ff = h(fault_free);
    let fe = h(faulted);
    let rmse_ff = rms(&ff);
    let bound = ERROR_FACTOR * rmse_ff;
    let in_window = |t: f64| windows.iter().any(|w| t >= w.start_s && t < w.end_s);
    let excused = |t: f64| {
        windows
            .iter()
            .any(|w| w.outage && t >= w.start_s && t < w.end_s + RECOVERY_S)
    };
    let last_end = windows
        .iter()
        .map(|w| w.end_s + if w.outage { RECOVERY_S } else { 0.0 });
    let last_end = last_end.fold(0.0, f64::max);
    let stat = |it: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = it.collect();
        if v.is_empty() {
            return eval::Stat {
                rmse: f64::NAN,
                max: f64::NAN,
            };
        }
        eval::Stat {
            rmse: (v.iter().fold(0.0, |a, e| a + e * e) / v.len() as f64).sqrt(),
            max: v.iter().copied().fold(0.0, f64::max),
        }
    };
    let judged = |t: f64| t >= CONVERGENCE_S && !excused(t);
    let reacq = || {
        steps(faulted).filter(|(t, _, _)| {
            windows
                .iter()
                .any(|w| w.outage && *t > w.end_s && *t <= w.end_s + RECOVERY_S)
        })
    };
    let mut recovery_s: f64 = 0.0;
    for w in windows.iter().filter(|w| w.outage) {
        if let Some((t, _)) = fe.iter().rfind(|(t, e)| *t >= w.end_s && *e > bound) {
            recovery_s = recovery_s.max(t - w.end_s);
        }
    }
    ErrorJudgement {
        rmse_fault_free_m: rmse_ff,
        rmse_faulted_m: rms(&fe),
        during: stat(&mut fe.iter().filter(|(t, _)| in_window(*t)).map(|(_, e)| *e)),
        after: stat(&mut fe.iter().filter(|(t, _)| *t >= last_end).map(|(_, e)| *e)),
        worst_outside_ratio: fe
            .iter()
            .filter(|(t, _)| judged(*t))
            .map(|(_, e)| e / rmse_ff)
            .fold(0.0, f64::max),
        fault_free_worst_ratio: ff
            .iter()
            .filter(|(t, _)| judged(*t))
            .map(|(_, e)| e / rmse_ff)
            .fold(0.0, f64::max),
        recovery_s,
        epochs: fe.len(),
        reacquisition_step_m: reacq().map(|(_, d, _)| d).fold(0.0, f64::max),
        reacquisition_step_sigma: reacq().map(|(_, _, r)| r).fold(0.0, f64::max),
        fault_free_step_m: steps(fault_free)
            .filter(|(t, _, _)| *t >= CONVERGENCE_S)
            .map(|(_, d, _)| d)
            .fold(0.0, f64::max),
    }
}

/// What the navigator should show for each injected fault, from its final status.
pub fn fault_lines(s: &Scenario, injected: &[u64], status: &Status) -> Vec<FaultLine> {
    let Some(f) = &s.faults else {
        return Vec::new();
    };
    let c = |st: Stream| *status.counters(st);
    // Events of the same kind on the same stream share a counter.
    let total = |kind: FaultKind, stream: Stream| -> u64 {
        f.events
            .iter()
            .zip(injected)
            .filter(|(e, _)| e.kind == kind && e.stream == stream)
            .map(|(_, n)| n)
            .sum()
    };
    f.events
        .iter()
        .zip(injected)
        .map(|(e, &n)| {
            let what = format!(
                "{:?} {:?} {}-{} s{}",
                e.kind,
                e.stream,
                e.start_s,
                e.start_s + e.duration_s,
                if e.magnitude != 0.0 {
                    format!(" ({})", e.magnitude)
                } else {
                    String::new()
                }
            );
            let need = total(e.kind, e.stream);
            let (detected, ok) = match (e.kind, e.stream) {
                (FaultKind::Outage, Stream::Imu) => {
                    let gaps = f
                        .events
                        .iter()
                        .filter(|x| x.kind == FaultKind::Outage && x.stream == Stream::Imu)
                        .count() as u64;
                    (
                        Some(("imu gaps coasted".into(), status.imu_gap_count)),
                        status.imu_gap_count >= gaps,
                    )
                }
                (FaultKind::Outage, st) if c(st).seq_gaps > 0 => {
                    let v = c(st).seq_gaps;
                    (Some(("sequence gaps".into(), v)), v >= need)
                }
                (FaultKind::Outage, _) => (None, true),
                (FaultKind::Nan, st) => {
                    let v = c(st).rejected_invalid;
                    (Some(("rejected invalid".into(), v)), v >= need)
                }
                (FaultKind::TimeJump | FaultKind::Duplicate, st) => {
                    // An aid moved back is always too late. An IMU sample moved back
                    // is rejected only while its time is not after the last accepted
                    // one (a fraction magnitude/duration of the window); the rest
                    // arrive in order and leave a gap, which is coasted.
                    let jumped: u64 =
                        f.events
                            .iter()
                            .zip(injected)
                            .filter(|(x, _)| x.kind == FaultKind::TimeJump && x.stream == st)
                            .map(|(x, n)| match st {
                                Stream::Imu => (*n as f64 * (x.magnitude / x.duration_s).min(1.0))
                                    .floor() as u64,
                                _ => *n,
                            })
                            .sum();
                    let v = c(st).rejected_time;
                    (
                        Some(("rejected time".into(), v)),
                        v >= jumped + total(FaultKind::Duplicate, st),
                    )
                }
                (FaultKind::Outliers, Stream::Aid(AidKind::Srs)) => {
                    let v = status.aid(AidKind::Srs).exclusions
                        + c(Stream::Aid(AidKind::Srs)).rejected_gate
                        + c(Stream::Aid(AidKind::Srs)).rejected_invalid;
                    (Some(("lines excluded + rejected".into(), v)), v >= need)
                }
                (FaultKind::Outliers, Stream::Imu) => {
                    let v = c(Stream::Imu).rejected_invalid;
                    (Some(("rejected invalid".into(), v)), v >= need)
                }
                (FaultKind::Outliers, st) => {
                    let v = c(st).rejected_gate;
                    (Some(("rejected by gate".into(), v)), v >= need)
                }
                // After the ramp the receiver has no fix: each such fix is
                // refused as below 3D.
                (FaultKind::GnssJam, st) => {
                    let ramp = e.ramp_s.unwrap_or(0.5 * e.duration_s);
                    let lost = (n as f64 * (1.0 - ramp / e.duration_s)).floor() as u64;
                    let v = match st {
                        Stream::Aid(k) => status.aid(k).refused[1],
                        Stream::Imu => 0,
                    };
                    (
                        Some(("refused: no 3D fix".into(), v)),
                        v >= lost.saturating_sub(1),
                    )
                }
                // The integrity test excludes the spoofed receiver.
                (FaultKind::GnssSpoof, st) => {
                    let v = match st {
                        Stream::Aid(k) => status.aid(k).exclusions,
                        Stream::Imu => 0,
                    };
                    (Some(("integrity exclusions".into(), v)), v >= 1)
                }
            };
            FaultLine {
                what,
                injected: n,
                detected,
                ok,
            }
        })
        .collect()
}

/// The result of one scenario through `batch`.
#[derive(Debug, Clone)]
pub struct ScenarioResult {
    pub name: String,
    pub faults: Vec<FaultLine>,
    pub errors: ErrorJudgement,
    pub published: PerStream<u64>,
    pub status: Status,
    pub accounting: Result<(), String>,
    /// The faulted flight (navlog bytes), for a live run of the same data.
    pub faulted_log: Vec<u8>,
    pub truth: Vec<TruthRecord>,
    pub fault_free_rows: Vec<Row>,
}

impl ScenarioResult {
    pub fn ok(&self) -> bool {
        self.accounting.is_ok() && self.errors.ok() && self.faults.iter().all(|f| f.ok)
    }

    /// What failed the judgement, one phrase each (none when [`Self::ok`]).
    pub fn failures(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .faults
            .iter()
            .filter(|f| !f.ok)
            .map(|f| {
                format!(
                    "not detected: {} ({} injected, {})",
                    f.what,
                    f.injected,
                    f.detected
                        .as_ref()
                        .map_or("outage".into(), |(k, n)| format!("{k} {n}"))
                )
            })
            .collect();
        let e = &self.errors;
        if e.worst_outside_ratio > ERROR_FACTOR {
            v.push(format!(
                "horizontal error {:.2}x the fault-free RMSE outside the outages (bound {ERROR_FACTOR}x)",
                e.worst_outside_ratio
            ));
        }
        if e.recovery_s > RECOVERY_S {
            v.push(format!(
                "recovery {:.1} s after an outage (bound {RECOVERY_S:.0} s)",
                e.recovery_s
            ));
        }
        if e.reacquisition_step_sigma > 3.0 {
            v.push(format!(
                "correction step {:.2} sigma after an outage (bound 3 sigma)",
                e.reacquisition_step_sigma
            ));
        }
        if let Err(m) = &self.accounting {
            v.push(format!("accounting: {m}"));
        }
        v
    }
}

fn simulate_bytes(
    s: &Scenario,
    text: &str,
    seed: u64,
    faults: bool,
) -> Result<(Vec<u8>, Vec<u64>), String> {
    let mut buf = Vec::new();
    let sum = simulate(
        s,
        text,
        SimOptions {
            seed,
            faults,
            ..Default::default()
        },
        &mut buf,
    )
    .map_err(|e| e.to_string())?;
    Ok((buf, sum.injected))
}

/// Navigates navlog bytes as `batch` does with the default configuration
/// (the same session, the header's settings applied): the rows and the
/// final status.
pub fn navigate_rows(log: &[u8], name: &str) -> Result<(Vec<Row>, Status), String> {
    let (records, report) = msgs::navlog::read_all(log);
    if !report.is_clean() {
        return Err(format!("{name}: damaged log: {report}"));
    }
    let metadata = msgs::navlog::header_metadata(&records);
    let eff = effective(&ConfigFile::defaults(), metadata, &CliOverrides::default())
        .map_err(|e| e.to_string())?;
    let (out, status) = session::navigate(&records, eff.session());
    let rows = out.solutions.iter().map(Row::from_solution).collect();
    Ok((rows, status))
}

/// Simulates (with and without faults, seed 1) and navigates one scenario
/// file through `batch`.
pub fn run_scenario(path: &Path) -> Result<ScenarioResult, String> {
    let (s, text) = Scenario::load(path).map_err(|e| e.to_string())?;
    run_scenario_text(&s, &text, 1).map_err(|e| format!("{}: {e}", path.display()))
}

/// [`run_scenario`] of a scenario already parsed from `text`, with `seed`.
pub fn run_scenario_text(s: &Scenario, text: &str, seed: u64) -> Result<ScenarioResult, String> {
    let (faulted, injected) = simulate_bytes(s, text, seed, true)?;
    let (clean, _) = simulate_bytes(s, text, seed, false)?;
    let (records, report) = msgs::navlog::read_all(&faulted);
    if !report.is_clean() {
        return Err(format!("simulated log damaged: {report}"));
    }
    let truth: Vec<TruthRecord> = records
        .iter()
        .filter_map(|r| {
            if let Record::Truth(t) = r {
                Some(*t)
            } else {
                None
            }
        })
        .collect();
    let (rows_ff, _) = navigate_rows(&clean, &s.name)?;
    let (rows, status) = navigate_rows(&faulted, &s.name)?;
    let published = published(&records);
    Ok(ScenarioResult {
        name: s.name.clone(),
        faults: fault_lines(s, &injected, &status),
        errors: judge(&truth, &rows_ff, &rows, &windows(s)),
        published,
        // The log's own sequence gaps are the samples the fault never let
        // the source send (outages), as a live replay reports them.
        accounting: check_accounting(published, Some(upstream_missing(s, &injected)), &status),
        status,
        faulted_log: faulted,
        truth,
        fault_free_rows: rows_ff,
    })
}

/// The campaign report of one scenario, as printed.
pub fn report(r: &ScenarioResult, via: &str) -> String {
    let mut out = format!(
        "== {} ({via}): {}\n",
        r.name,
        if r.ok() { "PASS" } else { "FAIL" }
    );
    for f in &r.faults {
        let det = f
            .detected
            .as_ref()
            .map_or("outage (aid stale / coasting)".to_owned(), |(k, v)| {
                format!("{k} {v}")
            });
        out += &format!(
            "   injected {:<48} {:>6} samples   detected: {det}{}\n",
            f.what,
            f.injected,
            if f.ok { "" } else { "   << NOT DETECTED" }
        );
    }
    let e = &r.errors;
    out += &format!(
        "   horizontal error: fault-free RMSE {:.2} m, faulted RMSE {:.2} m; during faults RMS {:.2} / max {:.2} m; after RMS {:.2} / max {:.2} m\n",
        e.rmse_fault_free_m,
        e.rmse_faulted_m,
        e.during.rmse,
        e.during.max,
        e.after.rmse,
        e.after.max
    );
    out += &format!(
        "   worst after {CONVERGENCE_S:.0} s outside outages+{RECOVERY_S:.0} s: {:.2}x fault-free RMSE (bound {ERROR_FACTOR}x; fault-free run {:.2}x); recovery after outages {:.1} s (bound {RECOVERY_S:.0} s)\n",
        e.worst_outside_ratio, e.fault_free_worst_ratio, e.recovery_s
    );
    if e.reacquisition_step_m > 0.0 {
        out += &format!(
            "   largest correction step within {RECOVERY_S:.0} s after an outage {:.2} m = {:.2} σ (bound 3 σ; fault-free run after {CONVERGENCE_S:.0} s: {:.2} m)\n",
            e.reacquisition_step_m, e.reacquisition_step_sigma, e.fault_free_step_m
        );
    }
    out += &accounting_lines(&r.published, &r.status);
    if let Err(m) = &r.accounting {
        out += &format!("   ACCOUNTING MISMATCH: {m}\n");
    }
    out
}
