//! cpfg surface files (`*.s`): bicubic Bézier patches drawn by `~id` modules.
//!
//! Part of the model-folder support of issue 3. The format is the one of vlab's
//! `bezieredit` and cpfg's `patches.c`:
//!
//! ```text
//! -1.50 1.50   -1.74 2.03   -0.61 1.00       bounding box: x min max, y min max, z min max
//! PRECISION S: 5 T: 5                          optional default subdivisions
//! CONTACT POINT  X: 0.02 Y: -1.66 Z: 0.00      the point placed at the turtle
//! END POINT  X: 0.00 Y: 0.00 Z: 0.00           where the turtle is left afterwards
//! HEADING  X: 0.00 Y: 1.00 Z: 0.00             the surface direction along the turtle's heading
//! UP  X: 0.00 Y: 0.00 Z: -1.00                 the surface direction along the turtle's up
//! SIZE: 1.00                                   the length that becomes 1 (times the view scale)
//! patch                                        then patches: a name,
//! TOP COLOR: 0 DIFFUSE: 0.00 BOTTOM COLOR: 0 DIFFUSE: 0.00   colours (optional),
//! AL: ~ A: ~ AR: ~                             neighbours above (optional; `~` = none),
//! L: ~ R: ~                                    left and right,
//! BL: ~ B: ~ BR: ~                             below,
//! -0.60 1.21 0.10  0.47 2.02 -0.61  …          and 16 control points x y z, 4 rows of 4
//! ```
//!
//! Tokens are separated by blanks and colons, so spacing does not matter; keywords are
//! matched case-insensitively. A truncated patch, a missing header line, a SIZE that is
//! not positive or HEADING and UP that are zero or parallel are errors located in the
//! file (cpfg silently drops a truncated patch). Neighbour names are kept; a neighbour
//! that names no patch is not an error here ([`Surface::neighbour_problems`] lists them;
//! cpfg refuses such a surface).
//!
//! # Frame
//!
//! Row `i` of the control points runs along the patch parameter s, column `j` along t:
//! P(s, t) = Σ B_i(s) B_j(t) P\[i\]\[j\] with the cubic Bernstein polynomials B.
//! [`Surface::tessellate`] returns the surface in its **local frame**:
//!
//! - the contact point is the origin and lengths are divided by SIZE;
//! - +Y is HEADING (normalized), +Z is UP made perpendicular to HEADING, and
//!   +X = HEADING × UP (cpfg's "left" vector). The frame is right-handed.
//!
//! A turtle at `position` with heading H and up U (unit vectors) places a local point
//! (x, y, z) at `position + scale·(x·(H × U) + y·H + z·U)` ([`place`]), where `scale`
//! is the view file's surface scale times the module's parameter. This is a rotation
//! (no mirroring), so face winding is kept. In cpfg's turtle H × U is its left vector L,
//! which is exactly cpfg's placement (`transform_end_point`). sylva's turtle has
//! H × L = U, so there H × U = −L: the local +X goes to the turtle's *right*. A turtle
//! that wants the exact mirror image of a cpfg model should instead send +X to its own
//! L and reverse the winding of the faces.
//!
//! cpfg maps a file point p to Σ (p − contact)ₖ·\[L, H, U\]ₖ (the transposed rotation of
//! the one above); the two agree whenever that matrix is symmetric, which is the case
//! for every surface in the vlab corpus; sylva uses the rotation that takes HEADING to
//! the turtle's heading and UP to its up, as the format intends.
//!
//! # Tessellation
//!
//! Each patch becomes an s × t grid of quads split into two triangles each, with
//! face-varying UVs (u, v) = (s, t) over the patch and unit normals from the analytic
//! derivatives, oriented like cpfg's (∂P/∂t × ∂P/∂s); faces are counter-clockwise seen
//! from that side. Where the derivatives vanish (collapsed patch edges, leaf tips) the
//! normal is taken slightly inside the patch. Along edges and corners declared as
//! neighbours whose vertices coincide, the vertices are shared and their normals
//! averaged (cpfg averages them too), so neighbouring patches shade smoothly.

use super::{number, tokens, TextFile};
use crate::geometry::{FaceVarying, Mesh};
use crate::input::excerpt;
use crate::lsystem::source::LsystemError;
use glam::{Vec2, Vec3};

/// Index of the above-left neighbour in [`Patch::neighbours`].
pub const ABOVE_LEFT: usize = 0;
/// Index of the above neighbour.
pub const ABOVE: usize = 1;
/// Index of the above-right neighbour.
pub const ABOVE_RIGHT: usize = 2;
/// Index of the left neighbour.
pub const LEFT: usize = 3;
/// Index of the right neighbour.
pub const RIGHT: usize = 4;
/// Index of the below-left neighbour.
pub const BELOW_LEFT: usize = 5;
/// Index of the below neighbour.
pub const BELOW: usize = 6;
/// Index of the below-right neighbour.
pub const BELOW_RIGHT: usize = 7;

/// The most subdivisions per patch side [`Surface::tessellate`] makes.
pub const MAX_SUBDIVISIONS: u32 = 256;

/// One bicubic Bézier patch of a surface file.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// The patch name.
    pub name: String,
    /// `TOP COLOR` index (0 when absent).
    pub top_color: i32,
    /// `TOP … DIFFUSE` factor.
    pub top_diffuse: f64,
    /// `BOTTOM COLOR` index.
    pub bottom_color: i32,
    /// `BOTTOM … DIFFUSE` factor.
    pub bottom_diffuse: f64,
    /// Neighbour patch names: AL, A, AR, L, R, BL, B, BR (see [`ABOVE_LEFT`] …); `None`
    /// for `~`.
    pub neighbours: [Option<String>; 8],
    /// Control points in file coordinates: `control[i][j]`, row i along s, column j along t.
    pub control: [[[f64; 3]; 4]; 4],
}

/// A cpfg surface: header and patches, in file coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Bounding box from the first line: \[x, y, z\] × \[min, max\].
    pub bounds: [[f64; 2]; 3],
    /// `PRECISION S: T:`, when given.
    pub precision: Option<[u32; 2]>,
    /// `CONTACT POINT`.
    pub contact: [f64; 3],
    /// `END POINT`.
    pub end: [f64; 3],
    /// `HEADING` as written.
    pub heading: [f64; 3],
    /// `UP` as written.
    pub up: [f64; 3],
    /// `SIZE` (positive).
    pub size: f64,
    /// The patches, in file order.
    pub patches: Vec<Patch>,
}

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn mul(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
fn normalize(a: V3) -> Option<V3> {
    let l = norm(a);
    (l > 0.0 && l.is_finite()).then(|| mul(a, 1.0 / l))
}

/// Orthonormal (H × U, H, U) from a heading and an up that need not be perpendicular.
fn frame(heading: V3, up: V3) -> Option<[V3; 3]> {
    let h = normalize(heading)?;
    let x = normalize(cross(h, up))?;
    let u = cross(x, h);
    Some([x, h, u])
}

/// Bernstein polynomials and their derivatives at s.
fn bernstein(s: f64) -> ([f64; 4], [f64; 4]) {
    let r = 1.0 - s;
    (
        [r * r * r, 3.0 * s * r * r, 3.0 * s * s * r, s * s * s],
        [-3.0 * r * r, 3.0 * r * r - 6.0 * s * r, 6.0 * s * r - 3.0 * s * s, 3.0 * s * s],
    )
}

/// Position and the derivatives along s and t of a patch.
fn eval_patch(c: &[[V3; 4]; 4], s: f64, t: f64) -> (V3, V3, V3) {
    let (bs, dbs) = bernstein(s);
    let (bt, dbt) = bernstein(t);
    let mut p = [0.0; 3];
    let mut ds = [0.0; 3];
    let mut dt = [0.0; 3];
    for i in 0..4 {
        for j in 0..4 {
            p = add(p, mul(c[i][j], bs[i] * bt[j]));
            ds = add(ds, mul(c[i][j], dbs[i] * bt[j]));
            dt = add(dt, mul(c[i][j], bs[i] * dbt[j]));
        }
    }
    (p, ds, dt)
}

/// The unit normal (∂t × ∂s) at (s, t), looking slightly inside the patch where the
/// derivatives vanish.
fn patch_normal(c: &[[V3; 4]; 4], s: f64, t: f64) -> V3 {
    let mut extent = 0.0f64;
    for row in c {
        for p in row {
            extent = extent.max(norm(sub(*p, c[0][0])));
        }
    }
    let tiny = 1e-12 * extent * extent;
    for delta in [0.0, 1e-4, 1e-3, 1e-2, 0.1, 0.5] {
        let (s1, t1) = (s + (0.5 - s) * delta, t + (0.5 - t) * delta);
        let (_, ds, dt) = eval_patch(c, s1, t1);
        let n = cross(dt, ds);
        let l = norm(n);
        if l > tiny && l.is_finite() {
            return mul(n, 1.0 / l);
        }
    }
    [0.0, 0.0, 1.0]
}

impl Surface {
    /// The local frame's axes in file coordinates: (+X, +Y, +Z) = (HEADING × UP,
    /// HEADING, UP ⟂ HEADING), unit length.
    pub fn axes(&self) -> [[f64; 3]; 3] {
        frame(self.heading, self.up).unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    }

    /// A file-coordinate point in the local frame (contact point at the origin, divided
    /// by SIZE, axes as in [`Surface::axes`]).
    pub fn to_local(&self, p: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = self.axes();
        let d = mul(sub(p, self.contact), 1.0 / self.size);
        [dot(d, x), dot(d, y), dot(d, z)]
    }

    /// The END POINT in the local frame: where cpfg moves the turtle after drawing.
    pub fn end_point(&self) -> [f64; 3] {
        self.to_local(self.end)
    }

    /// The control points of patch `p` in the local frame.
    pub fn local_control(&self, p: usize) -> Option<[[[f64; 3]; 4]; 4]> {
        let patch = self.patches.get(p)?;
        Some(patch.control.map(|row| row.map(|p| self.to_local(p))))
    }

    /// Position and unit normal of patch `p` at (s, t) ∈ \[0, 1\]², in the local frame.
    pub fn point(&self, p: usize, s: f64, t: f64) -> Option<([f64; 3], [f64; 3])> {
        let c = self.local_control(p)?;
        let (s, t) = (s.clamp(0.0, 1.0), t.clamp(0.0, 1.0));
        Some((eval_patch(&c, s, t).0, patch_normal(&c, s, t)))
    }

    /// Neighbour declarations that name no patch of the surface, or whose patch does
    /// not name this one back in the opposite direction (cpfg's consistency check).
    pub fn neighbour_problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        for p in &self.patches {
            for (n, name) in p.neighbours.iter().enumerate() {
                let Some(name) = name else { continue };
                match self.patches.iter().find(|q| q.name == *name) {
                    None => out.push(format!("{}: no neighbour patch {}", excerpt(&p.name), excerpt(name))),
                    Some(q) => {
                        if q.neighbours[7 - n].as_deref() != Some(p.name.as_str()) {
                            out.push(format!(
                                "{}: neighbour {} does not name it back",
                                excerpt(&p.name),
                                excerpt(name)
                            ));
                        }
                    }
                }
            }
        }
        out
    }

    /// Tessellates every patch into an `n` × `n` grid (two triangles per cell).
    pub fn tessellate(&self, n: u32) -> Mesh {
        self.tessellate_st(n, n)
    }

    /// Tessellates every patch into `s` × `t` cells (each clamped to
    /// 1..=[`MAX_SUBDIVISIONS`]), in the local frame (see the module documentation).
    pub fn tessellate_st(&self, s: u32, t: u32) -> Mesh {
        let ns = s.clamp(1, MAX_SUBDIVISIONS) as usize;
        let nt = t.clamp(1, MAX_SUBDIVISIONS) as usize;
        let per = (ns + 1) * (nt + 1);
        let id = |p: usize, i: usize, j: usize| p * per + i * (nt + 1) + j;
        let total = per * self.patches.len();
        let mut pos: Vec<V3> = Vec::with_capacity(total);
        let mut nor: Vec<V3> = Vec::with_capacity(total);
        let mut uv: Vec<Vec2> = Vec::with_capacity(total);
        for p in 0..self.patches.len() {
            let c = self.local_control(p).unwrap_or([[[0.0; 3]; 4]; 4]);
            for i in 0..=ns {
                for j in 0..=nt {
                    let (s, t) = (i as f64 / ns as f64, j as f64 / nt as f64);
                    pos.push(eval_patch(&c, s, t).0);
                    nor.push(patch_normal(&c, s, t));
                    uv.push(Vec2::new(s as f32, t as f32));
                }
            }
        }

        // Share vertices along declared neighbour edges where they coincide.
        let mut parent: Vec<usize> = (0..total).collect();
        fn find(parent: &mut [usize], mut a: usize) -> usize {
            while parent[a] != a {
                parent[a] = parent[parent[a]];
                a = parent[a];
            }
            a
        }
        let tol = 1e-6;
        let index_of = |name: &str| self.patches.iter().position(|q| q.name == name);
        for (p, patch) in self.patches.iter().enumerate() {
            for (dir, name) in patch.neighbours.iter().enumerate() {
                let Some(q) = name.as_deref().and_then(index_of) else { continue };
                let pairs: Vec<((usize, usize), (usize, usize))> = match dir {
                    ABOVE_LEFT => vec![((0, 0), (ns, nt))],
                    ABOVE => (0..=nt).map(|j| ((0, j), (ns, j))).collect(),
                    ABOVE_RIGHT => vec![((0, nt), (ns, 0))],
                    LEFT => (0..=ns).map(|i| ((i, 0), (i, nt))).collect(),
                    RIGHT => (0..=ns).map(|i| ((i, nt), (i, 0))).collect(),
                    BELOW_LEFT => vec![((ns, 0), (0, nt))],
                    BELOW => (0..=nt).map(|j| ((ns, j), (0, j))).collect(),
                    _ => vec![((ns, nt), (0, 0))],
                };
                for ((i1, j1), (i2, j2)) in pairs {
                    let (a, b) = (id(p, i1, j1), id(q, i2, j2));
                    if norm(sub(pos[a], pos[b])) <= tol {
                        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                        if ra != rb {
                            parent[ra.max(rb)] = ra.min(rb);
                        }
                    }
                }
            }
        }
        let mut compact = vec![u32::MAX; total];
        let mut positions = Vec::new();
        let mut normal_sums: Vec<V3> = Vec::new();
        let mut first_normal: Vec<V3> = Vec::new();
        let mut vertex_of = vec![0u32; total];
        for v in 0..total {
            let r = find(&mut parent, v);
            if compact[r] == u32::MAX {
                compact[r] = positions.len() as u32;
                positions.push(pos[r]);
                normal_sums.push([0.0; 3]);
                first_normal.push(nor[v]);
            }
            let k = compact[r];
            vertex_of[v] = k;
            normal_sums[k as usize] = add(normal_sums[k as usize], nor[v]);
        }
        let normals: Vec<Vec3> = normal_sums
            .iter()
            .zip(&first_normal)
            .map(|(sum, first)| {
                // Opposite normals cancel: keep the first one then.
                let n = normalize(*sum).unwrap_or(*first);
                Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32)
            })
            .collect();

        let mut mesh = Mesh::new();
        mesh.positions = positions.iter().map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)).collect();
        let mut uv_idx = Vec::new();
        let mut n_idx = Vec::new();
        for p in 0..self.patches.len() {
            for i in 0..ns {
                for j in 0..nt {
                    let a = id(p, i, j);
                    let b = id(p, i, j + 1);
                    let c = id(p, i + 1, j + 1);
                    let d = id(p, i + 1, j);
                    for tri in [[a, b, c], [a, c, d]] {
                        mesh.push_face(&[vertex_of[tri[0]], vertex_of[tri[1]], vertex_of[tri[2]]]);
                        uv_idx.extend(tri.iter().map(|&v| v as u32));
                        n_idx.extend(tri.iter().map(|&v| vertex_of[v]));
                    }
                }
            }
        }
        mesh.uvs = Some(FaceVarying { values: uv, indices: uv_idx });
        mesh.normals = Some(FaceVarying { values: normals, indices: n_idx });
        mesh
    }
}

/// Places a mesh in the local frame of a surface at a turtle: a local point (x, y, z)
/// goes to `position + scale·(x·(H × U) + y·H + z·U)`, with H = `heading` normalized and
/// U = `up` made perpendicular to it. Normals are rotated; with a negative `scale` the
/// mesh is point-mirrored and the face winding is reversed so faces stay front-facing.
/// When H and U are zero or parallel, H = +Y, U = +Z are used.
pub fn place(mesh: &Mesh, position: [f64; 3], heading: [f64; 3], up: [f64; 3], scale: f64) -> Mesh {
    let [x, h, u] = frame(heading, up).unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let rot = |v: Vec3| -> V3 {
        let v = [v.x as f64, v.y as f64, v.z as f64];
        add(add(mul(x, v[0]), mul(h, v[1])), mul(u, v[2]))
    };
    let f = |v: V3| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
    let mut out = mesh.clone();
    out.positions = mesh.positions.iter().map(|&p| f(add(position, mul(rot(p), scale)))).collect();
    if let Some(n) = out.normals.as_mut() {
        for v in n.values.iter_mut() {
            *v = f(rot(*v));
        }
    }
    if scale < 0.0 {
        // A point reflection through the origin has determinant −1: flip the winding.
        for fi in 0..out.face_count() {
            let r = out.corners(fi);
            out.face_indices[r.clone()].reverse();
            if let Some(uv) = out.uvs.as_mut() {
                uv.indices[r.clone()].reverse();
            }
            if let Some(n) = out.normals.as_mut() {
                n.indices[r].reverse();
            }
        }
    }
    out
}

/// A token cursor over a surface file.
struct Cursor<'a> {
    file: &'a TextFile,
    toks: Vec<(usize, &'a str)>,
    next: usize,
    end: usize,
}

impl<'a> Cursor<'a> {
    fn peek(&self) -> Option<&'a str> {
        self.toks.get(self.next).map(|(_, t)| *t)
    }

    fn peek_is(&self, kw: &str) -> bool {
        self.peek().map(|t| t.eq_ignore_ascii_case(kw)).unwrap_or(false)
    }

    fn here(&self) -> (usize, usize) {
        self.toks.get(self.next).map(|(o, t)| (*o, t.len())).unwrap_or((self.end, 1))
    }

    fn fail(&self, what: &str) -> Box<LsystemError> {
        let (at, len) = self.here();
        let found = match self.peek() {
            Some(t) => format!("found `{}`", excerpt(t)),
            None => "the file ends".to_string(),
        };
        self.file.error(at, len, &format!("expected {what}, {found}"), &format!("expected {what}"))
    }

    fn keyword(&mut self, kw: &str) -> Result<(), Box<LsystemError>> {
        if self.peek_is(kw) {
            self.next += 1;
            Ok(())
        } else {
            Err(self.fail(&format!("`{kw}`")))
        }
    }

    fn number(&mut self) -> Result<f64, Box<LsystemError>> {
        match self.peek().and_then(number) {
            Some(v) => {
                self.next += 1;
                Ok(v)
            }
            None => Err(self.fail("a number")),
        }
    }

    fn int(&mut self) -> Result<i32, Box<LsystemError>> {
        match self.peek().and_then(|t| t.parse::<i32>().ok()) {
            Some(v) => {
                self.next += 1;
                Ok(v)
            }
            None => Err(self.fail("an integer")),
        }
    }

    fn word(&mut self) -> Result<&'a str, Box<LsystemError>> {
        match self.peek() {
            Some(t) => {
                self.next += 1;
                Ok(t)
            }
            None => Err(self.fail("a name")),
        }
    }

    /// `X: x Y: y Z: z`
    fn xyz(&mut self) -> Result<V3, Box<LsystemError>> {
        self.keyword("X")?;
        let x = self.number()?;
        self.keyword("Y")?;
        let y = self.number()?;
        self.keyword("Z")?;
        let z = self.number()?;
        Ok([x, y, z])
    }

    fn neighbour(&mut self, kw: &str) -> Result<Option<String>, Box<LsystemError>> {
        self.keyword(kw)?;
        let w = self.word()?;
        Ok((w != "~").then(|| w.to_string()))
    }
}

/// Parses a cpfg surface file. `name` is used in error messages.
pub fn parse(name: &str, text: &str) -> Result<Surface, Box<LsystemError>> {
    let file = TextFile::new(name, text);
    let mut c = Cursor {
        file: &file,
        toks: tokens(text, 0, |ch| ch.is_whitespace() || ch == ':'),
        next: 0,
        end: text.len(),
    };
    let mut bounds = [[0.0; 2]; 3];
    for b in bounds.iter_mut() {
        b[0] = c.number()?;
        b[1] = c.number()?;
    }
    let precision = if c.peek_is("PRECISION") {
        c.next += 1;
        c.keyword("S")?;
        let s = c.int()?;
        c.keyword("T")?;
        let t = c.int()?;
        Some([s.max(1) as u32, t.max(1) as u32])
    } else {
        None
    };
    c.keyword("CONTACT")?;
    c.keyword("POINT")?;
    let contact = c.xyz()?;
    c.keyword("END")?;
    c.keyword("POINT")?;
    let end = c.xyz()?;
    let heading_at = c.here();
    c.keyword("HEADING")?;
    let heading = c.xyz()?;
    c.keyword("UP")?;
    let up = c.xyz()?;
    if frame(heading, up).is_none() {
        return Err(file.error(
            heading_at.0,
            heading_at.1,
            "HEADING and UP must be non-zero and not parallel",
            "degenerate frame",
        ));
    }
    let size_at = c.here();
    c.keyword("SIZE")?;
    let size = c.number()?;
    if size <= 0.0 {
        return Err(file.error(
            size_at.0,
            size_at.1,
            &format!("SIZE must be positive, found {size}"),
            "SIZE",
        ));
    }
    let mut patches = Vec::new();
    while c.peek().is_some() {
        let name = c.word()?.to_string();
        let mut patch = Patch {
            name,
            top_color: 0,
            top_diffuse: 0.0,
            bottom_color: 0,
            bottom_diffuse: 0.0,
            neighbours: Default::default(),
            control: [[[0.0; 3]; 4]; 4],
        };
        if c.peek_is("TOP") {
            c.next += 1;
            c.keyword("COLOR")?;
            patch.top_color = c.int()?;
            c.keyword("DIFFUSE")?;
            patch.top_diffuse = c.number()?;
            c.keyword("BOTTOM")?;
            c.keyword("COLOR")?;
            patch.bottom_color = c.int()?;
            c.keyword("DIFFUSE")?;
            patch.bottom_diffuse = c.number()?;
        }
        if c.peek_is("AL") {
            patch.neighbours[ABOVE_LEFT] = c.neighbour("AL")?;
            patch.neighbours[ABOVE] = c.neighbour("A")?;
            patch.neighbours[ABOVE_RIGHT] = c.neighbour("AR")?;
        }
        if c.peek_is("L") {
            patch.neighbours[LEFT] = c.neighbour("L")?;
            patch.neighbours[RIGHT] = c.neighbour("R")?;
        }
        if c.peek_is("BL") {
            patch.neighbours[BELOW_LEFT] = c.neighbour("BL")?;
            patch.neighbours[BELOW] = c.neighbour("B")?;
            patch.neighbours[BELOW_RIGHT] = c.neighbour("BR")?;
        }
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..3 {
                    patch.control[i][j][k] = c.number()?;
                }
            }
        }
        patches.push(patch);
    }
    if patches.is_empty() {
        return Err(file.error(text.len(), 1, "the surface has no patches", "end of file"));
    }
    Ok(Surface { bounds, precision, contact, end, heading, up, size, patches })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat unit square patch in the z = 0 plane, contact at the origin.
    fn flat(heading: &str, up: &str) -> String {
        let mut s = format!(
            "0 3 0 3 0 0\nCONTACT POINT X: 0 Y: 0 Z: 0\nEND POINT X: 0 Y: 3 Z: 0\nHEADING {heading}\nUP {up}\nSIZE: 3\nsq\n\
             TOP COLOR: 1 DIFFUSE: 0.5 BOTTOM COLOR: 2 DIFFUSE: 0.5\nAL: ~ A: ~ AR: ~\nL: ~ R: ~\nBL: ~ B: ~ BR: ~\n"
        );
        for i in 0..4 {
            for j in 0..4 {
                s += &format!("{} {} 0  ", i, j);
            }
            s += "\n";
        }
        s
    }

    #[test]
    fn flat_patch_gives_flat_mesh_with_interpolated_corners() {
        let surf = parse("sq.s", &flat("X: 0 Y: 1 Z: 0", "X: 0 Y: 0 Z: 1")).unwrap();
        assert_eq!(surf.patches[0].top_color, 1);
        let m = surf.tessellate(4);
        m.validate().unwrap();
        assert_eq!(m.face_count(), 2 * 16);
        assert!(m.positions.iter().all(|p| p.z.abs() < 1e-6));
        // Corners (file (0,0,0), (3,0,0), (0,3,0), (3,3,0)) divided by SIZE 3; the local
        // frame is X = H × U = +X, Y = +Y, Z = +Z here.
        for corner in [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ] {
            assert!(m.positions.iter().any(|p| (*p - corner).length() < 1e-6), "{corner}");
        }
        let n = m.normals.as_ref().unwrap();
        assert!(n.values.iter().all(|v| (v.z.abs() - 1.0).abs() < 1e-6));
        assert_eq!(surf.end_point(), [0.0, 1.0, 0.0]);
    }

    #[test]
    fn frame_maps_heading_to_y_and_up_to_z() {
        // Heading along file +X, up along file +Z: file +X becomes local +Y.
        let surf = parse("sq.s", &flat("X: 1 Y: 0 Z: 0", "X: 0 Y: 0 Z: 1")).unwrap();
        let l = surf.to_local([3.0, 0.0, 0.0]);
        assert!((l[0]).abs() < 1e-12 && (l[1] - 1.0).abs() < 1e-12 && l[2].abs() < 1e-12, "{l:?}");
        let l = surf.to_local([0.0, 0.0, 3.0]);
        assert!((l[2] - 1.0).abs() < 1e-12, "{l:?}");
        // H × U = X × Z = −Y: file +Y becomes local −X.
        let l = surf.to_local([0.0, 3.0, 0.0]);
        assert!((l[0] + 1.0).abs() < 1e-12, "{l:?}");
    }

    #[test]
    fn faces_wind_counter_clockwise_around_the_normal() {
        let surf = parse("sq.s", &flat("X: 0 Y: 1 Z: 0", "X: 0 Y: 0 Z: 1")).unwrap();
        let m = surf.tessellate(3);
        let n = m.normals.as_ref().unwrap();
        for f in 0..m.face_count() {
            let v = m.face(f);
            let (a, b, c) =
                (m.positions[v[0] as usize], m.positions[v[1] as usize], m.positions[v[2] as usize]);
            let geo = (b - a).cross(c - a);
            let corner = m.corners(f).start;
            assert!(geo.dot(n.values[n.indices[corner] as usize]) > 0.0);
        }
    }

    #[test]
    fn placing_keeps_shape() {
        let surf = parse("sq.s", &flat("X: 0 Y: 1 Z: 0", "X: 0 Y: 0 Z: 1")).unwrap();
        let m = surf.tessellate(2);
        let placed = place(&m, [1.0, 2.0, 3.0], [0.0, 0.0, 2.0], [1.0, 0.0, 0.0], 2.0);
        placed.validate().unwrap();
        // Local +Y (the heading) goes to world +Z, scaled by 2.
        let tip = placed.positions.iter().map(|p| p.z).fold(f32::MIN, f32::max);
        assert!((tip - 5.0).abs() < 1e-5);
    }

    #[test]
    fn errors_are_located() {
        let e = parse("b.s", "0 1 0 1 0 1\nCONTACT POINT X: 0 Y: 0 Z: 0\nEND POINT X: 0 Y: 0\n").unwrap_err();
        assert!(e.message.contains("expected `Z`"), "{}", e.message);
        let text = flat("X: 0 Y: 1 Z: 0", "X: 0 Y: 2 Z: 0");
        let e = parse("b.s", &text).unwrap_err();
        assert!(e.message.starts_with("b.s:4:1"), "{}", e.message);
        let text = flat("X: 0 Y: 1 Z: 0", "X: 0 Y: 0 Z: 1");
        let cut = &text[..text.len() - 20];
        let e = parse("b.s", cut).unwrap_err();
        assert!(e.message.contains("the file ends"), "{}", e.message);
    }

    #[test]
    fn truncations_and_garbage_do_not_panic() {
        let text = flat("X: 0 Y: 1 Z: 0", "X: 0 Y: 0 Z: 1");
        for k in 0..text.len() {
            if text.is_char_boundary(k) {
                if let Ok(s) = parse("t.s", &text[..k]) {
                    s.tessellate(2).validate().unwrap();
                }
            }
        }
        for g in ["", ":::", "1 2 3 4 5 6 PRECISION S: x", "nan nan nan nan nan nan", "é ü"] {
            let _ = parse("g.s", g);
        }
    }
}
