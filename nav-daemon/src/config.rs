//! nav-daemon configuration (`config/nav-daemon.toml`). Unknown keys and bad
//! values are errors that name the file and the key.

use std::path::Path;

use serde::Deserialize;

use crate::frame_select::{FramePolicy, SwitchLatitudes};
use crate::navigator::NavigatorConfig;

/// The whole file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// iceoryx2 service prefix.
    #[serde(default = "default_prefix")]
    pub prefix: String,
    #[serde(default)]
    pub frame: FrameConfig,
}

fn default_prefix() -> String {
    msgs::service::DEFAULT_PREFIX.to_owned()
}

impl Default for Config {
    fn default() -> Self {
        Self {
            prefix: default_prefix(),
            frame: FrameConfig::default(),
        }
    }
}

/// `[frame]`: when to use the grid frame.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FrameConfig {
    /// Enter the grid frame at |latitude| ≥ this (deg).
    pub switch_enter_deg: f64,
    /// Leave it at |latitude| ≤ this (deg).
    pub switch_leave_deg: f64,
    /// Forced switch times (s); when non-empty the latitude rule is off.
    pub force_switch_s: Vec<f64>,
}

impl Default for FrameConfig {
    fn default() -> Self {
        Self {
            switch_enter_deg: 70.0,
            switch_leave_deg: 69.5,
            force_switch_s: Vec::new(),
        }
    }
}

/// A configuration error: exit status 2.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    #[error("{path}: key `{key}`: {message}")]
    Invalid {
        path: String,
        key: String,
        message: String,
    },
}

impl FrameConfig {
    /// Checks the values; `origin` and `table` name the place in errors.
    pub fn validate(&self, origin: &str, table: &str) -> Result<(), ConfigError> {
        let bad = |key: &str, message: String| ConfigError::Invalid {
            path: origin.to_owned(),
            key: format!("{table}.{key}"),
            message,
        };
        for (k, v) in [
            ("switch_enter_deg", self.switch_enter_deg),
            ("switch_leave_deg", self.switch_leave_deg),
        ] {
            if !(v.is_finite() && (0.0..=90.0).contains(&v)) {
                return Err(bad(
                    k,
                    format!("expected a latitude in [0, 90] degrees, got {v}"),
                ));
            }
        }
        if self.switch_leave_deg >= self.switch_enter_deg {
            return Err(bad(
                "switch_leave_deg",
                format!(
                    "must be below switch_enter_deg ({}) for hysteresis, got {}",
                    self.switch_enter_deg, self.switch_leave_deg
                ),
            ));
        }
        let mut last = f64::NEG_INFINITY;
        for &t in &self.force_switch_s {
            if !(t.is_finite() && t >= 0.0 && t > last) {
                return Err(bad(
                    "force_switch_s",
                    format!(
                        "expected ascending non-negative times in seconds, got {t} after {last}"
                    ),
                ));
            }
            last = t;
        }
        Ok(())
    }

    /// The frame policy these settings describe.
    pub fn policy(&self) -> FramePolicy {
        if self.force_switch_s.is_empty() {
            FramePolicy::Latitude(SwitchLatitudes {
                enter_rad: self.switch_enter_deg.to_radians(),
                leave_rad: self.switch_leave_deg.to_radians(),
            })
        } else {
            FramePolicy::Forced(
                self.force_switch_s
                    .iter()
                    .map(|t| (t * 1e9).round() as u64)
                    .collect(),
            )
        }
    }
}

impl Config {
    /// Parses configuration text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let c: Config = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: origin.to_owned(),
            message: e.to_string(),
        })?;
        if c.prefix.is_empty() || c.prefix.contains(char::is_whitespace) {
            return Err(ConfigError::Invalid {
                path: origin.to_owned(),
                key: "prefix".into(),
                message: format!(
                    "expected a non-empty service prefix without spaces, got {:?}",
                    c.prefix
                ),
            });
        }
        c.frame.validate(origin, "frame")?;
        Ok(c)
    }

    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: p.clone(),
            source,
        })?;
        Self::parse(&text, &p)
    }

    pub fn navigator(&self) -> NavigatorConfig {
        NavigatorConfig {
            frame_policy: self.frame.policy(),
        }
    }
}

/// The `[navigator]` table a scenario may carry in a navlog header's metadata.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ScenarioOverrides {
    pub switch_enter_deg: Option<f64>,
    pub switch_leave_deg: Option<f64>,
    pub force_switch_s: Option<Vec<f64>>,
}

impl ScenarioOverrides {
    /// Extracts `[navigator]` from header metadata (TOML); other tables are ignored.
    pub fn from_metadata(metadata: &str) -> Result<Option<Self>, ConfigError> {
        let origin = "navlog header [navigator]";
        let Ok(table) = metadata.parse::<toml::Table>() else {
            // Metadata of imported logs is free text, not TOML.
            return Ok(None);
        };
        let Some(nav) = table.get("navigator") else {
            return Ok(None);
        };
        let o: Self = nav
            .clone()
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError::Parse {
                path: origin.to_owned(),
                message: e.to_string(),
            })?;
        Ok(Some(o))
    }

    /// Applies the overrides on top of `frame`.
    pub fn apply(&self, frame: &mut FrameConfig) {
        if let Some(v) = self.switch_enter_deg {
            frame.switch_enter_deg = v;
        }
        if let Some(v) = self.switch_leave_deg {
            frame.switch_leave_deg = v;
        } else if self.switch_enter_deg.is_some() {
            frame.switch_leave_deg = frame.switch_enter_deg - 0.5;
        }
        if let Some(v) = &self.force_switch_s {
            frame.force_switch_s.clone_from(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_config_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/nav-daemon.toml");
        let c = Config::load(&path).expect("shipped config");
        assert_eq!(c.prefix, "polarnav");
    }

    #[test]
    fn unknown_key_names_file_and_key() {
        let e = Config::parse("[frame]\nswitch_entr_deg = 70\n", "x.toml")
            .expect_err("fails")
            .to_string();
        assert!(e.contains("x.toml") && e.contains("switch_entr_deg"), "{e}");
    }

    #[test]
    fn bad_hysteresis_names_the_key() {
        let e = Config::parse(
            "[frame]\nswitch_enter_deg = 70\nswitch_leave_deg = 71\n",
            "x.toml",
        )
        .expect_err("fails")
        .to_string();
        assert!(e.contains("frame.switch_leave_deg"), "{e}");
        let e = Config::parse("[frame]\nforce_switch_s = [900, 300]\n", "x.toml")
            .expect_err("fails")
            .to_string();
        assert!(e.contains("frame.force_switch_s"), "{e}");
    }

    #[test]
    fn scenario_overrides_apply_and_keep_hysteresis() {
        let o = ScenarioOverrides::from_metadata(
            "name='x'\n[navigator]\nswitch_enter_deg = 88.0\n[generated]\nseed=1\n",
        )
        .expect("parse")
        .expect("present");
        let mut f = FrameConfig::default();
        o.apply(&mut f);
        assert!((f.switch_enter_deg - 88.0).abs() < 1e-12);
        assert!((f.switch_leave_deg - 87.5).abs() < 1e-12);
        f.validate("t", "frame").expect("valid");
        assert!(
            ScenarioOverrides::from_metadata("not toml at all ===")
                .expect("ok")
                .is_none()
        );
    }
}
