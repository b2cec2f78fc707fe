//! The magnetometer (issue 30, item 2) over the North Pole: it disables
//! itself where the World Magnetic Model's horizontal field is below its
//! bound, says why in the status (its refusals counted under "horizontal
//! field below bound"), and fuses again once the field is back.
//!
//! `config/scenarios/mag-transpolar.toml`: 80° N on the 0° meridian over
//! the pole to 76° N on the 180° meridian at 250 m/s, the magnetometer at
//! 1 Hz with hard and soft iron that the navigator's settings calibrate.
//! The expected switching times come from the truth alone: the model's
//! horizontal field at each sample's true position against the bound.

use msgs::navlog::Record;
use msgs::{AidKind, Solution, Stream, solution_flags};
use polarnav::aids::mag::{self, cause};
use polarnav::earth;
use polarnav::session::{Event, Input, Session, SessionSettings, Sink};
use polarnav_config::{CliOverrides, ConfigFile, effective};
use polarnav_tests::{repo, simulate_records};

struct Quiet;

impl Sink for Quiet {
    fn wants_solution(&mut self, _t_ns: u64, _must: bool) -> bool {
        false
    }
    fn solution(&mut self, _s: &Solution) {}
    fn event(&mut self, _e: &Event) {}
}

/// What the status said of the magnetometer after one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Said {
    Fused,
    RefusedWeak,
    Other,
}

#[test]
fn transpolar_magnetometer_switches_off_near_the_pole_and_back_on_with_the_cause_in_the_status() {
    let text =
        std::fs::read_to_string(repo("config/scenarios/mag-transpolar.toml")).expect("scenario");
    let cfg = effective(
        &ConfigFile::defaults(),
        Some(&text),
        &CliOverrides::default(),
    )
    .expect("settings")
    .config
    .navigator();
    let m = cfg.aid_settings.own.mag.clone();
    assert_eq!(m.epoch_utc, "2026-06-01T00:00:00Z", "the scenario's date");
    let records = simulate_records(&text, 7);

    // Expected: the model's H at the true position of each sample.
    let truth: std::collections::BTreeMap<u64, [f64; 3]> = records
        .iter()
        .filter_map(|r| match r {
            Record::Truth(t) => Some((t.t_ns, t.r_e_m)),
            _ => None,
        })
        .collect();
    let expected: Vec<(u64, bool)> = records
        .iter()
        .filter_map(|r| match r {
            Record::Aid(a) if a.kind() == AidKind::Mag => {
                // The truth at or just before the sample (1 Hz, 250 m/s).
                let (_, r_e) = truth.range(..=a.t_ns()).next_back().expect("truth");
                let geo = earth::ecef_to_geodetic(&(*r_e).into());
                let f = mag::model_field(&geo, mag::date_of(a.t_ns(), &m).expect("date"))
                    .expect("model");
                Some((a.t_ns(), f.horizontal_nt() >= m.min_horizontal_nt))
            }
            _ => None,
        })
        .collect();
    let first_off = expected.iter().find(|(_, on)| !on).expect("a weak field").0;
    let back_on = expected
        .iter()
        .find(|(t, on)| *t > first_off && *on)
        .expect("the field back")
        .0;

    // The session, as batch runs it, watched after each second.
    let mut session = Session::new(SessionSettings {
        navigator: cfg.clone(),
        ..Default::default()
    });
    let mut sink = Quiet;
    let k = AidKind::Mag;
    let mut prev = (0u64, 0u64);
    let mut said: Vec<(u64, Said, bool)> = Vec::new();
    for rec in &records {
        match rec {
            Record::Truth(t) => {
                session.flush(&mut sink);
                let st = session.status();
                let accepted = st.streams[Stream::Aid(k).index()].accepted;
                let weak = st.aids[k.index()].refused[cause::WEAK_HORIZONTAL];
                let fresh = session
                    .navigator()
                    .is_some_and(|n| n.solution().flags & solution_flags::MAG_FRESH != 0);
                let now = match (accepted > prev.0, weak > prev.1) {
                    (true, false) => Said::Fused,
                    (false, true) => Said::RefusedWeak,
                    _ => Said::Other,
                };
                prev = (accepted, weak);
                said.push((t.t_ns, now, fresh));
            }
            other => {
                if let Some(input) = Input::from_record(other) {
                    session.push(input, &mut sink);
                }
            }
        }
    }
    session.finish(&mut sink);
    let st = session.status();

    let s = |t: u64| t as f64 * 1e-9;
    let t_off = said
        .iter()
        .find(|(_, w, _)| *w == Said::RefusedWeak)
        .expect("refused for a weak field")
        .0;
    let t_on = said
        .iter()
        .find(|(t, w, _)| *t > t_off && *w == Said::Fused)
        .expect("fused again")
        .0;
    println!(
        "mag over the pole: expected off at {:.0} s, on at {:.0} s; status says off at {:.0} s, on at {:.0} s; \
         refused {:?} (by cause), fused {} of {} samples",
        s(first_off),
        s(back_on),
        s(t_off),
        s(t_on),
        st.aids[k.index()].refused,
        st.streams[Stream::Aid(k).index()].accepted,
        expected.len()
    );
    // Each transition within one sample (1 s) of the truth's.
    assert!(
        t_off.abs_diff(first_off) <= 1_000_000_000,
        "off at {} s, expected {} s",
        s(t_off),
        s(first_off)
    );
    assert!(
        t_on.abs_diff(back_on) <= 1_000_000_000,
        "on at {} s, expected {} s",
        s(t_on),
        s(back_on)
    );
    // Before: fused every second and fresh; across the cap: refused for
    // the weak field, never fused, not fresh after the timeout; after:
    // fused and fresh again.
    for &(t, w, fresh) in &said {
        if t > 5_000_000_000 && t + 1_000_000_000 < t_off {
            assert!(
                w == Said::Fused && fresh,
                "{} s before: {w:?} fresh {fresh}",
                s(t)
            );
        } else if t > t_off && t < t_on {
            assert_eq!(w, Said::RefusedWeak, "{} s across the cap", s(t));
            if t > t_off + 4_000_000_000 {
                assert!(!fresh, "{} s: still fresh", s(t));
            }
        } else if t > t_on + 1_000_000_000 {
            assert!(
                w == Said::Fused && fresh,
                "{} s after: {w:?} fresh {fresh}",
                s(t)
            );
        }
    }
    let refused = st.aids[k.index()].refused;
    let weak_expected = expected.iter().filter(|(_, on)| !on).count() as u64;
    assert!(
        refused[cause::WEAK_HORIZONTAL].abs_diff(weak_expected) <= 2,
        "refused {refused:?}, expected {weak_expected} weak"
    );
    assert_eq!(refused[cause::INVALID], 0);
    assert_eq!(refused[cause::STRENGTH], 0);
    assert_eq!(refused[cause::OUTSIDE_MODEL], 0);
    // Whatever is not refused is fused (none rejected at the gate).
    let c = st.streams[Stream::Aid(k).index()];
    assert_eq!(c.rejected_gate, 0, "{c:?}");
    assert_eq!(
        c.accepted + refused.iter().sum::<u64>(),
        expected.len() as u64
    );
}
