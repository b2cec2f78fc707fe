//! Figures of `sensor-replay eval`, as a navigation engineer reads a flight:
//! position, velocity and attitude errors against truth with ±3σ envelopes,
//! IMU bias estimates against the simulated truth, normalized innovations
//! and test ratios per aid with the gate, the difference of a comparison
//! run, cumulative horizontal RMSE (papers/001 Figs. 5 and 9) and the track
//! in a polar stereographic projection. Every time plot marks the frame
//! switches with a labelled line; legends sit in a strip right of the
//! panels, never over data. PNG when a TrueType font is found (DejaVu Sans,
//! or $POLARNAV_FONT), otherwise SVG, whose text needs no font file.

use std::path::{Path, PathBuf};

use msgs::TruthRecord;
use msgs::navlog::TruthBias;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::eval::Epoch;
use crate::figures::{self, FigureData, FigureFeed, MAX_POINTS, Switch};
use crate::solution_file::{AidPoint, Aids, UpdatesOnDisk, aids_to_disk, for_each_update};
use polarnav::solution_csv::Row;

/// One run to draw.
#[derive(Debug)]
pub struct Series<'a> {
    pub label: &'a str,
    pub rows: &'a [Row],
    pub epochs: &'a [Epoch],
}

/// Everything the figures draw: the runs (the first is the solution, a
/// second the comparison), the log's truth and truth bias, and the aid
/// updates when the solution came as MCAP.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    pub runs: &'a [Series<'a>],
    pub truth: &'a [TruthRecord],
    pub truth_bias: &'a [TruthBias],
    pub aids: Option<&'a Aids>,
}

/// A written figure and what it shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub path: PathBuf,
    pub what: String,
}

/// Output format chosen from font availability.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
}

impl Format {
    pub(crate) fn ext(self) -> &'static str {
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

pub(crate) fn err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

pub(crate) fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

pub(crate) const BLUE: RGBColor = RGBColor(0, 90, 180);
pub(crate) const ORANGE: RGBColor = RGBColor(220, 110, 0);
pub(crate) const GREEN: RGBColor = RGBColor(0, 140, 60);
pub(crate) const RED_: RGBColor = RGBColor(200, 30, 30);
pub(crate) const GREY: RGBColor = RGBColor(110, 110, 110);
pub(crate) const AXIS_COLORS: [RGBColor; 3] = [BLUE, ORANGE, GREEN];
/// Width of the legend strip right of the panels (px).
const LEGEND_W: u32 = 290;
/// Height of each run's distance panel below the track's map (px).
const TRACK_PANEL_PX: u32 = 240;
/// Stroke widths of the truth's and a compared run's track, each wider
/// than the one drawn over it (the solution's is 2 px), so that tracks that
/// coincide at the map's scale show as nested rims.
const TRUTH_TRACK_W: u32 = 10;
const COMPARE_TRACK_W: u32 = 6;

/// The figures `write_all` can produce, in order.
pub const FIGURES: [&str; 8] = [
    "position_errors",
    "velocity_errors",
    "attitude_errors",
    "imu_biases",
    "innovations",
    "compare_difference",
    "horizontal_rmse",
    "track",
];

/// Draws every figure that the inputs allow into `dir`: the innovations
/// need aid updates (an MCAP solution), the difference a comparison run.
pub fn write_all(dir: &Path, inp: &Inputs<'_>) -> Result<Vec<Figure>, PlotError> {
    let io = |e: std::io::Error| err(dir, e);
    let labels: Vec<&str> = inp.runs.iter().map(|r| r.label).collect();
    let mut feed = FigureFeed::new(&labels).map_err(io)?;
    let runs: Vec<(&[Row], &[Epoch])> = inp.runs.iter().map(|r| (r.rows, r.epochs)).collect();
    figures::feed_from_memory(&mut feed, &runs, inp.truth, inp.truth_bias).map_err(io)?;
    let aids = match inp.aids {
        Some(a) => Some(aids_to_disk(a.clone()).map_err(|e| err(dir, e))?),
        None => None,
    };
    write_figures(dir, &feed.finish(aids).map_err(io)?)
}

/// Draws every figure that `d` allows into `dir` (see [`write_all`]).
pub fn write_figures(dir: &Path, d: &FigureData) -> Result<Vec<Figure>, PlotError> {
    let fmt = init_fonts();
    let mut out = Vec::new();
    if d.labels.is_empty() {
        return Ok(out);
    }
    let switches = &d.switches;
    for name in FIGURES {
        let (size, what) = match name {
            "position_errors" => ((1500, 1100), "position error east/north/up (m) with ±3σ"),
            "velocity_errors" => (
                (1500, 1100),
                "velocity error in nav-frame axes (m/s) with ±3σ",
            ),
            "attitude_errors" => (
                (1500, 1100),
                "attitude error: tilt about nav x/y and heading (arcmin) with ±3σ",
            ),
            "imu_biases" => (
                (1700, 1000),
                "gyro (°/h) and accelerometer (µg) bias estimates with their ±3σ against the simulated truth",
            ),
            "innovations" if d.aids.is_some() => (
                (1700, 1250),
                "normalized innovations and test ratios per aid with the gate",
            ),
            "compare_difference" if d.labels.len() > 1 => (
                (1500, 1200),
                "compare − solution: position, velocity and heading differences",
            ),
            "horizontal_rmse" => ((1500, 700), "cumulative horizontal position RMSE (m)"),
            "track" => (
                (1400, 1640),
                "track in polar stereographic projection: truth, solution, start, end, switches; below, each run's horizontal distance from the truth",
            ),
            _ => continue,
        };
        let path = dir.join(format!("{name}.{}", fmt.ext()));
        match fmt {
            Format::Png => draw(
                BitMapBackend::new(&path, size).into_drawing_area(),
                d,
                switches,
                name,
            ),
            Format::Svg => draw(
                SVGBackend::new(&path, size).into_drawing_area(),
                d,
                switches,
                name,
            ),
        }
        .map_err(|e| err(&path, e))?;
        out.push(Figure {
            path,
            what: what.into(),
        });
    }
    Ok(out)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
    name: &str,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(s)?;
    match name {
        "position_errors" => position_errors(&root, inp, sw),
        "velocity_errors" => velocity_errors(&root, inp, sw),
        "attitude_errors" => attitude_errors(&root, inp, sw),
        "imu_biases" => biases(&root, inp, sw),
        "innovations" => innovations(&root, inp, sw),
        "compare_difference" => compare_difference(&root, inp, sw),
        "horizontal_rmse" => cumulative_rmse(&root, inp, sw),
        _ => track(&root, inp, sw),
    }?;
    root.present().map_err(s)
}

/// Tick labels with as many decimals as the axis span needs (never cut:
/// the label areas are sized for 9 characters).
pub(crate) fn tick(v: f64, span: f64) -> String {
    let d = if span > 0.0 && span.is_finite() {
        (1.0 - span.log10().floor()).clamp(0.0, 6.0) as usize
    } else {
        2
    };
    if span > 0.0 && span < 1e-3 {
        return if v.abs() < span * 1e-6 {
            "0".to_owned()
        } else {
            format!("{v:.1e}")
        };
    }
    let t = format!("{v:.d$}");
    if t.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".to_owned()
    } else {
        t
    }
}

fn decimate<T: Copy>(v: &[T]) -> impl Iterator<Item = T> + '_ {
    v.iter().step_by((v.len() / MAX_POINTS).max(1)).copied()
}

/// The points of a panel's curve to draw: `decimate`d, unless `picked`
/// already (a curve reduced as the flight streamed in).
fn drawn<T: Copy>(v: &[T], picked: bool) -> impl Iterator<Item = T> + '_ {
    let step = if picked {
        1
    } else {
        (v.len() / MAX_POINTS).max(1)
    };
    v.iter().step_by(step).copied()
}

/// The value at `q` (0..1) of the finite magnitudes.
fn quantile_abs(values: impl Iterator<Item = f64>, q: f64) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).map(f64::abs).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy)]
pub enum Mark {
    Line(RGBColor, u32),
    Band(RGBColor),
    Dot(RGBColor),
    Cross(RGBColor),
    Square(RGBColor),
    Triangle,
    Switch,
}

/// The legend in the strip right of the panels: a title, the entries, then
/// the notes in grey, wrapped to the strip's width (24 and 30 characters in
/// the evaluator's 290-pixel strip).
pub fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    entries: &[(String, Mark)],
    notes: &[String],
) -> Result<(), String> {
    let strip = area.dim_in_pixel().0 as usize;
    let (label_w, note_w) = (strip.saturating_sub(50) / 10, strip.saturating_sub(20) / 9);
    let font = ("sans-serif", 17).into_font();
    let mut y = 60;
    area.draw(&Text::new(
        title.to_owned(),
        (10, y - 30),
        ("sans-serif", 18).into_font().style(FontStyle::Bold),
    ))
    .map_err(s)?;
    for (label, mark) in entries {
        let (x0, x1) = (12, 48);
        match *mark {
            Mark::Line(c, w) => area
                .draw(&PathElement::new([(x0, y), (x1, y)], c.stroke_width(w)))
                .map_err(s)?,
            Mark::Band(c) => area
                .draw(&Rectangle::new(
                    [(x0, y - 7), (x1, y + 7)],
                    c.mix(0.25).filled(),
                ))
                .map_err(s)?,
            Mark::Dot(c) => area
                .draw(&Circle::new(((x0 + x1) / 2, y), 4, c.filled()))
                .map_err(s)?,
            Mark::Cross(c) => area
                .draw(&Cross::new(((x0 + x1) / 2, y), 5, c.stroke_width(2)))
                .map_err(s)?,
            Mark::Square(c) => area
                .draw(&Rectangle::new(
                    [((x0 + x1) / 2 - 6, y - 6), ((x0 + x1) / 2 + 6, y + 6)],
                    c.filled(),
                ))
                .map_err(s)?,
            Mark::Triangle => area
                .draw(&TriangleMarker::new(((x0 + x1) / 2, y), 9, BLACK.filled()))
                .map_err(s)?,
            Mark::Switch => area
                .draw(&PathElement::new(
                    [((x0 + x1) / 2, y - 10), ((x0 + x1) / 2, y + 10)],
                    BLACK.mix(0.6).stroke_width(2),
                ))
                .map_err(s)?,
        }
        let mut yy = y - 9;
        for part in wrap(label, label_w.max(8)) {
            area.draw(&Text::new(part, (x1 + 10, yy), font.clone()))
                .map_err(s)?;
            yy += 20;
        }
        y = yy + 16;
    }
    y += 10;
    for n in notes {
        for part in wrap(n, note_w.max(8)) {
            area.draw(&Text::new(
                part,
                (10, y),
                ("sans-serif", 15).into_font().color(&GREY),
            ))
            .map_err(s)?;
            y += 19;
        }
        y += 8;
    }
    Ok(())
}

/// Greedy word wrap at `width` characters (a longer word is cut).
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut out: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        let mut word: Vec<char> = word.chars().collect();
        while word.len() > width {
            out.push(word.drain(..width).collect());
        }
        let word: String = word.into_iter().collect();
        match out.last_mut() {
            Some(l) if l.chars().count() + 1 + word.chars().count() <= width => {
                l.push(' ');
                l.push_str(&word);
            }
            _ => out.push(word),
        }
    }
    out
}

/// A curve: points, colour, stroke width.
pub(crate) type Line = (Vec<(f64, f64)>, RGBColor, u32);
/// An envelope: (t, lo, hi) points and its colour.
pub(crate) type Band = (Vec<(f64, f64, f64)>, RGBColor);
/// Points too many to hold, handed over a chunk at a time when drawn.
pub(crate) type OnDisk =
    Box<dyn Fn(&mut dyn FnMut(&[(f64, f64)]) -> Result<(), String>) -> Result<(), String>>;
/// A drawing area of a figure.
pub(crate) type Area<DB> = DrawingArea<DB, Shift>;

/// One time-series panel.
#[derive(Default)]
pub(crate) struct Panel {
    pub(crate) title: String,
    /// (t, lo, hi) filled.
    pub(crate) bands: Vec<Band>,
    pub(crate) lines: Vec<Line>,
    pub(crate) dots: Vec<(Vec<(f64, f64)>, RGBColor)>,
    pub(crate) crosses: Vec<(Vec<(f64, f64)>, RGBColor)>,
    pub(crate) hlines: Vec<(f64, RGBColor)>,
    /// Fixed y range (otherwise from the data, symmetric when `symmetric`).
    pub(crate) y: Option<(f64, f64)>,
    pub(crate) symmetric: bool,
    /// Tick label of a y value (default: decimals from the span).
    pub(crate) y_fmt: Option<fn(f64) -> String>,
    /// Time axis from–to (s); default 0 to the figure's end.
    pub(crate) x: Option<(f64, f64)>,
    /// Label of the y axis (its quantity and unit).
    pub(crate) y_desc: Option<String>,
    /// The curves hold the points `decimate` picks already (reduced as the
    /// flight streamed in): drawn as they are.
    pub(crate) picked: bool,
    /// With `picked`: the extent of every finite point of the lines, dots
    /// and crosses, and the 99th percentile of |value| of every band point.
    pub(crate) extent: Option<(f64, f64)>,
    pub(crate) band_q99: Option<f64>,
    /// Crosses drawn after `crosses`, read from disk (not in the y range).
    pub(crate) crosses_on_disk: Vec<(OnDisk, RGBColor)>,
}

impl std::fmt::Debug for Panel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.title)
    }
}

impl Panel {
    fn y_range(&self) -> (f64, f64) {
        if let Some(r) = self.y {
            return r;
        }
        let data = self
            .lines
            .iter()
            .flat_map(|l| l.0.iter().map(|p| p.1))
            .chain(self.dots.iter().flat_map(|l| l.0.iter().map(|p| p.1)))
            .chain(self.crosses.iter().flat_map(|l| l.0.iter().map(|p| p.1)));
        // Envelopes: the 99th percentile, so that the first seconds of a
        // wide initial σ do not flatten the converged part.
        let band_hi = self.band_q99.unwrap_or_else(|| {
            quantile_abs(
                self.bands
                    .iter()
                    .flat_map(|b| b.0.iter().flat_map(|p| [p.1, p.2])),
                0.99,
            )
        });
        let (mut lo, mut hi) = self.extent.unwrap_or_else(|| {
            data.filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                })
        });
        if band_hi.is_finite() {
            lo = lo.min(-band_hi);
            hi = hi.max(band_hi);
        }
        for (h, _) in &self.hlines {
            lo = lo.min(*h);
            hi = hi.max(*h);
        }
        if !lo.is_finite() || !hi.is_finite() {
            return (-1.0, 1.0);
        }
        if self.symmetric {
            let m = lo.abs().max(hi.abs());
            (lo, hi) = (-m, m);
        }
        let pad = ((hi - lo) * 0.05).max(1e-12);
        (lo - pad, hi + pad)
    }
}

/// Draws a time panel with the switch lines and their labels in a band
/// kept free of data above the curves.
pub(crate) fn time_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    t_max: f64,
    sw: &[Switch],
) -> Result<(), String> {
    let (t_min, t_max) = p.x.unwrap_or((0.0, t_max));
    let (lo, hi0) = p.y_range();
    let hi = match sw.len() {
        0 => hi0,
        1 => hi0 + (hi0 - lo) * 0.16,
        _ => hi0 + (hi0 - lo) * 0.26,
    };
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, ("sans-serif", 19))
        .margin_left(10)
        .margin_right(25)
        .margin_top(6)
        .margin_bottom(4)
        .x_label_area_size(42)
        .y_label_area_size(95)
        .build_cartesian_2d(t_min..t_max, lo..hi)
        .map_err(s)?;
    let span = hi - lo;
    let yf = p.y_fmt;
    // At most one time label per 85 px of the plot: five-digit seconds in a
    // panel a third of a figure wide ran together at plotters' default ten.
    let (w, _) = area.dim_in_pixel();
    let x_labels = (w.saturating_sub(95 + 35) / 85).clamp(2, 10) as usize;
    chart
        .configure_mesh()
        .x_labels(x_labels)
        .x_desc("t (s)")
        .y_desc(p.y_desc.as_deref().unwrap_or(""))
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| yf.map_or_else(|| tick(*v, span), |f| f(*v)))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(s)?;
    for (h, c) in &p.hlines {
        chart
            .draw_series(LineSeries::new(
                [(t_min, *h), (t_max, *h)],
                c.stroke_width(1),
            ))
            .map_err(s)?;
    }
    for (b, c) in &p.bands {
        let pts: Vec<(f64, f64, f64)> = drawn(b, p.picked)
            .filter(|x| x.1.is_finite() && x.2.is_finite())
            .collect();
        let poly: Vec<(f64, f64)> = pts
            .iter()
            .map(|x| (x.0, x.2.min(hi0)))
            .chain(pts.iter().rev().map(|x| (x.0, x.1.max(lo))))
            .collect();
        if poly.len() > 2 {
            chart
                .draw_series(std::iter::once(Polygon::new(poly, c.mix(0.18).filled())))
                .map_err(s)?;
            for k in [1, 2] {
                chart
                    .draw_series(LineSeries::new(
                        pts.iter()
                            .map(|x| (x.0, if k == 1 { x.1.max(lo) } else { x.2.min(hi0) })),
                        c.mix(0.5).stroke_width(1),
                    ))
                    .map_err(s)?;
            }
        }
    }
    for (l, c, w) in &p.lines {
        chart
            .draw_series(LineSeries::new(
                drawn(l, p.picked).filter(|x| x.1.is_finite()),
                c.stroke_width(*w),
            ))
            .map_err(s)?;
    }
    for (d, c) in &p.dots {
        chart
            .draw_series(
                drawn(d, p.picked)
                    .filter(|x| x.1.is_finite())
                    .map(|x| Circle::new(x, 2, c.filled())),
            )
            .map_err(s)?;
    }
    for (d, c) in &p.crosses {
        chart
            .draw_series(
                d.iter()
                    .filter(|x| x.1.is_finite())
                    .map(|x| Cross::new(*x, 5, c.stroke_width(2))),
            )
            .map_err(s)?;
    }
    for (d, c) in &p.crosses_on_disk {
        d(&mut |chunk| {
            chart
                .draw_series(
                    chunk
                        .iter()
                        .filter(|x| x.1.is_finite())
                        .map(|x| Cross::new(*x, 5, c.stroke_width(2))),
                )
                .map(|_| ())
                .map_err(s)
        })?;
    }
    for (k, w) in sw.iter().enumerate() {
        chart
            .draw_series(LineSeries::new(
                [(w.t_s, lo), (w.t_s, hi)],
                BLACK.mix(0.6).stroke_width(2),
            ))
            .map_err(s)?;
        // Right of the line, or left of it near the right edge; successive
        // labels alternate between two rows so that close switches stay legible.
        let width = 9 * w.label.chars().count() as i32;
        let dx = if w.t_s > t_min + 0.8 * (t_max - t_min) {
            -width - 6
        } else {
            6
        };
        let dy = if k % 2 == 0 { 4 } else { 22 };
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((w.t_s, hi))
                    + Text::new(w.label.clone(), (dx, dy), ("sans-serif", 16).into_font()),
            ))
            .map_err(s)?;
    }
    Ok(())
}

/// Splits the figure into a title, the panel column and the legend strip.
pub(crate) fn layout<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<(Area<DB>, Area<DB>), String> {
    let root = root
        .margin(6, 0, 0, 0)
        .titled(title, ("sans-serif", 24))
        .map_err(s)?;
    let (w, _) = root.dim_in_pixel();
    let (main, side) = root.split_horizontally(w.saturating_sub(LEGEND_W));
    Ok((main, side))
}

pub(crate) fn switch_notes(sw: &[Switch]) -> Vec<String> {
    sw.iter()
        .map(|w| format!("switch {} at t = {:.1} s", w.label, w.t_s))
        .collect()
}

/// An error figure of the first run: three components (channels of
/// [`crate::figures::error_components`]) with their ±3σ.
fn error_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
    title: &str,
    comps: [(&str, usize); 3],
    notes: &[&str],
) -> Result<(), String> {
    let (main, side) = layout(root, title)?;
    let tm = inp.t_max;
    for (k, (area, (name, ch))) in main.split_evenly((3, 1)).iter().zip(comps).enumerate() {
        let c = AXIS_COLORS[k];
        let e = &inp.errors[ch];
        let rms = (e.sum_sq / e.n_err.max(1) as f64).sqrt();
        let p = Panel {
            title: format!(
                "{name}   (RMS {}, inside ±3σ {:.1} %)",
                tick(rms, rms),
                100.0 * e.inside as f64 / e.n_band.max(1) as f64
            ),
            bands: vec![(e.band.clone(), c)],
            lines: vec![(e.err.pts.clone(), c, 2)],
            hlines: vec![(0.0, GREY)],
            symmetric: true,
            picked: true,
            extent: Some(e.err.extent),
            band_q99: Some(e.band_q99),
            ..Default::default()
        };
        time_panel(area, &p, tm, sw)?;
    }
    let mut n: Vec<String> = notes.iter().map(|x| (*x).to_owned()).collect();
    n.extend(switch_notes(sw));
    if inp.labels.len() > 1 {
        n.push("the compare run is drawn in compare_difference".into());
    }
    legend(
        &side,
        &inp.labels[0],
        &[
            ("error (solution − truth)".into(), Mark::Line(BLUE, 2)),
            ("±3σ of the solution".into(), Mark::Band(BLUE)),
            ("frame switch".into(), Mark::Switch),
        ],
        &n,
    )
}

fn position_errors<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    error_figure(
        root,
        inp,
        sw,
        "Position error against truth (m), local east/north/up",
        [("east (m)", 0), ("north (m)", 1), ("up (m)", 2)],
        &["errors and σ both in the local geographic east/north/up axes of the truth position"],
    )
}

fn velocity_errors<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    error_figure(
        root,
        inp,
        sw,
        "Velocity error against truth (m/s), navigation-frame axes",
        [
            ("nav x: east in g, grid east in G (m/s)", 3),
            ("nav y: north in g, grid north in G (m/s)", 4),
            ("up (m/s)", 5),
        ],
        &[
            "the error is projected on the axes of the frame in use (those of the σ columns): at a switch x/y turn by the grid angle, so the curves may step there while the error itself does not",
        ],
    )
}

fn attitude_errors<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    error_figure(
        root,
        inp,
        sw,
        "Attitude error φ against truth (arcmin): tilt about nav x / nav y, heading about up",
        [
            ("tilt about nav x: east in g, grid east in G (arcmin)", 6),
            ("tilt about nav y: north in g, grid north in G (arcmin)", 7),
            ("heading, about up (arcmin)", 8),
        ],
        &[
            "φ from the body→ECEF quaternions (C = (I − φ×) C_true), projected on the axes of the frame in use, those of the σ columns; up is the same axis in g and G",
        ],
    )
}

fn biases<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    let (main, side) = layout(
        root,
        if inp.bias_sigma_any {
            "IMU bias estimates with ±3σ against the simulated truth, body axes"
        } else {
            "IMU bias estimates against the simulated truth, body axes"
        },
    )?;
    let tm = inp.t_max;
    let panels = main.split_evenly((2, 3));
    let mut with_sigma = false;
    let mut inside = Vec::new();
    for (k, area) in panels.iter().enumerate() {
        let (i, gyro) = (k % 3, k < 3);
        let axis = ["x", "y", "z"][i];
        let est: Vec<(f64, f64)> = inp.bias_rows.iter().map(|(t, b)| (*t, b[k])).collect();
        let truth = &inp.truth_bias[k];
        // ±3σ of the estimate, where the solution carries the bias σ.
        let band = figures::bias_band(inp, k);
        with_sigma |= !band.is_empty();
        if let Some(f) = inp.truth_bias_inside[k] {
            inside.push(format!(
                "{} {axis} {:.0} %",
                if gyro { "gyro" } else { "accel" },
                100.0 * f
            ));
        }
        let last = est.last().map_or(f64::NAN, |p| p.1);
        let last_truth = inp.truth_bias_last[k];
        // Every estimate drawn is in memory: its extent, and its points as
        // `decimate` picks them, beside the truth's of every record.
        let (lo, hi) = est
            .iter()
            .map(|p| p.1)
            .filter(|v| v.is_finite())
            .fold(truth.extent, |(a, b), v| (a.min(v), b.max(v)));
        let p = Panel {
            title: format!(
                "{} {axis} ({})   end: est {} / true {}",
                if gyro { "gyro" } else { "accel" },
                if gyro { "°/h" } else { "µg" },
                tick(last, last.abs().max(last_truth.abs())),
                tick(last_truth, last.abs().max(last_truth.abs()))
            ),
            bands: if band.is_empty() {
                Vec::new()
            } else {
                vec![(decimate(&band).collect(), AXIS_COLORS[i])]
            },
            lines: vec![
                (truth.pts.clone(), BLACK, 2),
                (decimate(&est).collect(), AXIS_COLORS[i], 2),
            ],
            hlines: vec![(0.0, GREY)],
            picked: true,
            extent: Some((lo, hi)),
            ..Default::default()
        };
        time_panel(area, &p, tm, sw)?;
    }
    let mut notes = vec![if with_sigma {
        "±3σ of the estimate from the solution's bias σ (sig_bg_*_rps, sig_ba_*_mps2)".to_owned()
    } else {
        format!(
            "no σ band: the solution has no bias σ (columns {}; written by solution version 3 and later)",
            crate::solution_file::BIAS_SIGMA_COLUMNS.join(", ")
        )
    }];
    if !inside.is_empty() {
        notes.push(format!(
            "true bias inside ±3σ (share of the truth epochs): {}",
            inside.join(", ")
        ));
    }
    if inp.truth_bias_n == 0 {
        notes.push("no truth: the log has no truth-bias records (simulate writes them)".into());
    }
    notes.extend(switch_notes(sw));
    let mut entries = vec![
        ("estimate x / y / z".to_owned(), Mark::Line(BLUE, 2)),
        (
            "true bias (simulator: constant draw + Gauss–Markov)".into(),
            Mark::Line(BLACK, 2),
        ),
    ];
    if with_sigma {
        entries.push(("±3σ of the estimate".into(), Mark::Band(BLUE)));
    }
    entries.push(("frame switch".into(), Mark::Switch));
    legend(&side, &inp.labels[0], &entries, &notes)
}

/// The points `keep` makes of the updates of `pts`, handed over in chunks
/// when drawn (read from disk each time).
fn aid_chunks(
    pts: &UpdatesOnDisk,
    keep: impl Fn(&AidPoint, &mut Vec<(f64, f64)>) + 'static,
) -> OnDisk {
    let pts = pts.clone();
    Box::new(move |f| {
        let mut chunk = Vec::with_capacity(4096);
        let mut failed = None;
        for_each_update(&pts, |a| {
            if failed.is_some() {
                return;
            }
            keep(&a, &mut chunk);
            if chunk.len() >= 4096 {
                failed = f(&chunk).err();
                chunk.clear();
            }
        })
        .map_err(s)?;
        if let Some(e) = failed {
            return Err(e);
        }
        f(&chunk)
    })
}

fn innovations<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    let Some(aids) = &inp.aids else {
        return Ok(());
    };
    let (main, side) = layout(
        root,
        "Aid innovations normalized by √(innovation variance), and test ratios against the gate",
    )?;
    let tm = inp.t_max;
    // A row per aid that had updates in this run.
    let set: Vec<(&str, &UpdatesOnDisk, Vec<&str>)> = aids
        .iter()
        .filter(|(_, pts)| !pts.is_empty())
        .map(|(k, pts)| {
            let comps = k
                .decl()
                .components
                .iter()
                .take(3)
                .map(|c| c.label)
                .collect();
            (k.decl().title, pts, comps)
        })
        .collect();
    if set.is_empty() {
        return Ok(());
    }
    let cells = main.split_evenly((set.len(), 2));
    const CLIP: f64 = 6.0;
    // Test ratio on a log axis: log10 drawn, labelled in ratio units.
    const FLOOR: f64 = -3.0;
    let tr = |a: &AidPoint| (a.t_ns as f64 * 1e-9, a.test_ratio.log10().max(FLOOR));
    for (k, (name, pts, comps)) in set.iter().enumerate() {
        // Counts first: which points a curve keeps depends on its length.
        let (mut fused, mut per_comp, mut clipped, mut hi) = (0u64, [0u64; 3], 0, 0.5f64);
        for_each_update(pts, |a| {
            hi = hi.max(tr(&a).1);
            if a.fused == 0 {
                return;
            }
            fused += 1;
            for (c, n) in per_comp.iter_mut().enumerate().take(comps.len()) {
                if let Some(v) = a.normalized(c) {
                    *n += 1;
                    clipped += usize::from(v.abs() > CLIP);
                }
            }
        })
        .map_err(s)?;
        let rejected = pts.len() - fused;
        let steps = per_comp.map(figures::step_of);
        let fused_step = figures::step_of(fused);
        let mut dots: [Vec<(f64, f64)>; 3] = Default::default();
        let mut fused_pts = Vec::new();
        let (mut seen, mut seen_fused) = ([0u64; 3], 0u64);
        for_each_update(pts, |a| {
            if a.fused == 0 {
                return;
            }
            let t = a.t_ns as f64 * 1e-9;
            for c in 0..comps.len() {
                if let Some(v) = a.normalized(c) {
                    if seen[c].is_multiple_of(steps[c]) {
                        dots[c].push((t, v.clamp(-CLIP * 0.97, CLIP * 0.97)));
                    }
                    seen[c] += 1;
                }
            }
            if seen_fused.is_multiple_of(fused_step) {
                fused_pts.push(tr(&a));
            }
            seen_fused += 1;
        })
        .map_err(s)?;
        let mut p = Panel {
            title: format!("{name}: innovation / σ (unit-free), {} updates", pts.len()),
            hlines: vec![(3.0, GREY), (-3.0, GREY), (0.0, GREY)],
            y: Some((-CLIP, CLIP)),
            picked: true,
            ..Default::default()
        };
        for (c, _) in comps.iter().enumerate() {
            p.dots.push((std::mem::take(&mut dots[c]), AXIS_COLORS[c]));
        }
        let n = comps.len();
        p.crosses_on_disk.push((
            aid_chunks(pts, move |a, out| {
                if a.fused == 0 {
                    let t = a.t_ns as f64 * 1e-9;
                    out.extend(
                        (0..n)
                            .filter_map(|c| a.normalized(c))
                            .map(|v| (t, v.clamp(-CLIP * 0.97, CLIP * 0.97))),
                    );
                }
            }),
            RED_,
        ));
        if clipped > 0 {
            p.title
                .push_str(&format!(", {clipped} beyond ±{CLIP} drawn at the edge"));
        }
        time_panel(&cells[2 * k], &p, tm, sw)?;
        let q = Panel {
            title: format!(
                "{name}: test ratio (log scale, < 0.001 drawn at 0.001), fused {fused}, rejected {rejected}"
            ),
            dots: vec![(fused_pts, BLACK)],
            crosses_on_disk: vec![(
                aid_chunks(pts, move |a, out| {
                    if a.fused == 0 {
                        out.push(tr(a));
                    }
                }),
                RED_,
            )],
            hlines: vec![(0.0, RED_)],
            y: Some((FLOOR - 0.15, hi.max(1.0) + 0.15)),
            y_fmt: Some(|v| {
                let x = 10f64.powf(v);
                if x >= 1.0 {
                    format!("{x:.0}")
                } else {
                    let d = (-x.log10()).ceil().max(1.0) as usize;
                    format!("{x:.d$}")
                }
            }),
            picked: true,
            ..Default::default()
        };
        time_panel(&cells[2 * k + 1], &q, tm, sw)?;
    }
    let mut notes = vec![
        "innovation / σ: each component over the square root of its variance; ±3 grey".to_owned(),
        "test ratio: normalized innovation squared over the gate; above 1 rejected".to_owned(),
        "CNS components: Δlatitude, Δlongitude in g; grid x, y position in G".to_owned(),
    ];
    notes.extend(switch_notes(sw));
    legend(
        &side,
        &inp.labels[0],
        &[
            ("component x / lat / h".into(), Mark::Dot(BLUE)),
            ("component y / lon".into(), Mark::Dot(ORANGE)),
            ("component z".into(), Mark::Dot(GREEN)),
            ("test ratio of a fused update".into(), Mark::Dot(BLACK)),
            ("rejected at the gate".into(), Mark::Cross(RED_)),
            ("gate (test ratio 1)".into(), Mark::Line(RED_, 1)),
            ("frame switch".into(), Mark::Switch),
        ],
        &notes,
    )
}

fn compare_difference<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    let (a, b) = (&inp.labels[0], &inp.labels[1]);
    let (main, side) = layout(root, &format!("Difference {b} − {a} (same truth epochs)"))?;
    let tm = inp.t_max;
    let names: [&str; 5] = [
        "east position (m)",
        "north position (m)",
        "up position (m)",
        "velocity, magnitude of the difference (m/s)",
        "heading, about up (arcmin)",
    ];
    for (k, (area, name)) in main.split_evenly((5, 1)).iter().zip(names).enumerate() {
        let v = &inp.compare[k];
        let mx = inp.compare_max[k];
        let p = Panel {
            title: format!("{name}   max |Δ| {}", tick(mx, mx)),
            lines: vec![(v.pts.clone(), AXIS_COLORS[k % 3], 2)],
            hlines: vec![(0.0, GREY)],
            symmetric: k != 3,
            picked: true,
            extent: Some(v.extent),
            ..Default::default()
        };
        time_panel(area, &p, tm, sw)?;
    }
    let mut notes = vec![format!(
        "{} epochs in both runs; differences of the errors against truth, i.e. of the solutions themselves",
        inp.compare_n
    )];
    notes.extend(switch_notes(sw));
    legend(
        &side,
        "compare − solution",
        &[
            (format!("{b} − {a}"), Mark::Line(BLUE, 2)),
            (format!("frame switch of {a}"), Mark::Switch),
        ],
        &notes,
    )
}

fn cumulative_rmse<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    let (main, side) = layout(root, "Cumulative horizontal position RMSE (m)")?;
    let curves: Vec<Line> = inp
        .cumulative
        .iter()
        .enumerate()
        .map(|(k, c)| (c.pts.clone(), [BLUE, ORANGE][k % 2], 2))
        .collect();
    let hi = inp.cumulative_hi;
    let p = Panel {
        title: "√(mean of horizontal error² from the start) (m)".into(),
        lines: curves,
        y: Some((0.0, hi * 1.05)),
        picked: true,
        ..Default::default()
    };
    time_panel(&main, &p, inp.t_max, sw)?;
    let entries: Vec<(String, Mark)> = inp
        .labels
        .iter()
        .enumerate()
        .map(|(k, r)| (r.clone(), Mark::Line([BLUE, ORANGE][k % 2], 2)))
        .chain(std::iter::once(("frame switch".to_owned(), Mark::Switch)))
        .collect();
    legend(&side, "runs", &entries, &switch_notes(sw))
}

/// Polar stereographic projection about the pole of the flight's hemisphere
/// (km; spherical, radius 6371 km): well defined across the pole.
fn stereo(r_e: &[f64; 3], north: bool) -> (f64, f64) {
    let g = polarnav::earth::ecef_to_geodetic(&nalgebra::Vector3::from(*r_e));
    let colat = if north {
        std::f64::consts::FRAC_PI_2 - g.lat_rad
    } else {
        std::f64::consts::FRAC_PI_2 + g.lat_rad
    };
    let rho = 2.0 * 6371.0 * (colat / 2.0).tan();
    let (sl, cl) = g.lon_rad.sin_cos();
    if north {
        (rho * sl, -rho * cl)
    } else {
        (rho * sl, rho * cl)
    }
}

fn track<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    inp: &FigureData,
    sw: &[Switch],
) -> Result<(), String> {
    if inp.rows_n == 0 {
        return Ok(());
    }
    let north = inp.middle_lat_deg >= 0.0;
    let (main, side) = layout(
        root,
        &format!(
            "Track, polar stereographic about the {} Pole (km)",
            if north { "North" } else { "South" }
        ),
    )?;
    let sol: Vec<(f64, f64)> = inp.track.iter().map(|r| stereo(r, north)).collect();
    let truth: Vec<(f64, f64)> = inp.track_truth.iter().map(|t| stereo(t, north)).collect();
    let cmp: Vec<(f64, f64)> = inp
        .track_compare
        .as_ref()
        .map(|r| r.iter().map(|x| stereo(x, north)).collect())
        .unwrap_or_default();
    let all = || truth.iter().chain(&sol).chain(&cmp);
    let (mut x0, mut x1, mut y0, mut y1) = all().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |a, p| (a.0.min(p.0), a.1.max(p.0), a.2.min(p.1), a.3.max(p.1)),
    );
    // Show the pole when it is within one track extent.
    let ext = (x1 - x0).max(y1 - y0).max(1.0);
    let pole_shown = x0 - ext < 0.0 && x1 + ext > 0.0 && y0 - ext < 0.0 && y1 + ext > 0.0;
    if pole_shown {
        (x0, x1, y0, y1) = (x0.min(0.0), x1.max(0.0), y0.min(0.0), y1.max(0.0));
    }
    let half = (x1 - x0).max(y1 - y0) / 2.0 * 1.12 + 1.0;
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    // Below the map, one panel per run with its horizontal distance from
    // the truth: at the map's scale the runs lie within a pixel of each
    // other and of the truth, so the map alone hides a compared (reference)
    // run under the solution; one panel each, since at the metre scale
    // they still coincide except around the switches.
    let distances: Vec<(&str, Line)> = inp
        .distance
        .iter()
        .take(2)
        .enumerate()
        .filter(|(_, d)| !d.is_empty())
        .map(|(k, d)| (inp.labels[k].as_str(), (d.clone(), [BLUE, ORANGE][k], 1)))
        .collect();
    let (w, h) = main.dim_in_pixel();
    let panel_px = TRACK_PANEL_PX * distances.len() as u32;
    let side_px = w.min(h.saturating_sub(panel_px));
    let (map_row, below) = main.split_vertically(side_px);
    let (square, _) = map_row.split_horizontally(side_px);
    let mut chart = ChartBuilder::on(&square)
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d((cx - half)..(cx + half), (cy - half)..(cy + half))
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc("x (km), toward 90°E")
        .y_desc(if north {
            "y (km), toward 180°"
        } else {
            "y (km), toward 0°"
        })
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
        .bold_line_style(BLACK.mix(0.08))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(s)?;
    chart
        .draw_series(LineSeries::new(
            truth.iter().copied(),
            BLACK.mix(0.35).stroke_width(TRUTH_TRACK_W),
        ))
        .map_err(s)?;
    if !cmp.is_empty() {
        chart
            .draw_series(LineSeries::new(
                cmp.iter().copied(),
                ORANGE.stroke_width(COMPARE_TRACK_W),
            ))
            .map_err(s)?;
    }
    chart
        .draw_series(LineSeries::new(sol.iter().copied(), BLUE.stroke_width(2)))
        .map_err(s)?;
    let font = ("sans-serif", 17).into_font();
    if pole_shown {
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((0.0, 0.0))
                    + Cross::new((0, 0), 8, BLACK.stroke_width(2))
                    + Text::new("pole", (10, 4), font.clone()),
            ))
            .map_err(s)?;
    }
    if let (Some(a), Some(b)) = (sol.first(), sol.last()) {
        chart
            .draw_series(std::iter::once(
                EmptyElement::at(*a)
                    + Circle::new((0, 0), 9, GREEN.filled())
                    + Text::new("start", (12, -22), font.clone()),
            ))
            .map_err(s)?;
        chart
            .draw_series(std::iter::once(
                EmptyElement::at(*b)
                    + Rectangle::new([(-8, -8), (8, 8)], RED_.filled())
                    + Text::new("end", (12, -22), font.clone()),
            ))
            .map_err(s)?;
    }
    chart
        .draw_series(sw.iter().map(|w| {
            EmptyElement::at(stereo(&w.r_e_m, north))
                + TriangleMarker::new((0, 0), 11, BLACK.filled())
                + Text::new(
                    format!("{} t={:.0} s", w.label, w.t_s),
                    (14, 4),
                    font.clone(),
                )
        }))
        .map_err(s)?;
    let hmax = inp.hmax;
    if !distances.is_empty() {
        // One y range for all, so that the panels compare at a glance.
        let hi = distances
            .iter()
            .flat_map(|(_, l)| l.0.iter().map(|p| p.1))
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let areas = below.split_evenly((distances.len(), 1));
        for (area, (label, line)) in areas.iter().zip(distances) {
            let p = Panel {
                title: format!("{label}: horizontal distance from the truth (m)"),
                lines: vec![line],
                hlines: vec![(0.0, GREY)],
                y: Some((0.0, hi.max(1e-3) * 1.05)),
                y_desc: Some("distance (m)".into()),
                picked: true,
                ..Default::default()
            };
            time_panel(area, &p, inp.t_max, sw)?;
        }
    }
    let mut notes = vec![
        format!(
            "the solution's horizontal error (max {} m) is far below a pixel on the map: the panels below it draw each run's distance from the truth",
            tick(hmax, hmax)
        ),
        "spherical polar stereographic projection (R = 6371 km), valid across the pole".to_owned(),
    ];
    notes.extend(switch_notes(sw));
    let mut entries = vec![
        ("truth".to_owned(), Mark::Line(GREY, TRUTH_TRACK_W)),
        (inp.labels[0].clone(), Mark::Line(BLUE, 2)),
    ];
    if let Some(r) = inp.labels.get(1) {
        entries.push((r.clone(), Mark::Line(ORANGE, COMPARE_TRACK_W)));
        notes.insert(
            1,
            format!("{r} is drawn wider, under the solution: where the two coincide it is the orange rim"),
        );
    }
    entries.push(("start".into(), Mark::Dot(GREEN)));
    entries.push(("end".into(), Mark::Square(RED_)));
    entries.push((
        "frame switch (position of the solution)".into(),
        Mark::Triangle,
    ));
    legend(&side, "track", &entries, &notes)
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
                vel_nav: Vector3::new(0.01, 0.0, 0.0),
                att_nav: Vector3::new(0.0, 0.0, 1e-4),
                frame: r.frame,
            })
            .collect();
        let dir = std::env::temp_dir().join(format!("polarnav-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let runs = [Series {
            label: "run",
            rows: &rows,
            epochs: &epochs,
        }];
        let files = write_all(
            &dir,
            &Inputs {
                runs: &runs,
                truth: &[],
                truth_bias: &[],
                aids: None,
            },
        )
        .expect("plots");
        // No aid updates (CSV solution), no compare run: no innovations, no difference.
        assert_eq!(files.len(), 6);
        for f in files.iter().map(|f| &f.path) {
            let bytes = std::fs::read(f).expect("read");
            let png = bytes.starts_with(b"\x89PNG");
            let svg = bytes.starts_with(b"<svg");
            assert!(png || svg, "{} is neither PNG nor SVG", f.display());
            assert!(bytes.len() > 5_000, "{} is suspiciously small", f.display());
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
