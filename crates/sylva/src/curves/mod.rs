//! Magnetic curves: stylised, spiralling abstract trees and ornaments drawn by charged
//! particles moving through a magnetic field (Xu2015 ch. 7, "Abstract Tree Modeling
//! with Magnetic Curves"; Xu2015-spec §3).
//!
//! ```text
//!  preset (TOML, kind = "curves") ─► Composition ─► layers ─► Drawing ─► Picture ─► .svg / .png
//!   load_preset (+ --set)            compose/       magnetic.rs (trace, branching)   render.rs
//!                                                   fill.rs (occupancy, ladder)      svg.rs
//!                                                   crate::noise (Perlin fields)
//!                                                   space.rs (3D, sphere) ─► Skeleton ─► tube mesh ─► .glb …
//! ```
//!
//! - [`magnetic`]: the particle, charge profiles `q(t)`, fields `B_z(x, y)`, the
//!   constant-speed exact integrator and recursive branching (§7.2.1–§7.2.3);
//! - [`fill`]: space filling with an occupancy grid, the parent-cell rule and the
//!   `(T, α)` ladder (§7.2.4);
//! - [`compose`]: the `[curves]` table and its layers (§7.3's compositions);
//! - [`render`]: tapered, outlined, coloured strokes to polygons and PNG;
//! - [`space`]: 3D curves, skeletons and curves on a sphere (§8.1 future work);
//! - [`svg`]: a picture as vector paths.
//!
//! A composition is a `kind = "curves"` preset (`presets/curves-*.toml`) or file; it is
//! not a `sylva grow` recipe. Drawing units are pixels with **y up**; with the defaults
//! `m = |v| = B = dt = 1` a curve of duration T is about T units long. Every random
//! choice flows from the preset's `seed` through `Pcg64`, so the same preset and seed
//! give byte-identical files.

pub mod compose;
pub mod fill;
pub mod magnetic;
pub mod render;
pub mod space;
pub mod svg;

use crate::error::{Error, Result};
use std::path::Path;

pub use compose::{CurvesSpec, Generated, LayerSpec, PresetFile, Stats};
pub use render::{Drawing, Picture};

/// The value of the top-level `kind` key that marks a curves composition.
pub const KIND: &str = "curves";

/// A loaded, checked composition.
#[derive(Debug, Clone, PartialEq)]
pub struct Composition {
    /// Its name (the preset's name or the file stem).
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Seed of every random choice.
    pub seed: u64,
    /// The `[curves]` table.
    pub spec: CurvesSpec,
}

/// Whether a parsed TOML document is a curves composition (`kind = "curves"`): the
/// recipe loader of `sylva grow` uses this to send such files to `sylva curves`.
pub fn is_curves_table(table: &toml::Table) -> bool {
    table.get("kind").and_then(|k| k.as_str()) == Some(KIND)
}

impl Composition {
    /// Builds a composition from a parsed preset after applying `sets` (`--set
    /// key=value`, dotted keys). `origin` names the source in messages. Unknown keys are
    /// errors naming the key with its path.
    pub fn from_table(mut table: toml::Table, sets: &[(String, toml::Value)], origin: &str) -> Result<Self> {
        for (k, v) in sets {
            crate::recipe::set_key(&mut table, k, v.clone())?;
        }
        if !is_curves_table(&table) {
            return Err(Error::Recipe(format!(
                "{origin} is not a curves composition (it lacks `kind = \"curves\"`); grow recipes go to `sylva grow`"
            )));
        }
        let file: PresetFile = serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(
            |e: serde_path_to_error::Error<toml::de::Error>| {
                let path = e.path().to_string();
                let why = e.into_inner().message().trim().to_string();
                if path == "." {
                    Error::Recipe(format!("{origin}: {why}"))
                } else {
                    Error::Recipe(format!("{origin}: `{path}`: {why}"))
                }
            },
        )?;
        let name = if file.name.is_empty() { origin.to_string() } else { file.name };
        Ok(Composition { name, description: file.description, seed: file.seed, spec: file.curves })
    }

    /// Runs every layer and returns the drawing, the 3D curves and statistics.
    pub fn generate(&self) -> Result<Generated> {
        compose::generate(&self.spec, self.seed, &self.name)
    }
}

/// Loads a composition: an embedded preset by name (`curves-klimt-tree`) or a `.toml`
/// file, with `--set` overrides applied before deserialization.
pub fn load_preset(name_or_path: &str, sets: &[(String, toml::Value)]) -> Result<Composition> {
    let path = Path::new(name_or_path);
    let is_file = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"))
        || name_or_path.contains('/')
        || name_or_path.contains('\\');
    let (text, origin) = if is_file {
        (
            crate::input::read_input_to_string(path, crate::input::DEFAULT_MAX_BYTES)?,
            path.display().to_string(),
        )
    } else if let Some(p) = crate::presets::get(name_or_path) {
        (p.recipe.to_string(), format!("preset `{}`", p.name))
    } else {
        let known: Vec<&str> =
            crate::presets::all().into_iter().map(|p| p.name).filter(|n| n.starts_with("curves-")).collect();
        return Err(Error::Recipe(format!(
            "unknown curves preset `{name_or_path}`; the curves presets are: {}",
            known.join(", ")
        )));
    };
    let table: toml::Table =
        toml::from_str(&text).map_err(|e| Error::Recipe(format!("{origin}: {}", e.to_string().trim())))?;
    let mut c = Composition::from_table(table, sets, &origin)?;
    if c.name == origin && !is_file {
        c.name = name_or_path.to_string();
    }
    Ok(c)
}

/// Output formats of a drawing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// Vector paths.
    Svg,
    /// Anti-aliased raster.
    Png,
    /// The 3D curves as a tube mesh (`.glb`, `.gltf`, `.obj`, `.ply`).
    Mesh(crate::export::Format),
}

impl Output {
    /// Picks the format from the extension of `path`.
    pub fn from_path(path: &Path) -> Result<Output> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "svg" => Ok(Output::Svg),
            "png" => Ok(Output::Png),
            _ => crate::export::Format::from_path(path).map(Output::Mesh).map_err(|_| Error::UnknownFormat {
                path: path.to_path_buf(),
                expected: ".svg, .png (drawings); .glb, .gltf, .obj, .ply (3D curves)",
            }),
        }
    }
}

/// Writes a drawing as SVG or PNG (by extension) `width_px` pixels wide, atomically;
/// outlines are simplified to 0.2 output pixels ([`render::tolerance_for`]).
pub fn write_drawing(drawing: &Drawing, path: &Path, width_px: u32) -> Result<()> {
    let picture = render::picture(drawing, render::tolerance_for(drawing, width_px));
    match Output::from_path(path)? {
        Output::Svg => svg::write(&picture, path, width_px),
        Output::Png => render::write_png(&picture, path, width_px),
        Output::Mesh(_) => Err(Error::UnknownFormat { path: path.to_path_buf(), expected: ".svg, .png" }),
    }
}

/// The 3D curves of `space` and `sphere` layers as a skeleton (see
/// [`space::to_skeleton`]); an error when the composition has none.
pub fn skeleton(generated: &Generated, opts: &space::SkeletonOptions) -> Result<crate::Skeleton> {
    if generated.curves3d.is_empty() {
        return Err(Error::Recipe(
            "this composition has no 3D curves (`space` or `sphere` layers); write .svg or .png instead"
                .into(),
        ));
    }
    space::to_skeleton(&generated.curves3d, opts)
}

/// The 3D curves meshed as tubes (`crate::mesh::tube`) in a one-part model.
pub fn model(generated: &Generated, opts: &space::SkeletonOptions) -> Result<crate::Model> {
    let sk = skeleton(generated, opts)?;
    let tube = crate::mesh::tube::tube_mesh(&sk, &crate::mesh::tube::TubeOptions::default())?;
    let mut material = crate::Material::bark();
    material.name = "curves".into();
    Ok(crate::Model {
        parts: vec![crate::Part { name: "curves".into(), mesh: tube.mesh, material, ..Default::default() }],
        ..Default::default()
    })
}

/// Writes a generated composition to `path`: `.svg`/`.png` draw it `width_px` wide;
/// mesh formats export its 3D curves as tubes. Atomic; no partial file on failure.
pub fn write(generated: &Generated, path: &Path, width_px: u32) -> Result<()> {
    match Output::from_path(path)? {
        Output::Mesh(_) => crate::export::write(&model(generated, &space::SkeletonOptions::default())?, path),
        _ => write_drawing(&generated.drawing, path, width_px),
    }
}

/// Writes the SVG text of a drawing to any writer (no file).
pub fn svg_string(drawing: &Drawing, width_px: u32) -> Result<String> {
    svg::to_svg(&render::picture(drawing, render::tolerance_for(drawing, width_px)), width_px)
}

/// Encodes a drawing as PNG bytes (no file).
pub fn png_bytes(drawing: &Drawing, width_px: u32) -> Result<Vec<u8>> {
    let raster =
        render::rasterize(&render::picture(drawing, render::tolerance_for(drawing, width_px)), width_px)?;
    let mut out = Vec::new();
    render::encode_png(&raster, &mut out)
        .map_err(|e| Error::InvalidGeometry { what: "PNG encoder".into(), why: e.to_string() })?;
    Ok(out)
}
