//! Wavefront OBJ reader for subdivision control meshes, with OpenSubdiv's crease tags.
//!
//! Reads `v x y z` (extra columns such as `w` or vertex colours are ignored), `vt u v`,
//! `vn x y z` and `f` with every corner form (`v`, `v/vt`, `v//vn`, `v/vt/vn`; 1-based,
//! negative indices count back from the latest element; 0 is an error) — Pieterse2012-spec §3.
//! Subdivision tags follow OpenSubdiv's shape files (0-based vertex indices):
//!
//! ```text
//! t crease 2/1 v0 v1 sharpness          # more pairs: t crease 4/2 a b c d s_ab s_cd
//! t corner 1/1 v sharpness
//! t interpolateboundary 1/0 1           # 1 edge-and-corner, 2 edge-only
//! t creasemethod 0/0/1 chaikin          # or "normal"
//! ```
//!
//! `g`, `o`, `s`, `usemtl`, `mtllib`, `l`, comments and unknown statements or tags are
//! ignored. Errors carry the line number. UVs and normals become face-varying channels
//! (one index per corner, so seams are exact); a mesh keeps a channel only when every
//! face has it.

use crate::geometry::{Crease, FaceVarying, Mesh};
use crate::refine::{BoundaryInterpolation, Corner, CreasingMethod};
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

/// A control mesh read from OBJ, with its subdivision tags.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObjMesh {
    /// Positions, faces, UVs, normals and crease edges.
    pub mesh: Mesh,
    /// Sharp vertices (`t corner`).
    pub corners: Vec<Corner>,
    /// Boundary rule from `t interpolateboundary`, if given.
    pub boundary: Option<BoundaryInterpolation>,
    /// Creasing method from `t creasemethod`, if given.
    pub creasing: Option<CreasingMethod>,
}

/// Why an OBJ file could not be read.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum ObjError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A malformed statement.
    #[error(
        "{}line {line}: {}",
        path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default(),
        crate::diagnostic::clip(&crate::diagnostic::clip_quoted(message), crate::diagnostic::MAX_MESSAGE_CHARS)
    )]
    Parse {
        /// The file, when reading from one.
        path: Option<PathBuf>,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Reads an OBJ file (see the module docs for what is understood).
pub fn read_obj(path: &Path) -> Result<ObjMesh, ObjError> {
    let text =
        crate::input::read_input_to_string(path, crate::input::DEFAULT_MAX_BYTES).map_err(|e| match e {
            crate::Error::Read { path, source } => ObjError::Io { path, source },
            other => {
                ObjError::Io { path: path.to_path_buf(), source: std::io::Error::other(other.to_string()) }
            }
        })?;
    parse_obj(&text).map_err(|e| match e {
        ObjError::Parse { line, message, .. } => {
            ObjError::Parse { path: Some(path.to_path_buf()), line, message }
        }
        other => other,
    })
}

/// Parses OBJ text.
pub fn parse_obj(text: &str) -> Result<ObjMesh, ObjError> {
    let mut out = ObjMesh { mesh: Mesh::new(), ..Default::default() };
    let mut uv_values: Vec<Vec2> = Vec::new();
    let mut normal_values: Vec<Vec3> = Vec::new();
    let mut uv_idx: Vec<u32> = Vec::new();
    let mut n_idx: Vec<u32> = Vec::new();
    let (mut faces_with_uv, mut faces_with_n) = (0usize, 0usize);
    let mut tags: Vec<(usize, Vec<String>)> = Vec::new();
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let err = |message: String| ObjError::Parse { path: None, line, message };
        let content = raw.split('#').next().unwrap_or("").trim();
        let mut words = content.split_whitespace();
        let Some(keyword) = words.next() else { continue };
        let args: Vec<&str> = words.collect();
        let floats = |n: usize, what: &str| -> Result<Vec<f32>, ObjError> {
            if args.len() < n {
                return Err(err(format!("`{what}` needs {n} numbers, found {}", args.len())));
            }
            args[..n]
                .iter()
                .map(|a| {
                    a.parse::<f32>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| err(format!("`{a}` is not a finite number")))
                })
                .collect()
        };
        match keyword {
            "v" => {
                let p = floats(3, "v")?;
                out.mesh.positions.push(Vec3::new(p[0], p[1], p[2]));
            }
            "vt" => {
                let p = floats(1, "vt")?;
                let v = if args.len() > 1 { floats(2, "vt")?[1] } else { 0.0 };
                uv_values.push(Vec2::new(p[0], v));
            }
            "vn" => {
                let p = floats(3, "vn")?;
                normal_values.push(Vec3::new(p[0], p[1], p[2]));
            }
            "f" => {
                if args.len() < 3 {
                    return Err(err(format!("a face needs at least 3 corners, found {}", args.len())));
                }
                let mut verts = Vec::with_capacity(args.len());
                let (mut has_uv, mut has_n) = (0usize, 0usize);
                let (mut fuv, mut fn_) = (Vec::new(), Vec::new());
                for a in &args {
                    let mut parts = a.split('/');
                    let v = parts.next().unwrap_or("");
                    let vt = parts.next().unwrap_or("");
                    let vn = parts.next().unwrap_or("");
                    if parts.next().is_some() {
                        return Err(err(format!("bad face corner `{a}`")));
                    }
                    verts.push(resolve(v, out.mesh.positions.len(), "vertex").map_err(err)?);
                    if !vt.is_empty() {
                        has_uv += 1;
                        fuv.push(resolve(vt, uv_values.len(), "texture coordinate").map_err(err)?);
                    }
                    if !vn.is_empty() {
                        has_n += 1;
                        fn_.push(resolve(vn, normal_values.len(), "normal").map_err(err)?);
                    }
                }
                if has_uv != 0 && has_uv != args.len() || has_n != 0 && has_n != args.len() {
                    return Err(err(
                        "some corners of this face have texture coordinates or normals and some do not"
                            .into(),
                    ));
                }
                if has_uv > 0 {
                    faces_with_uv += 1;
                    uv_idx.extend(fuv);
                } else {
                    uv_idx.extend(std::iter::repeat_n(0, args.len()));
                }
                if has_n > 0 {
                    faces_with_n += 1;
                    n_idx.extend(fn_);
                } else {
                    n_idx.extend(std::iter::repeat_n(0, args.len()));
                }
                out.mesh.push_face(&verts);
            }
            "t" => tags.push((line, args.iter().map(|s| s.to_string()).collect())),
            _ => {} // g, o, s, usemtl, mtllib, l, vp, …
        }
    }
    let faces = out.mesh.face_count();
    if faces > 0 && faces_with_uv == faces {
        out.mesh.uvs = Some(FaceVarying { values: uv_values, indices: uv_idx });
    }
    if faces > 0 && faces_with_n == faces {
        out.mesh.normals = Some(FaceVarying { values: normal_values, indices: n_idx });
    }
    for (line, args) in tags {
        apply_tag(&mut out, line, &args)?;
    }
    Ok(out)
}

/// A 1-based or negative OBJ index into a list of `len` elements, as 0-based.
fn resolve(s: &str, len: usize, what: &str) -> Result<u32, String> {
    let i: i64 = s.parse().map_err(|_| format!("`{s}` is not a {what} index"))?;
    let idx = if i > 0 {
        i - 1
    } else if i < 0 {
        len as i64 + i
    } else {
        return Err(format!("{what} index 0 is invalid (OBJ indices start at 1)"));
    };
    if idx < 0 || idx >= len as i64 {
        return Err(format!("{what} index {i} is out of range ({len} defined so far)"));
    }
    Ok(idx as u32)
}

/// Applies one `t name nint/nfloat[/nstring] ints… floats… strings…` tag.
fn apply_tag(out: &mut ObjMesh, line: usize, args: &[String]) -> Result<(), ObjError> {
    let err = |message: String| ObjError::Parse { path: None, line, message };
    let (Some(name), Some(counts)) = (args.first(), args.get(1)) else {
        return Err(err("a tag needs a name and counts, e.g. `t crease 2/1 0 1 2.5`".into()));
    };
    let counts: Vec<usize> = counts
        .split('/')
        .map(|c| c.parse().map_err(|_| err(format!("bad tag counts `{counts}`"))))
        .collect::<Result<_, _>>()?;
    let (ni, nf, ns) = (
        counts.first().copied().unwrap_or(0),
        counts.get(1).copied().unwrap_or(0),
        counts.get(2).copied().unwrap_or(0),
    );
    let rest = &args[2..];
    if ni.checked_add(nf).and_then(|x| x.checked_add(ns)) != Some(rest.len()) {
        return Err(err(format!("tag `{name}` announces {ni}/{nf}/{ns} arguments but has {}", rest.len())));
    }
    let ints: Vec<i64> = rest[..ni]
        .iter()
        .map(|s| s.parse().map_err(|_| err(format!("`{s}` is not an integer"))))
        .collect::<Result<_, _>>()?;
    let floats: Vec<f32> = rest[ni..ni + nf]
        .iter()
        .map(|s| s.parse().map_err(|_| err(format!("`{s}` is not a number"))))
        .collect::<Result<_, _>>()?;
    let strings = &rest[ni + nf..];
    let nv = out.mesh.positions.len() as i64;
    let vertex = |i: i64| -> Result<u32, ObjError> {
        if (0..nv).contains(&i) {
            Ok(i as u32)
        } else {
            Err(err(format!(
                "tag `{name}` refers to vertex {i}, but there are {nv} (tag indices are 0-based)"
            )))
        }
    };
    let sharpness = |k: usize| -> Result<f32, ObjError> {
        let s = if floats.len() > 1 { floats.get(k).copied() } else { floats.first().copied() };
        let s = s.ok_or_else(|| err(format!("tag `{name}` has no sharpness for its item {}", k + 1)))?;
        if s.is_nan() || s < 0.0 {
            return Err(err(format!("sharpness {s} must be a number ≥ 0")));
        }
        Ok(s)
    };
    match name.as_str() {
        "crease" => {
            if ni < 2 || ni % 2 != 0 {
                return Err(err("`t crease` needs pairs of vertices".into()));
            }
            for k in 0..ni / 2 {
                let (a, b) = (vertex(ints[2 * k])?, vertex(ints[2 * k + 1])?);
                out.mesh.creases.push(Crease { a, b, sharpness: sharpness(k)? });
            }
        }
        "corner" => {
            for (k, &i) in ints.iter().enumerate() {
                out.corners.push(Corner { vertex: vertex(i)?, sharpness: sharpness(k)? });
            }
        }
        "interpolateboundary" => {
            out.boundary = match ints.first() {
                Some(1) => Some(BoundaryInterpolation::EdgeAndCorner),
                Some(2) => Some(BoundaryInterpolation::EdgeOnly),
                other => {
                    return Err(err(format!("interpolateboundary {other:?} is not supported (use 1 or 2)")))
                }
            }
        }
        "creasemethod" => {
            out.creasing = match strings.first().map(String::as_str) {
                Some("normal") => Some(CreasingMethod::Uniform),
                Some("chaikin") => Some(CreasingMethod::Chaikin),
                other => return Err(err(format!("creasemethod {other:?} is not `normal` or `chaikin`"))),
            }
        }
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_every_corner_form_and_negative_indices() {
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
                   vn 0 0 1\ng quad\nusemtl bark\nf 1/1/1 2/2/1 3/3/1 4/4/1\nf -4/-4 -2/-2 -1/-1\n";
        let m = parse_obj(obj).unwrap();
        assert_eq!(m.mesh.positions.len(), 4);
        assert_eq!(m.mesh.face(0), &[0, 1, 2, 3]);
        assert_eq!(m.mesh.face(1), &[0, 2, 3]);
        let uv = m.mesh.uvs.as_ref().unwrap();
        assert_eq!(uv.indices, vec![0, 1, 2, 3, 0, 2, 3]);
        assert!(m.mesh.normals.is_none(), "the second face has no normals");
        let m = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\nvn 0 0 1\n");
        assert!(m.is_err(), "normal referenced before it is defined");
        let m = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(m.mesh.uvs.is_none());
    }

    #[test]
    fn reads_opensubdiv_tags() {
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nt crease 2/1 0 1 2.5\nt crease 4/2 1 2 2 0 1 10\n\
                   t corner 1/1 2 3\nt interpolateboundary 1/0 2\nt creasemethod 0/0/1 chaikin\nt hole 1/0 0\n";
        let m = parse_obj(obj).unwrap();
        assert_eq!(
            m.mesh.creases,
            vec![
                Crease { a: 0, b: 1, sharpness: 2.5 },
                Crease { a: 1, b: 2, sharpness: 1.0 },
                Crease { a: 2, b: 0, sharpness: 10.0 }
            ]
        );
        assert_eq!(m.corners, vec![Corner { vertex: 2, sharpness: 3.0 }]);
        assert_eq!(m.boundary, Some(BoundaryInterpolation::EdgeOnly));
        assert_eq!(m.creasing, Some(CreasingMethod::Chaikin));
    }

    #[test]
    fn errors_carry_line_numbers() {
        let e = parse_obj("v 0 0 0\nv 1 0 0\nf 1 2 0\n").unwrap_err();
        assert!(e.to_string().contains("line 3") && e.to_string().contains("index 0"), "{e}");
        let e = parse_obj("v 0 0\n").unwrap_err();
        assert!(e.to_string().contains("line 1"), "{e}");
        let e = parse_obj("v 0 0 nan\n").unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");
        let e = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n").unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
        let e = parse_obj("v 0 0 0\nt crease 2/1 0 7 1.0\n").unwrap_err();
        assert!(e.to_string().contains("line 2") && e.to_string().contains("vertex 7"), "{e}");
        let e = parse_obj("v 0 0 0\nt crease 2/1 0 0\n").unwrap_err();
        assert!(e.to_string().contains("announces"), "{e}");
        let e = read_obj(Path::new("/nonexistent/x.obj")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/x.obj"));
    }
}
