//! `nav-daemon batch`: the navigator core run over a navlog as fast as possible.

use std::io::{BufRead, Write};

use msgs::navlog::{NavlogReader, ReadReport, Record};

use crate::config::{Config, ConfigError, FilterSettings, FrameConfig, ScenarioOverrides};
use crate::navigator::{Navigator, NavigatorConfig, SwitchEvent};
use crate::solution_csv;

pub use crate::navigator::{AidSet, Conversion};

/// Options of one batch run beyond the config file.
#[derive(Debug, Clone, Default)]
pub struct BatchOptions {
    pub aids: AidSet,
    pub conversion: Conversion,
    /// `--force-switch` times (s), overriding config and scenario; an empty
    /// list means never switch (`--no-switch`).
    pub force_switch_s: Option<Vec<f64>>,
    /// Print a progress line to stderr every this many seconds of flight (0 = quiet).
    pub progress_every_s: f64,
    /// Stationary coarse alignment over this many seconds of IMU data after
    /// the init record, whose position is kept and whose attitude is replaced.
    pub align_s: Option<f64>,
}

/// What a batch run did.
#[derive(Debug, Clone, Default)]
pub struct BatchReport {
    pub read: ReadReport,
    pub rows: u64,
    pub imu_rejected: u64,
    /// IMU samples before the init record (cannot be navigated).
    pub imu_before_init: u64,
    /// Aid records fused, rejected (gate, content or time), and present but not selected.
    pub aid_fused: u64,
    pub aid_rejected: u64,
    pub aid_records_unused: u64,
    /// SRS solutions that excluded a faulty line.
    pub srs_exclusions: u64,
    pub switches: Vec<SwitchEvent>,
    pub frame: FrameConfig,
    pub filter: FilterSettings,
    pub first_t_ns: u64,
    /// The alignment, when `align_s` was given.
    pub alignment: Option<crate::align::Alignment>,
    /// IMU samples consumed by the alignment.
    pub imu_aligning: u64,
    pub last_t_ns: u64,
    /// Init records rejected as invalid (non-finite or implausible).
    pub init_rejected: u64,
    /// The navigator's status at the end, with every record of the log
    /// accounted for: per stream `received = accepted + rejected_* + not_used`.
    pub status: msgs::Status,
}

#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// Invalid settings (exit 2).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The log has no init record and no initial state was configured (exit 2).
    #[error(
        "{0}: no init record before the first IMU sample and no [init] in the configuration; the log cannot be navigated"
    )]
    NoInit(String),
    /// The alignment could not be solved (exit 1).
    #[error("{0}: alignment failed: {1}")]
    Align(String, crate::align::AlignError),
    /// The log ended before the alignment window was complete (exit 2).
    #[error("{log}: only {have_s:.1} s of IMU data for a {need_s:.1} s alignment")]
    AlignIncomplete {
        log: String,
        have_s: f64,
        need_s: f64,
    },
    /// Reading the log failed (exit 1).
    #[error("{path}: {source}")]
    Read {
        path: String,
        source: msgs::navlog::ReadError,
    },
    /// Writing the solution failed (exit 1).
    #[error("writing the solution: {0}")]
    Write(#[from] std::io::Error),
}

impl BatchError {
    /// Process exit status per DESIGN.
    pub fn exit_code(&self) -> i32 {
        match self {
            BatchError::Config(_) | BatchError::NoInit(_) | BatchError::AlignIncomplete { .. } => 2,
            BatchError::Read { .. } | BatchError::Write(_) | BatchError::Align(..) => 1,
        }
    }
}

fn write_solution_row<W: Write>(
    out: &mut W,
    n: &Navigator,
    report: &mut BatchReport,
    progress_ns: u64,
    next_progress_ns: &mut u64,
) -> std::io::Result<()> {
    let sol = n.solution();
    solution_csv::write_row(out, &sol)?;
    report.rows += 1;
    if progress_ns > 0 && sol.t_ns >= *next_progress_ns {
        *next_progress_ns += progress_ns;
        eprintln!(
            "batch: t = {:7.1} s  frame {}  lat {:9.5}°  lon {:10.5}°  h {:8.1} m  heading {:6.2}°",
            sol.t_ns as f64 * 1e-9,
            n.state().kind().to_wire().letter(),
            sol.lat_rad.to_degrees(),
            sol.lon_rad.to_degrees(),
            sol.h_m,
            sol.heading_rad.to_degrees()
        );
    }
    Ok(())
}

fn apply_cli_frame(opts: &BatchOptions, frame: &mut FrameConfig) {
    if let Some(f) = &opts.force_switch_s {
        frame.force_switch_s.clone_from(f);
        frame.never_switch = f.is_empty();
    }
}

/// Runs the navigator over `log`, writing the solution CSV to `out`.
/// `log_name` names the log in errors.
pub fn run<R: BufRead, W: Write>(
    log: R,
    log_name: &str,
    mut out: W,
    config: &Config,
    opts: &BatchOptions,
) -> Result<BatchReport, BatchError> {
    let mut reader = NavlogReader::new(log);
    let mut report = BatchReport {
        frame: config.frame.clone(),
        ..Default::default()
    };
    let read_err = |source| BatchError::Read {
        path: log_name.to_owned(),
        source,
    };
    writeln!(out, "{}", solution_csv::HEADER)?;

    let mut nav: Option<Navigator> = None;
    // Alignment in progress: the init record it started from, its configuration and the accumulator.
    let mut aligning: Option<(
        msgs::InitState,
        NavigatorConfig,
        crate::align::AlignmentAccumulator,
    )> = None;
    let mut rejected_logged = 0u32;
    let progress_ns = (opts.progress_every_s.max(0.0) * 1e9) as u64;
    let mut next_progress_ns = progress_ns;
    let mut row_pending = false;
    // Records never handed to a navigator, per stream (IMU, SRS, CNS, baro).
    let mut not_used = [0u64; 4];
    let mut align_rejected = 0u64;
    // Aids stamped after the newest accepted IMU sample, in log order.
    let mut waiting: Vec<Record> = Vec::new();
    while let Some(rec) = reader.next_record().map_err(read_err)? {
        match rec {
            Record::Header(h) => {
                if let Some(o) = ScenarioOverrides::from_metadata(&h.metadata)? {
                    o.apply(&mut report.frame);
                    o.apply_filter(&mut report.filter);
                    report.filter.validate(log_name)?;
                }
                apply_cli_frame(opts, &mut report.frame);
                report.frame.validate(log_name, "navigator")?;
            }
            Record::Init(init) => {
                if let Err(e) = crate::navigator::check_init(&init) {
                    report.init_rejected += 1;
                    tracing::error!(t_ns = init.t_ns, "{log_name}: init record rejected: {e}");
                    continue;
                }
                if opts.force_switch_s.is_some() && nav.is_none() {
                    report.frame.validate("--force-switch", "frame")?;
                }
                let cfg = navigator_config(&report, config, opts);
                if let Some(n) = nav.as_ref().filter(|_| row_pending) {
                    write_solution_row(
                        &mut out,
                        n,
                        &mut report,
                        progress_ns,
                        &mut next_progress_ns,
                    )?;
                    row_pending = false;
                }
                if nav.is_some() {
                    tracing::info!(t_ns = init.t_ns, "new init record: re-initializing");
                }
                report.first_t_ns = init.t_ns;
                if opts.align_s.is_some() {
                    nav = None;
                    aligning = Some((init, cfg, crate::align::AlignmentAccumulator::default()));
                } else if let Some(n) = nav.as_mut() {
                    n.reinitialize(&init, &cfg);
                } else {
                    nav = Some(Navigator::new(&init, &cfg));
                }
            }
            Record::Imu(s) => {
                if let Some((init, _, acc)) = aligning.as_mut() {
                    let ok = s.t_ns > init.t_ns
                        && s.dt_s > 0.0
                        && s.d_theta_rad
                            .iter()
                            .chain(&s.d_v_mps)
                            .all(|x| x.is_finite());
                    if ok {
                        acc.add(&s.d_theta_rad.into(), &s.d_v_mps.into(), s.dt_s);
                        report.imu_aligning += 1;
                    } else {
                        align_rejected += 1;
                    }
                    if acc.time_s() >= opts.align_s.unwrap_or(0.0) {
                        let (init, cfg, acc) = aligning.take().expect("aligning");
                        let (aligned, a) =
                            crate::align::aligned_init(&init, &cfg.filter, &acc, s.t_ns)
                                .map_err(|e| BatchError::Align(log_name.to_owned(), e))?;
                        tracing::info!(
                            heading_deg = a.heading_rad.to_degrees(),
                            pitch_deg = a.pitch_rad.to_degrees(),
                            roll_deg = a.roll_rad.to_degrees(),
                            sigma_tilt_arcmin = a.sigma_tilt_rad.to_degrees() * 60.0,
                            sigma_heading_arcmin = a.sigma_heading_rad.to_degrees() * 60.0,
                            time_s = a.time_s,
                            "stationary alignment"
                        );
                        report.alignment = Some(a);
                        nav = Some(Navigator::new(&aligned, &cfg));
                    }
                    continue;
                }
                if nav.is_none()
                    && let Some(ci) = &config.init
                {
                    // No init record: start from [init] of the configuration, one sample back.
                    let t0 = s.t_ns.saturating_sub((s.dt_s * 1e9).round() as u64);
                    tracing::info!(
                        t_ns = t0,
                        "no init record before the first IMU sample: initializing from the configuration"
                    );
                    let cfg = navigator_config(&report, config, opts);
                    nav = Some(Navigator::new(&ci.to_init(t0), &cfg));
                    report.first_t_ns = t0;
                }
                let Some(n) = nav.as_mut() else {
                    report.imu_before_init += 1;
                    not_used[0] += 1;
                    continue;
                };
                if row_pending {
                    write_solution_row(
                        &mut out,
                        n,
                        &mut report,
                        progress_ns,
                        &mut next_progress_ns,
                    )?;
                    row_pending = false;
                }
                match n.on_imu(&s) {
                    Ok(o) => {
                        if let Some(sw) = o.switch {
                            tracing::info!(t_s = sw.t_ns as f64 * 1e-9, from = ?sw.from, to = ?sw.to, lat_deg = sw.lat_rad.to_degrees(), "frame switch");
                            report.switches.push(sw);
                        }
                        // The row of this sample is written when the next sample arrives
                        // (or at the end), after the aids stamped up to its time: a
                        // solution at t includes every measurement stamped <= t, as the
                        // live daemon publishes it.
                        row_pending = true;
                        report.last_t_ns = s.t_ns;
                        let now = n.t_ns();
                        if waiting
                            .first()
                            .and_then(Record::t_ns)
                            .is_some_and(|t| t <= now)
                        {
                            let due = waiting
                                .iter()
                                .take_while(|r| r.t_ns().is_some_and(|t| t <= now))
                                .count();
                            for rec in waiting.drain(..due) {
                                apply_aid(n, &rec, &mut report, log_name, &mut rejected_logged);
                            }
                        }
                    }
                    Err(e) => {
                        report.imu_rejected += 1;
                        if rejected_logged < 10 {
                            rejected_logged += 1;
                            tracing::warn!(
                                t_ns = s.t_ns,
                                seq = s.seq,
                                "{log_name}: IMU sample rejected: {e}"
                            );
                        }
                    }
                }
            }
            Record::Srs(_) | Record::Cns(_) | Record::Baro(_) => {
                let selected = match &rec {
                    Record::Srs(_) => opts.aids.srs,
                    Record::Cns(_) => opts.aids.cns,
                    _ => opts.aids.baro,
                };
                let Some(n) = nav.as_mut().filter(|_| selected) else {
                    report.aid_records_unused += 1;
                    let k = match &rec {
                        Record::Srs(_) => 1,
                        Record::Cns(_) => 2,
                        _ => 3,
                    };
                    not_used[k] += 1;
                    continue;
                };
                if rec.t_ns().is_some_and(|t| t > n.t_ns()) {
                    // Ahead of the newest accepted IMU sample (its own IMU sample may
                    // have been rejected or lost): it waits for the next one, as the
                    // live daemon holds it.
                    waiting.push(rec);
                } else {
                    apply_aid(n, &rec, &mut report, log_name, &mut rejected_logged);
                }
            }
            Record::Truth(_) | Record::Solution(_) | Record::Status(_) => {}
        }
    }
    if let Some(n) = nav.as_mut() {
        // Aids after the last IMU sample: offered (and counted) as ahead of the IMU.
        for rec in waiting.drain(..) {
            apply_aid(n, &rec, &mut report, log_name, &mut rejected_logged);
        }
    }
    if let Some(n) = nav.as_ref().filter(|_| row_pending) {
        write_solution_row(&mut out, n, &mut report, progress_ns, &mut next_progress_ns)?;
    }
    report.read = reader.report().clone();
    if let Some((_, _, acc)) = &aligning {
        return Err(BatchError::AlignIncomplete {
            log: log_name.to_owned(),
            have_s: acc.time_s(),
            need_s: opts.align_s.unwrap_or(0.0),
        });
    }
    let Some(n) = nav.as_ref() else {
        return Err(BatchError::NoInit(log_name.to_owned()));
    };
    report.status = n.status();
    // Samples consumed by the stationary alignment were accepted by it.
    report.status.imu.received += report.imu_aligning + align_rejected;
    report.status.imu.accepted += report.imu_aligning;
    report.status.imu.rejected_invalid += align_rejected;
    for (c, k) in [
        &mut report.status.imu,
        &mut report.status.srs,
        &mut report.status.cns,
        &mut report.status.baro,
    ]
    .into_iter()
    .zip(not_used)
    {
        c.received += k;
        c.not_used += k;
    }
    out.flush()?;
    Ok(report)
}

/// The navigator settings of this run: frame and filter from the
/// configuration as overridden by the log header and the command line.
fn navigator_config(report: &BatchReport, config: &Config, opts: &BatchOptions) -> NavigatorConfig {
    NavigatorConfig {
        frame_policy: report.frame.policy(),
        conversion: opts.conversion,
        aids: opts.aids,
        filter: report.filter.clone(),
        aid_settings: config.aids.clone(),
    }
}

/// Offers one aid record to the navigator and accounts for the outcome.
fn apply_aid(
    n: &mut Navigator,
    rec: &Record,
    report: &mut BatchReport,
    log_name: &str,
    rejected_logged: &mut u32,
) {
    let out = match rec {
        Record::Srs(x) => n.on_srs(x),
        Record::Cns(x) => n.on_cns(x),
        Record::Baro(x) => n.on_baro(x),
        _ => return,
    };
    match out {
        Ok(o) if o.fused => {
            report.aid_fused += 1;
            report.srs_exclusions += u64::from(o.excluded_body.is_some());
        }
        Ok(_) => report.aid_rejected += 1,
        Err(e) => {
            report.aid_rejected += 1;
            if *rejected_logged < 10 {
                *rejected_logged += 1;
                tracing::warn!(
                    t_ns = rec.t_ns().unwrap_or(0),
                    "{log_name}: aid sample rejected: {e}"
                );
            }
        }
    }
}
