//! `nav-nmea`: polarnav's solution to payloads as NMEA 0183 (GGA, RMC,
//! VTG, HDT) on UDP or a serial line. See `nav_out::nmea_bridge`.

use std::process::ExitCode;

use clap::Parser;
use nav_out::cli::{self, Bridge, Options};
use nav_out::nmea_bridge::{self, CONFIG_NAME, NmeaSettings};

#[derive(Debug, Parser)]
#[command(
    name = "nav-nmea",
    version,
    about = "polarnav's solution to payloads as NMEA 0183 sentences (GGA, RMC, VTG, HDT)",
    after_help = "Runs until SIGINT or SIGTERM. When the daemon stops, the next sentences say \
        no fix (GGA quality 0, RMC status V) within 1 s."
)]
struct Cli {
    #[command(flatten)]
    opts: Options,
}

fn main() -> ExitCode {
    polarnav_ipc::logging::init("nav-nmea");
    let cli = Cli::parse();
    cli::main(
        &Bridge {
            name: "nav-nmea",
            config_name: CONFIG_NAME,
            load: NmeaSettings::load,
            describe: NmeaSettings::describe,
            prefix: |s| &s.prefix,
            run: nmea_bridge::run,
        },
        cli.opts,
    )
}
