//! The polar frame tree in a batch MCAP, read by the reference reader:
//! `ecef` → `polar_north|south` → `body` composes back to every solution's
//! ECEF position and attitude, straight over the North Pole, and the track
//! lies in the polar frame on the solutions' positions.

use std::io::BufReader;

use nav_daemon::batch::{self, BatchOptions, Output};
use polarnav_config::ConfigFile;
use polarnav_foxglove::{AidSource, McapFile};
use polarnav_tests::{python, repo, simulate_file};

/// A batch MCAP of 90 s of paper-sim's aircraft and sensors from 89.9° N
/// heading north (over the pole after about 42 s, then south along the
/// 210° meridian), in a new directory named after `tag`: (directory, MCAP, rows).
fn over_the_pole_mcap(tag: &str) -> (std::path::PathBuf, std::path::PathBuf, u64) {
    let dir = std::env::temp_dir().join(format!("polarnav-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let text = std::fs::read_to_string(repo("config/scenarios/paper-sim.toml"))
        .expect("scenario")
        .replace("lat_deg = 87.5", "lat_deg = 89.9")
        .replace("duration_s = 600.0", "duration_s = 90.0");
    let log = dir.join("pole.navlog");
    simulate_file(&text, "over the pole (90 s)", &log);
    let mcap = dir.join("pole.mcap");
    let r = batch::run_to::<_, std::io::Sink>(
        BufReader::new(std::fs::File::open(&log).expect("open")),
        "pole.navlog",
        Output::Mcap(Box::new(
            McapFile::create(&mcap, AidSource::Updates).expect("mcap"),
        )),
        &ConfigFile::defaults(),
        &BatchOptions::default(),
    )
    .expect("batch mcap");
    (dir, mcap, r.rows)
}

#[test]
fn frame_tree_composes_back_to_the_solution_across_the_pole() {
    let (dir, mcap, rows) = over_the_pole_mcap("polar-scene");
    assert_eq!(rows, 18_000);
    let out = std::process::Command::new(python())
        .arg(repo("tests/python/check_polar.py"))
        .arg(&mcap)
        .output()
        .expect("python");
    assert!(
        out.status.success(),
        "the frame tree does not compose: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("summary");
    eprintln!("{v}");
    assert_eq!(v["solutions"].as_u64(), Some(18_000));
    assert!(v["worst_position_m"].as_f64().expect("position") <= 1e-3);
    assert!(v["worst_attitude_rad"].as_f64().expect("attitude") <= 1e-6);
    assert_eq!(v["pose_frames"], serde_json::json!(["polar_north"]));
    assert_eq!(v["track_frames"], serde_json::json!(["polar_north"]));
    // One point a second over 90 s.
    assert!(v["track_points"].as_u64().expect("points") >= 89);
    let entities = v["entities"].as_array().expect("entities");
    assert!(entities.contains(&serde_json::json!("polar_north-pole")));
    assert!(v["truth_segments"].as_u64().expect("truth") >= 1);
    // The flight really crosses the pole: the latitude rises then falls.
    std::fs::remove_dir_all(&dir).ok();
}

/// The shipped Foxglove layout opens the 3D panel on a frame this project
/// writes and shows only topics it writes; `sensor-replay scene` draws the
/// same view of a file (a real PNG with the track, the pole and aircraft).
#[test]
fn shipped_layout_names_written_frames_and_topics_and_the_scene_draws() {
    let text = std::fs::read_to_string(repo("config/foxglove/polar-layout.json")).expect("layout");
    let v: serde_json::Value = serde_json::from_str(&text).expect("layout JSON");
    let three_d = &v["configById"]["3D!polar"];
    assert_eq!(three_d["followTf"], "polar_north");
    for topic in three_d["topics"].as_object().expect("topics").keys() {
        assert!(
            polarnav_foxglove::topics().contains(&topic.as_str()),
            "{topic} is not written"
        );
    }
    for frame in three_d["transforms"].as_object().expect("frames").keys() {
        let name = frame.strip_prefix("frame:").expect("frame:");
        assert!(
            ["ecef", "polar_north", "polar_south", "body", "nav"].contains(&name),
            "{name} is not a frame of the tree"
        );
    }
    for path in v["configById"]["Plot!sigma"]["paths"]
        .as_array()
        .expect("paths")
    {
        let p = path["value"].as_str().expect("path");
        let (topic, field) = p.split_once('.').expect("topic.field");
        assert!(polarnav_foxglove::topics().contains(&topic), "{topic}");
        // /solution's fields are the solution CSV's columns, same names.
        assert_eq!(topic, "/solution", "{p}");
        assert!(
            polarnav::solution_csv::HEADER
                .split(',')
                .any(|c| c == field),
            "{p}: /solution has no field {field}"
        );
    }

    let (dir, mcap, _) = over_the_pole_mcap("polar-layout");
    let scene = sensor_replay::scene::read(&mcap, "polar_north").expect("scene");
    assert!(
        scene.lines.len() >= 2,
        "solution and truth segments: {}",
        scene.lines.len()
    );
    assert!(scene.markers.iter().any(|m| m.1 == "North Pole"));
    assert!(scene.poses.len() >= 10);
    // The aircraft passes within 15 km of the pole (it starts 11 km short
    // of it heading north).
    let closest = scene
        .poses
        .iter()
        .map(|p| (p.0.0.powi(2) + p.0.1.powi(2)).sqrt())
        .fold(f64::MAX, f64::min);
    assert!(closest < 15.0, "closest {closest} km");
    let png = dir.join("scene.png");
    sensor_replay::scene::draw(&scene, "over the pole", &png).expect("draw");
    let bytes = std::fs::read(&png).expect("png");
    assert!(
        bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 10_000,
        "{} bytes",
        bytes.len()
    );
    std::fs::remove_dir_all(&dir).ok();
}
