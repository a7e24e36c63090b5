//! Parser for cpfg L-system files (`.l`): the file structure, productions and module
//! strings, compiled once into symbol ids and bytecode.
//!
//! ```text
//! #define NAME value
//! Lsystem: 1
//! seed: 2454                        (optional)
//! derivation length: 10
//! ignore: +-F                       (or consider: ...; context matching only)
//! define: { array len[2] = {1, 0.85}; }
//! Start: { n = 0; }   StartEach: { }   EndEach: { n = n + 1; }   End: { }
//! Axiom: A(1, 0.3)
//! A(s,w) : s >= MIN --> !(w)F(s)[+(A1)A(s*R1, w*Q^E)][+(A2)A(s*R2, w*(1-Q)^E)]
//! b < a > c : {x = 1;} t > 0 {y = 2;} --> a     (contexts and statement blocks)
//! F --> F[+F]F : 0.33               (stochastic: probability after the successor)
//! decomposition                     (applied after every step)
//! maximum depth: 5
//! homomorphism                      (applied for interpretation only)
//! endlsystem
//! ```
//!
//! Keywords are case-insensitive, as in cpfg. A production may continue on the
//! following lines until a blank line, a keyword or the next production. `*` as a
//! condition means "none"; `*` as a successor is the empty string. Variables assigned in
//! statement blocks are global, as in cpfg; assignments to a production's parameters are
//! local to that application. McLoughlin2021 §2 gives the grammars this must read; ABOP ch. 1
//! and the cpfg manual give the syntax.

use super::expr::{compile, compile_block, declared_names, Evaluator, Expr, Globals, Scope};
use super::preprocess::IncludeResolver;
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

/// One element of a right context: a module (symbol, parameter count) or a bracket.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContextItem {
    /// A module with this many parameters, bound to consecutive local slots.
    Module(u16, usize),
    /// `[`: the context continues inside a branch.
    Open,
    /// `]`: the context continues after the end of the current branch.
    Close,
}

/// A compiled production `lc < pred > rc : {pre} cond {post} --> succ : prob`.
#[derive(Debug, Clone, PartialEq)]
pub struct Production {
    /// Strict predecessor symbol.
    pub pred: u16,
    /// Number of parameters of the predecessor (its first local slots).
    pub arity: usize,
    /// Further modules of a multi-module predecessor (symbol, parameter count), which
    /// must follow the first one immediately; their parameters follow its own.
    pub rest: Vec<(u16, usize)>,
    /// All local names: predecessor parameters, then left- and right-context parameters.
    pub params: Vec<String>,
    /// Left context modules in string order (symbol, parameter count).
    pub left: Vec<(u16, usize)>,
    /// Right context in string order.
    pub right: Vec<ContextItem>,
    /// Statements run before the condition.
    pub pre: Option<Expr>,
    /// Condition, if any.
    pub cond: Option<Expr>,
    /// Statements run after a true condition.
    pub post: Option<Expr>,
    /// Successor modules.
    pub succ: Vec<ModuleTemplate>,
    /// Probability weight for stochastic productions.
    pub prob: Option<Expr>,
    /// Offset of the production's first character in the preprocessed source.
    pub at: u32,
    /// Length of the production's text.
    pub len: u32,
    /// 1-based line of the production in its file.
    pub line: usize,
}

impl Production {
    /// True when the production needs a locals buffer (contexts or statements) instead
    /// of reading the module's parameters in place.
    pub fn needs_buffer(&self) -> bool {
        !self.left.is_empty()
            || !self.right.is_empty()
            || !self.rest.is_empty()
            || self.pre.is_some()
            || self.post.is_some()
    }
}

/// Productions of one section, indexed by predecessor symbol.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RuleSet {
    /// Productions in file order.
    pub productions: Vec<Production>,
    /// For each symbol id, the indices of its productions in file order.
    pub by_symbol: Vec<Vec<u32>>,
    /// Recursion depth (`maximum depth:`, default 1).
    pub max_depth: u32,
    /// True when the file gave `maximum depth:`; then exceeding it is an error.
    pub depth_explicit: bool,
    /// Most further modules of any predecessor ([`Production::rest`]): 0 when every
    /// predecessor is one module. Set when the L-system is built.
    pub lookahead: usize,
}

/// A parsed and compiled L-system.
#[derive(Debug, Clone)]
pub struct LSystem {
    /// The preprocessed source, for error messages.
    pub source: Source,
    /// Interned module names.
    pub symbols: Symbols,
    /// Global variables and arrays.
    pub globals: Globals,
    /// The axiom.
    pub axiom: Vec<ModuleTemplate>,
    /// Productions in file order (kept as a field for direct access).
    pub productions: Vec<Production>,
    /// For each symbol id, the indices of its productions in file order.
    pub by_symbol: Vec<Vec<u32>>,
    /// Decomposition productions, applied after every derivation step.
    pub decomposition: RuleSet,
    /// Homomorphism productions, applied for interpretation only.
    pub homomorphism: RuleSet,
    /// Per symbol: skipped during context matching (`ignore:` / `consider:`).
    pub context_skip: Vec<bool>,
    /// True when some production has a context.
    pub has_context: bool,
    /// `ring L-system`: the string is circular for context matching.
    pub ring: bool,
    /// True when the L-system uses query modules (`?P`, `?H`, `?U`, `?L`), which the
    /// turtle answers after every derivation step.
    pub has_queries: bool,
    /// Byte offset (in the preprocessed source) of the first communication module `?E`,
    /// when the L-system uses them: the derivation then needs an environmental program.
    pub environment_at: Option<usize>,
    /// True when the model opens files (`fopen`): sylva discards file output like
    /// `printf` output, and the pipeline says so.
    pub writes_files: bool,
    /// Derivation length from the file (`derivation length:`), 0 when absent.
    pub derivation_length: u32,
    /// Seed from the file (`seed:`), if given.
    pub seed: Option<u64>,
    /// `define:` block (array declarations and assignments), run first.
    pub define_block: Option<Expr>,
    /// `Start:` block, run before the derivation.
    pub start: Option<Expr>,
    /// `StartEach:` block, run before every step.
    pub start_each: Option<Expr>,
    /// `EndEach:` block, run after every step.
    pub end_each: Option<Expr>,
    /// `End:` block, run after the derivation.
    pub end: Option<Expr>,
    /// The number of this L-system's `Lsystem: n` line (1 when it gave none).
    pub number: i64,
    /// The file's further `Lsystem: n` blocks, the sub-L-systems that `?(n, scale)` …
    /// `$` calls (empty for a sub-L-system itself).
    pub subsystems: Vec<SubLsystem>,
}

/// A sub-L-system: an `Lsystem: n` block after the file's first one. The modules
/// between a `?(n, scale)` and its `$` are rewritten with its productions,
/// decomposition and homomorphism; its axiom and derivation length only matter when
/// it is grown on its own. It shares the main L-system's symbols, globals and source.
#[derive(Debug, Clone)]
pub struct SubLsystem {
    /// The `n` of its `Lsystem: n` line.
    pub number: i64,
    /// Its rules (`subsystems` is empty).
    pub lsystem: LSystem,
}

/// What one `Lsystem:` … `endlsystem` block declared, before symbol indexing.
struct Block {
    number: i64,
    axiom: Vec<ModuleTemplate>,
    productions: Vec<Production>,
    decomposition: RuleSet,
    homomorphism: RuleSet,
    derivation_length: u32,
    seed: Option<u64>,
    ring: bool,
    ignore: Option<(Vec<String>, bool, usize)>,
}

/// Modules that have a fixed maximum number of parameters in the turtle.
fn turtle_max_arity(name: &str) -> Option<usize> {
    Some(match name {
        "F" | "f" | "G" | "g" | "+" | "-" | "&" | "^" | "\\" | "/" | "!" | "#" | ";" | "," => 1,
        "[" | "]" | "|" | "$" | "%" => 0,
        _ => return None,
    })
}

/// Which section productions go to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Section {
    Productions,
    Decomposition,
    Homomorphism,
}

/// One logical item of the file: a keyword line, a block or a production.
#[derive(Debug, Clone)]
enum Item {
    Keyword { kw: Kw, value: usize, end: usize, at: usize },
    Block { kw: Kw, start: usize, end: usize, at: usize },
    Production { start: usize, end: usize },
    Ring,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kw {
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
/// and the byte offset (within `line`) where its value starts.
fn keyword(line: &str) -> Option<(Kw, usize)> {
    let lower = line.to_ascii_lowercase();
    for &(name, kw, colon) in KEYWORDS {
        let Some(rest) = lower.strip_prefix(name) else { continue };
        let trimmed = rest.trim_start();
        if colon {
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
fn arrow(text: &str) -> Option<(usize, usize)> {
    top_level_find_str(text, "-->").map(|a| (a, 3)).or_else(|| top_level_find_str(text, "->").map(|a| (a, 2)))
}

impl LSystem {
    /// Parses an L-system file. `name` is used in messages; `defines` override the
    /// file's `#define` values.
    pub fn parse(name: &str, text: &str, defines: &[(String, String)]) -> PResult<LSystem> {
        Self::parse_with(name, text, defines, &|_| Err("no such file next to the model".into()))
    }

    /// Like [`LSystem::parse`], resolving `#include` through `resolve`.
    pub fn parse_with(
        name: &str,
        text: &str,
        defines: &[(String, String)],
        resolve: IncludeResolver,
    ) -> PResult<LSystem> {
        let source = Source::with_includes(name, text, defines, resolve)?;
        let mut ls = LSystem {
            source,
            symbols: Symbols::default(),
            globals: Globals::default(),
            axiom: Vec::new(),
            productions: Vec::new(),
            by_symbol: Vec::new(),
            decomposition: RuleSet { max_depth: 1, ..Default::default() },
            homomorphism: RuleSet { max_depth: 1, ..Default::default() },
            context_skip: Vec::new(),
            has_context: false,
            ring: false,
            has_queries: false,
            environment_at: None,
            writes_files: false,
            derivation_length: 0,
            seed: None,
            define_block: None,
            start: None,
            start_each: None,
            end_each: None,
            end: None,
            number: 1,
            subsystems: Vec::new(),
        };
        let items = ls.items()?;
        ls.declare_globals(&items)?;
        let mut blocks = ls.compile_items(&items)?.into_iter();
        let main = blocks.next().expect("compile_items returns the main block");
        ls.install(main);
        let mut subsystems: Vec<SubLsystem> = Vec::new();
        for b in blocks {
            if b.number == ls.number || subsystems.iter().any(|s| s.number == b.number) {
                return Err(ls.source.error_nowhere(
                    ErrorKind::Syntax,
                    &format!("two `Lsystem: {}` blocks: sub-L-system numbers must differ", b.number),
                ));
            }
            let mut sub = ls.clone();
            sub.install(b);
            subsystems.push(SubLsystem { number: sub.number, lsystem: sub });
        }
        ls.subsystems = subsystems;
        ls.has_queries = ["?P", "?H", "?U", "?L"].iter().any(|q| ls.symbols.get(q).is_some());
        ls.writes_files = ls.source.text.contains("fopen");
        Ok(ls)
    }

    /// Takes the current block's declarations out of `self` (leaving it blank for the
    /// next block).
    fn take_block(&mut self, number: i64, ignore: Option<(Vec<String>, bool, usize)>) -> Block {
        let blank = || RuleSet { max_depth: 1, ..Default::default() };
        Block {
            number,
            axiom: std::mem::take(&mut self.axiom),
            productions: std::mem::take(&mut self.productions),
            decomposition: std::mem::replace(&mut self.decomposition, blank()),
            homomorphism: std::mem::replace(&mut self.homomorphism, blank()),
            derivation_length: std::mem::take(&mut self.derivation_length),
            seed: self.seed.take(),
            ring: std::mem::take(&mut self.ring),
            ignore,
        }
    }

    /// Makes `b` this L-system's rules and indexes them by symbol.
    fn install(&mut self, b: Block) {
        self.number = b.number;
        self.axiom = b.axiom;
        self.productions = b.productions;
        self.decomposition = b.decomposition;
        self.homomorphism = b.homomorphism;
        self.derivation_length = b.derivation_length;
        self.seed = b.seed;
        self.ring = b.ring;
        let n = self.symbols.len();
        let index = |prods: &[Production]| {
            let mut by = vec![Vec::new(); n];
            for (k, p) in prods.iter().enumerate() {
                by[p.pred as usize].push(k as u32);
            }
            by
        };
        self.by_symbol = index(&self.productions);
        self.decomposition.by_symbol = index(&self.decomposition.productions);
        self.homomorphism.by_symbol = index(&self.homomorphism.productions);
        for rules in [&mut self.decomposition, &mut self.homomorphism] {
            rules.lookahead = rules.productions.iter().map(|p| p.rest.len()).max().unwrap_or(0);
        }
        self.context_skip = vec![false; n];
        if let Some((names, is_ignore, _)) = b.ignore {
            for i in 0..n {
                let name = self.symbols.name(i as u16);
                let listed = names.iter().any(|s| s == name);
                self.context_skip[i] = name != "[" && name != "]" && listed == is_ignore;
            }
        }
        self.has_context = self.productions.iter().any(|p| !p.left.is_empty() || !p.right.is_empty());
    }

    /// Groups the preprocessed text into keyword lines, blocks and productions.
    fn items(&self) -> PResult<Vec<Item>> {
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

    /// Declares every global: arrays of `define:` and names assigned in any block.
    fn declare_globals(&mut self, items: &[Item]) -> PResult<()> {
        let mut blocks: Vec<(usize, usize, Vec<String>)> = Vec::new();
        for it in items {
            match *it {
                Item::Block { start, end, .. } => blocks.push((start, end, Vec::new())),
                Item::Production { start, end } => {
                    let (lhs_end, _) = match arrow(&self.source.text[start..end]) {
                        Some((a, _)) => (start + a, 0),
                        None => continue,
                    };
                    let lhs = &self.source.text[start..lhs_end];
                    if lhs.contains('{') {
                        let params = self.lhs_param_names(start, lhs_end);
                        blocks.push((start, lhs_end, params));
                    }
                }
                _ => {}
            }
        }
        for (start, end, params) in blocks {
            let text = self.source.text[start..end].to_string();
            for (name, arr) in declared_names(&text, &params) {
                match arr {
                    None => {
                        self.globals.scalar(&name);
                    }
                    Some((dims, values)) => {
                        let at = start + text.find(&name).unwrap_or(0);
                        let consts = |v: &[String], what: &str| -> PResult<Vec<f64>> {
                            v.iter()
                                .map(|t| {
                                    let tmp = Source::new(&self.source.name, t, &[])?;
                                    let e = compile(&tmp, 0, tmp.text.len(), &Scope::default()).map_err(
                                        |_| {
                                            self.source.error(
                                                ErrorKind::Syntax,
                                                at,
                                                name.len(),
                                                &format!("array `{name}`: {what} `{t}` is not a constant"),
                                                "array",
                                            )
                                        },
                                    )?;
                                    Evaluator::new(0).eval(&e, &[]).map_err(|_| {
                                        self.source.error(
                                            ErrorKind::NonFinite,
                                            at,
                                            name.len(),
                                            &format!("array `{name}`: bad {what} `{t}`"),
                                            "array",
                                        )
                                    })
                                })
                                .collect()
                        };
                        let dims: Vec<u32> = consts(&dims, "dimension")?
                            .into_iter()
                            .map(|d| if (1.0..=1e7).contains(&d) { d as u32 } else { 0 })
                            .collect();
                        let values = consts(&values, "initial value")?;
                        self.globals.array(&name, dims, &values).map_err(|why| {
                            self.source.error(ErrorKind::OutOfRange, at, name.len(), &why, "array")
                        })?;
                    }
                }
            }
        }
        Ok(())
    }

    /// Parameter names of a production's predecessor and contexts (for excluding them
    /// from globals).
    fn lhs_param_names(&self, start: usize, lhs_end: usize) -> Vec<String> {
        let lhs = &self.source.text[start..lhs_end];
        let pred_part = match top_level_find(lhs, b':') {
            Some(c) => &lhs[..c],
            None => lhs,
        };
        let mut names = Vec::new();
        let b = pred_part.as_bytes();
        let mut depth = 0;
        let mut cur = String::new();
        for &c in b {
            match c {
                b'(' => {
                    depth += 1;
                    cur.clear();
                }
                b')' | b',' if depth > 0 => {
                    if !cur.trim().is_empty() {
                        names.push(cur.trim().to_string());
                    }
                    cur.clear();
                    if c == b')' {
                        depth -= 1;
                    }
                }
                _ if depth > 0 => cur.push(c as char),
                _ => {}
            }
        }
        names
    }

    /// Compiles every `Lsystem:` block; returns them in file order (the first is the
    /// main L-system, the others its sub-L-systems). Statement blocks (`Start:` …) of
    /// sub-L-systems are compiled but only the main L-system's run.
    fn compile_items(&mut self, items: &[Item]) -> PResult<Vec<Block>> {
        #[derive(PartialEq)]
        enum State {
            Before,
            Inside,
            After,
        }
        let mut state = State::Before;
        let mut section = Section::Productions;
        let mut seen_axiom = false;
        let mut ignore: Option<(Vec<String>, bool, usize)> = None;
        let mut blocks: Vec<Block> = Vec::new();
        let mut number = 1i64;
        let mut main_blocks: [Option<Expr>; 5] = Default::default();
        for it in items {
            let (at, kw) = match *it {
                Item::Keyword { at, kw, .. } | Item::Block { at, kw, .. } => (at, Some(kw)),
                Item::Production { start, .. } => (start, None),
                Item::Ring => {
                    self.ring = true;
                    continue;
                }
            };
            if let (Some(Kw::Lsystem), Item::Keyword { value, end, .. }) = (kw, it) {
                if state == State::Inside {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        at,
                        8,
                        "a second `Lsystem:` before the previous one's `endlsystem`",
                        "here",
                    ));
                }
                number = if value < end && !self.source.text[*value..*end].trim().is_empty() {
                    let n = self.constant(*value, *end, "L-system number")?;
                    if n.fract() != 0.0 || n.abs() > 1e9 {
                        return Err(self.source.error(
                            ErrorKind::Syntax,
                            *value,
                            end - value,
                            &format!("an L-system number must be a whole number, got {n}"),
                            "bad number",
                        ));
                    }
                    n as i64
                } else {
                    1
                };
                if blocks.len() == 1 {
                    // Keep the main L-system's statement blocks apart from the subs'.
                    main_blocks = [
                        self.define_block.take(),
                        self.start.take(),
                        self.start_each.take(),
                        self.end_each.take(),
                        self.end.take(),
                    ];
                }
                state = State::Inside;
                section = Section::Productions;
                seen_axiom = false;
                continue;
            }
            if state != State::Inside {
                let what = if state == State::Before {
                    "expected `Lsystem:` before the L-system"
                } else {
                    "text after `endlsystem`"
                };
                return Err(self.source.error(ErrorKind::Syntax, at, 1, what, "here"));
            }
            match it {
                Item::Ring => {}
                Item::Production { start, end } => {
                    let p = self.production(*start, *end, section)?;
                    match section {
                        Section::Productions => self.productions.push(p),
                        Section::Decomposition => self.decomposition.productions.push(p),
                        Section::Homomorphism => self.homomorphism.productions.push(p),
                    }
                }
                Item::Block { kw, start, end, .. } => {
                    let scope = Scope::new(&[], &self.globals);
                    let e = compile_block(&self.source, *start, *end, &scope)?;
                    let slot = match kw {
                        Kw::Define => &mut self.define_block,
                        Kw::Start => &mut self.start,
                        Kw::StartEach => &mut self.start_each,
                        Kw::EndEach => &mut self.end_each,
                        _ => &mut self.end,
                    };
                    *slot = Some(e);
                }
                Item::Keyword { kw, value, end, at } => {
                    let (value, end, at) = (*value, *end, *at);
                    match kw {
                        Kw::EndLsystem => {
                            if blocks.is_empty() && !seen_axiom {
                                return Err(self
                                    .source
                                    .error_nowhere(ErrorKind::Syntax, "the L-system has no `Axiom:`"));
                            }
                            blocks.push(self.take_block(number, ignore.take()));
                            state = State::After;
                        }
                        Kw::DerivationLength => {
                            let n = self.constant(value, end, "derivation length")?;
                            if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                                return Err(self.source.error(
                                    ErrorKind::Syntax,
                                    value,
                                    end - value,
                                    &format!("derivation length must be a whole number 0..1000000, got {n}"),
                                    "bad derivation length",
                                ));
                            }
                            self.derivation_length = n as u32;
                        }
                        Kw::Seed => {
                            let n = self.constant(value, end, "seed")?;
                            self.seed = Some(n.abs() as u64);
                        }
                        Kw::Axiom => {
                            self.axiom = self.module_string(value, end, &[])?;
                            seen_axiom = true;
                        }
                        Kw::Ignore | Kw::Consider => {
                            let names = self.symbol_list(value, end)?;
                            ignore = Some((names, *kw == Kw::Ignore, at));
                        }
                        Kw::Homomorphism => section = Section::Homomorphism,
                        Kw::Decomposition => section = Section::Decomposition,
                        Kw::MaximumDepth => {
                            let rules =
                                match section {
                                    Section::Homomorphism => &self.homomorphism,
                                    Section::Decomposition => &self.decomposition,
                                    Section::Productions => return Err(self.source.error(
                                        ErrorKind::Syntax,
                                        at,
                                        end - at,
                                        "`maximum depth:` belongs to a homomorphism or decomposition section",
                                        "here",
                                    )),
                                };
                            let _ = rules;
                            let n = self.constant(value, end, "maximum depth")?;
                            if !(1.0..=10000.0).contains(&n) {
                                return Err(self.source.error(
                                    ErrorKind::Syntax,
                                    value,
                                    end - value,
                                    &format!("maximum depth must be 1..10000, got {n}"),
                                    "bad depth",
                                ));
                            }
                            let rules = if section == Section::Homomorphism {
                                &mut self.homomorphism
                            } else {
                                &mut self.decomposition
                            };
                            rules.max_depth = n as u32;
                            rules.depth_explicit = true;
                        }
                        Kw::Warnings => {}
                        Kw::Lsystem | Kw::Define | Kw::Start | Kw::StartEach | Kw::EndEach | Kw::End => {}
                    }
                }
            }
        }
        if state == State::Before {
            return Err(self.source.error_nowhere(ErrorKind::Syntax, "no `Lsystem:` block found"));
        }
        if state == State::Inside {
            if blocks.is_empty() && !seen_axiom {
                return Err(self.source.error_nowhere(ErrorKind::Syntax, "the L-system has no `Axiom:`"));
            }
            blocks.push(self.take_block(number, ignore.take()));
        }
        if blocks.len() > 1 {
            [self.define_block, self.start, self.start_each, self.end_each, self.end] = main_blocks;
        }
        Ok(blocks)
    }

    /// Symbols listed after `ignore:` / `consider:` (module names, no parameters).
    fn symbol_list(&mut self, start: usize, end: usize) -> PResult<Vec<String>> {
        let text = self.source.text.clone();
        let mut out = Vec::new();
        let mut i = skip_ws(text.as_bytes(), start, end);
        while i < end {
            let (name, next) = symbol_at(&text, i, end);
            self.check_symbol(&name, i)?;
            self.intern(&name, i)?;
            out.push(name);
            i = skip_ws(text.as_bytes(), next, end);
        }
        Ok(out)
    }

    fn constant(&self, start: usize, end: usize, what: &str) -> PResult<f64> {
        let e = compile(&self.source, start, end, &Scope::default())?;
        let mut ev = Evaluator::new(0);
        ev.eval(&e, &[]).map_err(|_| {
            self.source.error(ErrorKind::NonFinite, start, end - start, &format!("bad {what}"), "here")
        })
    }

    /// Parses a production on `text[start..end]`.
    fn production(&mut self, start: usize, end: usize, section: Section) -> PResult<Production> {
        let text = self.source.text.clone();
        let Some((arrow_at, alen)) = arrow(&text[start..end]) else {
            return Err(self.source.error(ErrorKind::Syntax, start, end - start, "expected `-->`", "here"));
        };
        let lhs_end = start + arrow_at;
        let rhs_start = lhs_end + alen;
        // Left-hand side: `pred` or `pred : cond`.
        let (pred_end, cond_range) = match top_level_find(&text[start..lhs_end], b':') {
            Some(c) => (start + c, Some((start + c + 1, lhs_end))),
            None => (lhs_end, None),
        };
        // Contexts: `lc < pred > rc`.
        let pred_text = &text[start..pred_end];
        let (lc, strict, rc) = {
            let lt = top_level_find(pred_text, b'<');
            let after = lt.map(|l| l + 1).unwrap_or(0);
            let gt = top_level_find(&pred_text[after..], b'>').map(|g| g + after);
            let lc = lt.map(|l| (start, start + l));
            let s0 = start + after;
            let s1 = gt.map(|g| start + g).unwrap_or(pred_end);
            let rc = gt.map(|g| (start + g + 1, pred_end));
            (lc, (s0, s1), rc)
        };
        if section != Section::Productions && (lc.is_some() || rc.is_some()) {
            return Err(self.source.error(
                ErrorKind::Unsupported,
                start,
                pred_end - start,
                "unsupported: context in decomposition or homomorphism productions",
                "context",
            ));
        }
        // A predecessor of several modules matches consecutive modules, in decomposition
        // and homomorphism productions too (of the string being rewritten: `expand_run`
        // in derive.rs).
        let (pred, rest, mut params, arity) = self.predecessor(strict.0, strict.1)?;
        let mut left = Vec::new();
        if let Some((a, b)) = lc {
            for (sym, names, at) in self.context_modules(a, b, false)? {
                match sym {
                    Some(sym) => {
                        left.push((sym, names.len()));
                        self.add_params(&mut params, names, at)?;
                    }
                    None => {
                        return Err(self.source.error(
                            ErrorKind::Unsupported,
                            at,
                            1,
                            "unsupported: brackets in a left context",
                            "bracket",
                        ))
                    }
                }
            }
        }
        let mut right = Vec::new();
        if let Some((a, b)) = rc {
            for (sym, names, at) in self.context_modules(a, b, true)? {
                match sym {
                    // cpfg's `=` in a right context (`[B(x)=]`): the rest of the branch
                    // does not matter; the following `]` already skips it.
                    Some(sym) if self.symbols.name(sym) == "=" && names.is_empty() => {}
                    Some(sym) => {
                        right.push(ContextItem::Module(sym, names.len()));
                        self.add_params(&mut params, names, at)?;
                    }
                    None if text.as_bytes()[at] == b'[' => right.push(ContextItem::Open),
                    None => right.push(ContextItem::Close),
                }
            }
        }
        let scope_globals = self.globals.clone();
        let scope = Scope::new(&params, &scope_globals);
        // Condition part: `{pre} cond {post}`.
        let (mut pre, mut cond, mut post) = (None, None, None);
        if let Some((a, b)) = cond_range {
            let bytes = text.as_bytes();
            let mut i = skip_ws(bytes, a, b);
            if i < b && bytes[i] == b'{' {
                let close = matching(bytes, i, b, b'{', b'}').ok_or_else(|| {
                    self.source.error(ErrorKind::Syntax, i, 1, "unclosed `{` in the condition", "opened here")
                })?;
                pre = Some(compile_block(&self.source, i, close + 1, &scope)?);
                i = close + 1;
            }
            let cond_end = top_level_find(&text[i..b], b'{').map(|k| i + k).unwrap_or(b);
            let ctext = text[i..cond_end].trim();
            if !ctext.is_empty() && ctext != "*" {
                cond = Some(compile(&self.source, i, cond_end, &scope)?);
            }
            if cond_end < b {
                let close = matching(bytes, cond_end, b, b'{', b'}').ok_or_else(|| {
                    self.source.error(
                        ErrorKind::Syntax,
                        cond_end,
                        1,
                        "unclosed `{` after the condition",
                        "here",
                    )
                })?;
                post = Some(compile_block(&self.source, cond_end, close + 1, &scope)?);
                let rest = skip_ws(bytes, close + 1, b);
                if rest < b {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        rest,
                        b - rest,
                        "unexpected text after the statement block",
                        "here",
                    ));
                }
            }
        }
        // Right-hand side: `succ` or `succ : prob`.
        let (succ_end, prob) = match top_level_find(&text[rhs_start..end], b':') {
            Some(c) => (rhs_start + c, Some(compile(&self.source, rhs_start + c + 1, end, &scope)?)),
            None => (end, None),
        };
        let succ = if text[rhs_start..succ_end].trim() == "*" {
            Vec::new()
        } else {
            self.module_string(rhs_start, succ_end, &params)?
        };
        let line = self.source.line_of(start);
        Ok(Production {
            pred,
            arity,
            rest,
            params,
            left,
            right,
            pre,
            cond,
            post,
            succ,
            prob,
            at: start as u32,
            len: (end - start) as u32,
            line,
        })
    }

    fn add_params(&self, params: &mut Vec<String>, names: Vec<String>, at: usize) -> PResult<()> {
        for n in names {
            if params.contains(&n) {
                return Err(self.source.error(
                    ErrorKind::Syntax,
                    at,
                    1,
                    &format!("parameter `{n}` appears twice in the production"),
                    "duplicate",
                ));
            }
            params.push(n);
        }
        Ok(())
    }

    /// Modules of a context with formal parameters: (symbol or None for a bracket,
    /// parameter names, offset).
    #[allow(clippy::type_complexity)]
    fn context_modules(
        &mut self,
        start: usize,
        end: usize,
        brackets: bool,
    ) -> PResult<Vec<(Option<u16>, Vec<String>, usize)>> {
        let text = self.source.text.clone();
        let s = text.as_bytes();
        let mut out = Vec::new();
        let mut i = skip_ws(s, start, end);
        if i >= end {
            return Err(self.source.error(ErrorKind::Syntax, start, 1, "empty context", "here"));
        }
        while i < end {
            if brackets && (s[i] == b'[' || s[i] == b']') {
                out.push((None, Vec::new(), i));
                i = skip_ws(s, i + 1, end);
                continue;
            }
            let (m, names, next) = self.formal_module(&text, i, end)?;
            out.push((Some(m), names, i));
            i = skip_ws(s, next, end);
        }
        Ok(out)
    }

    /// A module with formal parameter names at `i`: (symbol, names, end offset).
    fn formal_module(&mut self, text: &str, i: usize, end: usize) -> PResult<(u16, Vec<String>, usize)> {
        let s = text.as_bytes();
        let (name, mut next) = symbol_at(text, i, end);
        self.check_symbol(&name, i)?;
        let sym = self.intern(&name, i)?;
        let mut params = Vec::new();
        // Blanks may separate a module from its parameters, as in cpfg: `A (x)`.
        let open = skip_ws(s, next, end);
        if open < end && s[open] == b'(' {
            next = open;
        }
        if next < end && s[next] == b'(' {
            let close = matching(s, next, end, b'(', b')').ok_or_else(|| {
                self.source.error(
                    ErrorKind::Syntax,
                    next,
                    1,
                    "unclosed `(` in a production's left side",
                    "here",
                )
            })?;
            for (a, b) in split_args(s, next + 1, close) {
                let p = text[a..b].trim();
                let valid = !p.is_empty()
                    && p.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_')
                    && !p.as_bytes()[0].is_ascii_digit();
                if !valid {
                    return Err(self.source.error(
                        ErrorKind::Syntax,
                        a,
                        (b - a).max(1),
                        &format!("parameter `{p}` of module `{name}` must be a name"),
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
            next = close + 1;
        }
        Ok((sym, params, next))
    }

    /// The strict predecessor: one module, or several consecutive modules (cpfg).
    /// Returns the first symbol, the other modules, all parameter names and the first
    /// module's parameter count.
    #[allow(clippy::type_complexity)]
    fn predecessor(
        &mut self,
        start: usize,
        end: usize,
    ) -> PResult<(u16, Vec<(u16, usize)>, Vec<String>, usize)> {
        let text = self.source.text.clone();
        let s = text.as_bytes();
        let mut i = skip_ws(s, start, end);
        if i >= end {
            return Err(self.source.error(ErrorKind::Syntax, start, 1, "missing predecessor", "here"));
        }
        let (sym, mut params, next) = self.formal_module(&text, i, end)?;
        let arity = params.len();
        let mut rest = Vec::new();
        i = skip_ws(s, next, end);
        while i < end {
            let (m, names, next) = self.formal_module(&text, i, end)?;
            rest.push((m, names.len()));
            self.add_params(&mut params, names, i)?;
            i = skip_ws(s, next, end);
        }
        Ok((sym, rest, params, arity))
    }

    fn intern(&mut self, name: &str, at: usize) -> PResult<u16> {
        self.symbols.intern(name).ok_or_else(|| {
            self.source.error(ErrorKind::Syntax, at, 1, "more than 65,535 distinct module names", "here")
        })
    }

    /// Notes the first communication module `?E` (every module name cpfg has is
    /// accepted; the derivation asks for an environmental program when `?E` is used).
    fn check_symbol(&mut self, name: &str, at: usize) -> PResult<()> {
        if name == "?E" && self.environment_at.is_none() {
            self.environment_at = Some(at);
        }
        Ok(())
    }

    /// Parses a module string (axiom or successor) on `text[start..end]`.
    fn module_string(&mut self, start: usize, end: usize, params: &[String]) -> PResult<Vec<ModuleTemplate>> {
        let mut out = Vec::new();
        let text = self.source.text.clone();
        let s = text.as_bytes();
        let globals = self.globals.clone();
        let scope = Scope::new(params, &globals);
        let mut i = skip_ws(s, start, end);
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
            let (name, next) = symbol_at(&text, i, end);
            self.check_symbol(&name, i)?;
            let sym = self.intern(&name, i)?;
            let at = i;
            i = next;
            // cpfg accepts blanks between a module and its parameters: `F (1)`, `\ (90)`.
            let open = skip_ws(s, i, end);
            if open < end && s[open] == b'(' {
                i = open;
            }
            let mut args = Vec::new();
            if i < end && s[i] == b'(' {
                let close = matching(s, i, end, b'(', b')').ok_or_else(|| {
                    self.source.error(
                        ErrorKind::Syntax,
                        i,
                        1,
                        &format!("unclosed `(` after module `{name}`"),
                        "opened here",
                    )
                })?;
                for (a, b) in split_args(s, i + 1, close) {
                    args.push(compile(&self.source, a, b, &scope)?);
                }
                i = close + 1;
            }
            if let Some(max) = turtle_max_arity(&name) {
                // cpfg ignores extra parameters of `F`, `+`, … (models carry data in
                // them); only parameter-less modules given parameters are rejected.
                if max == 0 && !args.is_empty() {
                    return Err(self.source.error(
                        ErrorKind::Arity,
                        at,
                        i - at,
                        &format!("turtle module `{name}` takes no parameters, got {}", args.len()),
                        "too many parameters",
                    ));
                }
            }
            out.push(ModuleTemplate { sym, args, at: at as u32 });
            i = skip_ws(s, i, end);
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

/// Reads one module name starting at byte `i`: a single character, `@X`/`@Xy`/`@#`, `?X`
/// (cpfg query and communication modules) or `~x` (named surface).
pub fn symbol_at(text: &str, i: usize, end: usize) -> (String, usize) {
    let s = text.as_bytes();
    let c = text[i..].chars().next().unwrap_or(' ');
    let mut j = i + c.len_utf8();
    match c {
        // `@#` selects a generalized cylinder's contour (issue 26).
        '@' if j < end && s[j] == b'#' => j += 1,
        '@' if j < end && s[j].is_ascii_alphabetic() => {
            j += 1;
            if j < end && j < s.len() && s[j].is_ascii_alphabetic() {
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

/// Index of the `close` matching the `open` at `at`, within `end`.
fn matching(s: &[u8], at: usize, end: usize, open: u8, close: u8) -> Option<usize> {
    let mut depth = 0usize;
    let mut k = at;
    while k < end.min(s.len()) {
        let c = s[k];
        if c == b'"' {
            k += 1;
            while k < end && s[k] != b'"' {
                k += 1;
            }
        } else if c == open {
            depth += 1;
        } else if c == close {
            depth = depth.saturating_sub(1);
            if depth == 0 {
                return Some(k);
            }
        }
        k += 1;
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
            b'(' | b'[' => depth += 1,
            b')' | b']' => depth -= 1,
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

/// Offset of the first `c` outside parentheses and braces.
fn top_level_find(text: &str, c: u8) -> Option<usize> {
    let mut depth = 0i32;
    let mut braces = 0i32;
    for (k, &b) in text.as_bytes().iter().enumerate() {
        match b {
            b'(' => depth += 1,
            b')' => depth -= 1,
            b'{' if c != b'{' => braces += 1,
            b'}' if c != b'{' => braces -= 1,
            _ if b == c && depth == 0 && braces == 0 => return Some(k),
            _ => {}
        }
    }
    None
}

/// Offset of the first `pat` outside parentheses and braces.
fn top_level_find_str(text: &str, pat: &str) -> Option<usize> {
    let b = text.as_bytes();
    let p = pat.as_bytes();
    let mut depth = 0i32;
    let mut k = 0;
    while k + p.len() <= b.len() {
        match b[k] {
            b'(' | b'{' => depth += 1,
            b')' | b'}' => depth -= 1,
            _ if depth <= 0 && &b[k..k + p.len()] == p => return Some(k),
            _ => {}
        }
        k += 1;
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
        let text = "Lsystem: 1\nAxiom: @Ts(1)@O~lF\nendlsystem\n";
        let ls = LSystem::parse("s.l", text, &[]).unwrap();
        let names: Vec<&str> = ls.axiom.iter().map(|m| ls.symbols.name(m.sym)).collect();
        assert_eq!(names, vec!["@Ts", "@O", "~l", "F"]);
        let ls = LSystem::parse("s.l", "Lsystem: 1\nAxiom: F?E(1)\nendlsystem\n", &[]).unwrap();
        let e = ls.source.error(ErrorKind::Unsupported, ls.environment_at.unwrap(), 2, "here", "");
        assert!(e.message.starts_with("s.l:2:9: "), "{}", e.message);
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
    fn multi_line_productions_contexts_and_blocks() {
        let text = "Lsystem: 1\nignore: +-\nStart: {n = 0;\n  m = 1;}\nAxiom: A(1)\n\
                    B(x) < A(t) > [C(y)]D : {t = t + 1;} t > 0 {k = t;} -->\n   A(t)\n   B(k)\n\n\
                    A --> B\nendlsystem\n";
        let ls = LSystem::parse("c.l", text, &[]).unwrap();
        assert_eq!(ls.productions.len(), 2);
        let p = &ls.productions[0];
        assert_eq!(p.params, vec!["t", "x", "y"]);
        assert_eq!(p.left.len(), 1);
        assert_eq!(p.right.len(), 4);
        assert!(p.pre.is_some() && p.cond.is_some() && p.post.is_some());
        assert_eq!(p.succ.len(), 2);
        assert!(ls.globals.names.contains_key("k") && ls.globals.names.contains_key("n"));
        assert!(!ls.globals.names.contains_key("t"));
        assert!(ls.start.is_some());
        let plus = ls.symbols.get("+").unwrap() as usize;
        assert!(ls.context_skip[plus]);
    }

    #[test]
    fn ring_lsystems_wrap_contexts() {
        let text = "Lsystem: 1\nring lsystem\nAxiom: BBA\nA < B --> A\nA --> B\nendlsystem\n";
        let ls = LSystem::parse("r.l", text, &[]).unwrap();
        assert!(ls.ring);
        let m = ls.derive(&crate::lsystem::DeriveOptions { steps: 1, budget: 100, seed: 1 }).unwrap();
        // The first B's left neighbour is the last A (the string is a ring).
        assert_eq!(ls.format(&m), "ABB");
        let text = "Lsystem: 1\nring lsystem\nAxiom: ABB\nB > A --> A\nA --> B\nendlsystem\n";
        let ls = LSystem::parse("r.l", text, &[]).unwrap();
        let m = ls.derive(&crate::lsystem::DeriveOptions { steps: 1, budget: 100, seed: 1 }).unwrap();
        assert_eq!(ls.format(&m), "BBA");
    }

    #[test]
    fn errors() {
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: F]($)\nendlsystem\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Syntax);
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: F[(2)\nendlsystem\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Arity);
        assert!(e.message.starts_with("e.l:2:9:"), "{}", e.message);
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: A(1\nendlsystem\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Syntax);
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: A\nA(x) --> B(y)\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::UndefinedName);
        assert!(e.message.starts_with("e.l:3:12:"), "{}", e.message);
        let e = LSystem::parse("e.l", "Lsystem: 1\nignore: +\nA B\nAxiom: A\n", &[]).unwrap_err();
        assert!(e.message.contains("expected a production"));
        let e = LSystem::parse("e.l", "Axiom: A\n", &[]).unwrap_err();
        assert!(e.message.contains("Lsystem:"));
        let e = LSystem::parse("e.l", "Lsystem: 1\nA --> B\n", &[]).unwrap_err();
        assert!(e.message.contains("no `Axiom:`"));
        let e = LSystem::parse("e.l", "Lsystem: 1\nAxiom: A\nLsystem: 2\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Syntax);
        assert!(e.message.starts_with("e.l:3:1: a second `Lsystem:` before the previous"), "{}", e.message);
        let ok =
            LSystem::parse("e.l", "Lsystem: 1\nAxiom: A\nendlsystem\nLsystem: 2\nAxiom: B\n", &[]).unwrap();
        assert_eq!(ok.subsystems[0].lsystem.number, 2, "the last block may end without `endlsystem`");
    }
}
