//! The LOD chain (issue 24, item 4): every level within ±10 % of its triangle budget,
//! LOD1 and LOD2 keep LOD0's silhouette from four views (≥ 90 %, ≥ 80 %), and the
//! impostor's billboards, seen from the eight side directions, cover LOD0's silhouette
//! (≥ 85 %). `cargo test --release -p sylva --test lod -- --nocapture` prints the
//! measured numbers (docs/lod.md records them).

use glam::Vec3;
use sylva::lod::{LevelKind, LevelReport};
use sylva::model::{Model, Part};
use sylva::preview::{render, PreviewOptions, ViewAngles};

fn sets(levels: &[i64], impostor: bool, extra: &[(&str, toml::Value)]) -> Vec<(String, toml::Value)> {
    let mut out = vec![
        (
            "lod.levels".to_string(),
            toml::Value::Array(levels.iter().map(|&b| toml::Value::Integer(b)).collect()),
        ),
        ("lod.impostor".to_string(), toml::Value::Boolean(impostor)),
    ];
    out.extend(extra.iter().map(|(k, v)| (k.to_string(), v.clone())));
    out
}

/// The full model and skeleton of `preset` (no LOD chain), and the model with the
/// chain built by the pipeline's LOD stage, with its level reports.
fn chain(preset: &str, sets: &[(String, toml::Value)]) -> (sylva::pipeline::Grown, Model, Vec<LevelReport>) {
    let loaded = sylva::recipe::load(preset, sets).unwrap();
    let mut plain = loaded.clone();
    plain.recipe.lod = Default::default();
    let full = sylva::pipeline::grow(&plain).unwrap();
    let mut model = full.model.clone();
    let mut report = sylva::pipeline::Report::default();
    let t = std::time::Instant::now();
    let levels =
        sylva::pipeline::lod_stage(&loaded, &full.skeleton, &Default::default(), &mut model, &mut report)
            .unwrap();
    println!("{preset}: chain built in {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    for w in &report.warnings {
        println!("  warning: {w}");
    }
    for (k, l) in levels.iter().enumerate() {
        let parts: Vec<String> = l
            .parts
            .iter()
            .map(|p| format!("{} {} → {} ({:?})", p.name, p.meshed, p.triangles, p.method))
            .collect();
        println!(
            "  LOD{k} {:?}: budget {:?}, {} triangles, {} cards, {} nodes, coverage {:.4}, {:.1} ms; {:?}; {}",
            l.kind,
            l.budget,
            l.triangles,
            l.cards,
            l.nodes.len(),
            l.screen_coverage,
            l.time.as_secs_f64() * 1e3,
            l.settings,
            parts.join(", ")
        );
    }
    (full, model, levels)
}

/// Level `k`'s parts (0: the model's own).
fn level(model: &Model, k: usize) -> &[Part] {
    if k == 0 {
        &model.parts
    } else {
        &model.lods[k - 1].parts
    }
}

/// The parts alone, with the model's images, as a model the preview can draw.
fn alone(model: &Model, parts: &[Part]) -> Model {
    Model { parts: parts.to_vec(), images: model.images.clone(), ..Default::default() }
}

const BACKGROUND: [u8; 3] = [236, 233, 225];

/// The covered pixels (not the flat background) of a render.
fn mask(model: &Model, opts: &PreviewOptions) -> Vec<bool> {
    let image = render(model, opts).unwrap();
    image.data.chunks(4).map(|p| p[..3] != BACKGROUND).collect()
}

fn options(
    frame: (Vec3, Vec3),
    size: u32,
    azimuth_deg: f32,
    elevation_deg: f32,
    fov_deg: f32,
) -> PreviewOptions {
    PreviewOptions {
        width: size,
        height: size,
        background: BACKGROUND,
        background_top: BACKGROUND,
        supersample: 1,
        fov_deg,
        view: Some(ViewAngles { azimuth_deg, elevation_deg }),
        frame: Some(frame),
    }
}

/// The share of `reference`'s covered pixels that `other` covers too.
fn covers(reference: &[bool], other: &[bool]) -> f64 {
    let both = reference.iter().zip(other).filter(|(a, b)| **a && **b).count();
    both as f64 / reference.iter().filter(|a| **a).count().max(1) as f64
}

/// Each level within ±10 % of its budget (or the full model as it is, under it).
fn check_budgets(levels: &[LevelReport]) {
    for (k, l) in levels.iter().enumerate() {
        let Some(budget) = l.budget else { continue };
        let off = l.triangles as f64 / budget as f64 - 1.0;
        println!("  LOD{k}: {} of {budget} triangles ({:+.2} %)", l.triangles, off * 100.0);
        match l.kind {
            LevelKind::AsIs => assert!(l.triangles as f64 <= budget as f64 * 1.1),
            _ => assert!(off.abs() <= 0.1, "LOD{k}: {} triangles for a budget of {budget}", l.triangles),
        }
    }
}

/// Everything a level must be: valid meshes, the full model's part names and
/// materials, decreasing coverages, a model the exporters accept.
fn check_structure(full: &Model, model: &Model) {
    sylva::export::validate_model(model).unwrap();
    let mut last = f32::INFINITY;
    for (k, c) in
        std::iter::once(model.lod0_coverage).chain(model.lods.iter().map(|l| l.screen_coverage)).enumerate()
    {
        assert!(c > 0.0 && c < last, "LOD{k}'s coverage {c} after {last}");
        last = c;
    }
    for k in 0..=model.lods.len() {
        for p in level(model, k) {
            p.mesh.validate().unwrap();
            if p.name == "impostor" {
                continue;
            }
            let original = full.parts.iter().chain(&full.shapes).find(|q| q.name == p.name);
            let original = original
                .unwrap_or_else(|| panic!("LOD{k} part `{}` is not a part of the full model", p.name));
            assert_eq!(
                p.material, original.material,
                "LOD{k} part `{}` shares the full model's material",
                p.name
            );
            if let Some(n) = &p.mesh.normals {
                assert!(n.values.iter().all(|v| (v.length() - 1.0).abs() < 1e-3), "unit normals");
            }
            if let Some(uv) = &p.mesh.uvs {
                assert_eq!(uv.indices.len(), p.mesh.face_indices.len());
            }
        }
    }
}

/// LOD1 and LOD2 against LOD0 from four views; returns the shares.
fn silhouettes(model: &Model, size: u32) -> Vec<Vec<f64>> {
    let frame = alone(model, level(model, 0)).bounds().unwrap();
    let views = [0.0f32, 90.0, 180.0, 270.0];
    let lod0: Vec<Vec<bool>> = views
        .iter()
        .map(|&az| mask(&alone(model, level(model, 0)), &options(frame, size, az, 10.0, 30.0)))
        .collect();
    (1..=model.lods.len().min(2))
        .map(|k| {
            views
                .iter()
                .zip(&lod0)
                .map(|(&az, reference)| {
                    covers(
                        reference,
                        &mask(&alone(model, level(model, k)), &options(frame, size, az, 10.0, 30.0)),
                    )
                })
                .collect()
        })
        .collect()
}

/// The impostor (the last level) against LOD0 from the eight side directions, with a
/// near-orthographic camera (5° field of view), as the atlas frames are drawn.
fn impostor_match(model: &Model, size: u32) -> Vec<f64> {
    let frame = alone(model, level(model, 0)).bounds().unwrap();
    let imp = model.lods.last().unwrap();
    assert_eq!(imp.parts[0].name, "impostor");
    (0..8)
        .map(|k| {
            let opts = options(frame, size, 45.0 * k as f32, 0.0, 5.0);
            covers(&mask(&alone(model, level(model, 0)), &opts), &mask(&alone(model, &imp.parts), &opts))
        })
        .collect()
}

fn percent(v: &[f64]) -> String {
    v.iter().map(|x| format!("{:.1} %", x * 100.0)).collect::<Vec<_>>().join(", ")
}

/// The cheap one: Honda's tree a (40,960 bark triangles, no leaves), small atlas.
#[test]
fn honda_chain_hits_its_budgets() {
    let s = sets(
        &[20000, 5000, 1000],
        true,
        &[("lod.atlas_size", toml::Value::Integer(256)), ("lod.atlas_frames", toml::Value::Integer(4))],
    );
    let (full, model, levels) = chain("lsys-honda-a", &s);
    check_budgets(&levels);
    check_structure(&full.model, &model);
    assert_eq!(levels.len(), 4);
    assert_eq!(levels[3].kind, LevelKind::Impostor);
    let names: Vec<&str> = model.images.iter().map(|i| i.name.as_str()).collect();
    assert!(names.ends_with(&["impostor_albedo", "impostor_normal"]), "{names:?}");
    let albedo = &model.images[model.images.len() - 2].image;
    assert_eq!((albedo.width, albedo.height, albedo.channels), (256, 256, 4));
    assert!(albedo.data.chunks(4).any(|p| p[3] == 255) && albedo.data.chunks(4).any(|p| p[3] == 0));
    let sil = silhouettes(&model, 128);
    println!("lsys-honda-a silhouettes (128 px): LOD1 {}; LOD2 {}", percent(&sil[0]), percent(&sil[1]));
    println!("lsys-honda-a impostor (128 px): {}", percent(&impostor_match(&model, 128)));
}

/// A budget above the full model's triangles keeps the full model, and says so; the
/// same recipe gives the same chain.
#[test]
fn a_generous_budget_keeps_the_full_model_and_the_chain_is_deterministic() {
    let s = sets(&[100000, 5000], false, &[]);
    let (full, model, levels) = chain("lsys-honda-a", &s);
    assert_eq!(levels[0].kind, LevelKind::AsIs);
    assert_eq!(model.parts, full.model.parts, "LOD0 is the full model");
    assert_eq!(model.lods.len(), 1);
    let (_, again, _) = chain("lsys-honda-a", &s);
    assert_eq!(again, model);
    // Through `grow` as well, with the warning in the report.
    let grown = sylva::pipeline::grow(&sylva::recipe::load("lsys-honda-a", &s).unwrap()).unwrap();
    assert_eq!(grown.model.lods, model.lods);
    assert!(
        grown.report.warnings.iter().any(|w| w.contains("LOD0") && w.contains("as it is")),
        "{:?}",
        grown.report.warnings
    );
}

/// Chain options of one level of 1,000 triangles, no impostor, 8 sides, no cards.
fn options_without_impostor() -> sylva::lod::LodOptions {
    sylva::lod::LodOptions {
        budgets: vec![1000],
        impostor: false,
        atlas_frames: 8,
        atlas_size: 1024,
        sides: 8,
        min_sides: 3,
        refine_factor: 1,
        per_card: 0,
    }
}

#[test]
fn bad_options_are_errors() {
    let (full, _, _) = chain("lsys-honda-a", &sets(&[1000], false, &[]));
    let opts = sylva::lod::LodOptions { budgets: vec![1000, 2000], ..options_without_impostor() };
    let mut never =
        |_: &sylva::Skeleton, _: &sylva::lod::LevelSettings| -> sylva::Result<Model> { unreachable!() };
    let e = sylva::lod::build_chain(&full.model, &full.skeleton, &opts, &mut never).unwrap_err();
    assert!(e.to_string().contains("decrease"), "{e}");
    let e = sylva::lod::build_chain(
        &full.model,
        &full.skeleton,
        &sylva::lod::LodOptions { budgets: vec![], ..opts.clone() },
        &mut never,
    )
    .unwrap_err();
    assert!(e.to_string().contains("no levels"), "{e}");
    let e = sylva::lod::build_chain(
        &Model::default(),
        &full.skeleton,
        &sylva::lod::LodOptions { budgets: vec![100], ..opts.clone() },
        &mut never,
    )
    .unwrap_err();
    assert!(e.to_string().contains("no triangles"), "{e}");
    // A failing re-mesh is the chain's error.
    let mut failing = |_: &sylva::Skeleton, _: &sylva::lod::LevelSettings| -> sylva::Result<Model> {
        Err(sylva::Error::Recipe("remesh failed".into()))
    };
    let e = sylva::lod::build_chain(
        &full.model,
        &full.skeleton,
        &sylva::lod::LodOptions { budgets: vec![100], ..opts },
        &mut failing,
    )
    .unwrap_err();
    assert!(e.to_string().contains("remesh failed"), "{e}");
    let e = sylva::recipe::load("lsys-honda-a", &sets(&[1000, 1000], false, &[])).unwrap_err();
    assert!(e.to_string().contains("lod.levels"), "{e}");
    let e = sylva::preview::render_layers(&full.model.parts, &[], &[], 0, 1).unwrap_err();
    assert!(e.to_string().contains("size"), "{e}");
}

/// A cancelled token stops the chain with `Error::Cancelled` before any level is
/// re-meshed (it is checked per level, per part before simplification and before the
/// impostor's views are drawn); the same call without the token builds the chain.
#[test]
fn a_cancelled_token_stops_the_chain() {
    let (full, _, _) = chain("lsys-honda-a", &sets(&[1000], false, &[]));
    let opts = sylva::lod::LodOptions {
        budgets: vec![1_000_000],
        impostor: true,
        atlas_frames: 2,
        atlas_size: 64,
        ..options_without_impostor()
    };
    let mut never =
        |_: &sylva::Skeleton, _: &sylva::lod::LevelSettings| -> sylva::Result<Model> { unreachable!() };
    let token = sylva::cancel::Cancel::new();
    token.cancel();
    let r = sylva::cancel::scope(&token, || {
        sylva::lod::build_chain(&full.model, &full.skeleton, &opts, &mut never)
    });
    assert!(matches!(r, Err(sylva::Error::Cancelled)), "{:?}", r.map(|c| c.levels.len()));
    let c = sylva::lod::build_chain(&full.model, &full.skeleton, &opts, &mut never).unwrap();
    assert_eq!(c.levels.len(), 2);
}

/// The acceptance test on the aspen: budgets 30,000 / 8,000 / 2,000 and the impostor.
#[test]
fn aspen_chain_keeps_budgets_and_silhouettes() {
    let (full, model, levels) = chain("wp-quaking-aspen", &sets(&[30000, 8000, 2000], true, &[]));
    check_budgets(&levels);
    check_structure(&full.model, &model);
    for size in [128, 256] {
        let sil = silhouettes(&model, size);
        let imp = impostor_match(&model, size);
        println!(
            "wp-quaking-aspen silhouettes ({size} px): LOD1 {}; LOD2 {}",
            percent(&sil[0]),
            percent(&sil[1])
        );
        println!("wp-quaking-aspen impostor ({size} px): {}", percent(&imp));
        if size == 256 {
            assert!(sil[0].iter().all(|&x| x >= 0.9), "LOD1 {}", percent(&sil[0]));
            assert!(sil[1].iter().all(|&x| x >= 0.8), "LOD2 {}", percent(&sil[1]));
            assert!(imp.iter().all(|&x| x >= 0.85), "impostor {}", percent(&imp));
        }
    }
}

/// Issue 26: pruning an LST skeleton keeps each kept internode's cylinder start radius
/// (it used to rebuild the skeleton without the column, so the meshers fell back to
/// their default and the cones changed).
#[test]
fn pruning_keeps_the_start_radii_of_kept_internodes() {
    let text = "LST 0.1\nCylinder(0.5, 0.1, 4) MovRel3f(0, 4, 0)\n\
                SB() RotRel3f(0.7, 0, 0, 1) Cylinder(0.02, 0.01, 1) MovRel3f(0, 1, 0) EB()\n\
                Cylinder(0.3, 0.05, 2) MovRel3f(0, 2, 0)\n";
    let opts = sylva::import::lst::LstOptions::default();
    let sk = sylva::import::lst::parse("t.lst", text, &opts).unwrap();
    let p = sylva::lod::prune::prune(&sk, 0.03);
    p.skeleton.validate().unwrap();
    assert!(p.skeleton.len() < sk.len(), "the thin lateral goes");
    let kept: Vec<Option<f32>> = (0..p.skeleton.len()).map(|k| p.skeleton.start_radius(k)).collect();
    let want: Vec<Option<f32>> = p.original.iter().map(|&o| sk.start_radius(o as usize)).collect();
    assert_eq!(kept, want);
    assert!(kept.contains(&Some(0.3)) && kept.contains(&Some(0.5)), "{kept:?}");
}
