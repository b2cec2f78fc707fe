//! polarnav settings as files: the nav-daemon configuration
//! (`config/nav-daemon.toml`), the `[navigator]` table of a navlog header,
//! and [`effective`], the one function that builds the settings a run uses
//! from the file, the header and the command line, for the live daemon and
//! `batch` alike, and says where each value came from. Unknown keys and bad
//! values are errors that name the file (or header, or option) and the key.

pub mod build_info;
mod effective;
pub mod provenance;

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use effective::{CliOverrides, ConfigFile, Effective, Source, effective};
use polarnav::navigator::NavigatorConfig;
pub use polarnav::settings::{
    AidSet, AidSettings, Conversion, FilterSettings, FrameSettings, InitSettings, SensorGrade,
    SettingsError,
};
use polarnav::settings::{Bound, MAX_FLIGHT_S};

/// Reads a `preset` value (a sensor grade's name); `origin` and `key` name it in errors.
pub fn parse_preset(v: &toml::Value, origin: &str, key: &str) -> Result<SensorGrade, ConfigError> {
    let invalid = |message: String| ConfigError::Invalid {
        path: origin.to_owned(),
        key: key.to_owned(),
        message,
    };
    match v.as_str() {
        Some(name) => SensorGrade::parse(name).map_err(invalid),
        None => Err(invalid(format!(
            "expected a sensor grade name (navigation, tactical, mems), got {v}"
        ))),
    }
}

/// Expands `filter.preset` of one place's settings (a file, or a header's
/// `[navigator]`): every noise key of the grade that the same table does not
/// set itself is set to the grade's value. Keys given beside the preset win.
pub fn expand_preset(t: &mut toml::Table, origin: &str) -> Result<(), ConfigError> {
    let Some(toml::Value::Table(filter)) = t.get_mut("filter") else {
        return Ok(());
    };
    let Some(v) = filter.get("preset") else {
        return Ok(());
    };
    let grade = parse_preset(v, origin, "filter.preset")?;
    for (k, v) in grade.values() {
        filter.entry(k.to_owned()).or_insert(toml::Value::Float(v));
    }
    Ok(())
}

/// The whole file.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// iceoryx2 service prefix.
    #[serde(default = "default_prefix")]
    pub prefix: String,
    #[serde(default)]
    pub frame: FrameSettings,
    #[serde(default)]
    pub filter: FilterSettings,
    #[serde(default)]
    pub aids: AidSettings,
    /// Initial state when no init record/message is received.
    pub init: Option<InitSettings>,
    #[serde(default)]
    pub live: LiveSettings,
}

/// `[live]`: the fixed-rate service.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct LiveSettings {
    /// Nominal IMU rate (Hz): the interval tick that detects a missing IMU and the overrun budget.
    pub imu_rate_hz: f64,
    /// The IMU is lost after this many nominal periods without a sample.
    pub imu_lost_periods: u32,
    /// Checkpoint file of the navigation state and covariance, written
    /// atomically (write, fsync, rename) every `checkpoint_period_s` of sensor
    /// time; empty disables checkpoints. At start the daemon resumes from it
    /// if the first IMU sample is no more than `checkpoint_max_age_s` after it
    /// (and no init message arrives), else it starts cold; it logs which.
    pub checkpoint_path: String,
    pub checkpoint_period_s: f64,
    pub checkpoint_max_age_s: f64,
}

impl Default for LiveSettings {
    fn default() -> Self {
        Self {
            imu_rate_hz: 200.0,
            imu_lost_periods: 5,
            checkpoint_path: String::new(),
            checkpoint_period_s: 1.0,
            checkpoint_max_age_s: 30.0,
        }
    }
}

fn default_prefix() -> String {
    msgs::service::DEFAULT_PREFIX.to_owned()
}

impl Default for Config {
    fn default() -> Self {
        Self {
            prefix: default_prefix(),
            frame: FrameSettings::default(),
            filter: FilterSettings::default(),
            aids: AidSettings::default(),
            init: None,
            live: LiveSettings::default(),
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

impl From<SettingsError> for ConfigError {
    fn from(e: SettingsError) -> Self {
        ConfigError::Invalid {
            path: e.origin,
            key: e.key,
            message: e.message,
        }
    }
}

fn invalid(origin: &str, key: &str, message: String) -> ConfigError {
    ConfigError::Invalid {
        path: origin.to_owned(),
        key: key.to_owned(),
        message,
    }
}

impl Config {
    /// Parses configuration text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self, ConfigError> {
        Self::from_table(Self::table(text, origin)?, origin)
    }

    /// The file's text as a table, with its `filter.preset` expanded.
    pub(crate) fn table(text: &str, origin: &str) -> Result<toml::Table, ConfigError> {
        let mut t: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| ConfigError::Parse {
                path: origin.to_owned(),
                message: e.to_string(),
            })?;
        expand_preset(&mut t, origin)?;
        Ok(t)
    }

    fn from_table(t: toml::Table, origin: &str) -> Result<Self, ConfigError> {
        let c: Config = toml::Value::Table(t)
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError::Parse {
                path: origin.to_owned(),
                message: e.to_string(),
            })?;
        c.validate(origin)?;
        Ok(c)
    }

    /// Every check the daemon makes of a configuration (`--check-config`
    /// runs exactly this, as does [`effective`] on the merged settings).
    pub fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        let c = self;
        if let Err(message) = msgs::service::validate_prefix(&c.prefix) {
            return Err(ConfigError::Invalid {
                path: origin.to_owned(),
                key: "prefix".into(),
                message,
            });
        }
        c.frame.validate(origin, "frame")?;
        c.filter.validate(origin)?;
        c.aids.validate(origin)?;
        if let Some(i) = &c.init {
            i.validate(origin)?;
        }
        let r = c.live.imu_rate_hz;
        Bound {
            lo: 10.0,
            hi: 1000.0,
            unit: "Hz",
            below: "an IMU slower than 10 Hz cannot carry a strapdown mechanization through \
                    a manoeuvre (and the loop's tick would be 0.1 s)",
            above: "the input buffers and the state history are sized for at most 1 kHz",
        }
        .check(origin, "live.imu_rate_hz", r)?;
        let period_s = 1.0 / r;
        // Keys whose bounds depend on the IMU rate (the live loop's and the
        // navigator's time lines must fit each other).
        let gap = c.filter.imu_gap_s;
        if gap < period_s {
            return Err(invalid(
                origin,
                "filter.imu_gap_s",
                format!(
                    "expected at least one IMU period (1 / live.imu_rate_hz = {period_s} s), \
                     got {gap}: every sample of a {r} Hz IMU would be a time jump"
                ),
            ));
        }
        let history_s = polarnav::navigator::STATE_HISTORY_LEN as f64 * period_s;
        let lat = c.aids.max_latency_s;
        if lat > history_s {
            return Err(invalid(
                origin,
                "aids.max_latency_s",
                format!(
                    "expected at most {history_s} s (the state history: {} samples at \
                     live.imu_rate_hz = {r} Hz), got {lat}: an aid that late has no state \
                     to be fused against",
                    polarnav::navigator::STATE_HISTORY_LEN
                ),
            ));
        }
        let n = c.live.imu_lost_periods;
        if n == 0 {
            return Err(invalid(
                origin,
                "live.imu_lost_periods",
                "expected at least 1, got 0: the IMU would be declared lost between any \
                 two samples"
                    .into(),
            ));
        }
        let lost_s = f64::from(n) * period_s;
        if lost_s > c.filter.imu_max_coast_s {
            return Err(invalid(
                origin,
                "live.imu_lost_periods",
                format!(
                    "expected at most filter.imu_max_coast_s × live.imu_rate_hz = {} periods, \
                     got {n} ({lost_s} s): an IMU silent longer than the longest coast is lost \
                     and must be reported before that",
                    (c.filter.imu_max_coast_s * r).floor()
                ),
            ));
        }
        Bound {
            lo: polarnav::settings::MIN_IMU_PERIOD_S,
            hi: MAX_FLIGHT_S,
            unit: "s",
            below: "shorter than one period of the fastest IMU (1 ms): a checkpoint (with \
                    fsync) at every sample",
            above: "longer than any flight (1e7 s, 116 days): no checkpoint would ever be \
                    written",
        }
        .check(
            origin,
            "live.checkpoint_period_s",
            c.live.checkpoint_period_s,
        )?;
        let coast = c.filter.imu_max_coast_s;
        let above_age = format!(
            "the gap from the checkpoint to the first IMU sample is coasted, and no gap \
             longer than filter.imu_max_coast_s ({coast} s) is"
        );
        Bound {
            lo: polarnav::settings::MIN_IMU_PERIOD_S,
            hi: coast,
            unit: "s",
            below: "shorter than one period of the fastest IMU (1 ms)",
            above: &above_age,
        }
        .check(
            origin,
            "live.checkpoint_max_age_s",
            c.live.checkpoint_max_age_s,
        )?;
        Ok(())
    }

    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: p.clone(),
            source,
        })?;
        Self::parse(&text, &p)
    }

    /// The navigator settings this configuration describes.
    pub fn navigator(&self) -> NavigatorConfig {
        NavigatorConfig {
            frame_policy: self.frame.policy(),
            conversion: self.frame.conversion,
            aids: self.aids.fuse,
            filter: self.filter.clone(),
            aid_settings: self.aids.clone(),
        }
    }
}

/// Assigns every leaf of `v` under the dotted key `key`: a table (an
/// aid's own, `aids.gnss`) sets its keys one by one, so that the keys it
/// does not name keep their values from the configuration.
fn put_leaves(key: &str, v: &toml::Value, put: &mut impl FnMut(&str, toml::Value)) {
    match v {
        toml::Value::Table(t) => {
            for (k, v) in t {
                put_leaves(&format!("{key}.{k}"), v, put);
            }
        }
        v => put(key, v.clone()),
    }
}

/// The `[navigator]` table a scenario carries in a navlog header's metadata,
/// and the flight recorder writes from the daemon's effective settings.
/// The flat keys are the scenarios' short forms; the tables `frame`,
/// `filter`, `aids` and `init` take any key of the configuration's tables
/// of those names, and `align_s` a stationary alignment.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ScenarioOverrides {
    pub frame: Option<toml::Table>,
    pub filter: Option<toml::Table>,
    pub aids: Option<toml::Table>,
    pub init: Option<toml::Table>,
    pub align_s: Option<f64>,
    pub switch_enter_deg: Option<f64>,
    pub switch_leave_deg: Option<f64>,
    pub force_switch_s: Option<Vec<f64>>,
    /// Sensor grade of the scenario's IMU (the short form of `filter.preset`):
    /// its noise keys, unless this table sets them itself.
    pub preset: Option<SensorGrade>,
    /// IMU noise model of the scenario's sensor class (replaces `[filter]` values that are set).
    pub gyro_bias_dph: Option<f64>,
    pub accel_bias_ug: Option<f64>,
    pub arw_dpsh: Option<f64>,
    pub vrw_ug_psqhz: Option<f64>,
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
        if let Some(v) = nav.get("filter").and_then(|f| f.get("preset")) {
            parse_preset(v, origin, "filter.preset")?;
        }
        let o: Self = nav
            .clone()
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError::Parse {
                path: origin.to_owned(),
                message: e.to_string(),
            })?;
        Ok(Some(o))
    }

    /// The settings this table assigns, as dotted keys of the
    /// configuration (`frame.switch_enter_deg`, `filter.arw_dpsh`, ...), in
    /// a fixed order; `align_s` is the session's.
    pub fn assignments(&self) -> Vec<(String, toml::Value)> {
        let mut out = Vec::new();
        let mut put = |k: &str, v: toml::Value| out.push((k.to_owned(), v));
        let f = toml::Value::Float;
        // A grade first, so that any key this table sets beside it wins.
        let table_grade = self
            .filter
            .as_ref()
            .and_then(|t| t.get("preset"))
            .and_then(toml::Value::as_str)
            .and_then(|n| SensorGrade::parse(n).ok());
        if let Some(g) = table_grade.or(self.preset) {
            put("filter.preset", toml::Value::String(g.name().to_owned()));
            for (k, v) in g.values() {
                put(&format!("filter.{k}"), f(v));
            }
        }
        if let Some(v) = self.switch_enter_deg {
            put("frame.switch_enter_deg", f(v));
            if self.switch_leave_deg.is_none() {
                // Keep the default hysteresis below a moved threshold.
                put("frame.switch_leave_deg", f(v - 0.5));
            }
        }
        if let Some(v) = self.switch_leave_deg {
            put("frame.switch_leave_deg", f(v));
        }
        if let Some(v) = &self.force_switch_s {
            put(
                "frame.force_switch_s",
                toml::Value::Array(v.iter().copied().map(f).collect()),
            );
        }
        for (k, v) in [
            ("filter.gyro_bias_dph", self.gyro_bias_dph),
            ("filter.accel_bias_ug", self.accel_bias_ug),
            ("filter.arw_dpsh", self.arw_dpsh),
            ("filter.vrw_ug_psqhz", self.vrw_ug_psqhz),
        ] {
            if let Some(v) = v {
                put(k, f(v));
            }
        }
        for (table, t) in [
            ("frame", &self.frame),
            ("filter", &self.filter),
            ("aids", &self.aids),
            ("init", &self.init),
        ] {
            for (k, v) in t.iter().flatten() {
                put_leaves(&format!("{table}.{k}"), v, &mut put);
            }
        }
        if let Some(v) = self.align_s {
            put("align_s", f(v));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_config_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/nav-daemon.toml");
        let c = Config::load(&path).expect("shipped config");
        assert_eq!(c.prefix, "polarnav");
    }

    /// Every shipped scenario's `[navigator]` table (what `batch` reads from
    /// the header of a log simulated from it) passes the same validation
    /// over the shipped configuration, so no bound refuses a shipped flight.
    #[test]
    fn every_shipped_scenario_passes_over_the_shipped_config() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config");
        let file = ConfigFile::load(&root.join("nav-daemon.toml")).expect("shipped config");
        let mut n = 0;
        for dir in [
            root.join("scenarios"),
            root.join("scenarios/faults"),
            root.join("scenarios/gnss"),
        ] {
            for entry in std::fs::read_dir(&dir).expect("scenarios") {
                let path = entry.expect("entry").path();
                if path.extension().is_some_and(|e| e == "toml") {
                    let text = std::fs::read_to_string(&path).expect("scenario");
                    effective(&file, Some(&text), &CliOverrides::default())
                        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                    n += 1;
                }
            }
        }
        assert!(n >= 17, "{n} scenarios");
    }

    #[test]
    fn init_from_config_builds_the_stated_attitude() {
        let c = Config::parse(
            "[init]\nlat_deg = 34.246048\nlon_deg = 108.909664\nh_m = 380.0\nheading_deg = 90.6\npitch_deg = 0.9\nroll_deg = 0.36\nsigma_pos_h_m = 10.0\nsigma_pos_v_m = 10.0\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 30.0\nsigma_heading_arcmin = 300.0\n",
            "x.toml",
        )
        .expect("config");
        let init = c.init.expect("init").to_init(5);
        let r = nalgebra::Vector3::from(init.r_e_m);
        let g = polarnav::earth::ecef_to_geodetic(&r);
        let [w, x, y, z] = init.q_b_e;
        let c_b_e =
            nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
                .to_rotation_matrix()
                .into_inner();
        let (h, p, rl) = polarnav::frames::euler_from_c_b_n(
            &(polarnav::frames::c_e_g(g.lat_rad, g.lon_rad) * c_b_e),
        );
        assert!(
            (h.to_degrees() - 90.6).abs() < 1e-9
                && (p.to_degrees() - 0.9).abs() < 1e-9
                && (rl.to_degrees() - 0.36).abs() < 1e-9
        );
        let e = Config::parse("[init]\nlat_deg = 95.0\nlon_deg = 0\nh_m = 0\nheading_deg = 0\nsigma_pos_h_m = 1\nsigma_pos_v_m = 1\nsigma_vel_mps = 1\nsigma_tilt_arcmin = 1\nsigma_heading_arcmin = 1\n", "x.toml")
            .expect_err("bad latitude")
            .to_string();
        assert!(e.contains("init.lat_deg"), "{e}");
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
        let meta = "name='x'\n[navigator]\nswitch_enter_deg = 88.0\n[generated]\nseed=1\n";
        let e = effective(
            &ConfigFile::defaults(),
            Some(meta),
            &CliOverrides::default(),
        )
        .expect("effective");
        let f = &e.config.frame;
        assert!((f.switch_enter_deg - 88.0).abs() < 1e-12);
        assert!((f.switch_leave_deg - 87.5).abs() < 1e-12);
        assert_eq!(e.source("frame.switch_enter_deg"), Some(&Source::Header));
        assert_eq!(e.source("frame.switch_leave_deg"), Some(&Source::Header));
        assert_eq!(e.source("filter.arw_dpsh"), Some(&Source::Default));
        assert!(
            ScenarioOverrides::from_metadata("not toml at all ===")
                .expect("ok")
                .is_none()
        );
    }

    #[test]
    #[allow(clippy::float_cmp)] // copies of the same decimal literals: exact
    fn the_shipped_config_is_what_the_readme_says_table_1_with_constant_biases() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/nav-daemon.toml");
        let c = Config::load(&path).expect("shipped config");
        assert_eq!(c.filter.preset, None);
        // The built-in defaults (papers/001 Table 1), written out.
        assert_eq!(c.filter, FilterSettings::default());
        assert_eq!(
            (
                c.filter.arw_dpsh,
                c.filter.vrw_ug_psqhz,
                c.filter.gyro_bias_dph,
                c.filter.accel_bias_ug
            ),
            (0.001, 10.0, 0.01, 100.0)
        );
        assert_eq!(
            (
                c.filter.gyro_bias_instability_dph,
                c.filter.accel_bias_instability_ug
            ),
            (0.0, 0.0),
            "constant biases"
        );
    }

    #[test]
    #[allow(clippy::float_cmp)] // copies of the same decimal literals: exact
    fn a_preset_expands_where_it_is_named_and_explicit_keys_win() {
        let c = Config::parse("[filter]\npreset = \"mems\"\narw_dpsh = 0.5\n", "x.toml")
            .expect("config");
        assert_eq!(c.filter.arw_dpsh, 0.5);
        assert_eq!(c.filter.gyro_bias_instability_dph, 50.0);
        assert_eq!(c.filter.accel_bias_tau_s, 600.0);
        // The header's preset replaces the file's noise keys; the command line wins over both.
        let file = ConfigFile::parse("[filter]\narw_dpsh = 0.5\n", "x.toml").expect("file");
        let meta = "[navigator]\npreset = \"tactical\"\n";
        let e = effective(&file, Some(meta), &CliOverrides::default()).expect("effective");
        assert_eq!(e.config.filter.arw_dpsh, 0.1);
        assert_eq!(e.source("filter.arw_dpsh"), Some(&Source::Header));
        let cli = CliOverrides {
            preset: Some(SensorGrade::Mems),
            ..Default::default()
        };
        let e = effective(&file, Some(meta), &cli).expect("effective");
        assert_eq!(e.config.filter.vrw_ug_psqhz, 300.0);
        assert_eq!(e.config.filter.preset, Some(SensorGrade::Mems));
        // A recorded header (every key) reproduces the settings.
        let again = effective(
            &ConfigFile::defaults(),
            Some(&e.header_toml()),
            &CliOverrides::default(),
        )
        .expect("effective");
        assert_eq!(again.config.filter, e.config.filter);
    }

    #[test]
    fn absurd_noise_and_recovery_values_name_the_file_and_key() {
        for (text, key) in [
            ("[filter]\npreset = \"consumer\"\n", "filter.preset"),
            ("[filter]\npreset = 3\n", "filter.preset"),
            (
                "[filter]\ngyro_bias_tau_s = -1.0\n",
                "filter.gyro_bias_tau_s",
            ),
            (
                "[filter]\ngyro_bias_tau_s = 1e-300\n",
                "filter.gyro_bias_tau_s",
            ),
            (
                "[filter]\naccel_bias_tau_s = 1e300\n",
                "filter.accel_bias_tau_s",
            ),
            (
                "[filter]\naccel_bias_tau_s = inf\n",
                "filter.accel_bias_tau_s",
            ),
            (
                "[filter]\ngyro_bias_instability_dph = nan\n",
                "filter.gyro_bias_instability_dph",
            ),
            (
                "[filter]\ngyro_bias_instability_dph = -0.1\n",
                "filter.gyro_bias_instability_dph",
            ),
            (
                "[filter]\naccel_bias_instability_ug = 1e300\n",
                "filter.accel_bias_instability_ug",
            ),
            ("[filter]\ngyro_bias_dph = 1e-300\n", "filter.gyro_bias_dph"),
            ("[filter]\narw_dpsh = 1e300\n", "filter.arw_dpsh"),
            ("[aids]\nreset_after_s = -1.0\n", "aids.reset_after_s"),
            ("[aids]\nreset_after_s = 1e-300\n", "aids.reset_after_s"),
            ("[aids]\nreset_after_s = nan\n", "aids.reset_after_s"),
            ("[aids]\nreset_after_s = 1e300\n", "aids.reset_after_s"),
        ] {
            let e = Config::parse(text, "x.toml").expect_err(text).to_string();
            assert!(e.contains("x.toml") && e.contains(key), "{text}: {e}");
        }
        let meta = "[navigator.filter]\npreset = \"consumer\"\n";
        let e = effective(
            &ConfigFile::defaults(),
            Some(meta),
            &CliOverrides::default(),
        )
        .expect_err("bad header preset")
        .to_string();
        assert!(
            e.contains("navlog header") && e.contains("filter.preset"),
            "{e}"
        );
        assert!(Config::parse("[aids]\nreset_after_s = 0.0\n", "x.toml").is_ok());
    }

    /// A scenario's `[navigator.aids.gnss]` (the simulated antenna's lever
    /// arm) sets its keys one by one: the file's other keys of that table
    /// keep their values.
    #[test]
    #[allow(clippy::float_cmp)] // copies of the same decimal literals: exact
    fn a_header_sets_an_aids_own_keys_one_by_one() {
        let file = ConfigFile::parse(
            "[aids.gnss]\nmax_pdop = 5.0\nlever_arm_b_m = [9.0, 9.0, 9.0]\n",
            "x.toml",
        )
        .expect("file");
        let meta = "name = 'x'\n[navigator.aids.gnss]\nlever_arm_b_m = [0.0, 1.5, 0.8]\n";
        let e = effective(&file, Some(meta), &CliOverrides::default()).expect("effective");
        let g = &e.config.aids.own.gnss;
        assert_eq!(g.lever_arm_b_m, [0.0, 1.5, 0.8]);
        assert_eq!(g.max_pdop, 5.0);
    }
}
