//! `obcheck`: obstacle checking against a data file (the environment of models that
//! must not grow into walls, rocks or the ground, as in Měch & Prusinkiewicz 96, §5:
//! plants growing around obstacles).
//!
//! The spec file names the obstacle file: `obstacles: FILE` (relative to the model
//! folder; the recipe's `generator.environment.obstacles` overrides it). The obstacle
//! file is text, one obstacle a line, `#` starting a comment:
//!
//! ```text
//! sphere cx cy cz r             # the ball |p − c| ≤ r (r > 0)
//! box x0 y0 z0 x1 y1 z1         # the axis-aligned box between two opposite corners
//! halfspace nx ny nz d          # the points with n̂·p ≥ d, n̂ = n/|n| and d/|n|
//! ```
//!
//! Each `?E(x, …)` module is a sensor at its turtle position. Its signed distance is the
//! minimum over the obstacles of each obstacle's signed distance (positive outside,
//! negative inside: the exact Euclidean distance outside a sphere, box or half-space,
//! minus the depth inside). The answer: the first parameter becomes 1 when the position
//! is free (signed distance > 0) and 0 when it is inside or on an obstacle; a second
//! parameter, when the module has one, becomes the signed distance (`f64::MAX` with no
//! obstacle at all). A sensor at a non-finite position gets 0 and distance 0.
//!
//! Work: one unit per sensor and one per obstacle tested.

use super::{Overrides, Sensor, Spec, Work};
use crate::input::{excerpt, SideFiles};
use glam::DVec3;
use std::sync::Arc;

/// The spec-file keys `obcheck` reads.
pub const KEYS: &[&str] = &["obstacles", "verbose"];

/// The most obstacles a file may hold.
pub const MAX_OBSTACLES: usize = 1_000_000;

/// One obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Obstacle {
    /// A ball: centre and radius.
    Sphere(DVec3, f64),
    /// An axis-aligned box: lower and upper corner.
    Box(DVec3, DVec3),
    /// The half-space n·p ≥ d (n a unit vector).
    HalfSpace(DVec3, f64),
}

impl Obstacle {
    /// The signed distance of `p`: positive outside, negative inside.
    pub fn distance(&self, p: DVec3) -> f64 {
        match *self {
            Obstacle::Sphere(c, r) => p.distance(c) - r,
            Obstacle::Box(lo, hi) => {
                let centre = (lo + hi) * 0.5;
                let q = (p - centre).abs() - (hi - lo) * 0.5;
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
            }
            Obstacle::HalfSpace(n, d) => d - n.dot(p),
        }
    }
}

/// `obcheck`'s settings: the obstacles of its data file.
#[derive(Debug, Clone, PartialEq)]
pub struct Obcheck {
    /// The obstacle file's name, as the spec or recipe gave it.
    pub file: String,
    /// The obstacles.
    pub obstacles: Arc<Vec<Obstacle>>,
}

/// Parses an obstacle file (`file` is the name errors show).
pub fn parse_obstacles(file: &str, text: &str) -> Result<Vec<Obstacle>, String> {
    let mut out = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = format!("{file}:{}", k + 1);
        let mut words = line.split_whitespace();
        let kind = words.next().unwrap_or("").to_ascii_lowercase();
        let nums: Vec<f64> = words
            .map(|w| w.parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| format!("{at}: `{}`: the values must be finite numbers", excerpt(line)))?;
        let want = |n: usize, names: &str| -> Result<(), String> {
            if nums.len() == n {
                Ok(())
            } else {
                Err(format!("{at}: `{}` needs {n} numbers ({names}), got {}", excerpt(&kind), nums.len()))
            }
        };
        let v = |i: usize| DVec3::new(nums[i], nums[i + 1], nums[i + 2]);
        out.push(match kind.as_str() {
            "sphere" => {
                want(4, "cx cy cz r")?;
                if nums[3] <= 0.0 {
                    return Err(format!("{at}: the sphere's radius must be positive, got {}", nums[3]));
                }
                Obstacle::Sphere(v(0), nums[3])
            }
            "box" => {
                want(6, "x0 y0 z0 x1 y1 z1")?;
                Obstacle::Box(v(0).min(v(3)), v(0).max(v(3)))
            }
            "halfspace" => {
                want(4, "nx ny nz d")?;
                let len = v(0).length();
                if !(len.is_finite() && len > 0.0) {
                    return Err(format!("{at}: the half-space's normal must not be zero"));
                }
                Obstacle::HalfSpace(v(0) / len, nums[3] / len)
            }
            other => {
                return Err(format!("{at}: unknown obstacle `{}` (sphere, box or halfspace)", excerpt(other)))
            }
        });
        if out.len() > MAX_OBSTACLES {
            return Err(format!("{at}: more than {MAX_OBSTACLES} obstacles"));
        }
    }
    Ok(out)
}

impl Obcheck {
    /// Settings from the spec file and the recipe's overrides; the obstacle file is
    /// read from the model folder `files` (confined to it, [`SideFiles`]). A missing,
    /// broken or refused obstacle file is an error naming it.
    pub fn configure(spec: &Spec, over: &Overrides, files: &SideFiles) -> Result<Obcheck, String> {
        let (file, at) = match (&over.obstacles, spec.get("obstacles")) {
            (Some(f), _) => (f.clone(), "`generator.environment.obstacles`".to_string()),
            (None, Some(e)) if !e.value.is_empty() => {
                (e.value.clone(), format!("{}:{}: `obstacles:`", spec.file, e.line))
            }
            (None, Some(e)) => return Err(spec.error(e, "expected the obstacle file's name")),
            (None, None) => {
                return Err(format!(
                    "obcheck: no obstacle file: give one with `obstacles: FILE` in {} or generator.environment.obstacles",
                    spec.file
                ))
            }
        };
        let path = files.resolve(&file, &at).map_err(|e| e.to_string())?;
        let bytes = files.read(&path, &at).map_err(|e| format!("obcheck: the obstacle file: {e}"))?;
        let obstacles = parse_obstacles(&path.display().to_string(), &String::from_utf8_lossy(&bytes))?;
        Ok(Obcheck { file, obstacles: Arc::new(obstacles) })
    }

    /// Answers the sensors (see the module documentation).
    pub fn respond(&self, sensors: &mut [Sensor], work: u64) -> Result<u64, u64> {
        let mut w = Work::new(work);
        let mut answers = Vec::with_capacity(sensors.len());
        for s in sensors.iter() {
            w.add(1)?;
            if !s.position.is_finite() {
                answers.push((0.0, 0.0));
                continue;
            }
            w.add(self.obstacles.len() as u64)?;
            let d = self.obstacles.iter().map(|o| o.distance(s.position)).fold(f64::MAX, f64::min);
            let d = if d.is_nan() { 0.0 } else { d.clamp(-f64::MAX, f64::MAX) };
            answers.push((if d > 0.0 { 1.0 } else { 0.0 }, d));
        }
        for (s, (free, d)) in sensors.iter_mut().zip(answers) {
            super::answer(&mut s.values, 0, free);
            if s.values.len() >= 2 {
                s.values[1] = d;
            }
        }
        Ok(w.used)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str) -> Obcheck {
        Obcheck { file: "o.txt".into(), obstacles: Arc::new(parse_obstacles("o.txt", text).unwrap()) }
    }

    fn at(x: f64, y: f64, z: f64) -> Sensor {
        Sensor { position: DVec3::new(x, y, z), values: vec![9.0, 9.0] }
    }

    #[test]
    fn free_positions_and_distances() {
        let o = check(
            "# obstacles\nsphere 0 0 0 1\nbox 5 5 5 3 3 3  # corners in any order\nhalfspace 0 2 0 20\n",
        );
        let mut s = vec![
            at(0.0, 0.0, 0.0),
            at(2.0, 0.0, 0.0),
            at(4.0, 4.0, 4.0),
            at(4.0, 7.0, 4.0),
            at(0.0, 11.0, 0.0),
        ];
        o.respond(&mut s, u64::MAX).unwrap();
        let got: Vec<(f64, f64)> = s.iter().map(|s| (s.values[0], s.values[1])).collect();
        assert_eq!(got[0], (0.0, -1.0));
        assert_eq!(got[1], (1.0, 1.0));
        assert_eq!(got[2], (0.0, -1.0));
        assert_eq!(got[3], (1.0, 2.0));
        assert_eq!(got[4], (0.0, -1.0), "y ≥ 10 is solid");
        let none = check("");
        let mut s = vec![at(0.0, 0.0, 0.0), Sensor { position: DVec3::NAN, values: vec![1.0] }];
        none.respond(&mut s, u64::MAX).unwrap();
        assert_eq!((s[0].values[0], s[0].values[1], s[1].values[0]), (1.0, f64::MAX, 0.0));
    }

    #[test]
    fn bad_obstacle_files_name_the_line() {
        for (bad, why) in [
            ("sphere 0 0 0\n", "needs 4 numbers"),
            ("sphere 0 0 0 -1\n", "positive"),
            ("cone 1 2 3\n", "unknown obstacle"),
            ("box 0 0 0 1 1 x\n", "finite numbers"),
            ("halfspace 0 0 0 1\n", "normal"),
        ] {
            let e = parse_obstacles("o.txt", &format!("# c\n{bad}")).unwrap_err();
            assert!(e.contains("o.txt:2:") && e.contains(why), "{bad}: {e}");
        }
        let e = Obcheck::configure(
            &Spec::parse("o.spec", "obstacles: nowhere.txt\n"),
            &Overrides::default(),
            &SideFiles::new(std::path::Path::new("."), &[], u64::MAX),
        )
        .unwrap_err();
        assert!(e.contains("nowhere.txt"), "{e}");
        let here = SideFiles::new(std::path::Path::new("."), &[], u64::MAX);
        let e = Obcheck::configure(&Spec::parse("o.spec", ""), &Overrides::default(), &here).unwrap_err();
        assert!(e.contains("obstacles"), "{e}");
    }

    #[test]
    fn budget() {
        let o = check(&"sphere 0 0 0 1\n".repeat(100));
        let mut s: Vec<Sensor> = (0..100).map(|i| at(i as f64, 0.0, 0.0)).collect();
        assert!(o.respond(&mut s, 1000).is_err());
    }
}
