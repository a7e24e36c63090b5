//! The LOD chain setup shared by `examples/lod_row.rs` and `benches/lod.rs` (issue 24
//! item 4): a preset with LOD budgets of 30,000 / 8,000 / 2,000 triangles, grown once
//! without the chain, and the chain built again on a copy of that tree's model as
//! `pipeline::lod_stage` does after meshing.

use sylva::lod::LevelReport;
use sylva::model::Model;
use sylva::pipeline::Tree;
use sylva::recipe::Loaded;

/// `preset` with the three LOD budgets (and the impostor when `impostor`), and its tree
/// grown without the chain.
pub fn grow_without_chain(preset: &str, impostor: bool) -> sylva::Result<(Loaded, Tree)> {
    let budgets = [30000i64, 8000, 2000].map(toml::Value::Integer).to_vec();
    let sets = vec![
        ("lod.levels".to_string(), toml::Value::Array(budgets)),
        ("lod.impostor".to_string(), toml::Value::Boolean(impostor)),
    ];
    let loaded = sylva::recipe::load(preset, &sets)?;
    let mut plain = loaded.clone();
    plain.recipe.lod = Default::default();
    let full = sylva::pipeline::grow(&plain)?;
    Ok((loaded, full))
}

/// Builds the chain `loaded` asks for on `model` (a copy of `full`'s model); a report
/// per level.
pub fn build_chain(loaded: &Loaded, full: &Tree, model: &mut Model) -> sylva::Result<Vec<LevelReport>> {
    let mut report = sylva::pipeline::Report::default();
    sylva::pipeline::lod_stage(loaded, &full.skeleton, &Default::default(), model, &mut report)
}
