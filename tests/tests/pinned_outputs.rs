//! The outputs of two shipped flights, pinned item by item at f256bf8, the
//! commit before the aids were moved onto one declaration (issue 29): the
//! simulated navlog, `batch`'s solution CSV and `batch`'s MCAP of
//! `paper-sim.toml` (SRS, CNS, baro; a frame switch) and
//! `transpolar-star.toml` (the four aids, 1.24 h over the pole).
//!
//! Re-pinned once, by the change that made a campaign's run faster
//! (issue 41): the simulator takes one RK4 step per IMU interval instead of
//! two, and the ECEF → geodetic conversion gives the sines and cosines of
//! its angles from its own intermediates and takes a cube root of its own
//! (within 1 ulp of the correctly rounded one). Every number of the
//! simulated truth and of the solution moved in its last bits (the
//! increments by 1e-6 of the IMU noise of one sample); the names, sizes,
//! record counts, settings and schemas of every item stayed, and 100
//! `integrity-clean` flights flown on the same seeds before and after have
//! the same statistics (the commit's message gives them). Everything
//! listed below as changed or added since f256bf8 still was.
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
        "{scenario}: outputs differ from those pinned (at f256bf8, re-pinned for issue 41):\n{}",
        wrong.join("\n")
    );
}

#[test]
fn paper_sim_outputs_are_the_pinned_ones() {
    check("paper-sim", PAPER_SIM);
}

#[test]
fn transpolar_star_outputs_are_the_pinned_ones() {
    check("transpolar-star", TRANSPOLAR_STAR);
}

const PAPER_SIM: &[(&str, &str)] = &[
    (
        "navlog after the header",
        "ba2cfd3914ee93ba7644cedf93718f47",
    ),
    ("navlog header format_version", "4"),
    ("navlog header magic", "b1e637967e362d257cafe4e7aef1935c"),
    ("navlog header metadata", "46e7239566a494c33753f32dd40b0c0c"),
    ("navlog header producer", "e36fdc9ffba5c20f50e2dbb43062e9d3"),
    ("navlog header scenario", "191433a7822e2a12b5e00463e525d779"),
    ("navlog header seed", "1"),
    ("csv column ba_x_mps2", "4b227eeca3e4879576b9fe2ad63ef431"),
    ("csv column ba_y_mps2", "fb1d390935360c52f7f355420661d986"),
    ("csv column ba_z_mps2", "6a4163d6fb27bc610c06f798ff107656"),
    ("csv column baro_fresh", "bc7cded10b638d85073291f5408bc22f"),
    ("csv column bg_x_rps", "26a6946e0aebc255308dbb2a94cb6557"),
    ("csv column bg_y_rps", "9869c74aef00ea509e610a53b74e1001"),
    ("csv column bg_z_rps", "9d5fb4b99ff69d76113d0c36cc4ce2c2"),
    ("csv column cns_fresh", "976a3a9e7fc09208cc4be3032aeb9aae"),
    ("csv column coasting", "e1eef1c66b0c352b8857733acaf21a9f"),
    ("csv column flags", "723257bccbce0399e4e8f4687aa580e1"),
    ("csv column frame", "229ac40203aeedf5a6f9a15e89a7e374"),
    (
        "csv column grid_heading_deg",
        "1c9f753a9586b168a716f36258a5c8a9",
    ),
    ("csv column h_m", "5980d2c5b7565cb35351c21daf04c372"),
    ("csv column heading_deg", "5fbd2e74b2e4daa8c534280bc6024cc5"),
    ("csv column imu_lost", "e1eef1c66b0c352b8857733acaf21a9f"),
    ("csv column lat_deg", "8018d876f965cba58e4f3d2710ef9884"),
    ("csv column lon_deg", "d4129cb677d28611c68fe3bc20bb75d7"),
    ("csv column pitch_deg", "e10725f7a880f16fa6082b5472afbc3f"),
    ("csv column qw", "53705cfd744cc1407897d14e45c2cb23"),
    ("csv column qx", "1ca465fb757ed911202e4e67e46bd07f"),
    ("csv column qy", "edf0df70a77e7903895c59ea68bba9dd"),
    ("csv column qz", "b908a8dfebed43e12e799bfb83875859"),
    ("csv column reset_count", "e1eef1c66b0c352b8857733acaf21a9f"),
    ("csv column roll_deg", "6cdd7370527111159f389c415dbacc9d"),
    (
        "csv column sig_att_x_deg",
        "6cad725df1b7caa7b9930f255a1fc883",
    ),
    (
        "csv column sig_att_y_deg",
        "2b79efe6ffbcefb58ec99a43a1d43934",
    ),
    (
        "csv column sig_att_z_deg",
        "388c40d3a1d512d8cf5a4e66c7b29ebb",
    ),
    (
        "csv column sig_ba_x_mps2",
        "b1c41ac17622b0fb8eae1cc7e24dfcee",
    ),
    (
        "csv column sig_ba_y_mps2",
        "f7bbf0b9397f8e0d703d573d3f7a5251",
    ),
    (
        "csv column sig_ba_z_mps2",
        "776ba92a3783b6154052c86386a5b9b4",
    ),
    (
        "csv column sig_bg_x_rps",
        "980316b2126bd27028934bc4851f4256",
    ),
    (
        "csv column sig_bg_y_rps",
        "58ebbc98f12e711c9d6ab2528b8f248a",
    ),
    (
        "csv column sig_bg_z_rps",
        "588289bb66ebffc13dbe9ac7c01923ab",
    ),
    ("csv column sig_e_m", "9379eec60e41d0603bc4607f322da443"),
    ("csv column sig_n_m", "49319f041c26776cbbfbef02ee6e38fb"),
    ("csv column sig_u_m", "0c61a8d059d8d0e3dc4ad8db9e784c06"),
    (
        "csv column sig_vnav_x_mps",
        "760b933b99b47fa56bc5b76cca96c74c",
    ),
    (
        "csv column sig_vnav_y_mps",
        "89272d9ec6a6acdca5709ee3d2b43d9b",
    ),
    (
        "csv column sig_vnav_z_mps",
        "e13ababb6f44814fe065fe054687f14c",
    ),
    ("csv column srs_fresh", "976a3a9e7fc09208cc4be3032aeb9aae"),
    (
        "csv column switch_count",
        "cf142a6e2e8ffa439f8f04b35a419cc1",
    ),
    ("csv column t_s", "6535bdf0f2b681124fe714f9033746c2"),
    ("csv column ve_mps", "957ce37bb64dfd66140aae083e0b4aea"),
    ("csv column vn_mps", "14f436090981b4341c46a7338c45fd80"),
    ("csv column vu_mps", "c8baafe0c35d936dcc426b57fd36b752"),
    ("csv column vx_mps", "679717761f66398b137249cd857ed459"),
    ("csv column vy_mps", "1a7d32ea91fb0870abc16d2ed6e5aa95"),
    ("csv column vz_mps", "8e6e6385e1046bc54f4401f5afc73b88"),
    ("csv column x_m", "e5b0853c8523e9aff204b1dca3432b06"),
    ("csv column y_m", "f549978797bd3a71f337b8567efe9bf8"),
    ("csv column z_m", "2a90bb06847ef401426ff9ee2f38d0e8"),
    ("csv header", "4b2a4db58ca566ad20824ab89b23c7ee"),
    ("csv rows", "120000"),
    (
        "mcap channel /aid/baro (6000 messages)",
        "1d50a1b44d81a97e5cfccd085574e22d",
    ),
    (
        "mcap channel /aid/baro kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/cns (600 messages)",
        "23ef47c5074b2442024b2e94cdbac43c",
    ),
    (
        "mcap channel /aid/cns kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/srs (600 messages)",
        "c43565b9bd19974cc0977dcd38210a2b",
    ),
    (
        "mcap channel /aid/srs kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /baro (6000 messages)",
        "3a4278c4976a4d19a5d116887de7b856",
    ),
    (
        "mcap channel /baro kind",
        "polarnav.BaroSample protobuf protobuf",
    ),
    (
        "mcap channel /cns (600 messages)",
        "f01048509d09ec949640ec1caf2c22eb",
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
        "9995f7879051e5e800888a4e58d34f45",
    ),
    (
        "mcap channel /events/switch kind",
        "polarnav.SwitchNote protobuf protobuf",
    ),
    (
        "mcap channel /imu (120000 messages)",
        "f116c1d9cddbb228ec9aa6a8d67dd609",
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
        "23d902bbefccbe2131051be6667f71a7",
    ),
    (
        "mcap channel /solution kind",
        "polarnav.Solution protobuf protobuf",
    ),
    (
        "mcap channel /solution/fix (12001 messages)",
        "86bb8fa16df5ac6495fe9499135d1b92",
    ),
    (
        "mcap channel /solution/fix kind",
        "foxglove.LocationFix protobuf protobuf",
    ),
    (
        "mcap channel /solution/nav_frame (12001 messages)",
        "9c47ac1ea0e357f8a0e820cc1fea81c8",
    ),
    (
        "mcap channel /solution/nav_frame kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /solution/pose (12001 messages)",
        "7a5654a91ff715d0748f01d9a7966c61",
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
        "550a0b4536dc332f9df7ba2e4231f548",
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
        "d14f9b7c10393fbd53f2d44184bb9a6c",
    ),
    (
        "mcap channel /track kind",
        "foxglove.SceneUpdate protobuf protobuf",
    ),
    (
        "mcap channel /truth (6001 messages)",
        "618ff5d0ba77430912869fd19f02626a",
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
        "7e58cb4565fc133eed220c3aae6cc57c",
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
        "f1ed3327b42322e4abfd72b32401952c",
    ),
    (
        "navlog record 03 (600 frames)",
        "0bf2e2f9a28f8fa280ff6850b0f3eb2d",
    ),
    (
        "navlog record 04 (600 frames)",
        "5f447dbe4abe5a249690925ddbc9b7f8",
    ),
    (
        "navlog record 05 (6000 frames)",
        "e8e1c319877cfae20e3eecddf35d1343",
    ),
    (
        "navlog record 06 (6001 frames)",
        "c0fc44a098f12c3a6cc28ac265573926",
    ),
    (
        "navlog record 10 (6001 frames)",
        "8c4bbd53571d66a745ab0ca858333936",
    ),
];

const TRANSPOLAR_STAR: &[(&str, &str)] = &[
    (
        "navlog after the header",
        "808936cf883209f4a75c5c6ddb19358f",
    ),
    ("navlog header format_version", "4"),
    ("navlog header magic", "b1e637967e362d257cafe4e7aef1935c"),
    ("navlog header metadata", "d23e4fcf915aa48e88fceb43bff350bd"),
    ("navlog header producer", "e36fdc9ffba5c20f50e2dbb43062e9d3"),
    ("navlog header scenario", "a56ce938935009d93b4dc3da8177d20b"),
    ("navlog header seed", "1"),
    ("csv column ba_x_mps2", "82b395ccf162c450a72fb2f9e6c0fb49"),
    ("csv column ba_y_mps2", "3b8c62ddad64718fb7c9ce9215273beb"),
    ("csv column ba_z_mps2", "5d7b86c0cbe1a914ef0bc5cc17e2d848"),
    ("csv column baro_fresh", "fead8e0203471723ac47a17d66f131b6"),
    ("csv column bg_x_rps", "aba1e7e63db414145bb53992aff1d75a"),
    ("csv column bg_y_rps", "bea36bbe4aea14b59561e9289419828a"),
    ("csv column bg_z_rps", "2e84d3b7f2c3f7be85416ab6a923bcfc"),
    ("csv column cns_fresh", "085b224753cd8008c8524051e1eed702"),
    ("csv column coasting", "5e5a76ecf8c0864a16e4e5a33ed56b2c"),
    ("csv column flags", "d75ac8ba4e5079d866cd7e75c306e038"),
    ("csv column frame", "cb868e4c0bde49010f15c714b6dff6c7"),
    (
        "csv column grid_heading_deg",
        "e190558dc67fff35e6975e6221fc27fa",
    ),
    ("csv column h_m", "71d3ad8557eab6060e9f1b02c327321b"),
    ("csv column heading_deg", "d8e8e68d2aea29ec0cf612719a269d49"),
    ("csv column imu_lost", "5e5a76ecf8c0864a16e4e5a33ed56b2c"),
    ("csv column lat_deg", "7025c21ae3e994476fd88f41a86bf99d"),
    ("csv column lon_deg", "6f081c002d8f4a73f065ac0207d0d853"),
    ("csv column pitch_deg", "f130d6e944fff533584c10cda14cbdf6"),
    ("csv column qw", "74acecab0b7e14fac52e27e56fab1371"),
    ("csv column qx", "357726a62ca7210fae9c86bfc1b0f09a"),
    ("csv column qy", "5dae80eaab4e41c44d958ba1ce068321"),
    ("csv column qz", "acd0d2e75df71e92d50461840c8ce22e"),
    ("csv column reset_count", "5e5a76ecf8c0864a16e4e5a33ed56b2c"),
    ("csv column roll_deg", "9537a5554638853f1a1ae906318b007d"),
    (
        "csv column sig_att_x_deg",
        "75c5c4b57fcb06439a47ba5f3d81fb0a",
    ),
    (
        "csv column sig_att_y_deg",
        "17ea65689773ebcf7e2d12821524428e",
    ),
    (
        "csv column sig_att_z_deg",
        "a31c80ca34f084e0ad32b73b8c8db1b9",
    ),
    (
        "csv column sig_ba_x_mps2",
        "b7bfb4b38da3ef6a8fb2dc4a59dc02e9",
    ),
    (
        "csv column sig_ba_y_mps2",
        "96c64ea7f1bb8a4486695e5779171332",
    ),
    (
        "csv column sig_ba_z_mps2",
        "b8f78f202ddb989aab5d45435d037e7d",
    ),
    (
        "csv column sig_bg_x_rps",
        "ef8470890be9539f175ab40f75769309",
    ),
    (
        "csv column sig_bg_y_rps",
        "694648c8164f10237c8305bc7fbabf9c",
    ),
    (
        "csv column sig_bg_z_rps",
        "72c8844d694b2245ee478c9847adf7e0",
    ),
    ("csv column sig_e_m", "b6d623f00ae0b6e6fe65c2d6d83a045a"),
    ("csv column sig_n_m", "052e09f93025054d756c2742fdf2e863"),
    ("csv column sig_u_m", "7a4b1cf0b056e5ebc5c0563e127bc2f6"),
    (
        "csv column sig_vnav_x_mps",
        "de6625d403e2c450c95511072913b26f",
    ),
    (
        "csv column sig_vnav_y_mps",
        "022f90a9baed99b4f14a6bce78d7231d",
    ),
    (
        "csv column sig_vnav_z_mps",
        "1cf8ee8929045f99f84927bb9b05a2bd",
    ),
    ("csv column srs_fresh", "085b224753cd8008c8524051e1eed702"),
    (
        "csv column switch_count",
        "5e5a76ecf8c0864a16e4e5a33ed56b2c",
    ),
    ("csv column t_s", "c4458e9b38eac3c1937d68281636395c"),
    ("csv column ve_mps", "4204df4bc1d6f0ab14cbd93f9122ed55"),
    ("csv column vn_mps", "871cdf407620b0a3bdb705903469d59f"),
    ("csv column vu_mps", "5b552f1102cc0bafaa3666b2d66c30ce"),
    ("csv column vx_mps", "fefa2e5df9fe26d60e2a8e88080aea7b"),
    ("csv column vy_mps", "1045198b1e4e0e8a0fdf2502b3399acd"),
    ("csv column vz_mps", "34a159849920ff213f21bd16b9524f2d"),
    ("csv column x_m", "af72c6fe4ca0ee95e4df47a75a90da39"),
    ("csv column y_m", "83ee8c130c420912bfecafa21843ba72"),
    ("csv column z_m", "bc77c902dfdfe8ff846f0462aeea9c23"),
    ("csv header", "4b2a4db58ca566ad20824ab89b23c7ee"),
    ("csv rows", "896000"),
    (
        "mcap channel /aid/baro (44800 messages)",
        "25eb17919d819a4e5f68cc200ec0fdb2",
    ),
    (
        "mcap channel /aid/baro kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/cns (4480 messages)",
        "9c60464e80efa5abffa1297f422e3dbd",
    ),
    (
        "mcap channel /aid/cns kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/srs (4480 messages)",
        "3dc29b6ad05655601001d5341337ee26",
    ),
    (
        "mcap channel /aid/srs kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /aid/star (4480 messages)",
        "2dc4ed4e0f0cdb8183a2619f33784680",
    ),
    (
        "mcap channel /aid/star kind",
        "polarnav.AidUpdate protobuf protobuf",
    ),
    (
        "mcap channel /baro (44800 messages)",
        "c81cf61cd6c66b19d12decf4917c5ba3",
    ),
    (
        "mcap channel /baro kind",
        "polarnav.BaroSample protobuf protobuf",
    ),
    (
        "mcap channel /cns (4480 messages)",
        "a4737482a2b63cd9b7f51d62c5b6804c",
    ),
    (
        "mcap channel /cns kind",
        "polarnav.CnsFix protobuf protobuf",
    ),
    (
        "mcap channel /imu (896000 messages)",
        "afa8a7e5f33403ce8e38b21e40646847",
    ),
    (
        "mcap channel /imu kind",
        "polarnav.ImuSample protobuf protobuf",
    ),
    (
        "mcap channel /init (1 messages)",
        "bde240dc421bcf52f8d494e3e9fe1c90",
    ),
    (
        "mcap channel /init kind",
        "polarnav.InitState protobuf protobuf",
    ),
    (
        "mcap channel /solution (896000 messages)",
        "9b048310ee3864db7c0ec2e9660d0bfb",
    ),
    (
        "mcap channel /solution kind",
        "polarnav.Solution protobuf protobuf",
    ),
    (
        "mcap channel /solution/fix (89600 messages)",
        "45e4682258046445820a1cee0ecb56bd",
    ),
    (
        "mcap channel /solution/fix kind",
        "foxglove.LocationFix protobuf protobuf",
    ),
    (
        "mcap channel /solution/nav_frame (89600 messages)",
        "4783100fb3ece71ffdb3fac247ace80b",
    ),
    (
        "mcap channel /solution/nav_frame kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /solution/pose (89600 messages)",
        "258f379c3157e24aedc22af9b27145c4",
    ),
    (
        "mcap channel /solution/pose kind",
        "foxglove.FrameTransform protobuf protobuf",
    ),
    (
        "mcap channel /srs (4480 messages)",
        "e4a5c3eee94d267c320d2911b9813ff7",
    ),
    (
        "mcap channel /srs kind",
        "polarnav.SrsSample protobuf protobuf",
    ),
    (
        "mcap channel /star (4480 messages)",
        "ad058f0bb710ca5e67cedcac4aa09f1d",
    ),
    (
        "mcap channel /star kind",
        "polarnav.StarSample protobuf protobuf",
    ),
    (
        "mcap channel /status (4481 messages)",
        "511acf6df1eeeb21e10df9184c32d405",
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
        "b9a4852cca745715e6c523ae01f55ca3",
    ),
    (
        "mcap channel /track kind",
        "foxglove.SceneUpdate protobuf protobuf",
    ),
    (
        "mcap channel /truth (44801 messages)",
        "f067d8ef6e8a0d2b60520a538849d4c2",
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
        "4cb1121ef967ebe9fcd43a3c588e2a81",
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
        "b288ac7adf01977696abd6e53ed68bdf",
    ),
    (
        "navlog record 02 (896000 frames)",
        "7e939548053b4fedb70cee0d8d39275d",
    ),
    (
        "navlog record 03 (4480 frames)",
        "e41f601e7a2d4380a2dcbf96c8450561",
    ),
    (
        "navlog record 04 (4480 frames)",
        "0361e90cedc46f9237dc01c38341a325",
    ),
    (
        "navlog record 05 (44800 frames)",
        "66a1bdff01249edc470972bccb7fdfab",
    ),
    (
        "navlog record 06 (44801 frames)",
        "61f1a716b7ac6e323f8f659daf10fe32",
    ),
    (
        "navlog record 09 (4480 frames)",
        "5d740bf3783ddd9a3ad657b6472e7e8b",
    ),
    (
        "navlog record 10 (44801 frames)",
        "781a7da86abfa65dff66d41d84e0cb31",
    ),
];
