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
#[derive(Debug, Clone, Deserialize, PartialEq)]
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

/// `[init]`: the initial state from configuration (used when a log or the
/// transport provides no init record), with its 1-σ.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InitSettings {
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub h_m: f64,
    /// Velocity east, north, up (m/s).
    #[serde(default)]
    pub vel_enu_mps: [f64; 3],
    pub heading_deg: f64,
    #[serde(default)]
    pub pitch_deg: f64,
    #[serde(default)]
    pub roll_deg: f64,
    pub sigma_pos_h_m: f64,
    pub sigma_pos_v_m: f64,
    pub sigma_vel_mps: f64,
    pub sigma_tilt_arcmin: f64,
    pub sigma_heading_arcmin: f64,
}

impl InitSettings {
    pub fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        check(
            origin,
            "init.lat_deg",
            self.lat_deg,
            self.lat_deg.abs() <= 90.0,
            "a latitude in [-90, 90]",
        )?;
        check(
            origin,
            "init.lon_deg",
            self.lon_deg,
            true,
            "a longitude in degrees",
        )?;
        check(
            origin,
            "init.h_m",
            self.h_m,
            self.h_m.abs() < 1e5,
            "a height in metres",
        )?;
        for (i, v) in self.vel_enu_mps.iter().enumerate() {
            check(
                origin,
                &format!("init.vel_enu_mps[{i}]"),
                *v,
                v.abs() < 2000.0,
                "a velocity in m/s",
            )?;
        }
        for (k, v) in [
            ("init.heading_deg", self.heading_deg),
            ("init.pitch_deg", self.pitch_deg),
            ("init.roll_deg", self.roll_deg),
        ] {
            check(origin, k, v, true, "an angle in degrees")?;
        }
        for (k, v) in [
            ("init.sigma_pos_h_m", self.sigma_pos_h_m),
            ("init.sigma_pos_v_m", self.sigma_pos_v_m),
            ("init.sigma_vel_mps", self.sigma_vel_mps),
            ("init.sigma_tilt_arcmin", self.sigma_tilt_arcmin),
            ("init.sigma_heading_arcmin", self.sigma_heading_arcmin),
        ] {
            check(origin, k, v, v > 0.0, "a positive 1-σ")?;
        }
        Ok(())
    }

    /// The init record these settings describe, valid at `t_ns`.
    pub fn to_init(&self, t_ns: u64) -> msgs::InitState {
        let geo = crate::earth::Geodetic::from_deg(self.lat_deg, self.lon_deg, self.h_m);
        let c_e_g = crate::frames::c_e_g(geo.lat_rad, geo.lon_rad);
        let c_b_g = crate::frames::c_b_n_from_euler(
            self.heading_deg.to_radians(),
            self.pitch_deg.to_radians(),
            self.roll_deg.to_radians(),
        );
        let q = crate::frames::quat_from_dcm(&(c_e_g.transpose() * c_b_g)).into_inner();
        let arcmin = std::f64::consts::PI / 180.0 / 60.0;
        msgs::InitState {
            t_ns,
            seq: 0,
            r_e_m: crate::earth::geodetic_to_ecef(&geo).into(),
            v_e_mps: (c_e_g.transpose() * nalgebra::Vector3::from(self.vel_enu_mps)).into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            sigma_pos_h_m: self.sigma_pos_h_m,
            sigma_pos_v_m: self.sigma_pos_v_m,
            sigma_vel_h_mps: self.sigma_vel_mps,
            sigma_vel_v_mps: self.sigma_vel_mps,
            sigma_tilt_rad: self.sigma_tilt_arcmin * arcmin,
            sigma_heading_rad: self.sigma_heading_arcmin * arcmin,
        }
    }
}

/// `[filter]`: IMU noise model and initial bias uncertainty, in datasheet units.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FilterSettings {
    /// Angle random walk (deg/√h).
    pub arw_dpsh: f64,
    /// Velocity random walk (µg/√Hz).
    pub vrw_ug_psqhz: f64,
    /// Initial 1-σ of the gyro bias (deg/h) and accelerometer bias (µg).
    pub gyro_bias_dph: f64,
    pub accel_bias_ug: f64,
    /// Bias instability as first-order Gauss–Markov: σ (deg/h, µg) and τ (s); σ = 0 means constant biases.
    pub gyro_bias_instability_dph: f64,
    pub gyro_bias_tau_s: f64,
    pub accel_bias_instability_ug: f64,
    pub accel_bias_tau_s: f64,
    /// Covariance propagation interval (s); the mechanization runs every IMU sample.
    pub covariance_interval_s: f64,
    /// IMU samples whose rate exceeds these are physically impossible and rejected
    /// (gyro °/s, accelerometer m/s²).
    pub max_gyro_rate_dps: f64,
    pub max_accel_mps2: f64,
    /// Missing IMU time (between the previous sample and the start of the next
    /// one's interval) is bridged on the last increments held constant. A gap
    /// longer than `imu_gap_s` is coasted: counted, flagged (`COASTING`) and
    /// covered by extra covariance for an unknown manoeuvre of 1-σ
    /// `coast_accel_mps2` and `coast_rate_dps` over the gap.
    pub imu_gap_s: f64,
    pub coast_accel_mps2: f64,
    pub coast_rate_dps: f64,
}

impl Default for FilterSettings {
    fn default() -> Self {
        // papers/001 Table 1.
        Self {
            arw_dpsh: 0.001,
            vrw_ug_psqhz: 10.0,
            gyro_bias_dph: 0.01,
            accel_bias_ug: 100.0,
            gyro_bias_instability_dph: 0.0,
            gyro_bias_tau_s: 3600.0,
            accel_bias_instability_ug: 0.0,
            accel_bias_tau_s: 3600.0,
            covariance_interval_s: 0.1,
            max_gyro_rate_dps: 2000.0,
            max_accel_mps2: 300.0,
            imu_gap_s: 0.05,
            coast_accel_mps2: 1.0,
            coast_rate_dps: 0.05,
        }
    }
}

/// `[aids]`: χ² gates (thresholds on the normalized innovation squared),
/// timeouts after which an aid is stale, and the latest an aid may arrive.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct AidSettings {
    pub srs_gate: f64,
    pub cns_gate: f64,
    pub baro_gate: f64,
    pub srs_timeout_s: f64,
    pub cns_timeout_s: f64,
    pub baro_timeout_s: f64,
    /// Aids older than this relative to the newest IMU sample are rejected as late (s).
    pub max_latency_s: f64,
}

impl Default for AidSettings {
    fn default() -> Self {
        // 99.9 % χ² quantiles for 3, 2 and 1 degrees of freedom.
        Self {
            srs_gate: 16.266,
            cns_gate: 13.816,
            baro_gate: 10.828,
            srs_timeout_s: 3.0,
            cns_timeout_s: 3.0,
            baro_timeout_s: 1.0,
            max_latency_s: 0.1,
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
            frame: FrameConfig::default(),
            filter: FilterSettings::default(),
            aids: AidSettings::default(),
            init: None,
            live: LiveSettings::default(),
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
    /// Stay in g for the whole run (reference runs of the switching experiments).
    pub never_switch: bool,
}

impl Default for FrameConfig {
    fn default() -> Self {
        Self {
            switch_enter_deg: 70.0,
            switch_leave_deg: 69.5,
            force_switch_s: Vec::new(),
            never_switch: false,
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

fn check(origin: &str, key: &str, v: f64, ok: bool, expected: &str) -> Result<(), ConfigError> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(ConfigError::Invalid {
            path: origin.to_owned(),
            key: key.to_owned(),
            message: format!("expected {expected}, got {v}"),
        })
    }
}

impl FilterSettings {
    pub fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        for (k, v) in [
            ("filter.arw_dpsh", self.arw_dpsh),
            ("filter.vrw_ug_psqhz", self.vrw_ug_psqhz),
            (
                "filter.gyro_bias_instability_dph",
                self.gyro_bias_instability_dph,
            ),
            (
                "filter.accel_bias_instability_ug",
                self.accel_bias_instability_ug,
            ),
        ] {
            check(origin, k, v, v >= 0.0, "a number ≥ 0")?;
        }
        for (k, v) in [
            ("filter.gyro_bias_dph", self.gyro_bias_dph),
            ("filter.accel_bias_ug", self.accel_bias_ug),
            ("filter.gyro_bias_tau_s", self.gyro_bias_tau_s),
            ("filter.accel_bias_tau_s", self.accel_bias_tau_s),
        ] {
            check(origin, k, v, v > 0.0, "a positive number")?;
        }
        for (k, v) in [
            ("filter.max_gyro_rate_dps", self.max_gyro_rate_dps),
            ("filter.max_accel_mps2", self.max_accel_mps2),
            ("filter.imu_gap_s", self.imu_gap_s),
        ] {
            check(origin, k, v, v > 0.0, "a positive number")?;
        }
        for (k, v) in [
            ("filter.coast_accel_mps2", self.coast_accel_mps2),
            ("filter.coast_rate_dps", self.coast_rate_dps),
        ] {
            check(origin, k, v, v >= 0.0, "a number ≥ 0")?;
        }
        let c = self.covariance_interval_s;
        check(
            origin,
            "filter.covariance_interval_s",
            c,
            c > 0.0 && c <= 1.0,
            "an interval in (0, 1] s",
        )
    }

    /// Process noise in SI units.
    pub fn process_noise(&self) -> crate::filter::ProcessNoise {
        let dph = std::f64::consts::PI / 180.0 / 3600.0;
        let ug = 1e-6 * crate::earth::G0;
        crate::filter::ProcessNoise {
            arw: self.arw_dpsh * std::f64::consts::PI / 180.0 / 60.0,
            vrw: self.vrw_ug_psqhz * ug,
            gyro_bias_sigma: self.gyro_bias_instability_dph * dph,
            gyro_bias_tau_s: if self.gyro_bias_instability_dph > 0.0 {
                self.gyro_bias_tau_s
            } else {
                f64::INFINITY
            },
            accel_bias_sigma: self.accel_bias_instability_ug * ug,
            accel_bias_tau_s: if self.accel_bias_instability_ug > 0.0 {
                self.accel_bias_tau_s
            } else {
                f64::INFINITY
            },
        }
    }
}

impl AidSettings {
    pub fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        for (k, v) in [
            ("aids.srs_gate", self.srs_gate),
            ("aids.cns_gate", self.cns_gate),
            ("aids.baro_gate", self.baro_gate),
        ] {
            check(origin, k, v, v > 0.0, "a positive χ² threshold")?;
        }
        for (k, v) in [
            ("aids.srs_timeout_s", self.srs_timeout_s),
            ("aids.cns_timeout_s", self.cns_timeout_s),
            ("aids.baro_timeout_s", self.baro_timeout_s),
            ("aids.max_latency_s", self.max_latency_s),
        ] {
            check(origin, k, v, v > 0.0, "a positive time in seconds")?;
        }
        Ok(())
    }
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
        if self.never_switch {
            FramePolicy::Forced(Vec::new())
        } else if self.force_switch_s.is_empty() {
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
        c.filter.validate(origin)?;
        c.aids.validate(origin)?;
        if let Some(i) = &c.init {
            i.validate(origin)?;
        }
        let r = c.live.imu_rate_hz;
        check(
            origin,
            "live.imu_rate_hz",
            r,
            (10.0..=1000.0).contains(&r),
            "an IMU rate in [10, 1000] Hz",
        )?;
        for (k, v) in [
            ("live.checkpoint_period_s", c.live.checkpoint_period_s),
            ("live.checkpoint_max_age_s", c.live.checkpoint_max_age_s),
        ] {
            check(origin, k, v, v > 0.0, "a positive time in seconds")?;
        }
        if c.live.imu_lost_periods == 0 {
            return Err(ConfigError::Invalid {
                path: origin.to_owned(),
                key: "live.imu_lost_periods".into(),
                message: "expected at least 1".into(),
            });
        }
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
            filter: self.filter.clone(),
            aid_settings: self.aids.clone(),
            ..Default::default()
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

    /// Applies the IMU-noise overrides on top of `filter`.
    pub fn apply_filter(&self, filter: &mut FilterSettings) {
        for (dst, src) in [
            (&mut filter.gyro_bias_dph, self.gyro_bias_dph),
            (&mut filter.accel_bias_ug, self.accel_bias_ug),
            (&mut filter.arw_dpsh, self.arw_dpsh),
            (&mut filter.vrw_ug_psqhz, self.vrw_ug_psqhz),
        ] {
            if let Some(v) = src {
                *dst = v;
            }
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
    fn init_from_config_builds_the_stated_attitude() {
        let c = Config::parse(
            "[init]\nlat_deg = 34.246048\nlon_deg = 108.909664\nh_m = 380.0\nheading_deg = 90.6\npitch_deg = 0.9\nroll_deg = 0.36\nsigma_pos_h_m = 10.0\nsigma_pos_v_m = 10.0\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 30.0\nsigma_heading_arcmin = 300.0\n",
            "x.toml",
        )
        .expect("config");
        let init = c.init.expect("init").to_init(5);
        let r = nalgebra::Vector3::from(init.r_e_m);
        let g = crate::earth::ecef_to_geodetic(&r);
        let [w, x, y, z] = init.q_b_e;
        let c_b_e =
            nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
                .to_rotation_matrix()
                .into_inner();
        let (h, p, rl) =
            crate::frames::euler_from_c_b_n(&(crate::frames::c_e_g(g.lat_rad, g.lon_rad) * c_b_e));
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
