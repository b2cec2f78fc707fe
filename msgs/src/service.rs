//! iceoryx2 service names. Every service lives under a configurable prefix
//! (default [`DEFAULT_PREFIX`]) so that tests and parallel deployments are
//! isolated from each other.

/// Prefix used when none is configured.
pub const DEFAULT_PREFIX: &str = "polarnav";

/// The services of DESIGN "Messages".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Topic {
    Imu,
    Srs,
    Cns,
    Baro,
    Init,
    Solution,
    Status,
    /// The daemon's effective settings (`EffectiveSettings`), once at start.
    Settings,
}

impl Topic {
    /// Every topic, in a fixed order.
    pub const ALL: [Topic; 8] = [
        Topic::Imu,
        Topic::Srs,
        Topic::Cns,
        Topic::Baro,
        Topic::Init,
        Topic::Solution,
        Topic::Status,
        Topic::Settings,
    ];

    /// The last path component of the service name.
    pub fn leaf(self) -> &'static str {
        match self {
            Topic::Imu => "imu",
            Topic::Srs => "srs",
            Topic::Cns => "cns",
            Topic::Baro => "baro",
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
