//! Property tests (proptest) of the navlog reader: arbitrary bytes never
//! make it panic, and in a damaged log every record whose frame was not
//! touched comes back, in order, while every loss is reported.

use msgs::navlog::{Header, NavlogWriter, Record, read_all};
use msgs::{BaroSample, CnsFix, ImuSample};
use proptest::prelude::*;

fn record(kind: u8, k: u64, x: f64) -> Record {
    match kind % 3 {
        0 => Record::Imu(ImuSample {
            t_ns: k,
            seq: k,
            dt_s: 0.005,
            d_theta_rad: [x, -x, 1e-9 * x],
            d_v_mps: [0.0, x, 0.049],
        }),
        1 => Record::aid(CnsFix {
            t_ns: k,
            seq: k,
            lat_rad: x,
            lon_rad: -x,
            sigma_h_m: 20.0,
        }),
        _ => Record::aid(BaroSample {
            t_ns: k,
            seq: k,
            pressure_pa: 7565.0 + x,
            temperature_k: 216.65,
            sigma_m: 10.0,
        }),
    }
}

/// Encoded log and the byte range of each record's frame (its delimiter included).
fn encode(records: &[Record]) -> (Vec<u8>, Vec<(usize, usize)>) {
    let mut w = NavlogWriter::new(Vec::new(), Header::new("fuzz", "fuzz", 0, "")).expect("header");
    for r in records {
        w.write(r).expect("write");
    }
    let bytes = w.finish().expect("finish");
    let ends: Vec<usize> = bytes
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == 0)
        .map(|(i, _)| i)
        .collect();
    // Frame 0 is the header; record k's frame follows delimiter k.
    let spans = ends.windows(2).map(|w| (w[0] + 1, w[1])).collect();
    (bytes, spans)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..4096)) {
        let (records, report) = read_all(&bytes);
        prop_assert_eq!(records.len() as u64, report.records);
    }

    #[test]
    fn untouched_records_survive_and_losses_are_reported(
        spec in proptest::collection::vec((any::<u8>(), -1.0e3f64..1.0e3), 1..60),
        flips in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 0..6),
        cut in proptest::option::of(any::<prop::sample::Index>()),
    ) {
        let originals: Vec<Record> = spec
            .iter()
            .enumerate()
            .map(|(k, (kind, x))| record(*kind, k as u64, *x))
            .collect();
        let (mut bytes, spans) = encode(&originals);
        let mut touched = vec![false; bytes.len()];
        for (at, xor) in &flips {
            let i = at.index(bytes.len());
            bytes[i] ^= xor;
            touched[i] = true;
        }
        let len = cut.map_or(bytes.len(), |c| c.index(bytes.len() + 1));
        bytes.truncate(len);
        let (got, report) = read_all(&bytes);
        // Returned records are originals, in order (a subsequence).
        let mut it = originals.iter();
        for g in got.iter().filter(|r| !matches!(r, Record::Header(_))) {
            prop_assert!(it.any(|o| o == g), "record {:?} is not an original in order", g);
        }
        // Every record whose frame and both delimiters are intact comes back.
        for (k, (a, b)) in spans.iter().enumerate() {
            let intact = *b < len && !touched[a - 1..=*b].iter().any(|t| *t);
            if intact {
                prop_assert!(got.contains(&originals[k]), "intact record {} lost", k);
            }
        }
        // Nothing is lost silently: a log cut exactly between frames is just a
        // shorter log, but any record of the kept length that does not come
        // back is reported.
        let returned = got.iter().filter(|r| !matches!(r, Record::Header(_))).count();
        let complete = spans.iter().filter(|(_, b)| *b < len).count();
        if returned < complete {
            prop_assert!(!report.is_clean(), "records lost but the report is clean");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4096))]

    /// The block-wise COBS decoder agrees with the `cobs` crate on valid
    /// encodings and on arbitrary (zero-free) frames.
    #[test]
    fn cobs_decoder_agrees_with_the_cobs_crate(
        data in proptest::collection::vec(any::<u8>(), 1..700),
        junk in proptest::collection::vec(1u8..=255, 0..300),
    ) {
        let mut enc = vec![0u8; cobs::max_encoding_length(data.len())];
        let n = cobs::encode(&data, &mut enc);
        let mut mine = Vec::new();
        prop_assert!(msgs::navlog::cobs_decode(&enc[..n], &mut mine).is_some());
        prop_assert_eq!(&mine, &data);

        let mut theirs = vec![0u8; junk.len()];
        let t = cobs::decode(&junk, &mut theirs);
        let m = msgs::navlog::cobs_decode(&junk, &mut mine);
        if let (Ok(k), Some(())) = (&t, m) {
            prop_assert_eq!(&mine[..], &theirs[..*k]);
        } else {
            prop_assert!(t.is_err() && m.is_none(), "crate {:?} vs ours {:?} on {:?}", t, m, junk);
        }
    }
}
