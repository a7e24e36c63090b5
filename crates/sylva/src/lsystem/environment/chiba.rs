//! `chiba`: the fraction of sky light each leaf intercepts, shaded by the other leaves
//! (after Chiba, Ohshima, Takenaka et al., "Visual simulation of botanical trees based
//! on virtual heliotropism and dormancy break", 1994, whose trees grow towards the light
//! each bud receives from a discretised sky).
//!
//! Every `?E(x, …)` module is a leaf: a sphere centred at its turtle position, of
//! radius the module's second parameter when it has one that is a positive finite
//! number, else `leaf radius:` (spec; default 0.5; the recipe's
//! `generator.environment.radius` overrides it).
//!
//! The sky is `directions: n` directions (default 32, at most [`MAX_DIRECTIONS`]) on the
//! upper hemisphere around the `up axis:` (default `y`, cpfg's default heading), spread
//! evenly over its solid angle by a Fibonacci spiral: direction k (k = 0 … n−1) has
//! cos θ = 1 − (k + ½)/n from the up axis and azimuth k × 137.508° (the golden angle),
//! measured from the first of the other two axes (x for up = y or z, y for up = x)
//! towards the second. Each direction carries the same share of light (a uniform
//! overcast sky).
//!
//! A leaf at p receives from direction d the product of the `transmittance:` (spec;
//! default 0, opaque; the recipe overrides it) of every *other* leaf whose sphere the
//! ray p + t·d, t > 0, passes through: a sphere of centre c and radius ρ is hit when
//! p lies inside it (|c − p| < ρ), or when (c − p)·d > 0 and the ray passes closer
//! than ρ to c. The answer, written into the first parameter, is the mean over the
//! directions, in \[0, 1\]: 1 for an exposed leaf, less under other leaves. A leaf at a
//! non-finite position gets 0 and shades nothing.
//!
//! Work: per leaf, one unit per other leaf (to keep those above its horizon) and one per
//! direction and kept leaf tested; so O(n² × directions) for n leaves, bounded by the
//! budget.

use super::{Overrides, Sensor, Spec, Work};
use glam::DVec3;

/// The spec-file keys `chiba` reads.
pub const KEYS: &[&str] = &["directions", "leaf radius", "transmittance", "up axis", "verbose"];

/// The most sky directions.
pub const MAX_DIRECTIONS: usize = 4096;

/// Default number of sky directions.
pub const DEFAULT_DIRECTIONS: usize = 32;

/// Default leaf radius, model units.
pub const DEFAULT_LEAF_RADIUS: f64 = 0.5;

/// `chiba`'s settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Chiba {
    /// The sky directions (unit vectors).
    pub directions: Vec<DVec3>,
    /// The leaf radius of modules without their own.
    pub leaf_radius: f64,
    /// The fraction of light a leaf lets through.
    pub transmittance: f64,
    /// The up axis (0 x, 1 y, 2 z).
    pub up: usize,
}

/// `n` directions on the hemisphere around axis `up` (see the module documentation).
pub fn sky(n: usize, up: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let (a, b) = match up {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    (0..n)
        .map(|k| {
            let c = 1.0 - (k as f64 + 0.5) / n as f64;
            let s = (1.0 - c * c).max(0.0).sqrt();
            let phi = k as f64 * golden;
            let mut v = [0.0; 3];
            v[up] = c;
            v[a] = s * phi.cos();
            v[b] = s * phi.sin();
            DVec3::from_array(v)
        })
        .collect()
}

impl Chiba {
    /// Settings from the spec file and the recipe's overrides.
    pub fn configure(spec: &Spec, over: &Overrides) -> Result<Chiba, String> {
        let whole = |n: f64| n >= 1.0 && n <= MAX_DIRECTIONS as f64 && n.fract() == 0.0;
        let mut n = spec.number_or(
            "directions",
            DEFAULT_DIRECTIONS as f64,
            whole,
            &format!("expected a whole number from 1 to {MAX_DIRECTIONS}"),
        )?;
        if let Some(d) = over.directions {
            if !whole(d) {
                return Err(format!(
                    "chiba: directions must be a whole number from 1 to {MAX_DIRECTIONS}, got {d}"
                ));
            }
            n = d;
        }
        let mut leaf_radius = spec.number_or(
            "leaf radius",
            DEFAULT_LEAF_RADIUS,
            |r| r > 0.0,
            "the leaf radius must be positive",
        )?;
        if let Some(r) = over.radius {
            if !(r.is_finite() && r > 0.0) {
                return Err(format!("chiba: radius must be a positive number, got {r}"));
            }
            leaf_radius = r;
        }
        let transmittance = super::transmittance(spec, over, 0.0, "chiba")?;
        let up = super::axis(spec, "up axis", 1)?;
        Ok(Chiba { directions: sky(n as usize, up), leaf_radius, transmittance, up })
    }

    /// Answers the sensors (see the module documentation).
    pub fn respond(&self, sensors: &mut [Sensor], work: u64) -> Result<u64, u64> {
        let mut w = Work::new(work);
        let radius = |s: &Sensor| match s.values.get(1) {
            Some(&r) if r.is_finite() && r > 0.0 => r,
            _ => self.leaf_radius,
        };
        let leaves: Vec<Option<(DVec3, f64)>> =
            sensors.iter().map(|s| s.position.is_finite().then(|| (s.position, radius(s)))).collect();
        let mut up = DVec3::ZERO;
        up[self.up] = 1.0;
        let mut answers = Vec::with_capacity(sensors.len());
        let mut above: Vec<(DVec3, f64)> = Vec::new();
        for (i, leaf) in leaves.iter().enumerate() {
            w.add(1)?;
            let Some((p, _)) = *leaf else {
                answers.push(0.0);
                continue;
            };
            // The other leaves that can be hit by an upward ray: above p's horizon.
            w.add(leaves.len() as u64)?;
            above.clear();
            for (j, other) in leaves.iter().enumerate() {
                if let Some((c, r)) = *other {
                    let v = c - p;
                    if j != i && v.is_finite() && v.dot(up) > -r {
                        above.push((v, r));
                    }
                }
            }
            let mut total = 0.0;
            for d in &self.directions {
                w.add(above.len() as u64 + 1)?;
                let mut light = 1.0;
                for &(v, r) in &above {
                    let b = v.dot(*d);
                    let inside = v.length_squared() < r * r;
                    if inside || (b > 0.0 && v.length_squared() - b * b < r * r) {
                        light *= self.transmittance;
                        if light == 0.0 {
                            break;
                        }
                    }
                }
                total += light;
            }
            let n = self.directions.len().max(1) as f64;
            answers.push((total / n).clamp(0.0, 1.0));
        }
        for (s, a) in sensors.iter_mut().zip(answers) {
            super::answer(&mut s.values, 0, a);
        }
        Ok(w.used)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf(x: f64, y: f64, r: f64) -> Sensor {
        Sensor { position: DVec3::new(x, y, 0.0), values: vec![0.0, r] }
    }

    #[test]
    fn sky_directions_are_unit_and_upward() {
        for up in 0..3 {
            let d = sky(64, up);
            assert_eq!(d.len(), 64);
            assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-12 && v[up] > 0.0));
            let mean = d.iter().copied().sum::<DVec3>() / 64.0;
            assert!((mean[up] - 0.5).abs() < 0.01, "uniform over the hemisphere: mean height ½");
        }
    }

    #[test]
    fn a_leaf_under_another_gets_less_light() {
        let c = Chiba::configure(&Spec::parse("c.spec", "directions: 64\n"), &Overrides::default()).unwrap();
        let mut s = vec![leaf(0.0, 0.0, 0.5), leaf(0.0, 2.0, 1.5), leaf(10.0, 10.0, 0.5)];
        c.respond(&mut s, u64::MAX).unwrap();
        let (under, top, open) = (s[0].values[0], s[1].values[0], s[2].values[0]);
        assert_eq!(open, 1.0);
        assert_eq!(top, 1.0, "nothing above the top leaf");
        assert!(under < 0.9 && under > 0.0, "{under}");
        // A translucent canopy lets some through.
        let t = Chiba::configure(
            &Spec::parse("c.spec", "directions: 64\ntransmittance: 0.5\n"),
            &Overrides::default(),
        )
        .unwrap();
        let mut s2 = vec![leaf(0.0, 0.0, 0.5), leaf(0.0, 2.0, 1.5)];
        t.respond(&mut s2, u64::MAX).unwrap();
        assert!(s2[0].values[0] > under && s2[0].values[0] < 1.0);
    }

    #[test]
    fn settings_errors_and_budget() {
        for bad in [
            "directions: 0\n",
            "directions: 2.5\n",
            "leaf radius: -1\n",
            "transmittance: 3\n",
            "up axis: w\n",
        ] {
            let e = Chiba::configure(&Spec::parse("c.spec", bad), &Overrides::default()).unwrap_err();
            assert!(e.contains("c.spec:1:"), "{e}");
        }
        let c = Chiba::configure(&Spec::parse("c.spec", ""), &Overrides::default()).unwrap();
        let mut pile: Vec<Sensor> = (0..100).map(|i| leaf(0.0, i as f64, 0.5)).collect();
        assert!(c.respond(&mut pile, 10_000).is_err());
    }
}
