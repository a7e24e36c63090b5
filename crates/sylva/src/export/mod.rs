//! Model exporters: glTF 2.0 (binary `.glb` and self-contained `.gltf`), Wavefront OBJ +
//! MTL, binary little-endian PLY and POV-Ray 3.7 (a `.pov` scene and one `.inc` per
//! mesh, MacMurchy2004 §A.3–A.4).
//!
//! [`write()`] picks the format from the file extension ([`Format::from_path`]), checks
//! every part's mesh ([`crate::Mesh::validate`]) so that no NaN or bad index reaches a
//! file, and writes every file of the model (the model, its `.mtl`, textures or
//! includes) as one [`crate::fsutil::OutputSet`], so a failure never leaves a
//! half-written file and never touches the files of an earlier export. Each format also has a pure in-memory writer for tests and
//! benchmarks: [`gltf::to_glb`], [`gltf::to_gltf_json`], [`obj::write_obj`],
//! [`obj::write_mtl`] and [`ply::write_ply`].
//!
//! glTF and PLY store one set of attributes per vertex, while a [`Mesh`] keeps UVs and
//! normals face-varying (one index per face corner). [`unify`] turns the corners into
//! output vertices: one per distinct (position, uv, normal) index tuple, in order of
//! first use, so UV seams split vertices and shared corners stay shared. OBJ stores
//! face-varying data natively and needs no unification.
//!
//! Instanced organs ([`Model::instances`], `leaves.mode = "instanced"`) go to glTF as
//! one mesh per shape on a node with `EXT_mesh_gpu_instancing` (or merged, with
//! [`InstancingFallback::Merged`]); OBJ and PLY cannot instance and write every copy
//! ([`Model::flattened`], [`instance`]). [`ExportOptions`] gathers what `[output]` says
//! about the file beyond its name: textures, the instancing fallback and compression.
//!
//! The real-time data of issue 24 — a rig with its skin weights and wind clip, the wind
//! channels and levels of detail ([`ExportOptions::lod_layout`],
//! [`ExportOptions::wind_colors`]) — goes to glTF only ([`gltf`] describes its layout);
//! OBJ and PLY write LOD0 (the model's parts) and ignore the rig, clip, channels and
//! levels.
//!
//! Output is deterministic: the same model gives byte-identical files.

pub mod gltf;
pub mod instance;
pub mod obj;
pub mod ply;
pub mod pov;
pub mod skeleton;

use crate::error::{Error, Result};
use crate::fsutil::OutputSet;
use crate::geometry::Mesh;
use crate::model::Model;
use glam::{Mat3, Vec2, Vec3};
use std::path::Path;

/// The extensions [`Format::from_path`] understands, for error messages.
pub const EXTENSIONS: &str = ".glb, .gltf, .obj, .ply, .pov";

/// The generator string written into every file: `sylva <version>`.
pub const GENERATOR: &str = concat!("sylva ", env!("CARGO_PKG_VERSION"));

/// An output file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Binary glTF 2.0: one `.glb` file holding the JSON and the binary buffer.
    Glb,
    /// glTF 2.0 JSON with the buffer embedded as a base64 data URI (one `.gltf` file).
    Gltf,
    /// Wavefront OBJ with a sibling `.mtl` material library.
    Obj,
    /// Binary little-endian PLY.
    Ply,
    /// A POV-Ray 3.7 scene with one `mesh2` include file per part beside it ([`pov`]).
    Pov,
}

impl Format {
    /// Chooses the format from the extension of `path` (case-insensitive).
    ///
    /// Anything other than `.glb`, `.gltf`, `.obj`, `.ply` or `.pov` is
    /// [`Error::UnknownFormat`].
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        match ext.to_ascii_lowercase().as_str() {
            "glb" => Ok(Format::Glb),
            "gltf" => Ok(Format::Gltf),
            "obj" => Ok(Format::Obj),
            "ply" => Ok(Format::Ply),
            "pov" => Ok(Format::Pov),
            _ => Err(Error::UnknownFormat { path: path.to_path_buf(), expected: EXTENSIONS }),
        }
    }

    /// The usual file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Glb => "glb",
            Format::Gltf => "gltf",
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Pov => "pov",
        }
    }
}

/// Where a model's textures go (`output.textures`: `embed`, `files` or `none`; serde
/// writes and reads those names, a read [`TextureMode::Files`] has an empty prefix).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum TextureMode {
    /// Inside the file: PNG buffer views in `.glb`, data URIs in `.gltf`. OBJ cannot
    /// embed, so `.obj` writes files as [`TextureMode::Files`] does.
    #[default]
    Embed,
    /// PNG files beside the model, named `<prefix><image>.png`, referred to by relative URI.
    Files {
        /// The file-name prefix (the model's stem and `_`), relative to the model.
        prefix: String,
    },
    /// No textures: materials keep their flat colours.
    None,
}

impl TextureMode {
    /// The recipe names, in the order of the variants.
    pub const NAMES: &'static [&'static str] = &["embed", "files", "none"];

    /// The mode's `output.textures` name.
    pub fn name(&self) -> &'static str {
        match self {
            TextureMode::Embed => "embed",
            TextureMode::Files { .. } => "files",
            TextureMode::None => "none",
        }
    }

    /// The mode called `name` (a [`TextureMode::Files`] with an empty prefix).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "embed" => Some(TextureMode::Embed),
            "files" => Some(TextureMode::Files { prefix: String::new() }),
            "none" => Some(TextureMode::None),
            _ => None,
        }
    }

    /// This mode for a model at `path`: [`TextureMode::Files`] gets the prefix of the
    /// model's stem and `_`.
    pub fn for_path(&self, path: &Path) -> TextureMode {
        match self {
            TextureMode::Files { .. } => {
                let stem = path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "tree".into());
                TextureMode::Files { prefix: format!("{stem}_") }
            }
            t => t.clone(),
        }
    }

    /// The mode for `output.textures` (`embed`, `files`, `none`) and a model at `path`.
    pub fn for_output(name: &str, path: &Path) -> Result<TextureMode> {
        match TextureMode::from_name(name) {
            Some(t) => Ok(t.for_path(path)),
            None => Err(Error::Recipe(format!("`output.textures` is `{name}`; use embed, files or none"))),
        }
    }
}

impl std::fmt::Display for TextureMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl serde::Serialize for TextureMode {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for TextureMode {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        /// The names `output.textures` takes.
        #[derive(serde::Deserialize)]
        #[serde(rename_all = "lowercase")]
        enum Name {
            Embed,
            Files,
            None,
        }
        Ok(match Name::deserialize(d)? {
            Name::Embed => TextureMode::Embed,
            Name::Files => TextureMode::Files { prefix: String::new() },
            Name::None => TextureMode::None,
        })
    }
}

/// What a glTF reader without `EXT_mesh_gpu_instancing` gets (`output.instancing_fallback`).
///
/// A node either carries the extension or not: a file cannot hold both the instanced
/// leaves and merged copies without readers that support the extension drawing the
/// leaves twice. So the choice is per file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InstancingFallback {
    /// `none`: instances as `EXT_mesh_gpu_instancing` (in `extensionsUsed`, not required).
    /// A reader without the extension draws the shape once, at the node's transform,
    /// which is the first instance's: one leaf, in its place.
    #[default]
    None,
    /// `merged`: every instance merged into an ordinary mesh, no extension: every reader
    /// sees every leaf, at the size of a file without instancing.
    Merged,
}

impl InstancingFallback {
    /// The recipe names, for messages.
    pub const NAMES: &'static str = "none or merged";

    /// The fallback called `name` (`none`, `merged`).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "none" => Some(InstancingFallback::None),
            "merged" => Some(InstancingFallback::Merged),
            _ => None,
        }
    }
}

/// Compression of the glTF buffer (`output.compress`); OBJ and PLY ignore it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Compression {
    /// `none`: `FLOAT` attributes.
    #[default]
    None,
    /// `quantize`: `KHR_mesh_quantization` (required): positions `SHORT`, normals and
    /// tangents `BYTE` normalized, UVs `UNSIGNED_SHORT` normalized.
    Quantize,
    /// `meshopt`: quantized as `quantize`, then every geometry buffer view compressed
    /// with `EXT_meshopt_compression` (required; no uncompressed fallback).
    Meshopt,
}

impl Compression {
    /// The recipe names, for messages.
    pub const NAMES: &'static str = "none, quantize or meshopt";

    /// The compression called `name` (`none`, `quantize`, `meshopt`).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "none" => Some(Compression::None),
            "quantize" => Some(Compression::Quantize),
            "meshopt" => Some(Compression::Meshopt),
            _ => None,
        }
    }
}

/// Where glTF puts the coarser levels of detail (`output.lod_layout`: `msft` or `scene`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LodLayout {
    /// `msft`: LOD1…n are nodes outside the scene named by LOD0's `MSFT_lod` (with
    /// `MSFT_screencoverage` hints); plain viewers show LOD0 only.
    #[default]
    Msft,
    /// `scene`: every level is a node of the scene (`<name>_LOD0 … _LODn`), for engines
    /// that build LOD groups from names; `MSFT_lod` is written too.
    Scene,
}

/// How a model is written beyond its file name: the `[output]` keys
/// `textures`, `instancing_fallback`, `compress`, `lod_layout` and `wind_colors`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ExportOptions {
    /// Where the textures go.
    pub textures: TextureMode,
    /// What glTF readers without `EXT_mesh_gpu_instancing` get.
    pub instancing_fallback: InstancingFallback,
    /// glTF buffer compression.
    pub compress: Compression,
    /// Where the levels of detail go.
    pub lod_layout: LodLayout,
    /// Also pack the wind channels into `COLOR_0` / `TEXCOORD_1` (docs/wind.md).
    pub wind_colors: bool,
}

/// Writes `model` to `path` in the format given by its extension, its textures embedded
/// (see [`write_with`]).
pub fn write(model: &Model, path: &Path) -> Result<()> {
    write_with(model, path, &TextureMode::Embed)
}

/// Writes `model` to `path` with its textures as `textures` says and the other options
/// at their defaults (see [`write_with_options`]).
pub fn write_with(model: &Model, path: &Path, textures: &TextureMode) -> Result<()> {
    write_with_options(model, path, &ExportOptions { textures: textures.clone(), ..Default::default() })
}

/// Writes `model` to `path` in the format given by its extension, as `options` say.
///
/// Every part's mesh is validated first (indices in range, finite numbers); a problem is
/// [`Error::InvalidGeometry`] naming the part, and nothing is written; so is a model
/// without a single triangle. `.obj` also writes the material library next to it
/// (`name.mtl`), `.pov` one include file per part.
///
/// With [`TextureMode::Files`] (and for `.obj` and `.pov`, which cannot embed, unless `None`; `.ply`
/// never refers to images) the images are written as `<prefix><name>.png` beside the model.
///
/// All the files are written as one [`OutputSet`]: each goes to a temporary first, and
/// they replace the files of an earlier export only when every one of them was written,
/// so on any error the earlier files are left exactly as they were and no temporary is
/// left (see [`stage_with_options`] to add more files, such as a preview, to the set).
///
/// Instances are written as `EXT_mesh_gpu_instancing` to glTF (unless
/// [`InstancingFallback::Merged`]) and merged for OBJ and PLY.
pub fn write_with_options(model: &Model, path: &Path, options: &ExportOptions) -> Result<()> {
    let mut set = OutputSet::new(path);
    stage_with_options(model, path, options, &mut set)?;
    set.commit()
}

/// [`write_with_options`], staged into `set` instead of written: the model and its side
/// files (`.mtl`, texture PNGs, POV-Ray includes) go to temporaries, and reach their
/// names when the caller commits the set ([`OutputSet::commit`]), together with whatever
/// else the run staged there. `set`'s primary output should be `path`, so that the model
/// is renamed last. On error the files staged so far stay in `set` (dropping it removes
/// them).
pub fn stage_with_options(
    model: &Model,
    path: &Path,
    options: &ExportOptions,
    set: &mut OutputSet,
) -> Result<()> {
    let textures = &options.textures;
    let format = Format::from_path(path)?;
    validate_model(model)?;
    // PLY cannot refer to images; OBJ and POV-Ray cannot embed them, so they write files.
    let textures = match (format, textures) {
        (Format::Ply, _) => TextureMode::None,
        (Format::Obj | Format::Pov, TextureMode::Embed) => {
            TextureMode::Files { prefix: String::new() }.for_path(path)
        }
        (_, t) => t.clone(),
    };
    if let TextureMode::Files { prefix } = &textures {
        use rayon::prelude::*;
        let pngs: Vec<Vec<u8>> = model.images.par_iter().map(|i| i.image.to_png()).collect::<Result<_>>()?;
        let dir = path.parent().unwrap_or(Path::new(""));
        for (im, png) in model.images.iter().zip(&pngs) {
            set.stage(&dir.join(format!("{prefix}{}.png", im.name)), |w| w.write_all(png))?;
        }
    }
    let options = ExportOptions { textures, ..options.clone() };
    stage_model(model, path, format, &options, set)
}

/// [`stage_with_options`] after validation and the image files: the model file and its
/// `.mtl` or includes.
fn stage_model(
    model: &Model,
    path: &Path,
    format: Format,
    options: &ExportOptions,
    set: &mut OutputSet,
) -> Result<()> {
    let textures = &options.textures;
    match format {
        Format::Glb => {
            let bytes = gltf::glb_unchecked(model, options)?;
            set.stage(path, |w| w.write_all(&bytes))
        }
        Format::Gltf => {
            let json = gltf::gltf_json_unchecked(model, options)?;
            set.stage(path, |w| w.write_all(json.as_bytes()))
        }
        Format::Obj => {
            let mtl_path = path.with_extension("mtl");
            let mtl_name = mtl_path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "materials.mtl".to_owned());
            let prefix = match textures {
                TextureMode::Files { prefix } if !model.images.is_empty() => Some(prefix.as_str()),
                _ => None,
            };
            set.stage(&mtl_path, |w| obj::write_mtl_unchecked(model, w, prefix))?;
            set.stage(path, |w| obj::write_obj_unchecked(model, w, &mtl_name))
        }
        Format::Ply => set.stage(path, |w| ply::write_ply_unchecked(model, w)),
        Format::Pov => {
            let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            let dir = path.parent().unwrap_or(Path::new(""));
            let incs = pov::includes(model, &stem);
            let flat = model.flattened();
            for inc in &incs {
                set.stage(&dir.join(&inc.file), |w| {
                    pov::write_inc(&flat.parts[inc.part].mesh, &inc.ident, w)
                })?;
            }
            let prefix = match textures {
                TextureMode::Files { prefix } if !model.images.is_empty() => Some(prefix.as_str()),
                _ => None,
            };
            set.stage(path, |w| pov::write_scene(model, &incs, prefix, w))
        }
    }
}

/// Checks every part's and shape's mesh with [`Mesh::validate`] (and the parts of every
/// level of detail), every material number for finiteness, every extra vertex channel
/// ([`crate::model::VertexAttributes::validate`]), every instance for a shape that exists
/// and a finite transform, and that the model has at least one triangle.
///
/// The rig and its clip (issue 24): a rig has joints, each with a finite head and a
/// parent before it; a part's skin weights (only in a model with a rig) hold one entry per
/// position, joint indices below the joint count and finite, non-negative weights with a
/// positive sum; a clip (only with a rig) has at least one sample time, all finite,
/// non-negative and increasing, and one finite, non-zero rotation per joint and time;
/// LOD screen coverages are finite and non-negative.
///
/// The first problem is [`Error::InvalidGeometry`] naming the part, shape, instance, rig,
/// clip or LOD (or the model).
pub fn validate_model(model: &Model) -> Result<()> {
    let joints = model.rig.as_ref().map(|r| r.joints.len());
    let lod_parts = model
        .lods
        .iter()
        .enumerate()
        .flat_map(|(k, l)| l.parts.iter().map(move |p| (format!("LOD {} part", k + 1), p)));
    if let Some(rig) = &model.rig {
        let bad = |why: String| Error::InvalidGeometry { what: "rig".into(), why };
        if rig.joints.is_empty() {
            return Err(bad("has no joints".into()));
        }
        for (j, joint) in rig.joints.iter().enumerate() {
            if !joint.head.is_finite() {
                return Err(bad(format!("joint {j}'s head is not finite")));
            }
            if let Some(p) = joint.parent.filter(|&p| p as usize >= j) {
                return Err(bad(format!("joint {j}'s parent {p} does not come before it")));
            }
        }
    }
    if let Some(clip) = &model.clip {
        let bad = |why: String| Error::InvalidGeometry { what: format!("clip '{}'", clip.name), why };
        let Some(joints) = joints else {
            return Err(bad("the model has no rig to play it".into()));
        };
        validate_clip(clip, joints).map_err(bad)?;
    }
    let named = model
        .parts
        .iter()
        .map(|p| ("part".to_owned(), p))
        .chain(model.shapes.iter().map(|p| ("shape".to_owned(), p)))
        .chain(lod_parts);
    for (kind, part) in named {
        let bad = |why: String| Error::InvalidGeometry { what: format!("{kind} '{}'", part.name), why };
        part.mesh.validate().map_err(bad)?;
        let m = &part.material;
        if !(m.base_color.iter().all(|c| c.is_finite()) && m.metallic.is_finite() && m.roughness.is_finite())
        {
            return Err(bad(format!("material '{}' has a non-finite value", m.name)));
        }
        let positions = part.mesh.positions.len();
        part.attributes.validate(positions).map_err(bad)?;
        if let Some(skin) = &part.skin {
            let Some(joints) = joints else {
                return Err(bad("has skin weights, but the model has no rig".into()));
            };
            validate_skin(skin, positions, joints).map_err(bad)?;
        }
    }
    if !model.lods.is_empty() {
        let coverages =
            std::iter::once(model.lod0_coverage).chain(model.lods.iter().map(|l| l.screen_coverage));
        for (k, c) in coverages.enumerate() {
            if !(c.is_finite() && c >= 0.0) {
                return Err(Error::InvalidGeometry {
                    what: format!("LOD {k}"),
                    why: format!("its screen coverage {c} is not a finite, non-negative number"),
                });
            }
        }
    }
    for (k, inst) in model.instances.iter().enumerate() {
        let bad = |why: String| Error::InvalidGeometry { what: format!("instance {k}"), why };
        if inst.shape as usize >= model.shapes.len() {
            return Err(bad(format!("refers to shape {}, but there are {}", inst.shape, model.shapes.len())));
        }
        if !inst.transform.is_finite() {
            return Err(bad("its transform has a non-finite number".into()));
        }
        if Mat3::from_mat4(inst.transform).determinant().abs() < 1e-30 {
            return Err(bad("its transform is singular (a zero scale)".into()));
        }
    }
    let instanced = model.instances.iter().any(|i| model.shapes[i.shape as usize].mesh.face_count() > 0);
    if !instanced && model.parts.iter().all(|p| p.mesh.face_count() == 0) {
        return Err(Error::InvalidGeometry {
            what: "model".into(),
            why: "no triangles to export (every part is empty)".into(),
        });
    }
    Ok(())
}

/// Checks a part's skin weights against its position count and the rig's joint count.
fn validate_skin(
    skin: &crate::model::SkinWeights,
    positions: usize,
    joints: usize,
) -> std::result::Result<(), String> {
    if skin.joints.len() != positions || skin.weights.len() != positions {
        return Err(format!(
            "skin has {} joint and {} weight entries for {positions} positions",
            skin.joints.len(),
            skin.weights.len()
        ));
    }
    for (v, (j, w)) in skin.joints.iter().zip(&skin.weights).enumerate() {
        if let Some(&bad) = j.iter().find(|&&j| j as usize >= joints) {
            return Err(format!("vertex {v} refers to joint {bad}, but the rig has {joints}"));
        }
        if !w.iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err(format!("vertex {v} has a negative or non-finite skin weight"));
        }
        if w.iter().sum::<f32>() <= 0.0 {
            return Err(format!("vertex {v}'s skin weights sum to zero"));
        }
    }
    Ok(())
}

/// Checks a clip's times and its rotations against the rig's joint count.
fn validate_clip(clip: &crate::model::Clip, joints: usize) -> std::result::Result<(), String> {
    let t = &clip.times;
    if t.is_empty() {
        return Err("has no sample times".into());
    }
    if !t.iter().all(|x| x.is_finite() && *x >= 0.0) {
        return Err("a sample time is negative or not finite".into());
    }
    if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(format!("sample time {} ({}) does not increase on {}", i + 1, t[i + 1], t[i]));
    }
    if clip.rotations.len() != joints {
        return Err(format!("has rotations for {} joints, but the rig has {joints}", clip.rotations.len()));
    }
    for (j, r) in clip.rotations.iter().enumerate() {
        if r.len() != t.len() {
            return Err(format!("joint {j} has {} rotations for {} sample times", r.len(), t.len()));
        }
        if !r.iter().all(|q| q.is_finite() && q.length_squared() > 1e-12) {
            return Err(format!("joint {j} has a zero or non-finite rotation"));
        }
    }
    Ok(())
}

/// [`validate_model`] for the `std::io::Write` based writers: the error becomes an
/// `InvalidData` I/O error.
fn validate_io(model: &Model) -> std::io::Result<()> {
    validate_model(model).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()))
}

/// Marks a missing face-varying index in a [`VertexKey`].
pub use crate::geometry::NONE;

/// What makes an output vertex: a position index and the corner's UV and normal
/// indices ([`NONE`] when the mesh lacks that channel).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct VertexKey {
    /// Index into [`Mesh::positions`].
    pub position: u32,
    /// Index into the UV channel's values, or [`NONE`].
    pub uv: u32,
    /// Index into the normal channel's values, or [`NONE`].
    pub normal: u32,
}

/// A mesh's face corners unified into output vertices (see the [module docs](self)).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Unified {
    /// The distinct corner tuples, in order of first use; output vertex `i` is
    /// `vertices[i]`.
    pub vertices: Vec<VertexKey>,
    /// The output vertex of every face corner, parallel to [`Mesh::face_indices`].
    pub corner_vertex: Vec<u32>,
}

/// Unifies the face-varying channels of `mesh` into per-vertex attributes: one output
/// vertex per distinct (position, uv, normal) index tuple, numbered in order of first
/// use by the face corners. Positions no face uses get no vertex.
///
/// Runs in time linear in the corner count (times the number of distinct tuples sharing
/// one position, which is small: the corners of a seam), with no hashing. The mesh must
/// be valid ([`Mesh::validate`]); out-of-range indices are treated as missing rather
/// than causing a panic.
pub fn unify(mesh: &Mesh) -> Unified {
    let corners = mesh.face_indices.len();
    let uv_idx = mesh.uvs.as_ref().map(|c| c.indices.as_slice()).filter(|i| i.len() == corners);
    let n_idx = mesh.normals.as_ref().map(|c| c.indices.as_slice()).filter(|i| i.len() == corners);
    // head[p]: first output vertex at position p; next[v]: the next one at the same
    // position (a singly linked list per position, usually of length 1).
    let mut head = vec![NONE; mesh.positions.len()];
    let mut next: Vec<u32> = Vec::with_capacity(mesh.positions.len());
    let mut vertices: Vec<VertexKey> = Vec::with_capacity(mesh.positions.len());
    let mut corner_vertex = Vec::with_capacity(corners);
    for (c, &p) in mesh.face_indices.iter().enumerate() {
        let key = VertexKey {
            position: p,
            uv: uv_idx.map_or(NONE, |i| i[c]),
            normal: n_idx.map_or(NONE, |i| i[c]),
        };
        let Some(slot) = head.get_mut(p as usize) else {
            // Out-of-range position: only possible for an unvalidated mesh.
            corner_vertex.push(0);
            continue;
        };
        let mut v = *slot;
        let mut last = NONE;
        while v != NONE && vertices[v as usize] != key {
            last = v;
            v = next[v as usize];
        }
        if v == NONE {
            v = vertices.len() as u32;
            vertices.push(key);
            next.push(NONE);
            if last == NONE {
                *slot = v;
            } else {
                next[last as usize] = v;
            }
        }
        corner_vertex.push(v);
    }
    Unified { vertices, corner_vertex }
}

/// Smooth, area-weighted unit normals per position of `mesh`: the normalized sum of the
/// vector areas of the faces around each position.
/// Positions with no well-defined normal (unused, or only degenerate faces) get +Y.
pub fn smooth_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; mesh.positions.len()];
    let pos = |i: u32| mesh.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO);
    for w in mesh.face_offsets.windows(2) {
        let Some(face) = mesh.face_indices.get(w[0] as usize..w[1] as usize) else {
            continue;
        };
        // The fan's cross products sum to the polygon's vector area (times two): exact
        // for planar polygons, a fair average for bent ones. Relative to the first
        // corner, so that geometry far from the origin keeps its precision.
        let Some((&first, rest)) = face.split_first() else {
            continue;
        };
        let p0 = pos(first);
        let mut n = Vec3::ZERO;
        for pair in rest.windows(2) {
            n += (pos(pair[0]) - p0).cross(pos(pair[1]) - p0);
        }
        for &i in face {
            if let Some(a) = acc.get_mut(i as usize) {
                *a += n;
            }
        }
    }
    for a in &mut acc {
        *a = a.normalize_or(Vec3::Y);
    }
    acc
}

/// The per-vertex attributes of one part, ready for glTF or PLY: unified vertices and
/// the sources their normals and UVs come from.
pub(crate) struct VertexData<'a> {
    /// The mesh.
    pub mesh: &'a Mesh,
    /// Its unified vertices.
    pub unified: Unified,
    /// Smooth normals per position when the mesh has no normal channel.
    pub computed_normals: Option<Vec<Vec3>>,
}

impl<'a> VertexData<'a> {
    /// Unifies `mesh` and computes normals if it has none.
    pub fn new(mesh: &'a Mesh) -> Self {
        let unified = unify(mesh);
        let computed_normals = if mesh.normals.is_some() { None } else { Some(smooth_normals(mesh)) };
        VertexData { mesh, unified, computed_normals }
    }

    /// Whether the mesh has UVs.
    pub fn has_uvs(&self) -> bool {
        self.mesh.uvs.is_some()
    }

    /// Position of output vertex `k`.
    #[inline]
    pub fn position(&self, k: &VertexKey) -> Vec3 {
        self.mesh.positions.get(k.position as usize).copied().unwrap_or(Vec3::ZERO)
    }

    /// Unit normal of output vertex `k` (+Y when the given normal is zero).
    #[inline]
    pub fn normal(&self, k: &VertexKey) -> Vec3 {
        match (&self.computed_normals, &self.mesh.normals) {
            (Some(n), _) => n.get(k.position as usize).copied().unwrap_or(Vec3::Y),
            (None, Some(ch)) => {
                ch.values.get(k.normal as usize).copied().unwrap_or(Vec3::Y).normalize_or(Vec3::Y)
            }
            (None, None) => Vec3::Y,
        }
    }

    /// UV of output vertex `k` (zero when the mesh has none).
    #[inline]
    pub fn uv(&self, k: &VertexKey) -> Vec2 {
        self.mesh.uvs.as_ref().and_then(|ch| ch.values.get(k.uv as usize)).copied().unwrap_or(Vec2::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::FaceVarying;

    /// Two quads sharing the edge 1–2, with a UV seam along it: the shared positions
    /// 1 and 2 get different UVs in the two faces.
    fn seam_mesh(seam: bool) -> Mesh {
        let mut m = Mesh::new();
        m.positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::Y,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        m.push_face(&[0, 1, 2, 3]);
        m.push_face(&[1, 4, 5, 2]);
        let uv_indices = if seam { vec![0, 1, 2, 3, 4, 5, 6, 7] } else { vec![0, 1, 2, 3, 1, 4, 5, 2] };
        m.uvs = Some(FaceVarying { values: vec![Vec2::ZERO; 8], indices: uv_indices });
        m
    }

    #[test]
    fn shared_corners_merge() {
        let u = unify(&seam_mesh(false));
        assert_eq!(u.vertices.len(), 6);
        assert_eq!(u.corner_vertex, vec![0, 1, 2, 3, 1, 4, 5, 2]);
    }

    #[test]
    fn seam_corners_split() {
        let u = unify(&seam_mesh(true));
        assert_eq!(u.vertices.len(), 8);
        assert_eq!(u.corner_vertex, (0..8).collect::<Vec<_>>());
        // The two vertices at position 1 differ only in their UV index.
        assert_eq!(u.vertices[1], VertexKey { position: 1, uv: 1, normal: NONE });
        assert_eq!(u.vertices[4], VertexKey { position: 1, uv: 4, normal: NONE });
    }

    #[test]
    fn normal_channel_splits_too() {
        let mut m = seam_mesh(false);
        m.normals =
            Some(FaceVarying { values: vec![Vec3::Z, Vec3::X], indices: vec![0, 0, 0, 0, 1, 1, 1, 1] });
        let u = unify(&m);
        // Positions 1 and 2 have one UV but two normals.
        assert_eq!(u.vertices.len(), 8);
        assert_eq!(u.corner_vertex, vec![0, 1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(u.vertices[7], VertexKey { position: 2, uv: 2, normal: 1 });
    }

    #[test]
    fn no_channels_follows_positions_and_drops_unused() {
        let mut m = Mesh::new();
        m.positions = vec![Vec3::X, Vec3::ZERO, Vec3::Y, Vec3::Z];
        m.push_face(&[1, 0, 2]);
        let u = unify(&m);
        assert_eq!(u.vertices.iter().map(|k| k.position).collect::<Vec<_>>(), vec![1, 0, 2]);
        assert_eq!(u.corner_vertex, vec![0, 1, 2]);
    }

    #[test]
    fn smooth_normals_of_a_quad_face_up() {
        let mut m = Mesh::new();
        m.positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, -1.0), Vec3::NEG_Z, Vec3::Y * 5.0];
        m.push_face(&[0, 1, 2, 3]);
        let n = smooth_normals(&m);
        for v in &n[..4] {
            assert!((*v - Vec3::Y).length() < 1e-6, "{v}");
        }
        assert_eq!(n[4], Vec3::Y); // unused
    }

    #[test]
    fn format_from_path() {
        assert_eq!(Format::from_path(Path::new("a/b.GLB")).unwrap(), Format::Glb);
        assert_eq!(Format::from_path(Path::new("t.gltf")).unwrap(), Format::Gltf);
        assert_eq!(Format::from_path(Path::new("t.Obj")).unwrap(), Format::Obj);
        assert_eq!(Format::from_path(Path::new("t.ply")).unwrap(), Format::Ply);
        let e = Format::from_path(Path::new("t.xyz")).unwrap_err().to_string();
        assert!(e.contains("t.xyz") && e.contains(".glb, .gltf, .obj, .ply"), "{e}");
        assert!(Format::from_path(Path::new("noext")).is_err());
    }
}
