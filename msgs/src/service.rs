//! iceoryx2 service names. Every service lives under a configurable prefix
//! (default [`DEFAULT_PREFIX`]) so that tests and parallel deployments are
//! isolated from each other.

use crate::aids::{AID_COUNT, AidKind};

/// Prefix used when none is configured.
pub const DEFAULT_PREFIX: &str = "polarnav";

/// Longest service prefix accepted: every service and node name built from
/// it stays inside iceoryx2's limits (service names 255 bytes, node names 128).
pub const PREFIX_MAX_LEN: usize = 64;

/// The one check of a service prefix, for the configuration file and every
/// command line (`--prefix`) alike: 1 to [`PREFIX_MAX_LEN`] characters of
/// `A-Z a-z 0-9 _ - .` in `/`-separated parts, none empty. iceoryx2 itself
/// takes any ASCII but NUL; this is narrower so that a prefix is also a
/// safe node name, file-name part and journal field.
pub fn validate_prefix(prefix: &str) -> Result<(), String> {
    if prefix.is_empty() {
        return Err("expected a service prefix, got an empty one".into());
    }
    if prefix.len() > PREFIX_MAX_LEN {
        return Err(format!(
            "expected at most {PREFIX_MAX_LEN} characters, got {}",
            prefix.len()
        ));
    }
    if let Some(c) = prefix
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | '/')))
    {
        return Err(format!(
            "expected only A-Z a-z 0-9 _ - . and /, got {c:?} in {prefix:?}"
        ));
    }
    if prefix.split('/').any(str::is_empty) {
        return Err(format!(
            "expected /-separated parts that are not empty, got {prefix:?}"
        ));
    }
    Ok(())
}

/// The services of DESIGN "Messages".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Topic {
    Imu,
    /// An aid's samples (its payload), `<prefix>/NAME`.
    Aid(AidKind),
    Init,
    Solution,
    Status,
    /// The daemon's effective settings (`EffectiveSettings`), once at start.
    Settings,
}

/// Number of services: the IMU, the aids, init, solution, status, settings.
pub const TOPIC_COUNT: usize = AID_COUNT + 5;

impl Topic {
    /// Every topic, in a fixed order: the IMU, the aids, then the rest.
    pub const ALL: [Topic; TOPIC_COUNT] = {
        let mut all = [Topic::Imu; TOPIC_COUNT];
        let mut k = 0;
        while k < AID_COUNT {
            all[1 + k] = Topic::Aid(AidKind::ALL[k]);
            k += 1;
        }
        all[AID_COUNT + 1] = Topic::Init;
        all[AID_COUNT + 2] = Topic::Solution;
        all[AID_COUNT + 3] = Topic::Status;
        all[AID_COUNT + 4] = Topic::Settings;
        all
    };

    /// The last path component of the service name.
    pub fn leaf(self) -> &'static str {
        match self {
            Topic::Imu => "imu",
            Topic::Aid(k) => k.name(),
            Topic::Init => "init",
            Topic::Solution => "solution",
            Topic::Status => "status",
            Topic::Settings => "settings",
        }
    }

    /// Full service name `<prefix>/<leaf>`; a trailing `/` on the prefix is ignored.
    pub fn service_name(self, prefix: &str) -> String {
        format!("{}/{}", prefix.trim_end_matches('/'), self.leaf())
    }

    /// Name of the companion event service used to wake WaitSets (`<prefix>/<leaf>/event`).
    pub fn event_name(self, prefix: &str) -> String {
        format!("{}/event", self.service_name(prefix))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefixes_outside_the_rule_are_refused_with_the_reason() {
        for ok in ["polarnav", "pntest_ab_12_0", "fleet/uav-7", "a.b"] {
            assert_eq!(validate_prefix(ok), Ok(()), "{ok}");
        }
        let long = "x".repeat(PREFIX_MAX_LEN + 1);
        for (bad, why) in [
            ("", "empty"),
            (long.as_str(), "at most 64"),
            ("a b", "' '"),
            ("a\0b", "'\\0'"),
            ("nav\u{e9}", "'\u{e9}'"),
            ("iox2://x", "':'"),
            ("/abs", "not empty"),
            ("a//b", "not empty"),
            ("trailing/", "not empty"),
        ] {
            let e = validate_prefix(bad).expect_err(bad);
            assert!(e.contains(why), "{bad:?}: {e}");
        }
        // The longest accepted prefix still makes valid iceoryx2 names.
        let max = "p".repeat(PREFIX_MAX_LEN);
        for t in Topic::ALL {
            assert!(t.event_name(&max).len() <= 255);
        }
    }

    #[test]
    fn service_names_share_the_prefix() {
        assert_eq!(Topic::Imu.service_name("polarnav"), "polarnav/imu");
        assert_eq!(Topic::Status.service_name("test-42/"), "test-42/status");
        assert_eq!(Topic::Solution.event_name("p"), "p/solution/event");
        let names: std::collections::HashSet<_> = Topic::ALL
            .iter()
            .map(|t| t.service_name(DEFAULT_PREFIX))
            .collect();
        assert_eq!(names.len(), Topic::ALL.len());
    }
}
