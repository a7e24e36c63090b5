//! Fractal noise displacement between subdivision levels (MacMurchy2004 §6.5 "Fractal Noise",
//! Figs 6.7–6.8; MacMurchy2004-spec §2.13; issue 4 item 8).
//!
//! MacMurchy2004 adapts Miller's method to Loop subdivision: after each subdivision step `i`
//! (the coarse mesh, `i = 0`, is never perturbed) every vertex moves along its normal by
//! a Gaussian amount with standard deviation
//!
//! ```text
//! S = k · L^(−iH) · Bias(b, t),      Bias(b, t) = t^(−ln b / ln 2)
//! ```
//!
//! with `k` a scale from the mesh size, `L` the lacunarity, `H ∈ [0, 1]` the fractal
//! dimension, and Perlin's bias function of a per-vertex feature size `t ∈ [0, 1]` (1 at
//! the base of the tree, smaller on younger branches; `b = 0.5` is linear, a result of 0
//! means no noise). The seed does not say how `t` is obtained; [`FeatureSize`] offers a
//! constant, a fall-off with height, or values given per control vertex (for instance
//! multiplied by the child/parent radius ratio at each branching, MacMurchy2004-spec's inference),
//! which are refined with the mesh.
//!
//! The random numbers come from a `Pcg64` seeded from `(seed, level)` and are drawn in
//! vertex order, so a fixed seed gives bit-identical output. Normals are the area-weighted
//! smooth normals of the level being displaced.

use super::{Corner, RefineError, Refiner, SubdivideOptions, Topology};
use crate::geometry::Mesh;
use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// The per-vertex feature size `t` of the bias function.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum FeatureSize {
    /// `t = 1` everywhere (uniform noise; the bias has no effect).
    #[default]
    Uniform,
    /// `t = 1` at the lowest point (the base, smallest y) falling linearly to `top` at
    /// the highest: an age proxy for a tree grown along +y.
    Height {
        /// `t` at the top, in \[0, 1\].
        top: f32,
    },
    /// One `t` per vertex of the mesh being displaced (for [`subdivide_with_noise`]: per
    /// control vertex; refined with the mesh by the same rules).
    PerVertex(Vec<f32>),
}

/// Noise parameters (MacMurchy2004 §6.5).
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseOptions {
    /// Scale `k` in the mesh's units (metres): the standard deviation at `i = 0`.
    pub k: f32,
    /// Lacunarity `L` (> 0; 2 halves the feature size per level with `H = 1`).
    pub lacunarity: f32,
    /// Fractal dimension `H` in \[0, 1\]: larger is smoother (faster decay per level).
    pub h: f32,
    /// Bias `b` in \[0, 1\] of Perlin's bias function (0.5 is linear in `t`).
    pub bias: f32,
    /// How `t` is found per vertex.
    pub feature: FeatureSize,
}

impl Default for NoiseOptions {
    /// `k = 0.01`, `L = 2`, `H = 0.5`, `b = 0.5`, uniform `t`.
    fn default() -> Self {
        NoiseOptions { k: 0.01, lacunarity: 2.0, h: 0.5, bias: 0.5, feature: FeatureSize::Uniform }
    }
}

impl NoiseOptions {
    /// Checks the ranges: `k ≥ 0`, `L > 0`, `H, b ∈ [0, 1]`, every `t ∈ [0, 1]`, all finite.
    pub fn validate(&self) -> Result<(), RefineError> {
        let bad = |what: &str, v: f32, range: &str| {
            Err(RefineError::InvalidOption(format!("noise {what} must be {range}, got {v}")))
        };
        if !(self.k.is_finite() && self.k >= 0.0) {
            return bad("scale k", self.k, "a finite number ≥ 0");
        }
        if !(self.lacunarity.is_finite() && self.lacunarity > 0.0) {
            return bad("lacunarity L", self.lacunarity, "a finite number > 0");
        }
        if !(0.0..=1.0).contains(&self.h) {
            return bad("fractal dimension H", self.h, "in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.bias) {
            return bad("bias b", self.bias, "in [0, 1]");
        }
        match &self.feature {
            FeatureSize::Height { top } if !(0.0..=1.0).contains(top) => {
                bad("feature size at the top", *top, "in [0, 1]")
            }
            FeatureSize::PerVertex(t) => match t.iter().find(|t| !(0.0..=1.0).contains(*t)) {
                Some(&x) => bad("feature size t", x, "in [0, 1]"),
                None => Ok(()),
            },
            _ => Ok(()),
        }
    }

    /// The standard deviation at level `i` before the bias: `S = k · L^(−iH)`.
    pub fn sigma(&self, level: u32) -> f32 {
        self.k * self.lacunarity.powf(-(level as f32) * self.h)
    }
}

/// Perlin's bias function `Bias(b, t) = t^(−ln b / ln 2)` on \[0, 1\]: `Bias(b, 0) = 0`,
/// `Bias(b, 1) = 1`, `Bias(0.5, t) = t`. Arguments are clamped to \[0, 1\] (NaN gives 0).
pub fn bias(b: f32, t: f32) -> f32 {
    let (b, t) = (clamp01(b), clamp01(t));
    if t <= 0.0 {
        return 0.0;
    }
    if t >= 1.0 {
        return 1.0;
    }
    if b <= 0.0 {
        return 0.0; // exponent +∞
    }
    t.powf(-b.ln() / std::f32::consts::LN_2)
}

fn clamp01(x: f32) -> f32 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// A standard normal sample (Box–Muller, one value per call).
fn gaussian(rng: &mut Pcg64) -> f32 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random::<f64>();
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
}

/// The random stream of one level.
fn level_rng(seed: u64, level: u32) -> Pcg64 {
    Pcg64::seed_from_u64(seed ^ (level as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// Area-weighted smooth vertex normals of the faces `face(f)`, `f < faces`.
fn vertex_normals<'a>(positions: &[Vec3], faces: usize, face: impl Fn(usize) -> &'a [u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for f in 0..faces {
        let vs = face(f);
        let mut fnorm = Vec3::ZERO;
        for (i, &a) in vs.iter().enumerate() {
            let b = vs[(i + 1) % vs.len()];
            fnorm += positions[a as usize].cross(positions[b as usize]);
        }
        for &v in vs {
            n[v as usize] += fnorm;
        }
    }
    n.iter_mut().for_each(|x| *x = x.normalize_or_zero());
    n
}

/// Moves every vertex along `normals` by `S(level) · Bias(b, t(v)) · N(0, 1)`.
fn displace_positions(
    positions: &mut [Vec3],
    normals: &[Vec3],
    level: u32,
    opts: &NoiseOptions,
    seed: u64,
    t: impl Fn(usize, Vec3) -> f32,
) {
    if level == 0 {
        return; // i starts at 1: the coarse mesh is never perturbed
    }
    let sigma = opts.sigma(level);
    if sigma.is_nan() || sigma <= 0.0 || sigma.is_infinite() {
        return;
    }
    let mut rng = level_rng(seed, level);
    for (i, p) in positions.iter_mut().enumerate() {
        let g = gaussian(&mut rng); // drawn for every vertex: the stream is position-independent
        let s = sigma * bias(opts.bias, t(i, *p));
        *p += normals[i] * (s * g);
    }
}

/// A `t(vertex, position)` function for the feature-size rule, with `y` measured in
/// `y_range` (the control mesh's, so that every level agrees).
fn feature_fn<'a>(
    feature: &'a FeatureSize,
    y_range: (f32, f32),
    per_vertex: Option<&'a [f32]>,
) -> impl Fn(usize, Vec3) -> f32 + 'a {
    move |i, p| match feature {
        FeatureSize::Uniform => 1.0,
        FeatureSize::Height { top } => {
            let (lo, hi) = y_range;
            let s = if hi > lo { ((p.y - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.0 };
            1.0 + (top - 1.0) * s
        }
        FeatureSize::PerVertex(_) => per_vertex.and_then(|t| t.get(i)).copied().unwrap_or(1.0),
    }
}

fn y_range(positions: &[Vec3]) -> (f32, f32) {
    positions.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| (lo.min(p.y), hi.max(p.y)))
}

/// Displaces `mesh` as subdivision level `level` (1 after the first step; level 0 leaves
/// the mesh unchanged) along its smooth vertex normals; see the [module docs](self).
/// Deterministic for a given `seed`. Face-varying normals of `mesh`, if any, are left as
/// they are (recompute them if needed).
///
/// ```
/// use sylva::refine::noise::{displace, NoiseOptions};
/// # use sylva::Mesh; use glam::Vec3;
/// let mut m = Mesh::new();
/// m.positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
/// m.push_face(&[0, 1, 2]);
/// let before = m.clone();
/// displace(&mut m, 1, &NoiseOptions { k: 0.1, ..Default::default() }, 7).unwrap();
/// assert!(m.positions.iter().zip(&before.positions).all(|(a, b)| (a.x, a.y) == (b.x, b.y)));
/// assert_ne!(m, before); // moved along ±z only
/// ```
pub fn displace(mesh: &mut Mesh, level: u32, opts: &NoiseOptions, seed: u64) -> Result<(), RefineError> {
    mesh.validate().map_err(RefineError::InvalidMesh)?;
    opts.validate()?;
    let per_vertex = match &opts.feature {
        FeatureSize::PerVertex(t) if t.len() != mesh.vertex_count() => {
            return Err(RefineError::WrongLength {
                what: "noise feature sizes",
                expected: mesh.vertex_count(),
                got: t.len(),
            })
        }
        FeatureSize::PerVertex(t) => Some(t.as_slice()),
        _ => None,
    };
    let normals = vertex_normals(&mesh.positions, mesh.face_count(), |f| mesh.face(f));
    let range = y_range(&mesh.positions);
    let t = feature_fn(&opts.feature, range, per_vertex);
    displace_positions(&mut mesh.positions, &normals, level, opts, seed, t);
    Ok(())
}

/// [`subdivide`](super::subdivide) with fractal noise applied after every level
/// (levels `1 … N`, MacMurchy2004 §6.5), then the optional limit projection and UVs as in
/// `subdivide`. With `noise.k == 0` the result equals `subdivide`'s exactly.
pub fn subdivide_with_noise(
    mesh: &Mesh,
    corners: &[Corner],
    options: &SubdivideOptions,
    noise: &NoiseOptions,
    seed: u64,
) -> Result<Mesh, RefineError> {
    mesh.validate().map_err(RefineError::InvalidMesh)?;
    noise.validate()?;
    if let FeatureSize::PerVertex(t) = &noise.feature {
        if t.len() != mesh.vertex_count() {
            return Err(RefineError::WrongLength {
                what: "noise feature sizes",
                expected: mesh.vertex_count(),
                got: t.len(),
            });
        }
    }
    if mesh.face_count() == 0 {
        let mut out = mesh.clone();
        out.normals = None;
        return Ok(out);
    }
    let mut ro = options.refine.clone();
    ro.full_last_level |= options.limit;
    let refiner = Refiner::new(mesh, corners, &ro)?;
    let range = y_range(&mesh.positions);
    let mut cur = mesh.positions.clone();
    let mut t_cur: Option<Vec<f32>> = match &noise.feature {
        FeatureSize::PerVertex(t) => Some(t.clone()),
        _ => None,
    };
    for l in 0..refiner.levels() {
        let child: &Topology = refiner.level(l + 1);
        let mut next = vec![Vec3::ZERO; child.vertex_count()];
        refiner.interpolate_level(l, &cur, &mut next);
        if let Some(t) = &t_cur {
            let mut tn = vec![0.0f32; child.vertex_count()];
            refiner.interpolate_level(l, t, &mut tn);
            t_cur = Some(tn);
        }
        if noise.k > 0.0 {
            let normals = vertex_normals(&next, child.face_count(), |f| child.face(f));
            let t = feature_fn(&noise.feature, range, t_cur.as_deref());
            displace_positions(&mut next, &normals, l as u32 + 1, noise, seed, t);
        }
        cur = next;
    }
    let mut normals = None;
    if options.limit {
        normals = Some(refiner.limit_normals(&cur)?);
        cur = refiner.limit(&cur)?;
    }
    let mut out = refiner.finest_mesh(cur);
    out.normals = normals;
    if let Some(uvs) = &mesh.uvs {
        let fvr = refiner.face_varying(&uvs.indices, options.uv)?;
        out.uvs = Some(fvr.interpolate(&uvs.values)?);
    }
    Ok(out)
}
