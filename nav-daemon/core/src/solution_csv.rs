//! Solution CSV, columns exactly as DESIGN "Command-line contract".
//!
//! The first 24 columns are the original contract; the columns after them
//! (σ of velocity and attitude, biases, grid heading, flags, aid freshness,
//! counters) were added after them so that readers that index the first 24
//! keep working. [`parse`] finds every column by its header name, so columns
//! may be reordered and unknown columns are ignored. The bias σ group
//! ([`HEADER_BIAS_SIGMA`], after `reset_count`, with `Solution_v3`) is
//! optional on reading: files written before it read with `None` there.
//!
//! The velocity columns carry their unit (`vx_mps`... ECEF, `ve_mps`...
//! ENU, m/s); files written before that name them `vx,vy,vz,ve,vn,vu`
//! ([`RENAMED`]), and [`parse`] still reads those for one version. A header
//! with both names of a column reads the new one (the old one is then an
//! unknown column, as it will be once the old names are no longer read).

use std::io::Write;

use msgs::{Solution, WireFrame, solution_flags};

/// The original 24 columns.
pub const HEADER_BASE: &str = "t_s,frame,lat_deg,lon_deg,h_m,x_m,y_m,z_m,vx_mps,vy_mps,vz_mps,ve_mps,vn_mps,vu_mps,qw,qx,qy,qz,heading_deg,pitch_deg,roll_deg,sig_e_m,sig_n_m,sig_u_m";

/// Columns renamed to carry their unit: (name written, former name still
/// read). The former names are read for one version after the rename.
pub const RENAMED: [(&str, &str); 6] = [
    ("vx_mps", "vx"),
    ("vy_mps", "vy"),
    ("vz_mps", "vz"),
    ("ve_mps", "ve"),
    ("vn_mps", "vn"),
    ("vu_mps", "vu"),
];

/// The former name of a renamed column ([`RENAMED`]).
pub fn former_name(column: &str) -> Option<&'static str> {
    RENAMED
        .iter()
        .find(|(new, _)| *new == column)
        .map(|&(_, old)| old)
}

/// The 45 columns every reader requires: [`HEADER_BASE`] and the ones
/// added after it up to `reset_count`.
pub const HEADER_REQUIRED: &str = "t_s,frame,lat_deg,lon_deg,h_m,x_m,y_m,z_m,vx_mps,vy_mps,vz_mps,ve_mps,vn_mps,vu_mps,qw,qx,qy,qz,heading_deg,pitch_deg,roll_deg,sig_e_m,sig_n_m,sig_u_m,sig_vnav_x_mps,sig_vnav_y_mps,sig_vnav_z_mps,sig_att_x_deg,sig_att_y_deg,sig_att_z_deg,bg_x_rps,bg_y_rps,bg_z_rps,ba_x_mps2,ba_y_mps2,ba_z_mps2,grid_heading_deg,flags,srs_fresh,cns_fresh,baro_fresh,imu_lost,coasting,switch_count,reset_count";

/// The bias σ group (`Solution_v3`): 1-σ of the gyro bias (rad/s) and of
/// the accelerometer bias (m/s²), body axes. Optional on reading.
pub const HEADER_BIAS_SIGMA: &str =
    "sig_bg_x_rps,sig_bg_y_rps,sig_bg_z_rps,sig_ba_x_mps2,sig_ba_y_mps2,sig_ba_z_mps2";

/// The columns read: [`HEADER_REQUIRED`], then [`HEADER_BIAS_SIGMA`].
/// A written file has the aid group ([`aid_columns`]) after them.
pub const HEADER: &str = "t_s,frame,lat_deg,lon_deg,h_m,x_m,y_m,z_m,vx_mps,vy_mps,vz_mps,ve_mps,vn_mps,vu_mps,qw,qx,qy,qz,heading_deg,pitch_deg,roll_deg,sig_e_m,sig_n_m,sig_u_m,sig_vnav_x_mps,sig_vnav_y_mps,sig_vnav_z_mps,sig_att_x_deg,sig_att_y_deg,sig_att_z_deg,bg_x_rps,bg_y_rps,bg_z_rps,ba_x_mps2,ba_y_mps2,ba_z_mps2,grid_heading_deg,flags,srs_fresh,cns_fresh,baro_fresh,imu_lost,coasting,switch_count,reset_count,sig_bg_x_rps,sig_bg_y_rps,sig_bg_z_rps,sig_ba_x_mps2,sig_ba_y_mps2,sig_ba_z_mps2";

/// The aid group, derived from the aid declaration (`msgs::for_each_aid!`):
/// `NAME_fresh` (0/1) for every aid whose freshness has no column among
/// [`HEADER_REQUIRED`] (the first three aids have theirs there), then
/// `NAME_excluded` (0/1) for every aid that is not autonomous (its
/// integrity test excludes it), then `NAME_untested` (0/1) for each of
/// them (fused untested: its integrity test unavailable). So a pandas or MATLAB user reads which
/// aids navigated at each epoch by name, e.g. `star_fresh`, `gnss_fresh`,
/// `gnss_excluded`. Each column repeats one bit of `flags`, which is what
/// [`parse`] reads: the group is ignored on reading, and a file written
/// before it reads the same. Paired with each column's bit of `flags`.
pub fn aid_columns() -> &'static [(String, u32)] {
    static GROUP: std::sync::OnceLock<Vec<(String, u32)>> = std::sync::OnceLock::new();
    GROUP.get_or_init(|| {
        let decls = msgs::AidKind::ALL.map(|k| k.decl());
        let fresh = decls.iter().filter_map(|d| {
            let name = format!("{}_fresh", d.name);
            (!HEADER_REQUIRED.split(',').any(|c| c == name)).then_some((name, d.fresh_flag))
        });
        let excluded = decls
            .iter()
            .filter(|d| !d.autonomous)
            .map(|d| (format!("{}_excluded", d.name), d.excluded_flag));
        let untested = decls
            .iter()
            .filter(|d| !d.autonomous)
            .map(|d| (format!("{}_untested", d.name), d.untested_flag));
        fresh.chain(excluded).chain(untested).collect()
    })
}

/// The header line a writer writes: [`HEADER`], then the aid group
/// ([`aid_columns`]).
pub fn header() -> &'static str {
    static LINE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    LINE.get_or_init(|| {
        let mut line = String::from(HEADER);
        for (name, _) in aid_columns() {
            line.push(',');
            line.push_str(name);
        }
        line
    })
}

/// Number of columns of [`HEADER_REQUIRED`].
pub const COLUMNS_REQUIRED: usize = 45;

/// Number of columns of [`HEADER_BIAS_SIGMA`].
pub const COLUMNS_BIAS_SIGMA: usize = 6;

/// Number of columns of [`HEADER`].
pub const COLUMNS: usize = COLUMNS_REQUIRED + COLUMNS_BIAS_SIGMA;

/// Writes one row (see [`RowWriter`]; a writer of many rows keeps one
/// [`RowWriter`], which skips reformatting the values that did not change).
pub fn write_row<W: Write>(out: &mut W, s: &Solution) -> std::io::Result<()> {
    RowWriter::new().write(out, s)
}

/// Number of floating-point columns of [`HEADER`]: the 35 after `t_s` and
/// `frame` (the eight integer columns follow them), and the bias σ group
/// after the integers.
const FLOAT_COLUMNS: usize = 35 + COLUMNS_BIAS_SIGMA;

/// Longest line: every column at most 24 bytes, separators and newline,
/// and the aid group's 0/1 columns (one per aid, two more per aid that
/// is not autonomous: at most three per aid).
const LINE_CAP: usize = COLUMNS * 25 + 16 + 6 * msgs::AID_COUNT;

/// The last value written in a column and its text.
#[derive(Clone, Copy)]
struct Formatted {
    bits: u64,
    len: u8,
    text: [u8; 24],
}

/// Writes solution rows. Numbers are written in their shortest round-trip
/// form (zmij, Schubfach-based), so a row reads back to the same f64 values
/// bit for bit. A value equal, bit for bit, to the one of the previous row
/// in its column (biases and σ between filter steps, counters) reuses that
/// row's text instead of being formatted again. The row is assembled in
/// the writer's own buffer and written once; no allocation.
pub struct RowWriter {
    line: [u8; LINE_CAP],
    last: [Formatted; FLOAT_COLUMNS],
    /// The aid group's bits of `flags`, in column order.
    aid_bits: &'static [(String, u32)],
}

impl std::fmt::Debug for RowWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RowWriter").finish_non_exhaustive()
    }
}

impl Default for RowWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl RowWriter {
    pub fn new() -> Self {
        // Every column starts as 0.0 with zmij's text of it, so the cache
        // is right for any bits a row brings.
        let mut zero = Formatted {
            bits: 0.0f64.to_bits(),
            len: 0,
            text: [0; 24],
        };
        let mut buf = zmij::Buffer::new();
        let text = buf.format(0.0f64).as_bytes();
        zero.len = text.len() as u8;
        zero.text[..text.len()].copy_from_slice(text);
        Self {
            line: [0; LINE_CAP],
            last: [zero; FLOAT_COLUMNS],
            aid_bits: aid_columns(),
        }
    }

    /// Writes the row of `s` to `out` (one `write_all`).
    pub fn write<W: Write>(&mut self, out: &mut W, s: &Solution) -> std::io::Result<()> {
        let n = self.assemble(s);
        out.write_all(&self.line[..n])
    }

    /// The row of `s` as text (for tests and tools).
    pub fn row(&mut self, s: &Solution) -> &str {
        let n = self.assemble(s);
        std::str::from_utf8(&self.line[..n]).unwrap_or_default()
    }

    fn assemble(&mut self, s: &Solution) -> usize {
        let [x, y, z] = s.r_e_m;
        let [vx, vy, vz] = s.v_e_mps;
        let [ve, vn, vu] = s.v_enu_mps;
        let [qw, qx, qy, qz] = s.q_b_e;
        let [se, sn, su] = s.sigma_pos_enu_m;
        let [svx, svy, svz] = s.sigma_vel_mps;
        let [sax, say, saz] = s.sigma_att_rad;
        let [bgx, bgy, bgz] = s.gyro_bias_rps;
        let [ba_x, ba_y, ba_z] = s.accel_bias_mps2;
        let [sbgx, sbgy, sbgz] = s.sigma_gyro_bias_rps;
        let [sbax, sbay, sbaz] = s.sigma_accel_bias_mps2;
        let floats: [f64; FLOAT_COLUMNS] = [
            s.lat_rad.to_degrees(),
            s.lon_rad.to_degrees(),
            s.h_m,
            x,
            y,
            z,
            vx,
            vy,
            vz,
            ve,
            vn,
            vu,
            qw,
            qx,
            qy,
            qz,
            s.heading_rad.to_degrees(),
            s.pitch_rad.to_degrees(),
            s.roll_rad.to_degrees(),
            se,
            sn,
            su,
            svx,
            svy,
            svz,
            sax.to_degrees(),
            say.to_degrees(),
            saz.to_degrees(),
            bgx,
            bgy,
            bgz,
            ba_x,
            ba_y,
            ba_z,
            s.grid_heading_rad.to_degrees(),
            sbgx,
            sbgy,
            sbgz,
            sbax,
            sbay,
            sbaz,
        ];
        let (head, tail) = floats.split_at(FLOAT_COLUMNS - COLUMNS_BIAS_SIGMA);
        let (last_head, last_tail) = self.last.split_at_mut(FLOAT_COLUMNS - COLUMNS_BIAS_SIGMA);
        let line = &mut self.line;
        let mut n = 0;
        let mut buf = zmij::Buffer::new();
        put(line, &mut n, buf.format(s.t_ns as f64 * 1e-9).as_bytes());
        let frame = WireFrame::from_u8(s.frame).map_or(b'?', |f| f.letter() as u8);
        line[n] = b',';
        line[n + 1] = frame;
        n += 2;
        put_floats(line, &mut n, &mut buf, head, last_head);
        let bit = |b: u32| u32::from(s.flags & b != 0);
        let mut ibuf = itoa_buf::Buf::default();
        for v in [
            s.flags,
            bit(solution_flags::SRS_FRESH),
            bit(solution_flags::CNS_FRESH),
            bit(solution_flags::BARO_FRESH),
            bit(solution_flags::IMU_LOST),
            bit(solution_flags::COASTING),
            s.switch_count,
            s.reset_count,
        ] {
            line[n] = b',';
            n += 1;
            put(line, &mut n, ibuf.format(v));
        }
        put_floats(line, &mut n, &mut buf, tail, last_tail);
        for (_, b) in self.aid_bits {
            line[n] = b',';
            line[n + 1] = if s.flags & b != 0 { b'1' } else { b'0' };
            n += 2;
        }
        line[n] = b'\n';
        n + 1
    }
}

/// Appends `,v` for each of `values` to `line` at `*n`; `last` holds the
/// previous row's value and text of each column.
#[inline(always)]
fn put_floats(
    line: &mut [u8],
    n: &mut usize,
    buf: &mut zmij::Buffer,
    values: &[f64],
    last: &mut [Formatted],
) {
    for (v, last) in values.iter().zip(last.iter_mut()) {
        line[*n] = b',';
        *n += 1;
        let bits = v.to_bits();
        if bits == last.bits {
            put(line, n, &last.text[..usize::from(last.len)]);
        } else {
            // Both copies from zmij's text: reading the cache back just
            // after writing it would stall on store forwarding.
            let text = buf.format(*v).as_bytes();
            put(line, n, text);
            last.bits = bits;
            last.len = text.len() as u8;
            put(&mut last.text, &mut 0, text);
        }
    }
}

/// Copies a short slice (at most 32 bytes) to `dst` at `*n` with
/// fixed-size moves (two overlapping ones), not a call to `memcpy` for a
/// few bytes: 45 of those per row were a sixth of `batch`'s time.
#[inline(always)]
fn put(dst: &mut [u8], n: &mut usize, src: &[u8]) {
    let len = src.len();
    let d = &mut dst[*n..*n + len];
    if len >= 16 {
        d[..16].copy_from_slice(&src[..16]);
        d[len - 16..].copy_from_slice(&src[len - 16..]);
    } else if len >= 8 {
        d[..8].copy_from_slice(&src[..8]);
        d[len - 8..].copy_from_slice(&src[len - 8..]);
    } else if len >= 4 {
        d[..4].copy_from_slice(&src[..4]);
        d[len - 4..].copy_from_slice(&src[len - 4..]);
    } else if len >= 2 {
        d[..2].copy_from_slice(&src[..2]);
        d[len - 2..].copy_from_slice(&src[len - 2..]);
    } else if len == 1 {
        d[0] = src[0];
    }
    *n += len;
}

/// Decimal formatting of a u32 without allocation.
mod itoa_buf {
    #[derive(Default)]
    pub struct Buf([u8; 10]);
    impl Buf {
        pub fn format(&mut self, mut v: u32) -> &[u8] {
            let mut i = self.0.len();
            loop {
                i -= 1;
                self.0[i] = b'0' + (v % 10) as u8;
                v /= 10;
                if v == 0 {
                    break;
                }
            }
            &self.0[i..]
        }
    }
}

/// One parsed row: every column of [`HEADER`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    pub t_s: f64,
    pub frame: char,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub h_m: f64,
    pub r_e_m: [f64; 3],
    pub v_e_mps: [f64; 3],
    pub v_enu_mps: [f64; 3],
    pub q_b_e: [f64; 4],
    pub heading_deg: f64,
    pub pitch_deg: f64,
    pub roll_deg: f64,
    pub sigma_enu_m: [f64; 3],
    /// 1-σ of velocity, navigation-frame axes (m/s).
    pub sigma_vel_nav_mps: [f64; 3],
    /// 1-σ of attitude error φ, navigation-frame axes (deg).
    pub sigma_att_deg: [f64; 3],
    /// Gyro bias estimate, body axes (rad/s).
    pub gyro_bias_rps: [f64; 3],
    /// Accelerometer bias estimate, body axes (m/s²).
    pub accel_bias_mps2: [f64; 3],
    pub grid_heading_deg: f64,
    /// `msgs::solution_flags` bit set.
    pub flags: u32,
    pub srs_fresh: bool,
    pub cns_fresh: bool,
    pub baro_fresh: bool,
    pub imu_lost: bool,
    pub coasting: bool,
    pub switch_count: u32,
    pub reset_count: u32,
    /// 1-σ of the gyro bias estimate, body axes (rad/s); `None` in a file
    /// written before the bias σ columns, or for a solution that did not
    /// know it (all NaN: decoded from an older MCAP).
    pub sigma_gyro_bias_rps: Option<[f64; 3]>,
    /// 1-σ of the accelerometer bias estimate, body axes (m/s²); `None` as
    /// for `sigma_gyro_bias_rps`.
    pub sigma_accel_bias_mps2: Option<[f64; 3]>,
}

/// `None` for a value the producer did not know (all NaN).
fn known(v: [f64; 3]) -> Option<[f64; 3]> {
    (!v.iter().all(|x| x.is_nan())).then_some(v)
}

impl Row {
    /// The row [`write_row`] writes for `s`, as [`parse`] reads it back
    /// (the same f64 values: the CSV numbers round-trip exactly), without
    /// the text in between.
    pub fn from_solution(s: &Solution) -> Self {
        let bit = |b: u32| s.flags & b != 0;
        Self {
            t_s: s.t_ns as f64 * 1e-9,
            frame: WireFrame::from_u8(s.frame).map_or('?', WireFrame::letter),
            lat_deg: s.lat_rad.to_degrees(),
            lon_deg: s.lon_rad.to_degrees(),
            h_m: s.h_m,
            r_e_m: s.r_e_m,
            v_e_mps: s.v_e_mps,
            v_enu_mps: s.v_enu_mps,
            q_b_e: s.q_b_e,
            heading_deg: s.heading_rad.to_degrees(),
            pitch_deg: s.pitch_rad.to_degrees(),
            roll_deg: s.roll_rad.to_degrees(),
            sigma_enu_m: s.sigma_pos_enu_m,
            sigma_vel_nav_mps: s.sigma_vel_mps,
            sigma_att_deg: s.sigma_att_rad.map(f64::to_degrees),
            gyro_bias_rps: s.gyro_bias_rps,
            accel_bias_mps2: s.accel_bias_mps2,
            grid_heading_deg: s.grid_heading_rad.to_degrees(),
            flags: s.flags,
            srs_fresh: bit(solution_flags::SRS_FRESH),
            cns_fresh: bit(solution_flags::CNS_FRESH),
            baro_fresh: bit(solution_flags::BARO_FRESH),
            imu_lost: bit(solution_flags::IMU_LOST),
            coasting: bit(solution_flags::COASTING),
            switch_count: s.switch_count,
            reset_count: s.reset_count,
            sigma_gyro_bias_rps: known(s.sigma_gyro_bias_rps),
            sigma_accel_bias_mps2: known(s.sigma_accel_bias_mps2),
        }
    }
}

/// Errors of reading a solution CSV.
#[derive(Debug, thiserror::Error)]
pub enum ReadCsvError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    /// The file is a navlog (a flight's inputs), not a solution: compute
    /// the solution with `nav-daemon batch` first.
    #[error(
        "{path} is a navlog, not a solution CSV or MCAP: run `nav-daemon batch --log {path} --out run.csv` first"
    )]
    Navlog { path: String },
    /// The file is an MCAP file not named `*.mcap`, so it was taken for a CSV.
    #[error("{path} is an MCAP file, not a solution CSV: name it *.mcap")]
    Mcap { path: String },
    /// The file is not text (binary data at byte `at`): not a solution CSV.
    #[error(
        "{path} is not a solution CSV or MCAP: binary data at byte {at} (expected UTF-8 text starting with the header t_s,frame,...)"
    )]
    NotText { path: String, at: usize },
    #[error("{path}: empty file, expected the solution CSV header")]
    Header { path: String },
    /// No column of this name (nor its former name, for a renamed column).
    #[error(
        "{path}: header has no column {column:?}{}",
        former.map_or(String::new(), |f| format!(" (nor its former name {f:?})"))
    )]
    MissingColumn {
        path: String,
        column: &'static str,
        former: Option<&'static str>,
    },
    /// Some but not all columns of an optional group: a damaged or
    /// hand-edited header.
    #[error(
        "{path}: header has {present:?} but no column {column:?} (the group {group} goes together)"
    )]
    PartialGroup {
        path: String,
        present: &'static str,
        column: &'static str,
        group: &'static str,
    },
    #[error("{path}:{line}: {what}")]
    Row {
        path: String,
        line: usize,
        what: String,
    },
}

/// Reads a solution CSV written by [`write_row`].
pub fn read(path: &std::path::Path) -> Result<Vec<Row>, ReadCsvError> {
    let p = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| ReadCsvError::Io {
        path: p.clone(),
        source,
    })?;
    // The wrong file is named for what it is, not only as invalid UTF-8.
    if msgs::navlog::starts_as_navlog(&bytes) {
        return Err(ReadCsvError::Navlog { path: p });
    }
    if bytes.starts_with(b"\x89MCAP") {
        return Err(ReadCsvError::Mcap { path: p });
    }
    let text = String::from_utf8(bytes).map_err(|e| ReadCsvError::NotText {
        path: p.clone(),
        at: e.utf8_error().valid_up_to(),
    })?;
    parse(&text, &p)
}

/// Parses solution CSV text; `p` names its origin in errors. Columns are found
/// by header name: any order, unknown columns ignored; a missing column is an
/// error naming it. A renamed column is also found by its former name
/// ([`RENAMED`]; the new name first). A leading UTF-8 byte-order mark
/// (spreadsheets' "CSV UTF-8" writes one) is not part of the first column's
/// name.
pub fn parse(text: &str, p: &str) -> Result<Vec<Row>, ReadCsvError> {
    let p = p.to_owned();
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines();
    let Some(head) = lines.next() else {
        return Err(ReadCsvError::Header { path: p });
    };
    let names: Vec<&str> = head.split(',').map(str::trim).collect();
    // idx[k] = position in the file of column k of HEADER.
    let mut idx = [0usize; COLUMNS];
    for (k, want) in HEADER_REQUIRED.split(',').enumerate() {
        let former = former_name(want);
        idx[k] = names
            .iter()
            .position(|n| *n == want)
            .or_else(|| former.and_then(|f| names.iter().position(|n| *n == f)))
            .ok_or(ReadCsvError::MissingColumn {
                path: p.clone(),
                column: want,
                former,
            })?;
    }
    let bias_sigma: Vec<(&'static str, Option<usize>)> = HEADER_BIAS_SIGMA
        .split(',')
        .map(|want| (want, names.iter().position(|n| *n == want)))
        .collect();
    let has_bias_sigma = match (
        bias_sigma.iter().find(|(_, i)| i.is_some()),
        bias_sigma.iter().find(|(_, i)| i.is_none()),
    ) {
        (Some(&(present, _)), Some(&(column, _))) => {
            return Err(ReadCsvError::PartialGroup {
                path: p,
                present,
                column,
                group: HEADER_BIAS_SIGMA,
            });
        }
        (_, None) => {
            for (k, (_, i)) in bias_sigma.iter().enumerate() {
                idx[COLUMNS_REQUIRED + k] = i.unwrap_or_default();
            }
            true
        }
        (None, Some(_)) => false,
    };
    let width = names.len();
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        let line_no = i + 2;
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != width {
            return Err(ReadCsvError::Row {
                path: p,
                line: line_no,
                what: format!("{} columns, the header has {width}", f.len()),
            });
        }
        let col = |k: usize| f[idx[k]];
        let num = |k: usize| -> Result<f64, ReadCsvError> {
            col(k).parse().map_err(|_| ReadCsvError::Row {
                path: p.clone(),
                line: line_no,
                what: format!("column {} is not a number: {:?}", names[idx[k]], col(k)),
            })
        };
        let int = |k: usize| -> Result<u32, ReadCsvError> {
            col(k).parse().map_err(|_| ReadCsvError::Row {
                path: p.clone(),
                line: line_no,
                what: format!(
                    "column {} is not an unsigned integer: {:?}",
                    names[idx[k]],
                    col(k)
                ),
            })
        };
        let mut v = [0.0f64; 37];
        for (k, slot) in v.iter_mut().enumerate() {
            if k != 1 {
                *slot = num(k)?;
            }
        }
        let mut u = [0u32; 8];
        for (j, slot) in u.iter_mut().enumerate() {
            *slot = int(37 + j)?;
        }
        let mut sig = [0.0f64; COLUMNS_BIAS_SIGMA];
        if has_bias_sigma {
            for (j, slot) in sig.iter_mut().enumerate() {
                *slot = num(COLUMNS_REQUIRED + j)?;
            }
        }
        rows.push(Row {
            t_s: v[0],
            frame: col(1).chars().next().unwrap_or('?'),
            lat_deg: v[2],
            lon_deg: v[3],
            h_m: v[4],
            r_e_m: [v[5], v[6], v[7]],
            v_e_mps: [v[8], v[9], v[10]],
            v_enu_mps: [v[11], v[12], v[13]],
            q_b_e: [v[14], v[15], v[16], v[17]],
            heading_deg: v[18],
            pitch_deg: v[19],
            roll_deg: v[20],
            sigma_enu_m: [v[21], v[22], v[23]],
            sigma_vel_nav_mps: [v[24], v[25], v[26]],
            sigma_att_deg: [v[27], v[28], v[29]],
            gyro_bias_rps: [v[30], v[31], v[32]],
            accel_bias_mps2: [v[33], v[34], v[35]],
            grid_heading_deg: v[36],
            flags: u[0],
            srs_fresh: u[1] != 0,
            cns_fresh: u[2] != 0,
            baro_fresh: u[3] != 0,
            imu_lost: u[4] != 0,
            coasting: u[5] != 0,
            switch_count: u[6],
            reset_count: u[7],
            sigma_gyro_bias_rps: has_bias_sigma
                .then_some([sig[0], sig[1], sig[2]])
                .and_then(known),
            sigma_accel_bias_mps2: has_bias_sigma
                .then_some([sig[3], sig[4], sig[5]])
                .and_then(known),
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Columns of a written row.
    fn written() -> usize {
        header().split(',').count()
    }

    #[test]
    fn row_has_every_header_column_and_reads_back() {
        let mut s = Solution {
            t_ns: 1_500_000_000,
            frame: 1,
            ..Default::default()
        };
        s.lat_rad = 1.2;
        s.r_e_m = [1.0, -2.0, 6.3e6];
        s.q_b_e = [1.0, 0.0, 0.0, 0.0];
        s.sigma_pos_enu_m = [f64::NAN; 3];
        let mut buf = Vec::new();
        write_row(&mut buf, &s).expect("write");
        let line = String::from_utf8(buf).expect("utf8");
        assert_eq!(line.trim().split(',').count(), header().split(',').count());
        let dir = std::env::temp_dir().join(format!("polarnav-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("s.csv");
        std::fs::write(&path, format!("{}\n{line}", header())).expect("write file");
        let rows = read(&path).expect("read");
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].frame, 'G');
        assert!((rows[0].t_s - 1.5).abs() < 1e-12);
        assert!((rows[0].lat_deg - 1.2f64.to_degrees()).abs() < 1e-9);
        assert!(rows[0].sigma_enu_m[0].is_nan());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_navlog_is_named_as_a_navlog_not_as_bad_utf8() {
        let mut log = Vec::new();
        let header = msgs::navlog::Header::new("test", "scenario", 1, "");
        let mut w = msgs::navlog::NavlogWriter::new(&mut log, header).expect("writer");
        w.write(&msgs::navlog::Record::Imu(Default::default()))
            .expect("record");
        w.finish().expect("finish");
        let dir = std::env::temp_dir().join(format!("polarnav-navlog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("flight.navlog");
        std::fs::write(&path, &log).expect("write");
        let e = read(&path).expect_err("a navlog is no solution");
        assert!(matches!(e, ReadCsvError::Navlog { .. }), "{e:?}");
        let m = e.to_string();
        assert!(m.contains("is a navlog"), "{m}");
        assert!(m.contains("nav-daemon batch --log"), "{m}");
        // Other binary data: named as not a solution CSV, with where.
        let bin = dir.join("x.csv");
        std::fs::write(&bin, b"t_s\n\xff\xfe").expect("write");
        let m = read(&bin).expect_err("binary").to_string();
        assert!(
            m.contains("not a solution CSV") && m.contains("byte 4"),
            "{m}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_byte_order_mark_reads_like_none() {
        let mut s = Solution {
            t_ns: 2_000_000_000,
            ..Default::default()
        };
        s.lat_rad = 1.4;
        let mut buf = Vec::new();
        write_row(&mut buf, &s).expect("write");
        let plain = format!("{}\n{}", header(), String::from_utf8(buf).expect("utf8"));
        let dir = std::env::temp_dir().join(format!("polarnav-bom-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let (with, without) = (dir.join("bom.csv"), dir.join("plain.csv"));
        std::fs::write(&with, format!("\u{feff}{plain}")).expect("write bom");
        std::fs::write(&without, &plain).expect("write plain");
        let a = read(&with).expect("a BOM is accepted");
        let b = read(&without).expect("plain");
        assert_eq!(a, b);
        assert_eq!(a.len(), 1);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn numbers_read_back_bit_for_bit() {
        let mut s = Solution {
            t_ns: 123_456_789_012,
            frame: 0,
            ..Default::default()
        };
        s.lat_rad = 1.234_567_890_123_456_7;
        s.lon_rad = -std::f64::consts::PI;
        s.h_m = 18_000.000_000_123;
        s.r_e_m = [6_378_137.123_456_789, -1.0e-300, 5.0e-324];
        s.v_e_mps = [250.1, f64::MIN_POSITIVE, -0.0];
        s.q_b_e = [
            std::f64::consts::FRAC_1_SQRT_2,
            0.0,
            -std::f64::consts::FRAC_1_SQRT_2,
            1e-17,
        ];
        s.heading_rad = std::f64::consts::TAU - 1e-12;
        s.sigma_pos_enu_m = [3.0, 4.5e-3, 1e10];
        let mut buf = Vec::new();
        write_row(&mut buf, &s).expect("write");
        let line = String::from_utf8(buf).expect("utf8");
        let f: Vec<f64> = line
            .trim()
            .split(',')
            .enumerate()
            .filter(|(i, _)| *i != 1)
            .map(|(_, x)| x.parse().expect("number"))
            .collect();
        let expect = [
            s.t_ns as f64 * 1e-9,
            s.lat_rad.to_degrees(),
            s.lon_rad.to_degrees(),
            s.h_m,
            s.r_e_m[0],
            s.r_e_m[1],
            s.r_e_m[2],
            s.v_e_mps[0],
            s.v_e_mps[1],
            s.v_e_mps[2],
        ];
        for (i, (a, b)) in f.iter().zip(expect).enumerate() {
            assert_eq!(a.to_bits(), b.to_bits(), "column {i}: {a} vs {b}");
        }
        let q = &f[13..17];
        for (a, b) in q.iter().zip(s.q_b_e) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    fn sample() -> Solution {
        let mut s = Solution {
            t_ns: 2_250_000_000,
            frame: 1,
            ..Default::default()
        };
        s.lat_rad = 1.5;
        s.sigma_vel_mps = [0.1, 0.2, 0.3];
        s.sigma_att_rad = [1e-3, 2e-3, 3e-2];
        s.gyro_bias_rps = [1e-6, -2e-6, 3.5e-7];
        s.accel_bias_mps2 = [1e-3, -4e-4, 2e-2];
        s.grid_heading_rad = 0.5;
        s.flags = solution_flags::SRS_FRESH | solution_flags::BARO_FRESH | solution_flags::COASTING;
        s.switch_count = 3;
        s.reset_count = 12;
        s.sigma_gyro_bias_rps = [4.8e-8, 5e-8, 1.25e-7];
        s.sigma_accel_bias_mps2 = [9.8e-4, 1e-3, 2.5e-3];
        s
    }

    fn csv_of(s: &Solution) -> String {
        let mut buf = Vec::new();
        write_row(&mut buf, s).expect("write");
        format!("{}\n{}", header(), String::from_utf8(buf).expect("utf8"))
    }

    #[test]
    fn the_aid_group_names_each_aid_that_has_no_column_and_reads_its_flag_bit() {
        // Written out here, independently of the derivation: the aids after
        // the first three have no freshness column among the required ones,
        // the freshness columns come before the exclusion ones, and GNSS
        // alone is not autonomous.
        let names: Vec<&str> = aid_columns().iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "star_fresh",
                "gnss_fresh",
                "baseline_fresh",
                "mag_fresh",
                "gnss_excluded",
                "gnss_untested"
            ]
        );
        let bits: Vec<u32> = aid_columns().iter().map(|&(_, b)| b).collect();
        assert_eq!(
            bits,
            [
                solution_flags::STAR_FRESH,
                solution_flags::GNSS_FRESH,
                solution_flags::BASELINE_FRESH,
                solution_flags::MAG_FRESH,
                solution_flags::GNSS_EXCLUDED,
                solution_flags::GNSS_UNTESTED
            ]
        );
        let head: Vec<&str> = header().split(',').collect();
        for (flags, want) in [
            (0, ["0", "0", "0", "0"]),
            (
                solution_flags::STAR_FRESH | solution_flags::SRS_FRESH,
                ["1", "0", "0", "0"],
            ),
            (solution_flags::GNSS_FRESH, ["0", "1", "0", "0"]),
            (
                solution_flags::GNSS_EXCLUDED | solution_flags::STAR_FRESH,
                ["1", "0", "0", "1"],
            ),
            (
                solution_flags::BASELINE_FRESH | solution_flags::GNSS_FRESH,
                ["0", "1", "1", "0"],
            ),
            (
                solution_flags::GNSS_UNTESTED | solution_flags::GNSS_FRESH,
                ["0", "1", "0", "0"],
            ),
        ] {
            let s = Solution { flags, ..sample() };
            let untested = if flags & solution_flags::GNSS_UNTESTED != 0 {
                "1"
            } else {
                "0"
            };
            let want = [want[0], want[1], want[2], "0", want[3], untested];
            let text = csv_of(&s);
            let row: Vec<&str> = text.lines().nth(1).expect("row").split(',').collect();
            assert_eq!(row.len(), head.len());
            for (name, w) in [
                "star_fresh",
                "gnss_fresh",
                "baseline_fresh",
                "mag_fresh",
                "gnss_excluded",
                "gnss_untested",
            ]
            .iter()
            .zip(want)
            {
                let k = head.iter().position(|h| h == name).expect("column");
                assert_eq!(row[k], w, "{name} of flags {flags:#x}");
            }
            // The group repeats bits of flags: the row reads back the same.
            assert_eq!(
                parse(&text, "f.csv").expect("parse")[0],
                Row::from_solution(&s)
            );
        }
    }

    #[test]
    fn header_has_the_declared_columns_and_keeps_the_original_24_first() {
        assert_eq!(header().split(',').count(), COLUMNS + aid_columns().len());
        assert!(HEADER.starts_with(&format!("{HEADER_BASE},")));
        assert_eq!(HEADER_BASE.split(',').count(), 24);
    }

    #[test]
    // Exact equality is the contract: the numbers round-trip bit for bit.
    #[allow(clippy::float_cmp)]
    fn new_columns_round_trip_to_the_solution_values() {
        let s = sample();
        let text = csv_of(&s);
        // Independent of the reader: split the written line by hand.
        let line = text.lines().nth(1).expect("row");
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), written());
        let num = |k: usize| f[k].parse::<f64>().expect("number");
        assert_eq!(num(24), 0.1);
        assert_eq!(num(26), 0.3);
        assert_eq!(num(29), 3e-2f64.to_degrees());
        assert_eq!(num(30), 1e-6);
        assert_eq!(num(35), 2e-2);
        assert_eq!(num(36), 0.5f64.to_degrees());
        assert_eq!(&f[37..45], ["74", "1", "0", "1", "0", "1", "3", "12"]);
        // And the reader gives the Solution's fields converted by hand.
        let rows = parse(&text, "t.csv").expect("rows");
        let r = rows[0];
        assert_eq!(r.sigma_vel_nav_mps, [0.1, 0.2, 0.3]);
        assert_eq!(
            r.sigma_att_deg,
            [
                1e-3f64.to_degrees(),
                2e-3f64.to_degrees(),
                3e-2f64.to_degrees()
            ]
        );
        assert_eq!(r.gyro_bias_rps, [1e-6, -2e-6, 3.5e-7]);
        assert_eq!(r.accel_bias_mps2, [1e-3, -4e-4, 2e-2]);
        assert_eq!(r.grid_heading_deg, 0.5f64.to_degrees());
        assert_eq!(r.flags, 2 | 8 | 64);
        assert!(r.srs_fresh && !r.cns_fresh && r.baro_fresh && !r.imu_lost && r.coasting);
        assert_eq!((r.switch_count, r.reset_count), (3, 12));
        assert_eq!(r, Row::from_solution(&s));
    }

    #[test]
    // Exact equality is the contract: the numbers round-trip bit for bit.
    #[allow(clippy::float_cmp)]
    fn bias_sigma_columns_follow_reset_count_and_round_trip() {
        let names: Vec<&str> = HEADER.split(',').collect();
        assert_eq!(
            &names[44..],
            [
                "reset_count",
                "sig_bg_x_rps",
                "sig_bg_y_rps",
                "sig_bg_z_rps",
                "sig_ba_x_mps2",
                "sig_ba_y_mps2",
                "sig_ba_z_mps2"
            ]
        );
        assert_eq!(HEADER, format!("{HEADER_REQUIRED},{HEADER_BIAS_SIGMA}"));
        assert_eq!(
            header(),
            format!(
                "{HEADER},{}",
                aid_columns()
                    .iter()
                    .map(|(n, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(",")
            )
        );
        let mut s = sample();
        let text = csv_of(&s);
        // By hand, independent of the reader.
        let line = text.lines().nth(1).expect("row");
        let f: Vec<f64> = line
            .split(',')
            .skip(45)
            .take(COLUMNS_BIAS_SIGMA)
            .map(|x| x.parse().expect("number"))
            .collect();
        assert_eq!(f, [4.8e-8, 5e-8, 1.25e-7, 9.8e-4, 1e-3, 2.5e-3]);
        let r = parse(&text, "t.csv").expect("rows")[0];
        assert_eq!(r.sigma_gyro_bias_rps, Some(s.sigma_gyro_bias_rps));
        assert_eq!(r.sigma_accel_bias_mps2, Some(s.sigma_accel_bias_mps2));
        // The writer's per-column cache: a second row with other σ writes them.
        let mut w = RowWriter::new();
        w.row(&s);
        s.sigma_accel_bias_mps2[2] = 7.5e-4;
        let second: Vec<f64> = w
            .row(&s)
            .trim_end()
            .split(',')
            .skip(48)
            .take(3)
            .map(|x| x.parse().expect("number"))
            .collect();
        assert_eq!(second, [9.8e-4, 1e-3, 7.5e-4]);
    }

    /// A CSV written before the bias σ columns (45 columns, up to
    /// `reset_count`) reads with every other value and the bias σ unknown.
    #[test]
    fn a_csv_without_the_bias_sigma_columns_still_reads() {
        let s = sample();
        let text = csv_of(&s);
        let old: String = text
            .lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                format!("{}\n", f[..COLUMNS_REQUIRED].join(","))
            })
            .collect();
        assert!(old.starts_with(&format!("{HEADER_REQUIRED}\n")));
        let r = parse(&old, "old.csv").expect("an older CSV reads")[0];
        assert_eq!(
            (r.sigma_gyro_bias_rps, r.sigma_accel_bias_mps2),
            (None, None)
        );
        assert_eq!(
            Row {
                sigma_gyro_bias_rps: None,
                sigma_accel_bias_mps2: None,
                ..Row::from_solution(&s)
            },
            r
        );
        // Part of the group is a damaged header, named.
        let order: Vec<usize> = (0..written()).filter(|&i| i != 47).collect();
        let e = parse(&permute(&text, &order, None), "cut.csv").expect_err("partial group");
        let m = e.to_string();
        assert!(
            m.starts_with("cut.csv: header has \"sig_bg_x_rps\" but no column \"sig_bg_z_rps\""),
            "{m}"
        );
        // A bias σ that is not a number is named like any column.
        let bad: String = text
            .lines()
            .enumerate()
            .map(|(i, l)| {
                let mut f: Vec<&str> = l.split(',').collect();
                if i == 1 {
                    f[48] = "n/a";
                }
                format!("{}\n", f.join(","))
            })
            .collect();
        let m = parse(&bad, "bad.csv")
            .expect_err("not a number")
            .to_string();
        assert!(m.contains("column sig_ba_x_mps2 is not a number"), "{m}");
    }

    /// Rewrites `text` with its columns in the order `order` (indices into the
    /// written columns), `extra` appended as an unknown column.
    fn permute(text: &str, order: &[usize], extra: Option<&str>) -> String {
        let mut out = String::new();
        for (i, line) in text.lines().enumerate() {
            let f: Vec<&str> = line.split(',').collect();
            let mut g: Vec<&str> = order.iter().map(|&k| f[k]).collect();
            if let Some(e) = extra {
                g.insert(3, if i == 0 { e } else { "not-a-number" });
            }
            out.push_str(&g.join(","));
            out.push('\n');
        }
        out
    }

    #[test]
    fn reordered_and_extra_columns_read_the_same_rows() {
        let s = sample();
        let text = csv_of(&s);
        let want = parse(&text, "a").expect("rows");
        let reversed: Vec<usize> = (0..written()).rev().collect();
        let got = parse(&permute(&text, &reversed, None), "b").expect("reordered");
        assert_eq!(got, want);
        let ident: Vec<usize> = (0..written()).collect();
        let got = parse(&permute(&text, &ident, Some("operator_note")), "c").expect("extra");
        assert_eq!(got, want);
    }

    #[test]
    fn a_missing_column_is_named_with_the_file() {
        let text = csv_of(&sample());
        for drop in ["sig_u_m", "baro_fresh", "t_s", "reset_count"] {
            let k = header().split(',').position(|n| n == drop).expect("known");
            let order: Vec<usize> = (0..written()).filter(|&i| i != k).collect();
            let err = parse(&permute(&text, &order, None), "flight.csv").expect_err("missing");
            assert_eq!(
                err.to_string(),
                format!("flight.csv: header has no column \"{drop}\"")
            );
        }
    }

    /// `sample()` with velocities of its own in every column.
    fn moving() -> Solution {
        let mut s = sample();
        s.v_e_mps = [-123.456_789_012_345_6, 250.000_000_000_1, -0.0];
        s.v_enu_mps = [1e-17, -271.828_182_845_904_5, 3.5];
        s
    }

    /// `text` with each header name `from` replaced by `to` (the rows kept).
    fn rename_columns(text: &str, pairs: &[(&str, &str)]) -> String {
        let (head, rows) = text.split_once('\n').expect("header line");
        let head: Vec<&str> = head
            .split(',')
            .map(|n| pairs.iter().find(|(a, _)| *a == n).map_or(n, |&(_, b)| b))
            .collect();
        format!("{}\n{rows}", head.join(","))
    }

    #[test]
    fn velocity_columns_are_written_with_their_unit() {
        let names: Vec<&str> = header().split(',').collect();
        assert_eq!(
            &names[8..14],
            ["vx_mps", "vy_mps", "vz_mps", "ve_mps", "vn_mps", "vu_mps"]
        );
        for (new, old) in RENAMED {
            assert!(names.contains(&new), "{new}");
            assert!(!names.contains(&old), "{old} is still written");
            assert_eq!(former_name(new), Some(old));
        }
        assert_eq!(former_name("h_m"), None);
        // What the writer's users put first in a file is this header.
        assert!(csv_of(&moving()).starts_with(&format!("{}\n", header())));
        // The values under the new names are the velocities, as written.
        let text = csv_of(&moving());
        let f: Vec<&str> = text.lines().nth(1).expect("row").split(',').collect();
        let s = moving();
        for (k, want) in s.v_e_mps.iter().chain(&s.v_enu_mps).enumerate() {
            let got: f64 = f[8 + k].parse().expect("number");
            assert_eq!(got.to_bits(), want.to_bits(), "{}", names[8 + k]);
        }
    }

    /// A file written before the rename (`vx,vy,vz,ve,vn,vu`) reads to the
    /// same rows as today's, in any column order.
    #[test]
    fn a_csv_with_the_former_velocity_names_reads_the_same_values() {
        let s = moving();
        let text = csv_of(&s);
        let old = rename_columns(&text, &RENAMED);
        assert!(old.starts_with("t_s,frame,lat_deg,lon_deg,h_m,x_m,y_m,z_m,vx,vy,vz,ve,vn,vu,qw"));
        let want = parse(&text, "new.csv").expect("new names");
        let got = parse(&old, "old.csv").expect("the former names read");
        // Debug prints each f64 in its shortest round-trip form: equal text
        // is equal bits (and -0.0 differs from 0.0).
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
        assert_eq!(
            format!("{:?}", got[0]),
            format!("{:?}", Row::from_solution(&s))
        );
        let reversed: Vec<usize> = (0..written()).rev().collect();
        let got = parse(&permute(&old, &reversed, None), "old-reversed.csv").expect("reordered");
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
        // One file may mix the names (a hand-edited header).
        let mixed = rename_columns(&text, &RENAMED[..3]);
        let got = parse(&mixed, "mixed.csv").expect("mixed names");
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
    }

    /// A header with both names of a column reads the new one: the former
    /// name is then an unknown column, as it will be once it is no longer
    /// read at all.
    #[test]
    fn with_both_names_the_new_column_is_read() {
        let s = moving();
        let text = csv_of(&s);
        let (head, row) = text.trim_end().split_once('\n').expect("two lines");
        let olds: Vec<&str> = RENAMED.iter().map(|&(_, old)| old).collect();
        let both = format!("{head},{}\n{row},1,2,3,4,5,6\n", olds.join(","));
        let r = parse(&both, "both.csv").expect("both names")[0];
        assert_eq!(r.v_e_mps.map(f64::to_bits), s.v_e_mps.map(f64::to_bits));
        assert_eq!(r.v_enu_mps.map(f64::to_bits), s.v_enu_mps.map(f64::to_bits));
        // And in the other order of the file's columns.
        let first = format!("{},{head}\n1,2,3,4,5,6,{row}\n", olds.join(","));
        let r = parse(&first, "first.csv").expect("both names")[0];
        assert_eq!(r.v_e_mps.map(f64::to_bits), s.v_e_mps.map(f64::to_bits));
        assert_eq!(r.v_enu_mps.map(f64::to_bits), s.v_enu_mps.map(f64::to_bits));
    }

    #[test]
    fn a_missing_velocity_column_is_named_with_its_former_name() {
        let text = csv_of(&sample());
        let k = HEADER
            .split(',')
            .position(|n| n == "vn_mps")
            .expect("known");
        let order: Vec<usize> = (0..written()).filter(|&i| i != k).collect();
        let err = parse(&permute(&text, &order, None), "flight.csv").expect_err("missing");
        assert_eq!(
            err.to_string(),
            "flight.csv: header has no column \"vn_mps\" (nor its former name \"vn\")"
        );
        // A value that is not a number is named as the file names its column.
        let old = rename_columns(&text, &RENAMED);
        let bad: String = old
            .lines()
            .enumerate()
            .map(|(i, l)| {
                let mut f: Vec<&str> = l.split(',').collect();
                if i == 1 {
                    f[9] = "fast";
                }
                format!("{}\n", f.join(","))
            })
            .collect();
        let m = parse(&bad, "old.csv")
            .expect_err("not a number")
            .to_string();
        assert_eq!(m, "old.csv:2: column vy is not a number: \"fast\"");
    }

    mod round_trip {
        use super::*;
        use proptest::prelude::*;

        /// Any f64 bit pattern: subnormals, ±0, ±∞ and NaN included.
        fn any_f64() -> impl Strategy<Value = f64> {
            prop_oneof![
                8 => any::<u64>().prop_map(f64::from_bits),
                1 => prop::sample::select(vec![
                    0.0,
                    -0.0,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NAN,
                    f64::MIN_POSITIVE,
                    5e-324,
                    f64::MAX,
                ]),
            ]
        }

        fn arr<const N: usize>() -> impl Strategy<Value = [f64; N]> {
            prop::array::uniform(any_f64())
        }

        prop_compose! {
            fn any_solution()(
                t_ns in any::<u64>(),
                frame in 0u8..3,
                g in arr::<7>(),
                r in arr::<3>(),
                v in arr::<3>(),
                venu in arr::<3>(),
                q in arr::<4>(),
                sp in arr::<3>(),
                sv in arr::<3>(),
                sa in arr::<3>(),
                bg in arr::<3>(),
                ba in arr::<3>(),
                sbg in arr::<3>(),
                sba in arr::<3>(),
                flags in any::<u32>(),
                counts in any::<(u32, u32)>(),
            ) -> Solution {
                Solution {
                    t_ns,
                    frame,
                    lat_rad: g[0],
                    lon_rad: g[1],
                    h_m: g[2],
                    heading_rad: g[3],
                    grid_heading_rad: g[4],
                    pitch_rad: g[5],
                    roll_rad: g[6],
                    r_e_m: r,
                    v_e_mps: v,
                    v_enu_mps: venu,
                    q_b_e: q,
                    sigma_pos_enu_m: sp,
                    sigma_vel_mps: sv,
                    sigma_att_rad: sa,
                    gyro_bias_rps: bg,
                    accel_bias_mps2: ba,
                    sigma_gyro_bias_rps: sbg,
                    sigma_accel_bias_mps2: sba,
                    flags,
                    switch_count: counts.0,
                    reset_count: counts.1,
                    ..Default::default()
                }
            }
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(512))]

            /// Write then parse gives every column's f64 bit for bit (NaN
            /// as NaN: the text has no payload), under the new names and
            /// the former ones alike, through one writer for many rows
            /// (its per-column cache) as through a fresh one.
            #[test]
            fn write_then_parse_is_bit_identical(ss in prop::collection::vec(any_solution(), 1..6)) {
                let mut w = RowWriter::new();
                let mut text = format!("{}\n", header());
                for s in &ss {
                    text.push_str(w.row(s));
                }
                let want: Vec<Row> = ss.iter().map(Row::from_solution).collect();
                // Debug prints an f64 in its shortest round-trip form: equal
                // text is equal bits, except that every NaN prints "NaN".
                let want = format!("{want:?}");
                let rows = parse(&text, "p.csv").expect("parse");
                prop_assert_eq!(format!("{rows:?}"), want.clone());
                let old = rename_columns(&text, &RENAMED);
                let rows = parse(&old, "p-old.csv").expect("parse former names");
                prop_assert_eq!(format!("{rows:?}"), want);
            }
        }
    }
}
