//! Wavefront OBJ + MTL writer.
//!
//! The `.obj` file names its material library (`mtllib`), then for every part with
//! faces writes an object and a group (`o <part>`, `g <part>`: Blender imports one
//! object per part), its material (`usemtl`), all its positions (`v`), UVs (`vt`) and
//! normals (`vn`; a part without normals gets smooth area-weighted ones per position and
//! `s 1`, so it imports smooth, not faceted), and its faces as polygons, not triangulated
//! (`f v/vt/vn`, 1-based, with a missing UV omitted: `v//vn`). OBJ stores face-varying
//! attributes natively, so UV seams need no vertex splitting.
//!
//! The `.mtl` file has one `newmtl` per distinct material with `Kd` (base colour), `Ka`,
//! `Ks`, `Ns` (from roughness), `d` (alpha), `illum 2`, and the common PBR extension
//! keys `Pr` (roughness) and `Pm` (metallic); with texture files, `map_Kd` (colour),
//! `map_d` (alpha, leaf cards), `norm` and `map_Bump` (normal map), `map_Pr`
//! (the ORM map) name them. Names are made safe for the line-based
//! formats (whitespace becomes `_`); two different materials with one name get
//! distinct names (`leaf`, `leaf_2`).
//!
//! Crease edges of a mesh (`Mesh::creases`) are written after its faces as OpenSubdiv
//! shape tags, `t crease 2/1 a b sharpness`, with 0-based vertex indices into the whole
//! file's `v` list and infinite sharpness written as 10 (OpenSubdiv's "infinitely
//! sharp", which the refiner treats the same); `sylva subdivide` and
//! `mesh::obj_read` read them back.
//!
//! OBJ cannot instance: instanced organs ([`Model::instances`]) are written merged, one
//! object per shape after the parts ([`Model::flattened`]).
//!
//! Numbers use Rust's shortest round-trip formatting of `f32`.

use super::{validate_io, GENERATOR};
use crate::model::{Material, Model};
use std::io::Write;

/// Flush the line buffer to the output when it grows past this.
const CHUNK: usize = 1 << 16;

/// Writes the OBJ text of `model` to `obj`, referring to the material library
/// `mtl_name` (a file name relative to the `.obj`, such as `tree.mtl`).
///
/// The model is validated first ([`super::validate_model`]); invalid geometry or a
/// model without triangles is an `InvalidData` I/O error.
/// Parts without faces are left out.
pub fn write_obj(model: &Model, obj: &mut dyn Write, mtl_name: &str) -> std::io::Result<()> {
    validate_io(model)?;
    write_obj_unchecked(model, obj, mtl_name)
}

/// Writes the MTL material library of `model` (the materials [`write_obj`] uses).
///
/// The model is validated first, like [`write_obj`].
pub fn write_mtl(model: &Model, mtl: &mut dyn Write) -> std::io::Result<()> {
    validate_io(model)?;
    write_mtl_unchecked(model, mtl, None)
}

/// [`write_obj`] for a model already validated.
pub(crate) fn write_obj_unchecked(model: &Model, out: &mut dyn Write, mtl_name: &str) -> std::io::Result<()> {
    let flat = model.flattened();
    let model = flat.as_ref();
    let (part_material, materials) = material_table(model);
    let mut buf: Vec<u8> = Vec::with_capacity(CHUNK + 1024);
    writeln!(buf, "# {GENERATOR}")?;
    writeln!(buf, "mtllib {mtl_name}")?;
    // Running 1-based offsets of the global v / vt / vn lists.
    let (mut v_base, mut vt_base, mut vn_base) = (1usize, 1usize, 1usize);
    for (part, mat) in model.parts.iter().zip(&part_material) {
        let Some(mat) = *mat else { continue };
        let mesh = &part.mesh;
        writeln!(buf, "o {}", safe_name(&part.name))?;
        writeln!(buf, "g {}", safe_name(&part.name))?;
        writeln!(buf, "usemtl {}", materials[mat].0)?;
        for p in &mesh.positions {
            writeln!(buf, "v {} {} {}", p.x, p.y, p.z)?;
            flush_if_full(&mut buf, out)?;
        }
        if let Some(uvs) = &mesh.uvs {
            for t in &uvs.values {
                writeln!(buf, "vt {} {}", t.x, t.y)?;
                flush_if_full(&mut buf, out)?;
            }
        }
        // Given normals, or smooth ones per position (then indexed like the positions).
        let smooth = mesh.normals.is_none().then(|| super::smooth_normals(mesh));
        let normal_values = match (&mesh.normals, &smooth) {
            (Some(n), _) => n.values.as_slice(),
            (None, Some(s)) => s.as_slice(),
            (None, None) => &[],
        };
        for n in normal_values {
            writeln!(buf, "vn {} {} {}", n.x, n.y, n.z)?;
            flush_if_full(&mut buf, out)?;
        }
        writeln!(buf, "s 1")?;
        let uv_idx = mesh.uvs.as_ref().map(|c| c.indices.as_slice());
        let n_idx =
            Some(mesh.normals.as_ref().map_or(mesh.face_indices.as_slice(), |c| c.indices.as_slice()));
        for w in mesh.face_offsets.windows(2) {
            buf.push(b'f');
            for c in w[0] as usize..w[1] as usize {
                let v = mesh.face_indices.get(c).copied().unwrap_or(0) as usize + v_base;
                let vt = uv_idx.and_then(|i| i.get(c)).map(|&i| i as usize + vt_base);
                let vn = n_idx.and_then(|i| i.get(c)).map(|&i| i as usize + vn_base);
                buf.push(b' ');
                push_uint(&mut buf, v);
                match (vt, vn) {
                    (Some(vt), Some(vn)) => {
                        buf.push(b'/');
                        push_uint(&mut buf, vt);
                        buf.push(b'/');
                        push_uint(&mut buf, vn);
                    }
                    (None, Some(vn)) => {
                        buf.extend_from_slice(b"//");
                        push_uint(&mut buf, vn);
                    }
                    (Some(vt), None) => {
                        buf.push(b'/');
                        push_uint(&mut buf, vt);
                    }
                    (None, None) => {}
                }
            }
            buf.push(b'\n');
            flush_if_full(&mut buf, out)?;
        }
        for c in mesh.creases.iter().filter(|c| c.sharpness > 0.0) {
            let s = c.sharpness.min(crate::refine::crease::INFINITE);
            writeln!(buf, "t crease 2/1 {} {} {s}", c.a as usize + v_base - 1, c.b as usize + v_base - 1)?;
            flush_if_full(&mut buf, out)?;
        }
        v_base += mesh.positions.len();
        vt_base += mesh.uvs.as_ref().map_or(0, |c| c.values.len());
        vn_base += normal_values.len();
    }
    out.write_all(&buf)?;
    out.flush()
}

/// [`write_mtl`] for a model already validated.
///
/// `textures`: the file-name prefix of the model's images written beside it (see
/// [`super::TextureMode::Files`]), or `None` for flat colours only.
pub(crate) fn write_mtl_unchecked(
    model: &Model,
    out: &mut dyn Write,
    textures: Option<&str>,
) -> std::io::Result<()> {
    let flat = model.flattened();
    let (_, materials) = material_table(flat.as_ref());
    let mut buf: Vec<u8> = Vec::with_capacity(4096);
    writeln!(buf, "# {GENERATOR}")?;
    for (name, m) in &materials {
        let [r, g, b, a] = m.base_color;
        // Dielectrics reflect ~4 % white; metals reflect their base colour.
        let spec = |c: f32| 0.04 + (c - 0.04) * m.metallic;
        let roughness = m.roughness.clamp(0.0, 1.0);
        let shininess = (1.0 - roughness) * (1.0 - roughness) * 1000.0;
        writeln!(buf)?;
        writeln!(buf, "newmtl {name}")?;
        writeln!(buf, "Kd {r} {g} {b}")?;
        writeln!(buf, "Ka {r} {g} {b}")?;
        writeln!(buf, "Ks {} {} {}", spec(r), spec(g), spec(b))?;
        writeln!(buf, "Ns {shininess}")?;
        writeln!(buf, "d {a}")?;
        writeln!(buf, "illum 2")?;
        writeln!(buf, "Pr {}", m.roughness)?;
        writeln!(buf, "Pm {}", m.metallic)?;
        if let Some(prefix) = textures {
            let file = |i: Option<u32>| {
                i.and_then(|i| model.images.get(i as usize)).map(|im| format!("{prefix}{}.png", im.name))
            };
            if let Some(f) = file(m.maps.base_color) {
                writeln!(buf, "map_Kd {f}")?;
                if m.alpha_cutoff.is_some() {
                    writeln!(buf, "map_d {f}")?;
                }
            }
            if let Some(f) = file(m.maps.normal) {
                writeln!(buf, "norm {f}")?;
                writeln!(buf, "map_Bump -bm 1 {f}")?;
            }
            if let Some(f) = file(m.maps.occlusion_roughness_metallic) {
                writeln!(buf, "map_Pr {f}")?;
            }
        }
    }
    out.write_all(&buf)?;
    out.flush()
}

/// Appends the decimal digits of `n` (faster than `write!` for the many face indices).
#[inline]
fn push_uint(buf: &mut Vec<u8>, mut n: usize) {
    let mut digits = [0u8; 20];
    let mut i = digits.len();
    loop {
        i -= 1;
        digits[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    buf.extend_from_slice(&digits[i..]);
}

/// Hands the buffered lines to `out` once there are enough of them.
#[inline]
fn flush_if_full(buf: &mut Vec<u8>, out: &mut dyn Write) -> std::io::Result<()> {
    if buf.len() >= CHUNK {
        out.write_all(buf)?;
        buf.clear();
    }
    Ok(())
}

/// `name` with whitespace and control characters replaced by `_` (OBJ and MTL are
/// whitespace-separated); `unnamed` when empty.
fn safe_name(name: &str) -> String {
    if name.is_empty() {
        return "unnamed".to_owned();
    }
    name.chars().map(|c| if c.is_whitespace() || c.is_control() { '_' } else { c }).collect()
}

/// The materials used by the parts with faces, each under a unique safe name, and for
/// every part the index of its material in that list (`None` for parts left out).
fn material_table(model: &Model) -> (Vec<Option<usize>>, Vec<(String, &Material)>) {
    let mut materials: Vec<(String, &Material)> = Vec::new();
    let mut part_material = Vec::with_capacity(model.parts.len());
    for part in &model.parts {
        if part.mesh.face_count() == 0 {
            part_material.push(None);
            continue;
        }
        let m = &part.material;
        if let Some(i) = materials.iter().position(|(_, known)| *known == m) {
            part_material.push(Some(i));
            continue;
        }
        let base = safe_name(&m.name);
        let mut name = base.clone();
        let mut n = 2;
        while materials.iter().any(|(taken, _)| *taken == name) {
            name = format!("{base}_{n}");
            n += 1;
        }
        part_material.push(Some(materials.len()));
        materials.push((name, m));
    }
    (part_material, materials)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Mesh;
    use crate::model::Part;
    use glam::Vec3;

    fn tri_part(name: &str, material: Material) -> Part {
        let mut mesh = Mesh::new();
        mesh.positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        mesh.push_face(&[0, 1, 2]);
        Part::new(name, mesh, material)
    }

    #[test]
    fn faces_without_channels_and_offsets() {
        let model = Model {
            parts: vec![tri_part("a b", Material::bark()), tri_part("c", Material::bark())],
            ..Default::default()
        };
        let mut out = Vec::new();
        write_obj(&model, &mut out, "t.mtl").unwrap();
        let text = String::from_utf8(out).unwrap();
        // One object per part; smooth normals per position where the mesh has none.
        let part = "usemtl bark\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\ns 1\n";
        assert!(text.contains(&format!("mtllib t.mtl\no a_b\ng a_b\n{part}f 1//1 2//2 3//3\n")), "{text}");
        assert!(text.ends_with(&format!("o c\ng c\n{part}f 4//4 5//5 6//6\n")), "{text}");
    }

    #[test]
    fn creases_round_trip_as_opensubdiv_tags() {
        use crate::geometry::Crease;
        let mut first = tri_part("a", Material::bark());
        first.mesh.creases.push(Crease { a: 0, b: 1, sharpness: 2.5 });
        let mut second = tri_part("b", Material::leaf());
        second.mesh.creases.push(Crease { a: 1, b: 2, sharpness: f32::INFINITY });
        second.mesh.creases.push(Crease { a: 0, b: 2, sharpness: 0.0 }); // smooth: not written
        let mut out = Vec::new();
        write_obj_unchecked(&Model { parts: vec![first, second], ..Default::default() }, &mut out, "m.mtl")
            .unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("t crease 2/1 0 1 2.5\n"), "{text}");
        assert!(text.contains("t crease 2/1 4 5 10\n"), "{text}");
        assert_eq!(text.matches("t crease").count(), 2);
        let back = crate::mesh::obj_read::parse_obj(&text).unwrap();
        assert_eq!(
            back.mesh.creases,
            vec![Crease { a: 0, b: 1, sharpness: 2.5 }, Crease { a: 4, b: 5, sharpness: 10.0 }]
        );
    }

    #[test]
    fn push_uint_writes_decimal() {
        let mut b = Vec::new();
        for n in [0, 7, 10, 99, 100, 12345, usize::MAX] {
            b.clear();
            push_uint(&mut b, n);
            assert_eq!(String::from_utf8(b.clone()).unwrap(), n.to_string());
        }
    }

    #[test]
    fn clashing_material_names_are_made_unique() {
        let mut other = Material::bark();
        other.roughness = 0.1;
        let model = Model {
            parts: vec![
                tri_part("a", Material::bark()),
                tri_part("b", other),
                tri_part("c", Material::bark()),
            ],
            ..Default::default()
        };
        let (per_part, mats) = material_table(&model);
        assert_eq!(per_part, vec![Some(0), Some(1), Some(0)]);
        assert_eq!(mats.iter().map(|m| m.0.as_str()).collect::<Vec<_>>(), vec!["bark", "bark_2"]);
    }
}
