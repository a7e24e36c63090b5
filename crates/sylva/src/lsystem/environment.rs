//! Environmental programs: what answers cpfg's `?E` communication modules (open
//! L-systems).
//!
//! Issue 3 (cpfg models) and the open L-systems of Měch & Prusinkiewicz, "Visual
//! models of plants interacting with their environment" (SIGGRAPH 96), which the cpfg
//! corpus's `07-Open` and `20-EnviroPgms` models use. In cpfg the environment is a
//! separate process started from the model's `.e` file (`executable: honda81 …`):
//! after every derivation step cpfg interprets the string, sends each `?E(x, …)`
//! module's turtle position and parameters to it, and writes the answers back into the
//! module's parameters before the next step. sylva runs the same exchange in-process
//! (see `LSystem::derive_full`) with the programs built in here.
//!
//! # `honda81`: competition for space
//!
//! Named after Honda, Tomlinson & Fisher (1981), whose tree model resolves collisions
//! between branch tips by their vigor. The vlab program's parameter file is not in the
//! corpus, so sylva's version is defined by what the models' descriptions say it does:
//!
//! - every `?E(v, …)` module is a sensor at its turtle position with vigor `v` (its first
//!   parameter, 0 when it has none);
//! - two sensors *collide* when their distance is below `radius` (model units);
//! - a sensor that collides with nothing gets 1 ("grow"); a colliding sensor gets 1 only
//!   when its vigor is strictly greater than the vigor of every sensor it collides with,
//!   else 0 ("don't grow"). Equal vigors therefore stop each other: the deterministic
//!   Sierpinski model's tips annihilate in pairs, which is Pascal's triangle mod 2;
//! - the answer replaces the first parameter; other parameters are left alone.
//!
//! The neighbour search is a uniform hash grid with cells of size `radius`, so one
//! exchange costs O(n) for n sensors at bounded density.

use glam::DVec3;
use std::collections::HashMap;

/// Programs sylva has built in, by the name a cpfg `.e` file's `executable:` gives.
pub const PROGRAMS: &[&str] = &["honda81"];

/// Default collision radius of `honda81`, in model units (a unit turtle step is 1).
pub const DEFAULT_RADIUS: f64 = 0.5;

/// An environmental program answering `?E` modules.
#[derive(Debug, Clone, PartialEq)]
pub enum Environment {
    /// Collision between sensors, resolved by vigor (see the module documentation).
    Honda81 {
        /// Sensors closer than this collide.
        radius: f64,
    },
}

/// One `?E` module as the environment sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Turtle position at the module.
    pub position: DVec3,
    /// The module's parameters; the environment overwrites the ones it answers.
    pub values: Vec<f64>,
}

impl Environment {
    /// The program called `name` (as in a `.e` file's `executable:` line, path and
    /// arguments removed), with `radius` where the program uses one. `Err` names the
    /// programs sylva has.
    pub fn by_name(name: &str, radius: Option<f64>) -> Result<Environment, String> {
        match name {
            "honda81" => {
                let radius = radius.unwrap_or(DEFAULT_RADIUS);
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(format!("honda81: radius must be a positive number, got {radius}"));
                }
                Ok(Environment::Honda81 { radius })
            }
            other => Err(format!(
                "environmental program `{other}` is not built into sylva (it has: {})",
                PROGRAMS.join(", ")
            )),
        }
    }

    /// Answers every sensor: writes the program's responses into `sensors[i].values`.
    pub fn respond(&self, sensors: &mut [Sensor]) {
        let _ = self.respond_within(sensors, u64::MAX);
    }

    /// [`Environment::respond`] doing at most `work` units of work (one per neighbour
    /// tested, one per sensor): `Ok(work done)`, or `Err(work)` when that was not enough
    /// (sensors piled up in one place make the neighbour search quadratic), with the
    /// sensors left unanswered.
    pub fn respond_within(&self, sensors: &mut [Sensor], work: u64) -> Result<u64, u64> {
        match *self {
            Environment::Honda81 { radius } => honda81(sensors, radius, work),
        }
    }
}

/// The grid cell of `p`; coordinates beyond ±2⁶² cells are clamped (the cell index of a
/// far-away sensor must not overflow when its neighbours are visited).
fn cell(p: DVec3, size: f64) -> (i64, i64, i64) {
    const FAR: f64 = (1u64 << 62) as f64;
    let c = (p / size).floor().clamp(DVec3::splat(-FAR), DVec3::splat(FAR));
    (c.x as i64, c.y as i64, c.z as i64)
}

fn honda81(sensors: &mut [Sensor], radius: f64, work: u64) -> Result<u64, u64> {
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, s) in sensors.iter().enumerate() {
        if s.position.is_finite() {
            grid.entry(cell(s.position, radius)).or_default().push(i);
        }
    }
    let vigor = |s: &Sensor| s.values.first().copied().unwrap_or(0.0);
    let r2 = radius * radius;
    let mut used = 0u64;
    let mut answers: Vec<f64> = Vec::with_capacity(sensors.len());
    for (i, s) in sensors.iter().enumerate() {
        used = used.saturating_add(1);
        if used > work {
            return Err(work);
        }
        if !s.position.is_finite() {
            answers.push(0.0);
            continue;
        }
        let (cx, cy, cz) = cell(s.position, radius);
        let v = vigor(s);
        let mut answer = 1.0;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = (cx.wrapping_add(dx), cy.wrapping_add(dy), cz.wrapping_add(dz));
                    let Some(list) = grid.get(&key) else { continue };
                    used = used.saturating_add(list.len() as u64);
                    if used > work {
                        return Err(work);
                    }
                    for &j in list {
                        if j != i
                            && sensors[j].position.distance_squared(s.position) < r2
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
        match s.values.first_mut() {
            Some(x) => *x = a,
            None => s.values.push(a),
        }
    }
    Ok(used)
}

#[cfg(test)]
mod tests {
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
    fn unknown_programs_and_bad_radii_are_errors() {
        let e = Environment::by_name("clover", None).unwrap_err();
        assert!(e.contains("`clover`") && e.contains("honda81"), "{e}");
        assert!(Environment::by_name("honda81", Some(0.0)).is_err());
        assert!(Environment::by_name("honda81", Some(f64::NAN)).is_err());
    }
}
