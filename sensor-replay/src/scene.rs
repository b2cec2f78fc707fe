//! `sensor-replay scene`: the 3D panel's top-down view of a polarnav MCAP
//! file's polar frame, drawn from the file's own messages (`/track`
//! scene entities, `/solution/pose` transforms), for where Foxglove cannot
//! run. It is the view the layout `config/foxglove/polar-layout.json` opens
//! on: orthographic, looking down the polar frame's z axis, x to the right.

use std::collections::HashMap;
use std::path::Path;

use foxglove::messages::{FrameTransform, SceneUpdate};
use plotters::prelude::*;
use prost::Message;

/// A polyline of a scene entity (km), its colour (RGB), whether closed.
#[derive(Debug, Clone)]
pub struct Line {
    pub points: Vec<(f64, f64)>,
    pub rgb: (u8, u8, u8),
    pub closed: bool,
}

/// What the view draws, in the frame `frame` (km).
#[derive(Debug, Default)]
pub struct Scene {
    pub frame: String,
    /// Polylines.
    pub lines: Vec<Line>,
    /// Labelled markers (a dot and its name).
    pub markers: Vec<((f64, f64), String)>,
    /// Labels alone (the names of lines).
    pub labels: Vec<((f64, f64), String)>,
    /// Aircraft poses: position and the body's forward axis (y) in the frame.
    pub poses: Vec<((f64, f64), (f64, f64))>,
}

/// Reads the scene of `frame` (e.g. `polar_north`) from `mcap`.
pub fn read(mcap: &Path, frame: &str) -> Result<Scene, String> {
    let p = mcap.display();
    let mut scene = Scene {
        frame: frame.to_owned(),
        ..Default::default()
    };
    // Entities replace earlier ones of the same id, as in the panel.
    let mut entities: HashMap<String, usize> = HashMap::new();
    let mut all_poses = Vec::new();
    polarnav_eval::solution_file::for_each_message(mcap, |m| {
        let (data, sequence) = (m.data, m.sequence);
        match m.topic {
            "/track" => {
                let u = SceneUpdate::decode(data)
                    .map_err(|e| format!("{p}: /track message {sequence}: {e}"))?;
                for e in u.entities.into_iter().filter(|e| e.frame_id == frame) {
                    let lines: Vec<Line> = e
                        .lines
                        .iter()
                        .map(|l| {
                            let c = l.color.unwrap_or_default();
                            Line {
                                points: l.points.iter().map(|q| (q.x / 1e3, q.y / 1e3)).collect(),
                                rgb: (
                                    (c.r * 255.0) as u8,
                                    (c.g * 255.0) as u8,
                                    (c.b * 255.0) as u8,
                                ),
                                closed: l.r#type == 1,
                            }
                        })
                        .collect();
                    for s in &e.spheres {
                        if let Some(pos) = s.pose.as_ref().and_then(|p| p.position.as_ref()) {
                            let name = e.texts.first().map_or(e.id.clone(), |t| t.text.clone());
                            scene.markers.push(((pos.x / 1e3, pos.y / 1e3), name));
                        }
                    }
                    if e.spheres.is_empty() {
                        for t in &e.texts {
                            if let Some(pos) = t.pose.as_ref().and_then(|p| p.position.as_ref()) {
                                scene
                                    .labels
                                    .push(((pos.x / 1e3, pos.y / 1e3), t.text.clone()));
                            }
                        }
                    }
                    match entities.get(&e.id) {
                        Some(&k) => {
                            for (i, l) in lines.into_iter().enumerate() {
                                if let Some(slot) = scene.lines.get_mut(k + i) {
                                    *slot = l;
                                }
                            }
                        }
                        None => {
                            entities.insert(e.id.clone(), scene.lines.len());
                            scene.lines.extend(lines);
                        }
                    }
                }
            }
            "/solution/pose" => {
                let t = FrameTransform::decode(data)
                    .map_err(|e| format!("{p}: /solution/pose message {sequence}: {e}"))?;
                if t.parent_frame_id == frame
                    && let (Some(tr), Some(q)) = (t.translation, t.rotation)
                {
                    // The body's y axis (forward) in the frame: R ŷ.
                    let (w, x, y, z) = (q.w, q.x, q.y, q.z);
                    let fwd = (2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z));
                    all_poses.push(((tr.x / 1e3, tr.y / 1e3), fwd));
                }
            }
            _ => {}
        }
        Ok(())
    })?;
    if scene.lines.is_empty() && all_poses.is_empty() && scene.markers.is_empty() {
        return Err(format!(
            "{p}: nothing in frame {frame} (no /track entity, no /solution/pose)"
        ));
    }
    // A dozen aircraft along the flight, the last one included.
    let step = (all_poses.len() / 12).max(1);
    scene.poses = all_poses.iter().step_by(step).copied().collect();
    scene.poses.extend(all_poses.last().copied());
    for v in [&mut scene.markers, &mut scene.labels] {
        v.sort_by(|a, b| a.1.cmp(&b.1));
        v.dedup_by(|a, b| a.1 == b.1);
    }
    Ok(scene)
}

/// Draws `scene` to `out` (PNG), 1200 × 1200 pixels.
pub fn draw(scene: &Scene, title: &str, out: &Path) -> Result<(), String> {
    polarnav_eval::plots::init_fonts();
    let e = |x: &dyn std::fmt::Display| format!("{}: {x}", out.display());
    let root = BitMapBackend::new(out, (1200, 1200)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    // Equal scales: a square around everything drawn.
    let pts = scene
        .lines
        .iter()
        .flat_map(|l| l.points.iter().copied())
        .chain(scene.poses.iter().map(|p| p.0))
        .chain(scene.markers.iter().map(|m| m.0));
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let half = ((x1 - x0).max(y1 - y0) / 2.0 * 1.1).max(10.0);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d((cx - half)..(cx + half), (cy - half)..(cy + half))
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc(format!("x of {} (km): towards 0° E", scene.frame))
        .y_desc(format!(
            "y of {} (km): towards {}",
            scene.frame,
            if scene.frame.ends_with("south") {
                "90° W"
            } else {
                "90° E"
            }
        ))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|x| e(&x))?;
    for l in &scene.lines {
        let mut v = l.points.clone();
        if l.closed
            && let Some(f) = l.points.first()
        {
            v.push(*f);
        }
        let (r, g, b) = l.rgb;
        chart
            .draw_series(LineSeries::new(v, RGBColor(r, g, b).stroke_width(2)))
            .map_err(|x| e(&x))?;
    }
    let arrow = half * 0.04;
    for ((x, y), (fx, fy)) in &scene.poses {
        let n = (fx * fx + fy * fy).sqrt().max(1e-9);
        let tip = (x + arrow * fx / n, y + arrow * fy / n);
        chart
            .draw_series([PathElement::new(vec![(*x, *y), tip], BLACK.stroke_width(3))])
            .map_err(|x| e(&x))?;
        chart
            .draw_series([Circle::new((*x, *y), 4, BLACK.filled())])
            .map_err(|x| e(&x))?;
    }
    for ((x, y), name) in &scene.markers {
        chart
            .draw_series([Circle::new((*x, *y), 6, RGBColor(200, 30, 30).filled())])
            .map_err(|x| e(&x))?;
        chart
            .draw_series([Text::new(
                name.clone(),
                (*x, *y),
                ("sans-serif", 18).into_font(),
            )])
            .map_err(|x| e(&x))?;
    }
    for ((x, y), name) in &scene.labels {
        chart
            .draw_series([Text::new(
                name.clone(),
                (*x, *y),
                ("sans-serif", 18).into_font().color(&RGBColor(200, 120, 0)),
            )])
            .map_err(|x| e(&x))?;
    }
    root.present().map_err(|x| e(&x))?;
    Ok(())
}
