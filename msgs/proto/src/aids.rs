//! Each aid's payload as its protobuf message: the message of its MCAP
//! input channel (`/NAME`). One block per aid, beside its message in
//! `polarnav.proto`; the channels themselves come from the aid
//! declaration (`msgs::aids`).

use msgs::AidPayload;

use crate::{ProtoName, polarnav as pb};

/// An aid's payload as a protobuf message.
pub trait AidMessage: AidPayload {
    /// Its message of `polarnav.proto`.
    type Proto: prost::Message + ProtoName + Default + Send + Sync + 'static;
    /// The sample as that message.
    fn to_proto(&self) -> Self::Proto;
}

// ---- SRS ------------------------------------------------------------

impl ProtoName for pb::SrsSample {
    const NAME: &'static str = "polarnav.SrsSample";
}

impl AidMessage for msgs::SrsSample {
    type Proto = pb::SrsSample;
    /// Its `count` lines (at most the wire's capacity).
    fn to_proto(&self) -> pb::SrsSample {
        let n = usize::try_from(self.count)
            .unwrap_or(usize::MAX)
            .min(self.lines.len());
        pb::SrsSample {
            t_ns: self.t_ns,
            seq: self.seq,
            lines: self.lines[..n]
                .iter()
                .map(|l| pb::SrsLine {
                    los_x: l.los_i[0],
                    los_y: l.los_i[1],
                    los_z: l.los_i[2],
                    body_vx_mps: l.body_vel_i_mps[0],
                    body_vy_mps: l.body_vel_i_mps[1],
                    body_vz_mps: l.body_vel_i_mps[2],
                    rest_wavelength_m: l.rest_wavelength_m,
                    measured_wavelength_m: l.measured_wavelength_m,
                    sigma_mps: l.sigma_mps,
                    body_id: l.body_id,
                })
                .collect(),
        }
    }
}

// ---- CNS ------------------------------------------------------------

impl ProtoName for pb::CnsFix {
    const NAME: &'static str = "polarnav.CnsFix";
}

impl AidMessage for msgs::CnsFix {
    type Proto = pb::CnsFix;
    fn to_proto(&self) -> pb::CnsFix {
        pb::CnsFix {
            t_ns: self.t_ns,
            seq: self.seq,
            lat_rad: self.lat_rad,
            lon_rad: self.lon_rad,
            sigma_h_m: self.sigma_h_m,
        }
    }
}

// ---- barometer --------------------------------------------------------

impl ProtoName for pb::BaroSample {
    const NAME: &'static str = "polarnav.BaroSample";
}

impl AidMessage for msgs::BaroSample {
    type Proto = pb::BaroSample;
    fn to_proto(&self) -> pb::BaroSample {
        pb::BaroSample {
            t_ns: self.t_ns,
            seq: self.seq,
            pressure_pa: self.pressure_pa,
            temperature_k: self.temperature_k,
            sigma_m: self.sigma_m,
        }
    }
}

// ---- star tracker -------------------------------------------------------

impl ProtoName for pb::StarSample {
    const NAME: &'static str = "polarnav.StarSample";
}

impl AidMessage for msgs::StarSample {
    type Proto = pb::StarSample;
    fn to_proto(&self) -> pb::StarSample {
        let [q_b_i_w, q_b_i_x, q_b_i_y, q_b_i_z] = self.q_b_i;
        let [boresight_x, boresight_y, boresight_z] = self.boresight_b;
        pb::StarSample {
            t_ns: self.t_ns,
            seq: self.seq,
            q_b_i_w,
            q_b_i_x,
            q_b_i_y,
            q_b_i_z,
            boresight_x,
            boresight_y,
            boresight_z,
            sigma_cross_arcsec: self.sigma_cross_arcsec,
            sigma_boresight_arcsec: self.sigma_boresight_arcsec,
        }
    }
}

// ---- GNSS ---------------------------------------------------------------

impl ProtoName for pb::GnssFix {
    const NAME: &'static str = "polarnav.GnssFix";
}

impl AidMessage for msgs::GnssFix {
    type Proto = pb::GnssFix;
    fn to_proto(&self) -> pb::GnssFix {
        let [vel_n_mps, vel_e_mps, vel_d_mps] = self.vel_ned_mps;
        pb::GnssFix {
            t_ns: self.t_ns,
            seq: self.seq,
            lat_rad: self.lat_rad,
            lon_rad: self.lon_rad,
            height_m: self.height_m,
            vel_n_mps,
            vel_e_mps,
            vel_d_mps,
            h_acc_m: self.h_acc_m,
            v_acc_m: self.v_acc_m,
            s_acc_mps: self.s_acc_mps,
            pdop: self.pdop,
            itow_ms: self.itow_ms,
            fix_type: u32::from(self.fix_type),
            num_sv: u32::from(self.num_sv),
            flags: u32::from(self.flags),
        }
    }
}

// ---- dual-antenna baseline ---------------------------------------------

impl ProtoName for pb::BaselineSample {
    const NAME: &'static str = "polarnav.BaselineSample";
}

impl AidMessage for msgs::BaselineSample {
    type Proto = pb::BaselineSample;
    fn to_proto(&self) -> pb::BaselineSample {
        let [rel_pos_n_m, rel_pos_e_m, rel_pos_d_m] = self.rel_pos_ned_m;
        let [acc_n_m, acc_e_m, acc_d_m] = self.acc_ned_m;
        pb::BaselineSample {
            t_ns: self.t_ns,
            seq: self.seq,
            lat_rad: self.lat_rad,
            lon_rad: self.lon_rad,
            rel_pos_n_m,
            rel_pos_e_m,
            rel_pos_d_m,
            length_m: self.length_m,
            heading_rad: self.heading_rad,
            acc_heading_rad: self.acc_heading_rad,
            acc_n_m,
            acc_e_m,
            acc_d_m,
            itow_ms: self.itow_ms,
            carr_soln: u32::from(self.carr_soln),
            flags: u32::from(self.flags),
        }
    }
}

// ---- magnetometer -------------------------------------------------------

impl ProtoName for pb::MagSample {
    const NAME: &'static str = "polarnav.MagSample";
}

impl AidMessage for msgs::MagSample {
    type Proto = pb::MagSample;
    fn to_proto(&self) -> pb::MagSample {
        let [field_x_nt, field_y_nt, field_z_nt] = self.field_b_nt;
        let [sigma_x_nt, sigma_y_nt, sigma_z_nt] = self.sigma_nt;
        pb::MagSample {
            t_ns: self.t_ns,
            seq: self.seq,
            field_x_nt,
            field_y_nt,
            field_z_nt,
            sigma_x_nt,
            sigma_y_nt,
            sigma_z_nt,
        }
    }
}

/// Every aid has its message: a registration without one fails here.
macro_rules! every_aid_has_a_message {
    ([$(($K:ident, $n:ident, $P:ident, $d:tt)),* $(,)?]) => {
        #[allow(dead_code)]
        fn every_aid_has_a_message() {
            fn has<P: AidMessage>() {}
            $(has::<msgs::$P>();)*
        }

        /// The protobuf message name of each aid's payload.
        pub fn message_name(kind: msgs::AidKind) -> &'static str {
            match kind {
                $(msgs::AidKind::$K => <<msgs::$P as AidMessage>::Proto as ProtoName>::NAME,)*
            }
        }
    };
}
msgs::for_each_aid!(every_aid_has_a_message);
