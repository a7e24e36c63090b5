//! `sylva.Tree`, `sylva.Skeleton` and `sylva.Part`: what a grow made, as numpy arrays
//! and files.
//!
//! A part's arrays are the ones its glTF primitive holds (the engine's
//! [`sylva::export::unify`]: one vertex per distinct position, UV and normal of a face
//! corner, faces fan-triangulated, normals unit length or smooth where the mesh has
//! none, UVs with v flipped to glTF's top-left origin), so `tree.parts` and the arrays a
//! glTF reader finds in `tree.to_glb()` agree vertex for vertex.

use crate::convert::{array1, array2, image};
use crate::errors::guard;
use glam::{Vec2, Vec3};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;
use std::sync::Arc;
use sylva::recipe::Loaded;

/// A branching skeleton: nodes stored parent-first (a node's parent has a smaller
/// index), as numpy arrays.
#[pyclass(module = "sylva", name = "Skeleton", frozen)]
pub struct Skeleton {
    /// The skeleton.
    pub skeleton: Arc<sylva::Skeleton>,
}

#[pymethods]
impl Skeleton {
    /// Node positions, `(N, 3)` float32, metres, +Y up.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array2(py, self.skeleton.position.iter().flat_map(|p| p.to_array()).collect(), 3)
    }

    /// Each node's parent index, `(N,)` int32; −1 for a root.
    #[getter]
    fn parents<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let p = self.skeleton.parent.iter().map(|&p| if p == sylva::NO_PARENT { -1 } else { p as i32 });
        array1(py, p.collect::<Vec<i32>>())
    }

    /// Node radii, `(N,)` float32, metres.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        array1(py, self.skeleton.radius.clone())
    }

    /// Branch order of each node, `(N,)` int32: 0 on the trunk, +1 per branching.
    #[getter]
    fn order<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        array1(py, self.skeleton.order.iter().map(|&o| o as i32).collect::<Vec<i32>>())
    }

    /// Each node's orientation reference (the turtle's up), `(N, 3)` float32.
    #[getter]
    fn up<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array2(py, self.skeleton.up.iter().flat_map(|p| p.to_array()).collect(), 3)
    }

    /// Number of organs (leaves, flowers) placed on the skeleton.
    #[getter]
    fn organ_count(&self) -> usize {
        self.skeleton.organs.len()
    }

    /// Number of nodes.
    fn __len__(&self) -> usize {
        self.skeleton.position.len()
    }

    fn __repr__(&self) -> String {
        let s = self.skeleton.stats();
        format!("<sylva.Skeleton: {} nodes, {} tips, max order {}>", s.nodes, s.tips, s.max_order)
    }
}

/// One part of the model (`bark`, `leaves`, …): a triangle mesh as numpy arrays, its
/// material and the material's images.
#[pyclass(module = "sylva", name = "Part", frozen)]
pub struct Part {
    /// The part's name (the glTF node and mesh name).
    #[pyo3(get)]
    name: String,
    /// Vertex positions, `(V, 3)` float32.
    #[pyo3(get)]
    vertices: Py<PyAny>,
    /// Triangles as vertex indices, `(T, 3)` uint32, counter-clockwise seen from outside.
    #[pyo3(get)]
    faces: Py<PyAny>,
    /// Unit vertex normals, `(V, 3)` float32.
    #[pyo3(get)]
    normals: Py<PyAny>,
    /// Texture coordinates, `(V, 2)` float32, glTF's convention (origin top left);
    /// None when the part has none.
    #[pyo3(get)]
    uvs: Py<PyAny>,
    /// The material: `name`, `base_color` (linear RGBA), `metallic`, `roughness`,
    /// `double_sided`, `alpha_cutoff` (None: opaque).
    #[pyo3(get)]
    material: Py<PyAny>,
    /// The material's texture maps by role (`base_color`, `normal`,
    /// `occlusion_roughness_metallic`), each `(H, W, C)` uint8 (C = 3 or 4); only the
    /// maps the material has (and only where the part has UVs).
    #[pyo3(get)]
    images: Py<PyAny>,
}

#[pymethods]
impl Part {
    fn __repr__(&self, py: Python<'_>) -> String {
        let n = |a: &Py<PyAny>| a.bind(py).len().unwrap_or(0);
        format!("<sylva.Part {:?}: {} vertices, {} triangles>", self.name, n(&self.vertices), n(&self.faces))
    }
}

/// The arrays of `part` (of a model whose images are `images`).
fn part(py: Python<'_>, part: &sylva::Part, images: &[sylva::model::ModelImage]) -> PyResult<Part> {
    let mesh = &part.mesh;
    let unified = sylva::export::unify(mesh);
    let computed = if mesh.normals.is_some() { None } else { Some(sylva::export::smooth_normals(mesh)) };
    let keys = &unified.vertices;
    let position =
        |k: &sylva::export::VertexKey| mesh.positions.get(k.position as usize).copied().unwrap_or(Vec3::ZERO);
    let normal = |k: &sylva::export::VertexKey| match (&computed, &mesh.normals) {
        (Some(n), _) => n.get(k.position as usize).copied().unwrap_or(Vec3::Y),
        (None, Some(ch)) => {
            ch.values.get(k.normal as usize).copied().unwrap_or(Vec3::Y).normalize_or(Vec3::Y)
        }
        (None, None) => Vec3::Y,
    };
    let vertices = array2(py, keys.iter().flat_map(|k| position(k).to_array()).collect(), 3)?;
    let normals = array2(py, keys.iter().flat_map(|k| normal(k).to_array()).collect(), 3)?;
    let uvs = match &mesh.uvs {
        Some(ch) => {
            let uv =
                |k: &sylva::export::VertexKey| ch.values.get(k.uv as usize).copied().unwrap_or(Vec2::ZERO);
            array2(py, keys.iter().flat_map(|k| [uv(k).x, 1.0 - uv(k).y]).collect(), 2)?
        }
        None => py.None().into_bound(py),
    };
    let cv = &unified.corner_vertex;
    let mut tris: Vec<u32> = Vec::with_capacity(mesh.triangle_count() * 3);
    for w in mesh.face_offsets.windows(2) {
        let Some(face) = cv.get(w[0] as usize..w[1] as usize) else { continue };
        let Some((&first, rest)) = face.split_first() else { continue };
        for pair in rest.windows(2) {
            tris.extend_from_slice(&[first, pair[0], pair[1]]);
        }
    }
    let faces = array2(py, tris, 3)?;
    let m = &part.material;
    let material = PyDict::new(py);
    material.set_item("name", &m.name)?;
    material.set_item("base_color", m.base_color.to_vec())?;
    material.set_item("metallic", m.metallic)?;
    material.set_item("roughness", m.roughness)?;
    material.set_item("double_sided", m.double_sided)?;
    material.set_item("alpha_cutoff", m.alpha_cutoff)?;
    let maps = PyDict::new(py);
    if mesh.uvs.is_some() {
        let roles = [
            ("base_color", m.maps.base_color),
            ("normal", m.maps.normal),
            ("occlusion_roughness_metallic", m.maps.occlusion_roughness_metallic),
        ];
        for (role, index) in roles {
            if let Some(img) = index.and_then(|i| images.get(i as usize)) {
                maps.set_item(role, image(py, &img.image)?)?;
            }
        }
    }
    Ok(Part {
        name: part.name.clone(),
        vertices: vertices.unbind(),
        faces: faces.unbind(),
        normals: normals.unbind(),
        uvs: uvs.unbind(),
        material: material.into_any().unbind(),
        images: maps.into_any().unbind(),
    })
}

/// A grown tree: its skeleton, its model's parts as numpy arrays, its files and
/// preview, and the report of the run. `str(tree)` is the summary `sylva grow` prints.
#[pyclass(module = "sylva", name = "Tree", frozen)]
pub struct Tree {
    tree: Arc<sylva::Tree>,
    /// What it was grown from (its origin, where the recipe's files are read).
    base: Loaded,
}

impl Tree {
    /// A tree grown from `base` (whose origin `tree.recipe` keeps, so it reads its
    /// files from where the grown recipe did).
    pub fn grown_from(tree: sylva::Tree, base: Loaded) -> Tree {
        Tree { tree: Arc::new(tree), base }
    }
}

/// The lower-cased extension of `path`.
fn ext(path: &std::path::Path) -> String {
    path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase()
}

#[pymethods]
impl Tree {
    /// The skeleton the mesh was built on (`positions`, `parents`, `radii`, `order`).
    #[getter]
    fn skeleton(&self) -> Skeleton {
        Skeleton { skeleton: Arc::new(self.tree.skeleton.clone()) }
    }

    /// The model's parts with triangles, each as numpy arrays (`vertices`, `faces`,
    /// `normals`, `uvs`) with its material and images — the primitives of the `.glb`,
    /// in its order. Instanced organs are in `instances`. Built on each access.
    #[getter]
    fn parts(&self, py: Python<'_>) -> PyResult<Vec<Part>> {
        let model = &self.tree.model;
        model
            .parts
            .iter()
            .filter(|p| p.mesh.triangle_count() > 0)
            .map(|p| part(py, p, &model.images))
            .collect()
    }

    /// Instanced organs (leaves the `.glb` writes once with `EXT_mesh_gpu_instancing`):
    /// a list of `(part, transforms)`, `transforms` `(K, 4, 4)` float32 matrices
    /// (column vectors: `p' = M @ p`) placing the part's copies. Empty when the leaves
    /// are merged into `parts`.
    #[getter]
    fn instances<'py>(&self, py: Python<'py>) -> PyResult<Vec<(Part, Bound<'py, PyAny>)>> {
        let model = &self.tree.model;
        let mut out = Vec::new();
        for (s, shape) in model.shapes.iter().enumerate() {
            let mats: Vec<f32> = model
                .instances
                .iter()
                .filter(|i| i.shape as usize == s)
                .flat_map(|i| i.transform.transpose().to_cols_array())
                .collect();
            if mats.is_empty() {
                continue;
            }
            let k = mats.len() / 16;
            let arr = array2(py, mats, 16)?.call_method1("reshape", ((k, 4, 4),))?;
            out.push((part(py, shape, &model.images)?, arr));
        }
        Ok(out)
    }

    /// The tree as binary glTF bytes (`.glb`), with the recipe's `[output]` settings.
    fn to_glb<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let tree = self.tree.clone();
        let bytes = py.detach(move || guard(|| tree.to_glb()))?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// Writes the tree to `path` in the format its extension names: `.glb`, `.gltf`,
    /// `.obj` (+ `.mtl` and textures), `.ply`, `.pov`, the skeleton as `.lst` or `.json`,
    /// or the preview as `.png` (`output.preview_size` pixels). The files reach their
    /// names together or not at all.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let tree = self.tree.clone();
        py.detach(move || {
            guard(|| {
                if ext(&path) == "png" {
                    let size = tree.recipe.output.preview_size;
                    let opts =
                        sylva::preview::PreviewOptions { width: size, height: size, ..Default::default() };
                    let img = sylva::preview::render(&tree.model, &opts)?;
                    sylva::preview::write_png(&img, &path)
                } else {
                    tree.write(&path)
                }
            })
        })
    }

    /// A preview picture (the CPU renderer), `size` × `size` pixels, as PNG bytes.
    /// `azimuth` and `elevation` (degrees) fix the view; by default it is chosen from
    /// the tree's shape.
    #[pyo3(signature = (size=512, azimuth=None, elevation=None))]
    fn preview<'py>(
        &self,
        py: Python<'py>,
        size: u32,
        azimuth: Option<f32>,
        elevation: Option<f32>,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let view = match (azimuth, elevation) {
            (None, None) => None,
            (a, e) => Some(sylva::preview::ViewAngles {
                azimuth_deg: a.unwrap_or(0.0),
                elevation_deg: e.unwrap_or(15.0),
            }),
        };
        let tree = self.tree.clone();
        let png = py.detach(move || {
            guard(|| {
                let opts =
                    sylva::preview::PreviewOptions { width: size, height: size, view, ..Default::default() };
                sylva::preview::render(&tree.model, &opts)?.to_png()
            })
        })?;
        Ok(PyBytes::new(py, &png))
    }

    /// The preview Jupyter shows (512 × 512 PNG bytes).
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        self.preview(py, 512, None, None)
    }

    /// What the run built, as a dict: `steps`, `modules`, skeleton statistics (`nodes`,
    /// `segments`, `tips`, `depth`, `max_order`, `total_length`, `height`), `axes`,
    /// `triangles`, `vertices`, `joints`, `warnings`, `missing_surfaces`, `summary`,
    /// stage times in seconds (`stage_times`, `derive_time`, `interpret_time`,
    /// `mesh_time`, `wind_time`) and `text` (the printed summary's lines).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = &self.tree.report;
        let s = &r.skeleton;
        let d = PyDict::new(py);
        d.set_item("steps", r.steps)?;
        d.set_item("modules", r.modules)?;
        d.set_item("nodes", s.nodes)?;
        d.set_item("segments", s.segments)?;
        d.set_item("tips", s.tips)?;
        d.set_item("depth", s.depth)?;
        d.set_item("max_order", s.max_order)?;
        d.set_item("total_length", s.total_length)?;
        d.set_item("height", s.bounds.1.y - s.bounds.0.y)?;
        d.set_item("axes", r.axes)?;
        d.set_item("triangles", r.triangles)?;
        d.set_item("vertices", r.vertices)?;
        d.set_item("joints", r.joints)?;
        d.set_item("warnings", r.warnings.clone())?;
        d.set_item("missing_surfaces", r.missing_surfaces.clone())?;
        d.set_item("summary", &r.summary)?;
        let times = PyDict::new(py);
        for (name, t) in &r.stage_times {
            times.set_item(*name, t.as_secs_f64())?;
        }
        d.set_item("stage_times", times)?;
        d.set_item("derive_time", r.derive_time.as_secs_f64())?;
        d.set_item("interpret_time", r.interpret_time.as_secs_f64())?;
        d.set_item("mesh_time", r.mesh_time.as_secs_f64())?;
        d.set_item("wind_time", r.wind_time.as_secs_f64())?;
        d.set_item("text", r.to_string())?;
        Ok(d)
    }

    /// The recipe the tree was grown from.
    #[getter]
    fn recipe(&self) -> PyResult<crate::recipe::Recipe> {
        let mut loaded = self.base.clone();
        loaded.recipe = self.tree.recipe.clone();
        Ok(crate::recipe::Recipe { loaded })
    }

    /// The seed it was grown with.
    #[getter]
    fn seed(&self) -> u64 {
        self.tree.recipe.seed
    }

    /// Triangles in the model (LOD0, instances counted once per copy as the report does).
    #[getter]
    fn triangles(&self) -> usize {
        self.tree.report.triangles
    }

    /// Vertices in the model.
    #[getter]
    fn vertices(&self) -> usize {
        self.tree.report.vertices
    }

    fn __str__(&self) -> String {
        self.tree.to_string()
    }

    fn __repr__(&self) -> String {
        format!(
            "<sylva.Tree {:?}: {} nodes, {} triangles>",
            self.tree.recipe.name, self.tree.report.skeleton.nodes, self.tree.report.triangles
        )
    }
}
