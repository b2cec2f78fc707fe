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
//! NAV-RELPOSNED (the baseline of a moving-base, dual-antenna receiver) is
//! decoded and counted but not published: no aid takes a baseline yet
//! (issue 30 adds one).

use msgs::GnssFix;
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
    /// Heading of the baseline (1e-5 °).
    pub heading_e5: i32,
    /// `flags` (bit 8 `relPosHeadingValid`).
    pub flags: u32,
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
            heading_e5: r.rel_pos_heading_degrees_raw(),
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
