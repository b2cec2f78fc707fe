//! The first non-finite floating-point field of a payload, found through
//! its serde serialization: every `f32` and `f64` it holds, at any depth
//! (arrays, nested structs, unused SRS line slots too), without a list of
//! fields to keep in step with the struct. A publisher refuses a sample
//! with a NaN or an infinity at the call, naming the field, before it
//! reaches the shared memory. No allocation.

use serde::Serialize;
use serde::ser::{self, Impossible};

/// The name of the first field (the innermost struct field that holds it)
/// whose value is NaN or infinite, or `None` when every float is finite.
pub fn first_non_finite<T: Serialize>(value: &T) -> Option<&'static str> {
    let mut scan = Scan { field: "value" };
    match value.serialize(&mut scan) {
        Ok(()) => None,
        Err(Found(f)) => Some(f),
    }
}

/// The scan's "error": the field of the non-finite value, which ends it.
#[derive(Debug)]
struct Found(&'static str);

impl std::fmt::Display for Found {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "non-finite {}", self.0)
    }
}

impl std::error::Error for Found {}

impl ser::Error for Found {
    fn custom<T: std::fmt::Display>(_: T) -> Self {
        Found("(a field serde could not name)")
    }
}

struct Scan {
    field: &'static str,
}

impl Scan {
    fn float(&self, finite: bool) -> Result<(), Found> {
        if finite {
            Ok(())
        } else {
            Err(Found(self.field))
        }
    }
}

macro_rules! nothing_to_check {
    ($($f:ident: $t:ty),* $(,)?) => {
        $(fn $f(self, _: $t) -> Result<(), Found> { Ok(()) })*
    };
}

impl ser::Serializer for &mut Scan {
    type Ok = ();
    type Error = Found;
    type SerializeSeq = Self;
    type SerializeTuple = Self;
    type SerializeTupleStruct = Self;
    type SerializeTupleVariant = Self;
    type SerializeMap = Impossible<(), Found>;
    type SerializeStruct = Self;
    type SerializeStructVariant = Self;

    nothing_to_check!(
        serialize_bool: bool,
        serialize_i8: i8,
        serialize_i16: i16,
        serialize_i32: i32,
        serialize_i64: i64,
        serialize_i128: i128,
        serialize_u8: u8,
        serialize_u16: u16,
        serialize_u32: u32,
        serialize_u64: u64,
        serialize_u128: u128,
        serialize_char: char,
        serialize_str: &str,
        serialize_bytes: &[u8],
        serialize_unit_struct: &'static str,
    );

    fn serialize_f32(self, v: f32) -> Result<(), Found> {
        self.float(v.is_finite())
    }
    fn serialize_f64(self, v: f64) -> Result<(), Found> {
        self.float(v.is_finite())
    }
    fn serialize_none(self) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_some<T: ?Sized + Serialize>(self, v: &T) -> Result<(), Found> {
        v.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<(), Found> {
        v.serialize(self)
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        v: &T,
    ) -> Result<(), Found> {
        v.serialize(self)
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Self, Found> {
        Ok(self)
    }
    fn serialize_tuple(self, _: usize) -> Result<Self, Found> {
        Ok(self)
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Self, Found> {
        Ok(self)
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self, Found> {
        Ok(self)
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Found> {
        // No payload holds a map.
        Err(Found("(a map)"))
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, Found> {
        Ok(self)
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self, Found> {
        Ok(self)
    }
}

macro_rules! elements {
    ($($tr:ident :: $m:ident),* $(,)?) => {
        $(impl ser::$tr for &mut Scan {
            type Ok = ();
            type Error = Found;
            fn $m<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), Found> {
                v.serialize(&mut **self)
            }
            fn end(self) -> Result<(), Found> {
                Ok(())
            }
        })*
    };
}

elements!(
    SerializeSeq::serialize_element,
    SerializeTuple::serialize_element,
    SerializeTupleStruct::serialize_field,
    SerializeTupleVariant::serialize_field,
);

macro_rules! fields {
    ($($tr:ident),* $(,)?) => {
        $(impl ser::$tr for &mut Scan {
            type Ok = ();
            type Error = Found;
            fn serialize_field<T: ?Sized + Serialize>(
                &mut self,
                key: &'static str,
                v: &T,
            ) -> Result<(), Found> {
                let outer = std::mem::replace(&mut self.field, key);
                v.serialize(&mut **self)?;
                self.field = outer;
                Ok(())
            }
            fn end(self) -> Result<(), Found> {
                Ok(())
            }
        })*
    };
}

fields!(SerializeStruct, SerializeStructVariant);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GnssFix, ImuSample, SrsSample};

    #[test]
    fn every_float_field_is_seen_and_named() {
        let ok = ImuSample {
            t_ns: 1,
            dt_s: 0.005,
            ..Default::default()
        };
        assert_eq!(first_non_finite(&ok), None);
        for (bad, field) in [
            (
                ImuSample {
                    dt_s: f64::NAN,
                    ..ok
                },
                "dt_s",
            ),
            (
                ImuSample {
                    d_theta_rad: [0.0, f64::INFINITY, 0.0],
                    ..ok
                },
                "d_theta_rad",
            ),
            (
                ImuSample {
                    d_v_mps: [0.0, 0.0, f64::NEG_INFINITY],
                    ..ok
                },
                "d_v_mps",
            ),
        ] {
            assert_eq!(first_non_finite(&bad), Some(field));
        }
        // Nested: an SRS line's field, also in a slot past `count`.
        let mut srs = SrsSample::default();
        assert_eq!(first_non_finite(&srs), None);
        let last = srs.lines.len() - 1;
        srs.lines[last].measured_wavelength_m = f64::NAN;
        assert_eq!(first_non_finite(&srs), Some("measured_wavelength_m"));
        // Every float field of a GNSS fix, one at a time (listed here by
        // hand, from the C header): the scan finds and names each.
        type Set = fn(&mut GnssFix);
        let fields: [(Set, &str); 10] = [
            (|f| f.lat_rad = f64::NAN, "lat_rad"),
            (|f| f.lon_rad = f64::NAN, "lon_rad"),
            (|f| f.height_m = f64::INFINITY, "height_m"),
            (|f| f.vel_ned_mps[0] = f64::NAN, "vel_ned_mps"),
            (|f| f.vel_ned_mps[2] = f64::NAN, "vel_ned_mps"),
            (|f| f.h_acc_m = f64::NAN, "h_acc_m"),
            (|f| f.v_acc_m = f64::NAN, "v_acc_m"),
            (|f| f.s_acc_mps = f64::NAN, "s_acc_mps"),
            (|f| f.pdop = f64::NEG_INFINITY, "pdop"),
            (|f| f.lat_rad = 1e308 * 10.0, "lat_rad"),
        ];
        assert_eq!(first_non_finite(&GnssFix::default()), None);
        for (set, name) in fields {
            let mut fix = GnssFix::default();
            set(&mut fix);
            assert_eq!(first_non_finite(&fix), Some(name));
        }
    }
}
