//! polarnav's file and viewer messages as protobuf.
//!
//! The schemas are `proto/polarnav/polarnav.proto` (units in every field
//! name; field numbers never reused). The build compiles them with protox
//! and prost: [`polarnav`] holds the Rust types, [`FILE_DESCRIPTOR_SET`] the
//! serialized descriptor set that an MCAP channel or a Foxglove channel
//! carries as its schema (encoding `protobuf`, schema name
//! `polarnav.<Message>`).

#![warn(missing_docs)]

/// The generated message types (package `polarnav`).
#[allow(missing_docs, clippy::all, clippy::pedantic, unused_qualifications)]
pub mod polarnav {
    include!(concat!(env!("OUT_DIR"), "/polarnav.rs"));
}

pub mod aids;
mod solution;

pub use aids::AidMessage;

pub use polarnav::*;

/// The serialized `google.protobuf.FileDescriptorSet` of `polarnav.proto`.
pub const FILE_DESCRIPTOR_SET: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/polarnav.fds"));

/// The protobuf type name of a message of this package, as a schema names it.
pub trait ProtoName {
    /// `polarnav.Solution`, ...
    const NAME: &'static str;
}

macro_rules! names {
    ($($t:ident),* $(,)?) => {
        $(impl ProtoName for polarnav::$t {
            const NAME: &'static str = concat!("polarnav.", stringify!($t));
        })*
    };
}

// The messages that are not an aid's (each aid names its own in `aids`).
names!(
    Solution, ImuSample, InitState, AidUpdate, Status, SwitchNote, Truth, TruthBias,
);

#[cfg(test)]
mod tests {
    use prost::Message;
    use prost_types::field_descriptor_proto::Type;
    use prost_types::{DescriptorProto, FileDescriptorSet};

    /// The units a field name may end in.
    const UNITS: [&str; 12] = [
        "_m", "_mps", "_mps2", "_rad", "_deg", "_rps", "_s", "_ns", "_pa", "_k", "_arcsec", "_nt",
    ];

    /// Dimensionless floating-point fields, by the name patterns the
    /// .proto's header allows: quaternion components, unit-vector
    /// components and ratios.
    fn dimensionless(name: &str) -> bool {
        matches!(name, "qw" | "qx" | "qy" | "qz")
            || name.starts_with("q_b_")
            || name.starts_with("los_")
            || name.starts_with("boresight_")
            || name.ends_with("_ratio")
            || name.ends_with("dop")
    }

    fn messages(fds: &FileDescriptorSet) -> Vec<&DescriptorProto> {
        fds.file
            .iter()
            .flat_map(|f| f.message_type.iter())
            .collect()
    }

    /// Every floating-point field (a physical quantity unless it is one
    /// of the dimensionless kinds above) ends in a unit, and every integer
    /// field that is a time stamp or a duration (`t_*`, `*_t_*`, `*time_*`)
    /// ends in `_ns`. Fields are counted, so a schema
    /// that lost its messages fails too.
    #[test]
    fn every_physical_quantity_is_named_with_its_unit() {
        let fds = FileDescriptorSet::decode(super::FILE_DESCRIPTOR_SET).expect("descriptor set");
        let mut doubles = 0;
        let mut offenders = Vec::new();
        for m in messages(&fds) {
            for f in &m.field {
                let name = f.name();
                let is_float = matches!(f.r#type(), Type::Double | Type::Float);
                let has_unit = UNITS.iter().any(|u| name.ends_with(u));
                if is_float {
                    doubles += 1;
                    if !has_unit && !dimensionless(name) {
                        offenders.push(format!("{}.{name}", m.name()));
                    }
                } else if (name.starts_with("t_") || name.contains("_t_") || name.contains("time_"))
                    && !name.ends_with("_ns")
                {
                    offenders.push(format!("{}.{name} (a time)", m.name()));
                }
            }
        }
        assert!(offenders.is_empty(), "fields without a unit: {offenders:?}");
        assert!(doubles > 100, "only {doubles} floating-point fields");
    }

    /// The checker above is not vacuous: names without units, or with a
    /// unit only inside the name, are caught.
    #[test]
    fn the_unit_check_catches_a_field_without_a_unit() {
        for bad in [
            "innovation",
            "velocity",
            "vx",
            "m_height",
            "heading_degrees",
        ] {
            assert!(
                !UNITS.iter().any(|u| bad.ends_with(u)) && !dimensionless(bad),
                "{bad}"
            );
        }
    }

    /// Each message this crate names is in the descriptor set under that name.
    #[test]
    fn every_named_message_is_in_the_descriptor_set() {
        use super::ProtoName;
        let fds = FileDescriptorSet::decode(super::FILE_DESCRIPTOR_SET).expect("descriptor set");
        let names: Vec<String> = messages(&fds)
            .iter()
            .map(|m| format!("polarnav.{}", m.name()))
            .collect();
        for n in [
            super::Solution::NAME,
            super::ImuSample::NAME,
            super::InitState::NAME,
            super::AidUpdate::NAME,
            super::Status::NAME,
            super::SwitchNote::NAME,
            super::Truth::NAME,
            super::TruthBias::NAME,
        ]
        .into_iter()
        .chain(msgs::AidKind::ALL.map(super::aids::message_name))
        {
            assert!(names.iter().any(|x| x == n), "{n} not in {names:?}");
        }
    }
}
