//! The importers keep the contract (DESIGN, "Command-line contract"): a bad
//! line — not UTF-8, not numeric, not finite, an impossible position, time
//! or interval — is skipped and named with its true line number, every good
//! line is imported, one absurd line costs only itself, and only a file that
//! is not of the format fails. Memory stays bounded whatever a header or a
//! line says.

use std::io::Write;
use std::path::{Path, PathBuf};

use msgs::navlog::{Record, read_all};
use polarnav::navigator::IMU_DT_RANGE_S;
use proptest::prelude::*;
use sensor_replay::interop::{self, AidSynthesis, ImportError, ImportSummary, Skipped};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("polarnav-imp-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Start of the good IMU and truth time lines (s) and the IMU interval.
const T0: f64 = 1000.0;
const DT: f64 = 0.005;

/// A good KF-GINS IMU line at sample `k` (time T0 + k·DT).
fn imu_line(k: usize) -> String {
    format!(
        "{:.3} 1e-6 -2e-6 3e-6 0.01 -0.02 0.049\n",
        T0 + k as f64 * DT
    )
}

/// A good KF-GINS truth line at epoch `k` (time T0 + k·0.1 s).
fn truth_line(k: usize) -> String {
    format!(
        "2200 {:.1} 45.0 10.0 100.0 0 0 0 0.1 0.2 30.0\n",
        T0 + k as f64 * 0.1
    )
}

struct Imported {
    sum: ImportSummary,
    imu: Vec<msgs::ImuSample>,
    truth: Vec<msgs::TruthRecord>,
}

fn import_kfgins(dir: &Path, imu: &[u8], truth: &[u8]) -> Result<Imported, ImportError> {
    let (imu_path, truth_path) = (dir.join("imu.txt"), dir.join("truth.nav"));
    std::fs::write(&imu_path, imu).expect("write imu");
    std::fs::write(&truth_path, truth).expect("write truth");
    let mut buf = Vec::new();
    let sum = interop::import_kfgins(&imu_path, &truth_path, &AidSynthesis::default(), &mut buf)?;
    let (records, report) = read_all(&buf);
    assert!(report.is_clean(), "{report:?}");
    let mut out = Imported {
        sum,
        imu: Vec::new(),
        truth: Vec::new(),
    };
    for r in records {
        match r {
            Record::Imu(s) => out.imu.push(s),
            Record::Truth(t) => out.truth.push(t),
            _ => {}
        }
    }
    Ok(out)
}

/// The (file name, line) pairs of the skipped lines, file name only.
fn named(s: &Skipped) -> Vec<(String, usize)> {
    s.lines
        .iter()
        .map(|(f, l, _)| {
            let name = Path::new(f).file_name().expect("name").to_string_lossy();
            (name.into_owned(), *l)
        })
        .collect()
}

fn good_truth(n: usize) -> Vec<u8> {
    (0..n).map(truth_line).collect::<String>().into_bytes()
}

fn good_imu(n: usize) -> Vec<String> {
    (0..n).map(imu_line).collect()
}

#[test]
fn a_non_utf8_line_costs_only_itself_in_either_file() {
    let dir = temp_dir("utf8");
    let mut imu: Vec<u8> = Vec::new();
    for (i, l) in good_imu(41).iter().enumerate() {
        if i == 10 {
            imu.extend_from_slice(b"1000.050 1e-6 \xff\xfe 0 0 0 0.049\n");
        } else {
            imu.extend_from_slice(l.as_bytes());
        }
    }
    let mut truth = good_truth(3);
    truth.extend_from_slice(b"2200 1000.3 45.0 \xc3\x28 100 0 0 0 0 0 0\n");
    truth.extend_from_slice(truth_line(4).as_bytes());
    let got = import_kfgins(&dir, &imu, &truth).expect("import");
    assert_eq!(
        named(&got.sum.skipped),
        [("truth.nav".to_owned(), 4), ("imu.txt".to_owned(), 11)],
        "{:?}",
        got.sum.skipped
    );
    assert!(got.sum.skipped.lines[0].2.contains("not UTF-8"));
    // 41 lines: the time base, 39 samples, the bad one.
    assert_eq!(got.imu.len(), 39);
    assert_eq!(got.truth.len(), 4);
    // The sample after the lost line keeps its own 5 ms interval: the
    // navigator bridges the lost one.
    let after = got
        .imu
        .iter()
        .find(|s| s.t_ns == 55_000_000)
        .expect("sample at 55 ms");
    assert!((after.dt_s - DT).abs() < 1e-9, "{}", after.dt_s);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_repeated_truth_time_is_named_at_its_own_line() {
    let dir = temp_dir("repeat");
    // 50 comment lines, then truth epochs; line 52 repeats line 51's time.
    let mut truth = String::new();
    for i in 0..50 {
        truth += &format!("# comment {i}\n");
    }
    truth += &truth_line(0);
    truth += &truth_line(0);
    truth += &truth_line(1);
    let got =
        import_kfgins(&dir, good_imu(30).concat().as_bytes(), truth.as_bytes()).expect("import");
    assert_eq!(named(&got.sum.skipped), [("truth.nav".to_owned(), 52)]);
    assert_eq!(got.truth.len(), 2);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn impossible_truth_positions_and_angles_are_skipped_not_wrapped() {
    let dir = temp_dir("latitude");
    let mut truth = good_truth(2);
    for bad in [
        "2200 1000.2 200.0 10.0 100.0 0 0 0 0 0 0\n", // line 3: latitude
        "2200 1000.3 45.0 1000.0 100.0 0 0 0 0 0 0\n", // line 4: longitude
        "2200 1000.4 45.0 10.0 1e9 0 0 0 0 0 0\n",    // line 5: height
        "2200 1000.5 45.0 10.0 100.0 0 0 0 0 0 1e6\n", // line 6: yaw
        "2200 1000.6 -90.5 10.0 100.0 0 0 0 0 0 0\n", // line 7: latitude
    ] {
        truth.extend_from_slice(bad.as_bytes());
    }
    truth.extend_from_slice(truth_line(7).as_bytes());
    let got = import_kfgins(&dir, good_imu(200).concat().as_bytes(), &truth).expect("import");
    let lines: Vec<usize> = got.sum.skipped.lines.iter().map(|l| l.1).collect();
    assert_eq!(lines, [3, 4, 5, 6, 7], "{:?}", got.sum.skipped);
    assert!(got.sum.skipped.lines[0].2.contains("latitude 200"));
    assert_eq!(got.truth.len(), 3);
    for t in &got.truth {
        let g = polarnav::earth::ecef_to_geodetic(&nalgebra::Vector3::from(t.r_e_m));
        assert!((g.lat_rad.to_degrees() - 45.0).abs() < 1e-9);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn one_absurd_stamp_costs_one_line_and_a_real_gap_is_kept() {
    let dir = temp_dir("stamps");
    let mut lines = good_imu(400);
    // Line 101: a stamp of 1e18 s; line 201: a stamp of 0; line 251: an
    // interval of 1e-10 s after line 250; line 301: a duplicate of line 300.
    lines[100] = "1e18 1e-6 0 0 0 0 0.049\n".into();
    lines[200] = "0 1e-6 0 0 0 0 0.049\n".into();
    lines[250] = format!("{} 1e-6 0 0 0 0 0.049\n", T0 + 249.0 * DT + 1e-10);
    lines[300] = lines[299].clone();
    // Then a real gap: from line 351 on, the data resume 1e6 s later.
    for (k, l) in lines.iter_mut().enumerate().skip(350) {
        *l = format!(
            "{:.3} 1e-6 -2e-6 3e-6 0.01 -0.02 0.049\n",
            T0 + 1e6 + k as f64 * DT
        );
    }
    let got = import_kfgins(&dir, lines.concat().as_bytes(), &good_truth(5)).expect("import");
    let skipped: Vec<usize> = got.sum.skipped.lines.iter().map(|l| l.1).collect();
    assert_eq!(skipped, [101, 201, 251, 301], "{:?}", got.sum.skipped);
    // Every other line: the time base, the samples, nothing unused besides the base.
    assert_eq!(got.sum.imu_unused, 1);
    assert_eq!(got.imu.len(), 400 - 1 - 4);
    // Time stamps increase; each interval is one the navigator accepts.
    for w in got.imu.windows(2) {
        assert!(w[1].t_ns > w[0].t_ns);
    }
    for s in &got.imu {
        assert!(
            (IMU_DT_RANGE_S.0..=IMU_DT_RANGE_S.1).contains(&s.dt_s),
            "{s:?}"
        );
    }
    // The line after the gap is imported with the interval of the lines before.
    let first_after = got
        .imu
        .iter()
        .find(|s| s.t_ns > 1_000_000_000_000)
        .expect("after the gap");
    assert_eq!(
        first_after.t_ns,
        ((1e6 + 350.0 * DT) * 1e9_f64).round() as u64
    );
    assert!((first_after.dt_s - DT).abs() < 1e-9);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_very_long_line_is_skipped_without_being_held() {
    let dir = temp_dir("longline");
    let mut imu = good_imu(20).concat().into_bytes();
    imu.extend(std::iter::repeat_n(b'7', 8 << 20));
    imu.push(b'\n');
    imu.extend_from_slice(good_imu(40)[20..].concat().as_bytes());
    let got = import_kfgins(&dir, &imu, &good_truth(2)).expect("import");
    assert_eq!(got.sum.skipped.lines.len(), 1);
    assert_eq!(got.sum.skipped.lines[0].1, 21);
    assert!(
        got.sum.skipped.lines[0].2.contains("8388608 bytes"),
        "{:?}",
        got.sum.skipped
    );
    // 40 good lines: the time base and 39 samples.
    assert_eq!(got.imu.len(), 39);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_flood_of_bad_lines_is_counted_and_the_first_thousand_named() {
    let dir = temp_dir("flood");
    let mut imu = good_imu(10).concat();
    for _ in 0..5000 {
        imu += "garbage\n";
    }
    imu += &good_imu(20)[10..].concat();
    let got = import_kfgins(&dir, imu.as_bytes(), &good_truth(1)).expect("import");
    assert_eq!(got.sum.skipped.count, 5000);
    assert_eq!(got.sum.skipped.lines.len(), Skipped::MAX_NAMED);
    assert_eq!(got.sum.skipped.lines[0].1, 11);
    assert_eq!(got.imu.len(), 19);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_file_not_of_the_format_fails_and_names_the_file() {
    let dir = temp_dir("notformat");
    let bin: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
        .collect();
    match import_kfgins(&dir, &bin, &good_truth(2)) {
        Err(ImportError::NotFormat { path, .. }) => assert!(path.ends_with("imu.txt")),
        other => panic!("expected NotFormat, got {:?}", other.map(|i| i.sum)),
    }
    match import_kfgins(&dir, good_imu(5).concat().as_bytes(), &bin) {
        Err(ImportError::NotFormat { path, .. }) => assert!(path.ends_with("truth.nav")),
        other => panic!("expected NotFormat, got {:?}", other.map(|i| i.sum)),
    }
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------- PSINS

/// A PSINS text IMU file with the given header lines 1–3 and data lines.
fn psins(dir: &Path, header: [&str; 3], data: &[&[u8]]) -> PathBuf {
    let path = dir.join("x.imu");
    let mut f = std::fs::File::create(&path).expect("create");
    f.write_all(b"% PSINS-format SIMU log file\n% comment\n\n")
        .expect("write");
    for h in header {
        writeln!(f, "{h}").expect("write");
    }
    for d in data {
        f.write_all(d).expect("write");
        f.write_all(b"\n").expect("write");
    }
    path
}

const PSINS_HEADER: [&str; 3] = [
    "0 0 -90.6 0 0 0",
    "34.246048 108.909664 380.0 0.0 10.0 9.780327",
    "0.1 0.1 0.1 125 125 125",
];

fn import_psins(path: &Path) -> Result<(ImportSummary, Vec<msgs::ImuSample>), ImportError> {
    let mut buf = Vec::new();
    let sum = interop::import_psins(path, &AidSynthesis::default(), &mut buf)?;
    let (records, report) = read_all(&buf);
    assert!(report.is_clean());
    let imu = records
        .into_iter()
        .filter_map(|r| match r {
            Record::Imu(s) => Some(s),
            _ => None,
        })
        .collect();
    Ok((sum, imu))
}

#[test]
fn psins_bad_data_lines_are_skipped_with_their_line_numbers() {
    let dir = temp_dir("psins-lines");
    let good: &[u8] = b"-5 2 13 -48 127 7833";
    let path = psins(
        &dir,
        PSINS_HEADER,
        &[
            good,                       // line 7
            b"-5 2 \xff 48 127 7833",   // line 8: not UTF-8
            b"-5 2 x -48 127 7833",     // line 9: not numeric
            b"-5 2 inf -48 127 7833",   // line 10: not finite
            b"-5 2 1e400 -48 127 7833", // line 11: overflows
            b"-5 2 13",                 // line 12: too few fields
            good,                       // line 13
        ],
    );
    let (sum, imu) = import_psins(&path).expect("import");
    let lines: Vec<usize> = sum.skipped.lines.iter().map(|l| l.1).collect();
    assert_eq!(lines, [8, 9, 10, 11, 12], "{:?}", sum.skipped);
    assert_eq!(imu.len(), 2);
    // A finite count that a (legal, if odd) scale factor makes non-finite.
    let path = psins(
        &dir,
        [
            PSINS_HEADER[0],
            PSINS_HEADER[1],
            "1e300 0.1 0.1 125 125 125",
        ],
        &[good, b"1e300 2 13 -48 127 7833", good],
    );
    let (sum, imu) = import_psins(&path).expect("import");
    assert_eq!(sum.skipped.lines.len(), 1);
    assert_eq!(sum.skipped.lines[0].1, 8);
    assert!(sum.skipped.lines[0].2.contains("not finite once scaled"));
    assert_eq!(imu.len(), 2);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn psins_impossible_headers_fail_with_exit_2_kind_and_bounded_memory() {
    let dir = temp_dir("psins-header");
    let data: &[&[u8]] = &[b"-5 2 13 -48 127 7833"];
    for (header, line, what) in [
        (
            [
                PSINS_HEADER[0],
                "34.2 108.9 380.0 0.0 1e10 9.78",
                PSINS_HEADER[2],
            ],
            5,
            "sample interval 10000000000 ms",
        ),
        (
            [
                PSINS_HEADER[0],
                "34.2 108.9 380.0 0.0 1e-10 9.78",
                PSINS_HEADER[2],
            ],
            5,
            "sample interval",
        ),
        (
            [
                PSINS_HEADER[0],
                "1000 108.9 380.0 0.0 10 9.78",
                PSINS_HEADER[2],
            ],
            5,
            "latitude 1000",
        ),
        (
            [
                PSINS_HEADER[0],
                "34.2 108.9 380.0 0.0 10 1e300",
                PSINS_HEADER[2],
            ],
            5,
            "gravity",
        ),
        (
            ["0 0 -90.6 1e300 0 0", PSINS_HEADER[1], PSINS_HEADER[2]],
            4,
            "speed",
        ),
        (
            [PSINS_HEADER[0], PSINS_HEADER[1], "0.1 0.1 -0.1 125 125 125"],
            6,
            "scale factor 3",
        ),
    ] {
        let path = psins(&dir, header, data);
        match import_psins(&path) {
            Err(e @ ImportError::NotFormat { .. }) => {
                let m = e.to_string();
                assert!(m.contains(&format!("line {line}:")), "{m}");
                assert!(m.contains(what), "{m}");
            }
            other => panic!(
                "{header:?}: expected NotFormat, got {:?}",
                other.map(|o| o.0)
            ),
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

// ------------------------------------------------------- property tests

/// An absurd value drawn log-uniformly over 1e-10 .. 1e18, with either sign,
/// or a non-finite one, or zero.
fn absurd() -> impl Strategy<Value = String> {
    prop_oneof![
        (-10.0f64..18.0, any::<bool>()).prop_map(|(e, neg)| {
            let v = 10f64.powf(e);
            format!("{}", if neg { -v } else { v })
        }),
        Just("nan".to_owned()),
        Just("inf".to_owned()),
        Just("-inf".to_owned()),
        Just("0".to_owned()),
    ]
}

/// A bad IMU line.
fn bad_imu_line() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        // A stamp that is non-finite, zero, or log-uniform over 1e-10 ..
        // 1e18 s with either sign, moved out of the flight's own time line
        // (a stamp inside it would be a good line).
        absurd().prop_map(|t| {
            let t = match t.parse::<f64>() {
                Ok(v) if (T0 - 1.0..T0 + 1e4).contains(&v) => (v + 1e5).to_string(),
                _ => t,
            };
            format!("{t} 1e-6 0 0 0 0 0.049").into_bytes()
        }),
        // An absurd increment (non-finite ones are refused; finite ones the
        // session judges, so only non-finite ones are generated here).
        prop_oneof![Just("nan"), Just("inf"), Just("-inf")]
            .prop_map(|v| format!("1000.0 {v} 0 0 0 0 0.049").into_bytes()),
        // Not UTF-8, not numeric, too short, empty fields.
        Just(b"1000.0 \xff\xfe 0 0 0 0 0".to_vec()),
        Just(b"hello world".to_vec()),
        Just(b"1000.0 1 2".to_vec()),
        Just(b",,,,,,,".to_vec()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A good IMU time line with isolated bad lines inserted anywhere: every
    /// bad line is skipped and named at its own number, every good line but
    /// the time base is imported, the accounting is exact, and every
    /// imported sample is finite with an interval the navigator accepts.
    #[test]
    fn isolated_bad_lines_cost_only_themselves(
        n_good in 20usize..200,
        bad in prop::collection::vec((0usize..200, bad_imu_line()), 0..12),
    ) {
        let dir = temp_dir(&format!("prop-{n_good}-{}", bad.len()));
        let good = good_imu(n_good);
        // Bad lines after the first good line, never two in a row.
        let mut at: Vec<(usize, Vec<u8>)> = bad
            .into_iter()
            .map(|(k, l)| (1 + k % (n_good - 1), l))
            .collect();
        at.sort_by_key(|(k, _)| *k);
        at.dedup_by_key(|(k, _)| *k);
        let mut file = Vec::new();
        let mut bad_lines = Vec::new();
        let mut line = 0;
        let mut next_bad = at.iter().peekable();
        for (k, g) in good.iter().enumerate() {
            if let Some((_, b)) = next_bad.next_if(|(kb, _)| *kb == k) {
                file.extend_from_slice(b);
                file.push(b'\n');
                line += 1;
                bad_lines.push(line);
            }
            file.extend_from_slice(g.as_bytes());
            line += 1;
        }
        let got = import_kfgins(&dir, &file, &good_truth(1)).expect("import");
        let skipped: Vec<usize> = got.sum.skipped.lines.iter().map(|l| l.1).collect();
        prop_assert_eq!(&skipped, &bad_lines);
        prop_assert_eq!(got.sum.skipped.count as usize, bad_lines.len());
        prop_assert_eq!(got.sum.imu_unused, 1);
        prop_assert_eq!(got.imu.len(), n_good - 1);
        for (i, s) in got.imu.iter().enumerate() {
            prop_assert_eq!(s.t_ns, ((i + 1) as f64 * DT * 1e9).round() as u64);
            prop_assert!((s.dt_s - DT).abs() < 1e-9, "{:?}", s);
            prop_assert!(s.d_theta_rad.iter().chain(&s.d_v_mps).all(|x| x.is_finite()));
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Any PSINS header values, log-uniform over the whole range or
    /// non-finite: the import either fails as not-the-format or imports
    /// every data line with an interval the navigator accepts, and the
    /// truth it makes is bounded by the data, whatever the header says.
    #[test]
    fn any_psins_header_is_refused_or_bounded(
        fields in prop::collection::vec(
            prop_oneof![2 => Just(None), 1 => absurd().prop_map(Some)],
            18,
        ),
    ) {
        let dir = temp_dir("prop-psins");
        let plausible: Vec<&str> = PSINS_HEADER.iter().flat_map(|l| l.split(' ')).collect();
        let fields: Vec<String> = fields
            .into_iter()
            .zip(plausible)
            .map(|(f, p)| f.unwrap_or_else(|| p.to_owned()))
            .collect();
        let h: Vec<String> = fields.chunks(6).map(|c| c.join(" ")).collect();
        let line: &[u8] = b"-5 2 13 -48 127 7833";
        let path = psins(&dir, [&h[0], &h[1], &h[2]], &[line; 3]);
        let mut buf = Vec::new();
        match interop::import_psins(&path, &AidSynthesis::default(), &mut buf) {
            Err(ImportError::NotFormat { why, .. }) => prop_assert!(why.contains("line ")),
            Err(e) => prop_assert!(false, "unexpected error {}", e),
            Ok(sum) => {
                prop_assert_eq!(sum.imu + sum.skipped.count, 3);
                // At most one truth epoch per second of data, plus the start.
                prop_assert!(sum.truth <= 2 + (3.0 * IMU_DT_RANGE_S.1) as u64);
                prop_assert!(buf.len() < 64 << 10, "{} bytes", buf.len());
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}

// ------------------------------------------------------- command line

/// The binary under a 40 MiB address-space limit (`ulimit -v`), with
/// backtraces asked for, so that a crash would show one.
fn run_limited(args: &[&str]) -> std::process::Output {
    let mut cmd = std::process::Command::new("sh");
    cmd.arg("-c")
        .arg("ulimit -v 40960 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_sensor-replay"))
        .args(args)
        .env("RUST_BACKTRACE", "1");
    cmd.output().expect("run sensor-replay")
}

#[test]
fn the_command_line_keeps_memory_bounded_and_fails_without_a_backtrace() {
    let dir = temp_dir("cli");
    let (imu, truth, out) = (
        dir.join("imu.txt"),
        dir.join("truth.nav"),
        dir.join("out.navlog"),
    );
    // A 64 MiB line between good ones: more than the process may map, so
    // reading it whole would fail.
    let mut text = good_imu(100).concat().into_bytes();
    text.extend(std::iter::repeat_n(b'1', 64 << 20));
    text.push(b'\n');
    text.extend_from_slice(good_imu(200)[100..].concat().as_bytes());
    std::fs::write(&imu, &text).expect("write");
    std::fs::write(&truth, good_truth(3)).expect("write");
    let o = run_limited(&[
        "import-kfgins",
        "--imu",
        imu.to_str().expect("utf-8"),
        "--truth",
        truth.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("imu.txt:101: skipped: line of 67108864 bytes"),
        "{err}"
    );
    assert!(err.contains("199 IMU"), "{err}");

    // A PSINS header with a 1e10 ms interval: exit 2, the line named, no backtrace.
    let psins = psins(
        &dir,
        [
            PSINS_HEADER[0],
            "34.2 108.9 380.0 0.0 1e10 9.78",
            PSINS_HEADER[2],
        ],
        &[b"-5 2 13 -48 127 7833"],
    );
    let o = run_limited(&[
        "import-psins",
        psins.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("line 5: header: sample interval 10000000000 ms outside"),
        "{err}"
    );
    assert!(
        !err.contains("panicked") && !err.contains("backtrace"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

// ------------------------------------------------------- KF-GINS GNSS

/// KF-GINS's GNSS file as its GnssFileLoader reads it: 7 columns (time,
/// lat, lon, h, σN, σE, σD), or 13 with the NED velocity after the height
/// and its σ last; the times on the IMU file's clock (T0 on). Wild lines
/// are marked with the reason they must be skipped.
const GNSS_FILE: &str = "\
# KF-GINS GNSS, hand-written
999.000    30.4447858054   114.4718661162     21.095    0.010    0.009    0.019
1000.000   30.4447858054   114.4718661162     21.095    0.030    0.040    0.050
1000.250   30.4447857891   114.4718661133     21.091    0.010    0.020    0.019
1000.500   NaN             114.4718661133     21.091    0.010    0.010    0.019
1000.750   30.4447857891   114.4718661133     21.091    1e300    0.010    0.019
1001.000   30.4447857891   114.4718661133     21.091    0.010    -0.01    0.019
1000.100   30.4447857891   114.4718661133     21.091    0.010    0.010    0.019
1000.250   30.4447857891   114.4718661133     21.091    0.010    0.010    0.019
1001.250   30.4447857891   114.4718661133
1001.500   91.0            114.4718661133     21.091    0.010    0.010    0.019
1001.750   30.4447858189   114.4718661201     21.087    1.5 -2.0 0.25   0.010 0.010 0.020   0.05 0.05 0.08
1002.000   30.4447858189   114.4718661201     21.087    1.5 -2.0 0.25   0.010 0.010 0.020   0.05 -0.05 0.08
1002.250   30.4447858189   114.4718661201     21.087    0.010    0.010    0.0
";

fn gnss_import(
    dir: &Path,
    truth: Option<&[u8]>,
    init: Option<interop::GivenInit>,
) -> Result<(ImportSummary, Vec<Record>), ImportError> {
    let (imu_path, truth_path, gnss_path) = (
        dir.join("imu.txt"),
        dir.join("truth.nav"),
        dir.join("gnss.txt"),
    );
    std::fs::write(&imu_path, good_imu(600).concat()).expect("write imu");
    std::fs::write(&gnss_path, GNSS_FILE).expect("write gnss");
    if let Some(t) = truth {
        std::fs::write(&truth_path, t).expect("write truth");
    }
    let files = interop::KfginsFiles {
        imu: &imu_path,
        truth: truth.map(|_| truth_path.as_path()),
        gnss: Some(&gnss_path),
        init,
    };
    let mut buf = Vec::new();
    let sum = interop::import_kfgins_files(&files, &AidSynthesis::default(), &mut buf)?;
    let (records, report) = read_all(&buf);
    assert!(report.is_clean(), "{report:?}");
    Ok((sum, records))
}

fn fixes(records: &[Record]) -> Vec<msgs::GnssFix> {
    records
        .iter()
        .filter_map(|r| match r {
            Record::Aid(a) => match **a {
                msgs::AidSample::Gnss(g) => Some(g),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

#[test]
#[allow(clippy::float_cmp)] // the values are the file's text, parsed: equal to the bit
fn kfgins_gnss_lines_become_fixes_on_the_imu_time_base_and_wild_lines_are_named() {
    use msgs::gnss::{fix_flags, fix_type};
    let dir = temp_dir("gnss");
    let (sum, records) = gnss_import(&dir, Some(&good_truth(30)), None).expect("import");
    let skipped: Vec<(usize, &str)> = sum
        .skipped
        .lines
        .iter()
        .map(|(f, l, why)| {
            assert!(f.ends_with("gnss.txt"), "{f}");
            (*l, why.as_str())
        })
        .collect();
    let lines: Vec<usize> = skipped.iter().map(|s| s.0).collect();
    assert_eq!(lines, [5, 6, 7, 8, 9, 10, 11, 13, 14], "{skipped:?}");
    for (line, why) in [
        (5, "not finite"),
        (6, "σ north"),
        (7, "σ east -0.01 m"),
        (8, "time 1000.1 not after 1000.25"),
        (9, "time 1000.25 not after 1000.25"),
        (10, "3 fields, expected 7 or 13"),
        (11, "latitude 91"),
        (13, "σ vE -0.05 m/s"),
        (14, "σ down 0 m"),
    ] {
        let got = skipped.iter().find(|s| s.0 == line).expect("named").1;
        assert!(got.contains(why), "line {line}: {got}");
    }
    // The fix at 999 s is before the truth's first epoch (the init).
    assert_eq!((sum.gnss, sum.gnss_unused), (3, 1));
    let f = fixes(&records);
    assert_eq!(f.len(), 3);
    assert_eq!(
        f.iter().map(|f| (f.t_ns, f.seq)).collect::<Vec<_>>(),
        [(0, 0), (250_000_000, 1), (1_750_000_000, 2)]
    );
    assert_eq!(f[0].lat_rad, 30.4447858054f64.to_radians());
    assert_eq!(f[0].lon_rad, 114.4718661162f64.to_radians());
    assert_eq!(f[0].height_m, 21.095);
    // R's north and east variances sum to σN² + σE²; vertical σD.
    assert!((f[0].h_acc_m - (0.5f64 * (0.03 * 0.03 + 0.04 * 0.04)).sqrt()).abs() < 1e-15);
    assert_eq!(f[0].v_acc_m, 0.05);
    assert_eq!(f[0].itow_ms, 1_000_000);
    for g in &f {
        assert_eq!(g.fix_type, fix_type::FIX_3D);
        assert!(g.is_3d());
    }
    // 7 columns: no velocity; 13: the velocity and its accuracy.
    assert_eq!(f[0].flags, fix_flags::FIX_OK | fix_flags::NO_VELOCITY);
    assert!(!f[1].has_velocity());
    assert!(f[2].has_velocity());
    assert_eq!(f[2].vel_ned_mps, [1.5, -2.0, 0.25]);
    assert!(
        (f[2].s_acc_mps - ((0.05f64.powi(2) * 2.0 + 0.08f64.powi(2)) / 3.0).sqrt()).abs() < 1e-15
    );
    assert_eq!(f[2].v_acc_m, 0.02);
    // The truth's init and every truth epoch are still there.
    assert!(
        records
            .iter()
            .any(|r| matches!(r, Record::Init(i) if i.t_ns == 0))
    );
    assert_eq!(sum.truth, 30);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
#[allow(clippy::float_cmp)] // the values are the file's text, parsed: equal to the bit
fn without_truth_the_first_fix_is_the_init_and_the_time_base() {
    let dir = temp_dir("gnss-init");
    let given = interop::GivenInit {
        att_rpy_deg: [1.0, -2.0, 185.7],
        vel_ned_mps: [3.0, -4.0, 0.5],
        sigma_tilt_deg: 2.0,
        sigma_heading_deg: 10.0,
        sigma_vel_h_mps: 0.2,
        sigma_vel_v_mps: 0.3,
    };
    let (sum, records) = gnss_import(&dir, None, Some(given)).expect("import");
    assert_eq!((sum.truth, sum.gnss, sum.gnss_unused), (0, 4, 0));
    let f = fixes(&records);
    assert_eq!(f[0].t_ns, 0, "the first fix (999 s) is the time base");
    let init = records
        .iter()
        .find_map(|r| match r {
            Record::Init(i) => Some(*i),
            _ => None,
        })
        .expect("init");
    assert_eq!(init.t_ns, 0);
    let geo = polarnav::earth::ecef_to_geodetic(&nalgebra::Vector3::from(init.r_e_m));
    assert!((geo.lat_rad.to_degrees() - 30.4447858054).abs() < 1e-10);
    assert!((geo.lon_rad.to_degrees() - 114.4718661162).abs() < 1e-10);
    assert!((geo.h_m - 21.095).abs() < 1e-6);
    assert_eq!(init.sigma_pos_v_m, 0.019);
    assert!((init.sigma_pos_h_m - (0.5f64 * (0.01 * 0.01 + 0.009 * 0.009)).sqrt()).abs() < 1e-15);
    assert_eq!(init.sigma_vel_h_mps, 0.2);
    assert!((init.sigma_heading_rad - 10f64.to_radians()).abs() < 1e-15);
    // Velocity: NED given, ENU in the local axes.
    let c_e_g = polarnav::frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let v_enu = c_e_g * nalgebra::Vector3::from(init.v_e_mps);
    assert!(
        (v_enu - nalgebra::Vector3::new(-4.0, 3.0, -0.5)).amax() < 1e-9,
        "{v_enu}"
    );
    // Heading 185.7° (yaw of the FRD body), as the KF-GINS truth would say it.
    let [w, x, y, z] = init.q_b_e;
    let c_b_e = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
        .to_rotation_matrix()
        .into_inner();
    let fwd = c_e_g * c_b_e * nalgebra::Vector3::new(0.0, 1.0, 0.0);
    let heading = fwd.x.atan2(fwd.y).to_degrees().rem_euclid(360.0);
    assert!((heading - 185.7).abs() < 1e-9, "{heading}");
    // IMU samples on the same base: the sample ending at 1000.005 s is at 1.005 s.
    let first_imu = records
        .iter()
        .find_map(|r| match r {
            Record::Imu(s) => Some(*s),
            _ => None,
        })
        .expect("imu");
    assert_eq!(first_imu.t_ns, 1_005_000_000);
    assert!(!records.iter().any(|r| matches!(r, Record::Truth(_))));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn without_truth_or_an_initial_attitude_there_is_no_init() {
    let dir = temp_dir("gnss-noinit");
    match gnss_import(&dir, None, None) {
        Err(ImportError::NoInit(why)) => assert!(why.contains("attitude"), "{why}"),
        other => panic!("expected NoInit, got {:?}", other.map(|o| o.0)),
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_command_line_refuses_a_missing_or_garbage_gnss_file_naming_it() {
    let dir = temp_dir("gnss-cli");
    let (imu, truth, gnss, out) = (
        dir.join("imu.txt"),
        dir.join("truth.nav"),
        dir.join("gnss.txt"),
        dir.join("out.navlog"),
    );
    std::fs::write(&imu, good_imu(100).concat()).expect("write");
    std::fs::write(&truth, good_truth(3)).expect("write");
    let s = |p: &PathBuf| p.to_str().expect("utf-8").to_owned();
    let run = |extra: &[String]| {
        let (imu_s, out_s) = (s(&imu), s(&out));
        let mut args = vec!["import-kfgins", "--imu", &imu_s, "--out", &out_s];
        args.extend(extra.iter().map(String::as_str));
        let o = run_limited(&args);
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let att = ["--init-att", "0,0,90", "--init-vel", "0,0,0"];
    let (g, t) = (s(&gnss), s(&truth));
    let with = |a: &[&str]| -> Vec<String> {
        a.iter()
            .chain(att.iter())
            .map(|x| (*x).to_owned())
            .collect()
    };
    // Missing.
    let (code, err) = run(&with(&["--gnss", &g]));
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("gnss.txt: cannot read"), "{err}");
    // Garbage.
    let bin: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
        .collect();
    std::fs::write(&gnss, &bin).expect("write");
    let (code, err) = run(&with(&["--gnss", &g]));
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("gnss.txt: not a KF-GINS GNSS file"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // Good, without truth: written.
    std::fs::write(&gnss, GNSS_FILE).expect("write");
    let (code, err) = run(&with(&["--gnss", &g]));
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("gnss.txt:5: skipped"), "{err}");
    assert!(err.contains("4 GNSS records"), "{err}");
    // No truth and no initial attitude; truth beside an initial attitude.
    let (code, err) = run(&["--gnss".to_owned(), g.clone()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--init-att"), "{err}");
    let (code, err) = run(&with(&["--gnss", &g, "--truth", &t]));
    assert_eq!(code, Some(2), "{err}");
    // Aids synthesized from a truth that is not there.
    let (code, err) = run(&with(&["--gnss", &g, "--cns-sigma", "10"]));
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("give --truth"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
