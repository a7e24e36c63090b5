//! The crown volume as a region to sample (Runions2007 §4): analytic shapes and a closed
//! OBJ mesh, with uniform rejection sampling and inside tests (ray parity along +X over a
//! (y, z) grid of triangles, shared edges and vertices counted once).

use super::params::bad;
use super::Envelope;
use crate::error::{Error, Result};
use glam::DVec3;
use rand::RngExt;
use rand_pcg::Pcg64;

/// Most sampling attempts per requested point for a mesh envelope before giving up.
const MESH_ATTEMPTS_PER_POINT: usize = 1000;

/// A region points can be sampled in and tested against.
pub(super) enum Region {
    Sphere { c: DVec3, r: f64 },
    Ellipsoid { c: DVec3, r: DVec3 },
    Cone { b: f64, h: f64, r: f64 },
    Cylinder { b: f64, h: f64, r: f64 },
    Mesh(MeshRegion),
}

impl Region {
    pub(super) fn new(env: &Envelope, read: &dyn Fn(&str) -> Result<(String, String)>) -> Result<Region> {
        Ok(match *env {
            Envelope::Sphere { center_height, radius } => {
                Region::Sphere { c: DVec3::new(0.0, center_height, 0.0), r: radius }
            }
            Envelope::Ellipsoid { center_height, radii } => {
                Region::Ellipsoid { c: DVec3::new(0.0, center_height, 0.0), r: DVec3::from_array(radii) }
            }
            Envelope::Cone { base_height, height, radius } => {
                Region::Cone { b: base_height, h: height, r: radius }
            }
            Envelope::Cylinder { base_height, height, radius } => {
                Region::Cylinder { b: base_height, h: height, r: radius }
            }
            Envelope::Mesh { ref file } => {
                let (name, text) = read(file)?;
                Region::Mesh(MeshRegion::parse(&name, &text)?)
            }
        })
    }

    /// Axis-aligned bounds (min, max).
    pub(super) fn bounds(&self) -> (DVec3, DVec3) {
        match self {
            Region::Sphere { c, r } => (*c - DVec3::splat(*r), *c + DVec3::splat(*r)),
            Region::Ellipsoid { c, r } => (*c - *r, *c + *r),
            Region::Cone { b, h, r } | Region::Cylinder { b, h, r } => {
                (DVec3::new(-r, *b, -r), DVec3::new(*r, b + h, *r))
            }
            Region::Mesh(m) => (m.lo, m.hi),
        }
    }

    pub(super) fn contains(&self, p: DVec3) -> bool {
        match self {
            Region::Sphere { c, r } => (p - *c).length_squared() <= r * r,
            Region::Ellipsoid { c, r } => ((p - *c) / *r).length_squared() <= 1.0,
            Region::Cone { b, h, r } => {
                let t = (p.y - b) / h;
                (0.0..=1.0).contains(&t) && (p.x * p.x + p.z * p.z).sqrt() <= r * (1.0 - t)
            }
            Region::Cylinder { b, h, r } => p.y >= *b && p.y <= b + h && p.x * p.x + p.z * p.z <= r * r,
            Region::Mesh(m) => m.contains(p),
        }
    }

    /// `n` points uniformly inside the region, by rejection in its bounding box.
    pub(super) fn sample(&self, n: usize, rng: &mut Pcg64) -> Result<Vec<DVec3>> {
        let (lo, hi) = self.bounds();
        let span = hi - lo;
        let mut out = Vec::with_capacity(n);
        let limit = match self {
            Region::Mesh(_) => n.saturating_mul(MESH_ATTEMPTS_PER_POINT).max(1_000_000),
            _ => usize::MAX, // analytic shapes accept ≥ π/12 of their box
        };
        let mut attempts = 0usize;
        while out.len() < n {
            if attempts >= limit {
                return bad(
                    "envelope.file",
                    format!(
                        "encloses too little of its bounding box: {} of {n} points inside after \
                         {attempts} tries (is the mesh closed?)",
                        out.len()
                    ),
                );
            }
            attempts += 1;
            let u = DVec3::new(rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>());
            let p = lo + span * u;
            if self.contains(p) {
                out.push(p);
            }
        }
        Ok(out)
    }
}

/// A closed mesh with a (y, z) grid of triangles for ray-parity inside tests along +X.
pub(super) struct MeshRegion {
    tris: Vec<[DVec3; 3]>,
    lo: DVec3,
    hi: DVec3,
    cells: (usize, usize),
    /// CSR: triangles overlapping grid cell `j * cells.0 + i` (i along y, j along z).
    offsets: Vec<u32>,
    items: Vec<u32>,
}

impl MeshRegion {
    pub(super) fn parse(name: &str, text: &str) -> Result<MeshRegion> {
        let obj = crate::mesh::obj_read::parse_obj(text)
            .map_err(|e| Error::Recipe(format!("`generator.envelope.file` {name}: {e}")))?;
        let m = &obj.mesh;
        let mut tris = Vec::new();
        for f in 0..m.face_count() {
            let face = m.face(f);
            for k in 1..face.len().saturating_sub(1) {
                let v = [face[0], face[k], face[k + 1]];
                if v.iter().any(|&i| i as usize >= m.positions.len()) {
                    return bad("envelope.file", format!("{name}: face {f} has a bad vertex index"));
                }
                let t = v.map(|i| m.positions[i as usize].as_dvec3());
                if t.iter().all(|p| p.is_finite()) {
                    tris.push(t);
                }
            }
        }
        if tris.len() < 4 {
            return bad(
                "envelope.file",
                format!("{name}: a closed envelope needs at least 4 triangles, got {}", tris.len()),
            );
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &tris {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let span = hi - lo;
        if !(span.x > 0.0 && span.y > 0.0 && span.z > 0.0) {
            return bad(
                "envelope.file",
                format!("{name}: the mesh is flat (bounds {lo} to {hi}); it must enclose a volume"),
            );
        }
        let side = ((tris.len() as f64).sqrt().ceil() as usize).clamp(1, 256);
        let cells = (side, side);
        let cell_of = |y: f64, z: f64| {
            let i = (((y - lo.y) / span.y) * side as f64).floor().clamp(0.0, (side - 1) as f64) as usize;
            let j = (((z - lo.z) / span.z) * side as f64).floor().clamp(0.0, (side - 1) as f64) as usize;
            (i, j)
        };
        let mut counts = vec![0u32; side * side + 1];
        let ranges: Vec<((usize, usize), (usize, usize))> = tris
            .iter()
            .map(|t| {
                let (ymin, ymax) = (t[0].y.min(t[1].y).min(t[2].y), t[0].y.max(t[1].y).max(t[2].y));
                let (zmin, zmax) = (t[0].z.min(t[1].z).min(t[2].z), t[0].z.max(t[1].z).max(t[2].z));
                (cell_of(ymin, zmin), cell_of(ymax, zmax))
            })
            .collect();
        for &((i0, j0), (i1, j1)) in &ranges {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    counts[j * side + i + 1] += 1;
                }
            }
        }
        for k in 0..side * side {
            counts[k + 1] += counts[k];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[side * side] as usize];
        for (t, &((i0, j0), (i1, j1))) in ranges.iter().enumerate() {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let slot = &mut fill[j * side + i];
                    items[*slot as usize] = t as u32;
                    *slot += 1;
                }
            }
        }
        Ok(MeshRegion { tris, lo, hi, cells, offsets: counts, items })
    }

    /// Ray parity along +X, with rays through shared edges and vertices counted once.
    pub(super) fn contains(&self, p: DVec3) -> bool {
        if p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return false;
        }
        let span = self.hi - self.lo;
        let (sy, sz) = self.cells;
        let i = (((p.y - self.lo.y) / span.y) * sy as f64).floor().clamp(0.0, (sy - 1) as f64) as usize;
        let j = (((p.z - self.lo.z) / span.z) * sz as f64).floor().clamp(0.0, (sz - 1) as f64) as usize;
        let c = j * sy + i;
        let mut inside = false;
        for &t in &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize] {
            let [a, b, d] = self.tris[t as usize];
            // Edge functions of (p.y, p.z) in the triangle's (y, z) projection.
            let e = |u: DVec3, v: DVec3| (v.y - u.y) * (p.z - u.z) - (v.z - u.z) * (p.y - u.y);
            let (w0, w1, w2) = (e(b, d), e(d, a), e(a, b));
            let area = w0 + w1 + w2;
            if area == 0.0 {
                continue;
            }
            // A ray through a shared edge or vertex must cross exactly one of the
            // triangles there: a zero edge function counts as inside only for edges
            // pointing +z (or +y when horizontal), i.e. the point is symbolically moved
            // by (−ε, ε²) in (y, z). Edges are taken counter-clockwise.
            let s = area.signum();
            let counts = |w: f64, u: DVec3, v: DVec3| {
                let (w, dy, dz) = (w * s, (v.y - u.y) * s, (v.z - u.z) * s);
                w > 0.0 || (w == 0.0 && (dz > 0.0 || (dz == 0.0 && dy > 0.0)))
            };
            if !(counts(w0, b, d) && counts(w1, d, a) && counts(w2, a, b)) {
                continue;
            }
            let x = (w0 * a.x + w1 * b.x + w2 * d.x) / area;
            if x > p.x {
                inside = !inside;
            }
        }
        inside
    }
}
