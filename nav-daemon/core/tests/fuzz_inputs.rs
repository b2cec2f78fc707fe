//! Property test (proptest): no sequence of inputs makes the navigator
//! panic or produce a non-finite solution. Samples are arbitrary (NaN, Inf,
//! huge, negative dt, times out of order, duplicates, aids with any
//! content); every one is counted exactly once.

use msgs::{BaroSample, CnsFix, ImuSample, InitState, SrsLine, SrsSample};
use polarnav::navigator::{Navigator, NavigatorConfig};
use proptest::prelude::*;

fn wild() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1.0e-2f64..1.0e-2,
        1 => any::<f64>(),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => -1.0e7f64..1.0e7,
    ]
}

#[derive(Debug, Clone)]
enum Input {
    Imu {
        dt_ns: i64,
        dt_s: f64,
        th: [f64; 3],
        dv: [f64; 3],
    },
    Cns {
        back_ns: u64,
        lat: f64,
        lon: f64,
        sigma: f64,
    },
    Baro {
        back_ns: u64,
        p: f64,
        sigma: f64,
    },
    Srs {
        back_ns: u64,
        count: u32,
        lam: f64,
        sigma: f64,
    },
}

fn input() -> impl Strategy<Value = Input> {
    prop_oneof![
        6 => (prop_oneof![4 => Just(5_000_000i64), 1 => -10_000_000i64..100_000_000], wild(), [wild(), wild(), wild()], [wild(), wild(), wild()])
            .prop_map(|(dt_ns, dt, th, dv)| Input::Imu {
                dt_ns,
                dt_s: if dt.is_finite() && dt.abs() < 1e-3 { 0.005 } else { dt },
                th,
                dv: [dv[0], dv[1], dv[2] + 0.049],
            }),
        1 => (0u64..200_000_000, wild(), wild(), wild())
            .prop_map(|(back_ns, lat, lon, sigma)| Input::Cns { back_ns, lat: 1.5 + lat, lon, sigma: 20.0 + sigma }),
        1 => (0u64..200_000_000, wild(), wild())
            .prop_map(|(back_ns, p, sigma)| Input::Baro { back_ns, p: 7500.0 + p * 1e3, sigma: 10.0 + sigma }),
        1 => (0u64..200_000_000, 0u32..12, wild(), wild())
            .prop_map(|(back_ns, count, lam, sigma)| Input::Srs { back_ns, count, lam, sigma: 0.5 + sigma }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_inputs_never_panic_and_are_all_counted(inputs in proptest::collection::vec(input(), 1..300)) {
        let geo = polarnav::earth::Geodetic::from_deg(86.0, 10.0, 18000.0);
        let r = polarnav::earth::geodetic_to_ecef(&geo);
        let init = InitState {
            t_ns: 1_000_000_000,
            r_e_m: r.into(),
            q_b_e: [1.0, 0.0, 0.0, 0.0],
            sigma_pos_h_m: 10.0,
            sigma_pos_v_m: 10.0,
            sigma_vel_h_mps: 0.1,
            sigma_vel_v_mps: 0.1,
            sigma_tilt_rad: 3e-4,
            sigma_heading_rad: 1e-3,
            ..Default::default()
        };
        let mut nav = Navigator::new(&init, &NavigatorConfig::default());
        let mut t: i64 = init.t_ns as i64;
        let mut sent = [0u64; 4];
        for (k, i) in inputs.iter().enumerate() {
            match i {
                Input::Imu { dt_ns, dt_s, th, dv } => {
                    t = (t + dt_ns).max(0);
                    let _ = nav.on_imu(&ImuSample { t_ns: t as u64, seq: k as u64, dt_s: *dt_s, d_theta_rad: *th, d_v_mps: *dv });
                    sent[0] += 1;
                }
                Input::Cns { back_ns, lat, lon, sigma } => {
                    let _ = nav.on_aid(&msgs::AidSample::Cns(CnsFix { t_ns: nav.t_ns().saturating_sub(*back_ns), seq: k as u64, lat_rad: *lat, lon_rad: *lon, sigma_h_m: *sigma }));
                    sent[2] += 1;
                }
                Input::Baro { back_ns, p, sigma } => {
                    let _ = nav.on_aid(&msgs::AidSample::Baro(BaroSample { t_ns: nav.t_ns().saturating_sub(*back_ns), seq: k as u64, pressure_pa: *p, temperature_k: 216.65, sigma_m: *sigma }));
                    sent[3] += 1;
                }
                Input::Srs { back_ns, count, lam, sigma } => {
                    let mut s = SrsSample { t_ns: nav.t_ns().saturating_sub(*back_ns), seq: k as u64, count: *count, ..Default::default() };
                    for (j, l) in s.lines.iter_mut().enumerate() {
                        let a = j as f64 * 0.8;
                        *l = SrsLine {
                            los_i: [a.cos() * 0.6, a.sin() * 0.6, 0.8],
                            body_vel_i_mps: [1e4, -2e4, 3e3],
                            rest_wavelength_m: 656.28e-9,
                            measured_wavelength_m: 656.28e-9 * (1.0 + lam * 1e-6),
                            sigma_mps: *sigma,
                            body_id: j as u32,
                            _pad: 0,
                        };
                    }
                    let _ = nav.on_aid(&s.into());
                    sent[1] += 1;
                }
            }
            let sol = nav.solution();
            let finite = sol.r_e_m.iter().chain(&sol.v_e_mps).chain(&sol.q_b_e).chain(&sol.sigma_pos_enu_m).all(|x| x.is_finite());
            prop_assert!(finite, "non-finite solution after input {}: {:?}", k, i);
        }
        let st = nav.status();
        for (c, n) in st.streams[..4].iter().zip(sent) {
            prop_assert_eq!(c.received, n);
            prop_assert_eq!(c.received, c.accepted + c.rejected_invalid + c.rejected_time + c.rejected_gate + c.rejected_integrity + c.not_used);
        }
    }
}
