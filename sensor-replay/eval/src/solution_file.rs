//! A solution to evaluate: the solution CSV, or an MCAP file written by
//! `nav-daemon batch --out F.mcap`, whose `/solution` messages give the
//! same rows and whose `/aid/*` messages give the innovations.

use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

use msgs::Solution;
use polarnav::solution_csv::{self, Row};
use serde::Deserialize;

/// One gated aid update as `/aid/srs`, `/aid/cns`, `/aid/baro`, `/aid/star` carry it
/// (`polarnav_foxglove::AidUpdate`; unknown fields ignored).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct AidPoint {
    pub t_ns: u64,
    pub innovation: [f64; 3],
    pub innovation_var: [f64; 3],
    pub test_ratio: f64,
    pub fused: u8,
}

impl AidPoint {
    /// Innovation component `k` over its standard deviation (unit-free);
    /// `None` for an unused component (zero variance).
    pub fn normalized(&self, k: usize) -> Option<f64> {
        let v = self.innovation_var[k];
        (v > 0.0 && v.is_finite()).then(|| self.innovation[k] / v.sqrt())
    }
}

/// The aid updates of a run, per aid.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Aids {
    pub srs: Vec<AidPoint>,
    pub cns: Vec<AidPoint>,
    pub baro: Vec<AidPoint>,
    pub star: Vec<AidPoint>,
}

/// A loaded solution.
#[derive(Debug, Clone, Default)]
pub struct Loaded {
    pub rows: Vec<Row>,
    /// Present for an MCAP solution.
    pub aids: Option<Aids>,
}

/// The longest MCAP record (a chunk, compressed or decompressed) eval reads.
pub const MAX_MCAP_RECORD_BYTES: usize = 64 << 20;

/// True for a file named `*.mcap`.
pub fn is_mcap(p: &Path) -> bool {
    p.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// Loads a solution CSV or (by extension) an MCAP file.
pub fn load(path: &Path) -> Result<Loaded, String> {
    if !is_mcap(path) {
        return solution_csv::read(path)
            .map(|rows| Loaded { rows, aids: None })
            .map_err(|e| e.to_string());
    }
    let p = path.display();
    let mut file = std::fs::File::open(path).map_err(|e| format!("{p}: {e}"))?;
    let mut rows = Vec::new();
    let mut aids = Aids::default();
    // Streamed record by record (chunks decompressed one at a time): memory
    // holds the rows, not the file, which carries every IMU sample too.
    let mut topic_of: HashMap<u16, String> = HashMap::new();
    // A record or chunk (compressed or not) longer than this is refused as
    // damage: a corrupt or hostile length must not make the reader allocate
    // it. The project's writers make 1 MiB chunks.
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default().with_record_length_limit(MAX_MCAP_RECORD_BYTES),
    );
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| format!("{p}: MCAP: {e}"))? {
            LinearReadEvent::ReadRequest(need) => {
                let n = file
                    .read(reader.insert(need))
                    .map_err(|e| format!("{p}: {e}"))?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, data } => {
                match mcap::parse_record(opcode, data).map_err(|e| format!("{p}: MCAP: {e}"))? {
                    Record::Channel(c) => {
                        topic_of.insert(c.id, c.topic);
                    }
                    Record::Message { header, data } => {
                        let topic = topic_of.get(&header.channel_id).map_or("", String::as_str);
                        let aid = match topic {
                            "/solution" => {
                                let s = solution_of_json(&data).map_err(|e| {
                                    format!("{p}: /solution message {}: {e}", header.sequence)
                                })?;
                                rows.push(Row::from_solution(&s));
                                continue;
                            }
                            "/aid/srs" => &mut aids.srs,
                            "/aid/cns" => &mut aids.cns,
                            "/aid/baro" => &mut aids.baro,
                            "/aid/star" => &mut aids.star,
                            _ => continue,
                        };
                        aid.push(serde_json::from_slice(&data).map_err(|e| {
                            format!("{p}: {topic} message {}: {e}", header.sequence)
                        })?);
                    }
                    _ => {}
                }
            }
        }
    }
    if rows.is_empty() {
        return Err(format!(
            "{p}: no /solution message (write it with nav-daemon batch --out FILE.mcap)"
        ));
    }
    // Chunks are in log-time order already; a stable sort keeps ties as written.
    rows.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    for v in [&mut aids.srs, &mut aids.cns, &mut aids.baro, &mut aids.star] {
        v.sort_by_key(|a| a.t_ns);
    }
    Ok(Loaded {
        rows,
        aids: Some(aids),
    })
}

/// A `/solution` JSON message (every `Solution` field but the zero padding).
fn solution_of_json(data: &[u8]) -> Result<Solution, serde_json::Error> {
    let mut v: serde_json::Value = serde_json::from_slice(data)?;
    if let Some(o) = v.as_object_mut() {
        o.entry("_pad")
            .or_insert_with(|| serde_json::json!([0, 0, 0]));
    }
    serde_json::from_value(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p =
            std::env::temp_dir().join(format!("polarnav-sf-{}-{name}.mcap", std::process::id()));
        std::fs::write(&p, bytes).expect("write");
        p
    }

    /// A record whose length field claims u64::MAX, 1e18 or just over the
    /// limit is refused as damage before anything of that size is allocated.
    #[test]
    fn an_absurd_record_length_is_refused_without_allocating_it() {
        for (k, len) in [
            u64::MAX,
            1_000_000_000_000_000_000,
            MAX_MCAP_RECORD_BYTES as u64 + 1,
        ]
        .into_iter()
        .enumerate()
        {
            let mut bytes = b"\x89MCAP0\r\n".to_vec();
            // A chunk (opcode 0x06) that says it is `len` bytes long.
            bytes.push(0x06);
            bytes.extend_from_slice(&len.to_le_bytes());
            bytes.extend_from_slice(&[0u8; 64]);
            let p = write(&format!("len{k}"), &bytes);
            let e = load(&p).expect_err("absurd length");
            assert!(e.contains("MCAP"), "{e}");
            let _ = std::fs::remove_file(&p);
        }
    }

    /// Not MCAP, or MCAP without any solution: an error that names the file.
    #[test]
    fn a_file_without_solutions_is_refused_naming_it() {
        let p = write("empty", b"\x89MCAP0\r\n");
        let e = load(&p).expect_err("no solution");
        assert!(e.contains(&p.display().to_string()), "{e}");
        let _ = std::fs::remove_file(&p);
        let p = write("text", b"t_s,frame\n1,g\n");
        assert!(load(&p).is_err());
        let _ = std::fs::remove_file(&p);
    }
}
