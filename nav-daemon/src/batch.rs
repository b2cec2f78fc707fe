//! `nav-daemon batch`: the navigator core run over a navlog as fast as possible.

use std::io::{BufRead, Write};

use msgs::navlog::{NavlogReader, ReadReport, Record};

use crate::config::{Config, ConfigError, FrameConfig, ScenarioOverrides};
use crate::navigator::{Navigator, SwitchEvent};
use crate::solution_csv;

/// Which aids to fuse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AidSet {
    pub srs: bool,
    pub cns: bool,
    pub baro: bool,
}

impl AidSet {
    /// Parses `srs,cns,baro` (any subset) or `none`.
    pub fn parse(s: &str) -> Result<Self, String> {
        let mut a = AidSet::default();
        if s.trim() == "none" {
            return Ok(a);
        }
        for part in s.split(',').map(str::trim) {
            match part {
                "srs" => a.srs = true,
                "cns" => a.cns = true,
                "baro" => a.baro = true,
                other => {
                    return Err(format!(
                        "unknown aid {other:?}: expected a list of srs, cns, baro, or none"
                    ));
                }
            }
        }
        Ok(a)
    }
    pub fn any(&self) -> bool {
        self.srs || self.cns || self.baro
    }
}

/// Filter parameter conversion at a frame switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Conversion {
    /// X and P converted (papers/001 eqs 32–38).
    #[default]
    Paper,
    /// Nominal parameters converted, X and P carried over unchanged (baseline).
    None,
}

/// Options of one batch run beyond the config file.
#[derive(Debug, Clone, Default)]
pub struct BatchOptions {
    pub aids: AidSet,
    pub conversion: Conversion,
    /// `--force-switch` times (s), overriding config and scenario.
    pub force_switch_s: Option<Vec<f64>>,
    /// Print a progress line to stderr every this many seconds of flight (0 = quiet).
    pub progress_every_s: f64,
}

/// What a batch run did.
#[derive(Debug, Clone, Default)]
pub struct BatchReport {
    pub read: ReadReport,
    pub rows: u64,
    pub imu_rejected: u64,
    /// IMU samples before the init record (cannot be navigated).
    pub imu_before_init: u64,
    /// Aid records present in the log but not fused in this run.
    pub aid_records_unused: u64,
    pub switches: Vec<SwitchEvent>,
    pub frame: FrameConfig,
    pub first_t_ns: u64,
    pub last_t_ns: u64,
}

#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// Invalid settings (exit 2).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The log has no init record and no initial state was configured (exit 2).
    #[error("{0}: no init record before the first IMU sample; the log cannot be navigated")]
    NoInit(String),
    /// The requested aids are not available in this build (exit 2).
    #[error("--aids {0}: aid fusion is not available in this build; use --aids none")]
    AidsUnavailable(String),
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
            BatchError::Config(_) | BatchError::NoInit(_) | BatchError::AidsUnavailable(_) => 2,
            BatchError::Read { .. } | BatchError::Write(_) => 1,
        }
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
    if opts.aids.any() {
        let list: Vec<&str> = [
            ("srs", opts.aids.srs),
            ("cns", opts.aids.cns),
            ("baro", opts.aids.baro),
        ]
        .iter()
        .filter(|(_, on)| *on)
        .map(|(n, _)| *n)
        .collect();
        return Err(BatchError::AidsUnavailable(list.join(",")));
    }
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
    let mut rejected_logged = 0u32;
    let progress_ns = (opts.progress_every_s.max(0.0) * 1e9) as u64;
    let mut next_progress_ns = progress_ns;
    while let Some(rec) = reader.next_record().map_err(read_err)? {
        match rec {
            Record::Header(h) => {
                if let Some(o) = ScenarioOverrides::from_metadata(&h.metadata)? {
                    o.apply(&mut report.frame);
                }
                if let Some(f) = &opts.force_switch_s {
                    report.frame.force_switch_s.clone_from(f);
                }
                report.frame.validate(log_name, "navigator")?;
            }
            Record::Init(init) => {
                if opts.force_switch_s.is_some() && nav.is_none() {
                    report.frame.validate("--force-switch", "frame")?;
                }
                let mut cfg = config.navigator();
                cfg.frame_policy = report.frame.policy();
                if nav.is_some() {
                    tracing::info!(t_ns = init.t_ns, "new init record: re-initializing");
                }
                nav = Some(Navigator::new(&init, &cfg));
                report.first_t_ns = init.t_ns;
            }
            Record::Imu(s) => {
                let Some(n) = nav.as_mut() else {
                    report.imu_before_init += 1;
                    continue;
                };
                match n.on_imu(&s) {
                    Ok(o) => {
                        if let Some(sw) = o.switch {
                            tracing::info!(t_s = sw.t_ns as f64 * 1e-9, from = ?sw.from, to = ?sw.to, lat_deg = sw.lat_rad.to_degrees(), "frame switch");
                            report.switches.push(sw);
                        }
                        let sol = n.solution();
                        solution_csv::write_row(&mut out, &sol)?;
                        report.rows += 1;
                        report.last_t_ns = s.t_ns;
                        if progress_ns > 0 && s.t_ns >= next_progress_ns {
                            next_progress_ns += progress_ns;
                            eprintln!(
                                "batch: t = {:7.1} s  frame {}  lat {:9.5}°  lon {:10.5}°  h {:8.1} m  heading {:6.2}°",
                                s.t_ns as f64 * 1e-9,
                                n.state().kind().to_wire().letter(),
                                sol.lat_rad.to_degrees(),
                                sol.lon_rad.to_degrees(),
                                sol.h_m,
                                sol.heading_rad.to_degrees()
                            );
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
            Record::Srs(_) | Record::Cns(_) | Record::Baro(_) => report.aid_records_unused += 1,
            Record::Truth(_) | Record::Solution(_) | Record::Status(_) => {}
        }
    }
    report.read = reader.report().clone();
    if nav.is_none() {
        return Err(BatchError::NoInit(log_name.to_owned()));
    }
    out.flush()?;
    Ok(report)
}
