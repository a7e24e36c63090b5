//! Bark UVs per mesher (issue 23): how long the UV seams are and how much the texture
//! stretches, measured on the refined bark of one tree, and `textures.scale`.
//!
//! Seam: the mesh edges whose two faces give either end a different UV (the texture
//! jumps there), as a share of every edge's length. Stretch: per triangle, the singular
//! values σ₁ ≥ σ₂ of the map from UV to the surface (metres per UV unit); σ₁/σ₂ is 1 for
//! square texels. `cargo test -p sylva --test bark_uvs -- --nocapture` prints the table
//! that docs/textures.md records.

use std::collections::HashMap;

fn bark(preset: &str, sets: &[(&str, &str)]) -> sylva::Mesh {
    let sets: Vec<(String, toml::Value)> = sets
        .iter()
        .map(|(k, v)| (k.to_string(), v.parse::<toml::Value>().unwrap_or(toml::Value::String(v.to_string()))))
        .collect();
    let loaded = sylva::recipe::load(preset, &sets).unwrap();
    let grown = sylva::pipeline::grow(&loaded).unwrap();
    grown.model.parts.into_iter().find(|p| p.name == "bark").unwrap().mesh
}

/// (seam share of the edge length, area-weighted median σ₁/σ₂, share of the area with
/// σ₁/σ₂ ≤ 1.5).
fn measure(m: &sylva::Mesh) -> (f64, f64, f64) {
    let uv = m.uvs.as_ref().expect("bark has UVs");
    // Undirected edge → the (uv at a, uv at b) of each face using it, ends ordered.
    let mut edges: HashMap<(u32, u32), Vec<(glam::Vec2, glam::Vec2)>> = HashMap::new();
    let (mut area, mut square) = (0.0f64, 0.0f64);
    let mut ratios: Vec<(f64, f64)> = Vec::new();
    for f in 0..m.face_count() {
        let c = m.corners(f);
        let k = c.len();
        for i in 0..k {
            let (ca, cb) = (c.start + i, c.start + (i + 1) % k);
            let (a, b) = (m.face_indices[ca], m.face_indices[cb]);
            let (ua, ub) = (uv.indices[ca], uv.indices[cb]);
            let (ta, tb) = (uv.values[ua as usize], uv.values[ub as usize]);
            let key = if a < b { ((a, b), (ta, tb)) } else { ((b, a), (tb, ta)) };
            edges.entry(key.0).or_default().push(key.1);
        }
        // Fan triangles of the face.
        for t in 1..k - 1 {
            let idx = [c.start, c.start + t, c.start + t + 1];
            let p = idx.map(|i| m.positions[m.face_indices[i] as usize].as_dvec3());
            let q = idx.map(|i| uv.values[uv.indices[i] as usize].as_dvec2());
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            let (d1, d2) = (q[1] - q[0], q[2] - q[0]);
            let det = d1.x * d2.y - d1.y * d2.x;
            let a = 0.5 * e1.cross(e2).length();
            if det.abs() < 1e-14 || a < 1e-14 {
                continue;
            }
            // dP/du and dP/dv.
            let pu = (e1 * d2.y - e2 * d1.y) / det;
            let pv = (e2 * d1.x - e1 * d2.x) / det;
            let (g11, g12, g22) = (pu.dot(pu), pu.dot(pv), pv.dot(pv));
            let tr = g11 + g22;
            let disc = ((g11 - g22).powi(2) + 4.0 * g12 * g12).sqrt();
            let (s1, s2) = (((tr + disc) / 2.0).sqrt(), ((tr - disc) / 2.0).max(0.0).sqrt());
            if s2.is_nan() || s2 <= 0.0 {
                continue;
            }
            let r = s1 / s2;
            area += a;
            ratios.push((r, a));
            if r <= 1.5 {
                square += a;
            }
        }
    }
    let (mut all, mut seam) = (0.0f64, 0.0f64);
    for ((a, b), uses) in &edges {
        let len = (m.positions[*a as usize] - m.positions[*b as usize]).length() as f64;
        all += len;
        let jump = |x: &(glam::Vec2, glam::Vec2)| (x.0 - uses[0].0).length().max((x.1 - uses[0].1).length());
        if uses.iter().any(|u| jump(u) > 1e-5) {
            seam += len;
        }
    }
    ratios.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut acc = 0.0;
    let median = ratios.iter().find(|(_, a)| {
        acc += a;
        acc >= 0.5 * area
    });
    (seam / all, median.map_or(f64::NAN, |m| m.0), square / area)
}

#[test]
fn bark_uv_seams_and_stretch_per_mesher() {
    println!("| mesher | seam share of edge length | median σ₁/σ₂ (by area) | area with σ₁/σ₂ ≤ 1.5 |");
    println!("|---|---|---|---|");
    let mut rows = Vec::new();
    for method in ["tube", "hull", "sweep", "quad"] {
        let m = bark("lsys-honda-a", &[("mesh.method", method)]);
        let (seam, aniso, square) = measure(&m);
        println!("| {method} | {:.1} % | {aniso:.2} | {:.1} % |", 100.0 * seam, 100.0 * square);
        assert!(seam.is_finite() && aniso.is_finite() && aniso >= 1.0, "{method}");
        rows.push((method, seam, aniso, square));
    }
    // Every mesher keeps texels near square on most of its area (v scaled to the distance
    // around a branch): taper makes the tube's and quad's u unit shrink toward a tip
    // while v's stays the axis base's.
    for &(method, _, median, square) in &rows[..] {
        assert!(
            median < 1.5 && square > 0.6,
            "{method}: median σ₁/σ₂ {median:.2}, {:.1} % within 1.5",
            100.0 * square
        );
    }
    // The sweep's reflected u and texel v have no seam at all.
    assert!(rows[2].1 < 0.01, "sweep seam {:.2} %", 100.0 * rows[2].1);
}

#[test]
fn texture_scale_multiplies_the_bark_uvs() {
    let one = bark("lsys-honda-c", &[]);
    let two = bark("lsys-honda-c", &[("textures.scale", "2.0")]);
    let (a, b) = (one.uvs.unwrap(), two.uvs.unwrap());
    assert_eq!(a.indices, b.indices);
    assert!(a.values.iter().zip(&b.values).all(|(x, y)| (*x * 2.0 - *y).length() < 1e-5));
    let e = sylva::recipe::load("lsys-honda-c", &[("textures.scale".into(), toml::Value::Float(0.0))])
        .unwrap_err()
        .to_string();
    assert!(e.contains("textures.scale"), "{e}");
}
