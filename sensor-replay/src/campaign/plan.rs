//! The campaign file and its run list.
//!
//! A campaign file (TOML; `config/campaigns/*.toml`) declares the flights,
//! a matrix of variations over them, how many seeds each variation is
//! flown with, and what each run does:
//!
//! ```toml
//! name = "integrity-spoof"
//! description = "every spoofer profile, its start and direction swept"
//! # Scenario files, relative to this file.
//! scenarios = ["../scenarios/gnss/spoof-drag-0.01.toml", "../scenarios/gnss/spoof-meaconing.toml"]
//!
//! [seeds]
//! base = 41     # the campaign's seed: run i flies with seed splitmix64(base + i·φ)
//! count = 25    # flights of every variation
//!
//! [matrix]      # every axis is optional; the run list is their product
//! preset = ["scenario", "mems"]          # --preset; "scenario": the scenario's own
//! aids = ["scenario", "srs,cns,baro"]    # --aids; "scenario": the scenario's own
//! conversion = ["paper", "none"]         # --conversion
//! gnss = ["on", "off"]                   # off: the scenario's [gnss] section removed
//! [matrix.set]  # scenario keys swept, by dotted path (array elements by index)
//! "faults.event.0.start_s" = [300.0, 500.0]
//! "faults.event.0.azimuth_deg" = [0.0, 90.0, 180.0, 270.0]
//!
//! [run]
//! kind = "navigate"      # or "fault-judge": also the fault-free twin, judged as the fault campaign
//! every_s = 1.0          # compare with the truth every this many seconds (0: every truth record)
//! smooth = false         # evaluate batch --smooth's smoothed solution instead of the forward one
//! duration_s = 600.0     # cut every flight to this long (a smoke test of a long campaign)
//! timeout_s = 1800.0     # a run still going after this (wall clock) is killed and fails
//! keep = ["accuracy", "nees", "events", "integrity", "faults"]   # metric groups kept
//! ```
//!
//! The run list: `variations × count` runs; run `i` flies variation
//! `i mod V` (V the number of variations, in the matrix's order:
//! scenarios outermost, then preset, aids, conversion, gnss and the `set`
//! keys sorted by name, each axis in its values' order) for the
//! `i div V`-th time. So the first V runs (`--only 0..V`) are one flight of
//! every variation, and the list only grows at its end when `count` does.
//! A run's seed is a function of the base seed and `i` alone
//! ([`seed_of`]), so run `i` is the same flight on any machine and under
//! any executor.
//!
//! Errors name the file and the key. A campaign is frozen into its result
//! directory ([`Frozen`]): the campaign file's text and every scenario's,
//! so that later edits of the files cannot change what a resumed or
//! cluster run flies, and the SHA-256 of that text names the campaign.

use std::path::{Path, PathBuf};

use polarnav::settings::{AidSet, Conversion, SensorGrade};
use polarnav_config::CliOverrides;
use polarnav_sim::scenario::Scenario;
use serde::{Deserialize, Serialize};

/// The most runs a campaign may list (a typo of `count` should not plan
/// 10¹⁵ flights).
pub const MAX_RUNS: u64 = 100_000_000;
/// The most variations.
pub const MAX_VARIATIONS: usize = 100_000;
/// Bounds of `timeout_s`, `duration_s` and `every_s` (s).
pub const TIMEOUT_RANGE_S: (f64, f64) = (1.0, 7.0 * 86_400.0);
pub const DURATION_RANGE_S: (f64, f64) = (1.0, 30.0 * 86_400.0);
pub const EVERY_RANGE_S: (f64, f64) = (0.0, 86_400.0);

/// What a campaign file says (the file's own keys, unknown ones refused).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampaignFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub scenarios: Vec<String>,
    pub seeds: Seeds,
    #[serde(default)]
    pub matrix: Matrix,
    #[serde(default)]
    pub run: RunSpec,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Seeds {
    pub base: u64,
    pub count: u64,
}

/// The axes of the variation matrix. An absent axis is the scenario's own.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Matrix {
    pub preset: Option<Vec<String>>,
    pub aids: Option<Vec<String>>,
    pub conversion: Option<Vec<String>>,
    pub gnss: Option<Vec<String>>,
    /// Scenario keys swept: dotted path → values (in the file's order).
    #[serde(default)]
    pub set: toml::Table,
}

/// What every run does.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunSpec {
    pub kind: RunKind,
    pub every_s: f64,
    pub smooth: bool,
    pub duration_s: Option<f64>,
    pub timeout_s: f64,
    pub keep: Vec<Group>,
}

impl Default for RunSpec {
    fn default() -> Self {
        Self {
            kind: RunKind::Navigate,
            every_s: 0.0,
            smooth: false,
            duration_s: None,
            timeout_s: 3600.0,
            keep: Group::ALL.to_vec(),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RunKind {
    /// Simulate the flight and navigate it as `batch` does.
    Navigate,
    /// Also the fault-free twin, and judge the faulted flight against it
    /// as the fault campaign does ([`super::faults`]).
    FaultJudge,
}

/// Groups of metrics a campaign keeps (the others are null in its table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Group {
    /// RMSE and maximum of the horizontal, vertical, velocity and attitude errors.
    Accuracy,
    /// Mean position, velocity and attitude NEES.
    Nees,
    /// Frame switches, resets and their causes, re-initializations.
    Events,
    /// GNSS fixes tested, exclusions, readmissions, false exclusions, largest q.
    Integrity,
    /// The injected fault: time to exclusion and error then, or missed.
    Faults,
}

impl Group {
    pub const ALL: [Group; 5] = [
        Group::Accuracy,
        Group::Nees,
        Group::Events,
        Group::Integrity,
        Group::Faults,
    ];
}

/// A campaign error: the file, the key, and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {key}: {why}")]
pub struct PlanError {
    pub file: String,
    pub key: String,
    pub why: String,
}

/// A campaign as it is frozen in its result directory: its file's text and
/// every scenario's, as read when it was first run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Frozen {
    /// The campaign file's path as given when it was first run (for messages).
    pub file: String,
    pub text: String,
    /// Each of `scenarios`, in order: its path as written and its text.
    pub scenarios: Vec<(String, String)>,
}

impl Frozen {
    /// Reads a campaign file and the scenarios it names.
    pub fn read(path: &Path) -> Result<Self, PlanError> {
        let file = path.display().to_string();
        let err = |key: &str, why: String| PlanError {
            file: file.clone(),
            key: key.into(),
            why,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err("(file)", e.to_string()))?;
        let cf = parse_file(&file, &text)?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut scenarios = Vec::new();
        for (i, s) in cf.scenarios.iter().enumerate() {
            let p: PathBuf = base.join(s);
            let t = std::fs::read_to_string(&p)
                .map_err(|e| err(&format!("scenarios[{i}]"), format!("{}: {e}", p.display())))?;
            scenarios.push((s.clone(), t));
        }
        Ok(Frozen {
            file,
            text,
            scenarios,
        })
    }

    /// The SHA-256 that names the campaign: of the campaign file's text and
    /// every scenario's, each preceded by its length (so no two different
    /// sets of texts hash alike by moving bytes between them).
    pub fn sha256(&self) -> String {
        let mut b = Vec::new();
        for t in std::iter::once(&self.text).chain(self.scenarios.iter().map(|(_, t)| t)) {
            b.extend_from_slice(&(t.len() as u64).to_le_bytes());
            b.extend_from_slice(t.as_bytes());
        }
        super::store::sha256_hex(&b)
    }
}

fn parse_file(file: &str, text: &str) -> Result<CampaignFile, PlanError> {
    toml::from_str::<CampaignFile>(text).map_err(|e| {
        let at = e.span().map(|s| s.start.min(text.len()));
        PlanError {
            file: file.to_owned(),
            key: at.map_or_else(|| "(file)".to_owned(), |at| key_at(text, at)),
            why: match at {
                Some(at) => format!(
                    "line {}: {}",
                    text[..at].matches('\n').count() + 1,
                    e.message().trim()
                ),
                None => e.message().trim().to_owned(),
            },
        }
    })
}

/// The dotted key of the TOML text at byte `at`: the table header above
/// it and the key of its line (`run.keep`, `seeds.count`), or the header
/// alone for an error on a header line.
fn key_at(text: &str, at: usize) -> String {
    let mut table = String::new();
    let mut line_start = 0;
    for line in text.split_inclusive('\n') {
        let end = line_start + line.len();
        let t = line.trim();
        if t.starts_with('[') {
            table = t.trim_matches(|c| c == '[' || c == ']').trim().to_owned();
        }
        if at < end || end == text.len() {
            let key = t
                .split_once('=')
                .map(|(k, _)| k.trim().trim_matches('"').to_owned())
                .filter(|_| !t.starts_with('['));
            return match (table.is_empty(), key) {
                (_, None) if table.is_empty() => "(file)".into(),
                (_, None) => table,
                (true, Some(k)) => k,
                (false, Some(k)) => format!("{table}.{k}"),
            };
        }
        line_start = end;
    }
    "(file)".into()
}

/// The seed of run `index`: SplitMix64's finalizer of `base + index·φ`
/// (φ = 2⁶⁴/golden ratio, odd, so distinct indices give distinct inputs,
/// and the finalizer is a bijection: distinct seeds for every index of a
/// campaign).
pub fn seed_of(base: u64, index: u64) -> u64 {
    let mut z = base.wrapping_add(index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// One point of the matrix: a scenario as it will be flown, and the
/// navigator's command-line settings.
#[derive(Debug, Clone)]
pub struct Variation {
    pub label: String,
    /// The scenario's text after the variation's edits (what the navlog's
    /// header carries), and the scenario parsed from it.
    pub text: String,
    pub scenario: Scenario,
    pub overrides: CliOverrides,
}

/// A campaign ready to run: its variations and run list.
#[derive(Debug, Clone)]
pub struct Plan {
    pub name: String,
    pub description: String,
    pub sha256: String,
    pub seeds: Seeds,
    pub run: RunSpec,
    pub variations: Vec<Variation>,
}

/// One run of the list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunId {
    pub index: u64,
    pub variation: usize,
    pub replicate: u64,
    pub seed: u64,
}

impl Plan {
    /// Builds the plan of a frozen campaign: every variation's scenario
    /// edited, parsed and checked as the simulator checks a scenario file.
    pub fn new(f: &Frozen) -> Result<Self, PlanError> {
        let err = |key: &str, why: String| PlanError {
            file: f.file.clone(),
            key: key.into(),
            why,
        };
        let cf = parse_file(&f.file, &f.text)?;
        if cf.name.trim().is_empty() {
            return Err(err("name", "is empty".into()));
        }
        if cf.scenarios.is_empty() {
            return Err(err("scenarios", "names no scenario".into()));
        }
        if cf.scenarios.len() != f.scenarios.len() {
            return Err(err(
                "scenarios",
                "the frozen campaign lacks some scenario texts".into(),
            ));
        }
        if cf.seeds.count == 0 || cf.seeds.count > MAX_RUNS {
            return Err(err(
                "seeds.count",
                format!("{} is outside 1 ..= {MAX_RUNS}", cf.seeds.count),
            ));
        }
        let r = &cf.run;
        let in_range = |x: f64, (lo, hi): (f64, f64)| x.is_finite() && x >= lo && x <= hi;
        if !in_range(r.timeout_s, TIMEOUT_RANGE_S) {
            return Err(err(
                "run.timeout_s",
                format!("{} s is outside {TIMEOUT_RANGE_S:?} s", r.timeout_s),
            ));
        }
        if !in_range(r.every_s, EVERY_RANGE_S) {
            return Err(err(
                "run.every_s",
                format!("{} s is outside {EVERY_RANGE_S:?} s", r.every_s),
            ));
        }
        if let Some(d) = r.duration_s
            && !in_range(d, DURATION_RANGE_S)
        {
            return Err(err(
                "run.duration_s",
                format!("{d} s is outside {DURATION_RANGE_S:?} s"),
            ));
        }
        if r.keep.is_empty() {
            return Err(err("run.keep", "keeps no metric".into()));
        }

        // The axes, each checked.
        let axis = |key: &str, v: &Option<Vec<String>>| -> Result<Vec<Option<String>>, PlanError> {
            match v {
                None => Ok(vec![None]),
                Some(v) if v.is_empty() => Err(err(&format!("matrix.{key}"), "is empty".into())),
                Some(v) => Ok(v
                    .iter()
                    .map(|x| (x != "scenario").then(|| x.clone()))
                    .collect()),
            }
        };
        let presets = axis("preset", &cf.matrix.preset)?;
        for p in presets.iter().flatten() {
            SensorGrade::parse(p).map_err(|e| err("matrix.preset", e))?;
        }
        let aids = axis("aids", &cf.matrix.aids)?;
        for a in aids.iter().flatten() {
            AidSet::parse(a).map_err(|e| err("matrix.aids", e))?;
        }
        let conversions = axis("conversion", &cf.matrix.conversion)?;
        for c in conversions.iter().flatten() {
            conversion(c).map_err(|e| err("matrix.conversion", e))?;
        }
        let gnss = axis("gnss", &cf.matrix.gnss)?;
        for g in gnss.iter().flatten() {
            if g != "on" && g != "off" {
                return Err(err(
                    "matrix.gnss",
                    format!("{g:?}: expected \"on\", \"off\" or \"scenario\""),
                ));
            }
        }
        let mut sets: Vec<(String, Vec<toml::Value>)> = Vec::new();
        for (k, v) in &cf.matrix.set {
            let key = format!("matrix.set.\"{k}\"");
            let toml::Value::Array(vals) = v else {
                return Err(err(&key, "expected an array of values".into()));
            };
            if vals.is_empty() {
                return Err(err(&key, "is empty".into()));
            }
            sets.push((k.clone(), vals.clone()));
        }

        // The product, scenarios outermost.
        let mut count: usize = f.scenarios.len();
        for n in [presets.len(), aids.len(), conversions.len(), gnss.len()]
            .into_iter()
            .chain(sets.iter().map(|(_, v)| v.len()))
        {
            count = count.saturating_mul(n);
        }
        if count > MAX_VARIATIONS {
            return Err(err(
                "matrix",
                format!("{count} variations, more than {MAX_VARIATIONS}"),
            ));
        }
        let runs = (count as u64).saturating_mul(cf.seeds.count);
        if runs > MAX_RUNS {
            return Err(err(
                "seeds.count",
                format!(
                    "{count} variations × {} seeds = {runs} runs, more than {MAX_RUNS}",
                    cf.seeds.count
                ),
            ));
        }
        let axes = Axes {
            presets,
            aids,
            conversions,
            gnss,
            sets,
        };
        let mut variations = Vec::with_capacity(count);
        for (si, (spath, stext)) in f.scenarios.iter().enumerate() {
            let skey = format!("scenarios[{si}]");
            let base: toml::Table = toml::from_str(stext)
                .map_err(|e| err(&skey, format!("{spath}: {}", e.message().trim())))?;
            let name = Scenario::parse(stext, spath)
                .map_err(|e| err(&skey, e.to_string()))?
                .name;
            let source = Source {
                path: spath,
                text: stext,
                key: &skey,
                name: &name,
                table: &base,
            };
            // Every combination of the axes, the last fastest (a mixed-radix
            // count over their lengths).
            let radix = axes.lengths();
            let mut digit = vec![0usize; radix.len()];
            loop {
                variations.push(axes.variation(&source, &digit, cf.run.duration_s, &err)?);
                let mut d = radix.len();
                loop {
                    if d == 0 {
                        break;
                    }
                    d -= 1;
                    digit[d] += 1;
                    if digit[d] < radix[d] {
                        break;
                    }
                    digit[d] = 0;
                }
                if digit.iter().all(|&i| i == 0) {
                    break;
                }
            }
        }
        Ok(Plan {
            name: cf.name,
            description: cf.description,
            sha256: f.sha256(),
            seeds: cf.seeds,
            run: cf.run,
            variations,
        })
    }

    /// The number of runs.
    pub fn runs(&self) -> u64 {
        self.variations.len() as u64 * self.seeds.count
    }

    /// Run `index` of the list.
    pub fn run_id(&self, index: u64) -> Option<RunId> {
        if index >= self.runs() {
            return None;
        }
        let v = self.variations.len() as u64;
        Some(RunId {
            index,
            variation: (index % v) as usize,
            replicate: index / v,
            seed: seed_of(self.seeds.base, index),
        })
    }

    /// Whether the campaign keeps a group of metrics.
    pub fn keeps(&self, g: Group) -> bool {
        self.run.keep.contains(&g)
    }
}

/// One scenario of the campaign as the variations start from it.
struct Source<'a> {
    path: &'a str,
    text: &'a str,
    /// `scenarios[i]`: where errors point.
    key: &'a str,
    name: &'a str,
    table: &'a toml::Table,
}

/// The matrix's axes after their checks: `None` is "the scenario's own".
struct Axes {
    presets: Vec<Option<String>>,
    aids: Vec<Option<String>>,
    conversions: Vec<Option<String>>,
    gnss: Vec<Option<String>>,
    /// The `set` keys (sorted by name) and their values.
    sets: Vec<(String, Vec<toml::Value>)>,
}

impl Axes {
    /// The length of each axis, in the run list's order (preset, aids,
    /// conversion, gnss, then the `set` keys).
    fn lengths(&self) -> Vec<usize> {
        [
            self.presets.len(),
            self.aids.len(),
            self.conversions.len(),
            self.gnss.len(),
        ]
        .into_iter()
        .chain(self.sets.iter().map(|(_, v)| v.len()))
        .collect()
    }

    /// The variation at `digit` (one index per axis, as [`Axes::lengths`]) of
    /// scenario `src`, its settings checked.
    fn variation(
        &self,
        src: &Source,
        digit: &[usize],
        duration_s: Option<f64>,
        err: &dyn Fn(&str, String) -> PlanError,
    ) -> Result<Variation, PlanError> {
        let (p, a, c, g) = (
            &self.presets[digit[0]],
            &self.aids[digit[1]],
            &self.conversions[digit[2]],
            &self.gnss[digit[3]],
        );
        let spath = src.path;
        let own = |x: &Option<String>| x.as_deref().unwrap_or("scenario").to_owned();
        let mut label = format!("scenario={}", src.name);
        for (key, axis, value) in [
            ("preset", self.presets.len(), p),
            ("aids", self.aids.len(), a),
            ("conversion", self.conversions.len(), c),
            ("gnss", self.gnss.len(), g),
        ] {
            if axis > 1 {
                label += &format!(" {key}={}", own(value));
            }
        }
        let mut table = src.table.clone();
        let mut edited = false;
        for ((k, vals), &j) in self.sets.iter().zip(&digit[4..]) {
            set_path(&mut table, k, vals[j].clone())
                .map_err(|why| err(&format!("matrix.set.\"{k}\""), format!("{spath}: {why}")))?;
            edited = true;
            if vals.len() > 1 {
                label += &format!(" {k}={}", vals[j]);
            }
        }
        if g.as_deref() == Some("off") {
            edited |= table.remove("gnss").is_some();
        } else if g.as_deref() == Some("on") && !table.contains_key("gnss") {
            return Err(err(
                "matrix.gnss",
                format!("\"on\": {spath} has no [gnss] section to fly"),
            ));
        }
        if let Some(d) = duration_s {
            edited |= cut(&mut table, d)
                .map_err(|why| err("run.duration_s", format!("{spath}: {why}")))?;
        }
        // An unedited scenario is flown from its own text, so a run is the
        // same flight as `simulate --scenario FILE`.
        let text = if edited {
            toml::to_string(&table).map_err(|e| err(src.key, e.to_string()))?
        } else {
            src.text.to_owned()
        };
        let scenario = Scenario::parse(&text, spath)
            .map_err(|e| err(src.key, format!("after the variation {label:?}: {e}")))?;
        let overrides = CliOverrides {
            preset: p
                .as_deref()
                .map(|x| SensorGrade::parse(x).expect("checked")),
            fuse: a.as_deref().map(|x| AidSet::parse(x).expect("checked")),
            conversion: c.as_deref().map(|x| conversion(x).expect("checked")),
            ..Default::default()
        };
        // The navigator's settings are checked now, not in every run.
        polarnav_config::effective(
            &polarnav_config::ConfigFile::defaults(),
            Some(&text),
            &overrides,
        )
        .map_err(|e| err(src.key, format!("the variation {label:?}: {e}")))?;
        Ok(Variation {
            label,
            text,
            scenario,
            overrides,
        })
    }
}

fn conversion(s: &str) -> Result<Conversion, String> {
    match s {
        "paper" => Ok(Conversion::Paper),
        "none" => Ok(Conversion::None),
        _ => Err(format!(
            "{s:?}: expected \"paper\", \"none\" or \"scenario\""
        )),
    }
}

/// Sets a dotted path (`faults.event.0.magnitude`) of a TOML table: the
/// tables and array elements on the way must exist (a typo there is an
/// error naming where the path stops), the last key may be new, and a
/// value keeps the type of the one it replaces (an integer may replace a
/// float).
fn set_path(table: &mut toml::Table, path: &str, value: toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = path.split('.').collect();
    let mut cur: &mut toml::Value = table
        .get_mut(parts[0])
        .ok_or_else(|| format!("no key {:?}", parts[0]))?;
    for (i, p) in parts.iter().enumerate().skip(1) {
        let here = parts[..i].join(".");
        let last = i + 1 == parts.len();
        cur = match cur {
            // A table's last key may be new (an optional key the scenario
            // leaves at its default): the scenario's own parser refuses a
            // key it does not know, naming it.
            toml::Value::Table(t) if last && !t.contains_key(*p) => {
                t.insert((*p).to_owned(), value);
                return Ok(());
            }
            toml::Value::Table(t) => t
                .get_mut(*p)
                .ok_or_else(|| format!("{here} has no key {p:?}"))?,
            toml::Value::Array(a) => {
                let k: usize = p
                    .parse()
                    .map_err(|_| format!("{here} is an array: {p:?} is not an index"))?;
                let n = a.len();
                a.get_mut(k)
                    .ok_or_else(|| format!("{here} has {n} elements, no [{k}]"))?
            }
            _ => return Err(format!("{here} is a value, not a table or an array")),
        };
    }
    let value = match (&*cur, value) {
        (toml::Value::Float(_), toml::Value::Integer(i)) => toml::Value::Float(i as f64),
        (old, new) if std::mem::discriminant(old) == std::mem::discriminant(&new) => new,
        (old, new) => {
            return Err(format!(
                "{path} is a {}, the matrix gives a {}",
                old.type_str(),
                new.type_str()
            ));
        }
    };
    *cur = value;
    Ok(())
}

/// Cuts a scenario's segments to `duration_s` of flight: the segment that
/// reaches it shortened, the ones after it dropped. `Ok(false)` when the
/// flight is not longer.
fn cut(table: &mut toml::Table, duration_s: f64) -> Result<bool, String> {
    let Some(toml::Value::Array(segs)) = table.get_mut("segment") else {
        return Err("no [[segment]]".into());
    };
    let mut t = 0.0;
    for (i, s) in segs.iter_mut().enumerate() {
        let d = s
            .get("duration_s")
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            .ok_or_else(|| format!("segment[{i}] has no duration_s"))?;
        if t + d >= duration_s {
            if let Some(tbl) = s.as_table_mut() {
                tbl.insert("duration_s".into(), toml::Value::Float(duration_s - t));
                // A manoeuvre cut short keeps its rate: its change is cut in proportion.
                for key in [
                    "heading_change_deg",
                    "altitude_change_m",
                    "speed_change_mps",
                ] {
                    if let Some(v) = tbl.get(key).and_then(toml::Value::as_float) {
                        tbl.insert(key.into(), toml::Value::Float(v * (duration_s - t) / d));
                    }
                }
            }
            // Dropping the later segments is an edit too (it was once
            // tested after the truncation, so a cut at a segment's end flew
            // the whole scenario).
            let dropped = segs.len() > i + 1;
            segs.truncate(i + 1);
            return Ok(t + d > duration_s || dropped);
        }
        t += d;
    }
    Ok(false)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cut_shortens_or_drops_and_says_so() {
        let two = |a: f64, b: f64| -> toml::Table {
            format!("[[segment]]\nkind = \"cruise\"\nduration_s = {a:?}\n[[segment]]\nkind = \"turn\"\nduration_s = {b:?}\nheading_change_deg = 90.0\n")
                .parse()
                .expect("toml")
        };
        let segs = |t: &toml::Table| -> Vec<f64> {
            t["segment"]
                .as_array()
                .expect("segments")
                .iter()
                .map(|s| s["duration_s"].as_float().expect("duration"))
                .collect()
        };
        // At the first segment's end: the second dropped, an edit.
        let mut t = two(300.0, 300.0);
        assert_eq!(cut(&mut t, 300.0), Ok(true));
        assert_eq!(segs(&t), [300.0]);
        // Inside the turn: shortened, its change in proportion.
        let mut t = two(300.0, 300.0);
        assert_eq!(cut(&mut t, 450.0), Ok(true));
        assert_eq!(segs(&t), [300.0, 150.0]);
        assert_eq!(t["segment"][1]["heading_change_deg"].as_float(), Some(45.0));
        // At the flight's end or beyond: no edit.
        for d in [600.0, 1e6] {
            let mut t = two(300.0, 300.0);
            assert_eq!(cut(&mut t, d), Ok(false), "{d}");
            assert_eq!(segs(&t), [300.0, 300.0]);
        }
    }

    #[test]
    fn seeds_are_distinct_and_depend_on_base_and_index() {
        let mut s: Vec<u64> = (0..200_000).map(|i| seed_of(7, i)).collect();
        s.sort_unstable();
        s.dedup();
        assert_eq!(s.len(), 200_000);
        assert_ne!(seed_of(7, 3), seed_of(8, 3));
        // SplitMix64's published first outputs for seed 0 (the state
        // advanced by φ before each): an independent check of the constants.
        assert_eq!(seed_of(0, 1), 0xE220_A839_7B1D_CDAF);
        assert_eq!(seed_of(0, 2), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn errors_name_the_dotted_key() {
        let e = parse_file(
            "c.toml",
            "name = \"x\"\nscenarios = []\nbogus = 1\n[seeds]\nbase = 1\ncount = 2\n",
        )
        .unwrap_err();
        assert_eq!(
            (e.file.as_str(), e.key.as_str()),
            ("c.toml", "bogus"),
            "{e}"
        );
        let e = parse_file(
            "c.toml",
            "name = \"x\"\nscenarios = []\n[seeds]\nbase = 1\ncount = -5\n",
        )
        .unwrap_err();
        assert_eq!(e.key, "seeds.count", "{e}");
        let e = parse_file(
            "c.toml",
            "name = \"x\"\nscenarios = []\n[seeds]\nbase = 1\ncount = 2\n[run]\nkeep = [\"nees\", \"bogus\"]\n",
        )
        .unwrap_err();
        assert_eq!(e.key, "run.keep", "{e}");
        let e = parse_file(
            "c.toml",
            "name = \"x\"\nscenarios = []\n[seeds]\nbase = 1\ncount = 2\n[mtrix]\n",
        )
        .unwrap_err();
        assert!(e.why.contains("mtrix"), "{e}");
    }

    #[test]
    fn set_path_edits_an_existing_key_only() {
        let mut t: toml::Table =
            toml::from_str("[[faults.event]]\nmagnitude = 1.0\nkind = \"x\"\n").expect("toml");
        set_path(&mut t, "faults.event.0.magnitude", toml::Value::Integer(3)).expect("set");
        assert_eq!(t["faults"]["event"][0]["magnitude"].as_float(), Some(3.0));
        assert!(set_path(&mut t, "faults.event.1.magnitude", toml::Value::Float(1.0)).is_err());
        assert!(set_path(&mut t, "faults.evnt.0.magnitude", toml::Value::Float(1.0)).is_err());
        set_path(
            &mut t,
            "faults.event.0.azimuth_deg",
            toml::Value::Float(90.0),
        )
        .expect("a new last key");
        assert_eq!(
            t["faults"]["event"][0]["azimuth_deg"].as_float(),
            Some(90.0)
        );
        assert!(set_path(&mut t, "faults.event.0.kind", toml::Value::Float(1.0)).is_err());
    }

    mod extremes {
        use super::*;
        use proptest::prelude::*;

        /// A number log-uniform over the whole range of f64 magnitudes, of
        /// either sign, or one of the special values.
        fn wide_f64() -> impl Strategy<Value = f64> {
            prop_oneof![
                6 => (-1074.0f64..1023.0, any::<bool>()).prop_map(|(e, neg)| {
                    let x = 2f64.powf(e);
                    if neg { -x } else { x }
                }),
                1 => prop::sample::select(vec![
                    0.0,
                    -0.0,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NAN,
                    1e-10,
                    1e6,
                    1e18,
                ]),
            ]
        }

        /// A count log-uniform over the whole u64 range.
        fn wide_u64() -> impl Strategy<Value = u64> {
            (0u32..64, any::<u64>())
                .prop_map(|(bits, r)| if bits == 0 { 0 } else { r >> (64 - bits) })
        }

        /// TOML's spelling of a float (`nan`, `inf`, `-inf` included).
        fn toml_f64(x: f64) -> String {
            if x.is_nan() {
                "nan".into()
            } else if x.is_infinite() {
                if x > 0.0 { "inf".into() } else { "-inf".into() }
            } else {
                format!("{x:e}")
            }
        }

        proptest! {
            #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

            /// Any numbers in a campaign's keys: a plan within its bounds
            /// (runs ≤ MAX_RUNS, every limit finite and inside its range) or
            /// an error naming the file and a key; never a panic, and the
            /// work done is bounded (the scenario is parsed once per
            /// variation, at most one variation here).
            #[test]
            fn any_numbers_give_a_bounded_plan_or_a_named_error(
                count in wide_u64(),
                base in any::<u64>(),
                timeout in wide_f64(),
                every in wide_f64(),
                duration in wide_f64(),
            ) {
                let text = format!(
                    "name = \"p\"\nscenarios = [\"s.toml\"]\n[seeds]\nbase = {}\ncount = {}\n[run]\ntimeout_s = {}\nevery_s = {}\nduration_s = {}\n",
                    // TOML integers are i64: a base past it is refused by the parser, naming the key.
                    base, count, toml_f64(timeout), toml_f64(every), toml_f64(duration)
                );
                let f = Frozen {
                    file: "p.toml".into(),
                    text,
                    scenarios: vec![(
                        "s.toml".into(),
                        include_str!("../../../config/scenarios/paper-sim.toml").into(),
                    )],
                };
                match Plan::new(&f) {
                    Ok(p) => {
                        prop_assert!(p.runs() >= 1 && p.runs() <= MAX_RUNS);
                        prop_assert!(p.run.timeout_s.is_finite() && p.run.timeout_s >= TIMEOUT_RANGE_S.0 && p.run.timeout_s <= TIMEOUT_RANGE_S.1);
                        prop_assert!(p.run.every_s.is_finite() && p.run.every_s >= 0.0);
                        let d = p.variations[0].scenario.duration_s();
                        prop_assert!(d.is_finite() && d > 0.0 && d <= duration.max(600.0));
                        let last = p.run_id(p.runs() - 1).expect("the last run");
                        prop_assert_eq!(last.variation, 0);
                        prop_assert!(p.run_id(p.runs()).is_none());
                    }
                    Err(e) => {
                        prop_assert_eq!(e.file.as_str(), "p.toml");
                        prop_assert!(
                            ["seeds.count", "seeds.base", "run.timeout_s", "run.every_s", "run.duration_s", "scenarios[0]"]
                                .contains(&e.key.as_str()),
                            "{}", e
                        );
                    }
                }
            }
        }
    }
}
