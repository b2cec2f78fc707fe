//! The payloads this driver uses, decoded by the `ublox` crate (UBX
//! protocol 27, ZED-F9P), and their mapping onto [`msgs::GnssFix`].
//!
//! NAV-PVT → `GnssFix` (units of the u-blox interface description):
//!
//! | NAV-PVT | unit | GnssFix |
//! |---|---|---|
//! | `lat`, `lon` | 1e-7 ° | `lat_rad`, `lon_rad` (÷ 1e7, then to radians) |
//! | `height` (above the ellipsoid; not `hMSL`) | mm | `height_m` |
//! | `velN`, `velE`, `velD` | mm/s | `vel_ned_mps` |
//! | `hAcc`, `vAcc` | mm | `h_acc_m`, `v_acc_m` |
//! | `sAcc` | mm/s | `s_acc_mps` |
//! | `pDOP` | 0.01 | `pdop` |
//! | `iTOW` | ms | `itow_ms`, and `t_ns` by [`crate::time`] |
//! | `fixType`, `numSV` | | `fix_type`, `num_sv` (as sent) |
//! | `flags` | bits | `flags` (the byte as sent: gnssFixOK bit 0, diffSoln bit 1, psmState bits 2–4, headVehValid bit 5, carrSoln bits 6–7: 1 float, 2 fixed) |
//!
//! except that gnssFixOK is cleared when `flags3` says `invalidLlh` (the
//! receiver marks the position itself invalid), and counted.
//!
//! NAV-RELPOSNED (version 1, the baseline of a moving-base, dual-antenna
//! receiver) → `BaselineSample` (issue 30), paired by the driver with the
//! NAV-PVT of the same `iTOW` (which stamps it and gives the latitude and
//! longitude whose NED axes the baseline is in):
//!
//! | NAV-RELPOSNED | unit | BaselineSample |
//! |---|---|---|
//! | `relPosN/E/D` + `relPosHPN/E/D` | cm + 0.1 mm | `rel_pos_ned_m` |
//! | `relPosLength` + `relPosHPLength` | cm + 0.1 mm | `length_m` |
//! | `relPosHeading`, `accHeading` | 1e-5 ° | `heading_rad`, `acc_heading_rad` |
//! | `accN/E/D` | 0.1 mm | `acc_ned_m` |
//! | `flags` bits 0–2, 5–9 | bits | `flags` bits 0–7 ([`msgs::baseline::baseline_flags`]) |
//! | `flags` bits 3–4 (`carrSoln`) | | `carr_soln` |
//! | `iTOW` | ms | `itow_ms` |

use msgs::baseline::baseline_flags;
use msgs::{BaselineSample, GnssFix};
use ublox::proto27::PacketRef;
use ublox::{UbxProtocol, proto27::Proto27};

use crate::framing::Frame;
use crate::time::PvtDate;

/// NAV-PVT's class and id.
pub const NAV_PVT: (u8, u8) = (0x01, 0x07);
/// NAV-RELPOSNED's class and id.
pub const NAV_RELPOSNED: (u8, u8) = (0x01, 0x3C);

/// `carrSoln` of NAV-PVT `flags` (bits 6–7).
pub const CARR_SOLN_SHIFT: u8 = 6;
/// `invalidLlh` of NAV-PVT `flags3`.
pub const INVALID_LLH: u8 = 1;

/// A NAV-PVT's fields that the driver uses, as sent (integers).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Pvt {
    /// `iTOW` (ms).
    pub itow_ms: u32,
    /// UTC date and time with `valid`.
    pub date: PvtDate,
    /// `fixType`.
    pub fix_type: u8,
    /// `flags`.
    pub flags: u8,
    /// `flags3`, low byte (bit 0 `invalidLlh`).
    pub flags3: u8,
    /// `numSV`.
    pub num_sv: u8,
    /// `lon` (1e-7 °).
    pub lon_e7: i32,
    /// `lat` (1e-7 °).
    pub lat_e7: i32,
    /// `height` above the ellipsoid (mm).
    pub height_mm: i32,
    /// `hAcc` (mm).
    pub h_acc_mm: u32,
    /// `vAcc` (mm).
    pub v_acc_mm: u32,
    /// `velN`, `velE`, `velD` (mm/s).
    pub vel_ned_mmps: [i32; 3],
    /// `sAcc` (mm/s).
    pub s_acc_mmps: u32,
    /// `pDOP` (0.01).
    pub pdop_e2: u16,
}

/// A NAV-RELPOSNED (version 1): the baseline from the moving base.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RelPosNed {
    /// `iTOW` (ms).
    pub itow_ms: u32,
    /// North, east, down (cm).
    pub rel_pos_cm: [i32; 3],
    /// Their 0.1 mm parts.
    pub rel_pos_hp_01mm: [i8; 3],
    /// Baseline length (cm).
    pub length_cm: i32,
    /// Its 0.1 mm part.
    pub length_hp_01mm: i8,
    /// Heading of the baseline (1e-5 °).
    pub heading_e5: i32,
    /// `accN`, `accE`, `accD` (0.1 mm).
    pub acc_ned_01mm: [u32; 3],
    /// `accHeading` (1e-5 °).
    pub acc_heading_e5: u32,
    /// `flags` (bit 8 `relPosHeadingValid`).
    pub flags: u32,
}

impl RelPosNed {
    /// The payload, stamped `t_ns` and numbered `seq`, in the NED axes of
    /// (`lat_rad`, `lon_rad`) (the paired NAV-PVT's fix).
    pub fn to_baseline(&self, t_ns: u64, seq: u64, lat_rad: f64, lon_rad: f64) -> BaselineSample {
        let m = |cm: i32, hp: i8| f64::from(cm) / 1e2 + f64::from(hp) / 1e4;
        let bit = |k: u32| self.flags & (1 << k) != 0;
        // u-blox bits 0, 1, 2, 5, 6, 7, 8, 9 → ours 0..7 (carrSoln apart).
        let mut flags = 0u8;
        for (ublox, ours) in [
            (0, baseline_flags::GNSS_FIX_OK),
            (1, baseline_flags::DIFF_CORRECTED),
            (2, baseline_flags::REL_POS_VALID),
            (5, baseline_flags::IS_MOVING),
            (6, baseline_flags::REF_POS_MISS),
            (7, baseline_flags::REF_OBS_MISS),
            (8, baseline_flags::HEADING_VALID),
            (9, baseline_flags::NORMALIZED),
        ] {
            if bit(ublox) {
                flags |= ours;
            }
        }
        BaselineSample {
            t_ns,
            seq,
            lat_rad,
            lon_rad,
            rel_pos_ned_m: [0, 1, 2].map(|k| m(self.rel_pos_cm[k], self.rel_pos_hp_01mm[k])),
            length_m: m(self.length_cm, self.length_hp_01mm),
            heading_rad: (f64::from(self.heading_e5) / 1e5).to_radians(),
            acc_heading_rad: (f64::from(self.acc_heading_e5) / 1e5).to_radians(),
            acc_ned_m: self.acc_ned_01mm.map(|a| f64::from(a) / 1e4),
            itow_ms: self.itow_ms,
            carr_soln: ((self.flags >> 3) & 0b11) as u8,
            flags,
            _pad: 0,
        }
    }
}

/// `relPosHeadingValid` of NAV-RELPOSNED `flags`.
pub const REL_POS_HEADING_VALID: u32 = 1 << 8;

/// What a good frame carried.
#[derive(Debug, Clone, PartialEq)]
pub enum Decoded {
    /// A NAV-PVT.
    Pvt(Pvt),
    /// A NAV-RELPOSNED.
    RelPosNed(RelPosNed),
    /// A class and id this driver does not use.
    Unused,
    /// NAV-PVT or NAV-RELPOSNED whose payload the decoder refused (a
    /// length of another protocol version: it takes that as an unknown packet).
    Invalid,
}

/// Decodes one good frame.
pub fn decode(frame: &Frame<'_>) -> Decoded {
    let key = (frame.class, frame.id);
    if key != NAV_PVT && key != NAV_RELPOSNED {
        return Decoded::Unused;
    }
    match Proto27::match_packet(frame.class, frame.id, frame.payload) {
        Ok(PacketRef::NavPvt(p)) => Decoded::Pvt(Pvt {
            itow_ms: p.itow(),
            date: PvtDate {
                year: p.year(),
                month: p.month(),
                day: p.day(),
                hour: p.hour(),
                min: p.min(),
                sec: p.sec(),
                valid: p.valid_raw(),
            },
            fix_type: p.fix_type_raw(),
            flags: p.flags_raw(),
            flags3: p.flags3_raw(),
            num_sv: p.num_satellites(),
            lon_e7: p.longitude_raw(),
            lat_e7: p.latitude_raw(),
            height_mm: p.height_above_ellipsoid_raw(),
            h_acc_mm: p.horizontal_accuracy_raw(),
            v_acc_mm: p.vertical_accuracy_raw(),
            vel_ned_mmps: [p.vel_north_raw(), p.vel_east_raw(), p.vel_down_raw()],
            s_acc_mmps: p.speed_accuracy_raw(),
            pdop_e2: p.pdop_raw(),
        }),
        Ok(PacketRef::NavRelPosNed(r)) => Decoded::RelPosNed(RelPosNed {
            itow_ms: r.itow(),
            rel_pos_cm: [
                r.rel_pos_n_cm_raw(),
                r.rel_pos_e_cm_raw(),
                r.rel_pos_d_cm_raw(),
            ],
            rel_pos_hp_01mm: [
                r.rel_pos_hp_n_mm_raw(),
                r.rel_pos_hp_e_mm_raw(),
                r.rel_pos_hp_d_mm_raw(),
            ],
            length_cm: r.rel_pos_length_cm_raw(),
            length_hp_01mm: r.rel_pos_hp_length_mm_raw(),
            heading_e5: r.rel_pos_heading_degrees_raw(),
            acc_ned_01mm: [r.acc_n_mm_raw(), r.acc_e_mm_raw(), r.acc_d_mm_raw()],
            acc_heading_e5: r.acc_heading_degrees_raw(),
            flags: r.flags_raw(),
        }),
        Ok(_) | Err(_) => Decoded::Invalid,
    }
}

impl Pvt {
    /// Whether the receiver marks the position invalid (`flags3.invalidLlh`).
    pub fn invalid_llh(&self) -> bool {
        self.flags3 & INVALID_LLH != 0
    }

    /// The payload, stamped `t_ns` and numbered `seq`.
    pub fn to_fix(&self, t_ns: u64, seq: u64) -> GnssFix {
        let mut flags = self.flags;
        if self.invalid_llh() {
            flags &= !msgs::gnss::fix_flags::FIX_OK;
        }
        GnssFix {
            t_ns,
            seq,
            lat_rad: (f64::from(self.lat_e7) / 1e7).to_radians(),
            lon_rad: (f64::from(self.lon_e7) / 1e7).to_radians(),
            height_m: f64::from(self.height_mm) / 1e3,
            vel_ned_mps: self.vel_ned_mmps.map(|v| f64::from(v) / 1e3),
            h_acc_m: f64::from(self.h_acc_mm) / 1e3,
            v_acc_m: f64::from(self.v_acc_mm) / 1e3,
            s_acc_mps: f64::from(self.s_acc_mmps) / 1e3,
            pdop: f64::from(self.pdop_e2) / 1e2,
            itow_ms: self.itow_ms,
            fix_type: self.fix_type,
            num_sv: self.num_sv,
            flags,
            _pad: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A NAV-PVT payload (92 bytes) laid out by hand from the interface
    /// description's offsets, independently of the decoder.
    fn nav_pvt_payload(p: &Pvt) -> Vec<u8> {
        let mut b = vec![0u8; 92];
        let mut put = |off: usize, bytes: &[u8]| b[off..off + bytes.len()].copy_from_slice(bytes);
        put(0, &p.itow_ms.to_le_bytes());
        put(4, &p.date.year.to_le_bytes());
        put(
            6,
            &[
                p.date.month,
                p.date.day,
                p.date.hour,
                p.date.min,
                p.date.sec,
                p.date.valid,
            ],
        );
        put(20, &[p.fix_type, p.flags, 0, p.num_sv]);
        put(24, &p.lon_e7.to_le_bytes());
        put(28, &p.lat_e7.to_le_bytes());
        put(32, &p.height_mm.to_le_bytes());
        put(36, &(-7i32).to_le_bytes()); // hMSL: not used
        put(40, &p.h_acc_mm.to_le_bytes());
        put(44, &p.v_acc_mm.to_le_bytes());
        put(48, &p.vel_ned_mmps[0].to_le_bytes());
        put(52, &p.vel_ned_mmps[1].to_le_bytes());
        put(56, &p.vel_ned_mmps[2].to_le_bytes());
        put(68, &p.s_acc_mmps.to_le_bytes());
        put(76, &p.pdop_e2.to_le_bytes());
        put(78, &[p.flags3]);
        b
    }

    #[test]
    #[allow(clippy::float_cmp)] // the conversions are exact to the last bit: checked so
    fn nav_pvt_fields_come_out_at_their_offsets_and_in_si_units() {
        let p = Pvt {
            itow_ms: 604_799_999,
            date: PvtDate {
                year: 2026,
                month: 11,
                day: 25,
                hour: 18,
                min: 0,
                sec: 60,
                valid: 7,
            },
            fix_type: 3,
            flags: 0b1000_0011,
            flags3: 0,
            num_sv: 255,
            lon_e7: -1_800_000_000,
            lat_e7: 900_000_000,
            height_mm: i32::MIN,
            h_acc_mm: u32::MAX,
            v_acc_mm: 1,
            vel_ned_mmps: [i32::MAX, -1, 0],
            s_acc_mmps: 12,
            pdop_e2: u16::MAX,
        };
        let payload = nav_pvt_payload(&p);
        let d = decode(&Frame {
            class: 1,
            id: 7,
            payload: &payload,
        });
        assert_eq!(d, Decoded::Pvt(p));
        let f = p.to_fix(5, 6);
        assert_eq!(f.lat_rad, std::f64::consts::FRAC_PI_2);
        assert_eq!(f.lon_rad, -std::f64::consts::PI);
        assert_eq!(f.height_m, -2_147_483.648);
        assert_eq!(f.h_acc_m, 4_294_967.295);
        assert_eq!(f.vel_ned_mps, [2_147_483.647, -0.001, 0.0]);
        assert_eq!(f.pdop, 655.35);
        assert_eq!(
            (f.fix_type, f.num_sv, f.flags, f.itow_ms),
            (3, 255, 0b1000_0011, 604_799_999)
        );
        let invalid = Pvt { flags3: 1, ..p }.to_fix(5, 6);
        assert_eq!(invalid.flags, 0b1000_0010, "invalidLlh clears gnssFixOK");
    }

    /// A NAV-RELPOSNED version-1 payload (64 bytes) laid out by hand from
    /// the interface description's offsets, independently of the decoder.
    fn relposned_payload(r: &RelPosNed) -> Vec<u8> {
        let mut b = vec![0u8; 64];
        let mut put = |off: usize, bytes: &[u8]| b[off..off + bytes.len()].copy_from_slice(bytes);
        put(0, &[1, 0]);
        put(4, &r.itow_ms.to_le_bytes());
        for k in 0..3 {
            put(8 + 4 * k, &r.rel_pos_cm[k].to_le_bytes());
            put(32 + k, &r.rel_pos_hp_01mm[k].to_le_bytes());
            put(36 + 4 * k, &r.acc_ned_01mm[k].to_le_bytes());
        }
        put(20, &r.length_cm.to_le_bytes());
        put(24, &r.heading_e5.to_le_bytes());
        put(35, &r.length_hp_01mm.to_le_bytes());
        put(48, &(7u32).to_le_bytes()); // accLength: not used
        put(52, &r.acc_heading_e5.to_le_bytes());
        put(56, &(9u32).to_le_bytes()); // reserved
        put(60, &r.flags.to_le_bytes());
        b
    }

    #[test]
    #[allow(clippy::float_cmp)] // exact decimal conversions, checked to the last bit where exact
    fn relposned_fields_come_out_at_their_offsets_and_in_si_units() {
        let r = RelPosNed {
            itow_ms: 123_456_789,
            rel_pos_cm: [150, -2, i32::MIN],
            rel_pos_hp_01mm: [-99, 99, 0],
            length_cm: 150,
            length_hp_01mm: 37,
            heading_e5: 35_999_999,
            acc_ned_01mm: [12, 0, u32::MAX],
            acc_heading_e5: 100_000,
            // gnssFixOK, relPosValid, carrSoln 2, isMoving, relPosHeadingValid.
            flags: 0b1_0011_0101,
        };
        let payload = relposned_payload(&r);
        let d = decode(&Frame {
            class: 1,
            id: 0x3C,
            payload: &payload,
        });
        assert_eq!(d, Decoded::RelPosNed(r));
        let b = r.to_baseline(5, 6, 0.1, -0.2);
        assert_eq!((b.t_ns, b.seq, b.lat_rad, b.lon_rad), (5, 6, 0.1, -0.2));
        assert!((b.rel_pos_ned_m[0] - 1.4901).abs() < 1e-12);
        assert!((b.rel_pos_ned_m[1] - (-0.0101)).abs() < 1e-12);
        assert_eq!(b.rel_pos_ned_m[2], -21_474_836.48);
        assert!((b.length_m - 1.5037).abs() < 1e-12);
        assert!((b.heading_rad - 359.999_99f64.to_radians()).abs() < 1e-12);
        assert!((b.acc_heading_rad - 1f64.to_radians()).abs() < 1e-15);
        assert!((b.acc_ned_m[0] - 0.0012).abs() < 1e-15);
        assert_eq!(b.acc_ned_m[1], 0.0);
        assert!((b.acc_ned_m[2] - 429_496.729_5).abs() < 1e-9);
        assert_eq!(b.carr_soln, msgs::baseline::carr_soln::FIXED);
        assert_eq!(
            b.flags,
            baseline_flags::GNSS_FIX_OK
                | baseline_flags::REL_POS_VALID
                | baseline_flags::IS_MOVING
                | baseline_flags::HEADING_VALID
        );
        assert!(b.is_fixed());
        // Every other flag lands on its own bit.
        let all = RelPosNed {
            flags: 0b11_1110_0111,
            ..r
        }
        .to_baseline(0, 0, 0.0, 0.0);
        assert_eq!((all.flags, all.carr_soln), (0xFF, 0));
        let float = RelPosNed {
            flags: 0b0_0000_1101,
            ..r
        }
        .to_baseline(0, 0, 0.0, 0.0);
        assert_eq!(float.carr_soln, msgs::baseline::carr_soln::FLOAT);
        assert!(!float.is_fixed());
    }

    #[test]
    fn a_nav_pvt_of_another_length_is_invalid_and_other_classes_unused() {
        let short = [0u8; 84];
        let d = decode(&Frame {
            class: 1,
            id: 7,
            payload: &short,
        });
        assert_eq!(d, Decoded::Invalid);
        let d = decode(&Frame {
            class: 1,
            id: 4,
            payload: &[0u8; 18],
        });
        assert_eq!(d, Decoded::Unused);
    }
}
