//! Reading a navlog file into memory by record kind, with the damage report.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use msgs::navlog::{Header, NavlogReader, ReadReport, Record, TruthBias};
use msgs::{AidKind, AidSample, ImuSample, InitState, Solution, Status, TruthRecord};

/// Each aid's samples, each in a vector of its own payload type (compact:
/// a barometer sample takes its 40 bytes, not an SRS sample's 720).
macro_rules! aid_records {
    ([$(($K:ident, $n:ident, $P:ident, $d:tt)),* $(,)?]) => {
        /// Each aid's samples, in log order.
        #[derive(Debug, Default, Clone)]
        pub struct AidRecords {
            $(pub $n: Vec<msgs::$P>,)*
        }

        impl AidRecords {
            /// Appends `x`; returns its index among its aid's samples.
            pub fn push(&mut self, x: AidSample) -> usize {
                match x {
                    $(AidSample::$K(x) => {
                        self.$n.push(x);
                        self.$n.len() - 1
                    })*
                }
            }

            /// Sample `i` of aid `k`.
            pub fn get(&self, k: AidKind, i: usize) -> Option<AidSample> {
                match k {
                    $(AidKind::$K => self.$n.get(i).map(|x| AidSample::$K(*x)),)*
                }
            }

            /// The number of samples of aid `k`.
            pub fn len(&self, k: AidKind) -> usize {
                match k {
                    $(AidKind::$K => self.$n.len(),)*
                }
            }

            /// True when no aid has a sample.
            pub fn is_empty(&self) -> bool {
                AidKind::ALL.iter().all(|k| self.len(*k) == 0)
            }
        }
    };
}
msgs::for_each_aid!(aid_records);

/// Every intact record of a log, grouped by kind.
#[derive(Debug, Default, Clone)]
pub struct LogContents {
    pub header: Option<Header>,
    pub init: Vec<InitState>,
    pub imu: Vec<ImuSample>,
    pub aids: AidRecords,
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
    Aid(AidKind, usize),
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

/// A navlog read one record at a time: memory holds one record and the
/// read buffer, whatever the file's length. Errors name the file.
#[derive(Debug)]
pub struct LogReader {
    path: String,
    reader: NavlogReader<BufReader<File>>,
}

impl LogReader {
    /// Opens `path` for reading from its first record.
    pub fn open(path: &Path) -> Result<Self, LoadError> {
        let p = path.display().to_string();
        let f = File::open(path).map_err(|source| LoadError::Open {
            path: p.clone(),
            source,
        })?;
        Ok(Self {
            path: p,
            reader: NavlogReader::new(BufReader::with_capacity(1 << 20, f)),
        })
    }

    /// The next intact record (damaged frames are counted in
    /// [`LogReader::report`] and skipped); `None` at the end.
    pub fn next_record(&mut self) -> Result<Option<Record>, LoadError> {
        self.reader.next_record().map_err(|source| LoadError::Read {
            path: self.path.clone(),
            source,
        })
    }

    /// What was read and skipped so far (complete at the end).
    pub fn report(&self) -> &ReadReport {
        self.reader.report()
    }

    /// The file, as errors name it.
    pub fn path(&self) -> &str {
        &self.path
    }
}

/// Loads a navlog; the report says what was skipped.
pub fn load(path: &Path) -> Result<LogContents, LoadError> {
    let mut r = LogReader::open(path)?;
    let mut c = LogContents::default();
    while let Some(rec) = r.next_record()? {
        match rec {
            Record::Header(h) => c.header = Some(*h),
            Record::Init(x) => c.init.push(x),
            Record::Imu(x) => {
                c.order.push(SensorRef::Imu(c.imu.len()));
                c.imu.push(x);
            }
            Record::Aid(x) => {
                let k = x.kind();
                let i = c.aids.push(*x);
                c.order.push(SensorRef::Aid(k, i));
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
