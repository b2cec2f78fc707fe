//! Navigator settings: plain structs the core owns, in datasheet units, each
//! with its validation. The daemon's TOML schema (crate `polarnav-config`)
//! deserializes into them; nothing here knows a file format.

use serde::{Deserialize, Serialize};

use msgs::{AID_COUNT, AidKind, PerAid};

use crate::aids::OwnAidSettings;
pub use crate::bounds::{Bound, MAX_FLIGHT_S, SettingsError};
use crate::frame_select::{FramePolicy, SwitchLatitudes};

/// Filter parameter conversion at a frame switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Conversion {
    /// X and P converted (papers/001 eqs 32–38).
    #[default]
    Paper,
    /// Nominal parameters converted, P carried over unchanged (the papers' baseline).
    None,
}

/// Which aids to fuse: one flag per aid, written as the list of the names
/// of those on (`srs,cns,baro,star`) or `none`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(try_from = "String", into = "String")]
pub struct AidSet(pub PerAid<bool>);

impl Default for AidSet {
    /// Every aid: a log or a live system that has an aid's stream fuses
    /// it, and one without it simply has no samples.
    fn default() -> Self {
        Self(PerAid([true; AID_COUNT]))
    }
}

impl AidSet {
    pub const NONE: AidSet = AidSet(PerAid([false; AID_COUNT]));

    /// Whether aid `k` is on.
    pub fn has(&self, k: AidKind) -> bool {
        self.0[k]
    }

    /// This set with aid `k` on or off.
    pub fn with(mut self, k: AidKind, on: bool) -> Self {
        self.0[k] = on;
        self
    }

    /// Parses a comma-separated list of aid names (any subset) or `none`.
    pub fn parse(s: &str) -> Result<Self, String> {
        if s.trim() == "none" {
            return Ok(Self::NONE);
        }
        let mut a = Self::NONE;
        for part in s.split(',').map(str::trim) {
            match AidKind::from_name(part) {
                Some(k) => a.0[k] = true,
                None => {
                    return Err(format!(
                        "unknown aid {part:?}: expected a list of {}, or none",
                        AidKind::names()
                    ));
                }
            }
        }
        Ok(a)
    }
}

impl TryFrom<String> for AidSet {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        Self::parse(&s)
    }
}

impl From<AidSet> for String {
    fn from(a: AidSet) -> String {
        a.to_string()
    }
}

impl std::fmt::Display for AidSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = self
            .0
            .iter()
            .filter_map(|(k, on)| on.then_some(k.name()))
            .collect();
        if names.is_empty() {
            f.write_str("none")
        } else {
            f.write_str(&names.join(","))
        }
    }
}

/// The largest 1-σ an init may state: position 100 km, velocity 1 km/s,
/// tilt 1 rad, heading 2π (beyond these the state carries no information
/// and P₀ would span more magnitudes than a double resolves). The
/// navigator refuses an init beyond them (`navigator::check_init`); the
/// settings refuse a configured one before any navigator exists.
pub const INIT_SIGMA_MAX: [f64; 6] = [1e5, 1e5, 1e3, 1e3, 1.0, std::f64::consts::TAU];

/// `[init]`: the initial state from configuration (used when a log or the
/// transport provides no init record), with its 1-σ.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
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
    pub fn validate(&self, origin: &str) -> Result<(), SettingsError> {
        // The same limits as the navigator's check of an init record
        // (`navigator::check_init`, `INIT_SIGMA_MAX`): an init outside them
        // would be refused at the first IMU sample, and nothing would start.
        let angle = |lo: f64, hi: f64, what: &'static str| Bound {
            lo,
            hi,
            unit: "deg",
            below: what,
            above: what,
        };
        angle(-90.0, 90.0, "a latitude is at most 90° from the equator").check(
            origin,
            "init.lat_deg",
            self.lat_deg,
        )?;
        angle(-360.0, 360.0, "a longitude is an angle of at most a turn").check(
            origin,
            "init.lon_deg",
            self.lon_deg,
        )?;
        Bound {
            lo: -1000.0,
            hi: 1e5,
            unit: "m",
            below: "more than 1 km below the ellipsoid is underground everywhere",
            above: "100 km is space: the barometer and the atmosphere model end far below",
        }
        .check(origin, "init.h_m", self.h_m)?;
        for (i, v) in self.vel_enu_mps.iter().enumerate() {
            Bound {
                lo: -1000.0,
                hi: 1000.0,
                unit: "m/s",
                below: "faster than 1 km/s is not this aircraft",
                above: "faster than 1 km/s is not this aircraft",
            }
            .check(origin, &format!("init.vel_enu_mps[{i}]"), *v)?;
        }
        let speed = self.vel_enu_mps.iter().map(|v| v * v).sum::<f64>().sqrt();
        if speed > 1000.0 {
            return Err(SettingsError {
                origin: origin.to_owned(),
                key: "init.vel_enu_mps".to_owned(),
                message: format!(
                    "expected a speed of at most 1000 m/s, got {speed}: the navigator refuses \
                     a faster init (not this aircraft)"
                ),
            });
        }
        angle(-360.0, 360.0, "a heading is an angle of at most a turn").check(
            origin,
            "init.heading_deg",
            self.heading_deg,
        )?;
        angle(
            -90.0,
            90.0,
            "pitch is at most 90° (Euler angles beyond are another attitude)",
        )
        .check(origin, "init.pitch_deg", self.pitch_deg)?;
        angle(-180.0, 180.0, "roll is at most half a turn").check(
            origin,
            "init.roll_deg",
            self.roll_deg,
        )?;
        let max = INIT_SIGMA_MAX;
        let arcmin = 180.0 / std::f64::consts::PI * 60.0;
        for (k, v, hi, unit) in [
            ("init.sigma_pos_h_m", self.sigma_pos_h_m, max[0], "m"),
            ("init.sigma_pos_v_m", self.sigma_pos_v_m, max[1], "m"),
            ("init.sigma_vel_mps", self.sigma_vel_mps, max[2], "m/s"),
            (
                "init.sigma_tilt_arcmin",
                self.sigma_tilt_arcmin,
                max[4] * arcmin,
                "arcmin",
            ),
            (
                "init.sigma_heading_arcmin",
                self.sigma_heading_arcmin,
                max[5] * arcmin,
                "arcmin",
            ),
        ] {
            // A σ above 0 but below the navigator's floor (1 cm, 1 mm/s,
            // 1 µrad) is raised to it, so P₀ stays positive definite.
            Bound {
                lo: f64::MIN_POSITIVE,
                hi,
                unit,
                below: "a zero or negative 1-σ claims an exact state: P₀ would not be positive \
                        definite",
                above: "P₀ would span more magnitudes than a double resolves (and the \
                        navigator refuses such an init)",
            }
            .check(origin, k, v)?;
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
            ..Default::default()
        }
    }
}

/// A sensor grade: the IMU noise model of a class of sensors, by name
/// (`[filter] preset`, a scenario's `[navigator] preset`, the importers'
/// `--preset`). Each bias is one stationary first-order Gauss–Markov
/// process, so its initial 1-σ is its stationary σ (the filter's prior and
/// its process noise describe the same process).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SensorGrade {
    /// Navigation grade (ring-laser / fibre-optic gyros, servo
    /// accelerometers): papers/001 Table 1's noise and initial bias σ, the
    /// biases wandering with a 1 h correlation time.
    Navigation,
    /// Tactical grade (small FOG / high-end MEMS gyros).
    Tactical,
    /// Consumer/industrial MEMS.
    Mems,
}

impl SensorGrade {
    pub const ALL: [SensorGrade; 3] = [
        SensorGrade::Navigation,
        SensorGrade::Tactical,
        SensorGrade::Mems,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SensorGrade::Navigation => "navigation",
            SensorGrade::Tactical => "tactical",
            SensorGrade::Mems => "mems",
        }
    }

    /// Parses a grade name; the error lists the names.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|g| g.name() == s)
            .ok_or_else(|| {
                format!("unknown sensor grade {s:?}: expected navigation, tactical or mems")
            })
    }

    /// The `[filter]` keys this grade sets and their values (datasheet
    /// units: deg/√h, µg/√Hz, deg/h, µg, s).
    pub fn values(self) -> [(&'static str, f64); 8] {
        // (ARW, VRW, gyro bias σ, τ_g, accel bias σ, τ_a)
        let (arw, vrw, g, tg, a, ta) = match self {
            SensorGrade::Navigation => (0.001, 10.0, 0.01, 3600.0, 100.0, 3600.0),
            SensorGrade::Tactical => (0.1, 50.0, 1.0, 1800.0, 500.0, 1800.0),
            SensorGrade::Mems => (0.3, 300.0, 50.0, 600.0, 2000.0, 600.0),
        };
        [
            ("arw_dpsh", arw),
            ("vrw_ug_psqhz", vrw),
            ("gyro_bias_dph", g),
            ("gyro_bias_instability_dph", g),
            ("gyro_bias_tau_s", tg),
            ("accel_bias_ug", a),
            ("accel_bias_instability_ug", a),
            ("accel_bias_tau_s", ta),
        ]
    }

    /// The widest bias model of any grade: the largest bias-instability σ
    /// and the shortest correlation time among the presets, as a Gauss–Markov
    /// process in SI units (gyro rad/s, accelerometer m/s²). It bounds the
    /// biases of every IMU the presets describe whatever preset was chosen;
    /// an aid reset falls back to it (`navigator::recovery`).
    pub fn widest_bias_model() -> BiasModel {
        let dph = std::f64::consts::PI / 180.0 / 3600.0;
        let ug = 1e-6 * crate::earth::G0;
        let mut m = BiasModel {
            gyro_sigma: 0.0,
            gyro_tau_s: f64::INFINITY,
            accel_sigma: 0.0,
            accel_tau_s: f64::INFINITY,
        };
        for g in Self::ALL {
            for (k, v) in g.values() {
                match k {
                    "gyro_bias_instability_dph" => m.gyro_sigma = m.gyro_sigma.max(v * dph),
                    "gyro_bias_tau_s" => m.gyro_tau_s = m.gyro_tau_s.min(v),
                    "accel_bias_instability_ug" => m.accel_sigma = m.accel_sigma.max(v * ug),
                    "accel_bias_tau_s" => m.accel_tau_s = m.accel_tau_s.min(v),
                    _ => {}
                }
            }
        }
        m
    }

    /// `base` with this grade's noise model (other keys unchanged).
    pub fn apply(self, base: &FilterSettings) -> FilterSettings {
        let mut f = base.clone();
        for (k, v) in self.values() {
            *f.noise_key_mut(k).expect("a preset sets noise keys only") = v;
        }
        f.preset = Some(self);
        f
    }
}

/// The filter's bias model (defined with the process noise it shapes).
pub use crate::filter::BiasModel;

impl std::fmt::Display for SensorGrade {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `[filter]`: IMU noise model and initial bias uncertainty, in datasheet units.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FilterSettings {
    /// The sensor grade the noise keys were taken from (keys given beside
    /// it in the same place override it); `None` when they are given one by one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preset: Option<SensorGrade>,
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
    /// The longest gap that is coasted (s). A sample further ahead of the
    /// previous one, or behind it, is a time jump: the session holds it and
    /// re-synchronizes only when the samples after it confirm the new time
    /// base (the covariance then grows as for a coast of this length).
    pub imu_max_coast_s: f64,
    pub coast_accel_mps2: f64,
    pub coast_rate_dps: f64,
    /// `[filter.flight_state]`: flight-state recognition and the
    /// accelerometers' attitude compensation (paper 003 §4.5).
    pub flight_state: crate::flight_state::FlightStateSettings,
}

impl Default for FilterSettings {
    fn default() -> Self {
        // papers/001 Table 1.
        Self {
            preset: None,
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
            imu_max_coast_s: 60.0,
            coast_accel_mps2: 1.0,
            coast_rate_dps: 0.05,
            flight_state: Default::default(),
        }
    }
}

/// `[aids]`: χ² gates (thresholds on the normalized innovation squared),
/// timeouts after which an aid is stale, the latest an aid may arrive, and
/// each aid's own settings. Written with one key per aid for its gate and
/// timeout (`srs_gate`, `srs_timeout_s`, ..., the names of the aid
/// declaration) and a table `[aids.NAME]` for an aid that has settings of
/// its own.
#[derive(Debug, Clone, PartialEq)]
pub struct AidSettings {
    /// Per aid: the χ² threshold of its innovation (`NAME_gate`).
    pub gate: PerAid<f64>,
    /// Per aid: stale after this long without a fused sample (`NAME_timeout_s`, s).
    pub timeout_s: PerAid<f64>,
    /// Aids older than this relative to the newest IMU sample are rejected as late (s).
    pub max_latency_s: f64,
    /// The aids to fuse: a list of aid names, or `none` (received samples
    /// of the others are counted as not used).
    pub fuse: AidSet,
    /// An aid rejected at the gate continuously for this long (s) while its
    /// own innovations agree with each other and with its last fused sample
    /// resets the states it observes to it (0 = never).
    pub reset_after_s: f64,
    /// Each aid's own settings.
    pub own: OwnAidSettings,
}

impl Default for AidSettings {
    fn default() -> Self {
        // The declarations' defaults: 99.9 % χ² quantiles for the aid's
        // degrees of freedom, and its timeout.
        Self {
            gate: PerAid::from_fn(|k| k.decl().gate),
            timeout_s: PerAid::from_fn(|k| k.decl().timeout_s),
            max_latency_s: 0.1,
            fuse: AidSet::default(),
            reset_after_s: 5.0,
            own: OwnAidSettings::default(),
        }
    }
}

/// The keys of `[aids]` besides each aid's: in the order they are written.
const AID_TABLE_KEYS: [&str; 3] = ["max_latency_s", "fuse", "reset_after_s"];

macro_rules! aid_keys {
    ([$(($K:ident, $n:ident, $P:ident, $d:tt)),* $(,)?]) => {
        /// `NAME_gate` of each aid.
        const GATE_KEYS: [&str; AID_COUNT] = [$(concat!(stringify!($n), "_gate")),*];
        /// `NAME_timeout_s` of each aid.
        const TIMEOUT_KEYS: [&str; AID_COUNT] = [$(concat!(stringify!($n), "_timeout_s")),*];
        /// Every key `[aids]` takes (for the unknown-key message).
        const ALL_AID_KEYS: &[&str] = &[
            $(concat!(stringify!($n), "_gate"),)*
            $(concat!(stringify!($n), "_timeout_s"),)*
            "max_latency_s",
            "fuse",
            "reset_after_s",
            $(stringify!($n),)*
        ];
    };
}
msgs::for_each_aid!(aid_keys);

impl Serialize for AidSettings {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut t = s.serialize_struct("AidSettings", ALL_AID_KEYS.len())?;
        for (k, v) in GATE_KEYS.iter().zip(&self.gate.0) {
            t.serialize_field(k, v)?;
        }
        for (k, v) in TIMEOUT_KEYS.iter().zip(&self.timeout_s.0) {
            t.serialize_field(k, v)?;
        }
        t.serialize_field(AID_TABLE_KEYS[0], &self.max_latency_s)?;
        t.serialize_field(AID_TABLE_KEYS[1], &self.fuse)?;
        t.serialize_field(AID_TABLE_KEYS[2], &self.reset_after_s)?;
        self.own.serialize_into(&mut t)?;
        t.end()
    }
}

impl<'de> Deserialize<'de> for AidSettings {
    /// Every key optional (its default when absent), unknown keys refused.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{Error, MapAccess, Visitor};
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = AidSettings;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("struct AidSettings")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<AidSettings, A::Error> {
                let mut a = AidSettings::default();
                while let Some(key) = map.next_key::<String>()? {
                    let key = key.as_str();
                    if let Some(k) = GATE_KEYS.iter().position(|g| *g == key) {
                        a.gate.0[k] = map.next_value()?;
                    } else if let Some(k) = TIMEOUT_KEYS.iter().position(|g| *g == key) {
                        a.timeout_s.0[k] = map.next_value()?;
                    } else if key == AID_TABLE_KEYS[0] {
                        a.max_latency_s = map.next_value()?;
                    } else if key == AID_TABLE_KEYS[1] {
                        a.fuse = map.next_value()?;
                    } else if key == AID_TABLE_KEYS[2] {
                        a.reset_after_s = map.next_value()?;
                    } else if let Some(k) = AidKind::from_name(key) {
                        a.own.deserialize_from(k, &mut map)?;
                    } else {
                        return Err(A::Error::unknown_field(key, ALL_AID_KEYS));
                    }
                }
                Ok(a)
            }
        }
        d.deserialize_struct("AidSettings", ALL_AID_KEYS, V)
    }
}

/// `[frame]`: when to use the grid frame.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FrameSettings {
    /// Enter the grid frame at |latitude| ≥ this (deg).
    pub switch_enter_deg: f64,
    /// Leave it at |latitude| ≤ this (deg).
    pub switch_leave_deg: f64,
    /// Forced switch times (s); when non-empty the latitude rule is off.
    pub force_switch_s: Vec<f64>,
    /// Stay in g for the whole run (reference runs of the switching experiments).
    pub never_switch: bool,
    /// Filter parameter conversion at a switch: `paper` (X and P converted)
    /// or `none` (the papers' baseline: nominal state only).
    pub conversion: Conversion,
}

impl Default for FrameSettings {
    fn default() -> Self {
        Self {
            switch_enter_deg: 70.0,
            switch_leave_deg: 69.5,
            force_switch_s: Vec::new(),
            never_switch: false,
            conversion: Conversion::Paper,
        }
    }
}

fn check(origin: &str, key: &str, v: f64, ok: bool, expected: &str) -> Result<(), SettingsError> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(SettingsError {
            origin: origin.to_owned(),
            key: key.to_owned(),
            message: format!("expected {expected}, got {v}"),
        })
    }
}

/// The resolution of every time stamp (`t_ns`): a shorter time is not a time.
pub const STAMP_RESOLUTION_S: f64 = 1e-9;

/// The shortest IMU period the system takes (1 kHz, `[live] imu_rate_hz`).
pub const MIN_IMU_PERIOD_S: f64 = 1e-3;

/// The Earth's rotation rate in °/s (0.004178): what a gyro at rest measures.
pub fn earth_rate_dps() -> f64 {
    crate::earth::OMEGA_IE.to_degrees()
}

/// The largest normal gravity (at the poles, at the ellipsoid: 9.8322 m/s²):
/// the specific force an IMU at rest or in level flight measures there.
pub fn max_normal_gravity_mps2() -> f64 {
    crate::earth::normal_gravity(std::f64::consts::FRAC_PI_2, 0.0)
}

/// Above these the squares, 2σ²/τ and P₀ of the noise model leave the
/// range of normal doubles: a unit mistake, not a sensor.
const NOISE_TOO_LARGE: &str =
    "no IMU is that noisy, and the covariance built from it would overflow (a unit mistake?)";

impl FilterSettings {
    /// The noise key `name` (a key a [`SensorGrade`] sets).
    fn noise_key_mut(&mut self, name: &str) -> Option<&mut f64> {
        Some(match name {
            "arw_dpsh" => &mut self.arw_dpsh,
            "vrw_ug_psqhz" => &mut self.vrw_ug_psqhz,
            "gyro_bias_dph" => &mut self.gyro_bias_dph,
            "gyro_bias_instability_dph" => &mut self.gyro_bias_instability_dph,
            "gyro_bias_tau_s" => &mut self.gyro_bias_tau_s,
            "accel_bias_ug" => &mut self.accel_bias_ug,
            "accel_bias_instability_ug" => &mut self.accel_bias_instability_ug,
            "accel_bias_tau_s" => &mut self.accel_bias_tau_s,
            _ => return None,
        })
    }

    pub fn validate(&self, origin: &str) -> Result<(), SettingsError> {
        // Ranges wide enough for any real IMU and narrow enough that the
        // squares, 2σ²/τ and P₀ stay normal doubles: a value outside them is
        // a unit mistake, not a sensor.
        let white = "0 is a noise-free sensor; a negative density is not one";
        for (k, v, hi, unit) in [
            ("filter.arw_dpsh", self.arw_dpsh, 100.0, "deg/√h"),
            ("filter.vrw_ug_psqhz", self.vrw_ug_psqhz, 1e5, "µg/√Hz"),
            (
                "filter.gyro_bias_instability_dph",
                self.gyro_bias_instability_dph,
                1e4,
                "deg/h",
            ),
            (
                "filter.accel_bias_instability_ug",
                self.accel_bias_instability_ug,
                1e5,
                "µg",
            ),
        ] {
            Bound {
                lo: 0.0,
                hi,
                unit,
                below: white,
                above: NOISE_TOO_LARGE,
            }
            .check(origin, k, v)?;
        }
        for (k, v, lo, hi, unit) in [
            (
                "filter.gyro_bias_dph",
                self.gyro_bias_dph,
                1e-6,
                1e4,
                "deg/h",
            ),
            ("filter.accel_bias_ug", self.accel_bias_ug, 1e-3, 1e5, "µg"),
        ] {
            Bound {
                lo,
                hi,
                unit,
                below: "a smaller initial 1-σ leaves the bias block of P₀ too small beside the \
                        attitude and velocity variances for a double: the covariance would lose \
                        positive definiteness in the first updates",
                above: NOISE_TOO_LARGE,
            }
            .check(origin, k, v)?;
        }
        let c = self.covariance_interval_s;
        Bound {
            lo: STAMP_RESOLUTION_S,
            hi: 1.0,
            unit: "s",
            below: "shorter than the 1 ns resolution of the time stamps",
            above: "the covariance must be propagated at least once a second (the aid rates) \
                    for the first-order transition matrix to hold",
        }
        .check(origin, "filter.covariance_interval_s", c)?;
        for (k, v) in [
            ("filter.gyro_bias_tau_s", self.gyro_bias_tau_s),
            ("filter.accel_bias_tau_s", self.accel_bias_tau_s),
        ] {
            // Below 1 s a "bias" is white noise, and below 10 covariance
            // intervals the second-order Φ = 1 − Δt/τ + (Δt/τ)²/2 is no
            // longer close to e^(−Δt/τ); above ~11 days it is a constant
            // over any flight.
            let lo = (10.0 * c).max(1.0);
            Bound {
                lo,
                hi: 1e6,
                unit: "s",
                below: "below 1 s a bias is white noise, and below 10 filter.covariance_interval_s \
                        the discrete Gauss–Markov transition is no longer e^(−Δt/τ)",
                above: "beyond 11 days the bias is a constant over any flight: set its \
                        instability to 0 instead",
            }
            .check(origin, k, v)?;
        }
        let g = max_normal_gravity_mps2();
        Bound {
            lo: earth_rate_dps(),
            hi: 1e5,
            unit: "°/s",
            below: "every gyro at rest measures the Earth's rate (0.004178 °/s): every IMU \
                    sample would be refused",
            above: "no gyro measures 1e5 °/s (280 rev/s): the limit would refuse nothing",
        }
        .check(origin, "filter.max_gyro_rate_dps", self.max_gyro_rate_dps)?;
        let below_g = format!(
            "an IMU at rest or in level flight measures gravity ({g:.4} m/s² at the poles): \
             every IMU sample would be refused"
        );
        Bound {
            lo: g,
            hi: 1e5,
            unit: "m/s²",
            below: &below_g,
            above: "no accelerometer measures 1e4 g: the limit would refuse nothing",
        }
        .check(origin, "filter.max_accel_mps2", self.max_accel_mps2)?;
        Bound {
            lo: MIN_IMU_PERIOD_S,
            hi: 3600.0,
            unit: "s",
            below: "shorter than one period of the fastest IMU (1 kHz): every sample would be \
                    a time jump",
            above: "an hour without IMU cannot be bridged",
        }
        .check(origin, "filter.imu_gap_s", self.imu_gap_s)?;
        check(
            origin,
            "filter.imu_max_coast_s",
            self.imu_max_coast_s,
            self.imu_max_coast_s > self.imu_gap_s && self.imu_max_coast_s <= 3600.0,
            "a time in seconds above filter.imu_gap_s and at most 3600 (a coast is a gap \
             longer than imu_gap_s; after an hour without IMU the state is unknown)",
        )?;
        Bound {
            lo: 0.0,
            hi: 100.0,
            unit: "m/s²",
            below: "a negative 1-σ is not one",
            above: "no airframe of this class survives a 10 g manoeuvre",
        }
        .check(origin, "filter.coast_accel_mps2", self.coast_accel_mps2)?;
        Bound {
            lo: 0.0,
            hi: 360.0,
            unit: "°/s",
            below: "a negative 1-σ is not one",
            above: "a HALE airframe does not turn a full circle per second",
        }
        .check(origin, "filter.coast_rate_dps", self.coast_rate_dps)?;
        self.flight_state.validate(origin)?;
        Ok(())
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
    pub fn validate(&self, origin: &str) -> Result<(), SettingsError> {
        // A gate is a threshold on a χ² variable with as many degrees of
        // freedom as the aid has components (its declaration's); its mean
        // is that number.
        for (k, v) in self.gate.iter() {
            Bound {
                lo: k.decl().dof() as f64,
                hi: 1e4,
                unit: "(χ²)",
                below: "below the mean of the χ² of a consistent innovation (its degrees of \
                        freedom) most good samples of the aid would be refused",
                above: "beyond a 100-σ innovation the gate refuses nothing, not even a fault",
            }
            .check(origin, &format!("aids.{}", GATE_KEYS[k as usize]), *v)?;
        }
        for (k, v) in self.timeout_s.iter() {
            Bound {
                lo: 0.02,
                hi: MAX_FLIGHT_S,
                unit: "s",
                below: "shorter than one period of the fastest aid (50 Hz): the aid would be \
                        stale between every two samples",
                above: "longer than any flight (1e7 s, 116 days): a dead aid would never be \
                        reported",
            }
            .check(origin, &format!("aids.{}", TIMEOUT_KEYS[k as usize]), *v)?;
        }
        Bound {
            lo: MIN_IMU_PERIOD_S,
            hi: 1.0,
            unit: "s",
            below: "shorter than one period of the fastest IMU (1 ms): any transport delay \
                    would make every aid late",
            above: "an aid may wait at most 1 s for the IMU, and the state history reaches \
                    back no further",
        }
        .check(origin, "aids.max_latency_s", self.max_latency_s)?;
        let r = self.reset_after_s;
        check(
            origin,
            "aids.reset_after_s",
            r,
            r == 0.0 || (5.0..=3600.0).contains(&r),
            "0 (never) or a time in [5, 3600] s (a shorter streak cannot tell a drifting \
             filter from an aid fault; after an hour of refusals the state is lost anyway)",
        )?;
        self.own.validate(origin)
    }
}

impl FrameSettings {
    /// Checks the values; `origin` and `table` name the place in errors.
    pub fn validate(&self, origin: &str, table: &str) -> Result<(), SettingsError> {
        let bad = |key: &str, message: String| SettingsError {
            origin: origin.to_owned(),
            key: format!("{table}.{key}"),
            message,
        };
        Bound {
            lo: 1.0,
            hi: 89.0,
            unit: "deg",
            below: "the grid frame is singular on the equator at λ = ±90° (grid north = \
                    unit(n × ŷ_e) vanishes): it must not be entered within 1° of it",
            above: "the geographic frame's tan L terms grow beyond 57 within 1° of the pole: \
                    entering the grid frame later cannot carry a flight across it (set \
                    never_switch for a reference run that stays in g)",
        }
        .check(
            origin,
            &format!("{table}.switch_enter_deg"),
            self.switch_enter_deg,
        )?;
        Bound {
            lo: 1.0,
            hi: 89.0,
            unit: "deg",
            below: "the grid frame is singular on the equator at λ = ±90° (grid north = \
                    unit(n × ŷ_e) vanishes): it must be left at least 1° from it",
            above: "the geographic frame cannot be used within 1° of the pole",
        }
        .check(
            origin,
            &format!("{table}.switch_leave_deg"),
            self.switch_leave_deg,
        )?;
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
            if t > MAX_FLIGHT_S {
                return Err(bad(
                    "force_switch_s",
                    format!(
                        "expected times of at most {MAX_FLIGHT_S} s, got {t}: longer than any \
                         flight (116 days), the switch would never happen"
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
