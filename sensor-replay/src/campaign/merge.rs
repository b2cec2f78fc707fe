//! `sensor-replay campaign merge DIR`: every run's result gathered into two
//! Parquet tables and a report with figures.
//!
//! ```text
//! DIR/merged/metrics.parquet   one row per run with a usable result (its Metrics), by index
//! DIR/merged/cost.parquet      the same runs' Cost rows, by index
//! DIR/merged/report.md         the report; its figures in DIR/merged/figures/
//! ```
//!
//! The metrics table is a function of the rows alone: the same rows give
//! the same bytes (one row group, fixed writer settings, no time stamps, no
//! hash-map order), so a campaign run on a laptop and by a Slurm array
//! merge to identical files. Every [`Metrics`] field is a column, in the
//! struct's order, under its own name: `u64` as INT64 and `u32` as INT32
//! with the unsigned integer logical type, `f64` as DOUBLE, `bool` as
//! BOOLEAN, strings as UTF-8 BYTE_ARRAY, [`Outcome`] as its name; an
//! `Option` is an optional column whose `None` is a null. Uncompressed
//! (the dictionary encoding already shrinks the repeated strings, and the
//! floats do not compress), readable by any Parquet reader (pandas,
//! polars, pyarrow, DuckDB, Spark).
//!
//! Runs with no result or an unusable one (torn, of another campaign) are
//! counted and listed by index ranges, not an error: the report says which
//! to run again.
//!
//! Memory: the rows themselves (about 1 KiB per run with their strings)
//! and, one at a time, a column's values and a statistic's sorted copy.
//! On a 2-core machine 100 000 runs merge in 2.6 s with their files in
//! the page cache, 3.6 s read from the disk, in 133 MB
//! (`tests/benches/campaign_merge.rs`).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::fs;
use std::io::{BufWriter, Write as _};
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use parquet::basic::{LogicalType, Repetition, Type as PhysicalType};
use parquet::data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, Int32Type, Int64Type};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{EnabledStatistics, WriterProperties, WriterVersion};
use parquet::file::writer::{SerializedColumnWriter, SerializedFileWriter};
use parquet::schema::types::Type;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use polarnav_eval::plots::{Format, Mark, init_fonts, legend};

use super::row::{Cost, Metrics, Outcome};
use super::stats::{self, StatsError};
use super::store;

/// The confidence of every bound and band of the report.
pub const CONFIDENCE: f64 = 0.95;
/// Acceptance: the 95 % upper bound on the false-alarm rate (per flight hour).
pub const FALSE_ALARM_LIMIT_PER_H: f64 = 0.002;
/// Acceptance: the 95 % lower bound on each spoofer profile's detection rate.
pub const DETECTION_LIMIT: f64 = 0.99;
/// Acceptance: the average NEES is judged over at least this many runs.
pub const NEES_MIN_RUNS: u64 = 100;
/// Degrees of freedom of each NEES value (position, velocity, attitude).
const NEES_DOF: u32 = 3;
/// Curves per figure: more would not tell apart by colour.
const CURVES_PER_FIGURE: usize = 8;
/// Points of a drawn CDF (the upper tail gets as many again).
const CDF_POINTS: usize = 800;
/// Threads reading the results. The reading waits on the disk or the
/// network file system more than it computes (a checksum and a JSON parse
/// per file): on a 2-core machine with the page cache cold, 100 000 runs
/// read in 10.3 s on 2 threads, 5.3 s on 8, 4.4 s on 16, 4.0 s on 32.
const READERS: u64 = 16;
/// Unusable results whose reason the summary keeps (all are counted).
const UNUSABLE_KEPT: usize = 100;

/// Why the merge could not write its output (an unusable run result is not
/// an error: it is counted and listed).
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: writing Parquet: {message}")]
    Parquet { path: String, message: String },
    #[error("{path}: drawing the figure: {message}")]
    Figure { path: String, message: String },
    #[error("{path}: reading the results: a reader thread panicked")]
    Reader { path: String },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> MergeError + '_ {
    move |source| MergeError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// What a merge found and wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct MergeSummary {
    /// Runs of the campaign (indices 0..runs).
    pub runs: u64,
    /// Runs with a usable result (the rows of the tables), of which
    /// navigated (`ok`) and failed.
    pub rows: u64,
    pub ok: u64,
    pub failed: u64,
    /// Runs with no usable result (absent or unusable), as inclusive
    /// ranges of indices, and their count.
    pub missing: Vec<RangeInclusive<u64>>,
    pub missing_count: u64,
    /// The unusable results among them (a file there but refused), the
    /// first [`UNUSABLE_KEPT`] with why, and their count.
    pub unusable: Vec<(u64, String)>,
    pub unusable_count: u64,
    /// Flight hours navigated by the `ok` runs.
    pub flight_h: f64,
    pub metrics_parquet: PathBuf,
    pub cost_parquet: PathBuf,
    pub report: PathBuf,
    pub figures: Vec<PathBuf>,
}

impl std::fmt::Display for MergeSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} runs: {} done, {} failed, {} missing ({} unusable); {} flight hours",
            self.runs,
            self.ok,
            self.failed,
            self.missing_count,
            self.unusable_count,
            hours(self.flight_h)
        )?;
        if !self.missing.is_empty() {
            writeln!(f, "missing: {}", ranges_text(&self.missing, 20))?;
        }
        writeln!(f, "wrote {}", self.metrics_parquet.display())?;
        writeln!(f, "wrote {}", self.cost_parquet.display())?;
        write!(
            f,
            "wrote {} ({} figures)",
            self.report.display(),
            self.figures.len()
        )
    }
}

/// Merges the results of runs `0..runs` of the campaign whose file hashes
/// to `campaign_sha256` in `dir`: writes `DIR/merged/metrics.parquet`,
/// `DIR/merged/cost.parquet`, `DIR/merged/report.md` (titled `title`) and
/// its figures, each to a temporary name first, then renamed.
pub fn merge(
    dir: &Path,
    campaign_sha256: &str,
    runs: u64,
    title: &str,
) -> Result<MergeSummary, MergeError> {
    let read = read_all(dir, campaign_sha256, runs)?;
    let out = dir.join("merged");
    let fig_dir = out.join("figures");
    fs::create_dir_all(&fig_dir).map_err(io_err(&fig_dir))?;

    let metrics_parquet = out.join("metrics.parquet");
    let kv = vec![KeyValue::new(
        "polarnav.campaign_sha256".to_owned(),
        campaign_sha256.to_owned(),
    )];
    write_table(
        &metrics_parquet,
        "metrics",
        &metrics_columns(),
        &read.metrics,
        kv.clone(),
    )?;
    let cost_parquet = out.join("cost.parquet");
    write_table(&cost_parquet, "cost", &cost_columns(), &read.costs, kv)?;

    let ok = read
        .metrics
        .iter()
        .filter(|m| m.outcome == Outcome::Ok)
        .count() as u64;
    let flight_h: f64 = read
        .metrics
        .iter()
        .filter(|m| m.outcome == Outcome::Ok)
        .filter_map(|m| m.flight_h)
        .filter(|h| h.is_finite())
        .sum();
    let mut summary = MergeSummary {
        runs,
        rows: read.metrics.len() as u64,
        ok,
        failed: read.metrics.len() as u64 - ok,
        missing_count: read.missing.iter().map(|r| r.end() - r.start() + 1).sum(),
        missing: read.missing,
        unusable: read.unusable,
        unusable_count: read.unusable_count,
        flight_h,
        metrics_parquet,
        cost_parquet,
        report: out.join("report.md"),
        figures: Vec::new(),
    };
    let report = Report::new(&read.metrics, &read.costs);
    summary.figures = report.figures(&fig_dir)?;
    remove_stale_figures(&fig_dir, &summary.figures);
    let text = report.markdown(title, campaign_sha256, &summary, &out);
    write_atomic(&summary.report, text.as_bytes())?;
    // The renames reach the disk with their directories.
    for d in [&fig_dir, &out] {
        if let Ok(f) = fs::File::open(d) {
            let _ = f.sync_all();
        }
    }
    Ok(summary)
}

// ---------------------------------------------------------------------------
// Reading

/// The results read, in index order.
#[derive(Debug, Default)]
struct Read {
    metrics: Vec<Metrics>,
    costs: Vec<Cost>,
    missing: Vec<RangeInclusive<u64>>,
    unusable: Vec<(u64, String)>,
    unusable_count: u64,
}

impl Read {
    fn add_missing(&mut self, i: u64) {
        match self.missing.last_mut() {
            Some(r) if *r.end() + 1 == i => *r = *r.start()..=i,
            _ => self.missing.push(i..=i),
        }
    }

    /// Appends the next chunk (indices after all of this one's).
    fn append(&mut self, mut next: Read) {
        self.metrics.append(&mut next.metrics);
        self.costs.append(&mut next.costs);
        let mut ranges = next.missing.into_iter().peekable();
        if let (Some(last), Some(first)) = (self.missing.last_mut(), ranges.peek())
            && *last.end() + 1 == *first.start()
        {
            *last = *last.start()..=*first.end();
            ranges.next();
        }
        self.missing.extend(ranges);
        let room = UNUSABLE_KEPT.saturating_sub(self.unusable.len());
        self.unusable.extend(next.unusable.into_iter().take(room));
        self.unusable_count += next.unusable_count;
    }
}

/// Reads runs `0..runs` on [`READERS`] threads, each a contiguous range of
/// indices.
fn read_all(dir: &Path, sha: &str, runs: u64) -> Result<Read, MergeError> {
    let threads = READERS.min(runs / 512 + 1).max(1);
    let per = runs.div_ceil(threads);
    let chunks: Vec<Result<Read, MergeError>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let (a, b) = (t * per, ((t + 1) * per).min(runs));
                s.spawn(move || read_range(dir, sha, a, b))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join().map_err(|_| MergeError::Reader {
                    path: store::runs_dir(dir).display().to_string(),
                })
            })
            .collect()
    });
    let chunks = chunks
        .into_iter()
        .collect::<Result<Vec<Read>, MergeError>>()?;
    let n = chunks.iter().map(|c| c.metrics.len()).sum();
    let mut all = Read {
        metrics: Vec::with_capacity(n),
        costs: Vec::with_capacity(n),
        ..Read::default()
    };
    for c in chunks {
        all.append(c);
    }
    Ok(all)
}

fn read_range(dir: &Path, sha: &str, from: u64, to: u64) -> Read {
    let n = (to - from) as usize;
    let mut r = Read {
        metrics: Vec::with_capacity(n),
        costs: Vec::with_capacity(n),
        ..Read::default()
    };
    for i in from..to {
        match store::read_result(dir, i, sha) {
            Ok(Some(res)) => {
                r.metrics.push(res.metrics);
                r.costs.push(res.cost);
            }
            Ok(None) => r.add_missing(i),
            Err(e) => {
                r.add_missing(i);
                r.unusable_count += 1;
                if r.unusable.len() < UNUSABLE_KEPT {
                    r.unusable.push((i, e.to_string()));
                }
            }
        }
    }
    r
}

// ---------------------------------------------------------------------------
// Parquet

/// How a column is stored, and the Arrow type readers give it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnKind {
    U64,
    U32,
    F64,
    Bool,
    Str,
}

impl ColumnKind {
    /// The Arrow type name (as pyarrow prints it) a reader gives the column.
    pub fn arrow_name(self) -> &'static str {
        match self {
            ColumnKind::U64 => "uint64",
            ColumnKind::U32 => "uint32",
            ColumnKind::F64 => "double",
            ColumnKind::Bool => "bool",
            ColumnKind::Str => "string",
        }
    }
}

/// A column's value of a row.
enum Get<R> {
    U64(fn(&R) -> Option<u64>),
    U32(fn(&R) -> Option<u32>),
    F64(fn(&R) -> Option<f64>),
    Bool(fn(&R) -> Option<bool>),
    Str(fn(&R) -> Option<&str>),
}

/// A column of a table: its name, whether it may be null, its value.
struct Column<R> {
    name: &'static str,
    nullable: bool,
    get: Get<R>,
}

impl<R> Column<R> {
    fn req(name: &'static str, get: Get<R>) -> Self {
        Column {
            name,
            nullable: false,
            get,
        }
    }
    fn opt(name: &'static str, get: Get<R>) -> Self {
        Column {
            name,
            nullable: true,
            get,
        }
    }
    fn kind(&self) -> ColumnKind {
        match self.get {
            Get::U64(_) => ColumnKind::U64,
            Get::U32(_) => ColumnKind::U32,
            Get::F64(_) => ColumnKind::F64,
            Get::Bool(_) => ColumnKind::Bool,
            Get::Str(_) => ColumnKind::Str,
        }
    }
}

type M = Metrics;

/// The metrics table's columns: every [`Metrics`] field, in its order.
fn metrics_columns() -> Vec<Column<Metrics>> {
    use Get::*;
    vec![
        Column::req("index", U64(|m: &M| Some(m.index))),
        Column::req("variation", U32(|m: &M| Some(m.variation))),
        Column::req("variation_label", Str(|m: &M| Some(&m.variation_label))),
        Column::req("scenario", Str(|m: &M| Some(&m.scenario))),
        Column::req("seed", U64(|m: &M| Some(m.seed))),
        Column::req("outcome", Str(|m: &M| Some(m.outcome.name()))),
        Column::req("reason", Str(|m: &M| Some(&m.reason))),
        Column::opt("flight_h", F64(|m: &M| m.flight_h)),
        Column::opt("epochs", U64(|m: &M| m.epochs)),
        Column::opt("non_finite_epochs", U64(|m: &M| m.non_finite_epochs)),
        Column::opt("horizontal_rmse_m", F64(|m: &M| m.horizontal_rmse_m)),
        Column::opt("horizontal_max_m", F64(|m: &M| m.horizontal_max_m)),
        Column::opt("vertical_rmse_m", F64(|m: &M| m.vertical_rmse_m)),
        Column::opt("vertical_max_m", F64(|m: &M| m.vertical_max_m)),
        Column::opt("velocity_rmse_mps", F64(|m: &M| m.velocity_rmse_mps)),
        Column::opt("velocity_max_mps", F64(|m: &M| m.velocity_max_mps)),
        Column::opt("attitude_rmse_arcmin", F64(|m: &M| m.attitude_rmse_arcmin)),
        Column::opt("attitude_max_arcmin", F64(|m: &M| m.attitude_max_arcmin)),
        Column::opt("nees_position", F64(|m: &M| m.nees_position)),
        Column::opt("nees_velocity", F64(|m: &M| m.nees_velocity)),
        Column::opt("nees_attitude", F64(|m: &M| m.nees_attitude)),
        Column::opt("switches", U32(|m: &M| m.switches)),
        Column::opt("resets", U32(|m: &M| m.resets)),
        Column::opt("resets_aid", U32(|m: &M| m.resets_aid)),
        Column::opt("resets_integrity", U32(|m: &M| m.resets_integrity)),
        Column::opt("reset_causes", Str(|m: &M| m.reset_causes.as_deref())),
        Column::opt("reinits", U32(|m: &M| m.reinits)),
        Column::opt("covariance_repairs", U64(|m: &M| m.covariance_repairs)),
        Column::opt("gnss_fixes", U64(|m: &M| m.gnss_fixes)),
        Column::opt("gnss_tested", U64(|m: &M| m.gnss_tested)),
        Column::opt("gnss_untested", U64(|m: &M| m.gnss_untested)),
        Column::opt("gnss_exclusions", U64(|m: &M| m.gnss_exclusions)),
        Column::opt("gnss_readmissions", U64(|m: &M| m.gnss_readmissions)),
        Column::opt(
            "gnss_false_exclusions",
            U64(|m: &M| m.gnss_false_exclusions),
        ),
        Column::opt("max_q_ratio", F64(|m: &M| m.max_q_ratio)),
        Column::opt("fault", Str(|m: &M| m.fault.as_deref())),
        Column::opt("fault_start_s", F64(|m: &M| m.fault_start_s)),
        Column::opt("fault_detected", Bool(|m: &M| m.fault_detected)),
        Column::opt("time_to_exclusion_s", F64(|m: &M| m.time_to_exclusion_s)),
        Column::opt("error_at_exclusion_m", F64(|m: &M| m.error_at_exclusion_m)),
        Column::opt("judgement_pass", Bool(|m: &M| m.judgement_pass)),
        Column::opt(
            "judgement_failures",
            Str(|m: &M| m.judgement_failures.as_deref()),
        ),
    ]
}

/// The cost table's columns: every [`Cost`] field, in its order.
fn cost_columns() -> Vec<Column<Cost>> {
    use Get::*;
    vec![
        Column::req("index", U64(|c: &Cost| Some(c.index))),
        Column::req("flight_h", F64(|c: &Cost| Some(c.flight_h))),
        Column::req("cpu_s", F64(|c: &Cost| Some(c.cpu_s))),
        Column::req("simulate_cpu_s", F64(|c: &Cost| Some(c.simulate_cpu_s))),
        Column::req("navigate_cpu_s", F64(|c: &Cost| Some(c.navigate_cpu_s))),
        Column::req("evaluate_cpu_s", F64(|c: &Cost| Some(c.evaluate_cpu_s))),
        Column::req("wall_s", F64(|c: &Cost| Some(c.wall_s))),
        Column::req("peak_rss_mib", F64(|c: &Cost| Some(c.peak_rss_mib))),
        Column::req("host", Str(|c: &Cost| Some(&c.host))),
        Column::req("executor", Str(|c: &Cost| Some(&c.executor))),
        Column::req("version", Str(|c: &Cost| Some(&c.version))),
        Column::req("commit", Str(|c: &Cost| Some(&c.commit))),
    ]
}

/// The expectations `tests/python/check_campaign_parquet.py` checks the
/// metrics table merged from `rows` against, as JSON: the row count, and
/// per column (in order) its name, Arrow type, whether it is nullable and
/// its null count. A `Some(NaN)` counts as a null: a result file's JSON
/// writes a NaN as `null`, which reads back as `None`, so no NaN reaches
/// the table.
pub fn parquet_expectations(rows: &[Metrics]) -> String {
    let cols: Vec<serde_json::Value> = metrics_columns()
        .iter()
        .map(|c| {
            let nulls = rows.iter().filter(|r| is_null(c, r)).count();
            serde_json::json!({
                "name": c.name,
                "type": c.kind().arrow_name(),
                "nullable": c.nullable,
                "nulls": nulls,
            })
        })
        .collect();
    serde_json::json!({ "rows": rows.len(), "columns": cols }).to_string()
}

fn is_null<R>(c: &Column<R>, r: &R) -> bool {
    match c.get {
        Get::U64(f) => f(r).is_none(),
        Get::U32(f) => f(r).is_none(),
        Get::F64(f) => f(r).is_none_or(f64::is_nan),
        Get::Bool(f) => f(r).is_none(),
        Get::Str(f) => f(r).is_none(),
    }
}

fn parquet_schema<R>(message: &str, cols: &[Column<R>]) -> parquet::errors::Result<Type> {
    let fields = cols
        .iter()
        .map(|c| {
            let (physical, logical) = match c.kind() {
                ColumnKind::U64 => (PhysicalType::INT64, Some(LogicalType::integer(64, false))),
                ColumnKind::U32 => (PhysicalType::INT32, Some(LogicalType::integer(32, false))),
                ColumnKind::F64 => (PhysicalType::DOUBLE, None),
                ColumnKind::Bool => (PhysicalType::BOOLEAN, None),
                ColumnKind::Str => (PhysicalType::BYTE_ARRAY, Some(LogicalType::String)),
            };
            let repetition = if c.nullable {
                Repetition::OPTIONAL
            } else {
                Repetition::REQUIRED
            };
            Type::primitive_type_builder(c.name, physical)
                .with_repetition(repetition)
                .with_logical_type(logical)
                .build()
                .map(Arc::new)
        })
        .collect::<parquet::errors::Result<Vec<_>>>()?;
    Type::group_type_builder(message)
        .with_fields(fields)
        .build()
}

/// The writer's settings, fixed so that the bytes depend on the rows
/// alone: Parquet 1.0 data pages, dictionary encoding, no compression,
/// chunk-level statistics, no bloom filter, one row group whatever the
/// row count, the library's default `created_by` (its version).
fn writer_properties(kv: Vec<KeyValue>) -> WriterProperties {
    WriterProperties::builder()
        .set_writer_version(WriterVersion::PARQUET_1_0)
        .set_compression(parquet::basic::Compression::UNCOMPRESSED)
        .set_dictionary_enabled(true)
        .set_statistics_enabled(EnabledStatistics::Chunk)
        .set_bloom_filter_enabled(false)
        .set_max_row_group_row_count(None)
        .set_key_value_metadata(Some(kv))
        .build()
}

/// Writes `rows` as a Parquet table of `cols` at `path` (via a temporary
/// name in the same directory, synced, renamed).
fn write_table<R>(
    path: &Path,
    message: &str,
    cols: &[Column<R>],
    rows: &[R],
    kv: Vec<KeyValue>,
) -> Result<(), MergeError> {
    let pq = |e: parquet::errors::ParquetError| MergeError::Parquet {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let tmp = temp_name(path);
    let file = fs::File::create(&tmp).map_err(io_err(&tmp))?;
    let schema = Arc::new(parquet_schema(message, cols).map_err(pq)?);
    let props = Arc::new(writer_properties(kv));
    let result = (|| {
        let mut w =
            SerializedFileWriter::new(BufWriter::with_capacity(1 << 20, file), schema, props)
                .map_err(pq)?;
        if !rows.is_empty() {
            let mut rg = w.next_row_group().map_err(pq)?;
            for c in cols {
                let mut cw = rg.next_column().map_err(pq)?.ok_or_else(|| {
                    pq(parquet::errors::ParquetError::General(format!(
                        "no column writer for {}",
                        c.name
                    )))
                })?;
                write_column(&mut cw, c, rows).map_err(pq)?;
                cw.close().map_err(pq)?;
            }
            rg.close().map_err(pq)?;
        }
        let buf = w.into_inner().map_err(pq)?;
        let file = buf.into_inner().map_err(|e| MergeError::Io {
            path: tmp.display().to_string(),
            source: e.into_error(),
        })?;
        file.sync_all().map_err(io_err(&tmp))
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(e);
    }
    fs::rename(&tmp, path).map_err(io_err(path))
}

/// The values of a column (those present) and, for a nullable one, its
/// definition levels (1 present, 0 null).
fn gather<R, T>(
    rows: &[R],
    nullable: bool,
    name: &str,
    f: impl Fn(&R) -> Option<T>,
) -> parquet::errors::Result<(Vec<T>, Option<Vec<i16>>)> {
    let mut values = Vec::with_capacity(rows.len());
    let mut defs = Vec::with_capacity(if nullable { rows.len() } else { 0 });
    for r in rows {
        let v = f(r);
        if nullable {
            defs.push(i16::from(v.is_some()));
        } else if v.is_none() {
            return Err(parquet::errors::ParquetError::General(format!(
                "column {name} is required but a row has no value"
            )));
        }
        values.extend(v);
    }
    Ok((values, nullable.then_some(defs)))
}

fn write_column<R>(
    cw: &mut SerializedColumnWriter<'_>,
    c: &Column<R>,
    rows: &[R],
) -> parquet::errors::Result<()> {
    let (n, name) = (c.nullable, c.name);
    match c.get {
        Get::U64(f) => {
            // The unsigned logical type: the bits as INT64.
            let (v, d) = gather(rows, n, name, |r| f(r).map(|x| x as i64))?;
            cw.typed::<Int64Type>()
                .write_batch(&v, d.as_deref(), None)?;
        }
        Get::U32(f) => {
            let (v, d) = gather(rows, n, name, |r| f(r).map(|x| x as i32))?;
            cw.typed::<Int32Type>()
                .write_batch(&v, d.as_deref(), None)?;
        }
        Get::F64(f) => {
            let (v, d) = gather(rows, n, name, f)?;
            cw.typed::<DoubleType>()
                .write_batch(&v, d.as_deref(), None)?;
        }
        Get::Bool(f) => {
            let (v, d) = gather(rows, n, name, f)?;
            cw.typed::<BoolType>().write_batch(&v, d.as_deref(), None)?;
        }
        Get::Str(f) => {
            let (v, d) = gather(rows, n, name, |r| f(r).map(ByteArray::from))?;
            cw.typed::<ByteArrayType>()
                .write_batch(&v, d.as_deref(), None)?;
        }
    }
    Ok(())
}

fn temp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `bytes` to `path` through a temporary name, synced, renamed.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), MergeError> {
    let tmp = temp_name(path);
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(io_err(&tmp)(e));
    }
    fs::rename(&tmp, path).map_err(io_err(path))
}

// ---------------------------------------------------------------------------
// Statistics of the report

/// A metric of a row.
type Metric = fn(&M) -> Option<f64>;

/// An error of the report: its title and unit, its per-run RMSE and maximum.
struct ErrorQuantity {
    title: &'static str,
    unit: &'static str,
    rmse: Metric,
    max: Metric,
}

const ERRORS: [ErrorQuantity; 4] = [
    ErrorQuantity {
        title: "Horizontal position",
        unit: "m",
        rmse: |m| m.horizontal_rmse_m,
        max: |m| m.horizontal_max_m,
    },
    ErrorQuantity {
        title: "Vertical position",
        unit: "m",
        rmse: |m| m.vertical_rmse_m,
        max: |m| m.vertical_max_m,
    },
    ErrorQuantity {
        title: "Velocity",
        unit: "m/s",
        rmse: |m| m.velocity_rmse_mps,
        max: |m| m.velocity_max_mps,
    },
    ErrorQuantity {
        title: "Attitude",
        unit: "arcmin",
        rmse: |m| m.attitude_rmse_arcmin,
        max: |m| m.attitude_max_arcmin,
    },
];

const NEES: [(&str, Metric); 3] = [
    ("position", |m| m.nees_position),
    ("velocity", |m| m.nees_velocity),
    ("attitude", |m| m.nees_attitude),
];

/// Finite values, sorted.
fn sorted(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v
}

/// p50, p95, p99 and the maximum of sorted values (None when empty).
fn quantiles(sorted: &[f64]) -> Option<[f64; 4]> {
    let p = |q| stats::percentile(sorted, q).ok();
    Some([p(50.0)?, p(95.0)?, p(99.0)?, *sorted.last()?])
}

#[derive(Debug, Default)]
struct Variation {
    label: String,
    scenario: String,
    rows: u64,
    ok: u64,
    failed: u64,
    flight_h: f64,
    /// Per error quantity, the RMSEs and maxima of the ok runs, sorted.
    errors: Vec<(Vec<f64>, Vec<f64>)>,
    nees: Vec<Vec<f64>>,
    integrity: Integrity,
}

/// The integrity test over clean flights (no injected fault, ok, with the
/// integrity counters).
#[derive(Debug, Default, Clone, Copy)]
struct Integrity {
    runs: u64,
    flight_h: f64,
    tested: u64,
    false_exclusions: u64,
    exclusions: u64,
}

impl Integrity {
    fn add(&mut self, o: &Integrity) {
        self.runs += o.runs;
        self.flight_h += o.flight_h;
        self.tested += o.tested;
        self.false_exclusions += o.false_exclusions;
        self.exclusions += o.exclusions;
    }
    fn per_hour(&self) -> (Option<f64>, Result<f64, StatsError>) {
        let rate = (self.flight_h > 0.0).then(|| self.false_exclusions as f64 / self.flight_h);
        let bound = stats::poisson_upper(self.false_exclusions, self.flight_h, CONFIDENCE);
        (rate, bound)
    }
    fn per_fix(&self) -> (Option<f64>, Result<f64, StatsError>) {
        let rate = (self.tested > 0).then(|| self.false_exclusions as f64 / self.tested as f64);
        let bound = stats::clopper_pearson_upper(self.false_exclusions, self.tested, CONFIDENCE);
        (rate, bound)
    }
}

/// One spoofer profile's runs (those whose injected faults include `spoof`).
#[derive(Debug, Default)]
struct Profile {
    runs: u64,
    /// Runs with no verdict (`fault_detected` not recorded).
    no_verdict: u64,
    detected: u64,
    time_to_exclusion: Vec<f64>,
    error_at_exclusion: Vec<f64>,
}

impl Profile {
    fn time_to_exclusion(&self) -> &[f64] {
        &self.time_to_exclusion
    }
    fn error_at_exclusion(&self) -> &[f64] {
        &self.error_at_exclusion
    }
}

#[derive(Debug, Default)]
struct CostAgg {
    rows: u64,
    flight_h: f64,
    cpu_s: f64,
    simulate_s: f64,
    navigate_s: f64,
    evaluate_s: f64,
    wall_s: Vec<f64>,
    rss_mib: Vec<f64>,
    hosts: BTreeSet<String>,
    executors: BTreeMap<String, u64>,
    builds: BTreeMap<(String, String), u64>,
}

/// Everything the report shows, aggregated from the rows in index order.
#[derive(Debug, Default)]
struct Report {
    variations: BTreeMap<u32, Variation>,
    profiles: BTreeMap<String, Profile>,
    jammed_runs: u64,
    judged: (u64, u64),
    /// Judged runs that failed their judgement: (index, scenario, seed, what failed).
    judged_failed: Vec<(u64, String, u64, String)>,
    /// Failure reasons (one line, at most 200 characters): runs, first index.
    failures: BTreeMap<String, (u64, u64)>,
    cost: CostAgg,
    /// False exclusions in faulted flights (outside the fault windows):
    /// not in the rate, whose exposure is the clean flights'.
    faulted_false_exclusions: u64,
}

fn is_spoof(m: &Metrics) -> bool {
    m.fault
        .as_deref()
        .is_some_and(|f| f.split('+').any(|k| k == "spoof"))
}

fn is_jam(m: &Metrics) -> bool {
    m.fault
        .as_deref()
        .is_some_and(|f| f.split('+').any(|k| k == "jam"))
}

fn one_line(reason: &str) -> String {
    let s: String = reason
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .chars()
        .take(200)
        .collect();
    if s.is_empty() {
        "(no reason)".into()
    } else {
        s
    }
}

impl Report {
    fn new(metrics: &[Metrics], costs: &[Cost]) -> Report {
        let mut r = Report::default();
        // Per variation, the error columns (RMSE, max per quantity) and the
        // NEES columns, sorted once all are in.
        type Columns = (Vec<Vec<f64>>, Vec<Vec<f64>>);
        let mut raw: BTreeMap<u32, Columns> = BTreeMap::new();
        for m in metrics {
            let v = r
                .variations
                .entry(m.variation)
                .or_insert_with(|| Variation {
                    label: m.variation_label.clone(),
                    scenario: m.scenario.clone(),
                    ..Default::default()
                });
            v.rows += 1;
            if m.outcome == Outcome::Failed {
                v.failed += 1;
                let e = r
                    .failures
                    .entry(one_line(&m.reason))
                    .or_insert((0, m.index));
                e.0 += 1;
                continue;
            }
            v.ok += 1;
            v.flight_h += m.flight_h.filter(|h| h.is_finite()).unwrap_or(0.0);
            let (errs, nees) = raw
                .entry(m.variation)
                .or_insert_with(|| (vec![Vec::new(); 2 * ERRORS.len()], vec![Vec::new(); 3]));
            for (k, e) in ERRORS.iter().enumerate() {
                errs[2 * k].extend((e.rmse)(m));
                errs[2 * k + 1].extend((e.max)(m));
            }
            for (k, (_, get)) in NEES.iter().enumerate() {
                nees[k].extend(get(m));
            }
            if m.fault.is_none() {
                if let (Some(false_excl), Some(tested)) = (m.gnss_false_exclusions, m.gnss_tested)
                    && tested > 0
                {
                    v.integrity.add(&Integrity {
                        runs: 1,
                        flight_h: m.flight_h.filter(|h| h.is_finite()).unwrap_or(0.0),
                        tested,
                        false_exclusions: false_excl,
                        exclusions: m.gnss_exclusions.unwrap_or(0),
                    });
                }
            } else {
                r.faulted_false_exclusions += m.gnss_false_exclusions.unwrap_or(0);
            }
            if is_jam(m) {
                r.jammed_runs += 1;
            }
            if is_spoof(m) {
                let p = r.profiles.entry(m.scenario.clone()).or_default();
                p.runs += 1;
                match m.fault_detected {
                    None => p.no_verdict += 1,
                    Some(true) => {
                        p.detected += 1;
                        p.time_to_exclusion.extend(m.time_to_exclusion_s);
                        p.error_at_exclusion.extend(m.error_at_exclusion_m);
                    }
                    Some(false) => {}
                }
            }
            if let Some(pass) = m.judgement_pass {
                r.judged.0 += 1;
                r.judged.1 += u64::from(pass);
                if !pass {
                    r.judged_failed.push((
                        m.index,
                        m.scenario.clone(),
                        m.seed,
                        m.judgement_failures.clone().unwrap_or_default(),
                    ));
                }
            }
        }
        for (k, (errs, nees)) in raw {
            if let Some(v) = r.variations.get_mut(&k) {
                v.errors = errs
                    .chunks(2)
                    .map(|c| (sorted(c[0].iter().copied()), sorted(c[1].iter().copied())))
                    .collect();
                v.nees = nees.into_iter().map(|n| sorted(n.into_iter())).collect();
            }
        }
        for p in r.profiles.values_mut() {
            p.time_to_exclusion = sorted(p.time_to_exclusion.iter().copied());
            p.error_at_exclusion = sorted(p.error_at_exclusion.iter().copied());
        }
        let c = &mut r.cost;
        for k in costs {
            c.rows += 1;
            c.flight_h += k.flight_h;
            c.cpu_s += k.cpu_s;
            c.simulate_s += k.simulate_cpu_s;
            c.navigate_s += k.navigate_cpu_s;
            c.evaluate_s += k.evaluate_cpu_s;
            c.wall_s.push(k.wall_s);
            c.rss_mib.push(k.peak_rss_mib);
            if !c.hosts.contains(&k.host) {
                c.hosts.insert(k.host.clone());
            }
            *c.executors.entry(executor_kind(&k.executor)).or_default() += 1;
            *c.builds
                .entry((k.version.clone(), k.commit.clone()))
                .or_default() += 1;
        }
        c.wall_s = sorted(c.wall_s.iter().copied());
        c.rss_mib = sorted(c.rss_mib.iter().copied());
        r
    }

    fn integrity_total(&self) -> Integrity {
        let mut t = Integrity::default();
        for v in self.variations.values() {
            t.add(&v.integrity);
        }
        t
    }
}

/// `slurm 1234_5` → `slurm`: the executor's kind, not its task.
fn executor_kind(e: &str) -> String {
    e.split_whitespace().next().unwrap_or("(none)").to_owned()
}

// ---------------------------------------------------------------------------
// Formatting

/// `v` to `digits` significant digits, in plain notation from 1e-4 to 1e7.
fn sig(v: f64, digits: usize) -> String {
    if v.is_nan() {
        return "NaN".into();
    }
    if v.is_infinite() {
        return if v > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    if v == 0.0 {
        return "0".into();
    }
    let e = v.abs().log10().floor() as i32;
    if !(-4..7).contains(&e) {
        return format!("{:.*e}", digits.saturating_sub(1), v);
    }
    let decimals = (digits as i32 - 1 - e).max(0) as usize;
    format!("{v:.decimals$}")
}

/// A tick label: three significant digits, trailing zeros dropped.
fn tick(v: f64) -> String {
    let s = sig(v, 3);
    if s.contains('.') && !s.contains('e') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

/// A count with its thousands apart: 1 512 000.
fn count(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(ch);
    }
    out
}

fn hours(h: f64) -> String {
    if h >= 1000.0 && h.is_finite() {
        count(h.round() as u64)
    } else {
        sig(h, 4)
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "—".into(), |v| sig(v, 4))
}

fn bound(b: &Result<f64, StatsError>) -> String {
    match b {
        Ok(v) => sig(*v, 3),
        Err(e) => format!("— ({e})"),
    }
}

fn ranges_text(ranges: &[RangeInclusive<u64>], max: usize) -> String {
    let mut parts: Vec<String> = ranges
        .iter()
        .take(max)
        .map(|r| {
            if r.start() == r.end() {
                r.start().to_string()
            } else {
                format!("{}–{}", r.start(), r.end())
            }
        })
        .collect();
    if ranges.len() > max {
        parts.push(format!("and {} more ranges", ranges.len() - max));
    }
    parts.join(", ")
}

/// Text for a Markdown table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

fn code(s: &str) -> String {
    if s.is_empty() {
        "(none)".into()
    } else if s.contains('`') {
        cell(s)
    } else {
        format!("`{}`", cell(s))
    }
}

fn yes(ok: bool) -> &'static str {
    if ok { "yes" } else { "**NO**" }
}

macro_rules! w {
    ($s:expr, $($t:tt)*) => {
        let _ = writeln!($s, $($t)*);
    };
}

impl Report {
    fn markdown(&self, title: &str, sha: &str, s: &MergeSummary, out: &Path) -> String {
        let mut md = String::new();
        let fig = |p: &Path| {
            p.strip_prefix(out)
                .unwrap_or(p)
                .display()
                .to_string()
                .replace('\\', "/")
        };
        w!(md, "# Campaign report: {title}\n");
        w!(md, "Campaign `{sha}`.\n");
        w!(
            md,
            "| runs | done | failed | missing | of which unusable | flight hours (done) |"
        );
        w!(md, "| ---: | ---: | ---: | ---: | ---: | ---: |");
        w!(
            md,
            "| {} | {} | {} | {} | {} | {} |\n",
            count(s.runs),
            count(s.ok),
            count(s.failed),
            count(s.missing_count),
            count(s.unusable_count),
            hours(s.flight_h)
        );
        if !s.missing.is_empty() {
            w!(
                md,
                "Runs with no usable result (run them again): {}.\n",
                ranges_text(&s.missing, 50)
            );
        }
        if !s.unusable.is_empty() {
            w!(md, "Unusable results (a file there but refused):\n");
            for (i, why) in &s.unusable {
                w!(md, "- run {i}: {}", cell(&one_line(why)));
            }
            if s.unusable_count > s.unusable.len() as u64 {
                w!(
                    md,
                    "- and {} more",
                    count(s.unusable_count - s.unusable.len() as u64)
                );
            }
            w!(md, "");
        }
        self.acceptance(&mut md);
        self.variations_md(&mut md);
        self.errors_md(&mut md, s, &fig);
        self.nees_md(&mut md, s, &fig);
        self.integrity_md(&mut md);
        self.detection_md(&mut md, s, &fig);
        self.judgement_md(&mut md);
        self.cost_md(&mut md, s);
        md
    }

    /// The fault campaign's judgements (runs of kind `fault-judge`).
    fn judgement_md(&self, md: &mut String) {
        let (judged, passed) = self.judged;
        if judged == 0 {
            return;
        }
        w!(
            md,
            "## Fault judgement
"
        );
        w!(
            md,
            "Each faulted flight against its fault-free twin (the same seed): every injected fault detected, the accounting exact, the horizontal error within 3× the fault-free RMSE outside the outages and back within it 60 s after each. {} of {} judged runs pass.\n",
            count(passed),
            count(judged)
        );
        if !self.judged_failed.is_empty() {
            w!(md, "| run | scenario | seed | what failed |");
            w!(md, "| ---: | --- | ---: | --- |");
            for (i, sc, seed, why) in self.judged_failed.iter().take(50) {
                w!(md, "| {i} | `{sc}` | {seed} | {} |", cell(&one_line(why)));
            }
            if self.judged_failed.len() > 50 {
                w!(md, "\nand {} more.", self.judged_failed.len() - 50);
            }
            w!(md, "");
        }
    }

    fn acceptance(&self, md: &mut String) {
        w!(md, "## Summary\n");
        let t = self.integrity_total();
        match t.per_hour().1 {
            Ok(b) => {
                w!(
                    md,
                    "- False-alarm rate, 95 % upper bound ≤ {} /h: {} ({} /h).",
                    FALSE_ALARM_LIMIT_PER_H,
                    yes(b <= FALSE_ALARM_LIMIT_PER_H),
                    sig(b, 3)
                );
            }
            Err(_) if t.flight_h == 0.0 => {
                w!(md, "- False-alarm rate: no clean flight with tested fixes.");
            }
            Err(e) => {
                w!(md, "- False-alarm rate: no verdict ({e}).");
            }
        }
        if self.profiles.is_empty() {
            w!(md, "- Spoofing detection: no spoofed flight.");
        }
        for (name, p) in &self.profiles {
            let n = p.runs - p.no_verdict;
            match stats::clopper_pearson_lower(p.detected, n, CONFIDENCE) {
                Ok(lo) => {
                    w!(
                        md,
                        "- Detection of `{}`, 95 % lower bound ≥ {}: {} ({}).",
                        cell(name),
                        DETECTION_LIMIT,
                        yes(lo >= DETECTION_LIMIT),
                        sig(lo, 4)
                    );
                }
                Err(e) => {
                    w!(md, "- Detection of `{}`: no verdict ({e}).", cell(name));
                }
            }
        }
        let (mut judged, mut inside) = (0, 0);
        let mut outside: Vec<String> = Vec::new();
        for (k, v) in &self.variations {
            for (q, (name, _)) in NEES.iter().enumerate() {
                let vals: &[f64] = v.nees.get(q).map_or(&[], |x| x);
                let n = vals.len() as u64;
                if n < NEES_MIN_RUNS {
                    continue;
                }
                judged += 1;
                let mean = vals.iter().sum::<f64>() / n as f64;
                match stats::nees_band(n, NEES_DOF, CONFIDENCE) {
                    Ok((lo, hi)) if (lo..=hi).contains(&mean) => inside += 1,
                    _ => outside.push(format!("v{k} {name}")),
                }
            }
        }
        if judged == 0 {
            w!(
                md,
                "- Average NEES: no variation has {NEES_MIN_RUNS} runs or more with NEES."
            );
        } else {
            w!(
                md,
                "- Average NEES over ≥ {NEES_MIN_RUNS} runs inside its 95 % band: {} ({inside} of {judged}{}).",
                yes(inside == judged),
                if outside.is_empty() {
                    String::new()
                } else {
                    format!("; outside: {}", outside.join(", "))
                }
            );
        }
        let core_h = self.cost.cpu_s / 3600.0;
        if core_h > 0.0 {
            w!(
                md,
                "- Flight hours per core hour: {}.",
                sig(self.cost.flight_h / core_h, 4)
            );
        }
        w!(md, "");
    }

    fn variations_md(&self, md: &mut String) {
        w!(md, "## Variations\n");
        w!(
            md,
            "| variation | label | scenario | runs | done | failed | flight hours |"
        );
        w!(md, "| --- | --- | --- | ---: | ---: | ---: | ---: |");
        for (k, v) in &self.variations {
            w!(
                md,
                "| v{k} | {} | {} | {} | {} | {} | {} |",
                code(&v.label),
                code(&v.scenario),
                count(v.rows),
                count(v.ok),
                count(v.failed),
                hours(v.flight_h)
            );
        }
        w!(md, "");
    }

    fn errors_md(&self, md: &mut String, s: &MergeSummary, fig: &dyn Fn(&Path) -> String) {
        w!(md, "## Errors per variation\n");
        w!(
            md,
            "Per run, the RMSE and the maximum of each error against the truth; over the done runs of each variation, their percentiles (nearest rank: the value at rank ⌈p·N/100⌉ of the N sorted) and maximum. N counts the runs that have the metric.\n"
        );
        for (k, e) in ERRORS.iter().enumerate() {
            w!(md, "### {} ({})\n", e.title, e.unit);
            w!(
                md,
                "| variation | N | RMSE p50 | p95 | p99 | max | max p50 | p95 | p99 | max |"
            );
            w!(
                md,
                "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
            );
            for (i, v) in &self.variations {
                let Some((rmse, max)) = v.errors.get(k) else {
                    w!(md, "| v{i} | 0 | — | — | — | — | — | — | — | — |");
                    continue;
                };
                let q = |x: &[f64]| {
                    quantiles(x).map_or_else(
                        || "— | — | — | —".to_owned(),
                        |q| q.map(|v| sig(v, 4)).join(" | "),
                    )
                };
                w!(
                    md,
                    "| v{i} | {} | {} | {} |",
                    count(rmse.len().max(max.len()) as u64),
                    q(rmse),
                    q(max)
                );
            }
            w!(md, "");
        }
        for f in s
            .figures
            .iter()
            .filter(|f| name_of(f).starts_with(FIG_HORIZONTAL))
        {
            w!(
                md,
                "![CDF over the runs of the per-run horizontal RMSE and maximum]({})\n",
                fig(f)
            );
        }
    }

    fn nees_md(&self, md: &mut String, s: &MergeSummary, fig: &dyn Fn(&Path) -> String) {
        w!(md, "## NEES\n");
        w!(
            md,
            "Per variation, the average over its done runs of each run's mean NEES (3 degrees of freedom: ideal 3), against the two-sided 95 % band of the average of N χ²(3) values, [χ²₀.₀₂₅(3N)/N, χ²₀.₉₇₅(3N)/N]. Judged over ≥ {NEES_MIN_RUNS} runs; fewer are shown for information.\n"
        );
        w!(
            md,
            "| variation | N | 95 % band | position | velocity | attitude |"
        );
        w!(md, "| --- | ---: | :---: | ---: | ---: | ---: |");
        for (i, v) in &self.variations {
            let n_all = v.nees.iter().map(Vec::len).max().unwrap_or(0) as u64;
            if n_all == 0 {
                w!(md, "| v{i} | 0 | — | — | — | — |");
                continue;
            }
            let band = |n: u64| stats::nees_band(n, NEES_DOF, CONFIDENCE);
            let band_text = match band(n_all) {
                Ok((lo, hi)) => format!("[{}, {}]", sig(lo, 4), sig(hi, 4)),
                Err(e) => format!("— ({e})"),
            };
            let cells: Vec<String> = v
                .nees
                .iter()
                .map(|vals| {
                    let n = vals.len() as u64;
                    if n == 0 {
                        return "—".into();
                    }
                    let mean = vals.iter().sum::<f64>() / n as f64;
                    let verdict = match band(n) {
                        Ok((lo, hi)) if (lo..=hi).contains(&mean) => "inside".to_owned(),
                        Ok(_) => "**OUTSIDE**".to_owned(),
                        Err(e) => format!("({e})"),
                    };
                    let own_n = if n == n_all {
                        String::new()
                    } else {
                        format!(" (N = {n})")
                    };
                    format!("{} {verdict}{own_n}", sig(mean, 4))
                })
                .collect();
            let few = if n_all < NEES_MIN_RUNS {
                " (fewer than the runs judged)"
            } else {
                ""
            };
            w!(
                md,
                "| v{i} | {}{few} | {band_text} | {} |",
                count(n_all),
                cells.join(" | ")
            );
        }
        w!(md, "");
        for f in s
            .figures
            .iter()
            .filter(|f| name_of(f).starts_with(FIG_NEES))
        {
            w!(
                md,
                "![Average NEES per variation against its band]({})\n",
                fig(f)
            );
        }
    }

    fn integrity_md(&self, md: &mut String) {
        w!(md, "## Integrity: false alarms\n");
        w!(
            md,
            "Over clean flights (done, no injected fault, with at least one GNSS fix tested by the integrity test): every exclusion of the receiver there is a false alarm (`gnss_false_exclusions`, the exclusions with no GNSS fault active). The rate per flight hour is bounded by Garwood's exact Poisson bound, χ²₀.₉₅(2x + 2)/(2T) (the Poisson analogue of Clopper–Pearson); the rate per tested fix by the Clopper–Pearson bound; both one-sided at 95 %.\n"
        );
        let t = self.integrity_total();
        if t.runs == 0 {
            w!(md, "No clean flight with tested fixes.\n");
            return;
        }
        let (rate_h, bound_h) = t.per_hour();
        let (rate_f, bound_f) = t.per_fix();
        let bh = bound(&bound_h);
        let bf = bound(&bound_f);
        if t.false_exclusions == 0 {
            w!(
                md,
                "**0 false exclusions in {} flight hours: rate < {bh} /h at 95 %; 0 in {} tested fixes: < {bf} per fix at 95 %.**\n",
                hours(t.flight_h),
                count(t.tested)
            );
        } else {
            w!(
                md,
                "**{} false exclusions in {} flight hours: {} /h, < {bh} /h at 95 %; in {} tested fixes: {} per fix, < {bf} at 95 %.**\n",
                count(t.false_exclusions),
                hours(t.flight_h),
                opt(rate_h),
                count(t.tested),
                opt(rate_f)
            );
        }
        if let Ok(b) = bound_h {
            w!(
                md,
                "Acceptance (95 % bound ≤ {FALSE_ALARM_LIMIT_PER_H} /h): {}.\n",
                yes(b <= FALSE_ALARM_LIMIT_PER_H)
            );
        }
        if t.exclusions != t.false_exclusions {
            w!(
                md,
                "Note: these flights had {} exclusions in all but {} false ones: a flight with no fault recorded had one injected (a campaign that does not keep the `faults` group records none); the count above is of the false ones.\n",
                count(t.exclusions),
                count(t.false_exclusions)
            );
        }
        if self.faulted_false_exclusions > 0 {
            w!(
                md,
                "Faulted flights had {} exclusions outside their fault windows (not counted above: their exposure is not clean flight time).\n",
                count(self.faulted_false_exclusions)
            );
        }
        w!(
            md,
            "| variation | clean runs | flight hours | tested fixes | false exclusions | per hour | 95 % bound /h | per fix | 95 % bound /fix |"
        );
        w!(
            md,
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
        );
        let row = |md: &mut String, name: &str, g: &Integrity| {
            let (rh, bh) = g.per_hour();
            let (rf, bf) = g.per_fix();
            w!(
                md,
                "| {name} | {} | {} | {} | {} | {} | {} | {} | {} |",
                count(g.runs),
                hours(g.flight_h),
                count(g.tested),
                count(g.false_exclusions),
                opt(rh),
                bound(&bh),
                opt(rf),
                bound(&bf)
            );
        };
        for (i, v) in &self.variations {
            if v.integrity.runs > 0 {
                row(md, &format!("v{i}"), &v.integrity);
            }
        }
        row(md, "**all**", &t);
        w!(md, "");
    }

    fn detection_md(&self, md: &mut String, s: &MergeSummary, fig: &dyn Fn(&Path) -> String) {
        w!(md, "## Spoofing detection per profile\n");
        if self.profiles.is_empty() {
            w!(md, "No spoofed flight.\n");
            return;
        }
        w!(
            md,
            "A profile is a scenario whose injected faults include `spoof`; a run detects it when the integrity test excluded the receiver while the spoofing was active (`fault_detected`). The lower bound is Clopper–Pearson's, one-sided at 95 %; runs with no verdict are left out of the rate.\n"
        );
        w!(
            md,
            "| profile | spoofed runs | no verdict | detected | rate | 95 % lower bound | ≥ {DETECTION_LIMIT} |"
        );
        w!(md, "| --- | ---: | ---: | ---: | ---: | ---: | :---: |");
        for (name, p) in &self.profiles {
            let n = p.runs - p.no_verdict;
            let lo = stats::clopper_pearson_lower(p.detected, n, CONFIDENCE);
            let rate = (n > 0).then(|| p.detected as f64 / n as f64);
            w!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} |",
                code(name),
                count(p.runs),
                count(p.no_verdict),
                count(p.detected),
                opt(rate),
                lo.as_ref()
                    .map_or_else(|e| format!("— ({e})"), |v| sig(*v, 4)),
                lo.as_ref().map_or("—", |v| yes(*v >= DETECTION_LIMIT))
            );
        }
        w!(md, "");
        for (title, get) in [
            (
                "Time from the spoofing's start to the exclusion (s), detected runs",
                Profile::time_to_exclusion as fn(&Profile) -> &[f64],
            ),
            (
                "Horizontal error at the exclusion (m), detected runs",
                Profile::error_at_exclusion,
            ),
        ] {
            w!(md, "### {title}\n");
            w!(md, "| profile | N | p50 | p95 | p99 | max |");
            w!(md, "| --- | ---: | ---: | ---: | ---: | ---: |");
            for (name, p) in &self.profiles {
                let v = get(p);
                let q = quantiles(v).map_or_else(
                    || "— | — | — | —".to_owned(),
                    |q| q.map(|v| sig(v, 4)).join(" | "),
                );
                w!(md, "| {} | {} | {q} |", code(name), count(v.len() as u64));
            }
            w!(md, "");
        }
        for f in s
            .figures
            .iter()
            .filter(|f| name_of(f).starts_with(FIG_EXCLUSION))
        {
            w!(
                md,
                "![CDF over the detected runs of the time to exclusion and the error at exclusion]({})\n",
                fig(f)
            );
        }
        if self.jammed_runs > 0 {
            w!(
                md,
                "{} jammed flights (not a detection test: a jammed receiver gives no fix to exclude).\n",
                count(self.jammed_runs)
            );
        }
        if self.judged.0 > 0 {
            w!(
                md,
                "Fault-judge runs: {} of {} passed.\n",
                count(self.judged.1),
                count(self.judged.0)
            );
        }
    }

    fn cost_md(&self, md: &mut String, s: &MergeSummary) {
        let c = &self.cost;
        w!(md, "## Cost\n");
        if c.rows == 0 {
            w!(md, "No run result.\n");
            return;
        }
        let core_h = c.cpu_s / 3600.0;
        w!(
            md,
            "{} runs with a result used {} core hours for {} flight hours: **{} flight hours per core hour**.\n",
            count(c.rows),
            sig(core_h, 4),
            hours(c.flight_h),
            if core_h > 0.0 {
                sig(c.flight_h / core_h, 4)
            } else {
                "—".into()
            }
        );
        let share = |x: f64| {
            if c.cpu_s > 0.0 {
                format!("{:.1} %", 100.0 * x / c.cpu_s)
            } else {
                "—".into()
            }
        };
        let other = (c.cpu_s - c.simulate_s - c.navigate_s - c.evaluate_s).max(0.0);
        w!(md, "| part | core hours | share of the CPU time |");
        w!(md, "| --- | ---: | ---: |");
        for (name, x) in [
            ("simulate", c.simulate_s),
            (
                "navigate (both navigators, evaluated as the flight streams)",
                c.navigate_s,
            ),
            ("evaluate (after the flight)", c.evaluate_s),
            ("other (setup, writing the result)", other),
        ] {
            w!(md, "| {name} | {} | {} |", sig(x / 3600.0, 4), share(x));
        }
        w!(md, "");
        let q = |v: &[f64]| {
            quantiles(v).map_or_else(
                || "— | — | — | —".to_owned(),
                |q| q.map(|x| sig(x, 4)).join(" | "),
            )
        };
        w!(md, "| per run | p50 | p95 | p99 | max |");
        w!(md, "| --- | ---: | ---: | ---: | ---: |");
        w!(md, "| wall time (s) | {} |", q(&c.wall_s));
        w!(md, "| peak resident memory (MiB) | {} |", q(&c.rss_mib));
        w!(md, "");
        w!(
            md,
            "Wall time of the runs added up: {} h, on {} host{}; executors: {}.\n",
            sig(c.wall_s.iter().sum::<f64>() / 3600.0, 4),
            count(c.hosts.len() as u64),
            if c.hosts.len() == 1 { "" } else { "s" },
            c.executors
                .iter()
                .map(|(k, n)| format!("{} ({})", cell(k), count(*n)))
                .collect::<Vec<_>>()
                .join(", ")
        );
        if c.builds.len() > 1 {
            w!(
                md,
                "**The runs come from {} builds** (their metrics may differ):\n",
                c.builds.len()
            );
            for ((version, commit), n) in &c.builds {
                w!(
                    md,
                    "- {} {}: {} runs",
                    cell(version),
                    cell(commit),
                    count(*n)
                );
            }
            w!(md, "");
        } else if let Some(((version, commit), _)) = c.builds.iter().next() {
            w!(md, "Build: {} {}.\n", cell(version), cell(commit));
        }
        w!(md, "### Failed runs\n");
        if s.failed == 0 {
            w!(md, "None.\n");
            return;
        }
        let mut by: Vec<(&String, &(u64, u64))> = self.failures.iter().collect();
        by.sort_by(|a, b| b.1.0.cmp(&a.1.0).then(a.0.cmp(b.0)));
        w!(
            md,
            "{} runs failed ({} of the runs with a result); the reasons, most frequent first{}:\n",
            count(s.failed),
            format!("{:.2} %", 100.0 * s.failed as f64 / s.rows.max(1) as f64),
            if by.len() > 10 {
                format!(" (10 of {})", by.len())
            } else {
                String::new()
            }
        );
        w!(md, "| runs | first run | reason |");
        w!(md, "| ---: | ---: | --- |");
        for (reason, (n, first)) in by.iter().take(10) {
            w!(md, "| {} | {first} | {} |", count(*n), cell(reason));
        }
        w!(md, "");
    }
}

// ---------------------------------------------------------------------------
// Figures

const FIG_HORIZONTAL: &str = "horizontal_error_cdf";
const FIG_EXCLUSION: &str = "exclusion_cdf";
const FIG_NEES: &str = "nees";

const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 90, 180),
    RGBColor(220, 110, 0),
    RGBColor(0, 140, 60),
    RGBColor(200, 30, 30),
    RGBColor(120, 60, 170),
    RGBColor(130, 80, 40),
    RGBColor(210, 80, 160),
    RGBColor(0, 160, 180),
];
const GREY: RGBColor = RGBColor(110, 110, 110);
/// Width of the legend strip right of the panels (px).
const LEGEND_W: u32 = 400;

fn name_of(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// One curve of a CDF panel: points (value, fraction of runs ≤ it).
struct Curve {
    points: Vec<(f64, f64)>,
    color: RGBColor,
}

struct CdfPanel {
    caption: String,
    x_desc: String,
    curves: Vec<Curve>,
    /// The value axis's extent: the same on every page of a figure.
    extent: Option<(f64, f64)>,
}

/// A variation's average NEES and its band.
#[derive(Debug, Clone, Copy)]
struct NeesPoint {
    variation: u32,
    mean: f64,
    lo: f64,
    hi: f64,
}

enum Figure {
    Cdf {
        title: String,
        panels: Vec<CdfPanel>,
        /// The legend's title and entries.
        legend: (&'static str, Vec<(String, Mark)>),
        notes: Vec<String>,
    },
    Nees {
        title: String,
        /// Per quantity: its caption and its variations' averages.
        panels: Vec<(String, Vec<NeesPoint>)>,
    },
}

/// The CDF's points of sorted values: at most [`CDF_POINTS`] evenly spaced
/// in rank, and as many again over the top 2 % (where the 99th
/// percentile is read), each the value at that rank and its fraction.
fn cdf_points(sorted: &[f64]) -> Vec<(f64, f64)> {
    let n = sorted.len();
    if n == 0 {
        return Vec::new();
    }
    let mut ranks: Vec<usize> = if n <= 2 * CDF_POINTS {
        (0..n).collect()
    } else {
        let tail = n - n / 50;
        (0..CDF_POINTS)
            .map(|k| k * (n - 1) / (CDF_POINTS - 1))
            .chain((0..CDF_POINTS).map(|k| tail + k * (n - 1 - tail) / (CDF_POINTS - 1)))
            .collect()
    };
    ranks.sort_unstable();
    ranks.dedup();
    ranks
        .into_iter()
        .map(|i| (sorted[i], (i + 1) as f64 / n as f64))
        .collect()
}

impl Report {
    /// Draws the figures into `dir`; their paths.
    fn figures(&self, dir: &Path) -> Result<Vec<PathBuf>, MergeError> {
        let mut figs: Vec<(String, (u32, u32), Figure)> = Vec::new();
        // Horizontal error CDFs, at most 8 variations a figure.
        let vars: Vec<(&u32, &Variation)> = self
            .variations
            .iter()
            .filter(|(_, v)| v.errors.first().is_some_and(|e| !e.0.is_empty()))
            .collect();
        let pages = vars.len().div_ceil(CURVES_PER_FIGURE);
        let rmse_extent = joint_extent(vars.iter().map(|v| &v.1.errors[0].0[..]));
        let max_extent = joint_extent(vars.iter().map(|v| &v.1.errors[0].1[..]));
        for (page, chunk) in vars.chunks(CURVES_PER_FIGURE).enumerate() {
            let mut panels = vec![
                CdfPanel {
                    caption: "per-run horizontal RMSE".into(),
                    x_desc: "horizontal RMSE of a run (m)".into(),
                    curves: Vec::new(),
                    extent: rmse_extent,
                },
                CdfPanel {
                    caption: "per-run horizontal maximum".into(),
                    x_desc: "largest horizontal error of a run (m)".into(),
                    curves: Vec::new(),
                    extent: max_extent,
                },
            ];
            let mut legend = Vec::new();
            for (k, (i, v)) in chunk.iter().enumerate() {
                let color = PALETTE[k % PALETTE.len()];
                let (rmse, max) = &v.errors[0];
                panels[0].curves.push(Curve {
                    points: cdf_points(rmse),
                    color,
                });
                panels[1].curves.push(Curve {
                    points: cdf_points(max),
                    color,
                });
                legend.push((
                    format!(
                        "v{i} ({} run{}) {}",
                        count(rmse.len() as u64),
                        if rmse.len() == 1 { "" } else { "s" },
                        v.label
                    ),
                    Mark::Line(color, 3),
                ));
            }
            figs.push((
                page_name(FIG_HORIZONTAL, page, pages),
                (1800, 820),
                Figure::Cdf {
                    title: page_title(
                        "Horizontal position error: CDF over the runs of each variation",
                        page,
                        pages,
                    ),
                    panels,
                    legend: ("variations", legend),
                    notes: vec![
                        "grey lines: 50 %, 95 % and 99 % of the runs".into(),
                        "logarithmic value axis where the values span more than a factor of 10"
                            .into(),
                    ],
                },
            ));
        }
        // Time to exclusion and error at exclusion, per profile.
        let profiles: Vec<(&String, &Profile)> = self
            .profiles
            .iter()
            .filter(|(_, p)| !p.time_to_exclusion.is_empty() || !p.error_at_exclusion.is_empty())
            .collect();
        let pages = profiles.len().div_ceil(CURVES_PER_FIGURE);
        let tte_extent = joint_extent(profiles.iter().map(|p| &p.1.time_to_exclusion[..]));
        let eae_extent = joint_extent(profiles.iter().map(|p| &p.1.error_at_exclusion[..]));
        for (page, chunk) in profiles.chunks(CURVES_PER_FIGURE).enumerate() {
            let mut panels = vec![
                CdfPanel {
                    caption: "time to exclusion".into(),
                    x_desc: "time from the spoofing's start to the exclusion (s)".into(),
                    curves: Vec::new(),
                    extent: tte_extent,
                },
                CdfPanel {
                    caption: "error at exclusion".into(),
                    x_desc: "horizontal error at the exclusion (m)".into(),
                    curves: Vec::new(),
                    extent: eae_extent,
                },
            ];
            let mut legend = Vec::new();
            for (k, (name, p)) in chunk.iter().enumerate() {
                let color = PALETTE[k % PALETTE.len()];
                panels[0].curves.push(Curve {
                    points: cdf_points(&p.time_to_exclusion),
                    color,
                });
                panels[1].curves.push(Curve {
                    points: cdf_points(&p.error_at_exclusion),
                    color,
                });
                legend.push((
                    format!(
                        "{name} ({} of {} detected)",
                        count(p.detected),
                        count(p.runs - p.no_verdict)
                    ),
                    Mark::Line(color, 3),
                ));
            }
            figs.push((
                page_name(FIG_EXCLUSION, page, pages),
                (1800, 820),
                Figure::Cdf {
                    title: page_title(
                        "Spoofing: CDF over the detected runs of each profile",
                        page,
                        pages,
                    ),
                    panels,
                    legend: ("profiles", legend),
                    notes: vec![
                        "grey lines: 50 %, 95 % and 99 % of the detected runs".into(),
                        "undetected runs have no exclusion and are not drawn".into(),
                    ],
                },
            ));
        }
        // Average NEES against its band.
        let mut nees_panels = Vec::new();
        for (q, (name, _)) in NEES.iter().enumerate() {
            let pts: Vec<NeesPoint> = self
                .variations
                .iter()
                .filter_map(|(i, v)| {
                    let vals = v.nees.get(q)?;
                    let n = vals.len() as u64;
                    let (lo, hi) = stats::nees_band(n, NEES_DOF, CONFIDENCE).ok()?;
                    Some(NeesPoint {
                        variation: *i,
                        mean: vals.iter().sum::<f64>() / n as f64,
                        lo,
                        hi,
                    })
                })
                .collect();
            nees_panels.push((format!("{name} NEES"), pts));
        }
        if nees_panels.iter().any(|p| !p.1.is_empty()) {
            let h = 300 * nees_panels.len() as u32 + 60;
            figs.push((
                FIG_NEES.into(),
                (1800, h),
                Figure::Nees {
                    title: "Average NEES per variation against its two-sided 95 % χ² band".into(),
                    panels: nees_panels,
                },
            ));
        }
        let fmt = init_fonts();
        let ext = match fmt {
            Format::Png => "png",
            Format::Svg => "svg",
        };
        let mut out = Vec::new();
        for (name, size, f) in figs {
            let path = dir.join(format!("{name}.{ext}"));
            let tmp = dir.join(format!(".{name}.{}.tmp.{ext}", std::process::id()));
            let drawn = match fmt {
                Format::Png => draw(BitMapBackend::new(&tmp, size).into_drawing_area(), &f),
                Format::Svg => draw(SVGBackend::new(&tmp, size).into_drawing_area(), &f),
            };
            if let Err(message) = drawn {
                let _ = fs::remove_file(&tmp);
                return Err(MergeError::Figure {
                    path: path.display().to_string(),
                    message,
                });
            }
            fs::rename(&tmp, &path).map_err(io_err(&path))?;
            out.push(path);
        }
        Ok(out)
    }
}

fn page_name(base: &str, page: usize, pages: usize) -> String {
    if pages <= 1 {
        base.to_owned()
    } else {
        format!("{base}_{}", page + 1)
    }
}

fn page_title(base: &str, page: usize, pages: usize) -> String {
    if pages <= 1 {
        base.to_owned()
    } else {
        format!("{base} ({} of {pages})", page + 1)
    }
}

/// Removes figures of an earlier merge that this one did not draw.
fn remove_stale_figures(dir: &Path, keep: &[PathBuf]) {
    let Ok(rd) = fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        let ours = p.extension().is_some_and(|x| x == "png" || x == "svg");
        if ours && !keep.contains(&p) {
            let _ = fs::remove_file(&p);
        }
    }
}

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, f: &Figure) -> Result<(), String> {
    root.fill(&WHITE).map_err(s)?;
    match f {
        Figure::Cdf {
            title,
            panels,
            legend: entries,
            notes,
        } => {
            let root = root
                .margin(6, 0, 0, 0)
                .titled(title, ("sans-serif", 26))
                .map_err(s)?;
            let (w, _) = root.dim_in_pixel();
            let (main, side) = root.split_horizontally(w.saturating_sub(LEGEND_W));
            let areas = main.split_evenly((1, panels.len().max(1)));
            for (a, p) in areas.iter().zip(panels) {
                cdf_panel(a, p)?;
            }
            legend(&side, entries.0, &entries.1, notes)?;
        }
        Figure::Nees { title, panels } => {
            let root = root
                .margin(6, 0, 0, 0)
                .titled(title, ("sans-serif", 26))
                .map_err(s)?;
            let (w, _) = root.dim_in_pixel();
            let (main, side) = root.split_horizontally(w.saturating_sub(LEGEND_W));
            let areas = main.split_evenly((panels.len().max(1), 1));
            for (a, (caption, pts)) in areas.iter().zip(panels) {
                nees_panel(a, caption, pts)?;
            }
            let notes = [
                "each run's NEES is its mean over its epochs; a variation's average is over its done runs",
                "variations are listed in the report's table",
            ];
            legend(
                &side,
                "average NEES",
                &[
                    (
                        "95 % band of the average of N runs".into(),
                        Mark::Band(BAND),
                    ),
                    ("average inside its band".into(), Mark::Dot(INSIDE)),
                    ("average OUTSIDE its band".into(), Mark::Dot(OUTSIDE)),
                    (
                        "3: the ideal (3 degrees of freedom)".into(),
                        Mark::Line(GREY, 1),
                    ),
                ],
                &notes.map(String::from),
            )?;
        }
    }
    root.present().map_err(s)
}

/// The extent (smallest, largest) of sorted columns of finite values.
fn joint_extent<'a>(cols: impl Iterator<Item = &'a [f64]>) -> Option<(f64, f64)> {
    cols.filter_map(|c| Some((*c.first()?, *c.last()?)))
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
}

/// Whether values from `lo` to `hi` read better on a logarithmic axis:
/// all positive, spanning more than a factor of 10.
fn wants_log(lo: f64, hi: f64) -> bool {
    lo > 0.0 && hi / lo > 10.0
}

/// Labelled values of a logarithmic axis from `lo` to `hi`: 1, 2 and 5
/// times the powers of ten (1 and 3 over more than two decades, the powers
/// alone over more than four).
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let mults: &[f64] = match d1 - d0 {
        ..=2 => &[1.0, 2.0, 5.0],
        3..=4 => &[1.0, 3.0],
        _ => &[1.0],
    };
    (d0..=d1)
        .flat_map(|d| mults.iter().map(move |m| m * 10f64.powi(d)))
        .filter(|v| (lo..=hi).contains(v))
        .collect()
}

/// The extent of finite x values.
fn extent<'a>(pts: impl Iterator<Item = &'a (f64, f64)>) -> Option<(f64, f64)> {
    pts.map(|p| p.0)
        .filter(|x| x.is_finite())
        .fold(None, |acc, x| match acc {
            None => Some((x, x)),
            Some((a, b)) => Some((a.min(x), b.max(x))),
        })
}

fn cdf_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &CdfPanel,
) -> Result<(), String> {
    let all = || p.curves.iter().flat_map(|c| c.points.iter());
    let Some((lo, hi)) = p.extent.or_else(|| extent(all())) else {
        area.draw(&Text::new(
            format!("{}: no values", p.caption),
            (40, 40),
            ("sans-serif", 18).into_font(),
        ))
        .map_err(s)?;
        return Ok(());
    };
    if wants_log(lo, hi) {
        let (a, b) = (lo / 1.2, hi * 1.2);
        let axis = (a..b).log_scale().with_key_points(log_ticks(a, b));
        cdf_chart(area, p, axis, a, true)
    } else {
        let span = (hi - lo).max(hi.abs() * 1e-3).max(1e-12);
        let x0 = if lo >= 0.0 && lo < 0.25 * hi {
            0.0
        } else {
            lo - 0.03 * span
        };
        cdf_chart(area, p, x0..hi + 0.03 * span, x0, false)
    }
}

fn cdf_chart<DB, X>(
    area: &DrawingArea<DB, Shift>,
    p: &CdfPanel,
    x: X,
    x_floor: f64,
    log: bool,
) -> Result<(), String>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let caption = if log {
        format!("{} (logarithmic axis)", p.caption)
    } else {
        p.caption.clone()
    };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin_left(10)
        .margin_right(30)
        .margin_top(8)
        .x_label_area_size(52)
        .y_label_area_size(80)
        .build_cartesian_2d(x, 0.0..1.0)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc(p.x_desc.as_str())
        .y_desc("fraction of runs ≤ x")
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| format!("{v:.1}"))
        .x_labels(8)
        .y_labels(11)
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(s)?;
    let xr = chart.x_range();
    for q in [0.5, 0.95, 0.99] {
        chart
            .draw_series(LineSeries::new(
                [(xr.start, q), (xr.end, q)],
                GREY.mix(0.6).stroke_width(1),
            ))
            .map_err(s)?;
    }
    for c in &p.curves {
        // A step at each value: the CDF jumps there.
        let mut pts = Vec::with_capacity(2 * c.points.len() + 1);
        let mut prev = 0.0;
        for &(v, f) in c.points.iter().filter(|p| p.0.is_finite()) {
            let v = v.max(x_floor);
            pts.push((v, prev));
            pts.push((v, f));
            prev = f;
        }
        chart
            .draw_series(LineSeries::new(pts, c.color.stroke_width(2)))
            .map_err(s)?;
    }
    Ok(())
}

const INSIDE: RGBColor = RGBColor(0, 140, 60);
const OUTSIDE: RGBColor = RGBColor(200, 30, 30);
const BAND: RGBColor = RGBColor(0, 90, 180);

fn nees_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    pts: &[NeesPoint],
) -> Result<(), String> {
    if pts.is_empty() {
        area.draw(&Text::new(
            format!("{caption}: no values"),
            (40, 40),
            ("sans-serif", 18).into_font(),
        ))
        .map_err(s)?;
        return Ok(());
    }
    let lo = pts
        .iter()
        .flat_map(|p| [p.mean, p.lo])
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold(3.0_f64, f64::min);
    let hi = pts
        .iter()
        .flat_map(|p| [p.mean, p.hi])
        .filter(|v| v.is_finite())
        .fold(3.0_f64, f64::max);
    let x0 = f64::from(pts.first().map_or(0, |p| p.variation)) - 0.7;
    let x1 = f64::from(pts.last().map_or(0, |p| p.variation)) + 0.7;
    if wants_log(lo, hi) {
        let (a, b) = (lo / 1.3, hi * 1.3);
        let axis = (a..b).log_scale().with_key_points(log_ticks(a, b));
        nees_chart(area, caption, pts, x0..x1, axis, true)
    } else {
        let pad = 0.08 * (hi - lo);
        nees_chart(
            area,
            caption,
            pts,
            x0..x1,
            (lo - pad).max(0.0)..hi + pad,
            false,
        )
    }
}

fn nees_chart<DB, Y>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    pts: &[NeesPoint],
    x: std::ops::Range<f64>,
    y: Y,
    log: bool,
) -> Result<(), String>
where
    DB: DrawingBackend,
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let caption = if log {
        format!("{caption} (logarithmic axis)")
    } else {
        caption.to_owned()
    };
    let n_x = pts.len();
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin_left(10)
        .margin_right(30)
        .margin_top(6)
        .x_label_area_size(44)
        .y_label_area_size(80)
        .build_cartesian_2d(x.clone(), y)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc("variation")
        .y_desc("average NEES")
        .x_labels((n_x + 1).min(30))
        .x_label_formatter(&|v| {
            if (v - v.round()).abs() < 1e-6 && *v >= 0.0 {
                format!("v{}", v.round() as u64)
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| tick(*v))
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(s)?;
    chart
        .draw_series(LineSeries::new(
            [(x.start, 3.0), (x.end, 3.0)],
            GREY.mix(0.7).stroke_width(1),
        ))
        .map_err(s)?;
    let half = (0.3_f64).min(0.3 * (x.end - x.start) / n_x.max(1) as f64);
    chart
        .draw_series(pts.iter().map(|p| {
            let v = f64::from(p.variation);
            Rectangle::new(
                [(v - half, p.lo), (v + half, p.hi)],
                BAND.mix(0.25).filled(),
            )
        }))
        .map_err(s)?;
    chart
        .draw_series(pts.iter().map(|p| {
            let v = f64::from(p.variation);
            let c = if (p.lo..=p.hi).contains(&p.mean) {
                INSIDE
            } else {
                OUTSIDE
            };
            Circle::new((v, p.mean), 6, c.filled())
        }))
        .map_err(s)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use parquet::file::reader::{FileReader, SerializedFileReader};
    use parquet::record::Field;

    fn tmp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("pn-merge-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).expect("temp dir");
        d
    }

    fn sha() -> String {
        "ab".repeat(32)
    }

    /// A row exercising every kind of cell: nulls, seeds above 2^63,
    /// odd floats (−0, subnormal, a NaN), empty and non-ASCII strings.
    fn metrics(i: u64) -> Metrics {
        let variation = (i % 3) as u32;
        let label = format!("scenario=s{variation} preset=mems|x ünïcode");
        let scenario = ["transpolar-gnss", "spoof-ramp", "spoof-step"][variation as usize];
        if i % 11 == 7 {
            return Metrics::failed(
                i,
                variation,
                &label,
                scenario,
                u64::MAX - i,
                format!("panicked at 'index out of bounds' (run {})", i % 2),
            );
        }
        let x = i as f64;
        let mut m = Metrics::failed(i, variation, &label, scenario, u64::MAX - i, String::new());
        m.outcome = Outcome::Ok;
        m.flight_h = Some(1.0 + 0.01 * x);
        m.epochs = Some(36_000 + i);
        m.non_finite_epochs = Some(0);
        m.horizontal_rmse_m = Some(2.0 + (x * 0.37).sin().abs() * 10.0);
        m.horizontal_max_m = Some(if i == 3 { -0.0 } else { 5.0 + x * 0.1 });
        m.vertical_rmse_m = Some(if i == 4 { 5e-324 } else { 1.5 });
        m.vertical_max_m = i.is_multiple_of(2).then_some(3.0);
        m.velocity_rmse_mps = Some(0.1);
        m.velocity_max_mps = Some(0.4);
        m.attitude_rmse_arcmin = Some(2.5);
        m.attitude_max_arcmin = Some(if i == 5 { f64::NAN } else { 9.0 });
        m.nees_position = Some(3.0 + 0.1 * (x * 1.3).sin());
        m.nees_velocity = Some(2.9);
        m.nees_attitude = (!i.is_multiple_of(4)).then_some(3.2);
        m.switches = Some(1);
        m.resets = Some(i as u32 % 3);
        m.resets_aid = Some(0);
        m.resets_integrity = Some(u32::MAX);
        m.reset_causes = Some(if i.is_multiple_of(2) {
            String::new()
        } else {
            "gnss:1".into()
        });
        m.reinits = Some(0);
        m.covariance_repairs = Some(0);
        m.gnss_fixes = Some(3600);
        m.gnss_tested = Some(3500);
        m.gnss_untested = Some(100);
        m.gnss_exclusions = Some(u64::from(variation != 0));
        m.gnss_readmissions = Some(0);
        m.gnss_false_exclusions = Some(0);
        m.max_q_ratio = Some(0.8);
        if variation != 0 {
            m.fault = Some("spoof".into());
            m.fault_start_s = Some(600.0);
            m.fault_detected = Some(i % 13 != 1);
            if m.fault_detected == Some(true) {
                m.time_to_exclusion_s = Some(10.0 + x % 17.0);
                m.error_at_exclusion_m = Some(30.0 + x % 41.0);
            }
        }
        m.judgement_pass = i.is_multiple_of(5).then_some(true);
        m
    }

    fn cost(i: u64, host: &str) -> Cost {
        Cost {
            index: i,
            flight_h: 1.0,
            cpu_s: 10.0 + i as f64,
            simulate_cpu_s: 2.0,
            navigate_cpu_s: 6.0,
            evaluate_cpu_s: 1.0,
            wall_s: 11.0,
            peak_rss_mib: 80.0,
            host: host.into(),
            executor: "local".into(),
            version: "0.1.0".into(),
            commit: "abc".into(),
        }
    }

    fn write(dir: &Path, rows: &[Metrics], host: &str) {
        for m in rows {
            store::write_result(
                dir,
                &store::RunResult {
                    campaign_sha256: sha(),
                    metrics: m.clone(),
                    cost: cost(m.index, host),
                },
            )
            .expect("write");
        }
    }

    /// Every column is a field of `Metrics`, in the struct's order (the
    /// serde order), and none is missing.
    #[test]
    fn the_columns_are_the_fields() {
        let v = serde_json::to_value(metrics(1)).expect("json");
        let keys: Vec<&str> = v
            .as_object()
            .expect("object")
            .keys()
            .map(String::as_str)
            .collect();
        let cols: Vec<&str> = metrics_columns().iter().map(|c| c.name).collect();
        assert_eq!(cols, keys);
        let v = serde_json::to_value(cost(1, "h")).expect("json");
        let keys: Vec<&str> = v
            .as_object()
            .expect("object")
            .keys()
            .map(String::as_str)
            .collect();
        let cols: Vec<&str> = cost_columns().iter().map(|c| c.name).collect();
        assert_eq!(cols, keys);
    }

    /// A cell read back against the row's own serialization (serde_json
    /// of the struct: independent of the column getters).
    fn check_cell(field: &Field, want: &serde_json::Value, what: &str) {
        use serde_json::Value;
        match (field, want) {
            (Field::Null, Value::Null) => {}
            (Field::ULong(v), Value::Number(n)) => assert_eq!(Some(*v), n.as_u64(), "{what}"),
            (Field::UInt(v), Value::Number(n)) => {
                assert_eq!(Some(u64::from(*v)), n.as_u64(), "{what}")
            }
            (Field::Double(v), Value::Number(n)) => {
                let w = n.as_f64().expect("f64");
                assert_eq!(v.to_bits(), w.to_bits(), "{what}: {v} vs {w}");
            }
            (Field::Bool(v), Value::Bool(w)) => assert_eq!(v, w, "{what}"),
            (Field::Str(v), Value::String(w)) => assert_eq!(v, w, "{what}"),
            _ => panic!("{what}: {field:?} against {want}"),
        }
    }

    fn read_back(path: &Path) -> Vec<Vec<(String, Field)>> {
        let r = SerializedFileReader::new(fs::File::open(path).expect("open")).expect("reader");
        r.get_row_iter(None)
            .expect("rows")
            .map(|row| {
                row.expect("row")
                    .get_column_iter()
                    .map(|(n, f)| (n.clone(), f.clone()))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_tables_hold_every_cell_bit_for_bit() {
        let dir = tmp_dir("cells");
        let rows: Vec<Metrics> = (0..40).map(metrics).collect();
        write(&dir, &rows, "h1");
        let s = merge(&dir, &sha(), 40, "cells").expect("merge");
        assert_eq!((s.rows, s.missing_count), (40, 0));
        let back = read_back(&s.metrics_parquet);
        assert_eq!(back.len(), rows.len());
        for (m, cells) in rows.iter().zip(&back) {
            let want = serde_json::to_value(m).expect("json");
            let want = want.as_object().expect("object");
            assert_eq!(cells.len(), want.len());
            for ((name, field), (key, value)) in cells.iter().zip(want) {
                assert_eq!(name, key);
                check_cell(field, value, &format!("run {} {name}", m.index));
            }
            // A NaN is a null (the result file's JSON has no NaN); −0 keeps its sign.
            let cell = |name: &str| &cells.iter().find(|c| c.0 == name).expect("column").1;
            if m.index == 5 {
                assert!(matches!(cell("attitude_max_arcmin"), Field::Null));
            }
            if m.index == 3 {
                let f = cell("horizontal_max_m");
                assert!(matches!(f, Field::Double(v) if v.to_bits() == (-0.0_f64).to_bits()));
            }
        }
        let back = read_back(&s.cost_parquet);
        for (m, cells) in rows.iter().zip(&back) {
            let want = serde_json::to_value(cost(m.index, "h1")).expect("json");
            for ((name, field), (key, value)) in cells.iter().zip(want.as_object().expect("o")) {
                assert_eq!(name, key);
                check_cell(field, value, &format!("cost {} {name}", m.index));
            }
        }
        let _ = fs::remove_dir_all(&dir);
    }

    /// The same rows written in another order, with other costs, by
    /// "another executor": the same metrics bytes.
    #[test]
    fn the_metrics_table_is_a_function_of_the_rows() {
        let (a, b) = (tmp_dir("det-a"), tmp_dir("det-b"));
        let rows: Vec<Metrics> = (0..30).map(metrics).collect();
        write(&a, &rows, "laptop");
        let rev: Vec<Metrics> = rows.iter().rev().cloned().collect();
        write(&b, &rev, "node-17");
        let sa = merge(&a, &sha(), 30, "a").expect("merge a");
        let sb = merge(&b, &sha(), 30, "b").expect("merge b");
        let (ba, bb) = (
            fs::read(&sa.metrics_parquet).expect("a"),
            fs::read(&sb.metrics_parquet).expect("b"),
        );
        assert!(ba == bb, "the metrics tables differ");
        assert!(fs::read(&sa.cost_parquet).expect("a") != fs::read(&sb.cost_parquet).expect("b"));
        // Merging again writes the same bytes.
        let again = merge(&a, &sha(), 30, "a").expect("again");
        assert!(fs::read(&again.metrics_parquet).expect("again") == ba);
        let _ = fs::remove_dir_all(&a);
        let _ = fs::remove_dir_all(&b);
    }

    #[test]
    fn missing_and_unusable_runs_are_listed_not_fatal() {
        let dir = tmp_dir("missing");
        let rows: Vec<Metrics> = (0..25)
            .filter(|i| !(3..=5).contains(i) && *i != 9)
            .map(metrics)
            .collect();
        write(&dir, &rows, "h");
        // Run 12 damaged, run 13 of another campaign.
        let p = store::result_path(&dir, 12);
        let mut bytes = fs::read(&p).expect("read");
        bytes[10] ^= 1;
        fs::write(&p, bytes).expect("damage");
        let mut other = store::RunResult {
            campaign_sha256: "cd".repeat(32),
            metrics: metrics(13),
            cost: cost(13, "h"),
        };
        other.metrics.index = 13;
        fs::write(store::result_path(&dir, 13), store::encode(&other)).expect("other");
        let s = merge(&dir, &sha(), 27, "missing").expect("merge");
        assert_eq!(s.missing, vec![3..=5, 9..=9, 12..=13, 25..=26]);
        assert_eq!((s.missing_count, s.unusable_count), (8, 2));
        assert_eq!(s.rows, 19);
        assert!(s.unusable[0].1.contains("checksum"), "{:?}", s.unusable);
        assert!(s.unusable[1].1.contains("campaign"), "{:?}", s.unusable);
        let md = fs::read_to_string(&s.report).expect("report");
        assert!(md.contains("3–5, 9, 12–13, 25–26"), "{md}");
        let back = read_back(&s.metrics_parquet);
        let idx: Vec<u64> = back
            .iter()
            .map(|c| match c[0].1 {
                Field::ULong(v) => v,
                _ => u64::MAX,
            })
            .collect();
        let want: Vec<u64> = (0..25)
            .filter(|i| !(3..=5).contains(i) && *i != 9 && *i != 12 && *i != 13)
            .collect();
        assert_eq!(idx, want);
        let _ = fs::remove_dir_all(&dir);
    }

    /// The report's figures against a computation by hand on the rows.
    #[test]
    fn the_report_states_the_figures() {
        let dir = tmp_dir("report");
        let rows: Vec<Metrics> = (0..120).map(metrics).collect();
        write(&dir, &rows, "h");
        let s = merge(&dir, &sha(), 120, "Report test").expect("merge");
        let md = fs::read_to_string(&s.report).expect("report");
        assert!(md.starts_with("# Campaign report: Report test"));
        // Clean flights: variation 0, done.
        let clean: Vec<&Metrics> = rows
            .iter()
            .filter(|m| m.outcome == Outcome::Ok && m.fault.is_none())
            .collect();
        let hours_clean: f64 = clean.iter().filter_map(|m| m.flight_h).sum();
        let tested: u64 = clean.iter().filter_map(|m| m.gnss_tested).sum();
        let b = -(0.05_f64).ln() / hours_clean;
        let line = format!(
            "**0 false exclusions in {} flight hours: rate < {} /h at 95 %; 0 in {} tested fixes",
            hours(hours_clean),
            sig(b, 3),
            count(tested)
        );
        assert!(md.contains(&line), "no «{line}» in\n{md}");
        // Detection of profile spoof-ramp (variation 1).
        let ramp: Vec<&Metrics> = rows
            .iter()
            .filter(|m| m.outcome == Outcome::Ok && m.variation == 1)
            .collect();
        let det = ramp
            .iter()
            .filter(|m| m.fault_detected == Some(true))
            .count();
        let lo = stats::clopper_pearson_lower(det as u64, ramp.len() as u64, 0.95).expect("lo");
        let row = format!(
            "| `spoof-ramp` | {} | 0 | {det} | {} | {} |",
            ramp.len(),
            sig(det as f64 / ramp.len() as f64, 4),
            sig(lo, 4)
        );
        assert!(md.contains(&row), "no «{row}» in\n{md}");
        // The NEES band of variation 0's position NEES.
        let n = rows
            .iter()
            .filter(|m| m.outcome == Outcome::Ok && m.variation == 0)
            .count() as u64;
        let (blo, bhi) = stats::nees_band(n, 3, 0.95).expect("band");
        assert!(
            md.contains(&format!("[{}, {}]", sig(blo, 4), sig(bhi, 4))),
            "{md}"
        );
        // Cost: flight hours per core hour.
        let cpu: f64 = rows.iter().map(|m| cost(m.index, "h").cpu_s).sum();
        let fh = rows.len() as f64;
        assert!(md.contains(&format!(
            "**{} flight hours per core hour**",
            sig(fh / (cpu / 3600.0), 4)
        )));
        assert!(
            md.contains("| 6 | 7 | panicked at 'index out of bounds' (run 1) |"),
            "{md}"
        );
        assert!(
            md.contains("| 5 | 18 | panicked at 'index out of bounds' (run 0) |"),
            "{md}"
        );
        assert!(md.contains("`scenario=s0 preset=mems\\|x ünïcode`"), "{md}");
        for f in &s.figures {
            assert!(f.exists(), "{}", f.display());
            assert!(
                md.contains(&format!("figures/{}", name_of(f))),
                "{}",
                f.display()
            );
        }
        assert_eq!(s.figures.len(), 3);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_empty_campaign_merges() {
        let dir = tmp_dir("empty");
        let s = merge(&dir, &sha(), 5, "empty").expect("merge");
        assert_eq!((s.rows, s.missing_count), (0, 5));
        assert!(read_back(&s.metrics_parquet).is_empty());
        assert!(s.figures.is_empty());
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn expectations_count_nulls_and_nans() {
        let rows: Vec<Metrics> = (0..12).map(metrics).collect();
        let v: serde_json::Value =
            serde_json::from_str(&parquet_expectations(&rows)).expect("json");
        assert_eq!(v["rows"], 12);
        let col = |name: &str| {
            v["columns"]
                .as_array()
                .expect("array")
                .iter()
                .find(|c| c["name"] == name)
                .cloned()
                .expect("column")
        };
        assert_eq!(col("seed")["type"], "uint64");
        // Run 5's NaN is a null, as the store makes it.
        assert_eq!(col("attitude_max_arcmin")["nulls"], 1 + 1);
        // Run 7 failed: nulls in every optional column.
        assert_eq!(col("fault")["nulls"], 1 + 4);
        assert_eq!(col("flight_h")["nulls"], 1);
    }

    #[test]
    fn formats() {
        assert_eq!(count(1_512_000), "1 512 000");
        assert_eq!(count(12), "12");
        assert_eq!(sig(0.001_981_3, 3), "0.00198");
        assert_eq!(sig(12.345, 4), "12.35");
        assert_eq!(sig(1.5e-7, 3), "1.50e-7");
        assert_eq!(tick(2.50), "2.5");
        assert_eq!(tick(100.0), "100");
        assert_eq!(
            polarnav_eval::plots::wrap("scenario=a preset=bb", 12),
            vec!["scenario=a".to_owned(), "preset=bb".into()]
        );
        assert_eq!(
            polarnav_eval::plots::wrap("abcdefghij", 4),
            vec!["abcd", "efgh", "ij"]
        );
    }
}
