//! Settings that cannot work stop both bridges with exit status 2 and a
//! message naming the file and the key: a rate of 0 or 1e9, a UDP port in
//! use, a serial device that does not exist, an unknown key; the shipped
//! settings pass.

mod common;

use std::net::UdpSocket;
use std::path::Path;
use std::process::Command;

use common::scratch;

const MAVLINK: &str = env!("CARGO_BIN_EXE_nav-mavlink");
const NMEA: &str = env!("CARGO_BIN_EXE_nav-nmea");

/// Runs `bin` on a settings file with `text`, checking or starting; returns
/// the exit code and standard error.
fn run(bin: &str, dir: &Path, name: &str, text: &str, check: bool) -> (i32, String) {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("settings");
    let mut c = Command::new(bin);
    // Isolated from any real daemon: a test prefix and iceoryx2 root,
    // removed after the run.
    let cfg = polarnav_ipc::TransportConfig::isolated("navbad");
    if check {
        c.arg("--check-config").arg(&path);
    } else {
        c.arg("--config")
            .arg(&path)
            .arg("--prefix")
            .arg(&cfg.prefix)
            .env(
                "POLARNAV_IOX_PREFIX",
                cfg.iox_prefix.clone().expect("isolated"),
            )
            .env("POLARNAV_IOX_ROOT", cfg.iox_root.clone().expect("isolated"));
    }
    let out = c.output();
    polarnav_ipc::remove_isolated(&cfg);
    let out = out.expect("run bridge");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn assert_refused(bin: &str, dir: &Path, text: &str, key: &str, check: bool) {
    let (code, err) = run(bin, dir, "bad.toml", text, check);
    assert_eq!(code, 2, "{bin} with {text:?}: exit {code}, {err}");
    assert!(
        err.contains(&format!("key `{key}`")) && err.contains("bad.toml"),
        "{bin}: the message names the file and {key}: {err}"
    );
}

const UDP: &str = "[output]\ntransport = \"udp\"\nudp_target = \"127.0.0.1:9\"\n";

#[test]
fn rates_of_zero_or_1e9_exit_2_naming_the_key() {
    let dir = scratch("bad-rates");
    for (v, check) in [("0", true), ("1e9", true), ("0", false), ("1e9", false)] {
        assert_refused(
            MAVLINK,
            &dir,
            &format!("[mavlink]\ngps_input_hz = {v}\n{UDP}"),
            "mavlink.gps_input_hz",
            check,
        );
        assert_refused(
            MAVLINK,
            &dir,
            &format!("[mavlink.odometry]\nenabled = true\nrate_hz = {v}\n{UDP}"),
            "mavlink.odometry.rate_hz",
            check,
        );
        assert_refused(
            NMEA,
            &dir,
            &format!("[nmea]\nrate_hz = {v}\n{UDP}"),
            "nmea.rate_hz",
            check,
        );
    }
    for (bin, key) in [
        (MAVLINK, "health.silent_after_s"),
        (NMEA, "health.silent_after_s"),
    ] {
        assert_refused(
            bin,
            &dir,
            &format!("{UDP}[health]\nsilent_after_s = 1e9\n"),
            key,
            true,
        );
    }
    assert_refused(
        MAVLINK,
        &dir,
        &format!("[mavlink]\nsystem_id = 0\n{UDP}"),
        "mavlink.system_id",
        true,
    );
    assert_refused(
        MAVLINK,
        &dir,
        &format!("[mavlink]\nmav_type = 200\n{UDP}"),
        "mavlink.mav_type",
        true,
    );
    assert_refused(
        NMEA,
        &dir,
        &format!("[nmea]\ntalker = \"gps\"\n{UDP}"),
        "nmea.talker",
        true,
    );
    assert_refused(
        NMEA,
        &dir,
        &format!("[nmea]\nsentences = [\"GSV\"]\n{UDP}"),
        "nmea.sentences",
        true,
    );
    assert_refused(
        NMEA,
        &dir,
        "[nmea]\nrate_hz = 20\n[output]\ntransport = \"serial\"\nserial_device = \"/dev/null\"\nserial_baud = 4800\n",
        "output.serial_baud",
        true,
    );
    // An unknown key is refused by name too.
    let (code, err) = run(
        MAVLINK,
        &dir,
        "bad.toml",
        &format!("{UDP}gps_rate = 5\n"),
        true,
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("gps_rate"), "{err}");
}

#[test]
fn a_port_in_use_exits_2_naming_the_key() {
    let dir = scratch("bad-port");
    let held = UdpSocket::bind("127.0.0.1:0").expect("hold a port");
    let port = held.local_addr().expect("addr").port();
    for bin in [MAVLINK, NMEA] {
        assert_refused(
            bin,
            &dir,
            &format!("{UDP}udp_bind = \"127.0.0.1:{port}\"\n"),
            "output.udp_bind",
            false,
        );
    }
}

#[test]
fn an_unknown_serial_device_exits_2_naming_the_key() {
    let dir = scratch("bad-serial");
    for bin in [MAVLINK, NMEA] {
        assert_refused(
            bin,
            &dir,
            "[output]\ntransport = \"serial\"\nserial_device = \"/dev/polarnav-no-such-tty\"\n",
            "output.serial_device",
            false,
        );
    }
}

#[test]
fn the_shipped_settings_are_valid() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config");
    for (bin, file) in [(MAVLINK, "nav-mavlink.toml"), (NMEA, "nav-nmea.toml")] {
        let out = Command::new(bin)
            .arg("--check-config")
            .arg(root.join(file))
            .output()
            .expect("run");
        assert!(
            out.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Under systemd the bridges send from the UDP socket the `.socket` unit
/// opened (the service has no network of its own): given one, a bridge uses
/// it and never binds `udp_bind` (here a port in use, which it would refuse
/// with exit 2). Run through `systemd-socket-activate`, which passes a socket
/// as systemd does; skipped where that tool is not installed.
#[test]
fn a_socket_passed_by_systemd_is_used_instead_of_udp_bind() {
    let Ok(tool) = which("systemd-socket-activate") else {
        eprintln!("systemd-socket-activate not installed: skipped");
        return;
    };
    let dir = scratch("socket-activation");
    let rx = UdpSocket::bind("127.0.0.1:0").expect("receiver");
    rx.set_read_timeout(Some(std::time::Duration::from_secs(20)))
        .expect("timeout");
    let held = UdpSocket::bind("127.0.0.1:0").expect("a port in use");
    let listen = UdpSocket::bind("127.0.0.1:0").expect("free port");
    let listen_port = listen.local_addr().expect("addr").port();
    drop(listen);
    let cfg_path = dir.join("nav-mavlink.toml");
    std::fs::write(
        &cfg_path,
        format!(
            "[output]\ntransport = \"udp\"\nudp_target = \"{}\"\nudp_bind = \"{}\"\n",
            rx.local_addr().expect("addr"),
            held.local_addr().expect("addr")
        ),
    )
    .expect("settings");
    let cfg = polarnav_ipc::TransportConfig::isolated("navsock");
    // Its iceoryx2 root and shared-memory files go also when the test fails.
    let _cleanup = polarnav_ipc::IsolatedCleanup(cfg.clone());
    let mut child = Command::new(tool)
        .args(["-d", "-l", &format!("127.0.0.1:{listen_port}"), MAVLINK])
        .arg("--config")
        .arg(&cfg_path)
        .arg("--prefix")
        .arg(&cfg.prefix)
        .env(
            "POLARNAV_IOX_PREFIX",
            cfg.iox_prefix.clone().expect("isolated"),
        )
        .env("POLARNAV_IOX_ROOT", cfg.iox_root.clone().expect("isolated"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("systemd-socket-activate");
    // A datagram on the socket starts the service, as systemd would.
    let poke = UdpSocket::bind("127.0.0.1:0").expect("poke");
    let mut got = None;
    for _ in 0..100 {
        let _ = poke.send_to(b"start", ("127.0.0.1", listen_port));
        rx.set_read_timeout(Some(std::time::Duration::from_millis(200)))
            .expect("timeout");
        let mut buf = [0u8; 300];
        if let Ok((n, from)) = rx.recv_from(&mut buf) {
            got = Some((buf[..n].to_vec(), from));
            break;
        }
    }
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let status = child.wait().expect("wait");
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut err);
    }
    let (frame, from) = got.unwrap_or_else(|| panic!("nothing received: {err}"));
    assert_eq!(frame[0], 0xFD, "a MAVLink 2 frame");
    assert_eq!(
        from.port(),
        listen_port,
        "sent from the passed socket: {err}"
    );
    assert!(err.contains("UDP socket that systemd opened"), "{err}");
    assert!(status.success(), "{status}: {err}");
}

fn which(name: &str) -> Result<std::path::PathBuf, ()> {
    std::env::var_os("PATH")
        .and_then(|p| {
            std::env::split_paths(&p)
                .map(|d| d.join(name))
                .find(|f| f.is_file())
        })
        .ok_or(())
}
