//! The outputs of two shipped flights, pinned item by item at f256bf8, the
//! commit before the aids were moved onto one declaration (issue 29): the
//! simulated navlog, `batch`'s solution CSV and `batch`'s MCAP of
//! `paper-sim.toml` (SRS, CNS, baro; a frame switch) and
//! `transpolar-star.toml` (the four aids, 1.24 h over the pole).
//!
//! Each output is cut into items, hashed (SHA-256, 128 bits kept):
//! - navlog: the whole file, and the frames of each record variant (by the
//!   variant index postcard writes, read here from the COBS frames
//!   themselves, not through the crate's reader);
//! - CSV: the header, the row count and each column's values (by name);
//! - MCAP: per channel the topic's schema name and encoding and its
//!   messages (log time, publish time, sequence and bytes), per schema its
//!   descriptor bytes, per metadata record each entry.
//!
//! Every pinned item must be there with its hash. An item that is not
//! pinned fails the test unless it is named in [`ADDED_SINCE_THE_PIN`]
//! with the change that added it, so an output can grow (a new aid's
//! column, channel or schema) without an old item changing unseen.

use std::collections::BTreeMap;
use std::io::{BufReader, Write};

use nav_daemon::batch::{self, BatchOptions, Output};
use polarnav_config::ConfigFile;
use polarnav_foxglove::{AidSource, McapFile};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};
use polarnav_tests::repo;
use sha2::{Digest, Sha256};

/// Items that did not exist at the pin, with the change that added them
/// (prefix match on the item name).
const ADDED_SINCE_THE_PIN: &[(&str, &str)] = &[
    ("mcap metadata polarnav.settings aids.gnss", GNSS),
    ("csv column star_fresh", AID_COLUMNS),
    ("csv column gnss_fresh", AID_COLUMNS),
    ("csv column gnss_excluded", AID_COLUMNS),
    (
        "mcap metadata polarnav.settings filter.flight_state",
        FLIGHT_STATE,
    ),
    ("csv column mag_fresh", MAG),
    ("mcap metadata polarnav.settings aids.mag", MAG),
    ("mcap metadata polarnav.settings aids.baseline", BASELINE),
    ("csv column baseline_fresh", BASELINE),
    ("csv column gnss_untested", UNTESTED),
];

/// GNSS fused untested while its integrity test is unavailable (the
/// test's horizontal protection level from the reference beyond the alert limit): its
/// column in the CSV's aid group, `polarnav.Solution.gnss_untested`,
/// `AidStatus.integrity_unavailable` (and `[aids.gnss]
/// integrity_alert_limit_m`, under `aids.gnss` above). These flights fly
/// no GNSS: the column is 0 and the fields false (not encoded).
const UNTESTED: &str = "GNSS fused untested while its integrity test is unavailable";

/// The magnetometer, the seventh aid (issue 30): its settings (`[aids.mag]`,
/// `mag_gate`, `mag_timeout_s`), its freshness column, and its name among
/// the aids fused by default.
const MAG: &str = "the magnetometer, the seventh aid, and its settings (issue 30)";

/// The dual-antenna baseline, the sixth aid (issue 30): its settings
/// table, its name among the aids fused by default, its freshness column
/// in the CSV's aid group and field of `polarnav.Solution`, the grown
/// `Status` (`_v7`) and navlog format 7.
const BASELINE: &str = "the dual-antenna baseline, the sixth aid, and its settings (issue 30)";

/// The solution CSV's aid group (issue 29): a freshness column for each
/// aid that had none (star, GNSS) and GNSS's exclusion, after the bias σ.
const AID_COLUMNS: &str = "the CSV's aid group: star_fresh, gnss_fresh, gnss_excluded (issue 29)";

/// GNSS, the fifth aid (issue 29): its settings, and its name among the
/// aids fused by default.
const GNSS: &str = "GNSS, the fifth aid, and its settings (issue 29)";

/// Paper 003's flight state and the accelerometers' level (issue 30):
/// their settings, and the bits of the solution flags they take (15–17),
/// cleared before `flags` is hashed in the CSV, `/solution` and `/status`:
/// every other bit stays pinned.
const FLIGHT_STATE: &str = "flight state and the accelerometers' level (issue 30)";
const FLIGHT_STATE_BITS: u32 =
    msgs::solution_flags::FLIGHT_STATE_MASK | msgs::solution_flags::LEVEL_FUSED;

/// Pinned items whose value has changed on purpose since the pin, each
/// with the change (exact item names). Everything else they carry is
/// pinned by finer items: the navlog's frames after its header and the
/// header's fields, each MCAP channel's messages.
const CHANGED_SINCE_THE_PIN: &[(&str, &str)] = &[
    ("csv header", AID_COLUMNS_GROWN),
    ("navlog file", FORMAT_5),
    ("navlog record 00 (1 frames)", FORMAT_5),
    ("navlog header format_version", FORMAT_5),
    ("mcap metadata polarnav navlog_format_version", FORMAT_5),
    ("mcap metadata polarnav.settings aids.fuse", FUSE),
    ("mcap schema polarnav.AidUpdate", SCHEMA),
    ("mcap schema polarnav.BaroSample", SCHEMA),
    ("mcap schema polarnav.CnsFix", SCHEMA),
    ("mcap schema polarnav.ImuSample", SCHEMA),
    ("mcap schema polarnav.InitState", SCHEMA),
    ("mcap schema polarnav.Solution", SCHEMA),
    ("mcap schema polarnav.SrsSample", SCHEMA),
    ("mcap schema polarnav.StarSample", SCHEMA),
    ("mcap schema polarnav.Status", SCHEMA),
    ("mcap schema polarnav.SwitchNote", SCHEMA),
    ("mcap schema polarnav.Truth", SCHEMA),
    ("mcap schema polarnav.TruthBias", SCHEMA),
];

/// The navlog's format version 4 → 7 (the `_v5`, `_v6` then `_v7` status
/// record, the GNSS, baseline and magnetometer records): the header's one
/// field and what contains it.
const FORMAT_5: &str = "navlog format 7: the _v7 status record, the GNSS (issue 29), baseline and magnetometer (issue 30) records";
/// The aids fused by default: every declared one, GNSS (issue 29) then
/// the baseline and the magnetometer (issue 30).
const FUSE: &str = "the aids fused by default grew: gnss (issue 29), baseline and mag (issue 30)";
/// The CSV header: the aid group of issue 29, then `baseline_fresh` and
/// `mag_fresh`.
const AID_COLUMNS_GROWN: &str = "the CSV's aid group (issue 29), grown by baseline_fresh and \
                                 mag_fresh (issue 30), then gnss_untested";
/// `polarnav.proto` grew: Status.aids (every aid by name),
/// StreamCounters.rejected_integrity, AidStatus' integrity and refusal
/// fields (issue 29). Every channel's messages stay pinned.
const SCHEMA: &str = "polarnav.proto grew with the aids' status (issue 29), then the \
                      baseline's message and Solution.baseline_fresh (issue 30), then \
                      Solution.gnss_untested and AidStatus.integrity_unavailable";

/// The fields of `polarnav.Status` and `polarnav.Solution` added since the pin, cleared before a
/// `/status` or `/solution` message is hashed: every byte the message had at the pin
/// must be the same.
fn canonical(topic: &str, data: &[u8]) -> Vec<u8> {
    if topic == "/solution" {
        // The aid group's fields (AID_COLUMNS), bits of `flags` repeated.
        let mut s: polarnav_proto::Solution =
            prost::Message::decode(data).expect("a polarnav.Solution");
        s.star_fresh = false;
        s.gnss_fresh = false;
        s.gnss_excluded = false;
        s.flags &= !FLIGHT_STATE_BITS;
        s.mag_fresh = false;
        s.baseline_fresh = false;
        return prost::Message::encode_to_vec(&s);
    }
    if topic == "/init" {
        // How the attitude was found (issue 30): the shipped flights' inits
        // are given, and the proto's new fields say so; the rest as pinned.
        let mut i: polarnav_proto::InitState =
            prost::Message::decode(data).expect("a polarnav.InitState");
        assert_eq!(
            (i.method, i.heading_aid, i.method_name.as_str()),
            (0, 0, "given")
        );
        i.method_name.clear();
        return prost::Message::encode_to_vec(&i);
    }
    if topic != "/status" {
        return data.to_vec();
    }
    let mut s: polarnav_proto::Status = prost::Message::decode(data).expect("a polarnav.Status");
    s.aids.clear();
    s.flags &= !FLIGHT_STATE_BITS;
    let legacy = [&mut s.imu, &mut s.srs, &mut s.cns, &mut s.baro, &mut s.star];
    for c in legacy.into_iter().flatten() {
        c.rejected_integrity = 0;
    }
    for a in [
        &mut s.srs_aid,
        &mut s.cns_aid,
        &mut s.baro_aid,
        &mut s.star_aid,
    ]
    .into_iter()
    .flatten()
    {
        a.integrity_ratio = 0.0;
        a.excluded = false;
        a.excluded_since_t_ns = 0;
        a.exclusion_cause.clear();
        a.refused.clear();
    }
    prost::Message::encode_to_vec(&s)
}

/// 128 bits of the SHA-256 of `bytes`, in hex.
fn h(bytes: &[u8]) -> String {
    Sha256::digest(bytes)[..16]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn finish(d: Sha256) -> String {
    d.finalize()[..16]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The navlog's items: the whole file, the file after its header frame,
/// the header's fields, and per record variant its frames.
fn navlog_items(bytes: &[u8], items: &mut BTreeMap<String, String>) {
    items.insert("navlog file".into(), h(bytes));
    let bytes = &init_records_as_v1(bytes);
    let first_end = bytes.iter().position(|b| *b == 0).expect("a header frame") + 1;
    items.insert("navlog after the header".into(), h(&bytes[first_end..]));
    let raw = cobs::decode_vec(&bytes[..first_end - 1]).expect("the header frame");
    let header: msgs::navlog::Record =
        postcard::from_bytes(&raw[..raw.len() - 4]).expect("the header record");
    let msgs::navlog::Record::Header(hd) = header else {
        panic!("the first record is not a header")
    };
    items.insert("navlog header magic".into(), h(&hd.magic));
    items.insert(
        "navlog header format_version".into(),
        hd.format_version.to_string(),
    );
    for (k, v) in [
        ("producer", &hd.producer),
        ("scenario", &hd.scenario),
        ("metadata", &hd.metadata),
    ] {
        items.insert(format!("navlog header {k}"), h(v.as_bytes()));
    }
    items.insert("navlog header seed".into(), hd.seed.to_string());
    let mut kinds: BTreeMap<u32, (u64, Sha256)> = BTreeMap::new();
    for frame in bytes.split(|b| *b == 0).filter(|f| !f.is_empty()) {
        let raw = cobs::decode_vec(frame).expect("a COBS frame");
        // postcard's enum tag: a varint before the content.
        let (mut tag, mut shift) = (0u32, 0);
        for b in &raw {
            tag |= u32::from(b & 0x7f) << shift;
            shift += 7;
            if b & 0x80 == 0 {
                break;
            }
        }
        let e = kinds.entry(tag).or_insert_with(|| (0, Sha256::new()));
        e.0 += 1;
        e.1.update((raw.len() as u64).to_le_bytes());
        e.1.update(&raw);
    }
    for (tag, (n, d)) in kinds {
        items.insert(format!("navlog record {tag:02} ({n} frames)"), finish(d));
    }
}

/// Hashes a CSV as it is written: the header, the row count and each column.
struct CsvItems {
    line: Vec<u8>,
    names: Vec<String>,
    columns: Vec<Sha256>,
    header: String,
    rows: u64,
}

impl CsvItems {
    fn new() -> Self {
        Self {
            line: Vec::new(),
            names: Vec::new(),
            columns: Vec::new(),
            header: String::new(),
            rows: 0,
        }
    }

    fn take_line(&mut self) {
        let line = std::str::from_utf8(&self.line).expect("UTF-8 CSV");
        if self.names.is_empty() {
            self.header = h(line.as_bytes());
            self.names = line.split(',').map(str::to_owned).collect();
            self.columns = self.names.iter().map(|_| Sha256::new()).collect();
        } else {
            let cells: Vec<&str> = line.split(',').collect();
            assert_eq!(cells.len(), self.names.len(), "row {}", self.rows + 1);
            for ((d, c), name) in self.columns.iter_mut().zip(cells).zip(&self.names) {
                if name == "flags" {
                    let f: u32 = c.parse().expect("flags");
                    d.update((f & !FLIGHT_STATE_BITS).to_string().as_bytes());
                } else {
                    d.update(c.as_bytes());
                }
                d.update(b"\n");
            }
            self.rows += 1;
        }
        self.line.clear();
    }

    fn items(mut self, items: &mut BTreeMap<String, String>) {
        assert!(self.line.is_empty(), "the CSV does not end with a line end");
        items.insert("csv header".into(), self.header.clone());
        items.insert("csv rows".into(), self.rows.to_string());
        for (name, d) in std::mem::take(&mut self.names)
            .into_iter()
            .zip(self.columns)
        {
            items.insert(format!("csv column {name}"), finish(d));
        }
    }
}

impl Write for CsvItems {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        for &b in buf {
            if b == b'\n' {
                self.take_line();
            } else {
                self.line.push(b);
            }
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The navlog with each init record (variant 1) written in its `_v1`
/// layout, as before format 8 (issue 30): its postcard body without the
/// trailing `method`, `heading_aid` and padding bytes (one byte each),
/// which must say "given" (all zero), a new CRC and COBS frame. Every
/// other frame as it is: the pins hold everything else to the byte.
fn init_records_as_v1(bytes: &[u8]) -> Vec<u8> {
    const V2_TAIL: usize = 1 + 1 + 6;
    let mut out = Vec::with_capacity(bytes.len());
    for frame in bytes.split_inclusive(|b| *b == 0) {
        let body = frame.strip_suffix(&[0]).unwrap_or(frame);
        let raw = cobs::decode_vec(body).unwrap_or_default();
        let is_init = raw.len() > 4
            && matches!(
                postcard::from_bytes::<msgs::navlog::Record>(&raw[..raw.len() - 4]),
                Ok(msgs::navlog::Record::Init(_))
            );
        if !is_init {
            out.extend_from_slice(frame);
            continue;
        }
        let record = &raw[..raw.len() - 4];
        let (v1, tail) = record.split_at(record.len() - V2_TAIL);
        assert_eq!(tail, &[0u8; V2_TAIL], "a shipped flight's init is given");
        let mut raw = v1.to_vec();
        raw.extend_from_slice(&crc32fast::hash(v1).to_le_bytes());
        out.extend(cobs::encode_vec(&raw));
        out.push(0);
    }
    out
}

/// The MCAP file's items (read with the `mcap` crate).
fn mcap_items(bytes: &[u8], items: &mut BTreeMap<String, String>) {
    let mut channels: BTreeMap<String, (String, u64, Sha256)> = BTreeMap::new();
    for m in mcap::MessageStream::new(bytes).expect("MCAP") {
        let m = m.expect("a message");
        let schema = m.channel.schema.as_ref().map_or(String::new(), |s| {
            items.insert(format!("mcap schema {}", s.name), h(&s.data));
            format!("{} {}", s.name, s.encoding)
        });
        let e = channels.entry(m.channel.topic.clone()).or_insert_with(|| {
            (
                format!("{schema} {}", m.channel.message_encoding),
                0,
                Sha256::new(),
            )
        });
        e.1 += 1;
        e.2.update(m.log_time.to_le_bytes());
        e.2.update(m.publish_time.to_le_bytes());
        e.2.update(m.sequence.to_le_bytes());
        let data = canonical(&m.channel.topic, &m.data);
        e.2.update((data.len() as u64).to_le_bytes());
        e.2.update(&data);
    }
    for (topic, (kind, n, d)) in channels {
        items.insert(format!("mcap channel {topic} kind"), kind);
        items.insert(format!("mcap channel {topic} ({n} messages)"), finish(d));
    }
    for r in mcap::read::LinearReader::new(bytes).expect("MCAP") {
        if let mcap::records::Record::Metadata(m) = r.expect("a record") {
            for (k, v) in &m.metadata {
                items.insert(format!("mcap metadata {} {k}", m.name), h(v.as_bytes()));
            }
        }
    }
}

/// Simulates `scenario`, runs `batch` to CSV and to MCAP, and returns the
/// items of the three outputs.
fn outputs(scenario: &str) -> BTreeMap<String, String> {
    let text = std::fs::read_to_string(repo(&format!("config/scenarios/{scenario}.toml")))
        .expect("scenario");
    let s = Scenario::parse(&text, scenario).expect("scenario");
    let mut log = Vec::new();
    simulate(&s, &text, SimOptions::default(), &mut log).expect("simulate");
    let mut items = BTreeMap::new();
    navlog_items(&log, &mut items);

    let mut csv = CsvItems::new();
    batch::run(
        &log[..],
        scenario,
        &mut csv,
        &ConfigFile::defaults(),
        &BatchOptions::default(),
    )
    .expect("batch to CSV");
    csv.items(&mut items);

    let dir =
        std::env::temp_dir().join(format!("polarnav-pinned-{scenario}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let path = dir.join("run.mcap");
    let run = batch::run_to::<_, std::io::Sink>(
        BufReader::new(&log[..]),
        scenario,
        Output::Mcap(Box::new(
            McapFile::create(&path, AidSource::Updates).expect("MCAP file"),
        )),
        &ConfigFile::defaults(),
        &BatchOptions::default(),
    );
    let bytes = std::fs::read(&path);
    std::fs::remove_dir_all(&dir).ok();
    run.expect("batch to MCAP");
    mcap_items(&bytes.expect("the MCAP file"), &mut items);
    items
}

/// Compares the items of `scenario` with the pins; prints every item (to
/// pin a new output) and fails naming each difference.
fn check(scenario: &str, pins: &[(&str, &str)]) {
    let items = outputs(scenario);
    for (k, v) in &items {
        eprintln!("        (\"{k}\", \"{v}\"),");
    }
    let pinned: BTreeMap<&str, &str> = pins.iter().copied().collect();
    let mut wrong = Vec::new();
    for (k, v) in &pinned {
        match items.get(*k) {
            Some(x) if x == v => {}
            Some(x) => match CHANGED_SINCE_THE_PIN.iter().find(|(c, _)| c == k) {
                Some((_, why)) => eprintln!("{scenario}: {k}: changed since the pin ({why})"),
                None => wrong.push(format!("{k}: {x}, pinned {v}")),
            },
            None => wrong.push(format!("{k}: missing")),
        }
    }
    for k in items.keys().filter(|k| !pinned.contains_key(k.as_str())) {
        match ADDED_SINCE_THE_PIN.iter().find(|(p, _)| k.starts_with(p)) {
            Some((_, why)) => eprintln!("{scenario}: {k}: new since the pin ({why})"),
            None => wrong.push(format!("{k}: not pinned, and not named as added")),
        }
    }
    assert!(
        wrong.is_empty(),
        "{scenario}: outputs differ from those pinned at f256bf8:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn paper_sim_outputs_are_those_pinned_before_the_aid_declaration() {
    check("paper-sim", PAPER_SIM);
}

#[test]
fn transpolar_star_outputs_are_those_pinned_before_the_aid_declaration() {
    check("transpolar-star", TRANSPOLAR_STAR);
}

const PAPER_SIM: &[(&str, &str)] = &[
    (
        "navlog after the header",
        "a20f585f8b3d9287c013a29fc8b3a14f",
    ),
    ("navlog header format_version", "4"),
    ("navlog header magic", "b1e637967e362d257cafe4e7aef1935c"),
    ("navlog header metadata", "46e7239566a494c33753f32dd40b0c0c"),
    ("navlog header producer", "e36fdc9ffba5c20f50e2dbb43062e9d3"),
    ("navlog header scenario", "191433a7822e2a12b5e00463e525d779"),
    ("navlog header seed", "1"),
    ("csv column ba_x_mps2", "459a8d355fe22f3b4ae03482091707b7"),
    ("csv column ba_y_mps2", "8fa1ade633f371f1d37376f3e67c5482"),
    ("csv column ba_z_mps2", "68cfa2df53eda72af835b0188e19c3c9"),
    ("csv column baro_fresh", "bc7cded10b638d85073291f5408bc22f"),
    ("csv column bg_x_rps", "e2ef76206fd171a9dd9ae8711dde0fce"),
    ("csv column bg_y_rps", "d52c1efc55a86a33c80ab12788f741e9"),
    ("csv column bg_z_rps", "39797ac115d59c81e30cffc1a343d3d9"),
    ("csv column cns_fresh", "976a3a9e7fc09208cc4be3032aeb9aae"),
    ("csv column coasting", "e1eef1c66b0c352b8857733acaf21a9f"),
    ("csv column flags", "723257bccbce0399e4e8f4687aa580e1"),
    ("csv column frame", "229ac40203aeedf5a6f9a15e89a7e374"),
    (
        "csv column grid_heading_deg",
        "b01e0c4b10da67bbd953b67cdec9830e",
    ),
    ("csv column h_m", "58d0f46405db0b59430d17206eda7392"),
    ("csv column heading_deg", "376d2cc000eebbda93da44f604cd5147"),
    ("csv column imu_lost", "e1eef1c66b0c352b8857733acaf21a9f"),
    ("csv column lat_deg", "652eb9eea893dc8362eef5b7040c9a90"),
    ("csv column lon_deg", "c0a0a91c66ce59968c4cef79bcbb12aa"),
    ("csv column pitch_deg", "9bbb4ab3920529955c1d78d236c6454b"),
    ("csv column qw", "40fd6081366f17523dbddc620d6b85fb"),
    ("csv column qx", "3ebf50581f1204d46e31ab974fcb693e"),
    ("csv column qy", "034c9b8d3439f353d304eed816329a68"),
    ("csv column qz", "abc2dcc845481b446161ed53299632fe"),
    ("csv column reset_count", "e1eef1c66b0c352b8857733acaf21a9f"),
    ("csv column roll_deg", "4b1ddbc19ce33676ab40dd0f56a3ee16"),
    (
        "csv column sig_att_x_deg",
        "fcede1fadf2ee3d9ed8b49caf2e51151",
    ),
    (
        "csv column sig_att_y_deg",
        "3b1706f3efac84687399fc466c7b6ac3",
    ),
    (
        "csv column sig_att_z_deg",
        "d66a80e2afab020328a6b9e55618df69",
    ),
    (
        "csv column sig_ba_x_mps2",
        "ce80c2568a8c6d02aeb068a53ece0e67",
    ),
    (
        "csv column sig_ba_y_mps2",
        "f87d0781d6d30a7177f233a4e14a483a",
    ),
    (
        "csv column sig_ba_z_mps2",
        "12c7c104353ffea6a1448cfc976b48b1",
    ),
    (
        "csv column sig_bg_x_rps",
        "5c87767daec5e12749b03925cb081886",
    ),
    (
        "csv column sig_bg_y_rps",
        "615d666d7ecb84b1abaf3900cfbf7807",
    ),
    (
        "csv column sig_bg_z_rps",
        "588289bb66ebffc13dbe9ac7c01923ab",
    ),
    ("csv column sig_e_m", "502404058d9a1a3a63bb7ae153824c5c"),
    ("csv column sig_n_m", "ae1fb9d2101616f840512105bdcc041e"),
    ("csv column sig_u_m", "11ee1e500dfca13ad4a587257660de39"),
    (
        "csv column sig_vnav_x_mps",
        "d52a0804e851445cf8486985b8cce420",
    ),
    (
        "csv column sig_vnav_y_mps",
        "863f510d8eb4b185939e7b009d0db2a0",
    ),
    (
        "csv column sig_vnav_z_mps",
        "964b517b737c55d8ce97ff2b88377d44",
    ),
    ("csv column srs_fresh", "976a3a9e7fc09208cc4be3032aeb9aae"),
    (
        "csv column switch_count",
        "cf142a6e2e8ffa439f8f04b35a419cc1",
    ),
    ("csv column t_s", "6535bdf0f2b681124fe714f9033746c2"),
    ("csv column ve_mps", "7803f41cf474a8af8f6326deb90efb63"),
    ("csv column vn_mps", "8f29ee14761fb0a7f9eb4f12fc4a0725"),
    ("csv column vu_mps", "593cbf5d4df758894d2902a8099898fb"),
    ("csv column vx_mps", "a00e54867a0b67cbd5b5c7608852ef80"),
    ("csv column vy_mps", "9b6b9e3c810628d4ed08b9d1ce3b25ca"),
    ("csv column vz_mps", "537cb618c03401e8c1749eb7499dcd88"),
    ("csv column x_m", "20cad0a13e12f88207c1cde59b21522d"),
    ("csv column y_m", "b249988b0846e0ce746e6cefbb558aeb"),
    ("csv column z_m", "40c0ba8632d1f7f4b31d732c7179c5fa"),
    ("csv header", "4b2a4db58ca566ad20824ab89b23c7ee"),
    ("csv rows", "120000"),
    (
        "mcap channel /aid/baro (6000 messages)",
        "a503f2b0ae77d4a24058332bfe13f241",
    ),
    (
        "mcap channel /aid/baro kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/cns (600 messages)",
        "76746a7dc6a0ab98b913538ba6c45287",
    ),
    (
        "mcap channel /aid/cns kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/srs (600 messages)",
        "ae6dbb9ae3fca10161566c4cebfdeceb",
    ),
    (
        "mcap channel /aid/srs kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /baro (6000 messages)",
        "ff36fbe96912039f3d0b48c6eebb4290",
    ),
    (
        "mcap channel /baro kind",
        "polarnav.BaroSample protobuf protobuf",
    ),
    (
        "mcap channel /cns (600 messages)",
        "26c63550999c4326d90c01c22e632d39",
    ),
    (
        "mcap channel /cns kind",
        "polarnav.CnsFix protobuf protobuf",
    ),
    (
        "mcap channel /events (1 messages)",
        "84cbef798103c26a14cd2f3a5c4938c7",
    ),
    (
        "mcap channel /events kind",
        "foxglove.Log protobuf protobuf",
    ),
    (
        "mcap channel /events/switch (1 messages)",
        "2caa0f8f8009ebe9a92d2b5df8c696fa",
    ),
    (
        "mcap channel /events/switch kind",
        "polarnav.SwitchNote protobuf protobuf",
    ),
    (
        "mcap channel /imu (120000 messages)",
        "5f0f8b8a1b07cadec1f0e47b7ce4ba16",
    ),
    (
        "mcap channel /imu kind",
        "polarnav.ImuSample protobuf protobuf",
    ),
    (
        "mcap channel /init (1 messages)",
        "f82ffd42c82a4bdede8dd116dfc9f23f",
    ),
    (
        "mcap channel /init kind",
        "polarnav.InitState protobuf protobuf",
    ),
    (
        "mcap channel /solution (120000 messages)",
        "4f9e157bf0430a07b940093083661b56",
    ),
    (
        "mcap channel /solution kind",
        "polarnav.Solution protobuf protobuf",
    ),
    (
        "mcap channel /solution/fix (12001 messages)",
        "0cf6e1112055cc250ac6a2de55730384",
    ),
    (
        "mcap channel /solution/fix kind",
        "foxglove.LocationFix protobuf protobuf",
    ),
    (
        "mcap channel /solution/nav_frame (12001 messages)",
        "811aadc6b8765955e89231f39f6d2806",
    ),
    (
        "mcap channel /solution/nav_frame kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /solution/pose (12001 messages)",
        "67a370ba2a9d6dd90b8b9d53788333e9",
    ),
    (
        "mcap channel /solution/pose kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /srs (600 messages)",
        "9b9cf44e7e56a139e3ace2eb24d2c301",
    ),
    (
        "mcap channel /srs kind",
        "polarnav.SrsSample protobuf protobuf",
    ),
    (
        "mcap channel /status (601 messages)",
        "00638c47623ea66c2554c3a99413850e",
    ),
    (
        "mcap channel /status kind",
        "polarnav.Status protobuf protobuf",
    ),
    (
        "mcap channel /tf/polar (240 messages)",
        "a5f00093bd0eeeecfca8819ad873773d",
    ),
    (
        "mcap channel /tf/polar kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /track (132 messages)",
        "f23bb05c0fba7a65c998e51a1389411c",
    ),
    (
        "mcap channel /track kind",
        "foxglove.SceneUpdate protobuf protobuf",
    ),
    (
        "mcap channel /truth (6001 messages)",
        "ff4471c73dd2d3c759de850c02e630b5",
    ),
    (
        "mcap channel /truth kind",
        "polarnav.Truth protobuf protobuf",
    ),
    (
        "mcap channel /truth/bias (6001 messages)",
        "d513a0355c151813ecc9165c1e84fa03",
    ),
    (
        "mcap channel /truth/bias kind",
        "polarnav.TruthBias protobuf protobuf",
    ),
    (
        "mcap channel /truth/fix (6001 messages)",
        "8fb6860cb1fb0c53eb135d753b7c3dc5",
    ),
    (
        "mcap channel /truth/fix kind",
        "foxglove.LocationFix protobuf protobuf",
    ),
    (
        "mcap metadata polarnav navlog_format_version",
        "4b227777d4dd1fc61c6f884f48641d02",
    ),
    (
        "mcap metadata polarnav producer",
        "e36fdc9ffba5c20f50e2dbb43062e9d3",
    ),
    (
        "mcap metadata polarnav scenario",
        "191433a7822e2a12b5e00463e525d779",
    ),
    (
        "mcap metadata polarnav seed",
        "6b86b273ff34fce19d6b804eff5a3f57",
    ),
    (
        "mcap metadata polarnav settings",
        "46e7239566a494c33753f32dd40b0c0c",
    ),
    (
        "mcap metadata polarnav.settings aids.baro_gate",
        "1d8f2f5a634f102a4239b08d1e02de7c",
    ),
    (
        "mcap metadata polarnav.settings aids.baro_timeout_s",
        "e0e52f9134bc43c86c9a86334a62371d",
    ),
    (
        "mcap metadata polarnav.settings aids.cns_gate",
        "a7f179c06cda107bb2997b1603304cdd",
    ),
    (
        "mcap metadata polarnav.settings aids.cns_timeout_s",
        "85c96579d43f9231a6a7bc5a24ab2447",
    ),
    (
        "mcap metadata polarnav.settings aids.fuse",
        "84a623c689bc4dee53b8c797bb783411",
    ),
    (
        "mcap metadata polarnav.settings aids.max_latency_s",
        "f55a7f89d28a61e37c473e2ae14c0720",
    ),
    (
        "mcap metadata polarnav.settings aids.reset_after_s",
        "f2a2c79961750a07e4ac0d3bb3b191b8",
    ),
    (
        "mcap metadata polarnav.settings aids.srs_gate",
        "282c3fa347a53ea4514ffcb56f6087f3",
    ),
    (
        "mcap metadata polarnav.settings aids.srs_timeout_s",
        "85c96579d43f9231a6a7bc5a24ab2447",
    ),
    (
        "mcap metadata polarnav.settings aids.star_gate",
        "282c3fa347a53ea4514ffcb56f6087f3",
    ),
    (
        "mcap metadata polarnav.settings aids.star_timeout_s",
        "85c96579d43f9231a6a7bc5a24ab2447",
    ),
    (
        "mcap metadata polarnav.settings filter.accel_bias_instability_ug",
        "47c557d8f80cef4229f53082647caaaa",
    ),
    (
        "mcap metadata polarnav.settings filter.accel_bias_tau_s",
        "ad46350d8f36e89b48c50bc454e5567e",
    ),
    (
        "mcap metadata polarnav.settings filter.accel_bias_ug",
        "4fc0a33e084cb47cac23b9c885817c5a",
    ),
    (
        "mcap metadata polarnav.settings filter.arw_dpsh",
        "33f9d74dbeab87d5f4df383f6417b544",
    ),
    (
        "mcap metadata polarnav.settings filter.coast_accel_mps2",
        "e0e52f9134bc43c86c9a86334a62371d",
    ),
    (
        "mcap metadata polarnav.settings filter.coast_rate_dps",
        "25586e62014d251af809746de2dd0a86",
    ),
    (
        "mcap metadata polarnav.settings filter.covariance_interval_s",
        "f55a7f89d28a61e37c473e2ae14c0720",
    ),
    (
        "mcap metadata polarnav.settings filter.gyro_bias_dph",
        "9440e96919541bf395d5d45dfb807b70",
    ),
    (
        "mcap metadata polarnav.settings filter.gyro_bias_instability_dph",
        "47c557d8f80cef4229f53082647caaaa",
    ),
    (
        "mcap metadata polarnav.settings filter.gyro_bias_tau_s",
        "ad46350d8f36e89b48c50bc454e5567e",
    ),
    (
        "mcap metadata polarnav.settings filter.imu_gap_s",
        "25586e62014d251af809746de2dd0a86",
    ),
    (
        "mcap metadata polarnav.settings filter.imu_max_coast_s",
        "5e4d94b2d016fd10461d674fd2d053e2",
    ),
    (
        "mcap metadata polarnav.settings filter.max_accel_mps2",
        "4118ec55309d033f3a03c62447a85fdd",
    ),
    (
        "mcap metadata polarnav.settings filter.max_gyro_rate_dps",
        "81b45efac824a14fb5220d771b32de66",
    ),
    (
        "mcap metadata polarnav.settings filter.vrw_ug_psqhz",
        "fbf8c338494153824839368bc682317d",
    ),
    (
        "mcap metadata polarnav.settings frame.conversion",
        "7cd4502f57a9c2a0e1248e7112673ed6",
    ),
    (
        "mcap metadata polarnav.settings frame.force_switch_s",
        "964d19e6c7aa40378f7a6b56a037391e",
    ),
    (
        "mcap metadata polarnav.settings frame.never_switch",
        "a875798c08c89f2c22bbe29c6bf796ee",
    ),
    (
        "mcap metadata polarnav.settings frame.switch_enter_deg",
        "4c110aaab9386ead4323990929d460bd",
    ),
    (
        "mcap metadata polarnav.settings frame.switch_leave_deg",
        "608ffa31d09315e9f8a33c0880339de0",
    ),
    (
        "mcap metadata polarnav.settings live.checkpoint_max_age_s",
        "9540e65075cc84744a6c21c967286cfa",
    ),
    (
        "mcap metadata polarnav.settings live.checkpoint_path",
        "d524a5d50d200ae78c881ec9a38bec9e",
    ),
    (
        "mcap metadata polarnav.settings live.checkpoint_period_s",
        "e0e52f9134bc43c86c9a86334a62371d",
    ),
    (
        "mcap metadata polarnav.settings live.imu_lost_periods",
        "b39aa946f4a862286db86407a4a5df57",
    ),
    (
        "mcap metadata polarnav.settings live.imu_rate_hz",
        "1127cadeb24ffc114c19afbfad9b12f5",
    ),
    (
        "mcap metadata polarnav.settings prefix",
        "c161bb6f873056430f7e64dc00805110",
    ),
    (
        "mcap schema foxglove.FrameTransform",
        "9fea4f3a750674751115b9c7c37f1928",
    ),
    (
        "mcap schema foxglove.LocationFix",
        "a4213392ac9030972d2a9d19df002349",
    ),
    (
        "mcap schema foxglove.Log",
        "5dfc92a009d203622d302ecc5bf24b99",
    ),
    (
        "mcap schema foxglove.SceneUpdate",
        "554b56b84b93d7e7af70af415a6bfd74",
    ),
    (
        "mcap schema polarnav.AidUpdate",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.BaroSample",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.CnsFix",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.ImuSample",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.InitState",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.Solution",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.SrsSample",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.Status",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.SwitchNote",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.Truth",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.TruthBias",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    ("navlog file", "914699176d50d0c7295a1f06a55a44a6"),
    (
        "navlog record 00 (1 frames)",
        "3b247386073ff9a78ca1576b377e5520",
    ),
    (
        "navlog record 01 (1 frames)",
        "467aee35000856caef7a5df3e8a5fc31",
    ),
    (
        "navlog record 02 (120000 frames)",
        "21fa0ae0a9bd530b5c99d1fa90570d7f",
    ),
    (
        "navlog record 03 (600 frames)",
        "0bf2e2f9a28f8fa280ff6850b0f3eb2d",
    ),
    (
        "navlog record 04 (600 frames)",
        "a357b3f98a7ab9a008bf27584d7fab35",
    ),
    (
        "navlog record 05 (6000 frames)",
        "64f1ec46699ef1a40b62fb6b1a9932bb",
    ),
    (
        "navlog record 06 (6001 frames)",
        "b4cddac3f460edee678e889ea22b0f0f",
    ),
    (
        "navlog record 10 (6001 frames)",
        "8c4bbd53571d66a745ab0ca858333936",
    ),
];

const TRANSPOLAR_STAR: &[(&str, &str)] = &[
    (
        "navlog after the header",
        "991f094815830e526354cd8839a146ce",
    ),
    ("navlog header format_version", "4"),
    ("navlog header magic", "b1e637967e362d257cafe4e7aef1935c"),
    ("navlog header metadata", "d23e4fcf915aa48e88fceb43bff350bd"),
    ("navlog header producer", "e36fdc9ffba5c20f50e2dbb43062e9d3"),
    ("navlog header scenario", "a56ce938935009d93b4dc3da8177d20b"),
    ("navlog header seed", "1"),
    ("csv column ba_x_mps2", "3a709af09bfb07a01da1b16ed504d18c"),
    ("csv column ba_y_mps2", "fdf9be0e5c4680319b40dab7f367d89b"),
    ("csv column ba_z_mps2", "1555c69e2f89f75e63e8d8eacaf2ab0d"),
    ("csv column baro_fresh", "fead8e0203471723ac47a17d66f131b6"),
    ("csv column bg_x_rps", "d2722ceb72d5d2c2e27468208881b17e"),
    ("csv column bg_y_rps", "eb35ad81d9d11f0a914e56506eafd3a1"),
    ("csv column bg_z_rps", "8adbc1f3b4e50f6ae82dbd1f7d62e5f1"),
    ("csv column cns_fresh", "085b224753cd8008c8524051e1eed702"),
    ("csv column coasting", "5e5a76ecf8c0864a16e4e5a33ed56b2c"),
    ("csv column flags", "d75ac8ba4e5079d866cd7e75c306e038"),
    ("csv column frame", "cb868e4c0bde49010f15c714b6dff6c7"),
    (
        "csv column grid_heading_deg",
        "da63ad577ed46cc99b5ac54a3f7ca5b2",
    ),
    ("csv column h_m", "7d7bd57e84bf1e65a5f5e10d29e6299c"),
    ("csv column heading_deg", "44b3e9090af3d33c9094ed16b4f9a6f7"),
    ("csv column imu_lost", "5e5a76ecf8c0864a16e4e5a33ed56b2c"),
    ("csv column lat_deg", "39204324d4719fc12cfdd5cbe8d2dff2"),
    ("csv column lon_deg", "e77d502aa83a2b37c10bb2193ac4ca7c"),
    ("csv column pitch_deg", "4a62a32dbde11ff4b612048b224cd069"),
    ("csv column qw", "d87a06562a6321690dbb9fe73b0f186f"),
    ("csv column qx", "cac81c7b4257f1b6b1eefa1687c30350"),
    ("csv column qy", "79c0c32768d80052a84deef6d630a360"),
    ("csv column qz", "ad9342588d96b96fdd1526983aa14b40"),
    ("csv column reset_count", "5e5a76ecf8c0864a16e4e5a33ed56b2c"),
    ("csv column roll_deg", "cd62b3aeace50cef5801202c70b0f9fb"),
    (
        "csv column sig_att_x_deg",
        "dbcacd5b033d4dada7ac9d48aabb0dc4",
    ),
    (
        "csv column sig_att_y_deg",
        "3f01f7d4f49aadb4bcc5ccea7d4446a3",
    ),
    (
        "csv column sig_att_z_deg",
        "1fb8965f2e8e1236d4eb24fb8103ecbb",
    ),
    (
        "csv column sig_ba_x_mps2",
        "841ada64c8a8dccdbea5255abbcfe5ac",
    ),
    (
        "csv column sig_ba_y_mps2",
        "4a08efec58a96c6713baf434cb43f2d0",
    ),
    (
        "csv column sig_ba_z_mps2",
        "a3695224c77bca25c3eb5ab1f78c6e66",
    ),
    (
        "csv column sig_bg_x_rps",
        "95ad5ecb7bf76af46202de8bf9a96906",
    ),
    (
        "csv column sig_bg_y_rps",
        "a985784d3bc2bff9a4aade031e9fcf0f",
    ),
    (
        "csv column sig_bg_z_rps",
        "4cd218ff5637241e2844e551336e609d",
    ),
    ("csv column sig_e_m", "8de43c59edd8b41957d591b085ae8711"),
    ("csv column sig_n_m", "355bd0e13c7aa28d074b65f3c83b1247"),
    ("csv column sig_u_m", "f662a32351d41d7c6ed6f8e0f648632b"),
    (
        "csv column sig_vnav_x_mps",
        "31ad163577c22823cdd6cd7fe315a138",
    ),
    (
        "csv column sig_vnav_y_mps",
        "25b5ecab6da2df6c5003fe5e98b7d603",
    ),
    (
        "csv column sig_vnav_z_mps",
        "2cf75f68de201dad01d3ba505b3e7491",
    ),
    ("csv column srs_fresh", "085b224753cd8008c8524051e1eed702"),
    (
        "csv column switch_count",
        "5e5a76ecf8c0864a16e4e5a33ed56b2c",
    ),
    ("csv column t_s", "c4458e9b38eac3c1937d68281636395c"),
    ("csv column ve_mps", "73232461e9c9f47df869d0f87871bd7a"),
    ("csv column vn_mps", "a2419dd9b6507bce90c003b4dcbf007f"),
    ("csv column vu_mps", "044d3e6ecdba40c47a113f13cc95a0f5"),
    ("csv column vx_mps", "09a2429fd1e02b8cc72201fd6f3f8415"),
    ("csv column vy_mps", "53c779ef44a97dd2c6adc0a0d0515be2"),
    ("csv column vz_mps", "9893b9dbf1ccde3c7c897c244418322e"),
    ("csv column x_m", "904d7921f9a1f793dd3682ddc8b513cc"),
    ("csv column y_m", "5d554e2a925ccdb64f66af0cc2cb5531"),
    ("csv column z_m", "845e5c38f99576c9333b5796d387e816"),
    ("csv header", "4b2a4db58ca566ad20824ab89b23c7ee"),
    ("csv rows", "896000"),
    (
        "mcap channel /aid/baro (44800 messages)",
        "2886caa683588ff4c99b5b6942e54fa1",
    ),
    (
        "mcap channel /aid/baro kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/cns (4480 messages)",
        "391aa5de66cb013f392c1a0df9fd4e4f",
    ),
    (
        "mcap channel /aid/cns kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/srs (4480 messages)",
        "c079d1652508d6abc1d9304e60e3efd7",
    ),
    (
        "mcap channel /aid/srs kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/star (4480 messages)",
        "3bd2115b607980cb96e2bd2e8d073924",
    ),
    (
        "mcap channel /aid/star kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /baro (44800 messages)",
        "cc7b90582600314ffbe0eb8ee1549816",
    ),
    (
        "mcap channel /baro kind",
        "polarnav.BaroSample protobuf protobuf",
    ),
    (
        "mcap channel /cns (4480 messages)",
        "ddf5cbed37c60b0d6afb2dd9b0739adf",
    ),
    (
        "mcap channel /cns kind",
        "polarnav.CnsFix protobuf protobuf",
    ),
    (
        "mcap channel /imu (896000 messages)",
        "5f27ff0625be9fb8fcbbfd7bd3337e16",
    ),
    (
        "mcap channel /imu kind",
        "polarnav.ImuSample protobuf protobuf",
    ),
    (
        "mcap channel /init (1 messages)",
        "2b6560af46310a445e17fcc59bc56b90",
    ),
    (
        "mcap channel /init kind",
        "polarnav.InitState protobuf protobuf",
    ),
    (
        "mcap channel /solution (896000 messages)",
        "8a95873084cc7566c2863723490c2efc",
    ),
    (
        "mcap channel /solution kind",
        "polarnav.Solution protobuf protobuf",
    ),
    (
        "mcap channel /solution/fix (89600 messages)",
        "e04b4bb05779522cf14e546e21c380df",
    ),
    (
        "mcap channel /solution/fix kind",
        "foxglove.LocationFix protobuf protobuf",
    ),
    (
        "mcap channel /solution/nav_frame (89600 messages)",
        "128bcda249a66267fd918a2a9cc107d3",
    ),
    (
        "mcap channel /solution/nav_frame kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /solution/pose (89600 messages)",
        "1423c326ade6cf592a4980166c3842fd",
    ),
    (
        "mcap channel /solution/pose kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /srs (4480 messages)",
        "b4cbbfa124ae7732c732a6ad89339c43",
    ),
    (
        "mcap channel /srs kind",
        "polarnav.SrsSample protobuf protobuf",
    ),
    (
        "mcap channel /star (4480 messages)",
        "22887712790a1bcc3d83a1c4c50a8ace",
    ),
    (
        "mcap channel /star kind",
        "polarnav.StarSample protobuf protobuf",
    ),
    (
        "mcap channel /status (4481 messages)",
        "020a58a5690f6c44f60c595e882f8db4",
    ),
    (
        "mcap channel /status kind",
        "polarnav.Status protobuf protobuf",
    ),
    (
        "mcap channel /tf/polar (1792 messages)",
        "9f7e2224f88a37ec8d35e06d205cdebd",
    ),
    (
        "mcap channel /tf/polar kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /track (971 messages)",
        "881058095404bfa39ff092c0fa49334c",
    ),
    (
        "mcap channel /track kind",
        "foxglove.SceneUpdate protobuf protobuf",
    ),
    (
        "mcap channel /truth (44801 messages)",
        "5830c1d5b45bb4a5026b954e53c6556b",
    ),
    (
        "mcap channel /truth kind",
        "polarnav.Truth protobuf protobuf",
    ),
    (
        "mcap channel /truth/bias (44801 messages)",
        "34937a28bb9ebdaf6fdf633725514f5f",
    ),
    (
        "mcap channel /truth/bias kind",
        "polarnav.TruthBias protobuf protobuf",
    ),
    (
        "mcap channel /truth/fix (44801 messages)",
        "989b4773d4998dc6f4a948b7ac47c846",
    ),
    (
        "mcap channel /truth/fix kind",
        "foxglove.LocationFix protobuf protobuf",
    ),
    (
        "mcap metadata polarnav navlog_format_version",
        "4b227777d4dd1fc61c6f884f48641d02",
    ),
    (
        "mcap metadata polarnav producer",
        "e36fdc9ffba5c20f50e2dbb43062e9d3",
    ),
    (
        "mcap metadata polarnav scenario",
        "a56ce938935009d93b4dc3da8177d20b",
    ),
    (
        "mcap metadata polarnav seed",
        "6b86b273ff34fce19d6b804eff5a3f57",
    ),
    (
        "mcap metadata polarnav settings",
        "d23e4fcf915aa48e88fceb43bff350bd",
    ),
    (
        "mcap metadata polarnav.settings aids.baro_gate",
        "1d8f2f5a634f102a4239b08d1e02de7c",
    ),
    (
        "mcap metadata polarnav.settings aids.baro_timeout_s",
        "e0e52f9134bc43c86c9a86334a62371d",
    ),
    (
        "mcap metadata polarnav.settings aids.cns_gate",
        "a7f179c06cda107bb2997b1603304cdd",
    ),
    (
        "mcap metadata polarnav.settings aids.cns_timeout_s",
        "85c96579d43f9231a6a7bc5a24ab2447",
    ),
    (
        "mcap metadata polarnav.settings aids.fuse",
        "84a623c689bc4dee53b8c797bb783411",
    ),
    (
        "mcap metadata polarnav.settings aids.max_latency_s",
        "f55a7f89d28a61e37c473e2ae14c0720",
    ),
    (
        "mcap metadata polarnav.settings aids.reset_after_s",
        "f2a2c79961750a07e4ac0d3bb3b191b8",
    ),
    (
        "mcap metadata polarnav.settings aids.srs_gate",
        "282c3fa347a53ea4514ffcb56f6087f3",
    ),
    (
        "mcap metadata polarnav.settings aids.srs_timeout_s",
        "85c96579d43f9231a6a7bc5a24ab2447",
    ),
    (
        "mcap metadata polarnav.settings aids.star_gate",
        "282c3fa347a53ea4514ffcb56f6087f3",
    ),
    (
        "mcap metadata polarnav.settings aids.star_timeout_s",
        "85c96579d43f9231a6a7bc5a24ab2447",
    ),
    (
        "mcap metadata polarnav.settings filter.accel_bias_instability_ug",
        "47c557d8f80cef4229f53082647caaaa",
    ),
    (
        "mcap metadata polarnav.settings filter.accel_bias_tau_s",
        "ad46350d8f36e89b48c50bc454e5567e",
    ),
    (
        "mcap metadata polarnav.settings filter.accel_bias_ug",
        "4fc0a33e084cb47cac23b9c885817c5a",
    ),
    (
        "mcap metadata polarnav.settings filter.arw_dpsh",
        "33f9d74dbeab87d5f4df383f6417b544",
    ),
    (
        "mcap metadata polarnav.settings filter.coast_accel_mps2",
        "e0e52f9134bc43c86c9a86334a62371d",
    ),
    (
        "mcap metadata polarnav.settings filter.coast_rate_dps",
        "25586e62014d251af809746de2dd0a86",
    ),
    (
        "mcap metadata polarnav.settings filter.covariance_interval_s",
        "f55a7f89d28a61e37c473e2ae14c0720",
    ),
    (
        "mcap metadata polarnav.settings filter.gyro_bias_dph",
        "9440e96919541bf395d5d45dfb807b70",
    ),
    (
        "mcap metadata polarnav.settings filter.gyro_bias_instability_dph",
        "47c557d8f80cef4229f53082647caaaa",
    ),
    (
        "mcap metadata polarnav.settings filter.gyro_bias_tau_s",
        "ad46350d8f36e89b48c50bc454e5567e",
    ),
    (
        "mcap metadata polarnav.settings filter.imu_gap_s",
        "25586e62014d251af809746de2dd0a86",
    ),
    (
        "mcap metadata polarnav.settings filter.imu_max_coast_s",
        "5e4d94b2d016fd10461d674fd2d053e2",
    ),
    (
        "mcap metadata polarnav.settings filter.max_accel_mps2",
        "4118ec55309d033f3a03c62447a85fdd",
    ),
    (
        "mcap metadata polarnav.settings filter.max_gyro_rate_dps",
        "81b45efac824a14fb5220d771b32de66",
    ),
    (
        "mcap metadata polarnav.settings filter.vrw_ug_psqhz",
        "fbf8c338494153824839368bc682317d",
    ),
    (
        "mcap metadata polarnav.settings frame.conversion",
        "7cd4502f57a9c2a0e1248e7112673ed6",
    ),
    (
        "mcap metadata polarnav.settings frame.force_switch_s",
        "964d19e6c7aa40378f7a6b56a037391e",
    ),
    (
        "mcap metadata polarnav.settings frame.never_switch",
        "a875798c08c89f2c22bbe29c6bf796ee",
    ),
    (
        "mcap metadata polarnav.settings frame.switch_enter_deg",
        "6637ae0bb9628769bca444ba4721c118",
    ),
    (
        "mcap metadata polarnav.settings frame.switch_leave_deg",
        "bc8373470e15e320cad4bb5a96dcbd94",
    ),
    (
        "mcap metadata polarnav.settings live.checkpoint_max_age_s",
        "9540e65075cc84744a6c21c967286cfa",
    ),
    (
        "mcap metadata polarnav.settings live.checkpoint_path",
        "d524a5d50d200ae78c881ec9a38bec9e",
    ),
    (
        "mcap metadata polarnav.settings live.checkpoint_period_s",
        "e0e52f9134bc43c86c9a86334a62371d",
    ),
    (
        "mcap metadata polarnav.settings live.imu_lost_periods",
        "b39aa946f4a862286db86407a4a5df57",
    ),
    (
        "mcap metadata polarnav.settings live.imu_rate_hz",
        "1127cadeb24ffc114c19afbfad9b12f5",
    ),
    (
        "mcap metadata polarnav.settings prefix",
        "c161bb6f873056430f7e64dc00805110",
    ),
    (
        "mcap schema foxglove.FrameTransform",
        "9fea4f3a750674751115b9c7c37f1928",
    ),
    (
        "mcap schema foxglove.LocationFix",
        "a4213392ac9030972d2a9d19df002349",
    ),
    (
        "mcap schema foxglove.SceneUpdate",
        "554b56b84b93d7e7af70af415a6bfd74",
    ),
    (
        "mcap schema polarnav.AidUpdate",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.BaroSample",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.CnsFix",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.ImuSample",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.InitState",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.Solution",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.SrsSample",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.StarSample",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.Status",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.Truth",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    (
        "mcap schema polarnav.TruthBias",
        "e173a73ad4e1f030ffc245ec09e674fe",
    ),
    ("navlog file", "f22ef9beda2a325c3d1778154cada85b"),
    (
        "navlog record 00 (1 frames)",
        "8da517296867866b4098fae2fada8fba",
    ),
    (
        "navlog record 01 (1 frames)",
        "06c8bda08227993fed73c267944f66dc",
    ),
    (
        "navlog record 02 (896000 frames)",
        "ccbb4818b4488595f64b586b7bbb67ac",
    ),
    (
        "navlog record 03 (4480 frames)",
        "33ba830caa04cbb0599c59e58ebe1ca5",
    ),
    (
        "navlog record 04 (4480 frames)",
        "ef4f013477e96ff34b7dfcc67ba83eeb",
    ),
    (
        "navlog record 05 (44800 frames)",
        "f5f95d374fc090c0b93c42ffa563c165",
    ),
    (
        "navlog record 06 (44801 frames)",
        "1cea7690c07b888bafc29662accc4c77",
    ),
    (
        "navlog record 09 (4480 frames)",
        "8541d1c9ed29a65f6787e8589c558bcf",
    ),
    (
        "navlog record 10 (44801 frames)",
        "781a7da86abfa65dff66d41d84e0cb31",
    ),
];
