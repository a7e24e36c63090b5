//! Flat trunk bases (issue 23): with `mesh.base = "flat"` (the default) every mesher's
//! tree stands on y = 0 — the lowest bark point of an upright tree is exactly the root's
//! height — and the joint meshers' bark stays a closed, oriented manifold; `round` keeps
//! the meshers' own ends.

#[path = "common/checks.rs"]
mod checks;

use checks::closed_oriented_manifold;

/// The bark of `preset` meshed by `method` with `mesh.base = base`, the run's warnings,
/// and the root's position and radius.
fn bark(preset: &str, method: &str, base: &str) -> (sylva::Mesh, Vec<String>, glam::Vec3, f32) {
    let sets = [
        ("mesh.method".to_string(), toml::Value::String(method.into())),
        ("mesh.base".to_string(), toml::Value::String(base.into())),
    ];
    let loaded = sylva::recipe::load(preset, &sets).unwrap();
    let grown = sylva::pipeline::grow(&loaded).unwrap();
    assert_eq!(grown.skeleton.position[0].y, 0.0, "{preset}: the skeleton keeps its root");
    let part = grown.model.parts.iter().find(|p| p.name == "bark").unwrap();
    (part.mesh.clone(), grown.report.warnings, grown.skeleton.position[0], grown.skeleton.radius[0])
}

/// The lowest bark point at the trunk's base: within four root radii of the root,
/// horizontally (branches lying on the ground elsewhere are the generator's).
fn lowest(mesh: &sylva::Mesh, root: glam::Vec3, radius: f32) -> f32 {
    let near = |p: &&glam::Vec3| glam::Vec2::new(p.x - root.x, p.z - root.z).length() <= 4.0 * radius;
    mesh.positions.iter().filter(near).map(|p| p.y).fold(f32::INFINITY, f32::min)
}

#[test]
fn every_mesher_stands_on_the_ground() {
    for preset in ["lsys-honda-a", "bcm-elm"] {
        for method in ["tube", "hull", "sweep", "quad"] {
            let (mesh, warnings, root, radius) = bark(preset, method, "flat");
            let y = lowest(&mesh, root, radius);
            assert!(y.abs() <= 1e-6, "{preset} / {method}: lowest bark point at y = {y}");
            assert!(!warnings.iter().any(|w| w.contains("flat base")), "{preset} / {method}: {warnings:?}");
            if method != "tube" {
                if let Err(e) = closed_oriented_manifold(&mesh, false) {
                    panic!("{preset} / {method}: {e}");
                }
            }
        }
    }
}

#[test]
fn round_keeps_the_meshers_own_ends() {
    // bcm-elm's hull and quad ends reach below its root; flat cuts them at its height.
    let (hull, _, root, radius) = bark("bcm-elm", "hull", "round");
    let (quad, ..) = bark("bcm-elm", "quad", "round");
    let (h, q) = (lowest(&hull, root, radius), lowest(&quad, root, radius));
    assert!(h < -1e-3 && q < -1e-3, "hull {h}, quad {q}");
}

#[test]
fn a_bad_base_is_an_error_naming_the_key() {
    let sets = [("mesh.base".to_string(), toml::Value::String("pointy".into()))];
    let e = sylva::recipe::load("lsys-honda-a", &sets).unwrap_err().to_string();
    assert!(e.contains("mesh.base") && e.contains("pointy"), "{e}");
}
