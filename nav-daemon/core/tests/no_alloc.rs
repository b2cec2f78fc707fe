//! The steady-state filter loop performs no heap allocation: a counting
//! global allocator around IMU steps, every aid update (SRS, CNS, baro, star),
//! solution and status assembly, after a warm-up: first the navigator
//! alone, then the session that every driver feeds (ordering, the aid
//! queue, accounting, solution emission). Only allocations of the test's
//! own thread count (the harness's threads may allocate at any time).
#![allow(unsafe_code)] // a GlobalAlloc implementation is unsafe by definition

use msgs::AidKind;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use msgs::{BaroSample, CnsFix, ImuSample, InitState, SrsLine, SrsSample, StarSample};
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use polarnav::earth::{self, Geodetic, isa};
use polarnav::frames;
use polarnav::inbox::{Inbox, Received};
use polarnav::navigator::{Navigator, NavigatorConfig};
use polarnav::session::{Discard, Input, Session, SessionSettings};

struct Counting;

thread_local! {
    /// Allocations of this thread while `COUNTING` is set.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn count_one() {
    // `try_with`: the thread-locals may be gone while a thread exits.
    let _ = COUNTING.try_with(|c| {
        if c.get() {
            let _ = ALLOCATIONS.try_with(|a| a.set(a.get() + 1));
        }
    });
}

/// Runs `f` and returns its result and the allocations it made on this thread.
fn counted<T>(f: impl FnOnce() -> T) -> (T, u64) {
    ALLOCATIONS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    let out = f();
    COUNTING.with(|c| c.set(false));
    (out, ALLOCATIONS.with(Cell::get))
}

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_one();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_one();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steady_state_loop_does_not_allocate() {
    // A stationary vehicle at 80° N (grid frame), exact increments, aids from the truth.
    let geo = Geodetic::from_deg(80.0, 30.0, 500.0);
    let r = earth::geodetic_to_ecef(&geo);
    let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let q = UnitQuaternion::from_matrix(&c_e_g.transpose());
    let init = InitState {
        r_e_m: r.into(),
        q_b_e: [q.w, q.i, q.j, q.k],
        sigma_pos_h_m: 10.0,
        sigma_pos_v_m: 10.0,
        sigma_vel_h_mps: 0.1,
        sigma_vel_v_mps: 0.1,
        sigma_tilt_rad: 3e-4,
        sigma_heading_rad: 1e-3,
        ..Default::default()
    };
    let mut nav = Navigator::new(&init, &NavigatorConfig::default());
    let dt = 0.005;
    let w_b = c_e_g * earth::omega_ie_e();
    let f_b = Vector3::new(0.0, 0.0, earth::normal_gravity(geo.lat_rad, geo.h_m));
    let srs_at = |t_ns: u64| {
        let c =
            Rotation3::from_axis_angle(&Vector3::z_axis(), earth::OMEGA_IE * t_ns as f64 * 1e-9);
        let v_p = c * earth::omega_ie_e().cross(&r);
        let mut s = SrsSample {
            t_ns,
            count: 5,
            ..Default::default()
        };
        let dirs = [
            Vector3::new(1.0, 0.1, 0.5),
            Vector3::new(-0.3, 1.0, 0.4),
            Vector3::new(-0.7, -0.6, 0.6),
            Vector3::new(0.1, 0.2, 1.0),
            Vector3::new(0.5, -0.5, 0.7),
        ];
        for (k, d) in dirs.iter().enumerate() {
            let los = d.normalize();
            let v_k = Vector3::new(-29_780.0, 500.0 * k as f64, 1_000.0);
            let w = v_p - v_k;
            let c2 = 299_792_458.0f64 * 299_792_458.0;
            let opz = (299_792_458.0 + w.dot(&-los)) / (c2 - w.norm_squared()).sqrt();
            s.lines[k] = SrsLine {
                los_i: los.into(),
                body_vel_i_mps: v_k.into(),
                rest_wavelength_m: 5e-7,
                measured_wavelength_m: 5e-7 * opz,
                sigma_mps: 0.5,
                body_id: k as u32,
                _pad: 0,
            };
        }
        s
    };
    let p = isa::pressure(isa::geopotential_from_geometric(geo.h_m));
    // Body axes = ENU, so C_b^i = C_e^i(t) C_g^e.
    let star_at = |t_ns: u64| {
        let c_e_i =
            Rotation3::from_axis_angle(&Vector3::z_axis(), earth::OMEGA_IE * t_ns as f64 * 1e-9);
        let q = UnitQuaternion::from_matrix(&(c_e_i.matrix() * c_e_g.transpose()));
        StarSample {
            t_ns,
            seq: t_ns / 5_000_000,
            q_b_i: [q.w, q.i, q.j, q.k],
            boresight_b: [0.0, 0.0, 1.0],
            sigma_cross_arcsec: 5.0,
            sigma_boresight_arcsec: 40.0,
        }
    };
    let run = |from: u64, to: u64, nav: &mut Navigator| {
        let mut checksum = 0.0;
        for k in from..to {
            let t_ns = k * 5_000_000;
            nav.on_imu(&ImuSample {
                t_ns,
                seq: k,
                dt_s: dt,
                d_theta_rad: (w_b * dt).into(),
                d_v_mps: (f_b * dt).into(),
            })
            .expect("imu");
            if k % 20 == 0 {
                let _ = nav.on_aid(&msgs::AidSample::Baro(BaroSample {
                    t_ns,
                    seq: k,
                    pressure_pa: p,
                    temperature_k: 250.0,
                    sigma_m: 10.0,
                }));
            }
            if k % 200 == 0 {
                let _ = nav.on_aid(&msgs::AidSample::Cns(CnsFix {
                    t_ns,
                    seq: k,
                    lat_rad: geo.lat_rad,
                    lon_rad: geo.lon_rad,
                    sigma_h_m: 20.0,
                }));
                let _ = nav.on_aid(&msgs::AidSample::Srs(srs_at(t_ns)));
                let _ = nav.on_aid(&msgs::AidSample::Star(star_at(t_ns)));
            }
            checksum += nav.solution().h_m;
            if k % 200 == 0 {
                checksum += nav.status().cycles as f64;
            }
        }
        checksum
    };
    // The counter sees this thread's allocations.
    let (v, n) = counted(|| Vec::<u8>::with_capacity(16));
    assert!(
        n >= 1 && v.capacity() >= 16,
        "the counting allocator missed an allocation"
    );
    // Warm-up (lazy statics, first-time paths).
    run(1, 2_000, &mut nav);
    let (checksum, allocations) = counted(|| run(2_000, 12_000, &mut nav));
    assert!(checksum.is_finite());
    assert!(nav.imu_counters().accepted >= 11_999);
    // Every aid path ran and fused inside the counted window.
    let st = nav.status();
    assert!(
        st.aid_counters(AidKind::Srs).accepted >= 50
            && st.aid_counters(AidKind::Cns).accepted >= 50
            && st.aid_counters(AidKind::Baro).accepted >= 500
            && st.aid_counters(AidKind::Star).accepted >= 50,
        "srs {} cns {} baro {} star {}",
        st.aid_counters(AidKind::Srs).accepted,
        st.aid_counters(AidKind::Cns).accepted,
        st.aid_counters(AidKind::Baro).accepted,
        st.aid_counters(AidKind::Star).accepted
    );
    assert_eq!(
        allocations, 0,
        "navigator: {allocations} heap allocations in 10000 filter cycles"
    );

    // The same loop through the session, as the live driver runs it: the
    // baro sample of an epoch arrives before its IMU sample (it waits in the
    // queue), the CNS fix and SRS after it (fused at once); a flush per
    // cycle, status every second.
    let mut session = Session::new(SessionSettings::default());
    session.push(Input::Init(&init), &mut Discard);
    // Through the live loop's inbox, one cycle per IMU sample (the baro
    // drained before its IMU sample, the aids after).
    let mut inbox = Inbox::with_capacity(64);
    let session_run = |from: u64, to: u64, session: &mut Session, inbox: &mut Inbox| {
        let mut checksum = 0.0;
        for k in from..to {
            let t_ns = k * 5_000_000;
            let baro = BaroSample {
                t_ns,
                seq: k,
                pressure_pa: p,
                temperature_k: 250.0,
                sigma_m: 10.0,
            };
            if k % 20 == 0 {
                inbox.receive(session, Received::Aid(msgs::AidSample::Baro(baro)));
            }
            let imu = ImuSample {
                t_ns,
                seq: k,
                dt_s: dt,
                d_theta_rad: (w_b * dt).into(),
                d_v_mps: (f_b * dt).into(),
            };
            inbox.receive(session, Received::Imu(imu));
            if k % 200 == 0 {
                let cns = CnsFix {
                    t_ns,
                    seq: k,
                    lat_rad: geo.lat_rad,
                    lon_rad: geo.lon_rad,
                    sigma_h_m: 20.0,
                };
                inbox.receive(session, Received::Aid(msgs::AidSample::Cns(cns)));
                inbox.receive(session, Received::Aid(msgs::AidSample::Srs(srs_at(t_ns))));
                inbox.receive(session, Received::Aid(msgs::AidSample::Star(star_at(t_ns))));
                checksum += session.status().cycles as f64;
            }
            inbox.deliver(session, &mut Discard);
            checksum += session.navigator().map_or(f64::NAN, |n| n.solution().h_m);
        }
        checksum
    };
    session_run(1, 2_000, &mut session, &mut inbox);
    let (checksum, allocations) = counted(|| session_run(2_000, 12_000, &mut session, &mut inbox));
    assert!(checksum.is_finite());
    let st = session.status();
    assert!(st.imu().accepted >= 11_999, "{:?}", st.imu());
    assert!(
        st.aid_counters(AidKind::Srs).accepted >= 50
            && st.aid_counters(AidKind::Cns).accepted >= 50
            && st.aid_counters(AidKind::Baro).accepted >= 500
            && st.aid_counters(AidKind::Star).accepted >= 50,
        "srs {} cns {} baro {} star {}",
        st.aid_counters(AidKind::Srs).accepted,
        st.aid_counters(AidKind::Cns).accepted,
        st.aid_counters(AidKind::Baro).accepted,
        st.aid_counters(AidKind::Star).accepted
    );
    assert_eq!(
        allocations, 0,
        "session: {allocations} heap allocations in 10000 cycles"
    );
}
