//! Truth CSV export (DESIGN columns, the velocity ones with their unit as
//! in the solution CSV: `vx_mps,vy_mps,vz_mps`, ECEF, m/s; `vx,vy,vz`
//! before issue 22).

use std::io::Write;

use msgs::TruthRecord;
use nalgebra::Vector3;
use polarnav::earth;

pub const TRUTH_HEADER: &str =
    "t_s,lat_deg,lon_deg,h_m,x_m,y_m,z_m,vx_mps,vy_mps,vz_mps,qw,qx,qy,qz";

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_csv_names_its_velocity_columns_with_their_unit() {
        let t = TruthRecord {
            t_ns: 2_500_000_000,
            r_e_m: [0.0, 0.0, 6_356_752.314_245],
            v_e_mps: [12.5, -250.25, 0.125],
            q_b_e: [1.0, 0.0, 0.0, 0.0],
        };
        let mut out = Vec::new();
        write_truth_csv(&mut out, &[t]).expect("write");
        let text = String::from_utf8(out).expect("utf8");
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().expect("header").split(',').collect();
        assert_eq!(
            head,
            [
                "t_s", "lat_deg", "lon_deg", "h_m", "x_m", "y_m", "z_m", "vx_mps", "vy_mps",
                "vz_mps", "qw", "qx", "qy", "qz"
            ]
        );
        let row: Vec<f64> = lines
            .next()
            .expect("row")
            .split(',')
            .map(|x| x.parse().expect("number"))
            .collect();
        let col = |name: &str| row[head.iter().position(|n| *n == name).expect("column")];
        assert_eq!(
            [col("vx_mps"), col("vy_mps"), col("vz_mps")].map(f64::to_bits),
            t.v_e_mps.map(f64::to_bits)
        );
    }
}
