//! The file structure of a `.l` file: sections, keywords (case-insensitive, as in
//! cpfg), and the grouping of the preprocessed text into keyword lines, statement blocks
//! and productions that may continue over several lines (cpfg manual; McLoughlin2021 §2).

use super::scan::top_level_find_str;
use super::{LSystem, PResult};
use crate::lsystem::source::ErrorKind;

/// Which section productions go to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Section {
    Productions,
    Decomposition,
    Homomorphism,
}

/// One logical item of the file: a keyword line, a block or a production.
#[derive(Debug, Clone)]
pub(super) enum Item {
    Keyword { kw: Kw, value: usize, end: usize, at: usize },
    Block { kw: Kw, start: usize, end: usize, at: usize },
    Production { start: usize, end: usize },
    Ring,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kw {
    Lsystem,
    Seed,
    DerivationLength,
    Axiom,
    Ignore,
    Consider,
    EndLsystem,
    Homomorphism,
    Decomposition,
    MaximumDepth,
    Define,
    Start,
    StartEach,
    EndEach,
    End,
    Warnings,
}

/// Keywords in matching order (longer names first where one is a prefix of another).
const KEYWORDS: &[(&str, Kw, bool)] = &[
    ("lsystem", Kw::Lsystem, true),
    ("seed", Kw::Seed, true),
    ("derivation length", Kw::DerivationLength, true),
    ("axiom", Kw::Axiom, true),
    ("ignore", Kw::Ignore, true),
    ("consider", Kw::Consider, true),
    ("endlsystem", Kw::EndLsystem, false),
    ("homomorphism", Kw::Homomorphism, false),
    ("decomposition", Kw::Decomposition, false),
    ("maximum depth", Kw::MaximumDepth, true),
    ("define", Kw::Define, true),
    ("starteach", Kw::StartEach, true),
    ("start", Kw::Start, true),
    ("endeach", Kw::EndEach, true),
    ("end", Kw::End, true),
    ("warnings", Kw::Warnings, false),
];

/// Recognises a keyword at the start of `line` (already trimmed). Returns the keyword
/// and the byte offset (within `line`) where its value starts. A line with a production
/// arrow `-->` is a production even when it starts like a keyword, as cpfg reads it
/// (issue 46 item 6: `AXIOM : A_SW == 1 --> …` rewrites the modules `AXIOM` under a
/// condition; it is not an `Axiom:` line).
fn keyword(line: &str) -> Option<(Kw, usize)> {
    let lower = line.to_ascii_lowercase();
    for &(name, kw, colon) in KEYWORDS {
        let Some(rest) = lower.strip_prefix(name) else { continue };
        let trimmed = rest.trim_start();
        if colon {
            if top_level_find_str(line, "-->").is_some() {
                return None;
            }
            if let Some(v) = trimmed.strip_prefix(':') {
                return Some((kw, line.len() - v.len()));
            }
        } else if trimmed.is_empty() || trimmed.starts_with(':') {
            return Some((kw, line.len()));
        } else if kw == Kw::Homomorphism || kw == Kw::Decomposition {
            // `homomorphism warnings` / trailing words are tolerated.
            if trimmed.chars().all(|c| c.is_ascii_alphabetic() || c.is_whitespace()) {
                return Some((kw, line.len()));
            }
        }
    }
    None
}

/// `{` minus `}` outside string literals.
fn brace_depth(text: &str) -> i32 {
    let mut d = 0;
    let mut in_str = false;
    for c in text.bytes() {
        match c {
            b'"' => in_str = !in_str,
            b'{' if !in_str => d += 1,
            b'}' if !in_str => d -= 1,
            _ => {}
        }
    }
    d
}

/// Finds the production arrow outside parentheses: `-->`, else `->`.
pub(super) fn arrow(text: &str) -> Option<(usize, usize)> {
    top_level_find_str(text, "-->").map(|a| (a, 3)).or_else(|| top_level_find_str(text, "->").map(|a| (a, 2)))
}

impl LSystem {
    /// Groups the preprocessed text into keyword lines, blocks and productions.
    pub(super) fn items(&self) -> PResult<Vec<Item>> {
        let text = &self.source.text;
        let mut lines: Vec<(usize, usize)> = Vec::new(); // (start, end) of trimmed content
        let mut off = 0;
        for raw in text.split_inclusive('\n') {
            let t = raw.trim_end();
            let lead = t.len() - t.trim_start().len();
            lines.push((off + lead, off + t.len()));
            off += raw.len();
        }
        let mut items = Vec::new();
        let mut i = 0;
        while i < lines.len() {
            let (s, e) = lines[i];
            if s >= e {
                i += 1;
                continue;
            }
            let line = &text[s..e];
            if let Some((kw, v)) = keyword(line) {
                let value = s + v;
                if matches!(kw, Kw::Define | Kw::Start | Kw::StartEach | Kw::EndEach | Kw::End) {
                    // A block: from the value to where its braces balance.
                    let (bend, next) = self.block_extent(value, &lines, i)?;
                    items.push(Item::Block { kw, start: value, end: bend, at: s });
                    i = next;
                    continue;
                }
                let mut end = e;
                i += 1;
                if kw == Kw::Axiom {
                    // The axiom may continue on the following lines.
                    while i < lines.len() && self.is_continuation(&lines, i) {
                        end = lines[i].1;
                        i += 1;
                    }
                }
                items.push(Item::Keyword { kw, value, end, at: s });
                continue;
            }
            if line.to_ascii_lowercase().replace(['-', ' '], "") == "ringlsystem" {
                items.push(Item::Ring);
                i += 1;
                continue;
            }
            // A production: its left side may span lines while a statement block is
            // open; the successor continues on the following lines.
            let mut end = e;
            let mut j = i + 1;
            loop {
                let open = brace_depth(&text[s..end]) > 0;
                if (arrow(&text[s..end]).is_some() && !open) || j >= lines.len() {
                    break;
                }
                let (ls, le) = lines[j];
                if ls >= le {
                    // Blank (or comment-only) lines may sit inside a statement block.
                    if open {
                        j += 1;
                        continue;
                    }
                    break;
                }
                if !open && keyword(&text[ls..le]).is_some() {
                    break;
                }
                end = le;
                j += 1;
            }
            if arrow(&text[s..end]).is_some() {
                i = j;
                while i < lines.len() && self.is_continuation(&lines, i) {
                    end = lines[i].1;
                    i += 1;
                }
                items.push(Item::Production { start: s, end });
                continue;
            }
            return Err(self.source.error(
                ErrorKind::Syntax,
                s,
                e - s,
                "expected a production `predecessor --> successor` or a keyword",
                "not a production",
            ));
        }
        Ok(items)
    }

    /// True when line `i` continues the previous production (or axiom): it is not
    /// blank, not a keyword, has no arrow, and is not the left side of a production
    /// whose arrow starts a following line.
    fn is_continuation(&self, lines: &[(usize, usize)], i: usize) -> bool {
        let (s, e) = lines[i];
        if s >= e {
            return false;
        }
        let text = &self.source.text;
        let line = &text[s..e];
        if keyword(line).is_some() || arrow(line).is_some() {
            return false;
        }
        // Look ahead: an LHS whose `-->` starts a later line, possibly after statement
        // blocks on lines of their own.
        let mut depth = brace_depth(line);
        for &(ls, le) in &lines[i + 1..] {
            if ls >= le {
                if depth > 0 {
                    continue;
                }
                return true;
            }
            let l = &text[ls..le];
            if depth <= 0 {
                if l.starts_with("-->") || l.starts_with("->") {
                    return false;
                }
                if !l.starts_with('{') {
                    return true;
                }
            }
            depth += brace_depth(l);
        }
        true
    }

    /// End offset of a `{ ... }` block starting at `value`, and the index of the line
    /// after it.
    fn block_extent(&self, value: usize, lines: &[(usize, usize)], i: usize) -> PResult<(usize, usize)> {
        let text = self.source.text.as_bytes();
        let mut depth = 0i32;
        let mut seen = false;
        let mut k = value;
        let last = lines.last().map(|l| l.1).unwrap_or(text.len());
        while k < text.len().min(last.max(value)) {
            match text[k] {
                b'{' => {
                    depth += 1;
                    seen = true;
                }
                b'}' => {
                    depth -= 1;
                    if depth == 0 && seen {
                        let next =
                            lines.iter().position(|&(_, e)| e > k).map(|p| p + 1).unwrap_or(lines.len());
                        // Anything after the block on its line is a syntax error.
                        let line_end = lines[next - 1].1;
                        let rest = self.source.text[k + 1..line_end].trim();
                        if !rest.is_empty() {
                            return Err(self.source.error(
                                ErrorKind::Syntax,
                                k + 1,
                                1,
                                "unexpected text after a statement block",
                                "here",
                            ));
                        }
                        return Ok((k + 1, next));
                    }
                }
                b'"' => {
                    k += 1;
                    while k < text.len() && text[k] != b'"' {
                        k += 1;
                    }
                }
                _ => {}
            }
            k += 1;
        }
        let _ = i;
        if !seen {
            return Err(self.source.error(ErrorKind::Syntax, value, 1, "expected a `{ ... }` block", "here"));
        }
        Err(self.source.error(ErrorKind::Syntax, value, 1, "unclosed `{` in statement block", "opened here"))
    }
}
