//! `sensor-replay`: simulate flights, import/export logs, evaluate solutions.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use polarnav_eval::logfile;
use polarnav_foxglove::{AidSource, McapFile};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{self, SimOptions};
use sensor_replay::export;
use sensor_replay::interop::{self, AidSynthesis, ImportError};

#[derive(Debug, Parser)]
#[command(
    name = "sensor-replay",
    version = polarnav_config::build_info::LONG_VERSION,
    about = "polarnav flight simulator, log tools and evaluator"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Simulate a scenario into a navlog (IMU, aids, init, truth).
    Simulate {
        /// Scenario file (TOML), e.g. config/scenarios/polar-crossing.toml.
        #[arg(long)]
        scenario: PathBuf,
        /// The navlog to write.
        #[arg(long)]
        out: PathBuf,
        /// Random seed of the sensor errors and noise (same seed, same flight).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Error-free sensors and initial state.
        #[arg(long)]
        perfect: bool,
        /// Leave out the scenario's [faults] (the fault-free reference flight).
        #[arg(long)]
        no_faults: bool,
    },
    /// Publish a navlog's init and sensor records over iceoryx2 at wall-clock rate.
    Play {
        /// The navlog to publish.
        log: PathBuf,
        /// Time scale (2 = twice as fast).
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
        /// Replay again and again: each pass re-initializes, and its time stamps move on by whole
        /// sidereal days (the Earth has the same orientation, so SRS stays consistent).
        #[arg(long = "loop")]
        repeat: bool,
        /// Number of passes with --loop (0 = until stopped).
        #[arg(long, default_value_t = 0)]
        passes: u64,
        /// iceoryx2 service prefix (the daemon's `prefix`; same rule).
        #[arg(long, default_value = msgs::service::DEFAULT_PREFIX, value_parser = prefix_arg)]
        prefix: String,
        /// Stall the IMU stream as a delayed driver would: from AT seconds of
        /// flight (sensor time after the init) publish no IMU sample for FOR
        /// seconds of wall-clock time while the aids go on, then the held
        /// samples at once. Repeat the option or separate stalls by commas.
        #[arg(long = "stall-imu", value_name = "AT:FOR", value_delimiter = ',', value_parser = stall_arg)]
        stall_imu: Vec<sensor_replay::live::ImuStall>,
    },
    /// Campaigns of many flights: plan, run here or on a cluster, status, merge.
    Campaign {
        #[command(subcommand)]
        cmd: sensor_replay::campaign::cli::CampaignCmd,
    },
    /// Flight recorder: subscribe to every service and write a navlog until stopped.
    Record {
        /// One file (`.mcap`: MCAP, else navlog).
        #[arg(long, required_unless_present = "out_dir", conflicts_with = "out_dir")]
        out: Option<PathBuf>,
        /// A directory of navlog pieces `flight-NNNNNN-YYYYMMDDTHHMMSSZ.navlog`
        /// (created if missing), each readable alone.
        #[arg(long)]
        out_dir: Option<PathBuf>,
        /// With --out-dir: start a new piece once the open one holds this
        /// many bytes (K, M, G, T: binary units; 64K to 1T).
        #[arg(long, requires = "out_dir")]
        rotate_bytes: Option<String>,
        /// With --out-dir: start a new piece after this many seconds of the
        /// recorder's clock (1 to 1e7).
        #[arg(long, requires = "out_dir")]
        rotate_secs: Option<f64>,
        /// With --out-dir: remove the oldest pieces (never the open one, never
        /// a file of another name) while the pieces hold more than this.
        #[arg(long, requires = "out_dir")]
        keep_bytes: Option<String>,
        /// The daemon's configuration file: record the services of its
        /// `prefix` (read and validated as the daemon does).
        #[arg(long)]
        config: Option<PathBuf>,
        /// iceoryx2 service prefix (the daemon's `prefix`; same rule; over
        /// the one of --config; default polarnav).
        #[arg(long, value_parser = prefix_arg)]
        prefix: Option<String>,
        /// Stop after this many seconds.
        #[arg(long)]
        duration: Option<f64>,
        /// With --out F.mcap: UTC time of the daemon's sensor time 0 (RFC
        /// 3339, e.g. 2026-11-25T09:30:00Z), so the MCAP log times are dates.
        #[arg(long, value_name = "RFC3339", requires = "out")]
        utc_start: Option<String>,
    },
    /// Live monitor: solution and status in place, a few times per second.
    Listen {
        /// iceoryx2 service prefix (the daemon's `prefix`; same rule).
        #[arg(long, default_value = msgs::service::DEFAULT_PREFIX, value_parser = prefix_arg)]
        prefix: String,
        /// Stop after this many seconds.
        #[arg(long)]
        duration: Option<f64>,
    },
    /// Live view in Foxglove: serve the daemon's solution and health over the
    /// Foxglove WebSocket protocol (open Foxglove, connect to ws://HOST:PORT).
    /// Only a subscriber of the daemon's outputs: it never slows the daemon.
    View {
        /// iceoryx2 service prefix (the daemon's `prefix`; same rule).
        #[arg(long, default_value = msgs::service::DEFAULT_PREFIX, value_parser = prefix_arg)]
        prefix: String,
        /// Address to listen on (0.0.0.0 for every interface of the flight computer).
        #[arg(long, default_value = "127.0.0.1")]
        host: String,
        /// TCP port (Foxglove's default is 8765; 0 picks a free one).
        #[arg(long, default_value_t = 8765)]
        port: u16,
        /// Most messages per second sent on each channel (0: no limit);
        /// above it messages are dropped, not queued, and counted.
        #[arg(long, value_name = "HZ", default_value_t = sensor_replay::view::DEFAULT_MAX_RATE_HZ)]
        max_rate: f64,
        /// Stop after this many seconds.
        #[arg(long)]
        duration: Option<f64>,
    },
    /// Export a navlog's truth (and more) to text formats.
    Export {
        /// The navlog to export.
        log: PathBuf,
        /// Write the log's truth as CSV (t_s, geodetic and ECEF position,
        /// ECEF velocity, body→ECEF quaternion).
        #[arg(long)]
        truth_csv: Option<PathBuf>,
        /// Write the log's solution records (e.g. a recorded live run) as a solution CSV.
        #[arg(long)]
        solution_csv: Option<PathBuf>,
        /// Write KF-GINS imu.txt and truth.nav into this directory.
        #[arg(long)]
        kfgins: Option<PathBuf>,
        /// Write every record as an MCAP file for Foxglove and PlotJuggler
        /// (inputs, solutions, status, aid health from status, frame
        /// switches, truth); the log is streamed, not loaded.
        #[arg(long)]
        mcap: Option<PathBuf>,
        /// With --mcap: UTC time of the log's sensor time 0 (RFC 3339, e.g.
        /// 2026-11-25T09:30:00Z), so the MCAP log times are dates.
        #[arg(long, value_name = "RFC3339", requires = "mcap")]
        utc_start: Option<String>,
    },
    /// Import KF-GINS text logs (IMU increments FRD, NED truth).
    ImportKfgins {
        /// KF-GINS imu.txt: time, angle and velocity increments (body FRD).
        #[arg(long)]
        imu: PathBuf,
        /// KF-GINS truth.nav: time, latitude, longitude, height, NED velocity,
        /// roll, pitch, yaw. Its first epoch is the init and the time base.
        /// Optional with --gnss (a real flight has no truth): the init is then
        /// the first fix with --init-att and --init-vel.
        #[arg(long, required_unless_present = "gnss")]
        truth: Option<PathBuf>,
        /// KF-GINS's GNSS file, on the IMU file's clock: time (s), latitude,
        /// longitude (deg), ellipsoidal height (m), σ north, east, down (m);
        /// or 13 columns with the NED velocity (m/s) after the height and
        /// its σ (m/s) last. Written as GNSS records: h_acc = √((σN²+σE²)/2),
        /// v_acc = σD; a 7-column fix is flagged as having no velocity and
        /// only its position is fused.
        #[arg(long)]
        gnss: Option<PathBuf>,
        #[command(flatten)]
        init: InitArgs,
        /// The navlog to write.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        aids: AidArgs,
    },
    /// Import a PSINS text IMU file (e.g. ../shared/datasets/psins-lasergyro/lasergyro.imu).
    ImportPsins {
        /// PSINS text IMU file (header, then one sample per line).
        file: PathBuf,
        /// The navlog to write.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        aids: AidArgs,
    },
    /// Print the shell completion script (e.g. `sensor-replay completions bash >
    /// /usr/share/bash-completion/completions/sensor-replay`).
    Completions {
        /// The shell to complete in.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff; `sensor-replay man > sensor-replay.1`).
    Man,
    /// Draw the 3D panel's top-down view of an MCAP file's polar frame (the
    /// `/track` entities and `/solution/pose` transforms), as the layout
    /// config/foxglove/polar-layout.json shows it in Foxglove.
    Scene {
        /// The MCAP file (`nav-daemon batch --out F.mcap`, `record`, `export`).
        mcap: PathBuf,
        /// The PNG to write.
        #[arg(long)]
        out: PathBuf,
        /// The frame to look down on: polar_north or polar_south.
        #[arg(long, default_value = "polar_north")]
        frame: String,
    },
    /// Accuracy of a solution against the log's truth, with figures.
    Eval {
        /// The navlog of the flight, whose truth the solution is judged against.
        #[arg(long)]
        log: PathBuf,
        /// The solution CSV, or the MCAP file of `nav-daemon batch --out F.mcap`
        /// (which also gives the innovations figure).
        #[arg(long)]
        solution: PathBuf,
        /// A second solution to compare (e.g. --conversion none), CSV or MCAP;
        /// judged against the truth too, so the log must have truth.
        #[arg(long)]
        compare: Option<PathBuf>,
        /// A reference solution in the same columns (e.g. a smoothed run, or
        /// a run with more aids), CSV or MCAP: the solution's difference from
        /// it is drawn with the solution's ±3σ. Needs no truth.
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Directory for summary.md and the figures.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

/// Aid streams synthesized from the truth of an imported log.
#[derive(Debug, clap::Args)]
struct AidArgs {
    /// Add a 1 Hz CNS stream with this horizontal σ (m).
    #[arg(long)]
    cns_sigma: Option<f64>,
    /// Add a 10 Hz barometer stream with this altitude σ (m).
    #[arg(long)]
    baro_sigma: Option<f64>,
    /// Add a 1 Hz SRS stream with this radial-velocity σ per line (m/s).
    #[arg(long)]
    srs_sigma: Option<f64>,
    /// Random seed of the synthesized noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The IMU's sensor grade (navigation, tactical, mems), written to the
    /// log header so that `batch` uses its noise model.
    #[arg(long)]
    preset: Option<String>,
}

/// The initial state of an import without truth (KF-GINS's `initatt`,
/// `initvel` and their σ); the position is the first GNSS fix's.
#[derive(clap::Args, Debug)]
struct InitArgs {
    /// Without --truth: initial roll, pitch, yaw of the FRD body against
    /// NED (deg), as KF-GINS's `initatt`.
    #[arg(
        long,
        value_name = "ROLL,PITCH,YAW",
        value_delimiter = ',',
        allow_negative_numbers = true,
        required_unless_present = "truth",
        conflicts_with = "truth"
    )]
    init_att: Option<Vec<f64>>,
    /// Without --truth: initial velocity north, east, down (m/s), as
    /// KF-GINS's `initvel`.
    #[arg(
        long,
        value_name = "VN,VE,VD",
        value_delimiter = ',',
        allow_negative_numbers = true,
        required_unless_present = "truth",
        conflicts_with = "truth"
    )]
    init_vel: Option<Vec<f64>>,
    /// 1-σ of the initial roll and pitch, and of the yaw (deg).
    #[arg(long, value_name = "TILT,YAW", value_delimiter = ',',
          default_values_t = [1.0, 5.0], conflicts_with = "truth")]
    init_att_sigma: Vec<f64>,
    /// 1-σ of the initial velocity, horizontal and vertical (m/s).
    #[arg(long, value_name = "H,V", value_delimiter = ',',
          default_values_t = [0.1, 0.1], conflicts_with = "truth")]
    init_vel_sigma: Vec<f64>,
}

impl InitArgs {
    fn given(&self) -> Result<Option<interop::GivenInit>, Fail> {
        let (Some(att), Some(vel)) = (&self.init_att, &self.init_vel) else {
            return Ok(None);
        };
        for (name, v, n) in [
            ("--init-att", att.as_slice(), 3),
            ("--init-vel", vel.as_slice(), 3),
            ("--init-att-sigma", self.init_att_sigma.as_slice(), 2),
            ("--init-vel-sigma", self.init_vel_sigma.as_slice(), 2),
        ] {
            if v.len() != n {
                return Err(Fail(
                    2,
                    format!(
                        "{name}: expected {n} comma-separated numbers, got {}",
                        v.len()
                    ),
                ));
            }
        }
        let three = |v: &[f64]| [v[0], v[1], v[2]];
        let g = interop::GivenInit {
            att_rpy_deg: three(att),
            vel_ned_mps: three(vel),
            sigma_tilt_deg: self.init_att_sigma[0],
            sigma_heading_deg: self.init_att_sigma[1],
            sigma_vel_h_mps: self.init_vel_sigma[0],
            sigma_vel_v_mps: self.init_vel_sigma[1],
        };
        g.check()
            .map_err(|m| Fail(2, format!("--init-att/--init-vel: {m}")))?;
        Ok(Some(g))
    }
}

impl AidArgs {
    fn synthesis(&self) -> Result<AidSynthesis, Fail> {
        for (name, v) in [
            ("--cns-sigma", self.cns_sigma),
            ("--baro-sigma", self.baro_sigma),
            ("--srs-sigma", self.srs_sigma),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0)
            {
                return Err(Fail(
                    2,
                    format!("{name}: expected a positive number, got {v}"),
                ));
            }
        }
        let preset = self
            .preset
            .as_deref()
            .map(polarnav_config::SensorGrade::parse)
            .transpose()
            .map_err(|m| Fail(2, format!("--preset: {m}")))?;
        Ok(AidSynthesis {
            cns_sigma_m: self.cns_sigma,
            baro_sigma_m: self.baro_sigma,
            srs_sigma_mps: self.srs_sigma,
            seed: self.seed,
            preset,
        })
    }
}

fn report_import(out: &std::path::Path, s: &interop::ImportSummary) {
    for (file, line, why) in s.skipped.lines.iter().take(20) {
        polarnav_ipc::note!("warning: {file}:{line}: skipped: {why}");
    }
    if s.skipped.count > 20 {
        polarnav_ipc::note!(
            "warning: ... and {} more skipped lines",
            s.skipped.count - 20
        );
    }
    polarnav_ipc::note!(
        "import: wrote {}: {} IMU, {} truth, {} CNS, {} baro, {} SRS, {} GNSS records; {} line(s) skipped; {} IMU line(s) unused (the time base, or before the init); {} GNSS fix(es) before the init unused",
        out.display(),
        s.imu,
        s.truth,
        s.cns,
        s.baro,
        s.srs,
        s.gnss,
        s.skipped.count,
        s.imu_unused,
        s.gnss_unused
    );
}

/// A failure with its exit status (2 bad input, 1 other).
struct Fail(u8, String);

/// Writes the completion script of `shell` for sensor-replay.
fn completions(shell: clap_complete::Shell, out: &mut dyn Write) {
    use clap::CommandFactory;
    clap_complete::generate(shell, &mut Cli::command(), "sensor-replay", out);
}

/// Writes sensor-replay's manual page (roff).
fn man(out: &mut dyn Write) -> std::io::Result<()> {
    use clap::CommandFactory;
    clap_mangen::Man::new(Cli::command()).render(out)
}

fn run(cli: Cli) -> Result<(), Fail> {
    let bad = |m: String| Fail(2, m);
    match cli.cmd {
        Cmd::Completions { shell } => {
            completions(shell, &mut std::io::stdout());
            Ok(())
        }
        // `sensor-replay man | head`: a reader that stopped is not an error.
        Cmd::Man => {
            let mut page = Vec::new();
            man(&mut page).map_err(|e| Fail(1, format!("man: {e}")))?;
            print_stdout(&String::from_utf8_lossy(&page))
        }
        Cmd::Scene { mcap, out, frame } => {
            if frame != "polar_north" && frame != "polar_south" {
                return Err(bad(format!(
                    "--frame: polar_north or polar_south, not {frame:?}"
                )));
            }
            let scene = sensor_replay::scene::read(&mcap, &frame).map_err(bad)?;
            let title = format!(
                "{}: top-down on {frame}. Blue: solution; grey: truth; orange: switch latitude; arrows: aircraft forward axis",
                mcap.file_name()
                    .map_or(String::new(), |n| n.to_string_lossy().into_owned())
            );
            sensor_replay::scene::draw(&scene, &title, &out).map_err(|e| Fail(1, e))?;
            polarnav_ipc::note!(
                "scene: {} lines, {} aircraft poses, {} markers in {frame} to {}",
                scene.lines.len(),
                scene.poses.len(),
                scene.markers.len(),
                out.display()
            );
            Ok(())
        }
        Cmd::Simulate {
            scenario,
            out,
            seed,
            perfect,
            no_faults,
        } => {
            let (s, text) = Scenario::load(&scenario).map_err(|e| bad(e.to_string()))?;
            let f = File::create(&out)
                .map_err(|e| Fail(1, format!("{}: cannot create: {e}", out.display())))?;
            let t0 = std::time::Instant::now();
            polarnav_ipc::note!(
                "simulate: {} ({:.0} s of flight, seed {seed}{})",
                s.name,
                s.duration_s(),
                if perfect { ", perfect sensors" } else { "" }
            );
            let sum = simulate::simulate(
                &s,
                &text,
                SimOptions {
                    seed,
                    perfect,
                    faults: !no_faults,
                    ..Default::default()
                },
                BufWriter::with_capacity(1 << 20, f),
            )
            .map_err(|e| Fail(1, format!("{}: {e}", out.display())))?;
            let aids: String = sum
                .aids
                .iter()
                .map(|(k, n)| format!("{n} {}, ", k.decl().label))
                .collect();
            polarnav_ipc::note!(
                "simulate: wrote {} in {:.1} s: {} IMU, {aids}{} truth records",
                out.display(),
                t0.elapsed().as_secs_f64(),
                sum.imu,
                sum.truth
            );
            if let Some(f) = s.faults.as_ref().filter(|_| !no_faults) {
                for (e, n) in f.events.iter().zip(&sum.injected) {
                    polarnav_ipc::note!(
                        "simulate: fault {:?} on {:?} at {} s for {} s: {n} samples",
                        e.kind,
                        e.stream,
                        e.start_s,
                        e.duration_s
                    );
                }
            }
            Ok(())
        }
        Cmd::Campaign { cmd } => {
            sensor_replay::campaign::cli::run(cmd).map_err(|(code, m)| Fail(code, m))
        }
        Cmd::Play {
            log,
            speed,
            repeat,
            passes,
            prefix,
            stall_imu,
        } => {
            if !(speed.is_finite() && speed > 0.0) {
                return Err(bad(format!(
                    "--speed: expected a positive number, got {speed}"
                )));
            }
            // Read through once here (the init, the IMU count, the length);
            // each pass reads the file again: memory is bounded whatever its length.
            let c = sensor_replay::live::LogOutline::read(&log).map_err(|e| bad(e.to_string()))?;
            if !c.report.is_clean() {
                polarnav_ipc::note!("warning: {}: {}", log.display(), c.report);
            }
            if c.init.is_none() {
                return Err(bad(format!("{}: no init record to publish", log.display())));
            }
            let stop = stop_flag()?;
            let loops = if repeat {
                if passes == 0 { u64::MAX } else { passes }
            } else {
                1
            };
            let cfg = polarnav_ipc::TransportConfig::new(&prefix);
            polarnav_ipc::note!(
                "play: {} ({} IMU samples) on {prefix}/... at {speed}x",
                log.display(),
                c.imu
            );
            let p = sensor_replay::live::play(&log, &c, &cfg, speed, loops, &stall_imu, &stop)
                .map_err(|e| Fail(1, e.to_string()))?;
            print_stdout(&format!("{}\n", p.summary()))?;
            Ok(())
        }
        Cmd::Record {
            out,
            out_dir,
            rotate_bytes,
            rotate_secs,
            keep_bytes,
            config,
            prefix,
            duration,
            utc_start,
        } => {
            use sensor_replay::pieces::{self, McapProvenance, Output, Rotation};
            if let Some(d) = duration
                && !(d.is_finite() && d > 0.0 && d <= 1e9)
            {
                return Err(bad(format!(
                    "--duration: expected seconds in (0, 1e9], got {d}"
                )));
            }
            let (lo, hi) = pieces::ROTATE_BYTES_RANGE;
            let rotate_bytes = rotate_bytes
                .map(|s| pieces::parse_bytes(&s, lo, hi))
                .transpose()
                .map_err(|e| bad(format!("--rotate-bytes: {e}")))?;
            if let Some(s) = rotate_secs {
                let (lo, hi) = pieces::ROTATE_SECS_RANGE;
                if !(s.is_finite() && (lo..=hi).contains(&s)) {
                    return Err(bad(format!(
                        "--rotate-secs: expected seconds in [{lo}, {hi}], got {s}"
                    )));
                }
            }
            // At least one closed piece of the largest size must fit.
            let keep_lo = rotate_bytes.unwrap_or(lo);
            let keep_bytes = keep_bytes
                .map(|s| pieces::parse_bytes(&s, keep_lo, pieces::KEEP_BYTES_MAX))
                .transpose()
                .map_err(|e| {
                    bad(format!(
                        "--keep-bytes: {e} (at least --rotate-bytes, so that a closed piece is kept)"
                    ))
                })?;
            // The prefix: --prefix, else the daemon's configuration's, read
            // by the same crate and validated as the daemon does.
            let prefix = match (&prefix, &config) {
                (Some(p), _) => p.clone(),
                (None, Some(path)) => {
                    let file =
                        polarnav_config::ConfigFile::load(path).map_err(|e| bad(e.to_string()))?;
                    let eff = polarnav_config::effective(
                        &file,
                        None,
                        &polarnav_config::CliOverrides::default(),
                    )
                    .map_err(|e| bad(e.to_string()))?;
                    eff.config.prefix
                }
                (None, None) => msgs::service::DEFAULT_PREFIX.to_owned(),
            };
            let (target, shown) = match (out, out_dir) {
                (Some(f), _) => (Output::File(f.clone()), f.display().to_string()),
                (None, Some(dir)) => {
                    std::fs::create_dir_all(&dir)
                        .map_err(|e| Fail(1, format!("{}: cannot create: {e}", dir.display())))?;
                    let shown = format!("{}/flight-*.navlog", dir.display());
                    (
                        Output::Dir(Rotation {
                            dir,
                            rotate_bytes,
                            rotate_secs,
                            keep_bytes,
                        }),
                        shown,
                    )
                }
                (None, None) => return Err(bad("--out FILE or --out-dir DIR is required".into())),
            };
            let utc_start = utc_start
                .as_deref()
                .map(polarnav_config::provenance::UtcStart::parse)
                .transpose()
                .map_err(|m| bad(format!("--utc-start: {m}")))?;
            if utc_start.is_some() && !matches!(&target, Output::File(f) if pieces::is_mcap(f)) {
                return Err(bad(format!(
                    "--utc-start: only an MCAP output has log times (a navlog keeps sensor time); --out {shown} is not .mcap"
                )));
            }
            // An MCAP file says what produced it, as `export` and `batch` do.
            let args: Vec<String> = std::env::args().collect();
            let mcap = McapProvenance {
                provenance: polarnav_config::provenance::provenance(
                    "sensor-replay record",
                    &args,
                    utc_start.as_ref(),
                ),
                epoch_ns: utc_start.as_ref().map(|u| u.ns),
            };
            let stop = stop_flag()?;
            let cfg = polarnav_ipc::TransportConfig::new(&prefix);
            polarnav_ipc::note!("record: {prefix}/... -> {shown} (stop with Ctrl-C)");
            let n = sensor_replay::live::record(
                &cfg,
                target,
                pieces::create_file(),
                mcap,
                &stop,
                duration.map(std::time::Duration::from_secs_f64),
            )
            .map_err(|e| Fail(1, e.to_string()))?;
            print_stdout(&format!(
                "record: {} records ({} solutions) written to {shown} in {} piece(s), {} removed by --keep-bytes; {} records lost to a full disk or a failed write\n",
                n.records, n.solutions, n.pieces, n.removed, n.lost
            ))?;
            Ok(())
        }
        Cmd::Listen { prefix, duration } => {
            let stop = stop_flag()?;
            let cfg = polarnav_ipc::TransportConfig::new(&prefix);
            sensor_replay::monitor::listen(
                &cfg,
                &stop,
                duration.map(std::time::Duration::from_secs_f64),
            )
            .map_err(|e| Fail(1, e.to_string()))
        }
        Cmd::View {
            prefix,
            host,
            port,
            max_rate,
            duration,
        } => {
            if let Some(d) = duration
                && !(0.0..1e9).contains(&d)
            {
                return Err(bad(format!("--duration: expected seconds ≥ 0, got {d}")));
            }
            let max_rate = sensor_replay::view::check_max_rate(max_rate)
                .map_err(|m| bad(format!("--max-rate: {m}")))?;
            let stop = stop_flag()?;
            let cfg = polarnav_ipc::TransportConfig::new(&prefix);
            let n = sensor_replay::view::view(
                &cfg,
                &host,
                port,
                max_rate,
                &stop,
                duration.map(std::time::Duration::from_secs_f64),
                |port| {
                    // A test or a script reads the port from this line.
                    polarnav_ipc::note!("view: serving {prefix}/solution and {prefix}/status on ws://{host}:{port} (Foxglove WebSocket)");
                },
            )
            .map_err(|e| Fail(1, e.to_string()))?;
            let dropped: Vec<String> = n.dropped.iter().map(|(t, k)| format!("{t} {k}")).collect();
            print_stdout(&format!(
                "view: {} solutions and {} status forwarded, {} solutions missed; dropped by --max-rate: {}; {} client(s) refused\n",
                n.solutions,
                n.status,
                n.solution_gaps,
                if dropped.is_empty() {
                    "none".to_owned()
                } else {
                    dropped.join(", ")
                },
                n.refused_clients
            ))?;
            Ok(())
        }
        Cmd::ImportKfgins {
            imu,
            truth,
            gnss,
            init,
            out,
            aids,
        } => {
            let aids = aids.synthesis()?;
            if truth.is_none() && aids.any() {
                return Err(bad(
                    "--cns-sigma, --baro-sigma and --srs-sigma synthesize aids from the truth: give --truth"
                        .into(),
                ));
            }
            let files = interop::KfginsFiles {
                imu: &imu,
                truth: truth.as_deref(),
                gnss: gnss.as_deref(),
                init: init.given()?,
            };
            let f = File::create(&out)
                .map_err(|e| Fail(1, format!("{}: cannot create: {e}", out.display())))?;
            let s = interop::import_kfgins_files(&files, &aids, BufWriter::new(f))
                .map_err(import_fail)?;
            report_import(&out, &s);
            Ok(())
        }
        Cmd::ImportPsins { file, out, aids } => {
            let aids = aids.synthesis()?;
            let f = File::create(&out)
                .map_err(|e| Fail(1, format!("{}: cannot create: {e}", out.display())))?;
            let s = interop::import_psins(&file, &aids, BufWriter::new(f)).map_err(import_fail)?;
            report_import(&out, &s);
            Ok(())
        }
        Cmd::Export {
            log,
            truth_csv,
            solution_csv,
            kfgins,
            mcap,
            utc_start,
        } => {
            let utc_start = utc_start
                .as_deref()
                .map(polarnav_config::provenance::UtcStart::parse)
                .transpose()
                .map_err(|m| bad(format!("--utc-start: {m}")))?;
            if let Some(p) = &mcap {
                let n = export_mcap(&log, p, utc_start.as_ref())?;
                polarnav_ipc::note!("export: {n} records to {}", p.display());
                if truth_csv.is_none() && solution_csv.is_none() && kfgins.is_none() {
                    return Ok(());
                }
            }
            let c = logfile::load(&log).map_err(|e| bad(e.to_string()))?;
            if !c.report.is_clean() {
                polarnav_ipc::note!("warning: {}: {}", log.display(), c.report);
            }
            if let Some(p) = truth_csv {
                let f = File::create(&p).map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
                export::write_truth_csv(BufWriter::new(f), &c.truth)
                    .map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
                polarnav_ipc::note!("export: {} truth rows to {}", c.truth.len(), p.display());
            }
            if let Some(p) = solution_csv {
                let mut f = BufWriter::new(
                    File::create(&p).map_err(|e| Fail(1, format!("{}: {e}", p.display())))?,
                );
                let io = |e: std::io::Error| Fail(1, format!("{}: {e}", p.display()));
                writeln!(f, "{}", polarnav::solution_csv::header()).map_err(io)?;
                for s in &c.solution {
                    polarnav::solution_csv::write_row(&mut f, s).map_err(io)?;
                }
                f.flush().map_err(io)?;
                polarnav_ipc::note!(
                    "export: {} solution rows to {}",
                    c.solution.len(),
                    p.display()
                );
            }
            if let Some(dir) = kfgins {
                interop::export_kfgins(&dir, &c.imu, &c.truth)
                    .map_err(|e| Fail(1, format!("{}: {e}", dir.display())))?;
                polarnav_ipc::note!(
                    "export: KF-GINS imu.txt ({} samples) and truth.nav ({} rows) in {}",
                    c.imu.len(),
                    c.truth.len(),
                    dir.display()
                );
            }
            Ok(())
        }
        Cmd::Eval {
            log,
            solution,
            compare,
            reference,
            out,
        } => {
            use polarnav_eval::run::{self, EvalError};
            let e = run::run(&run::Args {
                log: &log,
                solution: &solution,
                compare: compare.as_deref(),
                reference: reference.as_deref(),
                out: out.as_deref(),
            })
            .map_err(|e| match e {
                EvalError::Input(m) => bad(m),
                EvalError::Output(m) => Fail(1, m),
            })?;
            for n in &e.notes {
                polarnav_ipc::note!("{n}");
            }
            let md = e.markdown;
            // `eval ... | head`: the reader may stop early; the summary
            // file below is written all the same.
            print_stdout(&format!("{md}\n"))?;
            if let Some(dir) = out {
                std::fs::create_dir_all(&dir)
                    .map_err(|e| Fail(1, format!("{}: {e}", dir.display())))?;
                let p = dir.join("summary.md");
                let mut f =
                    File::create(&p).map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
                f.write_all(md.as_bytes())
                    .map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
            }
            Ok(())
        }
    }
}

/// Streams a navlog into an MCAP file, record by record (bounded memory);
/// a damaged record costs itself, as in every reader of the project. Its
/// provenance (this program, version, commit, command line) is a metadata
/// record; `utc_start` makes the log times dates.
fn export_mcap(
    log: &std::path::Path,
    out: &std::path::Path,
    utc_start: Option<&polarnav_config::provenance::UtcStart>,
) -> Result<u64, Fail> {
    let f = File::open(log).map_err(|e| Fail(2, format!("{}: cannot open: {e}", log.display())))?;
    let mut reader = msgs::navlog::NavlogReader::new(std::io::BufReader::with_capacity(1 << 20, f));
    let mut m = McapFile::create(out, AidSource::Status).map_err(|e| Fail(1, e.to_string()))?;
    if let Some(u) = utc_start {
        m.channels().set_epoch_ns(u.ns);
    }
    let args: Vec<String> = std::env::args().collect();
    m.metadata(
        "polarnav.provenance",
        polarnav_config::provenance::provenance("sensor-replay export", &args, utc_start),
    )
    .map_err(|e| Fail(1, e.to_string()))?;
    let mut n = 0u64;
    while let Some(r) = reader
        .next_record()
        .map_err(|e| Fail(2, format!("{}: {e}", log.display())))?
    {
        match &r {
            msgs::navlog::Record::Header(h) => m.header(h).map_err(|e| Fail(1, e.to_string()))?,
            other => m.channels().record(other),
        }
        n += 1;
    }
    if !reader.report().is_clean() {
        polarnav_ipc::note!("warning: {}: {}", log.display(), reader.report());
    }
    m.close().map_err(|e| Fail(1, e.to_string()))?;
    Ok(n)
}

/// Writes `text` to standard output. A reader that stopped reading
/// (`sensor-replay eval ... | head`: a broken pipe) is not an error: the
/// rest of the text is dropped quietly and the command goes on (its files
/// are still written) and exits as it would have. Rust ignores SIGPIPE, so
/// without this `println!` panics there.
fn print_stdout(text: &str) -> Result<(), Fail> {
    sensor_replay::write_stdout(text.as_bytes())
        .map(drop)
        .map_err(|e| Fail(1, format!("standard output: {e}")))
}

/// SIGINT/SIGTERM set the returned flag (the loops finish their cycle and exit cleanly).
fn stop_flag() -> Result<std::sync::Arc<std::sync::atomic::AtomicBool>, Fail> {
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = std::sync::Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
        .map_err(|e| Fail(1, format!("cannot install the signal handler: {e}")))?;
    Ok(stop)
}

fn import_fail(e: ImportError) -> Fail {
    match e {
        ImportError::Write(_) => Fail(1, e.to_string()),
        _ => Fail(2, e.to_string()),
    }
}

/// `--prefix`: the one prefix rule of the project ([`msgs::service::validate_prefix`]).
fn prefix_arg(s: &str) -> Result<String, String> {
    msgs::service::validate_prefix(s).map(|()| s.to_owned())
}

fn stall_arg(s: &str) -> Result<sensor_replay::live::ImuStall, String> {
    sensor_replay::live::ImuStall::parse(s)
}

fn main() -> ExitCode {
    polarnav_ipc::logging::init("sensor-replay");
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Fail(code, msg)) => {
            polarnav_ipc::note!("error: {msg}");
            ExitCode::from(code)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// The arguments (path of subcommands, then id) and subcommands without help text.
    fn undocumented(cmd: &clap::Command, path: &str, out: &mut Vec<String>) {
        for a in cmd.get_arguments() {
            if a.get_help().is_none() && a.get_long_help().is_none() {
                out.push(format!("{path} {}", a.get_id()));
            }
        }
        for s in cmd.get_subcommands() {
            let sub = format!("{path} {}", s.get_name());
            if s.get_about().is_none() && s.get_long_about().is_none() {
                out.push(sub.clone());
            }
            undocumented(s, &sub, out);
        }
    }

    #[test]
    fn bash_completion_knows_the_subcommands_and_options() {
        let mut out = Vec::new();
        completions(clap_complete::Shell::Bash, &mut out);
        let text = String::from_utf8(out).expect("utf8");
        for word in [
            "sensor-replay",
            "simulate",
            "eval",
            "listen",
            "completions",
            "man",
            "--scenario",
        ] {
            assert!(text.contains(word), "{word} missing");
        }
    }

    #[test]
    fn man_page_is_roff_naming_the_program() {
        let mut out = Vec::new();
        man(&mut out).expect("render");
        let text = String::from_utf8(out).expect("utf8");
        assert!(text.starts_with('.'), "{text}");
        assert!(
            text.lines().any(|l| l.starts_with(".TH sensor-replay 1")),
            "{text}"
        );
        assert!(text.contains("simulate"), "{text}");
    }

    #[test]
    fn every_argument_and_subcommand_has_help_text() {
        let mut missing = Vec::new();
        undocumented(&Cli::command(), "sensor-replay", &mut missing);
        assert!(missing.is_empty(), "no help text for {missing:?}");
    }
}
