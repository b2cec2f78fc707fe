//! A scene the 3D panel can follow at the pole, where Foxglove's Map panel
//! (Web Mercator, nothing above 85.05°) shows nothing.
//!
//! Frames (every transform a `foxglove.FrameTransform`, parent → child, a
//! point of the child frame p_c lying at R p_c + t in the parent):
//!
//! - `ecef` → `polar_north` and `ecef` → `polar_south` (`/tf/polar`): the
//!   plane tangent to the WGS-84 ellipsoid at each pole, origin at the
//!   pole, z up (away from the Earth), x along the 0° meridian, y along 90° E
//!   at the North Pole and 90° W at the South Pole (so that x, y, z is right
//!   handed and x, y is the usual polar stereographic grid's orientation).
//!   Metres. Near the pole x, y are the polar stereographic coordinates to
//!   first order; they are not a projection but the same rigid frame the
//!   body lives in, so the scene is consistent in 3D.
//! - `polar_north|south` → `body` (`/solution/pose`): position and attitude
//!   of the solution, relative to the nearer pole's frame.
//! - `polar_north|south` → `nav` (`/solution/nav_frame`): the navigation frame of
//!   the moment, local east-north-up (g) or grid (G), at the aircraft.
//!
//! `/track` (`foxglove.SceneUpdate`, in the nearer pole's frame): the pole
//! (a sphere and its name), the circle of each latitude where a frame
//! switch happened, and the solution's and the truth's tracks, one point
//! per [`TRACK_POINT_NS`] of sensor time, in segments of
//! [`TRACK_SEGMENT_POINTS`] points that accumulate (a flight of a day is a
//! few thousand small messages, not one growing line).

use foxglove::messages::{
    Color, FrameTransform, LinePrimitive, Point3, Pose, Quaternion, SceneEntity, SceneUpdate,
    SpherePrimitive, TextPrimitive, Timestamp, Vector3,
};
use msgs::{Solution, TruthRecord, WireFrame};
use nalgebra::UnitQuaternion;
use polarnav::earth;
use polarnav::frames;

/// One track point per this much sensor time (1 s).
pub const TRACK_POINT_NS: u64 = 1_000_000_000;
/// Points per track segment (a minute at one point a second).
pub const TRACK_SEGMENT_POINTS: usize = 60;

/// The pole whose tangent frame a position is drawn in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pole {
    /// The North Pole (frame `polar_north`).
    North,
    /// The South Pole (frame `polar_south`).
    South,
}

impl Pole {
    /// The nearer pole of a latitude (the equator counts as north).
    pub fn nearer(lat_rad: f64) -> Self {
        if lat_rad < 0.0 {
            Pole::South
        } else {
            Pole::North
        }
    }

    /// The frame's name.
    pub fn frame_id(self) -> &'static str {
        match self {
            Pole::North => "polar_north",
            Pole::South => "polar_south",
        }
    }

    /// The origin (the pole on the ellipsoid), ECEF (m).
    pub fn origin_e(self) -> [f64; 3] {
        match self {
            Pole::North => [0.0, 0.0, earth::B],
            Pole::South => [0.0, 0.0, -earth::B],
        }
    }

    /// The rotation from ECEF axes to this frame's axes, C_e^polar, as a
    /// quaternion (identity at the North Pole, a half turn about x at the
    /// South Pole).
    pub fn q_e_polar(self) -> UnitQuaternion<f64> {
        match self {
            Pole::North => UnitQuaternion::identity(),
            Pole::South => {
                UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), std::f64::consts::PI)
            }
        }
    }

    /// An ECEF point in this frame (m).
    pub fn from_ecef(self, r_e: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = r_e;
        match self {
            Pole::North => [x, y, z - earth::B],
            Pole::South => [x, -y, -(z + earth::B)],
        }
    }
}

fn stamp(t_ns: u64) -> Timestamp {
    let sec = u32::try_from(t_ns / 1_000_000_000).unwrap_or(u32::MAX);
    Timestamp::new(sec, (t_ns % 1_000_000_000) as u32)
}

fn quat(q: &UnitQuaternion<f64>) -> Quaternion {
    Quaternion {
        x: q.i,
        y: q.j,
        z: q.k,
        w: q.w,
    }
}

fn vec3(p: [f64; 3]) -> Vector3 {
    Vector3 {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

fn point(p: [f64; 3]) -> Point3 {
    Point3 {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// The transform `parent` → `child` at `t_ns`.
fn transform(
    t_ns: u64,
    parent: &str,
    child: &str,
    t: [f64; 3],
    q: &UnitQuaternion<f64>,
) -> FrameTransform {
    FrameTransform {
        timestamp: Some(stamp(t_ns)),
        parent_frame_id: parent.into(),
        child_frame_id: child.into(),
        translation: Some(vec3(t)),
        rotation: Some(quat(q)),
    }
}

/// `polar` → `body` of a solution in the nearer pole's frame: the
/// translation is the position in that frame, the rotation C_e^polar C_b^e.
pub fn body_in_polar(s: &Solution) -> (Pole, [f64; 3], UnitQuaternion<f64>) {
    let pole = Pole::nearer(s.lat_rad);
    let [w, x, y, z] = s.q_b_e;
    let q_b_e = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
    (pole, pole.from_ecef(s.r_e_m), pole.q_e_polar() * q_b_e)
}

/// One track being drawn: its points since the last segment was sent.
#[derive(Debug)]
struct Track {
    name: &'static str,
    color: Color,
    pole: Option<Pole>,
    next_ns: u64,
    last_ns: u64,
    points: Vec<Point3>,
    segment: u64,
}

impl Track {
    fn new(name: &'static str, color: Color) -> Self {
        Self {
            name,
            color,
            pole: None,
            next_ns: 0,
            last_ns: 0,
            points: Vec::with_capacity(TRACK_SEGMENT_POINTS + 1),
            segment: 0,
        }
    }

    /// A position at `t_ns`; a segment when one is full or the pole changed.
    fn add(&mut self, t_ns: u64, lat_rad: f64, r_e: [f64; 3]) -> Option<SceneEntity> {
        let pole = Pole::nearer(lat_rad);
        let mut out = None;
        if self.pole.is_some_and(|p| p != pole) {
            out = self.flush(t_ns);
            self.points.clear();
        }
        self.pole = Some(pole);
        if t_ns < self.next_ns && !self.points.is_empty() {
            return out;
        }
        self.next_ns = t_ns.saturating_add(TRACK_POINT_NS);
        self.last_ns = t_ns;
        self.points.push(point(pole.from_ecef(r_e)));
        if self.points.len() > TRACK_SEGMENT_POINTS {
            out = self.flush(t_ns);
            // The next segment starts where this one ended.
            let last = self.points.last().cloned();
            self.points.clear();
            self.points.extend(last);
        }
        out
    }

    /// The points so far as one entity (None with fewer than two).
    fn flush(&mut self, t_ns: u64) -> Option<SceneEntity> {
        let pole = self.pole?;
        if self.points.len() < 2 {
            return None;
        }
        self.segment += 1;
        Some(SceneEntity {
            timestamp: Some(stamp(t_ns)),
            frame_id: pole.frame_id().into(),
            id: format!("{}-{}", self.name, self.segment),
            lines: vec![LinePrimitive {
                // LINE_STRIP
                r#type: 0,
                thickness: 3.0,
                scale_invariant: true,
                points: self.points.clone(),
                color: Some(self.color),
                ..Default::default()
            }],
            ..Default::default()
        })
    }
}

/// `polar` → `body` of a solution as the `/solution/pose` message, stamped `at_ns`.
pub fn pose_message(s: &Solution, at_ns: u64) -> FrameTransform {
    let (pole, t, q) = body_in_polar(s);
    transform(at_ns, pole.frame_id(), "body", t, &q)
}

/// `polar` → `nav` (ENU in g, grid in G, at the aircraft) as the
/// `/solution/nav_frame` message, stamped `at_ns`.
pub fn nav_frame_message(s: &Solution, at_ns: u64) -> FrameTransform {
    let (pole, t, _) = body_in_polar(s);
    let c_e_n = if s.frame == WireFrame::Grid as u8 {
        frames::c_e_grid(s.lat_rad, s.lon_rad)
    } else {
        frames::c_e_g(s.lat_rad, s.lon_rad)
    };
    let q_n_e = frames::quat_from_dcm(&c_e_n.transpose());
    transform(
        at_ns,
        pole.frame_id(),
        "nav",
        t,
        &(pole.q_e_polar() * q_n_e),
    )
}

/// What the scene sends with one input: the static frames (when due) and
/// a scene update (when there is one).
#[derive(Debug, Default)]
pub struct SceneOut {
    /// `ecef` → `polar_north` and `ecef` → `polar_south`, for `/tf/polar`.
    pub statics: Vec<FrameTransform>,
    /// For `/track`.
    pub update: Option<SceneUpdate>,
}

/// The state of the scene of one run: the tracks being drawn, the switch
/// latitudes drawn, when the static frames go out again. It owns no
/// channel: the caller logs what it returns.
#[derive(Debug)]
pub struct PolarScene {
    solution: Track,
    truth: Track,
    /// When the static frames and the poles go out again.
    next_static_ns: Option<u64>,
    switch_latitudes_cdeg: Vec<i64>,
}

/// The static frames and the pole markers are sent again every this much
/// sensor time, so that a player that seeks, or a live client that joins,
/// finds them within it (5 s).
const STATIC_PERIOD_NS: u64 = 5_000_000_000;

impl Default for PolarScene {
    fn default() -> Self {
        Self::new()
    }
}

impl PolarScene {
    /// A scene with nothing drawn yet.
    pub fn new() -> Self {
        Self {
            solution: Track::new(
                "solution",
                Color {
                    r: 0.1,
                    g: 0.45,
                    b: 0.9,
                    a: 1.0,
                },
            ),
            truth: Track::new(
                "truth",
                Color {
                    r: 0.2,
                    g: 0.2,
                    b: 0.2,
                    a: 0.8,
                },
            ),
            next_static_ns: None,
            switch_latitudes_cdeg: Vec::new(),
        }
    }

    /// The static frames and the poles, when due at `at_ns`.
    fn statics(&mut self, at_ns: u64, out: &mut SceneOut, entities: &mut Vec<SceneEntity>) {
        if self.next_static_ns.is_some_and(|n| at_ns < n) {
            return;
        }
        self.next_static_ns = Some(at_ns.saturating_add(STATIC_PERIOD_NS));
        for pole in [Pole::North, Pole::South] {
            out.statics.push(transform(
                at_ns,
                "ecef",
                pole.frame_id(),
                pole.origin_e(),
                &pole.q_e_polar().inverse(),
            ));
            entities.push(SceneEntity {
                timestamp: Some(stamp(at_ns)),
                frame_id: pole.frame_id().into(),
                id: format!("{}-pole", pole.frame_id()),
                spheres: vec![SpherePrimitive {
                    pose: Some(Pose {
                        position: Some(vec3([0.0; 3])),
                        orientation: Some(quat(&UnitQuaternion::identity())),
                    }),
                    size: Some(vec3([20_000.0; 3])),
                    color: Some(Color {
                        r: 0.8,
                        g: 0.1,
                        b: 0.1,
                        a: 1.0,
                    }),
                }],
                texts: vec![TextPrimitive {
                    pose: Some(Pose {
                        position: Some(vec3([0.0, 0.0, 30_000.0])),
                        orientation: Some(quat(&UnitQuaternion::identity())),
                    }),
                    billboard: true,
                    font_size: 14.0,
                    scale_invariant: true,
                    color: Some(Color {
                        r: 0.8,
                        g: 0.1,
                        b: 0.1,
                        a: 1.0,
                    }),
                    text: match pole {
                        Pole::North => "North Pole".into(),
                        Pole::South => "South Pole".into(),
                    },
                }],
                ..Default::default()
            });
        }
    }

    fn finish_out(mut out: SceneOut, entities: Vec<SceneEntity>) -> SceneOut {
        if !entities.is_empty() {
            out.update = Some(SceneUpdate {
                deletions: Vec::new(),
                entities,
            });
        }
        out
    }

    /// A solution at log time `at_ns`: the static frames when due, a track
    /// point, and the circle of its latitude when its frame `switched`.
    pub fn solution(&mut self, s: &Solution, switched: bool, at_ns: u64) -> SceneOut {
        let mut out = SceneOut::default();
        let mut entities = Vec::new();
        self.statics(at_ns, &mut out, &mut entities);
        if switched {
            let cdeg = (s.lat_rad.to_degrees() * 100.0).round() as i64;
            if !self.switch_latitudes_cdeg.contains(&cdeg) {
                self.switch_latitudes_cdeg.push(cdeg);
                entities.push(latitude_circle(
                    at_ns,
                    cdeg,
                    self.switch_latitudes_cdeg.len() - 1,
                ));
            }
        }
        entities.extend(self.solution.add(at_ns, s.lat_rad, s.r_e_m));
        Self::finish_out(out, entities)
    }

    /// A truth record at log time `at_ns` (latitude `lat_rad`): a point of the truth track.
    pub fn truth(&mut self, t: &TruthRecord, lat_rad: f64, at_ns: u64) -> SceneOut {
        let e = self.truth.add(at_ns, lat_rad, t.r_e_m);
        Self::finish_out(SceneOut::default(), e.into_iter().collect())
    }

    /// The end: the segments not yet sent, and their log time (that of the
    /// last point drawn).
    pub fn finish(&mut self) -> (SceneOut, u64) {
        let t = self.solution.last_ns.max(self.truth.last_ns);
        let mut entities: Vec<SceneEntity> = self.solution.flush(t).into_iter().collect();
        entities.extend(self.truth.flush(t));
        (Self::finish_out(SceneOut::default(), entities), t)
    }
}

/// The circle of latitude `cdeg` (hundredths of a degree) on the
/// ellipsoid, in the nearer pole's frame, labelled at a longitude of 30° +
/// 20° per circle before it (the `k`-th circle), so that labels do not overlap.
fn latitude_circle(t_ns: u64, cdeg: i64, k: usize) -> SceneEntity {
    let lat = (cdeg as f64 / 100.0).to_radians();
    let pole = Pole::nearer(lat);
    let points =
        (0..360)
            .map(|k| {
                let lon = (k as f64).to_radians();
                point(pole.from_ecef(
                    earth::geodetic_to_ecef(&earth::Geodetic::new(lat, lon, 0.0)).into(),
                ))
            })
            .collect();
    let label_lon = (10.0 + 20.0 * k as f64).to_radians();
    let label_at =
        pole.from_ecef(earth::geodetic_to_ecef(&earth::Geodetic::new(lat, label_lon, 0.0)).into());
    SceneEntity {
        timestamp: Some(stamp(t_ns)),
        frame_id: pole.frame_id().into(),
        id: format!("switch-latitude-{cdeg}"),
        lines: vec![LinePrimitive {
            // LINE_LOOP
            r#type: 1,
            thickness: 1.5,
            scale_invariant: true,
            points,
            color: Some(Color {
                r: 0.9,
                g: 0.6,
                b: 0.0,
                a: 1.0,
            }),
            ..Default::default()
        }],
        texts: vec![TextPrimitive {
            pose: Some(Pose {
                position: Some(vec3(label_at)),
                orientation: Some(quat(&UnitQuaternion::identity())),
            }),
            billboard: true,
            font_size: 12.0,
            scale_invariant: true,
            color: Some(Color {
                r: 0.9,
                g: 0.6,
                b: 0.0,
                a: 1.0,
            }),
            text: format!("frame switch at {:.2}°", cdeg as f64 / 100.0),
        }],
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The frame's rotation and origin agree with `from_ecef` (a second
    /// formulation: C_e^polar (r − o)), at both poles, and `ecef` → `polar`
    /// → `body` composes back to the solution's ECEF position and attitude.
    #[test]
    fn polar_frames_compose_back_to_ecef() {
        for (lat, lon) in [
            (89.9_f64, 12.0_f64),
            (70.0, -150.0),
            (-80.0, 33.0),
            (-89.99, 179.0),
        ] {
            let geo = earth::Geodetic::new(lat.to_radians(), lon.to_radians(), 18_000.0);
            let r: [f64; 3] = earth::geodetic_to_ecef(&geo).into();
            let pole = Pole::nearer(geo.lat_rad);
            let o = nalgebra::Vector3::from(pole.origin_e());
            let second = pole.q_e_polar() * (nalgebra::Vector3::from(r) - o);
            let first = nalgebra::Vector3::from(pole.from_ecef(r));
            assert!((first - second).norm() < 1e-6, "{lat}: {first} vs {second}");
            let q_b_e = UnitQuaternion::from_euler_angles(0.1, -0.2, 2.5);
            let c = q_b_e.into_inner();
            let s = Solution {
                lat_rad: geo.lat_rad,
                r_e_m: r,
                q_b_e: [c.w, c.i, c.j, c.k],
                ..Default::default()
            };
            let (p2, t, q) = body_in_polar(&s);
            assert_eq!(p2, pole);
            // ecef → polar: p_e = C_polar^e p_polar + o.
            let q_polar_e = pole.q_e_polar().inverse();
            let back = q_polar_e * nalgebra::Vector3::from(t) + o;
            assert!((back - nalgebra::Vector3::from(r)).norm() < 1e-6);
            assert!((q_polar_e * q).angle_to(&q_b_e) < 1e-12);
            // Up at the aircraft points away from the pole's plane (z grows with height).
            let higher = pole.from_ecef(
                earth::geodetic_to_ecef(&earth::Geodetic::new(geo.lat_rad, geo.lon_rad, 28_000.0))
                    .into(),
            );
            assert!(higher[2] > t[2]);
        }
    }
}
