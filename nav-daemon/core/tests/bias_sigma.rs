//! The bias σ the solution reports (`Solution_v3`) is the square root of
//! the filter covariance's bias diagonal: checked against the checkpoint's
//! copy of P (row-major 15 × 15, written by another path) and, at start,
//! against the configured initial bias σ.

use msgs::{CnsFix, ImuSample, InitState};
use polarnav::earth::{G0, Geodetic, OMEGA_IE, geodetic_to_ecef, normal_gravity, up_e};
use polarnav::error_model::idx;
use polarnav::navigator::{Navigator, NavigatorConfig};

const N: usize = idx::N;

/// σ of the bias blocks read from a checkpoint's P (independent of the
/// solution's report code).
fn sigma_from_checkpoint(nav: &Navigator) -> ([f64; 3], [f64; 3]) {
    let p = nav.checkpoint().p;
    let d = |o: usize| [0, 1, 2].map(|k| p[(o + k) * N + o + k].sqrt());
    (d(idx::BG), d(idx::BA))
}

fn assert_close(what: &str, got: [f64; 3], want: [f64; 3], rel: f64) {
    for k in 0..3 {
        assert!(
            want[k] > 0.0 && (got[k] - want[k]).abs() <= rel * want[k],
            "{what}[{k}]: solution {:e}, expected {:e} (relative tolerance {rel:e})",
            got[k],
            want[k]
        );
    }
}

#[test]
fn solution_bias_sigma_is_the_root_of_the_covariance_bias_diagonal() {
    let (lat, lon, h) = (80f64.to_radians(), 30f64.to_radians(), 1_000.0);
    let r = geodetic_to_ecef(&Geodetic::new(lat, lon, h));
    let init = InitState {
        t_ns: 1_000_000_000,
        r_e_m: r.into(),
        v_e_mps: [0.0; 3],
        q_b_e: [1.0, 0.0, 0.0, 0.0],
        sigma_pos_h_m: 10.0,
        sigma_pos_v_m: 5.0,
        sigma_vel_h_mps: 0.1,
        sigma_vel_v_mps: 0.1,
        sigma_tilt_rad: 1e-3,
        sigma_heading_rad: 1e-2,
        ..Default::default()
    };
    let mut config = NavigatorConfig::default();
    // Bias drift, so that the σ move with time and a stale copy would show.
    config.filter.gyro_bias_instability_dph = 0.005;
    config.filter.accel_bias_instability_ug = 50.0;
    config.filter.gyro_bias_tau_s = 100.0;
    config.filter.accel_bias_tau_s = 100.0;
    let mut nav = Navigator::new(&init, &config);

    // At start: the configured initial σ, converted to SI (deg/h → rad/s,
    // µg → m/s² with g0), to 1e-9 relative.
    let s0 = nav.solution();
    let dph = 1f64.to_radians() / 3600.0;
    assert_close(
        "initial sigma_gyro_bias_rps",
        s0.sigma_gyro_bias_rps,
        [config.filter.gyro_bias_dph * dph; 3],
        1e-9,
    );
    assert_close(
        "initial sigma_accel_bias_mps2",
        s0.sigma_accel_bias_mps2,
        [config.filter.accel_bias_ug * 1e-6 * G0; 3],
        1e-9,
    );

    // 60 s at rest (body axes = ECEF axes) with 1 Hz CNS fixes: the
    // covariance moves; the solution follows the checkpoint's P exactly
    // (same f64, one square root each: 1e-15 relative).
    let dt = 0.01;
    let f = up_e(lat, lon) * normal_gravity(lat, h);
    let mut moved = false;
    for k in 1..=6000u64 {
        let t_ns = init.t_ns + k * 10_000_000;
        let s = ImuSample {
            t_ns,
            seq: k,
            dt_s: dt,
            d_theta_rad: [0.0, 0.0, OMEGA_IE * dt],
            d_v_mps: (f * dt).into(),
        };
        nav.on_imu(&s).expect("imu sample");
        if k % 100 == 0 {
            nav.on_aid(&msgs::AidSample::Cns(CnsFix {
                t_ns,
                seq: k / 100,
                lat_rad: lat,
                lon_rad: lon,
                sigma_h_m: 10.0,
            }))
            .expect("cns fix");
        }
        if k % 500 == 0 {
            let sol = nav.solution();
            let (bg, ba) = sigma_from_checkpoint(&nav);
            assert_close("sigma_gyro_bias_rps", sol.sigma_gyro_bias_rps, bg, 1e-15);
            assert_close(
                "sigma_accel_bias_mps2",
                sol.sigma_accel_bias_mps2,
                ba,
                1e-15,
            );
            moved |= (sol.sigma_accel_bias_mps2[0] - s0.sigma_accel_bias_mps2[0]).abs()
                > 1e-3 * s0.sigma_accel_bias_mps2[0];
        }
    }
    assert!(
        moved,
        "the accelerometer bias σ never moved by 0.1 %: the test would not see a stale value"
    );
}
