//! `ecosystem`: plants as circles competing for space on the ground (Deussen et al.,
//! "Realistic modeling and rendering of plant ecosystems", SIGGRAPH 98; Lane &
//! Prusinkiewicz, "Generating spatial distributions for multilevel models of plant
//! communities", Graphics Interface 2002: self-thinning).
//!
//! Every `?E(r, …)` module is a plant: a circle of radius `r` (its first parameter)
//! centred at its turtle position projected on the ground plane. The ground is the
//! plane across the `up axis:` (default `y`, cpfg's default heading: the ground is the
//! x–z plane; `up axis: z` makes it the x–y plane).
//!
//! Plants are ranked by size: a plant is *larger* than another when its radius is
//! greater, or, for equal radii, when it comes earlier in the string (ties are thus
//! broken deterministically by string order). A plant is *dominated* when its circle
//! overlaps the circle of a larger plant: the distance of the centres is below the sum
//! of the radii (circles that only touch do not overlap). As in Lane & Prusinkiewicz,
//! domination is decided for all plants at once, also by plants that are themselves
//! dominated; so the survivors never overlap, and of two overlapping plants the smaller
//! always dies.
//!
//! The answer: a module with two or more parameters gets 1 (alive) or 0 (dominated:
//! the model should remove the plant) in its second parameter, the radius staying in the
//! first; a module with one parameter gets its radius back when alive and 0 when
//! dominated. Modules with a radius that is not a positive finite number, or at a
//! non-finite position, are not plants: they get the dominated answer and dominate
//! nothing.
//!
//! The neighbour search is a uniform hash grid on the ground plane with cells of the
//! largest diameter; work is one unit per plant and one per neighbour tested (plants of
//! very different sizes can make it quadratic, which the budget bounds).

use super::{Overrides, Sensor, Spec, Work};
use std::collections::HashMap;

/// The spec-file keys `ecosystem` reads.
pub const KEYS: &[&str] = &["up axis", "verbose"];

/// `ecosystem`'s settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Ecosystem {
    /// The up axis (0 x, 1 y, 2 z); the ground plane holds the other two.
    pub up: usize,
}

impl Ecosystem {
    /// Settings from the spec file (the recipe has no `ecosystem` overrides).
    pub fn configure(spec: &Spec, _over: &Overrides) -> Result<Ecosystem, String> {
        Ok(Ecosystem { up: super::axis(spec, "up axis", 1)? })
    }

    /// Answers the sensors (see the module documentation).
    pub fn respond(&self, sensors: &mut [Sensor], work: u64) -> Result<u64, u64> {
        let (a, b) = match self.up {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let mut w = Work::new(work);
        // (ground x, ground y, radius) of the plants.
        let plant = |s: &Sensor| -> Option<(f64, f64, f64)> {
            let r = *s.values.first()?;
            let p = s.position.to_array();
            (r.is_finite() && r > 0.0 && p[a].is_finite() && p[b].is_finite()).then_some((p[a], p[b], r))
        };
        let plants: Vec<Option<(f64, f64, f64)>> = sensors.iter().map(plant).collect();
        let rmax = plants.iter().flatten().map(|p| p.2).fold(0.0, f64::max);
        let size = (2.0 * rmax).max(f64::MIN_POSITIVE);
        let key = |x: f64, y: f64| {
            let c = super::honda81::cell(glam::DVec3::new(x, y, 0.0), size);
            (c.0, c.1)
        };
        let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, p) in plants.iter().enumerate() {
            if let Some((x, y, _)) = p {
                grid.entry(key(*x, *y)).or_default().push(i);
            }
        }
        // Larger: greater radius, or equal radius and earlier in the string.
        let larger = |j: usize, rj: f64, i: usize, ri: f64| rj > ri || (rj == ri && j < i);
        let mut alive = vec![false; sensors.len()];
        for (i, p) in plants.iter().enumerate() {
            w.add(1)?;
            let Some((x, y, r)) = *p else { continue };
            let (cx, cy) = key(x, y);
            let mut dominated = false;
            'search: for dx in -1..=1i64 {
                for dy in -1..=1i64 {
                    let Some(list) = grid.get(&(cx.wrapping_add(dx), cy.wrapping_add(dy))) else { continue };
                    w.add(list.len() as u64)?;
                    for &j in list {
                        let Some((xj, yj, rj)) = plants[j] else { continue };
                        let d = ((xj - x).powi(2) + (yj - y).powi(2)).sqrt();
                        if j != i && larger(j, rj, i, r) && d < r + rj {
                            dominated = true;
                            break 'search;
                        }
                    }
                }
            }
            alive[i] = !dominated;
        }
        for (s, live) in sensors.iter_mut().zip(alive) {
            if s.values.len() >= 2 {
                s.values[1] = if live { 1.0 } else { 0.0 };
            } else if !live {
                super::answer(&mut s.values, 0, 0.0);
            }
        }
        Ok(w.used)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn plant(x: f64, z: f64, r: f64) -> Sensor {
        Sensor { position: DVec3::new(x, 7.0, z), values: vec![r, 5.0] }
    }

    #[test]
    fn the_smaller_of_overlapping_plants_dies_and_ties_go_to_the_first() {
        let e = Ecosystem { up: 1 };
        let mut s =
            vec![plant(0.0, 0.0, 1.0), plant(1.5, 0.0, 0.6), plant(10.0, 0.0, 1.0), plant(11.0, 0.0, 1.0)];
        e.respond(&mut s, u64::MAX).unwrap();
        let alive: Vec<f64> = s.iter().map(|s| s.values[1]).collect();
        assert_eq!(alive, vec![1.0, 0.0, 1.0, 0.0]);
        assert_eq!(s[1].values[0], 0.6, "the radius stays");
        // Touching circles do not overlap; a chain kills both smaller ones.
        let mut s =
            vec![plant(0.0, 0.0, 1.0), plant(2.0, 0.0, 1.0), plant(3.0, 0.0, 0.9), plant(4.5, 0.0, 0.8)];
        e.respond(&mut s, u64::MAX).unwrap();
        let alive: Vec<f64> = s.iter().map(|s| s.values[1]).collect();
        assert_eq!(alive, vec![1.0, 1.0, 0.0, 0.0]);
        // One parameter: the radius or 0; bad radii are not plants.
        let mut s = vec![
            Sensor { position: DVec3::ZERO, values: vec![2.0] },
            Sensor { position: DVec3::X, values: vec![1.0] },
            Sensor { position: DVec3::ZERO, values: vec![f64::INFINITY] },
        ];
        e.respond(&mut s, u64::MAX).unwrap();
        assert_eq!([s[0].values[0], s[1].values[0], s[2].values[0]], [2.0, 0.0, 0.0]);
    }

    #[test]
    fn survivors_never_overlap_on_random_fields() {
        let e = Ecosystem { up: 2 };
        let mut seed = 12345u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20 {
            let mut s: Vec<Sensor> = (0..200)
                .map(|_| Sensor {
                    position: DVec3::new(next() * 20.0, next() * 20.0, next()),
                    values: vec![0.05 + next() * (if next() < 0.1 { 3.0 } else { 0.7 }), 0.0],
                })
                .collect();
            let before = s.clone();
            e.respond(&mut s, u64::MAX).unwrap();
            let live: Vec<usize> = (0..s.len()).filter(|&i| s[i].values[1] == 1.0).collect();
            let overlap = |i: usize, j: usize| {
                let (p, q) = (before[i].position, before[j].position);
                ((p.x - q.x).powi(2) + (p.y - q.y).powi(2)).sqrt() < before[i].values[0] + before[j].values[0]
            };
            for &i in &live {
                for &j in &live {
                    assert!(i == j || !overlap(i, j), "survivors {i} and {j} overlap");
                }
            }
            for i in 0..s.len() {
                let dominated = (0..s.len()).any(|j| {
                    j != i
                        && overlap(i, j)
                        && (before[j].values[0] > before[i].values[0]
                            || (before[j].values[0] == before[i].values[0] && j < i))
                });
                assert_eq!(s[i].values[1] == 0.0, dominated, "plant {i}");
            }
        }
        let mut pile: Vec<Sensor> = (0..300).map(|_| plant(0.0, 0.0, 1.0)).collect();
        assert!(e.respond(&mut pile, 1000).is_err());
    }
}
