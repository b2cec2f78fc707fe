//! Live and `batch` give the same answer bit for bit (DESIGN, "Parts and
//! layout"). `batch` pushes a navlog's inputs one by one; the live loop
//! drains its topics once per cycle — init, IMU, SRS, CNS, baro, one after
//! the other while the publisher goes on — sorts the cycle into navlog
//! order and hands it to the session. Where cycles end, and an aid drained
//! in the cycle before the IMU samples published ahead of it, must change
//! nothing: every solution equal, bit for bit, and the same accounting.

use msgs::navlog::Record;
use polarnav::inbox::{Inbox, Received};
use polarnav::session::{Collect, Input, Session, SessionSettings, Sink};
use polarnav_tests::{repo, simulate_records};

/// The topic a record comes on, in the live loop's drain order.
fn topic(r: &Record) -> Option<usize> {
    match r {
        Record::Init(_) => Some(0),
        Record::Imu(_) => Some(1),
        Record::Srs(_) => Some(2),
        Record::Cns(_) => Some(3),
        Record::Baro(_) => Some(4),
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
        Record::Srs(x) => Received::Srs(**x),
        Record::Cns(x) => Received::Cns(*x),
        Record::Baro(x) => Received::Baro(*x),
        _ => unreachable!("inputs only"),
    }
}

/// The live loop's view of a publisher that writes `records` in order:
/// each cycle drains topic after topic (through the daemon's [`Inbox`]), and
/// by the time it drains one topic the publisher has got further than when
/// it drained the one before.
fn live(records: &[&Record], seed: u64, max_step: usize) -> (Collect, msgs::Status) {
    let mut rng = Lcg(seed);
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
            *d = published;
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
        for (name, a, c) in [
            ("IMU", l_status.imu, b_status.imu),
            ("SRS", l_status.srs, b_status.srs),
            ("CNS", l_status.cns, b_status.cns),
            ("baro", l_status.baro, b_status.baro),
        ] {
            assert_eq!(a, c, "seed {seed}: {name} counters");
        }
    }
}
