//! The aids, each declared once (issue 29).
//!
//! An aid is an input stream that the navigator fuses at its own time
//! stamp. Everything the system keeps per aid comes from its one entry
//! here, and nowhere else lists the aids:
//!
//! | what | derived from the entry |
//! |---|---|
//! | payload | the entry's type (`#[repr(C)]`, zero-copy, in [`crate::payloads`] or the aid's own file) |
//! | iceoryx2 service | `<prefix>/NAME` ([`crate::service::Topic::Aid`]) |
//! | navlog record | variant index `record` of [`crate::navlog::Record`] |
//! | settings | `[aids] NAME_gate`, `NAME_timeout_s`, and the aid's own table `[aids.NAME]` if its model has settings |
//! | enable name | `--aids NAME` / `[aids] fuse` |
//! | counters and status | `Status::streams[1 + k]`, `Status::aids[k]` for `k = AidKind as usize` |
//! | freshness flag | `fresh_flag` in [`crate::solution_flags`]' bit set |
//! | MCAP channels | `/NAME` (the payload) and `/aid/NAME` (each update) |
//! | review figure | `aid_NAME`, one panel per innovation component |
//!
//! **The design, and why.** The entry list is an X-macro,
//! [`for_each_aid!`]: a crate that needs one item per aid (a struct field,
//! an enum variant, a match arm) hands the list to a macro of its own,
//! which the compiler expands; code that needs only the aid's data loops
//! over [`AidKind::ALL`] and reads its [`AidDecl`]. What an aid *does* is a
//! trait its payload implements in a file of the aid's own (PX4 EKF2 keeps
//! each aid source's control and fusion in a file of its own in the same
//! way): the measurement model in the core (`polarnav::aids::Aid`), the
//! protobuf message (`polarnav_proto::AidMessage`) and the simulator model
//! (`polarnav_sim::aids::SimAid`). Adding an aid is therefore: its payload,
//! its line in [`AidKind`] and its entry in [`for_each_aid!`] (this file),
//! its model, its protobuf message and its simulator model; the compiler
//! refuses a registration that lacks any of them. A table of function
//! pointers or trait objects would do the dispatch too, but could not make
//! the per-aid struct fields (settings sections, typed publishers and
//! subscribers, MCAP channels) that the macro makes, and an enum of
//! payloads keeps the navigator's queue allocation-free.
//!
//! The enum is written out (not generated) so that cbindgen, which does
//! not expand macros, puts it in the C header; a check below makes the
//! compiler hold it and the list to the same aids in the same order.

use crate::baseline::BaselineSample;
use crate::gnss::GnssFix;
use crate::mag::MagSample;
use crate::payloads::{BaroSample, CnsFix, SrsSample, StarSample};
use crate::solution_flags;

/// An aid, by its index in every per-aid array (`Status::aids`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum AidKind {
    /// Spectral-redshift velocity.
    Srs = 0,
    /// Celestial latitude and longitude.
    Cns = 1,
    /// Barometric altitude.
    Baro = 2,
    /// Star tracker attitude.
    Star = 3,
    /// GNSS position and velocity (not autonomous: tested for integrity).
    Gnss = 4,
    /// Dual-antenna GNSS baseline (attitude: heading and pitch, or roll).
    Baseline = 5,
    /// Magnetometer heading (the World Magnetic Model's declination).
    Mag = 6,
}

/// The most innovation components an aid has (the length of
/// `AidStatus::innovation`).
pub const MAX_COMPONENTS: usize = 6;

/// The most causes an aid refuses a sample for before fusion (the length
/// of `AidStatus::refused`).
pub const MAX_CAUSES: usize = 4;

/// Number of aids (the length of `Status::aids`).
pub const AID_COUNT: usize = 7;
/// Number of input streams with counters: the IMU and the aids (the
/// length of `Status::streams`).
pub const STREAM_COUNT: usize = AID_COUNT + 1;

/// The aids, each declared once: `(Kind, name, Payload, { declaration })`,
/// in [`AidKind`]'s order (the order of every per-aid array and of fusion
/// at equal time stamps).
///
/// `for_each_aid!(path::to::callback, extra, ...)` expands to
/// `callback! { extra, ..., [(Srs, srs, SrsSample, {..}), ...] }`: each
/// extra argument is one token tree, and the list comes last.
#[macro_export]
macro_rules! for_each_aid {
    ($($m:ident)::+ $(, $arg:tt)*) => {
        $($m)::+! { $($arg,)* [
            (Srs, srs, SrsSample, {
                label: "SRS",
                title: "spectral-redshift velocity",
                record: 3,
                fresh_flag: SRS_FRESH,
                components: &[
                    Component::new("v x", Unit::Mps),
                    Component::new("v y", Unit::Mps),
                    Component::new("v z", Unit::Mps),
                ],
                gate: 16.266,
                timeout_s: 3.0,
                causes: &["invalid content"],
                autonomous: true,
                excluded_flag: 0,
                untested_flag: 0,
            }),
            (Cns, cns, CnsFix, {
                label: "CNS",
                title: "celestial latitude and longitude",
                record: 4,
                fresh_flag: CNS_FRESH,
                components: &[
                    Component::new("north | grid x", Unit::LatitudeInG),
                    Component::new("east | grid y", Unit::LongitudeInG),
                ],
                gate: 13.816,
                timeout_s: 3.0,
                causes: &["invalid content"],
                autonomous: true,
                excluded_flag: 0,
                untested_flag: 0,
            }),
            (Baro, baro, BaroSample, {
                label: "baro",
                title: "barometric altitude",
                record: 5,
                fresh_flag: BARO_FRESH,
                components: &[Component::new("up", Unit::M)],
                gate: 10.828,
                timeout_s: 1.0,
                causes: &["invalid content"],
                autonomous: true,
                excluded_flag: 0,
                untested_flag: 0,
            }),
            (Star, star, StarSample, {
                label: "star",
                title: "star tracker attitude",
                record: 9,
                fresh_flag: STAR_FRESH,
                components: &[
                    Component::new("about x", Unit::Rad),
                    Component::new("about y", Unit::Rad),
                    Component::new("about z", Unit::Rad),
                ],
                gate: 16.266,
                timeout_s: 3.0,
                causes: &["invalid content"],
                autonomous: true,
                excluded_flag: 0,
                untested_flag: 0,
            }),
            (Gnss, gnss, GnssFix, {
                label: "GNSS",
                title: "GNSS position and velocity",
                record: 11,
                fresh_flag: GNSS_FRESH,
                components: &[
                    Component::new("east | grid x", Unit::M),
                    Component::new("north | grid y", Unit::M),
                    Component::new("up", Unit::M),
                    Component::new("v east | grid x", Unit::Mps),
                    Component::new("v north | grid y", Unit::Mps),
                    Component::new("v up", Unit::Mps),
                ],
                gate: 22.458,
                timeout_s: 3.0,
                causes: &[
                    "invalid content",
                    "fix below 3D",
                    "accuracy beyond bound",
                    "PDOP beyond gate",
                ],
                autonomous: false,
                excluded_flag: GNSS_EXCLUDED,
                untested_flag: GNSS_UNTESTED,
            }),
            (Baseline, baseline, BaselineSample, {
                label: "baseline",
                title: "dual-antenna GNSS baseline",
                record: 12,
                fresh_flag: BASELINE_FRESH,
                components: &[
                    Component::new("east | grid x", Unit::M),
                    Component::new("north | grid y", Unit::M),
                    Component::new("up", Unit::M),
                ],
                gate: 16.266,
                timeout_s: 3.0,
                causes: &[
                    "invalid content",
                    "carrier not fixed",
                    "length disagrees",
                ],
                // Autonomous, although it is GNSS: a jammer leaves no
                // fixed carrier solution (refused, "carrier not fixed");
                // a single-transmitter spoofer or a meaconer sends every
                // satellite's signal from one direction, so both antennas
                // see the same phase differences for all of them, the
                // double differences vanish and the baseline comes out
                // degenerate (near zero length, or no fix), which the
                // length check against the surveyed antennas refuses.
                // Faking a consistent baseline takes one transmitter per
                // satellite, phase-aligned at the airframe's attitude.
                // The aid observes attitude only, never position, so it
                // cannot drag the position as a GNSS spoofer does.
                autonomous: true,
                excluded_flag: 0,
                untested_flag: 0,
            }),
            (Mag, mag, MagSample, {
                label: "mag",
                title: "magnetometer heading",
                record: 13,
                fresh_flag: MAG_FRESH,
                components: &[Component::new("heading about up", Unit::Rad)],
                gate: 10.828,
                timeout_s: 3.0,
                causes: &[
                    "invalid content",
                    "horizontal field below bound",
                    "field strength disagrees with the model",
                    "outside the magnetic model",
                ],
                autonomous: true,
                excluded_flag: 0,
                untested_flag: 0,
            }),
        ] }
    };
}

/// The physical unit of an innovation component, as the wire's
/// `AidStatus::innovation` holds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Metres.
    M,
    /// Metres per second.
    Mps,
    /// Radians of attitude.
    Rad,
    /// A horizontal position component: Δlatitude in radians in the
    /// geographic frame (turned into metres north with the meridian
    /// radius where it was made), metres along grid x in the grid frame.
    LatitudeInG,
    /// Δlongitude in radians in g (metres east with the parallel's
    /// radius), metres along grid y in G.
    LongitudeInG,
}

impl Unit {
    /// The unit a person reads the component in (after the conversion of
    /// a geographic-frame angle into metres).
    pub fn shown(self) -> &'static str {
        match self {
            Unit::M | Unit::LatitudeInG | Unit::LongitudeInG => "m",
            Unit::Mps => "m/s",
            Unit::Rad => "rad",
        }
    }
}

/// One component of an aid's innovation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Component {
    /// Its axis, for labels.
    pub label: &'static str,
    pub unit: Unit,
}

impl Component {
    pub const fn new(label: &'static str, unit: Unit) -> Self {
        Self { label, unit }
    }
}

/// What the system knows of an aid besides its payload type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AidDecl {
    pub kind: AidKind,
    /// The aid's one name (service, `--aids`, settings keys, MCAP topics,
    /// figure, counters in logs).
    pub name: &'static str,
    /// The name of its [`AidKind`] variant (and of its navlog record variant).
    pub variant: &'static str,
    /// Its MCAP channel of samples, `/NAME`.
    pub topic: &'static str,
    /// Its MCAP channel of updates, `/aid/NAME`.
    pub update_topic: &'static str,
    /// Its short name in logs and figures (`SRS`, `baro`).
    pub label: &'static str,
    /// What it measures, for people.
    pub title: &'static str,
    /// The variant index of its navlog record (indices are never reused:
    /// the records before an aid keep their encoding).
    pub record: u32,
    /// Its bit of [`crate::solution_flags`]: fused within its timeout.
    pub fresh_flag: u32,
    /// Its innovation's components (their number is the χ² degrees of
    /// freedom of its gate).
    pub components: &'static [Component],
    /// Default χ² gate (99.9 % quantile for its degrees of freedom) and
    /// timeout (s) after which it is stale.
    pub gate: f64,
    pub timeout_s: f64,
    /// Why a sample is refused before fusion, in the order of
    /// `AidStatus::refused`: the first is always invalid content
    /// (non-finite or physically impossible), the rest are the aid's own
    /// quality checks (at most [`MAX_CAUSES`] in all).
    pub causes: &'static [&'static str],
    /// Trusted on its own: false for an aid that can be jammed or spoofed
    /// (GNSS), which is fused only while it agrees with the autonomous
    /// aids (the session's integrity test).
    pub autonomous: bool,
    /// Its bit of the solution's flags while its integrity test excludes
    /// it (0 for an autonomous aid).
    pub excluded_flag: u32,
    /// Its bit of the solution's flags while it is fused untested, its
    /// integrity test being unavailable (0 for an autonomous aid).
    pub untested_flag: u32,
}

impl AidDecl {
    /// Degrees of freedom of the aid's innovation.
    pub const fn dof(&self) -> usize {
        self.components.len()
    }
}

/// A payload of an aid stream.
pub trait AidPayload: Copy + Into<AidSample> {
    const KIND: AidKind;
    /// Sensor time of the sample (ns).
    fn t_ns(&self) -> u64;
    /// Publisher sequence number.
    fn seq(&self) -> u64;
    /// The payload of `sample` if it is one of this aid's.
    fn of(sample: &AidSample) -> Option<&Self>;
}

/// The items this crate makes of the list.
macro_rules! declare {
    ([$(($K:ident, $n:ident, $P:ident, { $($field:ident : $value:expr),* $(,)? })),* $(,)?]) => {
        // The written-out enum and the list name the same aids in the same
        // order: a variant missing from the list fails this match, one
        // missing from the enum fails to resolve, and a reordering fails
        // the index check.
        const _: () = {
            let mut k = 0;
            $(
                assert!(AidKind::$K as usize == k, "AidKind and for_each_aid! disagree on the order");
                k += 1;
            )*
            assert!(k == AID_COUNT, "AID_COUNT is not the number of aids in for_each_aid!");
        };

        impl AidKind {
            /// Every aid, in order.
            pub const ALL: [AidKind; AID_COUNT] = [$(AidKind::$K),*];

            /// The aid's declaration.
            pub const fn decl(self) -> &'static AidDecl {
                match self {
                    $(AidKind::$K => {
                        use solution_flags::*;
                        const D: AidDecl = AidDecl {
                            kind: AidKind::$K,
                            name: stringify!($n),
                            variant: stringify!($K),
                            topic: concat!("/", stringify!($n)),
                            update_topic: concat!("/aid/", stringify!($n)),
                            $($field: $value,)*
                        };
                        &D
                    })*
                }
            }
        }

        /// One sample of any aid, held by value (a queue of these does not
        /// allocate; SRS is the largest payload).
        #[allow(clippy::large_enum_variant)]
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum AidSample {
            $($K($P),)*
        }

        impl AidSample {
            pub fn kind(&self) -> AidKind {
                match self {
                    $(AidSample::$K(_) => AidKind::$K,)*
                }
            }
            pub fn t_ns(&self) -> u64 {
                match self {
                    $(AidSample::$K(x) => x.t_ns,)*
                }
            }
            pub fn seq(&self) -> u64 {
                match self {
                    $(AidSample::$K(x) => x.seq,)*
                }
            }
            /// The time stamp, to change (fault injection, re-stamping a replay).
            pub fn t_ns_mut(&mut self) -> &mut u64 {
                match self {
                    $(AidSample::$K(x) => &mut x.t_ns,)*
                }
            }
            /// The sequence number, to change.
            pub fn seq_mut(&mut self) -> &mut u64 {
                match self {
                    $(AidSample::$K(x) => &mut x.seq,)*
                }
            }
        }

        $(
            impl AidPayload for $P {
                const KIND: AidKind = AidKind::$K;
                fn t_ns(&self) -> u64 {
                    self.t_ns
                }
                fn seq(&self) -> u64 {
                    self.seq
                }
                #[allow(unreachable_patterns)]
                fn of(sample: &AidSample) -> Option<&Self> {
                    match sample {
                        AidSample::$K(x) => Some(x),
                        _ => None,
                    }
                }
            }

            impl From<$P> for AidSample {
                fn from(x: $P) -> Self {
                    AidSample::$K(x)
                }
            }
        )*
    };
}

for_each_aid!(declare);

impl AidKind {
    /// The aid's one name.
    pub const fn name(self) -> &'static str {
        self.decl().name
    }

    /// The aid named `name` (as `--aids` and settings keys spell it).
    pub fn from_name(name: &str) -> Option<AidKind> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The aid whose navlog record has variant index `record`.
    pub fn from_record(record: u32) -> Option<AidKind> {
        Self::ALL.into_iter().find(|k| k.decl().record == record)
    }

    /// Its index in per-aid arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The names of all aids, comma-separated (for messages).
    pub fn names() -> String {
        Self::ALL.map(AidKind::name).join(", ")
    }

    /// The exclusion bits of every aid that has one.
    pub const fn all_excluded_flags() -> u32 {
        let mut f = 0;
        let mut k = 0;
        while k < AID_COUNT {
            f |= Self::ALL[k].decl().excluded_flag;
            k += 1;
        }
        f
    }

    /// The bits of every aid that is fused untested while its integrity
    /// test is unavailable.
    pub const fn all_untested_flags() -> u32 {
        let mut f = 0;
        let mut k = 0;
        while k < AID_COUNT {
            f |= Self::ALL[k].decl().untested_flag;
            k += 1;
        }
        f
    }

    /// The freshness bits of every aid.
    pub const fn all_fresh_flags() -> u32 {
        let mut f = 0;
        let mut k = 0;
        while k < AID_COUNT {
            f |= Self::ALL[k].decl().fresh_flag;
            k += 1;
        }
        f
    }
}

/// Expands to a `match` of an [`AidSample`] that binds its payload to
/// `$x` in `$body` for every aid: `match_aid!(sample, x => f(x))`, with
/// `f` generic over the payload (typically a trait method).
#[macro_export]
macro_rules! match_aid {
    ($sample:expr, $x:ident => $body:expr) => {
        $crate::for_each_aid!($crate::__match_aid_arms, ($sample), $x, ($body))
    };
}

#[doc(hidden)]
#[macro_export]
macro_rules! __match_aid_arms {
    (($sample:expr), $x:ident, ($body:expr), [$(($K:ident, $n:ident, $P:ident, $d:tt)),* $(,)?]) => {
        match $sample {
            $($crate::AidSample::$K($x) => $body,)*
        }
    };
}

/// Expands to a `match` of an [`AidKind`] in which `$T` names the aid's
/// payload type in `$body`: `match_aid_kind!(kind, T => <T as Trait>::X)`.
#[macro_export]
macro_rules! match_aid_kind {
    ($kind:expr, $T:ident => $body:expr) => {
        $crate::for_each_aid!($crate::__match_aid_kind_arms, ($kind), $T, ($body))
    };
}

#[doc(hidden)]
#[macro_export]
macro_rules! __match_aid_kind_arms {
    (($kind:expr), $T:ident, ($body:expr), [$(($K:ident, $n:ident, $P:ident, $d:tt)),* $(,)?]) => {
        match $kind {
            $($crate::AidKind::$K => {
                #[allow(dead_code)]
                type $T = $crate::$P;
                $body
            })*
        }
    };
}

/// An input stream with counters: the IMU, or an aid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stream {
    Imu,
    Aid(AidKind),
}

impl Stream {
    /// Every stream: the IMU, then the aids in order.
    pub const ALL: [Stream; STREAM_COUNT] = {
        let mut all = [Stream::Imu; STREAM_COUNT];
        let mut k = 0;
        while k < AID_COUNT {
            all[k + 1] = Stream::Aid(AidKind::ALL[k]);
            k += 1;
        }
        all
    };

    /// Its name: `imu`, or the aid's.
    pub const fn name(self) -> &'static str {
        match self {
            Stream::Imu => "imu",
            Stream::Aid(k) => k.name(),
        }
    }

    /// Its index in per-stream arrays (`Status::streams`): 0 for the IMU,
    /// 1 + the aid's index.
    pub const fn index(self) -> usize {
        match self {
            Stream::Imu => 0,
            Stream::Aid(k) => 1 + k as usize,
        }
    }
}

/// One value per aid, indexed by [`AidKind`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PerAid<T>(pub [T; AID_COUNT]);

impl<T: Default> Default for PerAid<T> {
    fn default() -> Self {
        Self(std::array::from_fn(|_| T::default()))
    }
}

impl<T> PerAid<T> {
    /// One value per aid, made by `f`.
    pub fn from_fn(mut f: impl FnMut(AidKind) -> T) -> Self {
        Self(std::array::from_fn(|k| f(AidKind::ALL[k])))
    }
    /// Each aid with its value.
    pub fn iter(&self) -> impl Iterator<Item = (AidKind, &T)> {
        AidKind::ALL.into_iter().zip(self.0.iter())
    }
    /// Each aid with its value, mutable.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (AidKind, &mut T)> {
        AidKind::ALL.into_iter().zip(self.0.iter_mut())
    }
    pub fn map<U>(self, f: impl FnMut(T) -> U) -> PerAid<U> {
        PerAid(self.0.map(f))
    }
}

impl<T> std::ops::Index<AidKind> for PerAid<T> {
    type Output = T;
    fn index(&self, k: AidKind) -> &T {
        &self.0[k as usize]
    }
}

impl<T> std::ops::IndexMut<AidKind> for PerAid<T> {
    fn index_mut(&mut self, k: AidKind) -> &mut T {
        &mut self.0[k as usize]
    }
}

/// One value per input stream, indexed by [`Stream`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PerStream<T>(pub [T; STREAM_COUNT]);

impl<T: Default> Default for PerStream<T> {
    fn default() -> Self {
        Self(std::array::from_fn(|_| T::default()))
    }
}

impl<T> PerStream<T> {
    /// Each stream with its value.
    pub fn iter(&self) -> impl Iterator<Item = (Stream, &T)> {
        Stream::ALL.into_iter().zip(self.0.iter())
    }
    /// Each stream with its value, mutable.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (Stream, &mut T)> {
        Stream::ALL.into_iter().zip(self.0.iter_mut())
    }
    pub fn get(&self, s: Stream) -> &T {
        &self.0[s.index()]
    }
    pub fn get_mut(&mut self, s: Stream) -> &mut T {
        &mut self.0[s.index()]
    }
}

impl<T> std::ops::Index<Stream> for PerStream<T> {
    type Output = T;
    fn index(&self, s: Stream) -> &T {
        &self.0[s.index()]
    }
}

impl<T> std::ops::IndexMut<Stream> for PerStream<T> {
    fn index_mut(&mut self, s: Stream) -> &mut T {
        &mut self.0[s.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_records_and_flags_are_unique_and_streams_are_ordered() {
        let mut names = std::collections::HashSet::new();
        let mut records = std::collections::HashSet::new();
        let mut flags = 0u32;
        for k in AidKind::ALL {
            let d = k.decl();
            assert_eq!(d.kind, k);
            assert!(names.insert(d.name), "{} named twice", d.name);
            assert!(records.insert(d.record), "record {} used twice", d.record);
            assert_eq!(d.fresh_flag.count_ones(), 1, "{}", d.name);
            assert_eq!(flags & d.fresh_flag, 0, "{}: flag used twice", d.name);
            flags |= d.fresh_flag;
            assert!(!d.components.is_empty() && d.components.len() <= MAX_COMPONENTS);
            assert!(!d.causes.is_empty() && d.causes.len() <= MAX_CAUSES);
            assert_eq!(d.autonomous, d.excluded_flag == 0, "{}", d.name);
            assert_eq!(d.autonomous, d.untested_flag == 0, "{}", d.name);
            for f in [d.excluded_flag, d.untested_flag] {
                if f != 0 {
                    assert_eq!(f.count_ones(), 1, "{}", d.name);
                    assert_eq!(flags & f, 0, "{}: flag used twice", d.name);
                    flags |= f;
                }
            }
            // The components of one unit are neighbours (the integrity
            // test takes each unit's block as a run).
            let units: Vec<&str> = d.components.iter().map(|c| c.unit.shown()).collect();
            for (i, u) in units.iter().enumerate() {
                assert!(
                    !units[i + 1..]
                        .iter()
                        .skip_while(|x| *x == u)
                        .any(|x| x == u),
                    "{}: the {u} components are not neighbours",
                    d.name
                );
            }
            assert!(d.gate >= d.dof() as f64 && d.timeout_s > 0.0);
            assert_eq!(AidKind::from_name(d.name), Some(k));
            assert_eq!(AidKind::from_record(d.record), Some(k));
        }
        assert_eq!(
            AidKind::all_fresh_flags()
                | AidKind::all_excluded_flags()
                | AidKind::all_untested_flags(),
            flags
        );
        assert_eq!(
            AidKind::all_fresh_flags() & AidKind::all_excluded_flags(),
            0
        );
        // The navlog's other records keep their indices.
        for other in [0, 1, 2, 6, 7, 8, 10] {
            assert!(!records.contains(&other), "record {other} is not an aid's");
        }
        assert_eq!(Stream::ALL[0], Stream::Imu);
        for (i, s) in Stream::ALL.iter().enumerate() {
            assert_eq!(s.index(), i);
        }
        assert!(Stream::ALL.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(Stream::Aid(AidKind::Star).name(), "star");
    }

    #[test]
    fn a_sample_knows_its_aid_time_and_sequence() {
        let s: AidSample = CnsFix {
            t_ns: 7,
            seq: 3,
            ..Default::default()
        }
        .into();
        assert_eq!((s.kind(), s.t_ns(), s.seq()), (AidKind::Cns, 7, 3));
        fn name_of<P: AidPayload>(_: &P) -> &'static str {
            P::KIND.name()
        }
        assert_eq!(crate::match_aid!(&s, x => name_of(x)), "cns");
        assert_eq!(
            crate::match_aid_kind!(AidKind::Star, T => T::KIND),
            AidKind::Star
        );
    }
}
