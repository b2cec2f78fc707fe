//! Live and `batch` give the same answer bit for bit (DESIGN, "Parts and
//! layout"). `batch` pushes a navlog's inputs one by one; the live loop
//! drains its topics once per cycle — init, IMU, SRS, CNS, baro, one after
//! the other while the publisher goes on — sorts the cycle into navlog
//! order and hands it to the session. Where cycles end, and an aid drained
//! in the cycle before the IMU samples published ahead of it, must change
//! nothing: every solution equal, bit for bit, and the same accounting.

use msgs::AidKind;
use msgs::navlog::Record;
use polarnav::inbox::{Inbox, Received};
use polarnav::session::{Collect, Input, Session, SessionSettings, Sink};
use polarnav_tests::{repo, simulate_records};

/// The topic a record comes on, in the live loop's drain order.
fn topic(r: &Record) -> Option<usize> {
    match r {
        Record::Init(_) => Some(0),
        Record::Imu(_) => Some(1),
        Record::Aid(a) => Some(2 + a.kind() as usize),
        _ => None,
    }
}

fn batch(records: &[&Record]) -> (Collect, msgs::Status) {
    let mut s = Session::new(SessionSettings::default());
    let mut sink = Collect::default();
    for r in records {
        s.push(Input::from_record(r).expect("input"), &mut sink);
    }
    s.finish(&mut sink);
    (sink, s.status())
}

/// A small deterministic generator (the cycle pattern is part of the test).
struct Lcg(u64);
impl Lcg {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 33) % n as u64) as usize
    }
}

fn received(r: &Record) -> Received {
    match r {
        Record::Init(x) => Received::Init(*x),
        Record::Imu(x) => Received::Imu(*x),
        Record::Aid(x) => Received::Aid(**x),
        _ => unreachable!("inputs only"),
    }
}

/// The live loop's view of a publisher that writes `records` in order:
/// each cycle drains topic after topic (through the daemon's [`Inbox`]), and
/// by the time it drains one topic the publisher has got further than when
/// it drained the one before.
fn live(records: &[&Record], seed: u64, max_step: usize) -> (Collect, msgs::Status) {
    live_with(records, seed, max_step, usize::MAX)
}

/// [`live`], and the daemon declares the IMU lost after `lost_after`
/// cycles in a row without an IMU sample, as its wall-clock watch does
/// while the IMU driver is late.
fn live_with(
    records: &[&Record],
    seed: u64,
    max_step: usize,
    lost_after: usize,
) -> (Collect, msgs::Status) {
    let mut rng = Lcg(seed);
    let mut cycles_without_imu = 0usize;
    let mut s = Session::new(SessionSettings::default());
    let mut sink = Collect::default();
    let mut inbox = Inbox::with_capacity(1024);
    // How far the publisher had got when each topic was last drained.
    let mut drained = [0usize; 5];
    let mut published = 0usize;
    while drained.iter().any(|&d| d < records.len()) {
        for (k, d) in drained.iter_mut().enumerate() {
            published = (published + rng.below(max_step + 1)).min(records.len());
            for r in records[*d..published]
                .iter()
                .filter(|r| topic(r) == Some(k))
            {
                if let Some(e) = inbox.receive(&mut s, received(r)) {
                    sink.event(&e);
                }
            }
            if k == 1 {
                let got_imu = records[*d..published].iter().any(|r| topic(r) == Some(1));
                cycles_without_imu = if got_imu { 0 } else { cycles_without_imu + 1 };
            }
            *d = published;
        }
        if cycles_without_imu == lost_after {
            s.imu_lost(&mut sink);
        }
        inbox.deliver(&mut s, &mut sink);
    }
    inbox.deliver_all(&mut s, &mut sink);
    s.finish(&mut sink);
    (sink, s.status())
}

#[test]
fn however_the_live_loop_groups_its_inputs_its_solutions_are_those_of_batch() {
    // The quick start's flight (100 Hz IMU, 10 Hz baro, 1 Hz SRS and CNS),
    // its first 30 s: 3000 solutions, 330 aid epochs.
    let text = std::fs::read_to_string(repo("config/scenarios/polar-crossing.toml"))
        .expect("scenario")
        .replace("duration_s = 19600.0", "duration_s = 30.0");
    let all = simulate_records(&text, 1);
    let records: Vec<&Record> = all.iter().filter(|r| topic(r).is_some()).collect();
    let (b, b_status) = batch(&records);
    assert_eq!(b.solutions.len(), 3000);
    for (seed, max_step) in [(1, 1), (2, 2), (3, 3), (4, 8), (5, 20), (6, 200)] {
        let (l, l_status) = live(&records, seed, max_step);
        assert_eq!(l.solutions.len(), b.solutions.len(), "seed {seed}");
        if let Some((k, (x, y))) = l
            .solutions
            .iter()
            .zip(&b.solutions)
            .enumerate()
            .find(|(_, (x, y))| x != y)
        {
            panic!(
                "seed {seed}, steps up to {max_step}: solution {k} (t = {} s) differs from batch: σv {:?} vs {:?}, position {:?} vs {:?}",
                x.t_ns as f64 * 1e-9,
                x.sigma_vel_mps,
                y.sigma_vel_mps,
                x.r_e_m,
                y.r_e_m
            );
        }
        for (name, a, c) in
            msgs::Stream::ALL.map(|k| (k.name(), *l_status.counters(k), *b_status.counters(k)))
        {
            assert_eq!(a, c, "seed {seed}: {name} counters");
        }
    }
}

/// An IMU driver that stalls while the aids keep arriving (what
/// `play --stall-imu` does over iceoryx2): the IMU samples stamped in
/// `[t0, t1)` are published only after every aid stamped before `t1`.
fn stalled(records: &[&'static Record], stalls: &[(f64, f64)]) -> Vec<&'static Record> {
    let t = |r: &Record| match r {
        Record::Init(x) => x.t_ns,
        Record::Imu(x) => x.t_ns,
        Record::Aid(x) => x.t_ns(),
        _ => unreachable!("inputs only"),
    };
    let mut out: Vec<&Record> = records.to_vec();
    for &(t0, t1) in stalls {
        let (a, b) = ((t0 * 1e9) as u64, (t1 * 1e9) as u64);
        let held: Vec<&Record> = out
            .iter()
            .copied()
            .filter(|r| matches!(r, Record::Imu(_)) && (a..b).contains(&t(r)))
            .collect();
        out.retain(|r| !(matches!(r, Record::Imu(_)) && (a..b).contains(&t(r))));
        // After the last aid stamped before t1.
        let at = out
            .iter()
            .rposition(|r| !matches!(r, Record::Imu(_)) && t(r) < b)
            .map_or(0, |k| k + 1);
        out.splice(at..at, held);
    }
    out
}

/// The IMU stalls for 0.15 s, 0.5 s and 2 s of sensor time while the aids
/// keep coming, and the daemon declares it lost each time: every aid waits
/// for the IMU sample that follows it, none is refused that `batch` fuses,
/// and every solution is batch's, bit for bit.
#[test]
fn an_imu_stalled_and_declared_lost_changes_no_solution() {
    let text = std::fs::read_to_string(repo("config/scenarios/polar-crossing.toml"))
        .expect("scenario")
        .replace("duration_s = 19600.0", "duration_s = 30.0");
    let all: &'static [Record] = Box::leak(simulate_records(&text, 1).into_boxed_slice());
    let records: Vec<&Record> = all.iter().filter(|r| topic(r).is_some()).collect();
    let (b, b_status) = batch(&records);
    let arrival = stalled(&records, &[(5.0, 5.15), (10.0, 10.5), (15.0, 17.0)]);
    // The reordering is real: some aid now arrives before IMU samples
    // stamped earlier than it.
    let mut newest_aid = 0u64;
    let mut overtaken = 0usize;
    for r in &arrival {
        match r {
            Record::Imu(x) if x.t_ns < newest_aid => overtaken += 1,
            Record::Aid(x) => newest_aid = newest_aid.max(x.t_ns()),
            _ => {}
        }
    }
    // The 100 Hz samples of each window stamped before its last 10 Hz
    // barometer sample: 5.00-5.09, 10.00-10.39, 15.00-16.89 s.
    assert_eq!(overtaken, 10 + 40 + 190, "IMU samples overtaken by an aid");
    for (seed, max_step, lost_after) in [(7, 2, 3), (8, 8, 1), (9, 40, 2)] {
        let (l, l_status) = live_with(&arrival, seed, max_step, lost_after);
        assert_eq!(l.solutions.len(), b.solutions.len(), "seed {seed}");
        let differ = l
            .solutions
            .iter()
            .zip(&b.solutions)
            .position(|(x, y)| x != y);
        assert_eq!(differ, None, "seed {seed}: first differing solution");
        for (name, a, c) in
            msgs::Stream::ALL.map(|k| (k.name(), *l_status.counters(k), *b_status.counters(k)))
        {
            assert_eq!(a, c, "seed {seed}: {name} counters");
        }
        assert!(
            b_status.aid_counters(AidKind::Baro).accepted > 250,
            "{:?}",
            b_status.aid_counters(AidKind::Baro)
        );
    }
}

/// A solution is the posterior of its epoch: the one stamped at an aid's
/// time has fused that aid. The reference drives a [`Navigator`] by hand
/// (IMU sample, then every aid stamped at or before it, then the
/// solution); the session's solutions equal it, and at every barometer
/// epoch differ from the prior one (the solution taken before the fix).
#[test]
fn the_solution_at_a_fix_epoch_has_fused_that_fix() {
    use polarnav::navigator::Navigator;
    let text = std::fs::read_to_string(repo("config/scenarios/polar-crossing.toml"))
        .expect("scenario")
        .replace("duration_s = 19600.0", "duration_s = 10.0");
    let all = simulate_records(&text, 3);
    let records: Vec<&Record> = all.iter().filter(|r| topic(r).is_some()).collect();
    let (session, _) = batch(&records);

    let init = records
        .iter()
        .find_map(|r| match r {
            Record::Init(x) => Some(*x),
            _ => None,
        })
        .expect("init");
    let aid_t = |r: &Record| match r {
        Record::Aid(x) => Some(x.t_ns()),
        _ => None,
    };
    let mut nav = Navigator::new(&init, &SessionSettings::default().navigator);
    let aids: Vec<&Record> = records
        .iter()
        .copied()
        .filter(|r| aid_t(r).is_some())
        .collect();
    let mut next_aid = 0;
    let (mut posterior, mut prior_at_fix) = (Vec::new(), Vec::new());
    for r in &records {
        let Record::Imu(s) = r else { continue };
        nav.on_imu(s).expect("imu");
        let before = nav.solution();
        let mut baro_here = false;
        while next_aid < aids.len() && aid_t(aids[next_aid]).expect("aid") <= s.t_ns {
            // An aid the gate refuses is the session's to refuse too.
            let _ = match aids[next_aid] {
                Record::Aid(x) => {
                    baro_here |= x.kind() == AidKind::Baro && x.t_ns() == s.t_ns;
                    nav.on_aid(x)
                }
                _ => unreachable!(),
            };
            next_aid += 1;
        }
        if baro_here {
            prior_at_fix.push((posterior.len(), before));
        }
        posterior.push(nav.solution());
    }
    assert_eq!(session.solutions.len(), posterior.len());
    let state = |s: &msgs::Solution| (s.t_ns, s.r_e_m, s.v_e_mps, s.q_b_e, s.sigma_pos_enu_m);
    for (k, (a, b)) in session.solutions.iter().zip(&posterior).enumerate() {
        assert_eq!(state(a), state(b), "solution {k}");
    }
    assert!(
        prior_at_fix.len() >= 99,
        "{} baro epochs",
        prior_at_fix.len()
    );
    for (k, prior) in &prior_at_fix {
        let s = &session.solutions[*k];
        assert_eq!(s.t_ns, prior.t_ns);
        assert!(
            s.sigma_pos_enu_m[2] < prior.sigma_pos_enu_m[2],
            "t = {} s: σu {} not below the prior's {}",
            s.t_ns as f64 * 1e-9,
            s.sigma_pos_enu_m[2],
            prior.sigma_pos_enu_m[2]
        );
    }
}
