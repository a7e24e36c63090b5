//! Every embedded preset grows, and its tube mesh is a closed, consistently oriented
//! 2-manifold (each axis is closed at both ends, so every edge has exactly two faces);
//! an OBJ of it reads back with the same counts through an independent reader.

#[path = "common/edges.rs"]
mod edges;

use edges::check_closed_manifold;
use sylva::recipe;

#[test]
fn every_preset_meshes_closed_and_round_trips_through_obj() {
    let dir = std::env::temp_dir().join(format!("sylva-presets-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The presets grow on the rayon pool (CI has two cores).
    use rayon::prelude::*;
    sylva::presets::all().into_par_iter().filter(|p| !p.is_curves()).for_each(|p| {
        let loaded = recipe::load(p.name, &[]).unwrap();
        let grown = sylva::pipeline::grow(&loaded).unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let bark = &grown.model.parts[0].mesh;
        bark.validate().unwrap();
        check_closed_manifold(p.name, bark);
        assert!(grown.report.triangles > 0);

        let obj = dir.join(format!("{}.obj", p.name));
        sylva::export::write(&grown.model, &obj).unwrap();
        let (models, _) =
            tobj::load_obj(&obj, &tobj::LoadOptions { triangulate: false, ..Default::default() })
                .unwrap_or_else(|e| panic!("{}: tobj cannot read the OBJ: {e}", p.name));
        let positions: usize = models.iter().map(|m| m.mesh.positions.len() / 3).sum();
        // tobj leaves `face_arities` empty when every face of a model is a triangle.
        let faces: usize = models
            .iter()
            .map(|m| {
                if m.mesh.face_arities.is_empty() {
                    m.mesh.indices.len() / 3
                } else {
                    m.mesh.face_arities.len()
                }
            })
            .sum();
        let vertices: usize = grown.model.parts.iter().map(|p| p.mesh.vertex_count()).sum();
        let mesh_faces: usize = grown.model.parts.iter().map(|p| p.mesh.face_count()).sum();
        assert_eq!(positions, vertices, "{}: OBJ vertex count", p.name);
        assert_eq!(faces, mesh_faces, "{}: OBJ face count", p.name);
        for part in &grown.model.parts[1..] {
            part.mesh.validate().unwrap();
        }
    });
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn refine_section_subdivides_the_bark() {
    // The meshers' own ends (a flat base is cut after refinement, so it adds faces).
    let round = [recipe::parse_set("mesh.base=\"round\"").unwrap()];
    let plain = sylva::pipeline::grow(&recipe::load("lsys-honda-a", &round).unwrap()).unwrap();
    let sets: Vec<_> = ["refine.scheme=loop", "refine.levels=1", "mesh.base=\"round\""]
        .iter()
        .map(|s| recipe::parse_set(s).unwrap())
        .collect();
    let loaded = recipe::load("lsys-honda-a", &sets).unwrap();
    let refined = sylva::pipeline::grow(&loaded).unwrap();
    let (a, b) = (&plain.model.parts[0].mesh, &refined.model.parts[0].mesh);
    assert_eq!(b.face_count(), 4 * a.face_count());
    check_closed_manifold("lsys-honda-a refined", b);
    let bad: Vec<_> = ["refine.scheme=butterfly"].iter().map(|s| recipe::parse_set(s).unwrap()).collect();
    let e = recipe::load("lsys-honda-a", &bad).unwrap_err();
    assert!(e.to_string().contains("refine.scheme"), "{e}");
}

/// The catalogue (issue 6): every preset has a small picture in `docs/presets/` (grown)
/// or `docs/curves/` (curves), listed in `docs/presets.md`. Regenerate with
/// `tools/regen-previews.sh`.
#[test]
fn every_preset_has_a_catalogue_picture() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let catalogue = std::fs::read_to_string(root.join("docs/presets.md")).unwrap();
    for p in sylva::presets::all() {
        let dir = if p.name.starts_with("curves-") { "curves" } else { "presets" };
        let png = root.join(format!("docs/{dir}/{}.png", p.name));
        let len = std::fs::metadata(&png)
            .unwrap_or_else(|_| panic!("{} missing: run tools/regen-previews.sh", png.display()))
            .len();
        // Tree previews stay under 200 KB; curves pictures are dense line art (hair).
        let limit = if dir == "curves" { 400_000 } else { 200_000 };
        assert!(len < limit, "{}: {len} bytes (limit {limit})", png.display());
        assert!(catalogue.contains(&format!("`{}`", p.name)), "docs/presets.md does not list {}", p.name);
    }
}
