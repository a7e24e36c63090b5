//! POV-Ray 3.7 writer (MacMurchy2004 §7.1 and §A.3–A.4; MacMurchy2004-spec §1 item 5): one include
//! file per mesh plus a scene that renders as it is.
//!
//! `-o plant.pov` writes, beside it, `plant_<part>.inc` for every part with faces (the
//! seed's "each mesh in its own include file"), each declaring one `mesh2` with
//! `vertex_vectors`, `normal_vectors` and `uv_vectors` and their `face_indices`,
//! `normal_indices` and `uv_indices` (the engine's UVs and normals are face-varying, so
//! every triangle indexes its corners' own normal and UV). Polygons are triangulated as
//! fans from their first corner (the meshers' faces are convex). A part without normals
//! gets smooth area-weighted ones per position, as the OBJ writer gives it.
//!
//! `plant.pov` is a complete scene: `#version 3.7`, `assumed_gamma 1.0`, a sky-gradient
//! `sky_sphere`, a camera that frames the model's bounds from azimuth 30°, elevation 15°
//! (40° field of view, the preview's framing), a sun from over the camera's left shoulder
//! with a weak fill light, and one `object` per part with its material: the base colour
//! (linear RGB, transmit from alpha below 1), or, with texture files, an `image_map` of
//! the material's base-colour PNG with `uv_mapping` (leaf cards: the PNG's alpha cuts
//! the outline, which POV-Ray reads as transmit). Normal and ORM maps are not written:
//! POV-Ray's `bump_map` takes heights, not tangent-space normals.
//!
//! Coordinates: POV-Ray is left-handed with +Y up; the engine is right-handed with +Y up,
//! so every position and normal is written as `<x, y, −z>` — the picture is the model
//! as any right-handed viewer shows it, not its mirror image.
//!
//! Like OBJ, POV-Ray cannot instance the engine's way: instanced organs are written
//! merged ([`Model::flattened`]); levels of detail, the rig and its clip are ignored.
//! Identifiers are `SY_<part>` with anything but ASCII letters, digits and `_` made `_`
//! and cut to 32 characters (POV-Ray's limit is 40); clashing names get `_2`, `_3`….

use super::GENERATOR;
use crate::geometry::Mesh;
use crate::model::{Material, Model};
use glam::Vec3;
use std::io::Write;

/// The scene camera's azimuth and elevation, degrees (the CPU preview's default view).
pub const VIEW_DEG: (f32, f32) = (30.0, 15.0);

/// The scene camera's horizontal field of view, degrees.
pub const FOV_DEG: f32 = 40.0;

/// One include file: the identifier it declares and the part it holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Include {
    /// The file name, relative to the scene (`plant_bark.inc`).
    pub file: String,
    /// The declared identifier (`SY_bark`).
    pub ident: String,
    /// Index of the part in [`Model::flattened`]'s parts.
    pub part: usize,
}

/// The include files a model gets when its scene is `<stem>.pov`: one per part with
/// faces, in part order, with distinct identifiers and file names.
pub fn includes(model: &Model, stem: &str) -> Vec<Include> {
    let flat = model.flattened();
    let mut used: Vec<String> = Vec::new();
    let mut out = Vec::new();
    for (k, part) in flat.parts.iter().enumerate() {
        if part.mesh.face_count() == 0 {
            continue;
        }
        let base: String = part
            .name
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' })
            .take(28)
            .collect();
        let base = if base.is_empty() { format!("part{k}") } else { base };
        let mut name = base.clone();
        let mut n = 2;
        while used.contains(&name) {
            name = format!("{base}_{n}");
            n += 1;
        }
        used.push(name.clone());
        out.push(Include { file: format!("{stem}_{name}.inc"), ident: format!("SY_{name}"), part: k });
    }
    out
}

/// `<x, y, −z>`: a right-handed point or direction in POV-Ray's left-handed frame.
fn pov_vec(v: Vec3) -> String {
    format!("<{},{},{}>", v.x, v.y, -v.z)
}

/// Smooth area-weighted normals per position (for parts without normals).
fn smooth_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; mesh.positions.len()];
    for t in mesh.fan_corners() {
        let [a, b, c] = t.map(|i| mesh.face_indices[i] as usize);
        let n = (mesh.positions[b] - mesh.positions[a]).cross(mesh.positions[c] - mesh.positions[a]);
        for v in [a, b, c] {
            acc[v] += n;
        }
    }
    acc.into_iter().map(|n| n.try_normalize().unwrap_or(Vec3::Y)).collect()
}

/// Writes the include file declaring `ident` as a `mesh2` of `mesh`. The mesh must be
/// valid ([`Mesh::validate`]) and have at least one triangle.
pub fn write_inc(mesh: &Mesh, ident: &str, out: &mut dyn Write) -> std::io::Result<()> {
    // Written straight to `out` (a buffered file): an include of ten million triangles
    // is over a gigabyte of text, never held whole.
    let tris: Vec<[usize; 3]> = mesh.fan_corners().collect();
    writeln!(out, "// {GENERATOR}: {} triangles\n#declare {ident} = mesh2 {{", tris.len())?;
    writeln!(out, "  vertex_vectors {{\n    {},", mesh.positions.len())?;
    for p in &mesh.positions {
        writeln!(out, "    {},", pov_vec(*p))?;
    }
    out.write_all(b"  }\n")?;
    // Normals: the mesh's own (face-varying) or smooth ones per position.
    let (normals, normal_index): (Vec<Vec3>, Box<dyn Fn(usize) -> usize>) = match &mesh.normals {
        Some(n) => (n.values.clone(), Box::new(move |c| n.indices[c] as usize)),
        None => (smooth_normals(mesh), Box::new(|c| mesh.face_indices[c] as usize)),
    };
    writeln!(out, "  normal_vectors {{\n    {},", normals.len())?;
    for n in &normals {
        writeln!(out, "    {},", pov_vec(*n))?;
    }
    out.write_all(b"  }\n")?;
    if let Some(uv) = &mesh.uvs {
        writeln!(out, "  uv_vectors {{\n    {},", uv.values.len())?;
        for t in &uv.values {
            writeln!(out, "    <{},{}>,", t.x, t.y)?;
        }
        out.write_all(b"  }\n")?;
    }
    let indices = |out: &mut dyn Write, name: &str, f: &dyn Fn(usize) -> usize| -> std::io::Result<()> {
        writeln!(out, "  {name} {{\n    {},", tris.len())?;
        for t in &tris {
            writeln!(out, "    <{},{},{}>,", f(t[0]), f(t[1]), f(t[2]))?;
        }
        out.write_all(b"  }\n")
    };
    indices(out, "face_indices", &|c| mesh.face_indices[c] as usize)?;
    indices(out, "normal_indices", &*normal_index)?;
    if let Some(uv) = &mesh.uvs {
        indices(out, "uv_indices", &|c| uv.indices[c] as usize)?;
    }
    out.write_all(b"}\n")
}

/// A material as a POV-Ray `texture { … }`; `image` is the base-colour PNG's file name
/// when textures are written as files and the part has UVs.
fn texture(m: &Material, image: Option<&str>) -> String {
    let [r, g, bl, a] = m.base_color;
    let pigment = match image {
        Some(png) => format!(
            "pigment {{ uv_mapping image_map {{ png \"{}\" interpolate 2 }} }}",
            png.replace('\\', "/").replace('"', "_")
        ),
        None => format!("pigment {{ color rgbt <{r},{g},{bl},{}> }}", (1.0 - a).clamp(0.0, 1.0)),
    };
    // Glossier for smoother materials; never metallic-looking (trees).
    let specular = 0.4 * (1.0 - m.roughness).clamp(0.0, 1.0);
    format!(
        "texture {{ {pigment} finish {{ ambient 0 emission 0 diffuse 0.85 specular {specular} roughness 0.05 }} }}"
    )
}

/// Writes the scene that includes `incs` (from [`includes`]) and renders the model.
/// `image_prefix` is the texture files' prefix (`plant_`) when they are written beside
/// the scene, `None` for flat colours.
pub fn write_scene(
    model: &Model,
    incs: &[Include],
    image_prefix: Option<&str>,
    out: &mut dyn Write,
) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let flat = model.flattened();
    let (lo, hi) = flat.bounds().unwrap_or((Vec3::ZERO, Vec3::ONE));
    let centre = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let (az, el) = (VIEW_DEG.0.to_radians(), VIEW_DEG.1.to_radians());
    let toward = Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
    let distance = 1.1 * radius / (0.5 * FOV_DEG.to_radians()).sin();
    let eye = centre + toward * distance;
    let right = Vec3::Y.cross(toward).normalize_or(Vec3::X);
    let sun = centre + (toward + right * -0.8 + Vec3::Y * 1.2).normalize() * distance * 10.0;
    let fill = centre + (toward * 0.5 + right * 1.0 + Vec3::Y * 0.3).normalize() * distance * 10.0;
    let mut b = String::new();
    let _ = writeln!(
        b,
        "// {GENERATOR}: {} parts, {} triangles. Render: povray +I<this file> +W800 +H600 +A\n\
         #version 3.7;\n\
         global_settings {{ assumed_gamma 1.0 max_trace_level 16 }}\n\
         sky_sphere {{ pigment {{ gradient y color_map {{ [0 color rgb <0.82,0.86,0.9>] [1 color rgb <0.35,0.5,0.78>] }} }} }}\n\
         camera {{ perspective location {} look_at {} right x*image_width/image_height angle {FOV_DEG} }}\n\
         light_source {{ {} color rgb <1,0.97,0.9> }}\n\
         light_source {{ {} color rgb <0.35,0.38,0.45> shadowless }}",
        incs.len(),
        flat.triangle_count(),
        pov_vec(eye),
        pov_vec(centre),
        pov_vec(sun),
        pov_vec(fill),
    );
    for inc in incs {
        let part = &flat.parts[inc.part];
        let image = match (image_prefix, part.material.maps.base_color, &part.mesh.uvs) {
            (Some(prefix), Some(i), Some(_)) => {
                flat.images.get(i as usize).map(|im| format!("{prefix}{}.png", im.name))
            }
            _ => None,
        };
        let _ = writeln!(
            b,
            "#include \"{}\"\nobject {{ {} {} }}",
            inc.file,
            inc.ident,
            texture(&part.material, image.as_deref())
        );
    }
    out.write_all(b.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Part;

    fn quad() -> Mesh {
        let mut m = Mesh::new();
        m.positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.5), Vec3::Y];
        m.push_face(&[0, 1, 2, 3]);
        m
    }

    #[test]
    fn quads_become_two_triangles_with_their_own_normals() {
        let mut out = Vec::new();
        write_inc(&quad(), "SY_q", &mut out).unwrap();
        let s = String::from_utf8(out).unwrap();
        assert!(s.contains("#declare SY_q = mesh2 {"), "{s}");
        assert!(s.contains("face_indices {\n    2,\n    <0,1,2>,\n    <0,2,3>,"), "{s}");
        // z is negated: <1,1,-0.5>.
        assert!(s.contains("<1,1,-0.5>"), "{s}");
        assert!(!s.contains("uv_vectors"), "no UVs, no uv_vectors");
    }

    #[test]
    fn clashing_and_odd_part_names_get_distinct_identifiers() {
        let parts = vec![
            Part::new("leaf cards", quad(), Material::leaf()),
            Part::new("leaf_cards", quad(), Material::leaf()),
            Part::new("empty", Mesh::new(), Material::leaf()),
        ];
        let incs = includes(&Model::from_parts(parts), "t");
        let names: Vec<&str> = incs.iter().map(|i| i.ident.as_str()).collect();
        assert_eq!(names, ["SY_leaf_cards", "SY_leaf_cards_2"]);
        assert_eq!(incs[1].file, "t_leaf_cards_2.inc");
    }
}
