//! `nav-mavlink`: polarnav's solution to an autopilot over MAVLink 2
//! (HEARTBEAT, GPS_INPUT, SYSTEM_TIME, optionally ODOMETRY) on UDP or a
//! serial line. See `nav_out::mavlink_bridge`.

use std::process::ExitCode;

use clap::Parser;
use nav_out::cli::{self, Bridge, Options};
use nav_out::mavlink_bridge::{self, CONFIG_NAME, MavlinkSettings};

#[derive(Debug, Parser)]
#[command(
    name = "nav-mavlink",
    version,
    about = "polarnav's solution to an autopilot over MAVLink 2 (GPS_INPUT, ODOMETRY)",
    after_help = "Runs until SIGINT or SIGTERM. When the daemon stops, GPS_INPUT says fix type 0 \
        (NO_GPS) within 1 s; heartbeats go on."
)]
struct Cli {
    #[command(flatten)]
    opts: Options,
}

fn main() -> ExitCode {
    polarnav_ipc::logging::init("nav-mavlink");
    let cli = Cli::parse();
    cli::main(
        &Bridge {
            name: "nav-mavlink",
            config_name: CONFIG_NAME,
            load: MavlinkSettings::load,
            describe: MavlinkSettings::describe,
            prefix: |s| &s.prefix,
            run: mavlink_bridge::run,
        },
        cli.opts,
    )
}
