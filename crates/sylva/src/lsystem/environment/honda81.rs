//! `honda81`: competition for space (Honda, Tomlinson & Fisher 1981).
//!
//! Named after Honda, Tomlinson & Fisher (1981), whose tree model resolves collisions
//! between branch tips by their vigor; the corpus's Sierpinski and canalization models
//! use it. The vlab program's source is not available, so sylva's version is defined by
//! what the models' descriptions say it does:
//!
//! - every `?E(v, …)` module is a sensor at its turtle position with vigor `v` (its first
//!   parameter, 0 when it has none);
//! - two sensors *collide* when their distance is below `radius` (model units);
//! - a sensor that collides with nothing gets 1 ("grow"); a colliding sensor gets 1 only
//!   when its vigor is strictly greater than the vigor of every sensor it collides with,
//!   else 0 ("don't grow"). Equal vigors therefore stop each other: the deterministic
//!   Sierpinski model's tips annihilate in pairs, which is Pascal's triangle mod 2;
//! - the answer replaces the first parameter; other parameters are left alone;
//! - a sensor at a non-finite position gets 0 and collides with nothing.
//!
//! Spec file (`density.spec`): `radius: r` (default 0.5; the recipe's
//! `generator.environment.radius` overrides it), `3d case: on|off` (default on; off
//! measures distances in the x–y plane only, as the 2D case of the vlab program),
//! `verbose:` (accepted, no effect).
//!
//! The neighbour search is a uniform hash grid with cells of size `radius`, so one
//! exchange costs O(n) for n sensors at bounded density; work is one unit per sensor and
//! one per neighbour tested.

use super::{Overrides, Sensor, Spec, Work};
use glam::DVec3;
use std::collections::HashMap;

/// Default collision radius, in model units (a unit turtle step is 1).
pub const DEFAULT_RADIUS: f64 = 0.5;

/// The spec-file keys `honda81` reads.
pub const KEYS: &[&str] = &["radius", "3d case", "verbose"];

/// `honda81`'s settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Honda81 {
    /// Sensors closer than this collide.
    pub radius: f64,
    /// Distances in 3D (`true`) or in the x–y plane.
    pub three_d: bool,
}

impl Honda81 {
    /// Settings from the spec file and the recipe's overrides.
    pub fn configure(spec: &Spec, over: &Overrides) -> Result<Honda81, String> {
        let mut radius =
            spec.number_or("radius", DEFAULT_RADIUS, |r| r > 0.0, "the radius must be positive")?;
        if let Some(r) = over.radius {
            radius = r;
        }
        if !(radius.is_finite() && radius > 0.0) {
            return Err(format!("honda81: radius must be a positive number, got {radius}"));
        }
        let three_d = match spec.get("3d case") {
            Some(e) => spec.flag(e)?,
            None => true,
        };
        Ok(Honda81 { radius, three_d })
    }

    /// Answers the sensors (see the module documentation).
    pub fn respond(&self, sensors: &mut [Sensor], work: u64) -> Result<u64, u64> {
        let radius = self.radius;
        let flat = |p: DVec3| if self.three_d { p } else { DVec3::new(p.x, p.y, 0.0) };
        let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
        for (i, s) in sensors.iter().enumerate() {
            if s.position.is_finite() {
                grid.entry(cell(flat(s.position), radius)).or_default().push(i);
            }
        }
        let vigor = |s: &Sensor| s.values.first().copied().filter(|v| !v.is_nan()).unwrap_or(0.0);
        let r2 = radius * radius;
        let mut w = Work::new(work);
        let mut answers: Vec<f64> = Vec::with_capacity(sensors.len());
        for (i, s) in sensors.iter().enumerate() {
            w.add(1)?;
            if !s.position.is_finite() {
                answers.push(0.0);
                continue;
            }
            let p = flat(s.position);
            let (cx, cy, cz) = cell(p, radius);
            let v = vigor(s);
            let mut answer = 1.0;
            'search: for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let key = (cx.wrapping_add(dx), cy.wrapping_add(dy), cz.wrapping_add(dz));
                        let Some(list) = grid.get(&key) else { continue };
                        w.add(list.len() as u64)?;
                        for &j in list {
                            if j != i
                                && flat(sensors[j].position).distance_squared(p) < r2
                                && vigor(&sensors[j]) >= v
                            {
                                answer = 0.0;
                                break 'search;
                            }
                        }
                    }
                }
            }
            answers.push(answer);
        }
        for (s, a) in sensors.iter_mut().zip(answers) {
            super::answer(&mut s.values, 0, a);
        }
        Ok(w.used)
    }
}

/// The grid cell of `p`; coordinates beyond ±2⁶² cells are clamped (the cell index of a
/// far-away sensor must not overflow when its neighbours are visited).
pub(crate) fn cell(p: DVec3, size: f64) -> (i64, i64, i64) {
    const FAR: f64 = (1u64 << 62) as f64;
    let c = (p / size).floor().clamp(DVec3::splat(-FAR), DVec3::splat(FAR));
    if !c.is_finite() {
        return (0, 0, 0);
    }
    (c.x as i64, c.y as i64, c.z as i64)
}

#[cfg(test)]
mod tests {
    use super::super::Environment;
    use super::*;

    fn sensor(x: f64, y: f64, v: f64) -> Sensor {
        Sensor { position: DVec3::new(x, y, 0.0), values: vec![v, 7.0] }
    }

    #[test]
    fn isolated_sensors_grow_and_collisions_go_to_the_stronger() {
        let env = Environment::by_name("honda81", Some(0.5)).unwrap();
        let mut s =
            vec![sensor(0.0, 0.0, 3.0), sensor(0.3, 0.0, 5.0), sensor(2.0, 0.0, 1.0), sensor(2.0, 0.2, 1.0)];
        env.respond(&mut s);
        let got: Vec<f64> = s.iter().map(|s| s.values[0]).collect();
        // weaker of a pair loses, stronger wins; equal vigors both lose.
        assert_eq!(got, vec![0.0, 1.0, 0.0, 0.0]);
        assert!(s.iter().all(|s| s.values[1] == 7.0), "only the first parameter is answered");
        let mut alone = vec![sensor(0.0, 0.0, 0.0), sensor(0.6, 0.0, 0.0)];
        env.respond(&mut alone);
        assert_eq!(
            [alone[0].values[0], alone[1].values[0]],
            [1.0, 1.0],
            "0.6 apart is no collision at radius 0.5"
        );
    }

    #[test]
    fn spec_radius_and_2d_case() {
        let spec = Spec::parse("density.spec", "verbose: off\nradius:  0.01\n3d case: off\n");
        let h = Honda81::configure(&spec, &Overrides::default()).unwrap();
        assert_eq!((h.radius, h.three_d), (0.01, false));
        let h = Honda81::configure(&spec, &Overrides { radius: Some(2.0), ..Default::default() }).unwrap();
        assert_eq!(h.radius, 2.0, "the recipe overrides the spec file");
        // In the 2D case sensors differing in z only collide.
        let mut s = vec![
            Sensor { position: DVec3::new(0.0, 0.0, 0.0), values: vec![1.0] },
            Sensor { position: DVec3::new(0.0, 0.0, 5.0), values: vec![2.0] },
        ];
        h.respond(&mut s, u64::MAX).unwrap();
        assert_eq!((s[0].values[0], s[1].values[0]), (0.0, 1.0));
        for bad in ["radius: -1\n", "radius: abc\n", "3d case: maybe\n"] {
            let e = Honda81::configure(&Spec::parse("d.spec", bad), &Overrides::default()).unwrap_err();
            assert!(e.contains("d.spec:1:"), "{e}");
        }
    }

    #[test]
    fn bad_radii_and_budget() {
        assert!(Environment::by_name("honda81", Some(0.0)).is_err());
        assert!(Environment::by_name("honda81", Some(f64::NAN)).is_err());
        let env = Environment::by_name("honda81", Some(1.0)).unwrap();
        let mut pile: Vec<Sensor> = (0..100).map(|_| sensor(0.0, 0.0, 1.0)).collect();
        assert!(env.respond_within(&mut pile, 500).is_err());
    }
}
