//! The dual-antenna baseline through the navigator, at the exact North
//! Pole: each refusal is counted under its declared cause in the aid's
//! status (`AidStatus::refused`, in the order of `msgs::aids`), and an
//! error-free baseline is fused there with a finite solution.

use msgs::baseline::{baseline_flags, carr_soln};
use msgs::{AidKind, AidSample, BaselineSample, InitState};
use nalgebra::Vector3;
use polarnav::aids::baseline::BaselineSettings;
use polarnav::earth::{Geodetic, geodetic_to_ecef};
use polarnav::frames;
use polarnav::navigator::{Navigator, NavigatorConfig};

const T_NS: u64 = 1_000_000_000;

#[test]
fn each_refusal_is_counted_under_its_cause_and_a_good_baseline_is_fused_at_the_pole() {
    let geo = Geodetic::from_deg(90.0, 0.0, 500.0);
    // Body axes x right, y forward, z up; heading 30° from the meridian 0's north.
    let c_b_g = frames::c_b_n_from_euler(30f64.to_radians(), 0.0, 0.0);
    let c_b_e = frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose() * c_b_g;
    let q = frames::quat_from_dcm(&c_b_e);
    let init = InitState {
        t_ns: T_NS,
        r_e_m: geodetic_to_ecef(&geo).into(),
        v_e_mps: [0.0; 3],
        q_b_e: [q.w, q.i, q.j, q.k],
        sigma_pos_h_m: 10.0,
        sigma_pos_v_m: 10.0,
        sigma_vel_h_mps: 0.1,
        sigma_vel_v_mps: 0.1,
        sigma_tilt_rad: 1e-3,
        sigma_heading_rad: 0.05,
        ..Default::default()
    };
    let config = NavigatorConfig::default();
    let settings: BaselineSettings = Default::default();
    let mut nav = Navigator::new(&init, &config);
    // The receiver at the pole reports longitude 0 (its NED axes those of
    // the meridian 0), written out here from the textbook rotation.
    let b_e = c_b_e * settings.baseline_b();
    let (sl, cl) = geo.lat_rad.sin_cos();
    let n = Vector3::new(-sl, 0.0, cl).dot(&b_e);
    let e = Vector3::new(0.0, 1.0, 0.0).dot(&b_e);
    let d = -Vector3::new(cl, 0.0, sl).dot(&b_e);
    let good = BaselineSample {
        t_ns: T_NS,
        seq: 0,
        lat_rad: geo.lat_rad,
        lon_rad: 0.0,
        rel_pos_ned_m: [n, e, d],
        length_m: b_e.norm(),
        heading_rad: e.atan2(n),
        acc_heading_rad: 0.01,
        acc_ned_m: [0.006, 0.006, 0.012],
        itow_ms: 0,
        carr_soln: carr_soln::FIXED,
        flags: baseline_flags::GNSS_FIX_OK
            | baseline_flags::REL_POS_VALID
            | baseline_flags::HEADING_VALID,
        _pad: 0,
    };
    let bad = [
        // Invalid content: 3.
        BaselineSample {
            rel_pos_ned_m: [f64::NAN, e, d],
            ..good
        },
        BaselineSample {
            acc_ned_m: [1e300, 0.006, 0.012],
            ..good
        },
        BaselineSample {
            length_m: f64::INFINITY,
            ..good
        },
        // Carrier not fixed: 2.
        BaselineSample {
            carr_soln: carr_soln::FLOAT,
            ..good
        },
        BaselineSample {
            flags: baseline_flags::GNSS_FIX_OK,
            ..good
        },
        // Length disagrees: 1 (0.2 m longer; 5 σ of the length is 3 cm).
        BaselineSample {
            rel_pos_ned_m: [n * 1.2, e * 1.2, d * 1.2],
            length_m: b_e.norm() * 1.2,
            ..good
        },
    ];
    for s in bad {
        assert!(nav.on_aid(&AidSample::Baseline(s)).is_err(), "{s:?}");
    }
    let st = nav.aid_status(AidKind::Baseline);
    assert_eq!(st.refused, [3, 2, 1, 0], "refused by cause");
    let out = nav
        .on_aid(&AidSample::Baseline(good))
        .expect("a good baseline");
    assert!(out.fused, "{out:?}");
    let st = nav.aid_status(AidKind::Baseline);
    assert_eq!(st.refused, [3, 2, 1, 0]);
    assert_eq!(st.fused, 1);
    assert!(
        st.innovation[..3].iter().all(|x| x.abs() < 1e-6),
        "{:?}",
        st.innovation
    );
    let sol = nav.solution();
    assert!(sol.q_b_e.iter().chain(&sol.r_e_m).all(|x| x.is_finite()));
    eprintln!(
        "baseline at the pole: refused {:?}, fused with innovation {:?} m",
        st.refused,
        &st.innovation[..3]
    );
}
