//! `sensor-replay listen`: the live monitor (like `px4 listener`).

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use msgs::service::Topic;
use msgs::{Solution, Status, WireFrame, solution_flags};
use polarnav_ipc::{TopicSubscriber, TransportConfig, TransportError};

/// One screen of text for the newest solution and status.
pub fn render(sol: Option<&Solution>, st: Option<&Status>, solutions_per_s: f64) -> String {
    let mut s = String::new();
    match sol {
        None => s.push_str("solution: none yet\n"),
        Some(x) => {
            let frame = WireFrame::from_u8(x.frame).map_or('?', WireFrame::letter);
            let flag = |b: u32, name: &str| {
                if x.flags & b != 0 {
                    name.to_owned()
                } else {
                    format!("-{name}")
                }
            };
            s.push_str(&format!(
                "t {:.3} s  frame {frame}  switches {}  ({solutions_per_s:.0} solutions/s)\n",
                x.t_ns as f64 * 1e-9,
                x.switch_count
            ));
            s.push_str(&format!(
                "lat {:+.7}°  lon {:+.7}°  h {:.1} m   σ E/N/U {:.1} {:.1} {:.1} m\n",
                x.lat_rad.to_degrees(),
                x.lon_rad.to_degrees(),
                x.h_m,
                x.sigma_pos_enu_m[0],
                x.sigma_pos_enu_m[1],
                x.sigma_pos_enu_m[2]
            ));
            s.push_str(&format!(
                "v E/N/U {:+.2} {:+.2} {:+.2} m/s   heading {:.2}° (grid {:.2}°)  pitch {:+.2}°  roll {:+.2}°\n",
                x.v_enu_mps[0],
                x.v_enu_mps[1],
                x.v_enu_mps[2],
                x.heading_rad.to_degrees(),
                x.grid_heading_rad.to_degrees(),
                x.pitch_rad.to_degrees(),
                x.roll_rad.to_degrees()
            ));
            // The solution's own flags, then each aid's from its
            // declaration (fresh; for an aid that is not autonomous, its
            // exclusion and its untested fusion), so that a new aid is
            // listed without an edit here.
            let mut flags: Vec<String> = [
                (solution_flags::ALIGNED, "aligned"),
                (solution_flags::IMU_LOST, "imu-lost"),
                (solution_flags::LAST_INNOVATION_REJECTED, "rejected"),
                (solution_flags::COASTING, "coasting"),
                (solution_flags::RESUMED, "resumed"),
                (solution_flags::AID_RESET, "aid-reset"),
                (solution_flags::LEVEL_FUSED, "level"),
                (solution_flags::SECOND_PUBLISHER, "second-publisher"),
            ]
            .into_iter()
            .map(|(b, name)| flag(b, name))
            .collect();
            flags.push(format!(
                "state {}",
                polarnav::flight_state::FlightState::from_flags(x.flags).name()
            ));
            s.push_str(&format!(
                "flags: {}   resets {} (last Δr {:.2} m)\n",
                flags.join(" "),
                x.reset_count,
                x.reset_delta_pos_e_m
                    .iter()
                    .map(|d| d * d)
                    .sum::<f64>()
                    .sqrt()
            ));
            let mut aids = Vec::new();
            for k in msgs::AidKind::ALL {
                let d = k.decl();
                aids.push(flag(d.fresh_flag, d.name));
                if !d.autonomous {
                    aids.push(flag(d.excluded_flag, &format!("{}-excluded", d.name)));
                    aids.push(flag(d.untested_flag, &format!("{}-untested", d.name)));
                }
            }
            s.push_str(&format!("aids fresh: {}\n", aids.join(" ")));
        }
    }
    match st {
        None => s.push_str("status: none yet\n"),
        Some(x) => {
            s.push_str(&format!(
                "status seq {}: cycles {}  overruns {} (CPU {})  cycle mean {:.1} µs max {:.1} µs  reinits {}  IMU gaps {} ({:.2} s coasted)  checkpoints {}{}  attitude: {}\n",
                x.seq,
                x.cycles,
                x.overruns,
                x.overruns_cpu,
                x.cycle_time_mean_ns as f64 * 1e-3,
                x.cycle_time_max_ns as f64 * 1e-3,
                x.reinit_count,
                x.imu_gap_count,
                x.coasted_ns as f64 * 1e-9,
                x.checkpoints_written,
                if x.resumed == 1 { " (resumed)" } else { "" },
                x.init_method().map_or_else(
                    || format!("unknown method {}", x.init_method),
                    |m| format!("{m}")
                )
            ));
            if x.unavailable != 0 {
                s.push_str(&format!(
                    "  UNAVAILABLE services (not opened, retried): {}\n",
                    msgs::unavailable::describe(x.unavailable)
                ));
            }
            let rows = std::iter::once(("imu", x.imu(), None))
                .chain(x.each_aid().map(|(k, c, a)| (k.name(), c, Some((k, a)))));
            for (name, c, a) in rows {
                let name = format!("{name:<4}");
                s.push_str(&format!(
                    "  {name} rx {:8} ok {:8} bad {:4} time {:4} gate {:4} unused {:4} gaps {:4}",
                    c.received,
                    c.accepted,
                    c.rejected_invalid,
                    c.rejected_time,
                    c.rejected_gate,
                    c.not_used,
                    c.seq_gaps
                ));
                if let Some((k, a)) = a {
                    s.push_str(&format!(
                        "  test ratio {:.2} {}",
                        a.test_ratio,
                        if a.fresh == 1 { "fresh" } else { "stale" }
                    ));
                    if !k.decl().autonomous {
                        s.push_str(&integrity(a));
                    }
                }
                s.push('\n');
            }
        }
    }
    s
}

/// The integrity test of an aid that is not autonomous, for its row.
fn integrity(a: &msgs::AidStatus) -> String {
    use msgs::integrity_state as st;
    if a.excluded != 0 {
        return format!(
            "  EXCLUDED since {:.1} s: {} (q/threshold {:.2})",
            a.excluded_since_t_ns as f64 * 1e-9,
            polarnav::integrity::cause::text(a.exclusion_cause),
            a.integrity_ratio
        );
    }
    match a.integrity_state {
        st::TESTED => format!("  integrity tested, q/threshold {:.2}", a.integrity_ratio),
        st::UNAVAILABLE => "  integrity UNAVAILABLE: fused untested".to_owned(),
        st::NOT_TESTED => "  integrity not tested".to_owned(),
        other => format!("  integrity state {other} unknown"),
    }
}

/// One update of the monitor as written to stdout: on a terminal the screen
/// redrawn in place (cursor home, clear); elsewhere (a file, a pipe) plain
/// lines with a blank line between updates, no escape sequences.
pub fn update(screen: &str, terminal: bool) -> String {
    if terminal {
        format!("\x1b[H\x1b[2J{screen}")
    } else {
        format!("{screen}\n")
    }
}

/// Shows the newest solution and status until stopped: in place on a
/// terminal, as successive blocks of plain lines otherwise. A reader that
/// stopped reading (`sensor-replay listen | head`: a broken pipe) ends the
/// listening quietly; any other failed write (a full disk) is an error
/// naming standard output.
pub fn listen(
    cfg: &TransportConfig,
    stop: &AtomicBool,
    duration: Option<Duration>,
) -> Result<(), TransportError> {
    let node = polarnav_ipc::node(cfg, "sensor-replay-listen")?;
    let sol = TopicSubscriber::<Solution>::new(&node, cfg, Topic::Solution)?;
    let st = TopicSubscriber::<Status>::new(&node, cfg, Topic::Status)?;
    let terminal = std::io::stdout().is_terminal();
    let start = Instant::now();
    let (mut last_sol, mut last_st) = (None, None);
    let mut count = 0u64;
    let mut window = Instant::now();
    let mut rate = 0.0;
    while !stop.load(Ordering::Relaxed) && duration.is_none_or(|d| start.elapsed() < d) {
        std::thread::sleep(Duration::from_millis(250));
        count += sol.drain(|x| last_sol = Some(x))? as u64;
        st.drain(|x| last_st = Some(x))?;
        let dt = window.elapsed().as_secs_f64();
        if dt >= 1.0 {
            rate = count as f64 / dt;
            count = 0;
            window = Instant::now();
        }
        let text = update(&render(last_sol.as_ref(), last_st.as_ref(), rate), terminal);
        match crate::write_stdout(text.as_bytes()) {
            Ok(true) => {}
            Ok(false) => return Ok(()),
            Err(e) => return Err(TransportError::Io("standard output".into(), e.to_string())),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_shows_frame_position_and_aid_health() {
        let sol = Solution {
            t_ns: 1_500_000_000,
            frame: 1,
            lat_rad: 1.5,
            flags: solution_flags::ALIGNED | solution_flags::CNS_FRESH,
            ..Default::default()
        };
        let mut st = Status {
            cycles: 10,
            ..Default::default()
        };
        st.aid_mut(msgs::AidKind::Cns).fresh = 1;
        st.counters_mut(msgs::Stream::Imu).received = 300;
        let text = render(Some(&sol), Some(&st), 200.0);
        assert!(
            text.contains("frame G") && text.contains("lat +85.9436693°"),
            "{text}"
        );
        assert!(
            text.contains("cns") && text.contains("fresh") && text.contains("stale"),
            "{text}"
        );
        // Every aid's freshness from the declaration (the CNS's set, the
        // others not), GNSS's exclusion and untested fusion among them.
        assert!(
            text.contains(
                "aids fresh: -srs cns -baro -star -gnss -gnss-excluded -gnss-untested \
                 -baseline -mag\n"
            ),
            "{text}"
        );
        let gnss_sol = Solution {
            flags: solution_flags::GNSS_FRESH
                | solution_flags::GNSS_UNTESTED
                | solution_flags::MAG_FRESH
                | solution_flags::SECOND_PUBLISHER
                | (2 << solution_flags::FLIGHT_STATE_SHIFT),
            ..sol
        };
        let g = render(Some(&gnss_sol), None, 200.0);
        assert!(
            g.contains(" gnss -gnss-excluded gnss-untested -baseline mag\n")
                && g.contains(" second-publisher state steady ")
                && g.contains("-aligned"),
            "{g}"
        );
        assert!(text.contains("rx      300"), "{text}");
        assert!(render(None, None, 0.0).contains("none yet"));
        // GNSS, the aid that is not autonomous: its integrity test's state.
        let g = msgs::AidKind::Gnss;
        assert!(text.contains("integrity not tested"), "{text}");
        st.aid_mut(g).integrity_state = msgs::integrity_state::UNAVAILABLE;
        let text = render(Some(&sol), Some(&st), 200.0);
        assert!(
            text.contains("integrity UNAVAILABLE: fused untested"),
            "{text}"
        );
        st.aid_mut(g).excluded = 1;
        st.aid_mut(g).exclusion_cause = 2;
        st.aid_mut(g).excluded_since_t_ns = 318_000_000_000;
        let text = render(Some(&sol), Some(&st), 200.0);
        assert!(
            text.contains("EXCLUDED since 318.0 s: velocity inconsistent"),
            "{text}"
        );
        assert_eq!(text.matches("integrity").count(), 0, "{text}");
    }

    #[test]
    fn only_a_terminal_gets_redraw_escapes() {
        let screen = render(None, None, 0.0);
        assert!(update(&screen, true).starts_with("\x1b[H"));
        let plain = update(&screen, false);
        assert!(!plain.contains('\x1b'), "{plain:?}");
        assert!(plain.starts_with(&screen));
    }
}
