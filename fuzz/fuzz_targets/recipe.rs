//! A recipe (TOML) and `--set` lines: the first line of the input is `--set` values
//! separated by `;`, the rest the recipe; only the recipe check runs (no growing).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let (first, rest) = text.split_once('\n').unwrap_or((text, ""));
    let mut sets = Vec::new();
    for s in first.split(';').filter(|s| !s.is_empty()) {
        match sylva::recipe::parse_set(s) {
            Ok(kv) => sets.push(kv),
            Err(_) => return,
        }
    }
    let Ok(table) = toml::from_str::<toml::Table>(rest) else { return };
    let _ = sylva::recipe::from_table(table, &sets);
});
