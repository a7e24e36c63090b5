//! `clover`: light from above over a field, shaded by leaves (Měch & Prusinkiewicz 96,
//! §7, clover on a terrain under trees).
//!
//! The field is a grid in the x–y plane (z is up: the corpus clover creeps in the x–y
//! plane and lifts its leaves with `^(90)`): `grid position: x0 y0` is its corner,
//! `grid range: w h` its extent in model units and `grid size: nx ny` its cells (the
//! corpus writes `100x100`; text after the numbers is ignored with a note). Each cell
//! has the intensity of the light falling on it from above: the `input image:`
//! (SGI `.rgb` or PNG, [`super::image`]) resampled to the grid by nearest pixel (pixel
//! rows bottom to top along y), or 1 everywhere when no image is given or the file is
//! missing (with a note).
//!
//! The corpus model `plant.l` uses three kinds of modules, told apart by arity and
//! first parameter:
//!
//! - `?E(1, la)`: a new leaf of area `la` above its turtle position: the environment
//!   registers a shading disc of radius √(la/π) (the model's own leaf length
//!   `len = sqrt(la/3.14)`), covering the cells whose centres lie in the disc and always
//!   the cell under the disc's centre. The model deletes the module one step later
//!   (`?E(t,la) --> *`), so the environment remembers the leaf: the program keeps state
//!   between exchanges, as cpfg's memory-communicating clover does;
//! - `?E(2, la)`: the leaf of area `la` at this position dies (`L(la,a,rn) : a==0 -->
//!   ?E(2,la)`): its disc is removed (cell counts never go below 0);
//! - `?E(r)` (one parameter, or none): an apex asks for the light: the answer, written
//!   into the first parameter, is `I × transmittance^k` with `I` the cell's intensity
//!   and `k` the number of leaf discs covering the cell (`transmittance:` in \[0, 1\],
//!   default 0.1). The model grows an internode when the answer is at least `MinLight`.
//!   Outside the grid (or at a non-finite position) the answer is 0: the field ends
//!   there.
//!
//! Other two-parameter modules are left unanswered. In each exchange all leaf
//! registrations and removals (in string order) come before the light queries, so an
//! apex sees the leaves of the same step. Heights are not compared: the leaves stand
//! above the creeping stolons, so every registered leaf shades the ground below it.
//!
//! Work: one unit per sensor and one per grid cell a leaf's disc covers (its bounding
//! box, clipped to the grid). The grid has at most [`MAX_CELLS`] cells.

use super::image::{self, Intensity};
use super::{Overrides, Sensor, Spec, Work};
use crate::input::{excerpt, SideFiles};
use std::sync::{Arc, Mutex};

/// The spec-file keys `clover` reads.
pub const KEYS: &[&str] =
    &["grid position", "grid range", "grid size", "input image", "transmittance", "verbose"];

/// The most grid cells (2²⁴: a 4096 × 4096 grid).
pub const MAX_CELLS: usize = 1 << 24;

/// Default leaf transmittance.
pub const DEFAULT_TRANSMITTANCE: f64 = 0.1;

/// `clover`'s settings and its memory of registered leaves.
#[derive(Debug, Clone, PartialEq)]
pub struct Clover {
    /// The grid's corner (x, y).
    pub origin: [f64; 2],
    /// The grid's extent (x, y), model units.
    pub range: [f64; 2],
    /// The number of cells along x and y.
    pub size: [usize; 2],
    /// The light per cell (`size[0] × size[1]`, row `j` along y at `j × size[0]`);
    /// `None`: 1 everywhere.
    pub light: Option<Arc<Vec<f32>>>,
    /// The fraction of light a leaf lets through.
    pub transmittance: f64,
    leaves: Memory,
}

/// Leaf counts per cell, kept between exchanges (empty until the first leaf).
struct Memory(Mutex<Vec<u32>>);

impl Memory {
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<u32>> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl Clone for Memory {
    fn clone(&self) -> Memory {
        Memory(Mutex::new(self.lock().clone()))
    }
}

impl PartialEq for Memory {
    /// The memory is state, not configuration: it does not take part in comparisons.
    fn eq(&self, _: &Memory) -> bool {
        true
    }
}

impl std::fmt::Debug for Memory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let covered = self.lock().iter().filter(|&&c| c > 0).count();
        write!(f, "Memory({covered} shaded cells)")
    }
}

impl Clover {
    /// Settings from the spec file and the recipe's overrides; the image is read from
    /// the model folder `files` (confined to it, [`SideFiles`]). A missing image is a
    /// note (uniform light), a broken or refused one an error.
    pub fn configure(
        spec: &Spec,
        over: &Overrides,
        files: &SideFiles,
        notes: &mut Vec<String>,
    ) -> Result<Clover, String> {
        let mut pair = |key: &str, default: [f64; 2]| -> Result<[f64; 2], String> {
            let Some(e) = spec.get(key) else { return Ok(default) };
            let (v, rest) = spec.numbers(e, 2)?;
            if let Some(rest) = rest {
                notes.push(format!("{}:{}: `{}` after the {key} ignored", spec.file, e.line, excerpt(&rest)));
            }
            Ok([v[0], v[1]])
        };
        let origin = pair("grid position", [-50.0, -50.0])?;
        let range = pair("grid range", [100.0, 100.0])?;
        let size = pair("grid size", [256.0, 256.0])?;
        if !(range[0] > 0.0 && range[1] > 0.0) {
            let e = spec.get("grid range").map(|e| spec.error(e, "the range must be positive"));
            return Err(e.unwrap_or_else(|| "clover: the grid range must be positive".into()));
        }
        if !(size[0] >= 1.0 && size[1] >= 1.0 && size[0].fract() == 0.0 && size[1].fract() == 0.0)
            || size[0] * size[1] > MAX_CELLS as f64
        {
            let why = format!("the grid size must be whole numbers ≥ 1 with at most {MAX_CELLS} cells");
            let e = spec.get("grid size").map(|e| spec.error(e, &why));
            return Err(e.unwrap_or_else(|| format!("clover: {why}")));
        }
        let size = [size[0] as usize, size[1] as usize];
        let transmittance = super::transmittance(spec, over, DEFAULT_TRANSMITTANCE, "clover")?;
        let image = match (&over.image, spec.get("input image")) {
            (Some(name), _) => Some((name.clone(), "`generator.environment.image`".to_string())),
            (None, Some(e)) => Some((e.value.clone(), format!("{}:{}: `input image:`", spec.file, e.line))),
            (None, None) => None,
        };
        let light = match image {
            None => None,
            Some((name, at)) => {
                let path = files.resolve(&name, &at).map_err(|e| e.to_string())?;
                if path.exists() {
                    let bytes = files.read(&path, &at).map_err(|e| e.to_string())?;
                    let img = image::decode(&bytes).map_err(|why| format!("{}: {why}", path.display()))?;
                    Some(Arc::new(resample(&img, size)))
                } else {
                    notes.push(format!(
                        "clover: the input image {} is missing: uniform full light (1) over the whole grid",
                        excerpt(&name)
                    ));
                    None
                }
            }
        };
        Ok(Clover { origin, range, size, light, transmittance, leaves: Memory(Mutex::new(Vec::new())) })
    }

    /// Forgets the registered leaves.
    pub fn reset(&self) {
        self.leaves.lock().clear();
    }

    /// The grid cell (i, j) holding (x, y), `None` outside the grid or non-finite.
    fn cell(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        let u = (x - self.origin[0]) / self.range[0] * self.size[0] as f64;
        let v = (y - self.origin[1]) / self.range[1] * self.size[1] as f64;
        let inside = |t: f64, n: usize| t.is_finite() && t >= 0.0 && t < n as f64;
        (inside(u, self.size[0]) && inside(v, self.size[1])).then_some((u as usize, v as usize))
    }

    /// The light at cell (i, j) before shading.
    fn intensity(&self, i: usize, j: usize) -> f64 {
        match &self.light {
            Some(l) => l[j * self.size[0] + i] as f64,
            None => 1.0,
        }
    }

    /// Adds (`delta` = +1) or removes (−1) a leaf disc of area `area` at (x, y).
    fn shade(
        &self,
        counts: &mut Vec<u32>,
        x: f64,
        y: f64,
        area: f64,
        add: bool,
        w: &mut Work,
    ) -> Result<(), u64> {
        let Some((ci, cj)) = self.cell(x, y) else { return Ok(()) };
        if counts.is_empty() {
            counts.resize(self.size[0] * self.size[1], 0);
        }
        let rho = if area.is_finite() && area > 0.0 { (area / std::f64::consts::PI).sqrt() } else { 0.0 };
        let (dx, dy) = (self.range[0] / self.size[0] as f64, self.range[1] / self.size[1] as f64);
        // Cells whose centre x0 + (i + ½)dx lies within [x − ρ, x + ρ], clipped to the grid.
        let span = |c: f64, o: f64, d: f64, n: usize| -> (usize, usize) {
            let lo = ((c - rho - o) / d - 0.5).ceil().clamp(0.0, (n - 1) as f64);
            let hi = ((c + rho - o) / d - 0.5).floor().clamp(0.0, (n - 1) as f64);
            (lo as usize, hi as usize)
        };
        let (i0, i1) = span(x, self.origin[0], dx, self.size[0]);
        let (j0, j1) = span(y, self.origin[1], dy, self.size[1]);
        let touch = |c: &mut u32| *c = if add { c.saturating_add(1) } else { c.saturating_sub(1) };
        touch(&mut counts[cj * self.size[0] + ci]);
        if i0 > i1 || j0 > j1 {
            return Ok(());
        }
        w.add(((i1 - i0 + 1) as u64).saturating_mul((j1 - j0 + 1) as u64))?;
        for j in j0..=j1 {
            for i in i0..=i1 {
                if (i, j) == (ci, cj) {
                    continue;
                }
                let px = self.origin[0] + (i as f64 + 0.5) * dx - x;
                let py = self.origin[1] + (j as f64 + 0.5) * dy - y;
                if px * px + py * py <= rho * rho {
                    touch(&mut counts[j * self.size[0] + i]);
                }
            }
        }
        Ok(())
    }

    /// Answers the sensors (see the module documentation).
    pub fn respond(&self, sensors: &mut [Sensor], work: u64) -> Result<u64, u64> {
        let mut w = Work::new(work);
        let mut counts = self.leaves.lock();
        let mut next = counts.clone();
        for s in sensors.iter() {
            w.add(1)?;
            if let [kind, area, ..] = s.values[..] {
                let (x, y) = (s.position.x, s.position.y);
                if kind == 1.0 || kind == 2.0 {
                    self.shade(&mut next, x, y, area, kind == 1.0, &mut w)?;
                }
            }
        }
        for s in sensors.iter_mut() {
            if s.values.len() >= 2 {
                continue;
            }
            let light = match self.cell(s.position.x, s.position.y) {
                None => 0.0,
                Some((i, j)) => {
                    let k = next.get(j * self.size[0] + i).copied().unwrap_or(0);
                    self.intensity(i, j) * self.transmittance.powi(k.min(i32::MAX as u32) as i32)
                }
            };
            super::answer(&mut s.values, 0, light);
        }
        *counts = next;
        Ok(w.used)
    }
}

/// The image resampled to the grid by nearest pixel.
fn resample(img: &Intensity, size: [usize; 2]) -> Vec<f32> {
    let mut out = Vec::with_capacity(size[0] * size[1]);
    for j in 0..size[1] {
        let y = ((j as f64 + 0.5) / size[1] as f64 * img.height as f64) as usize;
        for i in 0..size[0] {
            let x = ((i as f64 + 0.5) / size[0] as f64 * img.width as f64) as usize;
            out.push(img.at(x, y));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn clover(spec: &str) -> Clover {
        Clover::configure(
            &Spec::parse("e.spec", spec),
            &Overrides::default(),
            &SideFiles::new(std::path::Path::new("."), &[], u64::MAX),
            &mut Vec::new(),
        )
        .unwrap()
    }

    fn at(x: f64, y: f64, values: Vec<f64>) -> Sensor {
        Sensor { position: DVec3::new(x, y, 0.0), values }
    }

    #[test]
    fn leaves_shade_until_they_die() {
        let c = clover("grid position: 0 0\ngrid range: 10x10junk\ngrid size: 10 10\ntransmittance: 0.5\n");
        let mut s = vec![at(5.5, 5.5, vec![1.0]), at(1.5, 1.5, vec![1.0]), at(20.0, 0.0, vec![1.0])];
        c.respond(&mut s, u64::MAX).unwrap();
        assert_eq!(
            [s[0].values[0], s[1].values[0], s[2].values[0]],
            [1.0, 1.0, 0.0],
            "full light; outside 0"
        );
        // Two leaves register over (5.5, 5.5): light ×0.25 there, and the apex at 1.5 is not covered.
        let area = std::f64::consts::PI * 1.2 * 1.2;
        let mut s =
            vec![at(5.5, 5.5, vec![1.0, area]), at(5.0, 5.0, vec![1.0, area]), at(5.5, 5.5, vec![1.0])];
        c.respond(&mut s, u64::MAX).unwrap();
        assert_eq!(s[2].values[0], 0.25);
        assert_eq!(s[0].values, vec![1.0, area], "leaf modules are not answered");
        // The memory lasts: the next exchange without leaf modules still sees them.
        let mut q = vec![at(5.5, 5.5, vec![1.0]), at(1.5, 1.5, vec![1.0])];
        c.respond(&mut q, u64::MAX).unwrap();
        assert_eq!([q[0].values[0], q[1].values[0]], [0.25, 1.0]);
        // One leaf dies.
        let mut s = vec![at(5.5, 5.5, vec![2.0, area]), at(5.5, 5.5, vec![7.0])];
        c.respond(&mut s, u64::MAX).unwrap();
        assert_eq!(s[1].values[0], 0.5);
        c.reset();
        let mut q = vec![at(5.5, 5.5, vec![1.0])];
        c.respond(&mut q, u64::MAX).unwrap();
        assert_eq!(q[0].values[0], 1.0, "reset forgets the leaves");
    }

    #[test]
    fn budget_bad_values_and_missing_image() {
        let c = clover("grid size: 1000 1000\n");
        let mut s = vec![at(0.0, 0.0, vec![1.0, 1e6])];
        assert!(c.respond(&mut s, 1000).is_err(), "a huge leaf exceeds a small budget");
        let mut s = vec![at(0.0, 0.0, vec![1.0, 1e300]), at(0.0, 0.0, vec![1.0])];
        c.respond(&mut s, u64::MAX).unwrap();
        assert_eq!(s[1].values[0], 0.1, "a leaf as large as the field covers it, clipped");
        for (bad, why) in [
            ("grid size: 0 4\n", "grid size"),
            ("grid size: 100000 100000\n", "grid size"),
            ("grid range: -1 1\n", "range"),
            ("transmittance: 2\n", "[0, 1]"),
            ("grid position: 1\n", "2 numbers"),
        ] {
            let e = Clover::configure(
                &Spec::parse("e.spec", bad),
                &Overrides::default(),
                &SideFiles::new(std::path::Path::new("."), &[], u64::MAX),
                &mut vec![],
            )
            .unwrap_err();
            assert!(e.contains("e.spec:1:") && e.contains(why), "{bad}: {e}");
        }
        let mut notes = Vec::new();
        let c = Clover::configure(
            &Spec::parse("e.spec", "input image: no-such-light.rgb\n"),
            &Overrides::default(),
            &SideFiles::new(std::path::Path::new("."), &[], u64::MAX),
            &mut notes,
        )
        .unwrap();
        assert!(c.light.is_none() && notes[0].contains("no-such-light.rgb"), "{notes:?}");
    }

    #[test]
    fn the_image_lights_the_grid() {
        // 2×1 image: left half dark (0.2), right half bright (1).
        let img = Intensity { width: 2, height: 1, values: vec![0.2, 1.0] };
        let c = Clover {
            light: Some(Arc::new(resample(&img, [4, 4]))),
            ..clover("grid position: 0 0\ngrid range: 4 4\ngrid size: 4 4\n")
        };
        let mut s = vec![at(0.5, 3.5, vec![1.0]), at(3.5, 0.5, vec![1.0])];
        c.respond(&mut s, u64::MAX).unwrap();
        assert_eq!([s[0].values[0], s[1].values[0]], [0.2f32 as f64, 1.0]);
    }
}
