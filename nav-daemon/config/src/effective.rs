//! The effective settings of a run: configuration file, then the navlog
//! header's `[navigator]` table, then the command line, each key taking the
//! last value given, with where it came from. The live daemon and `batch`
//! both call [`effective`]; both print [`Effective::describe`] at start.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::Path;

use polarnav::session::SessionSettings;
use polarnav::settings::{AidSet, Conversion};

use crate::{Config, ConfigError, ScenarioOverrides};

/// Where a setting's value came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// The built-in default.
    Default,
    /// The configuration file.
    File,
    /// The navlog header's `[navigator]` table.
    Header,
    /// A command-line option.
    CommandLine,
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Source::Default => "default",
            Source::File => "config file",
            Source::Header => "navlog header",
            Source::CommandLine => "command line",
        })
    }
}

/// A configuration file as read, with the keys it set itself.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigFile {
    pub config: Config,
    /// The file's path (`defaults` when there is none).
    pub origin: String,
    /// Dotted keys the file sets.
    pub keys: BTreeSet<String>,
}

impl ConfigFile {
    /// No file: the built-in defaults.
    pub fn defaults() -> Self {
        Self {
            config: Config::default(),
            origin: "defaults".to_owned(),
            keys: BTreeSet::new(),
        }
    }

    /// Parses and validates configuration text; `origin` names it.
    pub fn parse(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let config = Config::parse(text, origin)?;
        // The keys a preset expands to are the file's too.
        let table = Config::table(text, origin)?;
        let mut keys = BTreeSet::new();
        leaves(&table, "", &mut |k, _| {
            keys.insert(k);
        });
        Ok(Self {
            config,
            origin: origin.to_owned(),
            keys,
        })
    }

    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: p.clone(),
            source,
        })?;
        Self::parse(&text, &p)
    }
}

/// Settings given on the command line (`batch`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CliOverrides {
    pub conversion: Option<Conversion>,
    pub fuse: Option<AidSet>,
    /// `--force-switch` times (s); an empty list is `--no-switch`.
    pub force_switch_s: Option<Vec<f64>>,
    /// `--align SECONDS`.
    pub align_s: Option<f64>,
    /// `--preset GRADE`: the grade's noise keys (over the file's and the header's).
    pub preset: Option<polarnav::settings::SensorGrade>,
    /// `--prefix` (the live daemon).
    pub prefix: Option<String>,
}

/// The command-line option that sets a key, for error messages.
fn flag(key: &str) -> &'static str {
    match key {
        "prefix" => "--prefix",
        "frame.conversion" => "--conversion",
        "aids.fuse" => "--aids",
        "frame.force_switch_s" | "frame.never_switch" => "--force-switch/--no-switch",
        "align_s" => "--align",
        k if k.starts_with("filter.") => "--preset",
        _ => "an option",
    }
}

/// The settings a run uses, and the source of each.
#[derive(Debug, Clone, PartialEq)]
pub struct Effective {
    pub config: Config,
    /// Stationary alignment (s) after the init, when asked for.
    pub align_s: Option<f64>,
    sources: BTreeMap<String, Source>,
    origins: Origins,
}

#[derive(Debug, Clone, PartialEq)]
struct Origins {
    file: String,
    header: String,
}

const HEADER_ORIGIN: &str = "navlog header [navigator]";

impl Effective {
    /// What the estimator core's session needs.
    pub fn session(&self) -> SessionSettings {
        SessionSettings {
            navigator: self.config.navigator(),
            init: self.config.init.clone(),
            align_s: self.align_s,
            resume_max_age_ns: (self.config.live.checkpoint_max_age_s * 1e9).round() as u64,
        }
    }

    /// The source of a dotted key (`frame.switch_enter_deg`).
    pub fn source(&self, key: &str) -> Option<&Source> {
        self.sources.get(key)
    }

    /// Every setting as `(key, value as TOML, where it came from)`, sorted
    /// by key; the place names the file for a file's value.
    pub fn settings(&self) -> Vec<(String, String, String)> {
        let table = to_table(&self.config);
        let mut lines = Vec::new();
        leaves(&table, "", &mut |k, v| lines.push((k, v.to_string())));
        if let Some(a) = self.align_s {
            lines.push(("align_s".to_owned(), toml::Value::Float(a).to_string()));
        }
        lines.sort();
        lines
            .into_iter()
            .map(|(k, v)| {
                let src = self.sources.get(&k).unwrap_or(&Source::Default);
                let place = match src {
                    Source::File => format!("{src} {}", self.origins.file),
                    _ => src.to_string(),
                };
                (k, v, place)
            })
            .collect()
    }

    /// One line per setting, `key = value  # source`, sorted by key: what
    /// the daemon and `batch` print at start.
    pub fn describe(&self) -> String {
        self.settings()
            .into_iter()
            .map(|(k, v, place)| format!("{k} = {v}  # {place}\n"))
            .collect()
    }

    /// The navigator settings as a navlog header's `[navigator]` table (every
    /// key, so a run of `batch` on the log uses exactly these, whatever its
    /// own configuration file says).
    pub fn header_toml(&self) -> String {
        let table = to_table(&self.config);
        let mut nav = toml::Table::new();
        for k in ["frame", "filter", "aids", "init"] {
            if let Some(v) = table.get(k) {
                nav.insert(k.to_owned(), v.clone());
            }
        }
        if let Some(a) = self.align_s {
            nav.insert("align_s".to_owned(), toml::Value::Float(a));
        }
        let mut top = toml::Table::new();
        top.insert("navigator".to_owned(), toml::Value::Table(nav));
        toml::to_string(&top).unwrap_or_default()
    }
}

fn to_table(c: &Config) -> toml::Table {
    // Every field of Config is plain data that TOML can hold.
    toml::Table::try_from(c).unwrap_or_default()
}

/// Calls `f` with every leaf of `t` as a dotted key (arrays are leaves).
fn leaves(t: &toml::Table, prefix: &str, f: &mut impl FnMut(String, &toml::Value)) {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(sub) => leaves(sub, &key, f),
            _ => f(key, v),
        }
    }
}

/// Sets a dotted key in `t`, creating tables on the way.
fn set(t: &mut toml::Table, key: &str, v: toml::Value) {
    match key.split_once('.') {
        Some((head, rest)) => {
            let sub = t
                .entry(head.to_owned())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            if !sub.is_table() {
                *sub = toml::Value::Table(toml::Table::new());
            }
            if let toml::Value::Table(sub) = sub {
                set(sub, rest, v);
            }
        }
        None => {
            t.insert(key.to_owned(), v);
        }
    }
}

/// Builds the effective settings: `file`, then the `[navigator]` table of
/// the navlog header `header_metadata` (if it is TOML and has one), then
/// `cli`. The result is validated as a configuration file is; an error
/// names the place the offending value came from.
pub fn effective(
    file: &ConfigFile,
    header_metadata: Option<&str>,
    cli: &CliOverrides,
) -> Result<Effective, ConfigError> {
    let mut table = to_table(&file.config);
    let mut sources = BTreeMap::new();
    leaves(&table, "", &mut |k, _| {
        let s = if file.keys.contains(&k) {
            Source::File
        } else {
            Source::Default
        };
        sources.insert(k, s);
    });
    let mut align_s = None;
    let mut assign = |table: &mut toml::Table, k: &str, v: toml::Value, s: Source| {
        if k == "align_s" {
            align_s = v.as_float();
        } else {
            set(table, k, v);
        }
        sources.insert(k.to_owned(), s);
    };
    if let Some(o) = header_metadata
        .map(ScenarioOverrides::from_metadata)
        .transpose()?
        .flatten()
    {
        for (k, v) in o.assignments() {
            assign(&mut table, &k, v, Source::Header);
        }
    }
    if let Some(g) = cli.preset {
        assign(
            &mut table,
            "filter.preset",
            toml::Value::String(g.name().to_owned()),
            Source::CommandLine,
        );
        for (k, v) in g.values() {
            assign(
                &mut table,
                &format!("filter.{k}"),
                toml::Value::Float(v),
                Source::CommandLine,
            );
        }
    }
    if let Some(c) = cli.conversion {
        let v = toml::Value::String(
            if c == Conversion::None {
                "none"
            } else {
                "paper"
            }
            .into(),
        );
        assign(&mut table, "frame.conversion", v, Source::CommandLine);
    }
    if let Some(a) = cli.fuse {
        assign(
            &mut table,
            "aids.fuse",
            toml::Value::String(a.to_string()),
            Source::CommandLine,
        );
    }
    if let Some(times) = &cli.force_switch_s {
        let list = times.iter().copied().map(toml::Value::Float).collect();
        assign(
            &mut table,
            "frame.force_switch_s",
            toml::Value::Array(list),
            Source::CommandLine,
        );
        let never = toml::Value::Boolean(times.is_empty());
        assign(&mut table, "frame.never_switch", never, Source::CommandLine);
    }
    if let Some(p) = &cli.prefix {
        assign(
            &mut table,
            "prefix",
            toml::Value::String(p.clone()),
            Source::CommandLine,
        );
    }
    if let Some(a) = cli.align_s {
        assign(
            &mut table,
            "align_s",
            toml::Value::Float(a),
            Source::CommandLine,
        );
    }
    let origins = Origins {
        file: file.origin.clone(),
        header: HEADER_ORIGIN.to_owned(),
    };
    let place = |key: &str| match sources.get(key) {
        Some(Source::Header) => origins.header.clone(),
        Some(Source::CommandLine) => format!("command line {}", flag(key)),
        _ => origins.file.clone(),
    };
    let config: Config = toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| ConfigError::Parse {
            path: format!("{} + {}", origins.file, origins.header),
            message: e.to_string(),
        })?;
    if let Err(e) = config.validate("effective settings") {
        return Err(match e {
            ConfigError::Invalid { key, message, .. } => ConfigError::Invalid {
                path: place(&key),
                key,
                message,
            },
            other => other,
        });
    }
    if let Some(a) = align_s
        && !(a.is_finite() && a > 0.0 && a <= 3600.0)
    {
        return Err(ConfigError::Invalid {
            path: place("align_s"),
            key: "align_s".to_owned(),
            message: format!("expected an alignment time in (0, 3600] s, got {a}"),
        });
    }
    Ok(Effective {
        config,
        align_s,
        sources,
        origins,
    })
}
