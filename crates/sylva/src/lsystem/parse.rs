//! Parser for cpfg L-system files (`.l`): the file structure, productions and module
//! strings, compiled once into symbol ids and bytecode.
//!
//! ```text
//! #define NAME value
//! Lsystem: 1
//! seed: 2454                      (optional)
//! derivation length: 10
//! Axiom: A(1, 0.3)
//! A(s,w) : s >= MIN --> !(w)F(s)[+(A1)/(P1)A(s*R1, w*Q^E)][+(A2)/(P2)A(s*R2, w*(1-Q)^E)]
//! F --> F[+F]F : 0.33             (stochastic: probability after the successor)
//! endlsystem
//! ```
//!
//! Keywords are case-insensitive, as in cpfg. `*` as a condition means "none"; `*` as a
//! successor is the empty string. Seed 002 §2 gives the grammars this must read; ABOP
//! ch. 1 and the cpfg manual give the syntax.

use super::expr::{compile, Expr};
use super::source::{ErrorKind, LsystemError, Source};
use std::collections::HashMap;

type PResult<T> = Result<T, Box<LsystemError>>;

/// The interned module names of one L-system (`F`, `+`, `A`, `@Ts`, …).
#[derive(Debug, Clone, Default)]
pub struct Symbols {
    names: Vec<String>,
    ids: HashMap<String, u16>,
}

impl Symbols {
    /// The id of `name`, adding it if new.
    pub fn intern(&mut self, name: &str) -> Option<u16> {
        if let Some(&id) = self.ids.get(name) {
            return Some(id);
        }
        let id = u16::try_from(self.names.len()).ok()?;
        self.names.push(name.to_string());
        self.ids.insert(name.to_string(), id);
        Some(id)
    }

    /// The id of `name`, if the L-system uses it.
    pub fn get(&self, name: &str) -> Option<u16> {
        self.ids.get(name).copied()
    }

    /// The name of symbol `id`.
    pub fn name(&self, id: u16) -> &str {
        &self.names[id as usize]
    }

    /// Number of symbols.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

/// A module of an axiom or successor: a symbol and its parameter expressions.
#[derive(Debug, Clone, PartialEq)]
pub struct ModuleTemplate {
    /// Symbol id.
    pub sym: u16,
    /// Parameter expressions.
    pub args: Vec<Expr>,
    /// Offset of the module in the preprocessed source.
    pub at: u32,
}

/// A compiled production `pred : cond --> succ : prob`.
#[derive(Debug, Clone, PartialEq)]
pub struct Production {
    /// Strict predecessor symbol.
    pub pred: u16,
    /// Formal parameter names of the predecessor.
    pub params: Vec<String>,
    /// Condition, if any.
    pub cond: Option<Expr>,
    /// Successor modules.
    pub succ: Vec<ModuleTemplate>,
    /// Probability weight for stochastic productions.
    pub prob: Option<Expr>,
    /// Offset of the production's first character in the preprocessed source.
    pub at: u32,
    /// Length of the production's line.
    pub len: u32,
    /// 1-based line of the production in the original file.
    pub line: usize,
}

/// A parsed and compiled L-system.
#[derive(Debug, Clone)]
pub struct LSystem {
    /// The preprocessed source, for error messages.
    pub source: Source,
    /// Interned module names.
    pub symbols: Symbols,
    /// The axiom.
    pub axiom: Vec<ModuleTemplate>,
    /// Productions in file order.
    pub productions: Vec<Production>,
    /// For each symbol id, the indices of its productions in file order.
    pub by_symbol: Vec<Vec<u32>>,
    /// Derivation length from the file (`derivation length:`), 0 when absent.
    pub derivation_length: u32,
    /// Seed from the file (`seed:`), if given.
    pub seed: Option<u64>,
    /// Homomorphism productions (applied for interpretation only), in file order.
    pub homomorphism: Vec<Production>,
    /// For each symbol id, the indices of its homomorphism productions.
    pub homomorphism_by_symbol: Vec<Vec<u32>>,
    /// Recursion depth of the homomorphism (`maximum depth:`, default 1).
    pub homomorphism_depth: u32,
}

/// Modules that have a fixed maximum number of parameters in the turtle.
fn turtle_max_arity(name: &str) -> Option<usize> {
    Some(match name {
        "F" | "f" | "G" | "g" | "+" | "-" | "&" | "^" | "\\" | "/" | "!" | "#" | ";" | "," => 1,
        "[" | "]" | "|" | "$" | "%" => 0,
        _ => return None,
    })
}

impl LSystem {
    /// Parses an L-system file. `name` is used in messages; `defines` override the
    /// file's `#define` values.
    pub fn parse(name: &str, text: &str, defines: &[(String, String)]) -> PResult<LSystem> {
        let source = Source::new(name, text, defines)?;
        let mut ls = LSystem {
            source,
            symbols: Symbols::default(),
            axiom: Vec::new(),
            productions: Vec::new(),
            by_symbol: Vec::new(),
            derivation_length: 0,
            seed: None,
            homomorphism: Vec::new(),
            homomorphism_by_symbol: Vec::new(),
            homomorphism_depth: 1,
        };
        ls.parse_lines()?;
        let index = |prods: &[Production], n: usize| {
            let mut by = vec![Vec::new(); n];
            for (k, p) in prods.iter().enumerate() {
                by[p.pred as usize].push(k as u32);
            }
            by
        };
        ls.by_symbol = index(&ls.productions, ls.symbols.len());
        ls.homomorphism_by_symbol = index(&ls.homomorphism, ls.symbols.len());
        Ok(ls)
    }

    fn parse_lines(&mut self) -> PResult<()> {
        #[derive(PartialEq)]
        enum State {
            Before,
            Inside,
            After,
        }
        let text = self.source.text.clone();
        let mut state = State::Before;
        let mut seen_axiom = false;
        let mut in_homomorphism = false;
        let mut offset = 0usize;
        for raw in text.split_inclusive('\n') {
            let line_start = offset;
            offset += raw.len();
            let line = raw.trim_end();
            let lead = line.len() - line.trim_start().len();
            let line = line.trim_start();
            if line.is_empty() {
                continue;
            }
            let at = line_start + lead;
            let lower = line.to_ascii_lowercase();
            let keyword = |k: &str| -> Option<usize> {
                // `keyword:` with optional spaces before the colon; returns the value offset.
                let rest = lower.strip_prefix(k)?;
                let trimmed = rest.trim_start();
                let colon = trimmed.strip_prefix(':')?;
                Some(at + line.len() - colon.len())
            };
            if let Some(v) = keyword("lsystem") {
                if state == State::Inside {
                    return Err(self.source.error(
                        ErrorKind::Unsupported,
                        at,
                        line.len(),
                        "unsupported: a second `Lsystem:` block (sub-L-systems)",
                        "second L-system",
                    ));
                }
                let _ = v;
                state = State::Inside;
                continue;
            }
            if state != State::Inside {
                let what = if state == State::Before {
                    "expected `Lsystem:` before the L-system"
                } else {
                    "text after `endlsystem`"
                };
                return Err(self.source.error(ErrorKind::Syntax, at, line.len(), what, "here"));
            }
            if lower.starts_with("endlsystem") {
                state = State::After;
                continue;
            }
            if let Some(v) = keyword("derivation length") {
                let n = self.constant(v, line_start + raw.trim_end().len(), "derivation length")?;
                if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        v,
                        line.len(),
                        &format!("derivation length must be a whole number 0..1000000, got {n}"),
                        "bad derivation length",
                    ));
                }
                self.derivation_length = n as u32;
                continue;
            }
            if let Some(v) = keyword("seed") {
                let n = self.constant(v, line_start + raw.trim_end().len(), "seed")?;
                self.seed = Some(n.abs() as u64);
                continue;
            }
            if let Some(v) = keyword("axiom") {
                let end = line_start + raw.trim_end().len();
                self.axiom = self.module_string(v, end, &[])?;
                seen_axiom = true;
                continue;
            }
            if lower.starts_with("homomorphism")
                && lower["homomorphism".len()..].trim_start_matches(':').trim().is_empty()
            {
                in_homomorphism = true;
                continue;
            }
            if let Some(v) = keyword("maximum depth") {
                if !in_homomorphism {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        at,
                        line.len(),
                        "`maximum depth:` belongs to a homomorphism or decomposition section",
                        "here",
                    ));
                }
                let n = self.constant(v, line_start + raw.trim_end().len(), "maximum depth")?;
                if !(1.0..=1000.0).contains(&n) {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        v,
                        line.len(),
                        &format!("maximum depth must be 1..1000, got {n}"),
                        "bad depth",
                    ));
                }
                self.homomorphism_depth = n as u32;
                continue;
            }
            if keyword("ignore").is_some() || keyword("consider").is_some() {
                // Only context-sensitive productions read these lists, and those are
                // rejected below; accepting the line keeps context-free models loading.
                continue;
            }
            for (k, what) in [
                ("decomposition", "decomposition sections"),
                ("define", "`Define:` blocks"),
                ("startEach", "`StartEach:` blocks"),
                ("endEach", "`EndEach:` blocks"),
                ("start", "`Start:` blocks"),
                ("end", "`End:` blocks"),
            ] {
                let kl = k.to_ascii_lowercase();
                if lower.starts_with(&kl) && (lower.len() == kl.len() || keyword(&kl).is_some()) {
                    return Err(self.source.error(
                        ErrorKind::Unsupported,
                        at,
                        k.len(),
                        &format!("unsupported: {what}"),
                        "not supported yet",
                    ));
                }
            }
            let p = self.production(at, line_start + raw.trim_end().len())?;
            if in_homomorphism {
                self.homomorphism.push(p);
            } else {
                self.productions.push(p);
            }
        }
        if state == State::Before {
            return Err(self.source.error_nowhere(ErrorKind::Syntax, "no `Lsystem:` block found"));
        }
        if !seen_axiom {
            return Err(self.source.error_nowhere(ErrorKind::Syntax, "the L-system has no `Axiom:`"));
        }
        Ok(())
    }

    fn constant(&self, start: usize, end: usize, what: &str) -> PResult<f64> {
        let e = compile(&self.source, start, end, &[])?;
        let mut ev = super::expr::Evaluator::new(0);
        ev.eval(&e, &[]).map_err(|_| {
            self.source.error(ErrorKind::NonFinite, start, end - start, &format!("bad {what}"), "here")
        })
    }

    /// Parses a production on `text[start..end]`.
    fn production(&mut self, start: usize, end: usize) -> PResult<Production> {
        let text = &self.source.text[start..end];
        let Some((arrow, alen)) =
            text.find("-->").map(|a| (a, 3)).or_else(|| text.find("->").map(|a| (a, 2)))
        else {
            return Err(self.source.error(
                ErrorKind::Syntax,
                start,
                end - start,
                "expected a production `predecessor --> successor`",
                "no `-->` on this line",
            ));
        };
        let lhs_end = start + arrow;
        let rhs_start = lhs_end + alen;
        // Left-hand side: `pred` or `pred : cond`.
        let (pred_end, cond) = match top_level_find(&self.source.text[start..lhs_end], b':') {
            Some(c) => (start + c, Some((start + c + 1, lhs_end))),
            None => (lhs_end, None),
        };
        let pred_text = &self.source.text[start..pred_end];
        if top_level_find(pred_text, b'<').is_some() || top_level_find(pred_text, b'>').is_some() {
            return Err(self.source.error(
                ErrorKind::Unsupported,
                start,
                pred_end - start,
                "unsupported: context-sensitive productions (`<`, `>`)",
                "context",
            ));
        }
        let (pred, params) = self.predecessor(start, pred_end)?;
        let cond = match cond {
            Some((a, b)) if self.source.text[a..b].trim() != "*" => {
                Some(compile(&self.source, a, b, &params)?)
            }
            _ => None,
        };
        // Right-hand side: `succ` or `succ : prob`.
        let (succ_end, prob) = match top_level_find(&self.source.text[rhs_start..end], b':') {
            Some(c) => (rhs_start + c, Some(compile(&self.source, rhs_start + c + 1, end, &params)?)),
            None => (end, None),
        };
        let succ = if self.source.text[rhs_start..succ_end].trim() == "*" {
            Vec::new()
        } else {
            self.module_string(rhs_start, succ_end, &params)?
        };
        let orig = self.source.original_offset(start);
        let line = self.source.line_col(orig).0;
        Ok(Production { pred, params, cond, succ, prob, at: start as u32, len: (end - start) as u32, line })
    }

    fn predecessor(&mut self, start: usize, end: usize) -> PResult<(u16, Vec<String>)> {
        let text = self.source.text.clone();
        let s = text.as_bytes();
        let mut i = skip_ws(s, start, end);
        if i >= end {
            return Err(self.source.error(ErrorKind::Syntax, start, 1, "missing predecessor", "here"));
        }
        let (name, next) = symbol_at(&text, i, end);
        let sym = self.intern(&name, i)?;
        i = next;
        let mut params = Vec::new();
        if i < end && s[i] == b'(' {
            let close = matching_paren(s, i, end).ok_or_else(|| {
                self.source.error(ErrorKind::Syntax, i, 1, "unclosed `(` in predecessor", "opened here")
            })?;
            for (a, b) in split_args(s, i + 1, close) {
                let p = text[a..b].trim();
                let valid = !p.is_empty()
                    && p.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_')
                    && !p.as_bytes()[0].is_ascii_digit();
                if !valid {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        a,
                        b - a,
                        &format!("predecessor parameter `{p}` must be a name"),
                        "formal parameters are names",
                    ));
                }
                if params.iter().any(|q| q == p) {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        a,
                        b - a,
                        &format!("parameter `{p}` appears twice"),
                        "duplicate",
                    ));
                }
                params.push(p.to_string());
            }
            i = close + 1;
        }
        let rest = skip_ws(s, i, end);
        if rest < end {
            return Err(self.source.error(
                ErrorKind::Syntax,
                rest,
                end - rest,
                "a predecessor is a single module (use `<` and `>` for context)",
                "extra modules",
            ));
        }
        Ok((sym, params))
    }

    fn intern(&mut self, name: &str, at: usize) -> PResult<u16> {
        self.symbols.intern(name).ok_or_else(|| {
            self.source.error(ErrorKind::Syntax, at, 1, "more than 65,535 distinct module names", "here")
        })
    }

    /// Parses a module string (axiom or successor) on `text[start..end]`.
    fn module_string(&mut self, start: usize, end: usize, params: &[String]) -> PResult<Vec<ModuleTemplate>> {
        let mut out = Vec::new();
        let s = self.source.text.as_bytes().to_vec();
        let mut i = skip_ws(&s, start, end);
        while i < end {
            let c = s[i];
            if c == b'(' || c == b')' {
                return Err(self.source.error(
                    ErrorKind::Syntax,
                    i,
                    1,
                    &format!("unexpected `{}`: parameters must follow a module name directly", c as char),
                    "unexpected",
                ));
            }
            let (name, next) = symbol_at(&self.source.text, i, end);
            let sym = self.intern(&name, i)?;
            let at = i;
            i = next;
            let mut args = Vec::new();
            if i < end && s[i] == b'(' {
                let close = matching_paren(&s, i, end).ok_or_else(|| {
                    self.source.error(
                        ErrorKind::Syntax,
                        i,
                        1,
                        &format!("unclosed `(` after module `{name}`"),
                        "opened here",
                    )
                })?;
                for (a, b) in split_args(&s, i + 1, close) {
                    args.push(compile(&self.source, a, b, params)?);
                }
                i = close + 1;
            }
            if let Some(max) = turtle_max_arity(&name) {
                if args.len() > max {
                    return Err(self.source.error(
                        ErrorKind::Arity,
                        at,
                        i - at,
                        &format!(
                            "turtle module `{name}` takes at most {max} parameter(s), got {}",
                            args.len()
                        ),
                        "too many parameters",
                    ));
                }
            }
            out.push(ModuleTemplate { sym, args, at: at as u32 });
            i = skip_ws(&s, i, end);
        }
        Ok(out)
    }
}

fn skip_ws(s: &[u8], mut i: usize, end: usize) -> usize {
    while i < end && s[i].is_ascii_whitespace() {
        i += 1;
    }
    i
}

/// Two-letter `@` modules of cpfg (`@Ts`, `@Gs`, …); other `@X` are one letter.
const AT_TWO_LETTER: &[&str] = &[
    "Ts", "Tf", "Ti", "Td", "Tx", "Gs", "Gc", "Ge", "Gr", "Gt", "Di", "Dd", "Ds", "Dt", "Pa", "Pc", "Pd",
    "Pt", "Pm", "Ms", "Mb",
];

/// Reads one module name starting at byte `i`: a single character, `@X`/`@Xy`, `?X`
/// (cpfg query and communication modules) or `~x` (named surface).
fn symbol_at(text: &str, i: usize, end: usize) -> (String, usize) {
    let s = text.as_bytes();
    let c = text[i..].chars().next().unwrap_or(' ');
    let mut j = i + c.len_utf8();
    match c {
        '@' if j < end && s[j].is_ascii_alphabetic() => {
            j += 1;
            if j < end && j < s.len() {
                let two = &text[j - 1..(j + 1).min(text.len())];
                if AT_TWO_LETTER.contains(&two) {
                    j += 1;
                }
            }
        }
        '?' if j < end && s[j].is_ascii_uppercase() => j += 1,
        '~' if j < end && s[j].is_ascii_alphanumeric() => j += 1,
        _ => {}
    }
    (text[i..j].to_string(), j)
}

/// Index of the `)` matching the `(` at `open`, within `end`.
fn matching_paren(s: &[u8], open: usize, end: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (k, &c) in s.iter().enumerate().take(end).skip(open) {
        match c {
            b'(' => depth += 1,
            b')' => {
                depth -= 1;
                if depth == 0 {
                    return Some(k);
                }
            }
            _ => {}
        }
    }
    None
}

/// Splits `s[start..end]` at top-level commas.
fn split_args(s: &[u8], start: usize, end: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut a = start;
    for (k, &c) in s.iter().enumerate().take(end).skip(start) {
        match c {
            b'(' => depth += 1,
            b')' => depth -= 1,
            b',' if depth == 0 => {
                out.push((a, k));
                a = k + 1;
            }
            _ => {}
        }
    }
    out.push((a, end));
    out
}

/// Offset of the first `c` outside parentheses.
fn top_level_find(text: &str, c: u8) -> Option<usize> {
    let mut depth = 0i32;
    for (k, &b) in text.as_bytes().iter().enumerate() {
        match b {
            b'(' => depth += 1,
            b')' => depth -= 1,
            _ if b == c && depth == 0 => return Some(k),
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_honda_tree() {
        let text = "#define R1 0.75\nLsystem: 1\nderivation length: 10\nAxiom: A(1,0.3)\n\
                    A(s,w) : s >= 0 --> !(w)F(s)[+(35)A(s*R1, w*0.5^0.4)][+(-35)A(s*0.77, w*0.5^0.4)]\n\
                    endlsystem\n";
        let ls = LSystem::parse("h.l", text, &[]).unwrap();
        assert_eq!(ls.derivation_length, 10);
        assert_eq!(ls.axiom.len(), 1);
        assert_eq!(ls.productions.len(), 1);
        let p = &ls.productions[0];
        assert_eq!(p.params, vec!["s", "w"]);
        assert!(p.cond.is_some());
        assert_eq!(p.succ.len(), 10);
        assert_eq!(p.line, 5);
    }

    #[test]
    fn special_symbols() {
        let text = "Lsystem: 1\nAxiom: @Ts(1)@O?E(1)~lF\nendlsystem\n";
        let ls = LSystem::parse("s.l", text, &[]).unwrap();
        let names: Vec<&str> = ls.axiom.iter().map(|m| ls.symbols.name(m.sym)).collect();
        assert_eq!(names, vec!["@Ts", "@O", "?E", "~l", "F"]);
    }

    #[test]
    fn stochastic_and_empty() {
        let text = "Lsystem: 1\nseed: 5\nAxiom: F\nF --> F[+F]F : 0.3\nF --> * : 0.7\nendlsystem\n";
        let ls = LSystem::parse("s.l", text, &[]).unwrap();
        assert_eq!(ls.seed, Some(5));
        assert!(ls.productions[0].prob.is_some());
        assert!(ls.productions[1].succ.is_empty());
    }

    #[test]
    fn errors() {
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: F(1,2)\nendlsystem\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Arity);
        assert!(e.message.starts_with("e.l:2:8:"), "{}", e.message);
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: A(1\nendlsystem\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Syntax);
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: A\nA(x) --> B(y)\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::UndefinedName);
        assert!(e.message.starts_with("e.l:3:12:"), "{}", e.message);
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: A\nA B\n", &[]).unwrap_err();
        assert!(e.message.contains("expected a production"));
        let e = LSystem::parse("e.l", "Axiom: A\n", &[]).unwrap_err();
        assert!(e.message.contains("Lsystem:"));
        let e = LSystem::parse("e.l", "Lsystem: 1\nA --> B\n", &[]).unwrap_err();
        assert!(e.message.contains("no `Axiom:`"));
    }
}
