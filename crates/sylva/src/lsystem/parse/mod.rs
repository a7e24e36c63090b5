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

use super::expr::{compile, compile_block, declared_names, Evaluator, Expr, Globals, RandomGenerator, Scope};
use super::preprocess::IncludeResolver;
use super::source::{ErrorKind, LsystemError, Source};
use std::collections::HashMap;

mod items;
mod production;
mod scan;

use self::items::{arrow, Item, Kw, Section};
pub use self::scan::symbol_at;
use self::scan::top_level_find;

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
    /// True when the model opens files for writing (`fopen(…, "w")`): sylva discards
    /// file output like `printf` output, and the pipeline says so.
    pub writes_files: bool,
    /// The model's `fopen` calls (name, mode, place): the pipeline reads the files
    /// opened for reading from the model folder beforehand ([`crate::lsystem::expr::files`]).
    pub file_uses: Vec<crate::lsystem::expr::files::FileUse>,
    /// Derivation length from the file (`derivation length:`), 0 when absent.
    pub derivation_length: u32,
    /// Seed from the file (`seed:`), if given (its absolute value, for sylva's generator).
    pub seed: Option<u64>,
    /// The `seed:` value as cpfg reads it (a C `int`, truncated), if given: with cpfg's
    /// generator it seeds the choice of stochastic productions, and an L-system with a
    /// `seed:` line is a stochastic one ([`super::expr::random`]).
    pub cpfg_seed: Option<i64>,
    /// The generator the derivation draws from ([`RandomGenerator::Sylva`] unless the
    /// caller chooses; the pipeline sets it from `generator.random`).
    pub random: RandomGenerator,
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
    /// Per symbol: for a prefixed module `@X` or `~X` (X one character) whose own
    /// productions are none while X has some, X's symbol; [`NO_BASE`] otherwise. cpfg
    /// keeps `@` and `~` as separate symbols of its string, so X's productions rewrite
    /// the X of `@X(…)` (issue 46 item 4); see [`LSystem::prefixed_lead`].
    pub prefix_base: Vec<u16>,
}

/// The largest `maximum depth:` a decomposition or homomorphism may declare (issue 46
/// item 10: real ecosystem models use 15,000–25,000). Expansion keeps its own stack and
/// the module and work budgets bound what a deep recursion writes, so the depth itself
/// costs nothing until it is used.
pub const MAX_DEPTH: u32 = 1_000_000;

/// [`LSystem::prefix_base`] of a symbol that is not a prefixed module with a base.
pub const NO_BASE: u16 = u16::MAX;

/// `@X` / `~X` with X a single character: the prefix and X.
fn split_prefixed(name: &str) -> Option<(char, &str)> {
    let mut c = name.chars();
    let p = c.next().filter(|p| *p == '@' || *p == '~')?;
    let rest = c.as_str();
    (rest.chars().count() == 1).then_some((p, rest))
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
    cpfg_seed: Option<i64>,
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
        Self::parse_predefined(name, text, defines, &[], resolve)
    }

    /// Like [`LSystem::parse_with`], with `predefined` macros that the file's own
    /// `#define`s may replace (a cpfg command line's `-D`; the pipeline passes a function
    /// set's names, [`crate::lsystem::files::ModelFolder::gallery_names`]).
    pub fn parse_predefined(
        name: &str,
        text: &str,
        defines: &[(String, String)],
        predefined: &[(String, String)],
        resolve: IncludeResolver,
    ) -> PResult<LSystem> {
        let source = Source::with_predefined(name, text, defines, predefined, resolve)?;
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
            file_uses: Vec::new(),
            derivation_length: 0,
            seed: None,
            cpfg_seed: None,
            random: RandomGenerator::Sylva,
            define_block: None,
            start: None,
            start_each: None,
            end_each: None,
            end: None,
            number: 1,
            subsystems: Vec::new(),
            prefix_base: Vec::new(),
        };
        let items = ls.items()?;
        ls.declare_globals(&items)?;
        let blocks = ls.compile_items(&items)?;
        ls.intern_prefixed_leads(&blocks)?;
        let mut blocks = blocks.into_iter();
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
        ls.file_uses = crate::lsystem::expr::files::file_reads(&ls.source.text);
        ls.writes_files = ls.file_uses.iter().any(|u| !u.reads());
        Ok(ls)
    }

    /// Interns, for every prefixed module `@X` / `~X` and every production of X whose
    /// successor starts with a one-character module Y, the module `@Y` / `~Y` that
    /// rewriting the X of `@X` makes (cpfg's string keeps the prefix before Y).
    fn intern_prefixed_leads(&mut self, blocks: &[Block]) -> PResult<()> {
        for s in 0..self.symbols.len() {
            let name = self.symbols.name(s as u16).to_string();
            let Some((prefix, base)) = split_prefixed(&name) else { continue };
            let Some(b) = self.symbols.get(base) else { continue };
            let mut leads = Vec::new();
            for p in blocks.iter().flat_map(|k| &k.productions).filter(|p| p.pred == b && p.rest.is_empty()) {
                if let Some(first) = p.succ.first() {
                    let y = self.symbols.name(first.sym);
                    if y.chars().count() == 1 && y.chars().all(|c| c.is_ascii_alphanumeric()) {
                        leads.push(format!("{prefix}{y}"));
                    }
                }
            }
            for l in leads {
                self.symbols.intern(&l).ok_or_else(|| {
                    self.source.error_nowhere(ErrorKind::Syntax, "more than 65,535 distinct module names")
                })?;
            }
        }
        Ok(())
    }

    /// The module that rewriting the X of the prefixed module `sym` (`@X`, `~X`) writes
    /// first, for a successor that starts with `lead` (Y): `@Y` / `~Y`, as cpfg's string
    /// keeps the prefix before whatever replaces X. `None` when Y is not a module the
    /// prefix can carry (not one letter or digit), or was not interned.
    pub fn prefixed_lead(&self, sym: u16, lead: u16) -> Option<u16> {
        let (prefix, _) = split_prefixed(self.symbols.name(sym))?;
        let y = self.symbols.name(lead);
        if y.chars().count() != 1 || !y.chars().all(|c| c.is_ascii_alphanumeric()) {
            return None;
        }
        self.symbols.get(&format!("{prefix}{y}"))
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
            cpfg_seed: self.cpfg_seed.take(),
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
        self.cpfg_seed = b.cpfg_seed;
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
        self.prefix_base = (0..n)
            .map(|i| {
                let base = split_prefixed(self.symbols.name(i as u16)).and_then(|(_, x)| self.symbols.get(x));
                match base {
                    Some(b) if self.by_symbol[i].is_empty() && !self.by_symbol[b as usize].is_empty() => b,
                    _ => NO_BASE,
                }
            })
            .collect();
    }
}

impl LSystem {
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
                            // cpfg: `(int) Eval(...)`. A `seed:` in the homomorphism section
                            // is cpfg's homomorphism seed, not the L-system's: it does not
                            // make the L-system stochastic (its separate stream of
                            // homomorphism draws is not modelled; they come from the
                            // expression stream).
                            if section != Section::Homomorphism {
                                self.cpfg_seed = Some(n.clamp(i32::MIN as f64, i32::MAX as f64) as i64);
                            }
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
                            if !(1.0..=MAX_DEPTH as f64).contains(&n) {
                                return Err(self.source.error(
                                    ErrorKind::Syntax,
                                    value,
                                    end - value,
                                    &format!("maximum depth must be 1..{MAX_DEPTH}, got {n}"),
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
