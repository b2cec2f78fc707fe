//! `sensor-replay eval` on a short paper-sim flight (g→G at 212 s) with an
//! MCAP solution from batch: every figure is written as a real image and
//! named in the summary, and the simulator's IMU bias comes back from the
//! navlog as it was drawn.

use msgs::AidKind;
use std::io::BufWriter;

use nav_daemon::batch::Output;
use polarnav_config::CliOverrides;
use polarnav_eval::logfile;
use polarnav_eval::solution_file;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::sensors::ImuErrorModel;
use polarnav_sim::simulate::{SimOptions, simulate};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

mod common;
use common::{batch_to, eval, png_size, repo};

const SEED: u64 = 7;

#[test]
fn eval_writes_every_figure_from_an_mcap_solution_and_truth_bias_round_trips() {
    let dir = std::env::temp_dir().join(format!("polarnav-eval-figures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    // paper-sim shortened to 240 s: it still crosses 88° N at 212 s.
    let text = std::fs::read_to_string(repo("config/scenarios/paper-sim.toml"))
        .expect("scenario")
        .replace("duration_s = 600.0", "duration_s = 240.0");
    assert!(text.contains("duration_s = 240.0"));
    let s = Scenario::parse(&text, "paper-sim (240 s)").expect("scenario");
    let log = dir.join("paper.navlog");
    let sim = simulate(
        &s,
        &text,
        SimOptions {
            seed: SEED,
            ..Default::default()
        },
        std::fs::File::create(&log).expect("create"),
    )
    .expect("simulate");

    // The truth bias: one record per truth epoch (and t = 0), equal to the
    // simulator's draw (paper-sim has no Gauss–Markov part).
    let drawn = ImuErrorModel::new(&s.imu, &mut ChaCha20Rng::seed_from_u64(SEED)).drawn;
    let c = logfile::load(&log).expect("load");
    assert_eq!(c.truth_bias.len(), c.truth.len());
    assert_eq!(c.truth.len() as u64, sim.truth + 1);
    // Bit for bit: postcard stores the f64 values themselves.
    let bits = |v: [f64; 3]| v.map(f64::to_bits);
    for (b, t) in c.truth_bias.iter().zip(&c.truth) {
        assert_eq!(b.t_ns, t.t_ns);
        assert_eq!(bits(b.gyro_bias_rps), bits(drawn.gyro_bias_rps.into()));
        assert_eq!(bits(b.accel_bias_mps2), bits(drawn.accel_bias_mps2.into()));
    }
    assert!(drawn.gyro_bias_rps.norm() > 0.0 && drawn.accel_bias_mps2.norm() > 0.0);

    // The solution as MCAP (with the aid updates) and, never switching, as CSV.
    let mcap = dir.join("run.mcap");
    let m = polarnav_foxglove::McapFile::create(&mcap, polarnav_foxglove::AidSource::Updates)
        .expect("mcap");
    batch_to(&log, Output::Mcap(Box::new(m)), CliOverrides::default());
    let never = dir.join("never.csv");
    batch_to(
        &log,
        Output::Csv(BufWriter::new(
            std::fs::File::create(&never).expect("create"),
        )),
        CliOverrides {
            force_switch_s: Some(Vec::new()),
            ..Default::default()
        },
    );
    let loaded = solution_file::load(&mcap).expect("read the MCAP solution");
    let aids = loaded.aids.as_ref().expect("aid updates");
    assert!(
        !aids[AidKind::Srs].is_empty()
            && !aids[AidKind::Cns].is_empty()
            && !aids[AidKind::Baro].is_empty()
    );
    assert!(loaded.rows.iter().any(|r| r.frame == 'g'));
    assert!(loaded.rows.iter().any(|r| r.frame == 'G'));

    let fmt = polarnav_eval::plots::init_fonts();
    let ext = match fmt {
        polarnav_eval::plots::Format::Png => "png",
        polarnav_eval::plots::Format::Svg => "svg",
    };
    let figs = dir.join("figs");
    let summary = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        mcap.as_os_str(),
        "--compare".as_ref(),
        never.as_os_str(),
        "--out".as_ref(),
        figs.as_os_str(),
    ]);
    let on_disk = std::fs::read_to_string(figs.join("summary.md")).expect("summary.md");
    assert_eq!(on_disk.trim(), summary.trim());
    for name in polarnav_eval::plots::FIGURES {
        let file = format!("{name}.{ext}");
        let p = figs.join(&file);
        let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        if ext == "png" {
            let (w, h) = png_size(&bytes);
            assert!(w >= 1000 && h >= 600, "{file}: {w}×{h}");
        } else {
            assert!(bytes.starts_with(b"<svg"), "{file}");
        }
        assert!(bytes.len() > 20_000, "{file}: only {} bytes", bytes.len());
        assert!(
            summary.contains(&format!("`{file}`")),
            "summary does not name {file}:\n{summary}"
        );
    }

    // A CSV solution: no innovations, and the summary says how to get them.
    let figs_csv = dir.join("figs-csv");
    let summary = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        never.as_os_str(),
        "--out".as_ref(),
        figs_csv.as_os_str(),
    ]);
    assert!(!figs_csv.join(format!("innovations.{ext}")).exists());
    assert!(!figs_csv.join(format!("compare_difference.{ext}")).exists());
    assert!(figs_csv.join(format!("attitude_errors.{ext}")).exists());
    assert!(
        summary.contains("no `innovations` figure") && summary.contains("--out run.mcap"),
        "{summary}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
