//! Scenario files (`config/scenarios/*.toml`): trajectory, sensor errors,
//! aid rates and noise, initial errors, navigator overrides.
//!
//! Unknown keys are errors, and every error names the file and the key.

use std::path::Path;

use serde::Deserialize;

use crate::aids::SimAid;
pub use crate::aids::{BaroSpec, BodySpec, CnsSpec, MagSpec, SrsSpec, StarSpec};
pub use crate::sensors::{BiasModel, ImuSpec};

/// A whole scenario. Its aid sections are the declared aids' (`[srs]`,
/// `[cns]`, ..., each optional: [`crate::aids::SimAid::Spec`]), made by
/// the macro below from the declaration's list.
macro_rules! scenario {
    ([$(($K:ident, $n:ident, $P:ident, $d:tt)),* $(,)?]) => {
        #[derive(Debug, Clone, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct Scenario {
            pub name: String,
            #[serde(default)]
            pub description: String,
            pub start: Start,
            #[serde(default)]
            pub imu: ImuSpec,
            #[serde(default)]
            pub truth: TruthSpec,
            $(
                #[doc = concat!("`[", stringify!($n), "]`: the simulator model of the aid's stream.")]
                pub $n: Option<<msgs::$P as SimAid>::Spec>,
            )*
            #[serde(default)]
            pub init_error: InitErrorSpec,
            /// Navigator settings this scenario needs (e.g. the paper's 88° switch);
            /// passed to the navigator through the navlog header.
            pub navigator: Option<NavigatorOverrides>,
            /// Injected faults (`[[faults.event]]`), see [`crate::faults`].
            pub faults: Option<crate::faults::FaultsSpec>,
            #[serde(rename = "segment")]
            pub segments: Vec<Segment>,
        }

        $(
            impl SpecOf for msgs::$P {
                fn spec(s: &Scenario) -> Option<&<Self as SimAid>::Spec> {
                    s.$n.as_ref()
                }
            }
        )*
    };
}
msgs::for_each_aid!(scenario);

/// Where an aid's section is in a [`Scenario`].
pub trait SpecOf: SimAid {
    fn spec(s: &Scenario) -> Option<&<Self as SimAid>::Spec>;
}

/// Initial position, heading and speed.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Start {
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub h_m: f64,
    /// True heading, clockwise from north (deg).
    pub heading_deg: f64,
    /// Horizontal speed (m/s).
    pub speed_mps: f64,
    /// Bank in turns: coordinated (aircraft) or level (ground vehicle).
    #[serde(default)]
    pub bank: BankMode,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BankMode {
    #[default]
    Coordinated,
    Level,
}

/// Truth record rate.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TruthSpec {
    pub rate_hz: f64,
}

impl Default for TruthSpec {
    fn default() -> Self {
        Self { rate_hz: 10.0 }
    }
}

/// Initial errors of the state handed to the navigator (1-σ; drawn from the seed).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitErrorSpec {
    pub pos_h_m: f64,
    pub pos_v_m: f64,
    pub vel_h_mps: f64,
    pub vel_v_mps: f64,
    pub tilt_arcmin: f64,
    pub heading_arcmin: f64,
}

/// Navigator settings a scenario may impose: the navigator's own type, so
/// the simulator validates exactly what `nav-daemon batch` will apply.
pub type NavigatorOverrides = polarnav_config::ScenarioOverrides;

/// One trajectory segment. Changes ramp in and out smoothly over `ramp_s`.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Segment {
    /// Straight (great-circle) flight at constant speed and height.
    Cruise { duration_s: f64 },
    /// Turn by `heading_change_deg` (positive = right/clockwise).
    Turn {
        duration_s: f64,
        heading_change_deg: f64,
        ramp_s: Option<f64>,
    },
    /// Climb (or descend, negative) by `altitude_change_m`.
    Climb {
        duration_s: f64,
        altitude_change_m: f64,
        ramp_s: Option<f64>,
    },
    /// Change horizontal speed by `speed_change_mps`.
    Accelerate {
        duration_s: f64,
        speed_change_mps: f64,
        ramp_s: Option<f64>,
    },
}

impl Segment {
    pub fn duration_s(&self) -> f64 {
        match *self {
            Segment::Cruise { duration_s }
            | Segment::Turn { duration_s, .. }
            | Segment::Climb { duration_s, .. }
            | Segment::Accelerate { duration_s, .. } => duration_s,
        }
    }
}

/// Errors of loading a scenario: the same shape as a config error (file,
/// key, what was expected), so both are reported the same way.
pub type ScenarioError = polarnav_config::ConfigError;

impl Scenario {
    /// Loads and validates a scenario file.
    pub fn load(path: &Path) -> Result<(Self, String), ScenarioError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: p.clone(),
            source,
        })?;
        let s = Self::parse(&text, &p)?;
        Ok((s, text))
    }

    /// Parses and validates scenario text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self, ScenarioError> {
        let s: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            path: origin.to_owned(),
            message: e.to_string(),
        })?;
        s.validate(origin)?;
        Ok(s)
    }

    fn validate(&self, origin: &str) -> Result<(), ScenarioError> {
        let bad = |key: &str, message: String| ScenarioError::Invalid {
            path: origin.to_owned(),
            key: key.to_owned(),
            message,
        };
        let finite_pos = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(key, format!("must be a positive number, got {v}")))
            }
        };
        let non_neg = |key: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(bad(key, format!("must be ≥ 0, got {v}")))
            }
        };
        if let Some(f) = &self.faults {
            for (k, e) in f.events.iter().enumerate() {
                let key = format!("faults.event[{k}]");
                e.validate(&key).map_err(|m| {
                    let (key, message) = m.split_once(": ").unwrap_or((&key, &m));
                    bad(key, message.to_owned())
                })?;
            }
        }
        if !(-90.0..=90.0).contains(&self.start.lat_deg) {
            return Err(bad(
                "start.lat_deg",
                format!("must be in [-90, 90], got {}", self.start.lat_deg),
            ));
        }
        if self.start.lat_deg.abs() >= 90.0 {
            return Err(bad(
                "start.lat_deg",
                "a flight may cross a pole but not start on one (heading is undefined there)"
                    .into(),
            ));
        }
        if !self.start.lon_deg.is_finite()
            || !self.start.heading_deg.is_finite()
            || !self.start.h_m.is_finite()
        {
            return Err(bad(
                "start",
                "lon_deg, heading_deg and h_m must be finite".into(),
            ));
        }
        non_neg("start.speed_mps", self.start.speed_mps)?;
        finite_pos("imu.rate_hz", self.imu.rate_hz)?;
        if self.imu.rate_hz > 1000.0 {
            return Err(bad(
                "imu.rate_hz",
                format!("at most 1000 Hz, got {}", self.imu.rate_hz),
            ));
        }
        for (k, v) in [
            ("imu.gyro_bias_dph", self.imu.gyro_bias_dph),
            ("imu.accel_bias_ug", self.imu.accel_bias_ug),
            ("imu.arw_dpsh", self.imu.arw_dpsh),
            ("imu.vrw_ug_psqhz", self.imu.vrw_ug_psqhz),
            ("imu.gm_gyro_sigma_dph", self.imu.gm_gyro_sigma_dph),
            ("imu.gm_accel_sigma_ug", self.imu.gm_accel_sigma_ug),
            ("imu.gyro_quant_rad", self.imu.gyro_quant_rad),
            ("imu.accel_quant_mps", self.imu.accel_quant_mps),
            ("init_error.pos_h_m", self.init_error.pos_h_m),
            ("init_error.pos_v_m", self.init_error.pos_v_m),
            ("init_error.vel_h_mps", self.init_error.vel_h_mps),
            ("init_error.vel_v_mps", self.init_error.vel_v_mps),
            ("init_error.tilt_arcmin", self.init_error.tilt_arcmin),
            ("init_error.heading_arcmin", self.init_error.heading_arcmin),
        ] {
            non_neg(k, v)?;
        }
        finite_pos("imu.gm_gyro_tau_s", self.imu.gm_gyro_tau_s)?;
        finite_pos("imu.gm_accel_tau_s", self.imu.gm_accel_tau_s)?;
        finite_pos("truth.rate_hz", self.truth.rate_hz)?;
        for k in msgs::AidKind::ALL {
            let checked = msgs::match_aid_kind!(k, P => P::spec(self).map_or(Ok(()), P::validate));
            if let Err((key, message)) = checked {
                return Err(bad(&format!("{}.{key}", k.name()), message));
            }
        }
        if self.segments.is_empty() {
            return Err(bad(
                "segment",
                "at least one [[segment]] is required".into(),
            ));
        }
        for (i, seg) in self.segments.iter().enumerate() {
            finite_pos(&format!("segment[{i}].duration_s"), seg.duration_s())?;
            let ramp = match seg {
                Segment::Cruise { .. } => None,
                Segment::Turn { ramp_s, .. }
                | Segment::Climb { ramp_s, .. }
                | Segment::Accelerate { ramp_s, .. } => *ramp_s,
            };
            if let Some(r) = ramp
                && !(r > 0.0 && 2.0 * r <= seg.duration_s())
            {
                return Err(bad(
                    &format!("segment[{i}].ramp_s"),
                    format!("must be in (0, duration_s/2], got {r}"),
                ));
            }
        }
        if let Some(n) = &self.navigator
            && let (Some(e), Some(l)) = (n.switch_enter_deg, n.switch_leave_deg)
            && l >= e
        {
            return Err(bad(
                "navigator.switch_leave_deg",
                format!("must be below switch_enter_deg ({e}), got {l}"),
            ));
        }
        Ok(())
    }

    /// Total flight time (s).
    pub fn duration_s(&self) -> f64 {
        self.segments.iter().map(Segment::duration_s).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
name = "t"
[start]
lat_deg = 80.0
lon_deg = 0.0
h_m = 18000.0
heading_deg = 0.0
speed_mps = 250.0
[[segment]]
kind = "cruise"
duration_s = 10.0
"#;

    #[test]
    fn minimal_scenario_parses_with_defaults() {
        let s = Scenario::parse(MINIMAL, "mem").expect("parse");
        assert!((s.imu.rate_hz - 200.0).abs() < 1e-12);
        assert!((s.duration_s() - 10.0).abs() < 1e-12);
    }

    #[test]
    fn unknown_key_is_named() {
        let text = MINIMAL.replace("speed_mps = 250.0", "speed_mps = 250.0\nspeeed = 1");
        let e = Scenario::parse(&text, "file.toml")
            .expect_err("must fail")
            .to_string();
        assert!(e.contains("file.toml") && e.contains("speeed"), "{e}");
    }

    #[test]
    fn invalid_value_names_the_key() {
        let text = MINIMAL.replace("duration_s = 10.0", "duration_s = -1.0");
        let e = Scenario::parse(&text, "f")
            .expect_err("must fail")
            .to_string();
        assert!(e.contains("segment[0].duration_s"), "{e}");
        let text = MINIMAL.replace("lat_deg = 80.0", "lat_deg = 95.0");
        let e = Scenario::parse(&text, "f")
            .expect_err("must fail")
            .to_string();
        assert!(e.contains("start.lat_deg"), "{e}");
    }
}
