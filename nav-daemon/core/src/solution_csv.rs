//! Solution CSV, columns exactly as DESIGN "Command-line contract".

use std::io::Write;

use msgs::{Solution, WireFrame};

/// The header line.
pub const HEADER: &str = "t_s,frame,lat_deg,lon_deg,h_m,x_m,y_m,z_m,vx,vy,vz,ve,vn,vu,qw,qx,qy,qz,heading_deg,pitch_deg,roll_deg,sig_e_m,sig_n_m,sig_u_m";

/// Writes one row. Numbers are written in their shortest round-trip form
/// (zmij, Schubfach-based), so a row reads back to the same f64 values bit for bit. The row
/// is assembled in a stack buffer and written once; no allocation.
pub fn write_row<W: Write>(out: &mut W, s: &Solution) -> std::io::Result<()> {
    // 24 columns of at most 24 bytes each, plus separators.
    let mut line = [0u8; 640];
    let mut n = 0;
    let mut buf = zmij::Buffer::new();
    let mut push = |bytes: &[u8], n: &mut usize| {
        line[*n..*n + bytes.len()].copy_from_slice(bytes);
        *n += bytes.len();
    };
    push(buf.format(s.t_ns as f64 * 1e-9).as_bytes(), &mut n);
    let frame = WireFrame::from_u8(s.frame).map_or(b'?', |f| f.letter() as u8);
    push(&[b',', frame], &mut n);
    let [x, y, z] = s.r_e_m;
    let [vx, vy, vz] = s.v_e_mps;
    let [ve, vn, vu] = s.v_enu_mps;
    let [qw, qx, qy, qz] = s.q_b_e;
    let [se, sn, su] = s.sigma_pos_enu_m;
    for v in [
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
    ] {
        push(b",", &mut n);
        push(buf.format(v).as_bytes(), &mut n);
    }
    push(b"\n", &mut n);
    out.write_all(&line[..n])
}

/// One parsed row (the columns the evaluator needs).
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
}

impl Row {
    /// The row [`write_row`] writes for `s`, as [`parse`] reads it back
    /// (the same f64 values: the CSV numbers round-trip exactly), without
    /// the text in between.
    pub fn from_solution(s: &Solution) -> Self {
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
    #[error("{path}: header is not the solution CSV header")]
    Header { path: String },
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
    let text = std::fs::read_to_string(path).map_err(|source| ReadCsvError::Io {
        path: p.clone(),
        source,
    })?;
    parse(&text, &p)
}

/// Parses solution CSV text; `p` names its origin in errors.
pub fn parse(text: &str, p: &str) -> Result<Vec<Row>, ReadCsvError> {
    let p = p.to_owned();
    let mut lines = text.lines();
    if lines.next().map(str::trim) != Some(HEADER) {
        return Err(ReadCsvError::Header { path: p });
    }
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 24 {
            return Err(ReadCsvError::Row {
                path: p,
                line: i + 2,
                what: format!("{} columns, expected 24", f.len()),
            });
        }
        let mut v = [0.0f64; 24];
        for (k, s) in f.iter().enumerate() {
            if k == 1 {
                continue;
            }
            v[k] = s.trim().parse().map_err(|_| ReadCsvError::Row {
                path: p.clone(),
                line: i + 2,
                what: format!("column {} is not a number: {s:?}", k + 1),
            })?;
        }
        rows.push(Row {
            t_s: v[0],
            frame: f[1].chars().next().unwrap_or('?'),
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
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(line.trim().split(',').count(), HEADER.split(',').count());
        let dir = std::env::temp_dir().join(format!("polarnav-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("s.csv");
        std::fs::write(&path, format!("{HEADER}\n{line}")).expect("write file");
        let rows = read(&path).expect("read");
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].frame, 'G');
        assert!((rows[0].t_s - 1.5).abs() < 1e-12);
        assert!((rows[0].lat_deg - 1.2f64.to_degrees()).abs() < 1e-9);
        assert!(rows[0].sigma_enu_m[0].is_nan());
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
}
