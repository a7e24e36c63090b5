//! The embedded preset library: every recipe (`*.toml`) and model file under the
//! workspace's `presets/` folder, compiled into the engine by `build.rs`.
//!
//! A preset is a recipe whose name is its file stem (`lsys-honda-a`). Names are
//! kebab-case and start with the generator family (`lsys-…`, later `wp-…`,
//! `colonize-…`, `mig-…`, `mgv-…`, `curves-…`).

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/presets.rs"));
}

/// Name of the preset `sylva grow` uses when given none.
pub const DEFAULT_PRESET: &str = "lsys-ternary-tree";

/// One embedded preset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Preset {
    /// The preset's name (its recipe's file stem).
    pub name: &'static str,
    /// Its recipe, as TOML text.
    pub recipe: &'static str,
}

impl Preset {
    /// True for a magnetic-curves composition (`kind = "curves"`), which `sylva curves`
    /// renders; every other preset is a tree recipe for `sylva grow`.
    pub fn is_curves(&self) -> bool {
        toml::from_str::<toml::Table>(self.recipe)
            .ok()
            .is_some_and(|t| t.get("kind").and_then(|k| k.as_str()) == Some("curves"))
    }

    /// The recipe's `description` line, if it has one.
    pub fn description(&self) -> String {
        toml::from_str::<toml::Table>(self.recipe)
            .ok()
            .and_then(|t| t.get("description").and_then(|d| d.as_str().map(str::to_string)))
            .unwrap_or_default()
    }
}

/// Every preset, sorted by name.
pub fn all() -> Vec<Preset> {
    let mut v: Vec<Preset> = embedded::FILES
        .iter()
        .filter(|(path, _)| path.ends_with(".toml") && !path.contains('/'))
        .map(|(path, recipe)| Preset { name: &path[..path.len() - ".toml".len()], recipe })
        .collect();
    v.sort_by_key(|p| p.name);
    v
}

/// The preset called `name`.
pub fn get(name: &str) -> Option<Preset> {
    all().into_iter().find(|p| p.name == name)
}

/// An embedded file by its path relative to `presets/` (e.g. `lsystem/honda.l`).
pub fn file(path: &str) -> Option<&'static str> {
    embedded::FILES.iter().find(|(p, _)| *p == path).map(|(_, c)| *c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_kebab_case_with_a_family() {
        let all = all();
        assert!(all.len() >= 15, "only {} presets", all.len());
        for p in &all {
            assert!(
                p.name.bytes().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == b'-'),
                "{} is not kebab-case",
                p.name
            );
            let family = p.name.split('-').next().unwrap_or("");
            assert!(
                ["lsys", "wp", "colonize", "mig", "mgv", "bcm", "curves"].contains(&family),
                "{} has no generator family prefix",
                p.name
            );
            assert!(!p.description().is_empty(), "{} has no description", p.name);
        }
        assert!(get(DEFAULT_PRESET).is_some());
    }
}
