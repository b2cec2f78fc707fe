//! Truth CSV export (DESIGN columns).

use std::io::Write;

use msgs::TruthRecord;
use nalgebra::Vector3;
use polarnav::earth;

pub const TRUTH_HEADER: &str = "t_s,lat_deg,lon_deg,h_m,x_m,y_m,z_m,vx,vy,vz,qw,qx,qy,qz";

pub fn write_truth_csv<W: Write>(mut out: W, truth: &[TruthRecord]) -> std::io::Result<()> {
    writeln!(out, "{TRUTH_HEADER}")?;
    for t in truth {
        let g = earth::ecef_to_geodetic(&Vector3::from(t.r_e_m));
        let [x, y, z] = t.r_e_m;
        let [vx, vy, vz] = t.v_e_mps;
        let [qw, qx, qy, qz] = t.q_b_e;
        writeln!(
            out,
            "{:.9},{:.12},{:.12},{:.6},{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.15},{:.15},{:.15},{:.15}",
            t.t_ns as f64 * 1e-9,
            g.lat_rad.to_degrees(),
            g.lon_rad.to_degrees(),
            g.h_m,
            x,
            y,
            z,
            vx,
            vy,
            vz,
            qw,
            qx,
            qy,
            qz
        )?;
    }
    out.flush()
}
