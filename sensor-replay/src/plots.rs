//! Figures of `sensor-replay eval`: error curves with ±3σ envelopes and an
//! optional comparison run (papers/001 Fig. 4), cumulative horizontal RMSE
//! (Figs. 5 and 9) and the ground track. PNG when a TrueType font is found
//! (DejaVu Sans, or $POLARNAV_FONT), otherwise SVG, whose text needs no font file.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::eval::Epoch;
use polarnav::solution_csv::Row;

/// One run to draw.
#[derive(Debug)]
pub struct Series<'a> {
    pub label: &'a str,
    pub rows: &'a [Row],
    pub epochs: &'a [Epoch],
}

/// Output format chosen from font availability.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
}

impl Format {
    fn ext(self) -> &'static str {
        match self {
            Format::Png => "png",
            Format::Svg => "svg",
        }
    }
}

const FONT_CANDIDATES: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

/// Registers a font for PNG text once; returns the format figures will use.
pub fn init_fonts() -> Format {
    static FORMAT: std::sync::OnceLock<Format> = std::sync::OnceLock::new();
    *FORMAT.get_or_init(|| {
        let env = std::env::var("POLARNAV_FONT").ok();
        for path in env.iter().map(String::as_str).chain(FONT_CANDIDATES) {
            if let Ok(bytes) = std::fs::read(path) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return Format::Png;
                }
            }
        }
        Format::Svg
    })
}

/// Errors while drawing.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct PlotError {
    pub path: String,
    pub message: String,
}

fn err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

const COLORS: [RGBColor; 2] = [RGBColor(0, 90, 180), RGBColor(210, 60, 30)];
const ARCMIN: f64 = 60.0 * 180.0 / std::f64::consts::PI;

/// Draws every figure into `dir`; returns the files written.
pub fn write_all(dir: &Path, runs: &[Series<'_>]) -> Result<Vec<PathBuf>, PlotError> {
    let fmt = init_fonts();
    let mut out = Vec::new();
    for name in ["error_curves", "horizontal_rmse", "track"] {
        let path = dir.join(format!("{name}.{}", fmt.ext()));
        let size = (1400, if name == "error_curves" { 1500 } else { 800 });
        match fmt {
            Format::Png => draw(
                BitMapBackend::new(&path, size).into_drawing_area(),
                runs,
                name,
            ),
            Format::Svg => draw(SVGBackend::new(&path, size).into_drawing_area(), runs, name),
        }
        .map_err(|e| err(&path, e))?;
        out.push(path);
    }
    Ok(out)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    runs: &[Series<'_>],
    name: &str,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    dispatch(&root, runs, name)?;
    root.present().map_err(|e| e.to_string())
}

fn dispatch<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    runs: &[Series<'_>],
    name: &str,
) -> Result<(), String> {
    match name {
        "error_curves" => error_curves(root, runs),
        "horizontal_rmse" => cumulative_rmse(root, runs),
        _ => track(root, runs),
    }
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-9);
    (lo - pad, hi + pad)
}

/// σ columns of the row at each epoch's time (rows and epochs are both time-ordered).
fn sigmas_at(rows: &[Row], epochs: &[Epoch]) -> Vec<[f64; 3]> {
    let mut k = 0;
    epochs
        .iter()
        .map(|e| {
            while k + 1 < rows.len() && rows[k].t_s < e.t_s - 1e-7 {
                k += 1;
            }
            rows.get(k).map_or([f64::NAN; 3], |r| r.sigma_enu_m)
        })
        .collect()
}

fn switch_times(rows: &[Row]) -> Vec<f64> {
    rows.windows(2)
        .filter(|w| w[0].frame != w[1].frame)
        .map(|w| w[1].t_s)
        .collect()
}

type Quantity = (
    &'static str,
    fn(&Epoch) -> f64,
    Option<fn(&[f64; 3]) -> f64>,
);

fn error_curves<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    runs: &[Series<'_>],
) -> Result<(), String> {
    let quantities: [Quantity; 5] = [
        ("east position error (m)", |e| e.pos_enu.x, Some(|s| s[0])),
        ("north position error (m)", |e| e.pos_enu.y, Some(|s| s[1])),
        (
            "vertical position error (m)",
            |e| e.pos_enu.z,
            Some(|s| s[2]),
        ),
        ("velocity error magnitude (m/s)", |e| e.vel_enu.norm(), None),
        ("heading error (arcmin)", |e| e.att_enu.z * ARCMIN, None),
    ];
    let panels = root.split_evenly((quantities.len(), 1));
    let t_max = runs
        .iter()
        .flat_map(|r| r.epochs.last())
        .map(|e| e.t_s)
        .fold(1.0, f64::max);
    let switches = runs
        .first()
        .map(|r| switch_times(r.rows))
        .unwrap_or_default();
    for (panel, (title, f, sig)) in panels.iter().zip(quantities) {
        let sigmas: Vec<Vec<[f64; 3]>> = runs.iter().map(|r| sigmas_at(r.rows, r.epochs)).collect();
        let mut vals: Vec<f64> = runs.iter().flat_map(|r| r.epochs.iter().map(f)).collect();
        if let Some(s) = sig {
            vals.extend(
                sigmas
                    .iter()
                    .flatten()
                    .map(|x| 3.0 * s(x))
                    .filter(|v| v.is_finite()),
            );
            vals.extend(
                sigmas
                    .iter()
                    .flatten()
                    .map(|x| -3.0 * s(x))
                    .filter(|v| v.is_finite()),
            );
        }
        let (lo, hi) = range(vals.into_iter());
        let mut chart = ChartBuilder::on(panel)
            .caption(title, ("sans-serif", 20))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..t_max, lo..hi)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(|e| e.to_string())?;
        for t in &switches {
            chart
                .draw_series(LineSeries::new(
                    [(*t, lo), (*t, hi)],
                    BLACK.mix(0.4).stroke_width(1),
                ))
                .map_err(|e| e.to_string())?;
        }
        for (k, run) in runs.iter().enumerate() {
            let c = COLORS[k % COLORS.len()];
            if let Some(s) = sig {
                for sign in [3.0, -3.0] {
                    let env = run
                        .epochs
                        .iter()
                        .zip(&sigmas[k])
                        .map(|(e, x)| (e.t_s, sign * s(x)))
                        .filter(|p| p.1.is_finite());
                    chart
                        .draw_series(LineSeries::new(env, c.mix(0.45).stroke_width(1)))
                        .map_err(|e| e.to_string())?;
                }
            }
            chart
                .draw_series(LineSeries::new(
                    run.epochs.iter().map(|e| (e.t_s, f(e))),
                    c.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?
                .label(if sig.is_some() {
                    format!("{} (±3σ thin)", run.label)
                } else {
                    run.label.to_owned()
                })
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

fn cumulative_rmse<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    runs: &[Series<'_>],
) -> Result<(), String> {
    let curves: Vec<Vec<(f64, f64)>> = runs
        .iter()
        .map(|r| {
            let mut sum = 0.0;
            r.epochs
                .iter()
                .enumerate()
                .map(|(i, e)| {
                    sum += e.pos_enu.xy().norm_squared();
                    (e.t_s, (sum / (i + 1) as f64).sqrt())
                })
                .collect()
        })
        .collect();
    let t_max = curves
        .iter()
        .flat_map(|c| c.last())
        .map(|p| p.0)
        .fold(1.0, f64::max);
    let (_, hi) = range(curves.iter().flatten().map(|p| p.1));
    let mut chart = ChartBuilder::on(root)
        .caption(
            "cumulative horizontal position RMSE (m)",
            ("sans-serif", 24),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, 0.0..hi)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .draw()
        .map_err(|e| e.to_string())?;
    for (k, (run, c)) in runs.iter().zip(&curves).enumerate() {
        let col = COLORS[k % COLORS.len()];
        chart
            .draw_series(LineSeries::new(c.iter().copied(), col.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(run.label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Ground track in the tangent plane at the middle of the flight (km), truth and solution.
fn track<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    runs: &[Series<'_>],
) -> Result<(), String> {
    let Some(first) = runs.first() else {
        return Ok(());
    };
    let rows = first.rows;
    if rows.is_empty() {
        return Ok(());
    }
    let mid = &rows[rows.len() / 2];
    let (lat, lon) = (mid.lat_deg.to_radians(), mid.lon_deg.to_radians());
    let [e, n, _] = polarnav::frames::enu_axes_e(lat, lon);
    let r0 = nalgebra::Vector3::from(mid.r_e_m);
    let project =
        |r: nalgebra::Vector3<f64>| ((r - r0).dot(&e) / 1000.0, (r - r0).dot(&n) / 1000.0);
    let step = (rows.len() / 4000).max(1);
    let sol: Vec<(f64, f64)> = rows
        .iter()
        .step_by(step)
        .map(|r| project(nalgebra::Vector3::from(r.r_e_m)))
        .collect();
    let (x0, x1) = range(sol.iter().map(|p| p.0));
    let (y0, y1) = range(sol.iter().map(|p| p.1));
    let half = ((x1 - x0).max(y1 - y0)) / 2.0;
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!(
                "track in the tangent plane at {:.3}°, {:.3}° (km)",
                mid.lat_deg, mid.lon_deg
            ),
            ("sans-serif", 24),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d((cx - half)..(cx + half), (cy - half)..(cy + half))
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("east (km)")
        .y_desc("north (km)")
        .draw()
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(LineSeries::new(sol, COLORS[0].stroke_width(2)))
        .map_err(|e| e.to_string())?
        .label(first.label)
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], COLORS[0].stroke_width(2)));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn figures_are_written_as_images() {
        let rows: Vec<Row> = (0..200)
            .map(|k| Row {
                t_s: k as f64 * 0.1,
                frame: if k < 100 { 'g' } else { 'G' },
                lat_deg: 80.0 + k as f64 * 1e-4,
                lon_deg: 10.0,
                h_m: 100.0,
                r_e_m: polarnav::earth::geodetic_to_ecef(&polarnav::earth::Geodetic::from_deg(
                    80.0 + k as f64 * 1e-4,
                    10.0,
                    100.0,
                ))
                .into(),
                v_e_mps: [0.0; 3],
                v_enu_mps: [0.0; 3],
                q_b_e: [1.0, 0.0, 0.0, 0.0],
                heading_deg: 0.0,
                pitch_deg: 0.0,
                roll_deg: 0.0,
                sigma_enu_m: [5.0, 5.0, 2.0],
                ..Row::from_solution(&msgs::Solution::default())
            })
            .collect();
        let epochs: Vec<Epoch> = rows
            .iter()
            .map(|r| Epoch {
                t_s: r.t_s,
                pos_enu: Vector3::new(r.t_s.sin(), r.t_s.cos(), 0.1),
                vel_enu: Vector3::new(0.01, 0.0, 0.0),
                att_enu: Vector3::new(0.0, 0.0, 1e-4),
                frame: r.frame,
            })
            .collect();
        let dir = std::env::temp_dir().join(format!("polarnav-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let files = write_all(
            &dir,
            &[Series {
                label: "run",
                rows: &rows,
                epochs: &epochs,
            }],
        )
        .expect("plots");
        assert_eq!(files.len(), 3);
        for f in &files {
            let bytes = std::fs::read(f).expect("read");
            let png = bytes.starts_with(b"\x89PNG");
            let svg = bytes.starts_with(b"<svg");
            assert!(png || svg, "{} is neither PNG nor SVG", f.display());
            assert!(bytes.len() > 5_000, "{} is suspiciously small", f.display());
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
