//! The recipe schema (`sylva::recipe::schema`) against the recipes the library builds and
//! against `docs/recipe.md`: every key of every generator's defaults and of every preset
//! is in the schema and every schema key exists with its default; ranges and mode names
//! are the ones `Recipe::set` enforces; the doc tables list the same keys and defaults.

use std::collections::{BTreeMap, BTreeSet};
use std::ops::Bound;
use sylva::recipe::schema::{schema, DefaultValue, GeneratorKind, Key, Kind, Section, When};
use sylva::recipe::Recipe;

/// The smallest recipe of each generator type (required keys only).
fn base(kind: GeneratorKind) -> Recipe {
    let file = match kind {
        GeneratorKind::Lsystem => "file = \"model.l\"\n",
        GeneratorKind::Import => "file = \"tree.lst\"\n",
        _ => "",
    };
    Recipe::from_toml(&format!("[generator]\ntype = \"{kind}\"\n{file}"))
        .unwrap_or_else(|e| panic!("the smallest {kind} recipe: {e}"))
}

/// The generator type whose base recipe a key is tried on.
fn kind_of(key: &Key) -> GeneratorKind {
    key.section.generator().unwrap_or(GeneratorKind::Lsystem)
}

/// Schema keys that hold a free-form table (not broken into keys).
fn is_table(key: &str, kind: GeneratorKind) -> bool {
    sylva::recipe::schema::find(key, Some(kind)).is_some_and(|k| k.kind == Kind::Table)
}

/// Every dotted key of `table` with its value; arrays and free-form tables are values.
fn flatten(prefix: &str, table: &toml::Table, kind: GeneratorKind, out: &mut BTreeMap<String, toml::Value>) {
    for (k, v) in table {
        let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        match v {
            toml::Value::Table(t) if !is_table(&key, kind) => flatten(&key, t, kind, out),
            _ => {
                out.insert(key, v.clone());
            }
        }
    }
}

fn keys(recipe: &Recipe) -> BTreeMap<String, toml::Value> {
    let mut out = BTreeMap::new();
    flatten("", &recipe.to_table().unwrap(), recipe.generator.generator_kind(), &mut out);
    out
}

/// TOML values equal, numbers compared as numbers (f32 fields round-trip through f64).
fn same(a: &toml::Value, b: &toml::Value) -> bool {
    use toml::Value::*;
    let num = |v: &toml::Value| match v {
        Integer(i) => Some(*i as f64),
        Float(f) => Some(*f),
        _ => None,
    };
    match (a, b) {
        (Array(x), Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(a, b)| same(a, b)),
        (Table(x), Table(y)) => {
            x.len() == y.len() && x.iter().all(|(k, a)| y.get(k).is_some_and(|b| same(a, b)))
        }
        _ => match (num(a), num(b)) {
            (Some(x), Some(y)) => x == y || (x - y).abs() <= 1e-6 * x.abs().max(y.abs()),
            _ => a == b,
        },
    }
}

/// Sets the mode `key` to `name`; a tagged table such as `generator.envelope` is
/// replaced by one of that shape, with the required keys of that shape.
fn set_mode(recipe: &mut Recipe, key: &str, name: &str) -> Result<(), String> {
    let name_value = toml::Value::String(name.into());
    if recipe.set(key, name_value.clone()).is_ok() {
        return Ok(());
    }
    let (table, last) = key.rsplit_once('.').unwrap();
    let mut t = toml::Table::from_iter([(last.to_string(), name_value)]);
    let kind = recipe.generator.generator_kind();
    for k in schema().iter().filter(|k| k.default == DefaultValue::Required && kind_of(k) == kind) {
        let shape_needs = k
            .when
            .iter()
            .any(|w| matches!(w, When::Is { key: m, names } if *m == key && names.contains(&name)));
        if let (Some(rest), true) = (k.key.strip_prefix(&format!("{table}.")), shape_needs) {
            t.insert(rest.to_string(), sample(&k.kind));
        }
    }
    recipe.set(table, toml::Value::Table(t)).map_err(|e| e.to_string())
}

/// `recipe` with the key's conditions made true (each mode set to its first name).
fn with_conditions(mut recipe: Recipe, key: &Key) -> Recipe {
    for w in key.when {
        let done = match w {
            When::Is { key: mode, names } => set_mode(&mut recipe, mode, names[0]),
            When::Table(table) => {
                recipe.set(table, toml::Value::Table(toml::Table::new())).map_err(|e| e.to_string())
            }
        };
        done.unwrap_or_else(|e| panic!("{}: {e}", key.key));
    }
    recipe
}

/// A value of `kind` that `set` accepts (for keys without a default).
fn sample(kind: &Kind) -> toml::Value {
    match kind {
        Kind::Bool => toml::Value::Boolean(true),
        Kind::Integer { min, .. } => toml::Value::Integer(*min),
        Kind::Float { min: Bound::Included(x), .. } => toml::Value::Float(*x),
        Kind::Float { .. } => toml::Value::Float(0.5),
        Kind::Mode(names) => toml::Value::String(names[0].into()),
        Kind::String => toml::Value::String("honda81".into()),
        Kind::Path => toml::Value::String("file.png".into()),
        Kind::List { item, min_len, .. } => toml::Value::Array(vec![sample(item); *min_len]),
        Kind::Table => toml::Value::Table(toml::Table::new()),
    }
}

#[test]
fn keys_are_unique_per_section_and_defaults_parse() {
    let mut seen = BTreeSet::new();
    for key in schema() {
        assert!(seen.insert((key.key, format!("{:?}", key.section))), "{} twice", key.key);
        let table = key.section.table();
        assert!(table.is_empty() || key.key.starts_with(&format!("{table}.")), "{} in {table}", key.key);
        if let DefaultValue::Toml(text) = key.default {
            assert!(key.default_value().is_some(), "{}: default `{text}` is not TOML", key.key);
        }
        assert!(!key.doc.is_empty(), "{} has no doc", key.key);
    }
    for section in Section::ALL {
        assert!(sylva::recipe::schema::keys_of(*section).next().is_some(), "{section:?} has no keys");
        // A key the schema does not have is refused, naming it.
        let kind = section.generator().unwrap_or(GeneratorKind::Lsystem);
        let key = [section.table(), "no_such_key"].join(".");
        let key = key.trim_start_matches('.');
        let e = base(kind).set(key, 1).unwrap_err().to_string();
        assert!(e.contains(key) && (e.contains("unknown key") || e.contains("unknown field")), "{key}: {e}");
    }
}

/// Every key a recipe of each generator type writes is in the schema with the schema's
/// default, and every schema key is one `set` knows, set to its default without changing
/// the recipe.
#[test]
fn schema_matches_the_default_recipes() {
    for &kind in GeneratorKind::ALL {
        let recipe = base(kind);
        let written = keys(&recipe);
        for (k, v) in &written {
            let key = sylva::recipe::schema::find(k, Some(kind))
                .unwrap_or_else(|| panic!("{kind}: `{k}` is written but not in the schema"));
            if let Some(d) = key.default_value() {
                assert!(same(v, &d), "{kind}: `{k}` defaults to {v}, the schema says {d}");
            }
        }
        for key in schema().iter().filter(|k| k.section.generator().is_none_or(|g| g == kind)) {
            let mut r = with_conditions(recipe.clone(), key);
            let before = keys(&r);
            match key.default {
                DefaultValue::Toml(_) => {
                    let d = key.default_value().unwrap();
                    if let Some(v) = keys(&r).get(key.key) {
                        assert!(same(v, &d), "{kind}: `{}` is {v}, the schema's default {d}", key.key);
                    }
                    r.set(key.key, d.clone()).unwrap_or_else(|e| panic!("{kind}: `{}` = {d}: {e}", key.key));
                    let after = keys(&r);
                    let changed: Vec<_> = after.iter().filter(|(k, v)| before.get(*k) != Some(v)).collect();
                    assert!(
                        changed.is_empty() && after.len() == before.len(),
                        "{kind}: setting `{}` to its schema default {d} changed the recipe: {changed:?}",
                        key.key
                    );
                }
                DefaultValue::Unset => {
                    assert!(!keys(&r).contains_key(key.key), "{kind}: unset `{}` is written", key.key);
                    // Known: accepted, or refused for its value (naming it), not as unknown.
                    let v = sample(&key.kind);
                    if let Err(e) = r.set(key.key, v.clone()) {
                        let e = e.to_string();
                        assert!(
                            e.contains(key.key) && !e.contains("unknown key"),
                            "{kind}: `{}` = {v}: {e}",
                            key.key
                        );
                    }
                }
                DefaultValue::Required => {
                    let v = keys(&r).get(key.key).cloned();
                    let v = v.unwrap_or_else(|| sample(&key.kind));
                    if key.key != "generator.type" {
                        let mut t = r.to_table().unwrap();
                        sylva::recipe::set_key(&mut t, key.key, v).unwrap();
                        sylva::recipe::from_table(t, &[])
                            .unwrap_or_else(|e| panic!("{kind}: required `{}`: {e}", key.key));
                    }
                }
            }
        }
    }
}

/// `Recipe::default()` and every preset write only schema keys.
#[test]
fn every_preset_key_is_in_the_schema() {
    let mut recipes = vec![("default".to_string(), Recipe::default())];
    for p in sylva::presets::all().into_iter().filter(|p| !p.is_curves()) {
        recipes.push((p.name.to_string(), Recipe::preset(p.name).unwrap()));
    }
    assert!(recipes.len() > 40);
    for (name, recipe) in recipes {
        let kind = recipe.generator.generator_kind();
        for (k, v) in keys(&recipe) {
            let key = sylva::recipe::schema::find(&k, Some(kind))
                .unwrap_or_else(|| panic!("{name}: `{k}` is not in the schema"));
            assert!(key.section.generator().is_none_or(|g| g == kind), "{name}: `{k}`");
            check_value(&key.kind, &v).unwrap_or_else(|why| panic!("{name}: `{k}` = {v}: {why}"));
        }
    }
}

/// Whether `v` is of `kind` (and in its range).
fn check_value(kind: &Kind, v: &toml::Value) -> Result<(), String> {
    let in_bound = |x: f64, min: &Bound<f64>, max: &Bound<f64>| {
        let lo = match min {
            Bound::Included(m) => x >= *m,
            Bound::Excluded(m) => x > *m,
            Bound::Unbounded => true,
        };
        let hi = match max {
            Bound::Included(m) => x <= *m,
            Bound::Excluded(m) => x < *m,
            Bound::Unbounded => true,
        };
        lo && hi
    };
    match (kind, v) {
        (Kind::Bool, toml::Value::Boolean(_)) => Ok(()),
        (Kind::Integer { min, max }, toml::Value::Integer(i)) if (min..=max).contains(&i) => Ok(()),
        (Kind::Float { min, max }, toml::Value::Float(x)) if in_bound(*x, min, max) => Ok(()),
        (Kind::Float { min, max }, toml::Value::Integer(i)) if in_bound(*i as f64, min, max) => Ok(()),
        (Kind::Mode(names), toml::Value::String(s)) if names.contains(&s.as_str()) => Ok(()),
        (Kind::String | Kind::Path, toml::Value::String(_)) => Ok(()),
        (Kind::Table, toml::Value::Table(_)) => Ok(()),
        (Kind::List { item, min_len, max_len }, toml::Value::Array(a)) => {
            if !(min_len..=max_len).contains(&&a.len()) {
                return Err(format!("{} elements", a.len()));
            }
            a.iter().try_for_each(|x| check_value(item, x))
        }
        _ => Err(format!("not a {kind:?}")),
    }
}

/// The value `x` as the key's kind takes it: a number, or a list of it (as long as the
/// default, or the shortest list allowed).
fn value_of(key: &Key, x: f64) -> toml::Value {
    let scalar = |kind: &Kind| match kind {
        Kind::Integer { .. } => toml::Value::Integer(x as i64),
        _ => toml::Value::Float(x),
    };
    match key.kind {
        Kind::List { item, min_len, .. } => {
            let len = match key.default_value() {
                Some(toml::Value::Array(a)) if !a.is_empty() => a.len(),
                _ => min_len.max(1),
            };
            toml::Value::Array(vec![scalar(item); len])
        }
        _ => scalar(&key.kind),
    }
}

/// The numeric range of a key (its elements' for a list).
fn numeric(kind: &Kind) -> Option<(Bound<f64>, Bound<f64>, bool)> {
    match kind {
        Kind::Integer { min, max } => {
            // A type's own limit cannot be passed in TOML (i64) or is the type's error.
            let b = |v: i64| {
                if v == i64::MAX || v == i64::MIN {
                    Bound::Unbounded
                } else {
                    Bound::Included(v as f64)
                }
            };
            Some((b(*min), b(*max), true))
        }
        Kind::Float { min, max } => Some((*min, *max, false)),
        Kind::List { item, .. } => numeric(item),
        _ => None,
    }
}

/// Each finite bound of every numeric key is accepted (inclusive) or refused
/// (exclusive), and a value just outside it is refused with an error naming the key.
#[test]
fn ranges_are_the_ones_set_enforces() {
    let mut tried = 0;
    for key in schema().iter().filter(|k| k.limits.is_none()) {
        let Some((min, max, integer)) = numeric(&key.kind) else { continue };
        let r = with_conditions(base(kind_of(key)), key);
        let step = |b: f64| if integer { 1.0 } else { (b.abs() * 1e-3).max(1e-7) };
        let try_set = |x: f64| {
            let mut r = r.clone();
            r.set(key.key, value_of(key, x)).map_err(|e| e.to_string())
        };
        let refused = |x: f64| match try_set(x) {
            Ok(()) => panic!("`{}` = {x} is accepted, outside its range", key.key),
            Err(e) => {
                // The key the error names first is this one (or an element of it).
                let named = e.split('`').nth(1).unwrap_or("");
                let found = sylva::recipe::schema::find(named, Some(kind_of(key)));
                assert!(
                    found.is_some_and(|k| k.key == key.key),
                    "`{}` = {x}: the error names `{named}`, not the key: {e}",
                    key.key
                );
            }
        };
        let accepted = |x: f64| {
            try_set(x).unwrap_or_else(|e| panic!("`{}` = {x} is refused, inside its range: {e}", key.key))
        };
        for (bound, sign) in [(min, -1.0), (max, 1.0)] {
            match bound {
                Bound::Included(b) => {
                    accepted(b);
                    refused(b + sign * step(b));
                    tried += 1;
                }
                Bound::Excluded(b) => {
                    refused(b);
                    accepted(b - sign * step(b));
                    tried += 1;
                }
                Bound::Unbounded => {}
            }
        }
    }
    assert!(tried > 150, "only {tried} bounds tried");
}

/// Every name of every mode key is accepted, and another is refused with an error naming
/// the key and listing the schema's names.
#[test]
fn mode_names_are_the_ones_set_enforces() {
    for key in schema().iter().filter(|k| k.key != "generator.type") {
        let Kind::Mode(names) = key.kind else { continue };
        let r = with_conditions(base(kind_of(key)), key);
        for name in names {
            set_mode(&mut r.clone(), key.key, name).unwrap_or_else(|e| panic!("`{}` = {name}: {e}", key.key));
        }
        let e = r.clone().set(key.key, "no-such-name").unwrap_err().to_string();
        assert!(e.contains(key.key), "`{}`: {e}", key.key);
        let listed = e.split_once("; use ").map(|(_, list)| {
            list.split([',', ' ']).filter(|w| !w.is_empty() && *w != "or").collect::<BTreeSet<_>>()
        });
        let schema_names: BTreeSet<&str> = names.iter().copied().collect();
        let listed = listed.unwrap_or_else(|| panic!("`{}`: the error lists no names: {e}", key.key));
        assert_eq!(listed, schema_names, "`{}`: the error lists other names: {e}", key.key);
    }
    for &kind in GeneratorKind::ALL {
        assert_eq!(base(kind).generator.generator_kind(), kind);
    }
}

/// The doc's tables: section → key (relative to the section's table) → default cell.
fn doc_tables() -> BTreeMap<String, BTreeMap<String, String>> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/recipe.md");
    let text = std::fs::read_to_string(path).unwrap();
    let mut out: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    let mut section: Option<String> = None;
    for line in text.lines() {
        if line.starts_with('#') {
            section = doc_section(line);
            continue;
        }
        let Some(s) = &section else { continue };
        let cells: Vec<&str> = line.split(" | ").map(|c| c.trim().trim_matches('|').trim()).collect();
        if cells.len() < 3 || !cells[0].starts_with('`') {
            continue;
        }
        let key = cells[0].trim_matches('`').to_string();
        let prev = out.entry(s.clone()).or_default().insert(key.clone(), cells[1].to_string());
        assert!(prev.is_none(), "docs/recipe.md lists `{key}` twice under {s}");
    }
    out
}

/// The section a doc heading names, as [`section_id`] writes it: `## Top level` and
/// ``## `[mesh.tube]` `` and ``## `[generator]`, `type = "lsystem"` ``.
fn doc_section(heading: &str) -> Option<String> {
    if heading.trim_start_matches('#').trim() == "Top level" {
        return Some(String::new());
    }
    let (_, rest) = heading.split_once("`[")?;
    let (table, rest) = rest.split_once("]`")?;
    let kind = rest.split_once("type = \"").and_then(|(_, r)| r.split_once('"')).map(|(k, _)| k);
    Some(match kind {
        Some(k) => format!("{table}/{k}"),
        None => table.to_string(),
    })
}

fn section_id(section: Section) -> String {
    match section {
        Section::Generator(g) => format!("generator/{g}"),
        s => s.table().to_string(),
    }
}

/// The first backquoted TOML value of a doc cell (`` `8` ``, `` `"tube"` ``).
fn doc_default(cell: &str) -> Option<toml::Value> {
    let (_, rest) = cell.split_once('`')?;
    let (code, _) = rest.split_once('`')?;
    let t: toml::Table = toml::from_str(&format!("v = {code}")).ok()?;
    t.get("v").cloned()
}

/// `docs/recipe.md` lists every schema key in the table of its section with the same
/// default, and nothing else.
#[test]
fn docs_recipe_md_matches_the_schema() {
    let doc = doc_tables();
    let mut problems = Vec::new();
    for key in schema() {
        let id = section_id(key.section);
        let Some(cell) = doc.get(&id).and_then(|t| t.get(key.name())) else {
            problems.push(format!("`{}` ({id}) is not in docs/recipe.md", key.key));
            continue;
        };
        match key.default {
            DefaultValue::Toml(_) => {
                let d = key.default_value().unwrap();
                match doc_default(cell) {
                    Some(v) if same(&v, &d) => {}
                    v => problems.push(format!(
                        "`{}`: the doc's default is {v:?} (`{cell}`), the schema's {d}",
                        key.key
                    )),
                }
            }
            DefaultValue::Required => {
                if !cell.contains("required") {
                    problems.push(format!("`{}` is required; the doc says `{cell}`", key.key));
                }
            }
            DefaultValue::Unset => {}
        }
    }
    for (id, table) in &doc {
        for k in table.keys() {
            let known = schema().iter().any(|key| section_id(key.section) == *id && key.name() == k);
            if !known {
                problems
                    .push(format!("docs/recipe.md lists `{k}` under {id}, which the schema does not have"));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn find_resolves_the_keys_errors_name() {
    use sylva::recipe::schema::find;
    let at = |key: &str, kind| find(key, Some(kind)).map(|k| k.key);
    assert_eq!(at("mesh.sides", GeneratorKind::WeberPenn), Some("mesh.sides"));
    assert_eq!(at("generator.n_taper[2]", GeneratorKind::WeberPenn), Some("generator.n_taper"));
    assert_eq!(at("generator.n_taper[2]", GeneratorKind::Lsystem), None);
    assert_eq!(at("generator.define.R1", GeneratorKind::Lsystem), Some("generator.define"));
    assert_eq!(
        at("generator.iterations[0].rotation.rule", GeneratorKind::LeastCost),
        Some("generator.iterations")
    );
    assert_eq!(at("generator.iterations", GeneratorKind::Lsystem), Some("generator.iterations"));
    assert_eq!(find("generator.iterations", Some(GeneratorKind::Lsystem)).unwrap().kind.to_string(), "≥ 0");
    assert_eq!(at("mesh.sides.x", GeneratorKind::Lsystem), None);
    assert_eq!(at("mesh.nope", GeneratorKind::Lsystem), None);
    assert_eq!(
        find("generator.scale", None).map(|k| k.section),
        Some(Section::Generator(GeneratorKind::WeberPenn))
    );
    // The words of a few kinds, as the doc tables give ranges.
    let kind = |key: &str| find(key, None).unwrap().kind.to_string();
    assert_eq!(kind("mesh.sides"), "3..=1024");
    assert_eq!(kind("leaves.alpha_cutoff"), "(0, 1)");
    assert_eq!(kind("mesh.leaf.tip_size"), "(0, 100]");
    assert_eq!(kind("mesh.method"), "tube, hull, sweep, quad or leaf");
    assert_eq!(kind("fit.decollide.angles"), "at most 64 × (0, 180]");
}
