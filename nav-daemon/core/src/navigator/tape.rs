//! The smoother's record of a forward run (the tape): the format the
//! navigator writes and [`crate::smoother`] reads back. Each record is its
//! payload (little-endian f64), then its length (u32) and its tag, so that
//! the tape reads backward as easily as forward. The navigator owns the
//! format because it is the writer; the smoother depends on it, not the
//! other way round.

use msgs::Solution;
use nalgebra::{SVector, Vector3};

use crate::error_model::Mat15;
use crate::filter::ProcessNoise;
use crate::mech::{AnyNav, FrameKind};

type Vec15 = SVector<f64, 15>;

/// Record kinds (the last byte of a record).
pub(crate) mod tag {
    pub const PROPAGATE: u8 = 1;
    pub const CONVERT: u8 = 2;
    pub const ADD: u8 = 3;
    pub const UPDATE: u8 = 4;
    pub const BREAK: u8 = 5;
    pub const SOLUTION: u8 = 6;
}

/// Writing records.
pub(crate) mod write {
    use super::*;

    fn f64s(buf: &mut Vec<u8>, xs: &[f64]) {
        for x in xs {
            buf.extend_from_slice(&x.to_le_bytes());
        }
    }

    /// The upper triangle of a symmetric P (120 values).
    fn sym(buf: &mut Vec<u8>, p: &Mat15) {
        for i in 0..15 {
            for j in i..15 {
                buf.extend_from_slice(&p[(i, j)].to_le_bytes());
            }
        }
    }

    fn nav(buf: &mut Vec<u8>, n: &AnyNav) {
        let (kind, q, v, pos) = match n {
            AnyNav::Geographic(s) => (
                0.0,
                s.q_b_n,
                s.v_n,
                [s.pos.lat_rad, s.pos.lon_rad, s.pos.h_m],
            ),
            AnyNav::Grid(s) => (1.0, s.q_b_n, s.v_n, [s.pos.x, s.pos.y, s.pos.z]),
        };
        let q = q.into_inner();
        f64s(buf, &[kind, q.w, q.i, q.j, q.k, v.x, v.y, v.z]);
        f64s(buf, &pos);
    }

    fn end(buf: &mut Vec<u8>, start: usize, t: u8) {
        let len = (buf.len() - start) as u32;
        buf.extend_from_slice(&len.to_le_bytes());
        buf.push(t);
    }

    /// A propagation over `dt` s from `t_b` to `t_a` (ns of sensor time).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn propagate(
        buf: &mut Vec<u8>,
        t_b: f64,
        t_a: f64,
        dt: f64,
        f_b: &Vector3<f64>,
        n: &AnyNav,
        noise: &ProcessNoise,
        p_b: &Mat15,
    ) {
        let start = buf.len();
        f64s(buf, &[t_b, t_a, dt, f_b.x, f_b.y, f_b.z]);
        nav(buf, n);
        f64s(
            buf,
            &[
                noise.arw,
                noise.vrw,
                noise.gyro_bias_sigma,
                noise.gyro_bias_tau_s,
                noise.accel_bias_sigma,
                noise.accel_bias_tau_s,
            ],
        );
        sym(buf, p_b);
        end(buf, start, tag::PROPAGATE);
    }

    /// A frame conversion to `to` from the state `before`.
    pub(crate) fn convert(buf: &mut Vec<u8>, to: FrameKind, before: &AnyNav, p_b: &Mat15) {
        let start = buf.len();
        f64s(buf, &[f64::from(u8::from(to == FrameKind::Grid))]);
        nav(buf, before);
        sym(buf, p_b);
        end(buf, start, tag::CONVERT);
    }

    /// An addition to P alone (Φ = I).
    pub(crate) fn add(buf: &mut Vec<u8>, p_b: &Mat15, p_a: &Mat15) {
        let start = buf.len();
        sym(buf, p_b);
        sym(buf, p_a);
        end(buf, start, tag::ADD);
    }

    /// A correction fed back.
    pub(crate) fn update(buf: &mut Vec<u8>, dx: &Vec15) {
        let start = buf.len();
        f64s(buf, dx.as_slice());
        end(buf, start, tag::UPDATE);
    }

    /// A break, with P there.
    pub(crate) fn brk(buf: &mut Vec<u8>, p: &Mat15) {
        let start = buf.len();
        sym(buf, p);
        end(buf, start, tag::BREAK);
    }

    /// A solution emitted: what of it is not navigation (time, sequence,
    /// flags, counts, reset record) and the nominal state and bias
    /// estimates it was built from, so that the backward pass rebuilds it
    /// with the function that built it (bit for bit where nothing is learned).
    pub(crate) fn solution(
        buf: &mut Vec<u8>,
        s: &Solution,
        n: &AnyNav,
        gyro_bias: &Vector3<f64>,
        accel_bias: &Vector3<f64>,
    ) {
        let start = buf.len();
        f64s(
            buf,
            &[
                f64::from_bits(s.t_ns),
                f64::from_bits(s.seq),
                f64::from_bits(s.reset_t_ns),
                f64::from(s.flags),
                f64::from(s.switch_count),
                f64::from(s.reset_count),
                s.reset_delta_heading_rad,
            ],
        );
        f64s(buf, &s.reset_delta_pos_e_m);
        f64s(buf, &s.reset_delta_vel_e_mps);
        nav(buf, n);
        f64s(buf, gyro_bias.as_slice());
        f64s(buf, accel_bias.as_slice());
        end(buf, start, tag::SOLUTION);
    }
}
