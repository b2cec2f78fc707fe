//! The live view (`sensor-replay view`) over iceoryx2, each test on its own
//! service prefix with a deadline on every wait (tests/harness.rs): a
//! Foxglove protocol client receives only channels that carry data, at
//! most `--max-rate` messages per second on each, and the view's log names
//! a client refused for offering only the older subprotocol.

use std::time::Duration;

use polarnav_tests::harness::{Env, Proc, short_log, terminate, view_port, wait};
use polarnav_tests::{python, repo};

/// Topics whose data the view never has (it subscribes to the daemon's
/// outputs only): advertising one would be a channel without data.
const NEVER_IN_VIEW: [&str; 9] = [
    "/imu",
    "/srs",
    "/cns",
    "/baro",
    "/star",
    "/init",
    "/truth",
    "/truth/fix",
    "/truth/bias",
];

#[test]
fn view_advertises_only_channels_with_data_at_most_max_rate_and_names_an_old_protocol_client() {
    const RATE_HZ: f64 = 5.0;
    let env = Env::new("view");
    let log = short_log(&env.dir, 20.0);
    let _daemon = env.start_daemon("daemon", None);
    let mut view = env
        .command("sensor-replay", "view")
        .args(["view", "--prefix", &env.cfg.prefix, "--port", "0"])
        .args(["--max-rate", &RATE_HZ.to_string()])
        .spawn()
        .map(Proc)
        .expect("view");
    let port = view_port(&env, "view");
    let url = format!("ws://127.0.0.1:{port}");

    // A client of the older protocol (npm @foxglove/ws-protocol 0.8 offers
    // only this) is refused, and the view says so, naming the client.
    let old = env
        .command_for(&python(), "old")
        .arg(repo("tests/python/foxglove_client.py"))
        .args([&url, "*", "/dev/null", "10", "1", "foxglove.websocket.v1"])
        .status()
        .expect("old client");
    let said: serde_json::Value = serde_json::from_str(env.read("old.out").trim())
        .unwrap_or_else(|e| panic!("old client: {e}: {old:?} {}", env.read("old.err")));
    assert_eq!(said["refused"], 400, "{said}");
    assert!(
        said["body"]
            .as_str()
            .is_some_and(|b| b.contains("foxglove.sdk.v1")),
        "{said}"
    );
    env.wait_for("view", "refused client 127.0.0.1:", Duration::from_secs(10));
    let line = env
        .read("view.err")
        .lines()
        .find(|l| l.contains("refused client"))
        .map(str::to_owned)
        .unwrap_or_default();
    assert!(
        line.contains("offered only foxglove.websocket.v1")
            && line.contains("foxglove.sdk.v1 and foxglove.sdk.v1.1"),
        "{line}"
    );

    // A current client subscribes to whatever is advertised, before the
    // flight starts; it stops 3 s after the last solution.
    let mut client = env
        .command_for(&python(), "client")
        .arg(repo("tests/python/foxglove_client.py"))
        .args([&url, "*", "/dev/null", "90", "3"])
        .spawn()
        .map(Proc)
        .expect("client");
    env.wait_for("client", "subscribed to /solution", Duration::from_secs(30));
    // Speed 1: the view's wall-clock rate limit meets sensor time 1:1.
    let mut play = env.start_play("play", &log, "1");
    assert_eq!(wait(&mut play, Duration::from_secs(90)), Some(0), "play");
    assert_eq!(
        wait(&mut client, Duration::from_secs(90)),
        Some(0),
        "client: {}",
        env.read("client.err")
    );
    assert_eq!(terminate(&mut view, Duration::from_secs(10)), Some(0));
    let got: serde_json::Value =
        serde_json::from_str(env.read("client.out").trim()).expect("client summary");
    eprintln!("{got}");
    assert_eq!(got["subprotocol"], "foxglove.sdk.v1");
    let advertised: Vec<&str> = got["topics"]
        .as_array()
        .expect("advertised topics")
        .iter()
        .filter_map(|t| t.as_str())
        .collect();
    let count = |t: &str| got["counts"][t].as_u64().unwrap_or(0);
    for t in ["/solution", "/solution/fix", "/solution/pose", "/status"] {
        assert!(
            advertised.contains(&t),
            "{t} not advertised: {advertised:?}"
        );
    }
    for t in &advertised {
        assert!(!NEVER_IN_VIEW.contains(t), "{t} advertised without data");
        // Events are single messages (the one that creates the channel
        // precedes the subscription); every other channel keeps flowing.
        if !t.starts_with("/events") {
            assert!(count(t) > 0, "{t} advertised but carried no message");
        }
    }

    // The rate: 200 Hz solutions limited to RATE_HZ per channel. Over the
    // span of log times received (sensor time = wall time at speed 1, to
    // the replay's pacing), at most RATE_HZ · span + 1, with 5 % and one
    // message for pacing jitter; and not far under it (dropping, not
    // starving: at least 70 %).
    let view_out = env.read("view.out");
    for t in ["/solution", "/solution/fix", "/solution/pose"] {
        let span = &got["log_times"][t];
        let span_s =
            (span[1].as_u64().expect("last") - span[0].as_u64().expect("first")) as f64 * 1e-9;
        let n = count(t) as f64;
        assert!(span_s > 10.0, "{t}: only {span_s:.1} s received");
        let most = RATE_HZ * span_s * 1.05 + 2.0;
        assert!(
            n <= most,
            "{t}: {n} messages in {span_s:.2} s, more than {RATE_HZ} Hz allows ({most:.0})"
        );
        assert!(
            n >= 0.7 * RATE_HZ * span_s,
            "{t}: {n} messages in {span_s:.2} s, far under {RATE_HZ} Hz"
        );
        // The drops are counted and reported.
        let dropped: u64 = view_out
            .split("dropped by --max-rate: ")
            .nth(1)
            .and_then(|r| r.split(';').next())
            .and_then(|r| r.split(", ").find_map(|e| e.strip_prefix(&format!("{t} "))))
            .and_then(|k| k.parse().ok())
            .unwrap_or_else(|| panic!("{t}: no drop count in {view_out:?}"));
        // /solution comes at the IMU's 200 Hz, the display channels at one
        // solution per DISPLAY_PERIOD_NS of sensor time (20 Hz): of each
        // source message not passed, at least half are counted.
        let source_hz = if t == "/solution" {
            200.0
        } else {
            1e9 / polarnav_foxglove::DISPLAY_PERIOD_NS as f64
        };
        let expected = (source_hz / RATE_HZ - 1.0) * n;
        assert!(
            dropped as f64 > 0.5 * expected,
            "{t}: {dropped} dropped for {n} sent from a {source_hz} Hz source (about {expected:.0} expected)"
        );
    }
    assert!(view_out.contains("1 client(s) refused"), "{view_out}");
}
