//! The settings panel, generated from the recipe schema ([`sylva::recipe::schema()`]): one
//! collapsible group per section, one control per key — a checkbox for a bool, a slider
//! (logarithmic over wide ranges) or a drag value for a number, a drop-down for a mode,
//! a text field for text and file names, a row of numbers for a fixed-length list — with
//! the key's doc, range, unit and cross-key limits as its tooltip. Keys of the other
//! generators are not shown; keys whose `when` does not hold are shown disabled.
//!
//! The panel only reads the document and returns [`Edit`]s; the app applies them, so a
//! value the engine refuses leaves the recipe unchanged and shows the engine's message.

use crate::document::{lookup, Document};
use std::ops::Bound;
use sylva::recipe::schema::{schema, GeneratorKind, Key, Kind, Section, When};

/// A change the user made to one key.
#[derive(Debug, Clone, PartialEq)]
pub struct Edit {
    /// The dotted key.
    pub key: String,
    /// The new value.
    pub value: toml::Value,
    /// Part of a drag: joins the last undo step when it set the same key.
    pub dragging: bool,
}

/// The sections in the order the panel shows them, with their titles.
const SECTIONS: &[(Section, &str)] = &[
    (Section::Top, "Recipe"),
    (Section::Generator(GeneratorKind::Lsystem), "Generator: L-system"),
    (Section::Generator(GeneratorKind::Import), "Generator: imported skeleton"),
    (Section::Generator(GeneratorKind::WeberPenn), "Generator: Weber–Penn"),
    (Section::Generator(GeneratorKind::SpaceColonization), "Generator: space colonization"),
    (Section::Generator(GeneratorKind::LeastCost), "Generator: least-cost paths"),
    (Section::Leaves, "Leaves"),
    (Section::Textures, "Textures"),
    (Section::Wind, "Wind"),
    (Section::Mesh, "Mesh"),
    (Section::MeshTube, "Mesh: tube"),
    (Section::MeshHull, "Mesh: hull"),
    (Section::MeshSweep, "Mesh: sweep"),
    (Section::MeshQuad, "Mesh: quad"),
    (Section::MeshLeaf, "Mesh: leaf"),
    (Section::FitDecollide, "Fit: de-collision"),
    (Section::FitClear, "Fit: clearing"),
    (Section::Refine, "Refinement"),
    (Section::Lod, "Levels of detail"),
    (Section::Input, "Input limits"),
    (Section::Output, "Output"),
];

/// Sections open when the editor starts.
const OPEN: &[Section] = &[Section::Top, Section::Leaves, Section::Wind, Section::Mesh];

/// Shows every section of the document's generator; `filter` keeps keys whose dotted
/// name or doc contains it (case-insensitive). Returns what the user changed this frame.
pub fn show(ui: &mut egui::Ui, doc: &Document, filter: &str) -> Vec<Edit> {
    let generator = doc.recipe().generator.generator_kind();
    let filter = filter.trim().to_lowercase();
    let mut edits = Vec::new();
    for &(section, title) in SECTIONS {
        if section.generator().is_some_and(|g| g != generator) {
            continue;
        }
        let keys: Vec<&Key> = schema()
            .iter()
            .filter(|k| k.section == section)
            .filter(|k| {
                filter.is_empty()
                    || k.key.to_lowercase().contains(&filter)
                    || k.doc.to_lowercase().contains(&filter)
            })
            .collect();
        if keys.is_empty() {
            continue;
        }
        egui::CollapsingHeader::new(title)
            .id_salt(("section", title))
            .default_open(OPEN.contains(&section) || section.generator().is_some() || !filter.is_empty())
            .show(ui, |ui| {
                egui::Grid::new(("grid", title)).num_columns(2).striped(true).show(ui, |ui| {
                    for key in keys {
                        let applies = key.when.iter().all(|w| holds(w, doc.table()));
                        ui.label(key.name()).on_hover_text(key.key);
                        ui.add_enabled_ui(applies, |ui| {
                            if let Some(edit) = control(ui, key, doc) {
                                edits.push(edit);
                            }
                        });
                        ui.end_row();
                    }
                });
            });
    }
    edits
}

/// Whether `when` holds for the recipe table.
fn holds(when: &When, table: &toml::Table) -> bool {
    match when {
        When::Is { key, names } => {
            let value = lookup(table, key).and_then(|v| v.as_str().map(str::to_string)).or_else(|| {
                sylva::recipe::schema::find(key, None)
                    .and_then(|k| k.default_value())
                    .and_then(|v| v.as_str().map(str::to_string))
            });
            value.is_some_and(|v| names.contains(&v.as_str()))
        }
        When::Table(t) => lookup(table, t).is_some(),
    }
}

/// The tooltip of a key: its doc, values, unit, limits and dotted name.
pub fn tooltip(key: &Key) -> String {
    let mut text = format!("{}\n\nvalues: {}", key.doc, key.kind);
    if let Some(unit) = key.unit {
        text.push_str(&format!(" {}", unit.symbol()));
    }
    if let Some(limits) = key.limits {
        text.push_str(&format!("\nlimits: {limits}"));
    }
    text.push_str(&format!("\nkey: {}", key.key));
    text
}

/// The control of one key; `Some` when the user changed it this frame.
fn control(ui: &mut egui::Ui, key: &Key, doc: &Document) -> Option<Edit> {
    let current = doc.value(key.key).cloned().or_else(|| key.default_value());
    let tip = tooltip(key);
    let id = ui.make_persistent_id(("key", key.key));
    let edit = |value: toml::Value, dragging: bool| Edit { key: key.key.to_string(), value, dragging };
    match key.kind {
        Kind::Bool => {
            let mut v = current.and_then(|v| v.as_bool()).unwrap_or(false);
            let r = ui.checkbox(&mut v, "").on_hover_text(tip).accessible_name(key.key);
            r.changed().then(|| edit(toml::Value::Boolean(v), false))
        }
        Kind::Integer { min, max } => {
            let mut v = current.and_then(|v| v.as_integer()).unwrap_or(min.max(0));
            let r = if max - min <= 1000 {
                ui.add(egui::Slider::new(&mut v, min..=max))
            } else {
                ui.add(egui::DragValue::new(&mut v).range(min..=max))
            }
            .on_hover_text(tip)
            .accessible_name(key.key);
            number_edit(&r).map(|dragging| edit(toml::Value::Integer(v), dragging))
        }
        Kind::Float { min, max } => {
            let mut v = current
                .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
                .unwrap_or(0.0);
            let before = v;
            let (lo, hi) = inner(min, max);
            let r = match (lo, hi) {
                (Some(lo), Some(hi)) if hi - lo < 1e6 => {
                    let log = lo >= 0.0 && hi / lo.max(hi * 1e-4) > 1000.0;
                    let lo = if log && lo == 0.0 { 0.0 } else { lo };
                    ui.add(egui::Slider::new(&mut v, lo..=hi).logarithmic(log).max_decimals(4))
                }
                _ => {
                    let speed = (v.abs() * 0.01).max(0.001);
                    ui.add(
                        egui::DragValue::new(&mut v)
                            .speed(speed)
                            .range(lo.unwrap_or(f64::MIN)..=hi.unwrap_or(f64::MAX)),
                    )
                }
            }
            .on_hover_text(tip)
            .accessible_name(key.key);
            // A slider rounds what it shows (its decimals): a value the user did not move
            // is no edit, or an f32 key (0.6000000238) would be set to 0.6 every frame.
            let moved = (v - before).abs() > 1e-6 * before.abs().max(1.0);
            number_edit(&r).filter(|_| moved).map(|dragging| edit(toml::Value::Float(v), dragging))
        }
        Kind::Mode(names) => {
            let now = current.and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default();
            let mut chosen = None;
            egui::ComboBox::from_id_salt(("key", key.key))
                .selected_text(if now.is_empty() { "(auto)" } else { now.as_str() })
                .show_ui(ui, |ui| {
                    for name in names {
                        if ui.selectable_label(now == *name, *name).clicked() && now != *name {
                            chosen = Some(name.to_string());
                        }
                    }
                })
                .response
                .on_hover_text(tip)
                .accessible_name(key.key);
            chosen.map(|n| edit(toml::Value::String(n), false))
        }
        Kind::String | Kind::Path => {
            let now = current.and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default();
            let mut text = ui.data_mut(|d| d.get_temp::<String>(id)).unwrap_or_else(|| now.clone());
            let r = ui
                .add(egui::TextEdit::singleline(&mut text).id(id).desired_width(160.0))
                .on_hover_text(tip)
                .accessible_name(key.key);
            if r.has_focus() {
                ui.data_mut(|d| d.insert_temp(id, text.clone()));
            } else {
                ui.data_mut(|d| d.remove::<String>(id));
            }
            (r.lost_focus() && text != now).then(|| edit(toml::Value::String(text), false))
        }
        Kind::List { item, min_len, max_len } if min_len == max_len && max_len <= 8 => {
            let mut values: Vec<toml::Value> =
                current.and_then(|v| v.as_array().cloned()).unwrap_or_default();
            values.resize(max_len, toml::Value::Float(0.0));
            let mut changed = None;
            ui.horizontal(|ui| {
                for (i, v) in values.iter_mut().enumerate() {
                    let mut x = v.as_float().or_else(|| v.as_integer().map(|i| i as f64)).unwrap_or(0.0);
                    let (lo, hi) = match item {
                        Kind::Float { min, max } => inner(*min, *max),
                        Kind::Integer { min, max } => (Some(*min as f64), Some(*max as f64)),
                        _ => (None, None),
                    };
                    let speed = (x.abs() * 0.01).max(0.001);
                    let r = ui
                        .add(
                            egui::DragValue::new(&mut x)
                                .speed(speed)
                                .range(lo.unwrap_or(f64::MIN)..=hi.unwrap_or(f64::MAX)),
                        )
                        .on_hover_text(&tip)
                        .accessible_name(format!("{}[{i}]", key.key));
                    if let Some(dragging) = number_edit(&r) {
                        *v = match item {
                            Kind::Integer { .. } => toml::Value::Integer(x.round() as i64),
                            _ => toml::Value::Float(x),
                        };
                        changed = Some(dragging);
                    }
                }
            });
            changed.map(|dragging| edit(toml::Value::Array(values), dragging))
        }
        _ => {
            let text = current.map(|v| v.to_string()).unwrap_or_else(|| "(not set)".into());
            let short: String = text.chars().take(40).collect();
            ui.label(egui::RichText::new(short).weak())
                .on_hover_text(format!("{tip}\n\nedit this key in the recipe file"));
            None
        }
    }
}

/// `Some(dragging)` when a number control changed this frame.
fn number_edit(r: &egui::Response) -> Option<bool> {
    r.changed().then(|| r.dragged())
}

/// The range a control may take: inclusive bounds as they are, exclusive ones moved a
/// little inside (the engine refuses the bound itself), none as `None`.
fn inner(min: Bound<f64>, max: Bound<f64>) -> (Option<f64>, Option<f64>) {
    let value = |b: Bound<f64>| match b {
        Bound::Included(x) | Bound::Excluded(x) => Some(x),
        Bound::Unbounded => None,
    };
    let (lo, hi) = (value(min), value(max));
    let step = |x: f64| match (lo, hi) {
        (Some(a), Some(b)) => ((b - a) * 1e-4).max(f64::EPSILON),
        _ => (x.abs() * 1e-4).max(1e-6),
    };
    let lo = match min {
        Bound::Excluded(x) => Some(x + step(x)),
        _ => lo,
    };
    let hi = match max {
        Bound::Excluded(x) => Some(x - step(x)),
        _ => hi,
    };
    (lo, hi)
}
