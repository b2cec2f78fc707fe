//! A squatted service (issue 43, item 4): another process created one of
//! the daemon's services first with another payload type. The daemon
//! serves every other service, says so once in its log and in every
//! status (`Status::unavailable`, with the cause bit), retries, and takes
//! the service once the squatter is gone. Before, it exited with 1
//! (`PublishSubscribeOpenError(IncompatibleTypes)`), so any process of the
//! service's user could keep navigation down. The squatter is this test's
//! process; the daemon and the replay are others (their own iceoryx2
//! prefix and root, a deadline on every wait).

use std::time::{Duration, Instant};

use msgs::service::Topic;
use msgs::{GnssFix, Solution, Status, Stream, unavailable};
use polarnav_ipc::{TopicPublisher, TopicSubscriber};
use polarnav_tests::harness::{Env, short_log, status_until, terminate};

/// Lines of the daemon's log that say `service` is unavailable.
fn unavailable_lines(env: &Env, service: &str) -> usize {
    env.read("daemon.err")
        .lines()
        .filter(|l| l.contains("service unavailable") && l.contains(service))
        .count()
}

/// Whether a solution comes on `<prefix>/solution` within 20 s.
fn solutions_come(env: &Env) -> bool {
    let node = polarnav_ipc::node(&env.cfg, "test").expect("node");
    let sub = TopicSubscriber::<Solution>::new(&node, &env.cfg, Topic::Solution).expect("sub");
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(20) {
        if sub.drain(|_| {}).expect("drain") > 0 {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

/// The squatter's bits: the service, and the cause (another payload type).
fn squatted(bit: u32) -> u32 {
    bit | bit << unavailable::INCOMPATIBLE_SHIFT
}

#[test]
fn a_squatted_input_leaves_the_daemon_serving_and_is_taken_once_freed() {
    let env = Env::new("squatimu");
    let log = short_log(&env.dir, 30.0);
    let imu_bit = unavailable::stream(Stream::Imu);
    let imu = Topic::Imu.service_name(&env.cfg.prefix);
    // `<prefix>/imu` with a GNSS payload, before the daemon starts.
    let node = polarnav_ipc::node(&env.cfg, "squatter").expect("node");
    let squatter = TopicPublisher::<GnssFix>::new(&node, &env.cfg, Topic::Imu).expect("squatter");
    let mut daemon = env.start_daemon("daemon", None);
    // Its status goes out, saying which service it cannot serve and why.
    let st = status_until(&env, Duration::from_secs(10), |s| s.unavailable != 0);
    assert_eq!(st.unavailable, squatted(imu_bit), "{st:?}");
    // Retried once a second, said once: three more statuses (1 s apart)
    // see at least two retries.
    status_until(&env, Duration::from_secs(10), |s| {
        s.seq >= st.seq + 3 && s.unavailable != 0
    });
    assert!(
        daemon.try_wait().expect("wait").is_none(),
        "the daemon exited"
    );
    assert_eq!(
        unavailable_lines(&env, &imu),
        1,
        "{}",
        env.read("daemon.err")
    );
    // The squatter leaves; a replay feeds the IMU, init and aids.
    drop(squatter);
    drop(node);
    let _play = env.start_play("play", &log, "1");
    let st = status_until(&env, Duration::from_secs(20), |s| {
        s.unavailable == 0 && s.imu().received > 0
    });
    assert!(st.imu().received > 0);
    assert!(
        env.read("daemon.err").contains("service available: opened"),
        "{}",
        env.read("daemon.err")
    );
    // And it navigates: solutions come.
    assert!(
        solutions_come(&env),
        "no solution after the IMU's service was freed"
    );
    assert_eq!(terminate(&mut daemon, Duration::from_secs(10)), Some(0));
}

#[test]
fn a_squatted_output_leaves_the_daemon_navigating_and_is_taken_once_freed() {
    let env = Env::new("squatsol");
    let log = short_log(&env.dir, 30.0);
    let sol = Topic::Solution.service_name(&env.cfg.prefix);
    // `<prefix>/solution` with a status payload, before the daemon starts.
    let node = polarnav_ipc::node(&env.cfg, "squatter").expect("node");
    let squatter =
        TopicSubscriber::<Status>::new(&node, &env.cfg, Topic::Solution).expect("squatter");
    let mut daemon = env.start_daemon("daemon", None);
    let _play = env.start_play("play", &log, "1");
    // It takes and integrates the inputs, and says the solution has no service.
    let st = status_until(&env, Duration::from_secs(20), |s| {
        s.unavailable != 0 && s.imu().accepted > 0
    });
    assert_eq!(
        st.unavailable,
        squatted(unavailable::SOLUTION_SERVICE),
        "{st:?}"
    );
    // Three more statuses (1 s apart): at least two retries.
    status_until(&env, Duration::from_secs(10), |s| {
        s.seq >= st.seq + 3 && s.unavailable != 0
    });
    assert!(
        daemon.try_wait().expect("wait").is_none(),
        "the daemon exited"
    );
    assert_eq!(
        unavailable_lines(&env, &sol),
        1,
        "{}",
        env.read("daemon.err")
    );
    drop(squatter);
    drop(node);
    status_until(&env, Duration::from_secs(10), |s| s.unavailable == 0);
    assert!(
        solutions_come(&env),
        "no solution after the solution's service was freed"
    );
    assert_eq!(terminate(&mut daemon, Duration::from_secs(10)), Some(0));
}
