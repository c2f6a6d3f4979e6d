//! Camera paths (`manifests/paths/*.ron`): waypoints on the ground walked at eye
//! height with the paper's limits (000 §4.1.2: at most 30 units/s and 45°/s, 60° FOV,
//! 1024² output), sampled into frames at a fixed frame rate.
//!
//! Sampling: at each waypoint the camera first turns in place towards the next
//! segment at `max_turn_deg_per_s`, then walks the segment at `max_speed` looking
//! along it. Frames are taken every `1 / frame_rate` seconds of that motion, so a
//! path gives the same frames on every machine.
//!
//! Instead of waypoints a path may list explicit `views` (eye and direction), one
//! frame each, `1 / frame_rate` seconds apart: `pipeline benchmarks views` writes such
//! paths over the check viewpoints of sampled cells, so the player can measure a
//! partial bake without walking through cells that were not baked. The speed and
//! turn limits do not apply to views.

use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraPath {
    pub eye_height: f32,
    pub fov_y_deg: f32,
    pub resolution: (u32, u32),
    /// Units per second.
    pub max_speed: f32,
    pub max_turn_deg_per_s: f32,
    /// Frames sampled per second of motion.
    pub frame_rate: f32,
    /// (x, z) points on the ground (at least 2, or none when `views` is given).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub waypoints: Vec<(f32, f32)>,
    /// Explicit poses, `((x, y, z) eye, (x, y, z) direction)`, one frame each.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub views: Vec<PathView>,
}

/// An explicit camera pose of a path: `((x, y, z) eye, (x, y, z) direction)`.
pub type PathView = ((f32, f32, f32), (f32, f32, f32));

/// One sampled camera pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathFrame {
    /// Seconds since the start of the path.
    pub time_s: f32,
    pub eye: Vec3,
    /// Unit viewing direction (horizontal on walked paths).
    pub dir: Vec3,
}

#[derive(Debug, thiserror::Error)]
pub enum PathError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}:{col}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        col: usize,
        message: String,
    },
    #[error("{path}: {field}: {message}")]
    Invalid {
        path: PathBuf,
        field: &'static str,
        message: String,
    },
}

impl CameraPath {
    /// Reads and validates a path file.
    pub fn load(path: &Path) -> Result<CameraPath, PathError> {
        let text = std::fs::read_to_string(path).map_err(|source| PathError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates path text; `path` is only used in messages.
    pub fn parse(text: &str, path: &Path) -> Result<CameraPath, PathError> {
        let parsed: CameraPath = ron::from_str(text).map_err(|e| PathError::Parse {
            path: path.to_path_buf(),
            line: e.position.line,
            col: e.position.col,
            message: e.code.to_string(),
        })?;
        let invalid = |field, message: &str| PathError::Invalid {
            path: path.to_path_buf(),
            field,
            message: message.to_string(),
        };
        let positive = |v: f32| v.is_finite() && v > 0.0;
        if !positive(parsed.eye_height) {
            return Err(invalid("eye_height", "must be a positive number"));
        }
        if !(parsed.fov_y_deg > 1.0 && parsed.fov_y_deg < 179.0) {
            return Err(invalid("fov_y_deg", "must be in (1, 179) degrees"));
        }
        if parsed.resolution.0 == 0 || parsed.resolution.1 == 0 {
            return Err(invalid("resolution", "must be at least 1 × 1"));
        }
        if !positive(parsed.max_speed) {
            return Err(invalid("max_speed", "must be a positive number"));
        }
        if !positive(parsed.max_turn_deg_per_s) {
            return Err(invalid("max_turn_deg_per_s", "must be a positive number"));
        }
        if !positive(parsed.frame_rate) {
            return Err(invalid("frame_rate", "must be a positive number"));
        }
        if !parsed.views.is_empty() {
            if !parsed.waypoints.is_empty() {
                return Err(invalid("views", "give either waypoints or views, not both"));
            }
            for (k, &((x, y, z), (dx, dy, dz))) in parsed.views.iter().enumerate() {
                if ![x, y, z, dx, dy, dz].iter().all(|v| v.is_finite()) {
                    return Err(invalid(
                        "views",
                        &format!("view {k}: every coordinate must be finite"),
                    ));
                }
                if dx * dx + dy * dy + dz * dz < 1e-12 {
                    return Err(invalid(
                        "views",
                        &format!("view {k}: the direction must not be zero"),
                    ));
                }
            }
            return Ok(parsed);
        }
        if parsed.waypoints.len() < 2 {
            return Err(invalid(
                "waypoints",
                "needs at least 2 points (or give views)",
            ));
        }
        if parsed
            .waypoints
            .iter()
            .any(|&(x, z)| !x.is_finite() || !z.is_finite())
        {
            return Err(invalid("waypoints", "every coordinate must be finite"));
        }
        if parsed.waypoints.windows(2).any(|w| w[0] == w[1]) {
            return Err(invalid("waypoints", "two consecutive points are equal"));
        }
        Ok(parsed)
    }

    /// Total length in units of the walked segments.
    pub fn length(&self) -> f32 {
        self.segments().map(|(a, b)| a.distance(b)).sum()
    }

    fn segments(&self) -> impl Iterator<Item = (Vec2, Vec2)> + '_ {
        self.waypoints
            .windows(2)
            .map(|w| (Vec2::new(w[0].0, w[0].1), Vec2::new(w[1].0, w[1].1)))
    }

    /// Samples the motion into frames, or lists the explicit views (module docs).
    pub fn frames(&self) -> Vec<PathFrame> {
        if !self.views.is_empty() {
            return self
                .views
                .iter()
                .enumerate()
                .map(|(i, &((x, y, z), (dx, dy, dz)))| PathFrame {
                    time_s: i as f32 / self.frame_rate,
                    eye: Vec3::new(x, y, z),
                    dir: Vec3::new(dx, dy, dz).normalize(),
                })
                .collect();
        }
        // 1. Build the motion as a list of timed pieces: turns in place and walks.
        enum Piece {
            Turn { at: Vec2, from: f32, to: f32 },
            Walk { from: Vec2, to: Vec2, heading: f32 },
        }
        let turn_rate = self.max_turn_deg_per_s.to_radians();
        let mut pieces: Vec<(f32, Piece)> = Vec::new();
        let mut heading: Option<f32> = None;
        for (a, b) in self.segments() {
            let d = b - a;
            let target = d.y.atan2(d.x);
            if let Some(h) = heading {
                let mut delta = target - h;
                while delta > std::f32::consts::PI {
                    delta -= std::f32::consts::TAU;
                }
                while delta < -std::f32::consts::PI {
                    delta += std::f32::consts::TAU;
                }
                if delta.abs() > 1e-6 {
                    let to = h + delta;
                    pieces.push((delta.abs() / turn_rate, Piece::Turn { at: a, from: h, to }));
                }
            }
            pieces.push((
                d.length() / self.max_speed,
                Piece::Walk {
                    from: a,
                    to: b,
                    heading: target,
                },
            ));
            heading = Some(target);
        }
        // 2. Sample every 1/frame_rate seconds, plus the final pose.
        let total: f32 = pieces.iter().map(|p| p.0).sum();
        let n = (total * self.frame_rate).floor() as usize + 1;
        let mut frames = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f32 / self.frame_rate;
            let mut rest = t;
            let mut pose = None;
            for (duration, piece) in &pieces {
                if rest <= *duration || std::ptr::eq(piece, &pieces.last().unwrap().1) {
                    let f = if *duration > 0.0 {
                        (rest / duration).clamp(0.0, 1.0)
                    } else {
                        1.0
                    };
                    pose = Some(match piece {
                        Piece::Turn { at, from, to } => (*at, from + (to - from) * f),
                        Piece::Walk { from, to, heading } => (from.lerp(*to, f), *heading),
                    });
                    break;
                }
                rest -= duration;
            }
            let (p, h) = pose.expect("a path has at least one walk");
            frames.push(PathFrame {
                time_s: t,
                eye: Vec3::new(p.x, self.eye_height, p.y),
                dir: Vec3::new(h.cos(), 0.0, h.sin()),
            });
        }
        frames
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(waypoints: Vec<(f32, f32)>) -> CameraPath {
        CameraPath {
            eye_height: 8.0,
            fov_y_deg: 60.0,
            resolution: (64, 64),
            max_speed: 30.0,
            max_turn_deg_per_s: 45.0,
            frame_rate: 10.0,
            waypoints,
            views: Vec::new(),
        }
    }

    #[test]
    fn frames_respect_speed_and_turn_limits() {
        let p = path(vec![(0.0, 0.0), (300.0, 0.0), (300.0, 300.0)]);
        let frames = p.frames();
        // 600 units at 30/s plus a 90° turn at 45°/s: 22 s, 10 frames/s.
        assert_eq!(frames.len(), 221);
        for w in frames.windows(2) {
            let step = w[0].eye.distance(w[1].eye);
            assert!(step <= 3.0 + 1e-3, "moved {step} in 0.1 s");
            let turn = w[0].dir.angle_between(w[1].dir).to_degrees();
            assert!(turn <= 4.5 + 1e-2, "turned {turn}° in 0.1 s");
        }
        let last = frames.last().unwrap();
        assert!(last.eye.distance(Vec3::new(300.0, 8.0, 300.0)) < 1e-3);
    }

    #[test]
    fn bad_fields_are_named() {
        let err = CameraPath::parse(
            "(eye_height: 8.0, fov_y_deg: 60.0, resolution: (8, 8), max_speed: 30.0, \
             max_turn_deg_per_s: 45.0, frame_rate: 10.0, waypoints: [(0.0, 0.0)])",
            Path::new("p.ron"),
        )
        .unwrap_err();
        assert!(err.to_string().contains("waypoints"), "{err}");
        let err = CameraPath::parse("(eye_hight: 8.0)", Path::new("p.ron")).unwrap_err();
        assert!(err.to_string().starts_with("p.ron:1:"), "{err}");
    }

    #[test]
    fn explicit_views_are_one_frame_each_and_round_trip() {
        let text = "(eye_height: 8.0, fov_y_deg: 60.0, resolution: (8, 8), max_speed: 30.0, \
                    max_turn_deg_per_s: 45.0, frame_rate: 10.0, \
                    views: [((1.0, 8.0, 2.0), (2.0, 0.0, 0.0)), ((5.0, 9.0, 6.0), (0.0, 0.0, -1.0))])";
        let p = CameraPath::parse(text, Path::new("v.ron")).unwrap();
        let frames = p.frames();
        assert_eq!(frames.len(), 2);
        assert_eq!(frames[0].eye, Vec3::new(1.0, 8.0, 2.0));
        assert_eq!(frames[0].dir, Vec3::X);
        assert_eq!(frames[1].time_s, 0.1);
        let again = CameraPath::parse(&ron::to_string(&p).unwrap(), Path::new("v.ron")).unwrap();
        assert_eq!(again, p);
        // Both, or a zero direction, are refused with the field named.
        let both = text.replace("views:", "waypoints: [(0.0, 0.0), (1.0, 0.0)], views:");
        let err = CameraPath::parse(&both, Path::new("v.ron")).unwrap_err();
        assert!(err.to_string().contains("not both"), "{err}");
        let zero = text.replace("(2.0, 0.0, 0.0)", "(0.0, 0.0, 0.0)");
        let err = CameraPath::parse(&zero, Path::new("v.ron")).unwrap_err();
        assert!(err.to_string().contains("view 0"), "{err}");
    }
}
