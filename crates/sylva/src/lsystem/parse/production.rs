//! Productions and module strings: predecessors with their contexts and formal
//! parameters, conditions, successors (stochastic probabilities after them), symbol
//! interning and constants (ABOP ch. 1; cpfg manual).

use super::items::{arrow, Section};
use super::scan::{matching, skip_ws, split_args, symbol_at, top_level_find};
use super::{turtle_max_arity, ContextItem, LSystem, ModuleTemplate, PResult, Production};
use crate::lsystem::expr::{compile, compile_block, Evaluator, Scope};
use crate::lsystem::source::ErrorKind;

impl LSystem {
    /// Symbols listed after `ignore:` / `consider:` (module names, no parameters).
    pub(super) fn symbol_list(&mut self, start: usize, end: usize) -> PResult<Vec<String>> {
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

    pub(super) fn constant(&self, start: usize, end: usize, what: &str) -> PResult<f64> {
        let e = compile(&self.source, start, end, &Scope::default())?;
        let mut ev = Evaluator::new(0);
        ev.eval(&e, &[]).map_err(|_| {
            self.source.error(ErrorKind::NonFinite, start, end - start, &format!("bad {what}"), "here")
        })
    }

    /// Parses a production on `text[start..end]`.
    pub(super) fn production(&mut self, start: usize, end: usize, section: Section) -> PResult<Production> {
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
            // cpfg's `*` as a whole context means any context (a module or none), as
            // no context does (issue 46 item 3): `* < A > * --> …` is `A --> …`.
            let any = |r: Option<(usize, usize)>| r.filter(|&(a, b)| text[a..b].trim() != "*");
            (any(lc), (s0, s1), any(rc))
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
        // in derive/expand.rs).
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
            if s[i] == b'*' {
                return Err(self.source.error(
                    ErrorKind::Unsupported,
                    i,
                    1,
                    "unsupported: `*` among the modules of a context (a context of `*` alone means any \
                     context)",
                    "`*`",
                ));
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
    pub(super) fn module_string(
        &mut self,
        start: usize,
        end: usize,
        params: &[String],
    ) -> PResult<Vec<ModuleTemplate>> {
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
