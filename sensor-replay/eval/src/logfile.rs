//! Reading a navlog file into memory by record kind, with the damage report.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use msgs::navlog::{Header, NavlogReader, ReadReport, Record, TruthBias};
use msgs::{
    BaroSample, CnsFix, ImuSample, InitState, Solution, SrsSample, StarSample, Status, TruthRecord,
};

/// Every intact record of a log, grouped by kind.
#[derive(Debug, Default, Clone)]
pub struct LogContents {
    pub header: Option<Header>,
    pub init: Vec<InitState>,
    pub imu: Vec<ImuSample>,
    pub srs: Vec<SrsSample>,
    pub cns: Vec<CnsFix>,
    pub baro: Vec<BaroSample>,
    pub star: Vec<StarSample>,
    pub truth: Vec<TruthRecord>,
    /// The simulated IMU bias at the truth epochs (simulated logs only).
    pub truth_bias: Vec<TruthBias>,
    pub solution: Vec<Solution>,
    /// The daemon's status records (a live recording: 1 Hz).
    pub status: Vec<Status>,
    pub report: ReadReport,
    /// The sensor records in log order (the order they arrived or were
    /// emitted in), as indices into the per-stream vectors.
    pub order: Vec<SensorRef>,
}

/// A sensor record of a [`LogContents`], by stream and index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorRef {
    Imu(usize),
    Srs(usize),
    Cns(usize),
    Baro(usize),
    Star(usize),
}

/// Errors that stop loading (damage inside the file does not).
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("{path}: cannot open: {source}")]
    Open {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Read {
        path: String,
        source: msgs::navlog::ReadError,
    },
}

/// Loads a navlog; the report says what was skipped.
pub fn load(path: &Path) -> Result<LogContents, LoadError> {
    let p = path.display().to_string();
    let f = File::open(path).map_err(|source| LoadError::Open {
        path: p.clone(),
        source,
    })?;
    let mut r = NavlogReader::new(BufReader::with_capacity(1 << 20, f));
    let mut c = LogContents::default();
    while let Some(rec) = r.next_record().map_err(|source| LoadError::Read {
        path: p.clone(),
        source,
    })? {
        match rec {
            Record::Header(h) => c.header = Some(*h),
            Record::Init(x) => c.init.push(x),
            Record::Imu(x) => {
                c.order.push(SensorRef::Imu(c.imu.len()));
                c.imu.push(x);
            }
            Record::Srs(x) => {
                c.order.push(SensorRef::Srs(c.srs.len()));
                c.srs.push(*x);
            }
            Record::Cns(x) => {
                c.order.push(SensorRef::Cns(c.cns.len()));
                c.cns.push(x);
            }
            Record::Baro(x) => {
                c.order.push(SensorRef::Baro(c.baro.len()));
                c.baro.push(x);
            }
            Record::Star(x) => {
                c.order.push(SensorRef::Star(c.star.len()));
                c.star.push(x);
            }
            Record::Truth(x) => c.truth.push(x),
            Record::Solution(x) => c.solution.push(*x),
            Record::Status(x) => c.status.push(*x),
            Record::TruthBias(x) => c.truth_bias.push(x),
        }
    }
    c.report = r.report().clone();
    Ok(c)
}
