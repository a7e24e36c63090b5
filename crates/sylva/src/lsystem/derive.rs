//! Parallel rewriting of module strings with compiled productions.
//!
//! Each step replaces every module by the successor of the first production (in file
//! order) whose predecessor symbol and parameter count match and whose condition
//! holds; modules without a matching production are copied. Stochastic productions
//! (a probability after the successor) are chosen among all matching stochastic
//! productions of the module, weighted by their probabilities, with draws from the
//! recipe's seed. Seed 002 §2 (D0L and parametric L-systems), ABOP ch. 1.
//!
//! A module budget is enforced while writing each step, so an exploding grammar stops
//! with a clear message instead of running out of memory.

use super::expr::{EvalError, Evaluator};
use super::parse::{LSystem, ModuleTemplate, Production};
use super::source::{ErrorKind, LsystemError};

/// Default limit on the number of modules in a derived string.
pub const DEFAULT_MODULE_BUDGET: usize = 50_000_000;

/// A string of parametric modules, stored flat: symbol ids plus parameter offsets.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModuleString {
    /// Symbol id of each module.
    pub syms: Vec<u16>,
    /// Parameter offsets: module i's parameters are `params[pofs[i]..pofs[i+1]]`.
    pub pofs: Vec<u32>,
    /// All parameters.
    pub params: Vec<f64>,
}

impl ModuleString {
    /// An empty string.
    pub fn new() -> Self {
        ModuleString { syms: Vec::new(), pofs: vec![0], params: Vec::new() }
    }

    /// An empty string with room for `modules` modules and `params` parameters.
    pub fn with_capacity(modules: usize, params: usize) -> Self {
        let mut pofs = Vec::with_capacity(modules + 1);
        pofs.push(0);
        ModuleString { syms: Vec::with_capacity(modules), pofs, params: Vec::with_capacity(params) }
    }

    /// Number of modules.
    pub fn len(&self) -> usize {
        self.syms.len()
    }

    /// True when there are no modules.
    pub fn is_empty(&self) -> bool {
        self.syms.is_empty()
    }

    /// Symbol and parameters of module `i`.
    #[inline]
    pub fn module(&self, i: usize) -> (u16, &[f64]) {
        (self.syms[i], &self.params[self.pofs[i] as usize..self.pofs[i + 1] as usize])
    }

    /// Appends a module.
    #[inline]
    pub fn push(&mut self, sym: u16, params: &[f64]) {
        self.syms.push(sym);
        self.params.extend_from_slice(params);
        self.pofs.push(self.params.len() as u32);
    }

    /// Number of modules with symbol `sym`.
    pub fn count(&self, sym: u16) -> usize {
        self.syms.iter().filter(|&&s| s == sym).count()
    }
}

/// Options of a derivation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeriveOptions {
    /// Number of rewriting steps.
    pub steps: u32,
    /// Maximum number of modules in any derived string.
    pub budget: usize,
    /// Seed of `ran`, `nran` and stochastic productions.
    pub seed: u64,
}

impl LSystem {
    /// The axiom as a module string (its expressions evaluated).
    pub fn axiom_string(&self, ev: &mut Evaluator) -> Result<ModuleString, Box<LsystemError>> {
        let mut out = ModuleString::new();
        let mut buf = Vec::new();
        for m in &self.axiom {
            buf.clear();
            for a in &m.args {
                let v = ev.eval(a, &[]).map_err(|e| self.eval_error(e, "evaluating the axiom", None))?;
                buf.push(v);
            }
            out.push(m.sym, &buf);
        }
        Ok(out)
    }

    /// Derives `opts.steps` steps from the axiom.
    pub fn derive(&self, opts: &DeriveOptions) -> Result<ModuleString, Box<LsystemError>> {
        let mut ev = Evaluator::new(opts.seed);
        let mut cur = self.axiom_string(&mut ev)?;
        if cur.len() > opts.budget {
            return Err(self.budget_error(0, opts, cur.len()));
        }
        let mut next = ModuleString::new();
        for step in 1..=opts.steps {
            self.step(&cur, &mut next, &mut ev, opts, step)?;
            std::mem::swap(&mut cur, &mut next);
        }
        Ok(cur)
    }

    /// One parallel rewriting step from `cur` into `out` (cleared first).
    pub fn step(
        &self,
        cur: &ModuleString,
        out: &mut ModuleString,
        ev: &mut Evaluator,
        opts: &DeriveOptions,
        step: u32,
    ) -> Result<(), Box<LsystemError>> {
        out.syms.clear();
        out.params.clear();
        out.pofs.clear();
        out.pofs.push(0);
        // Reserve from a cheap estimate (no successor longer than its symbol's longest),
        // capped by the budget so the reservation itself can never explode.
        let estimate = self.growth_bound(cur).min(opts.budget + 1);
        out.syms.reserve(estimate);
        out.pofs.reserve(estimate);
        let ratio = if cur.is_empty() { 1 } else { cur.params.len().div_ceil(cur.len()).max(1) };
        out.params.reserve(estimate.saturating_mul(ratio).min(opts.budget.saturating_mul(4)));
        let mut args: Vec<f64> = Vec::with_capacity(16);
        for i in 0..cur.len() {
            let (sym, params) = cur.module(i);
            let prods = &self.by_symbol[sym as usize];
            let chosen =
                if prods.is_empty() { None } else { self.choose(&self.productions, prods, params, ev, i)? };
            match chosen {
                None => out.push(sym, params),
                Some(p) => self.emit(p, params, out, ev, &mut args)?,
            }
            if out.syms.len() > opts.budget {
                return Err(self.budget_error(step, opts, out.syms.len()));
            }
        }
        Ok(())
    }

    /// Upper bound of the next string's length.
    fn growth_bound(&self, cur: &ModuleString) -> usize {
        let longest: Vec<usize> = self
            .by_symbol
            .iter()
            .map(|ps| ps.iter().map(|&k| self.productions[k as usize].succ.len()).max().unwrap_or(1))
            .collect();
        cur.syms.iter().map(|&s| longest[s as usize]).sum()
    }

    /// The production to apply to a module, if any.
    #[inline]
    fn choose<'a>(
        &self,
        list: &'a [Production],
        prods: &[u32],
        params: &[f64],
        ev: &mut Evaluator,
        i: usize,
    ) -> Result<Option<&'a Production>, Box<LsystemError>> {
        for (n, &k) in prods.iter().enumerate() {
            let p = &list[k as usize];
            if !self.matches(p, params, ev, i)? {
                continue;
            }
            if p.prob.is_none() {
                return Ok(Some(p));
            }
            return self.choose_stochastic(list, &prods[n..], params, ev, i);
        }
        Ok(None)
    }

    #[inline]
    fn matches(
        &self,
        p: &Production,
        params: &[f64],
        ev: &mut Evaluator,
        i: usize,
    ) -> Result<bool, Box<LsystemError>> {
        if p.params.len() != params.len() {
            return Ok(false);
        }
        match &p.cond {
            None => Ok(true),
            Some(c) => {
                let v = ev
                    .eval(c, params)
                    .map_err(|e| self.eval_error(e, "evaluating the condition", Some((p, params, i))))?;
                Ok(v != 0.0)
            }
        }
    }

    /// Chooses among the matching stochastic productions of `prods` by their weights.
    fn choose_stochastic<'a>(
        &self,
        list: &'a [Production],
        prods: &[u32],
        params: &[f64],
        ev: &mut Evaluator,
        i: usize,
    ) -> Result<Option<&'a Production>, Box<LsystemError>> {
        let mut cands: Vec<(&Production, f64)> = Vec::new();
        let mut total = 0.0;
        for (n, &k) in prods.iter().enumerate() {
            let p = &list[k as usize];
            // The first candidate is known to match; re-test the rest.
            if n > 0 && !self.matches(p, params, ev, i)? {
                continue;
            }
            let Some(pe) = &p.prob else { continue };
            let w = ev
                .eval(pe, params)
                .map_err(|e| self.eval_error(e, "evaluating the probability", Some((p, params, i))))?;
            if w < 0.0 {
                return Err(self.source.error(
                    ErrorKind::NonFinite,
                    pe.at as usize,
                    pe.len as usize,
                    &format!("production probability is negative ({w})"),
                    "negative probability",
                ));
            }
            total += w;
            cands.push((p, w));
        }
        if total <= 0.0 {
            return Ok(None);
        }
        let mut x = ev.uniform() * total;
        for &(p, w) in &cands {
            if x < w {
                return Ok(Some(p));
            }
            x -= w;
        }
        Ok(cands.last().map(|c| c.0))
    }

    #[inline]
    fn emit(
        &self,
        p: &Production,
        params: &[f64],
        out: &mut ModuleString,
        ev: &mut Evaluator,
        args: &mut Vec<f64>,
    ) -> Result<(), Box<LsystemError>> {
        for m in &p.succ {
            if m.args.is_empty() {
                out.syms.push(m.sym);
                out.pofs.push(out.params.len() as u32);
                continue;
            }
            args.clear();
            for a in &m.args {
                match ev.eval(a, params) {
                    Ok(v) => args.push(v),
                    Err(e) => return Err(self.successor_error(e, p, m, params)),
                }
            }
            out.push(m.sym, args);
        }
        Ok(())
    }

    fn successor_error(
        &self,
        e: EvalError,
        p: &Production,
        m: &ModuleTemplate,
        params: &[f64],
    ) -> Box<LsystemError> {
        let module = self.symbols.name(m.sym);
        let what = match e.kind {
            ErrorKind::DivisionByZero => "division by zero",
            _ => "the result is not a finite number",
        };
        self.source.error(
            e.kind,
            e.at as usize,
            1,
            &format!(
                "{what} in a parameter of module `{module}` while applying the production of line {} to {}",
                p.line,
                self.format_module(p.pred, params)
            ),
            what,
        )
    }

    fn eval_error(
        &self,
        e: EvalError,
        doing: &str,
        prod: Option<(&Production, &[f64], usize)>,
    ) -> Box<LsystemError> {
        let what = match e.kind {
            ErrorKind::DivisionByZero => "division by zero",
            _ => "the result is not a finite number",
        };
        let context = match prod {
            Some((p, params, _)) => {
                format!(" of the production of line {} for {}", p.line, self.format_module(p.pred, params))
            }
            None => String::new(),
        };
        self.source.error(e.kind, e.at as usize, 1, &format!("{what} while {doing}{context}"), what)
    }

    fn budget_error(&self, step: u32, opts: &DeriveOptions, len: usize) -> Box<LsystemError> {
        let e = self
            .source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "derivation step {step} of {} exceeds the module budget: more than {} modules (reached {len})",
                    opts.steps, opts.budget
                ),
            );
        e.with_help("derive fewer steps (-n) or raise the limit with --set generator.max_modules=N")
    }

    /// The string the turtle reads: `m` with the homomorphism applied (recursively, up
    /// to `maximum depth`). Borrowed unchanged when there is no homomorphism. The
    /// derived string itself is never changed.
    pub fn interpretation<'m>(
        &self,
        m: &'m ModuleString,
        seed: u64,
        budget: usize,
    ) -> Result<std::borrow::Cow<'m, ModuleString>, Box<LsystemError>> {
        if self.homomorphism.is_empty() {
            return Ok(std::borrow::Cow::Borrowed(m));
        }
        let mut ev = Evaluator::new(seed ^ 0x9e37_79b9_7f4a_7c15);
        let mut out = ModuleString::with_capacity(m.len(), m.params.len());
        let mut args = Vec::new();
        for i in 0..m.len() {
            let (sym, params) = m.module(i);
            self.expand(sym, params, 0, &mut out, &mut ev, &mut args, i)?;
            if out.len() > budget {
                let e = self.source.error_nowhere(
                    ErrorKind::Budget,
                    &format!("the homomorphism makes more than {budget} modules"),
                );
                return Err(e.with_help("raise the limit with --set generator.max_modules=N"));
            }
        }
        Ok(std::borrow::Cow::Owned(out))
    }

    #[allow(clippy::too_many_arguments)]
    fn expand(
        &self,
        sym: u16,
        params: &[f64],
        depth: u32,
        out: &mut ModuleString,
        ev: &mut Evaluator,
        args: &mut Vec<f64>,
        i: usize,
    ) -> Result<(), Box<LsystemError>> {
        let prods = &self.homomorphism_by_symbol[sym as usize];
        let chosen = if depth >= self.homomorphism_depth || prods.is_empty() {
            None
        } else {
            self.choose(&self.homomorphism, prods, params, ev, i)?
        };
        let Some(p) = chosen else {
            out.push(sym, params);
            return Ok(());
        };
        if depth + 1 >= self.homomorphism_depth {
            return self.emit(p, params, out, ev, args);
        }
        let mut tmp = ModuleString::new();
        self.emit(p, params, &mut tmp, ev, args)?;
        for k in 0..tmp.len() {
            let (s2, p2) = tmp.module(k);
            self.expand(s2, p2, depth + 1, out, ev, args, i)?;
        }
        Ok(())
    }

    /// One module as text: `A(1,0.5)`.
    pub fn format_module(&self, sym: u16, params: &[f64]) -> String {
        let mut s = String::new();
        self.write_module(&mut s, sym, params);
        s
    }

    fn write_module(&self, s: &mut String, sym: u16, params: &[f64]) {
        use std::fmt::Write;
        s.push_str(self.symbols.name(sym));
        if !params.is_empty() {
            s.push('(');
            for (k, v) in params.iter().enumerate() {
                if k > 0 {
                    s.push(',');
                }
                let _ = write!(s, "{v}");
            }
            s.push(')');
        }
    }

    /// The whole string as text, cpfg-style (`b[a]a`, `F(1)+(60)F(1)`).
    pub fn format(&self, m: &ModuleString) -> String {
        let mut s = String::with_capacity(m.len() * 2);
        for i in 0..m.len() {
            let (sym, params) = m.module(i);
            self.write_module(&mut s, sym, params);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derive(text: &str, n: u32) -> (LSystem, ModuleString) {
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: n, budget: DEFAULT_MODULE_BUDGET, seed: 1 }).unwrap();
        (ls, m)
    }

    const BINARY: &str = "Lsystem: 1\nAxiom: a\na --> b[a]a\nb --> bb\nendlsystem\n";

    #[test]
    fn binary_tree_strings() {
        let expect = ["b[a]a", "bb[b[a]a]b[a]a", "bbbb[bb[b[a]a]b[a]a]bb[b[a]a]b[a]a"];
        for (n, e) in expect.iter().enumerate() {
            let (ls, m) = derive(BINARY, n as u32 + 1);
            assert_eq!(ls.format(&m), *e);
            assert_eq!(m.len(), [5, 14, 34][n]);
        }
        let (ls, m) = derive(BINARY, 6);
        assert_eq!(m.len(), 382);
        assert_eq!(m.count(ls.symbols.get("a").unwrap()), 64);
        assert_eq!(m.count(ls.symbols.get("b").unwrap()), 192);
    }

    #[test]
    fn first_match_and_conditions() {
        let t = "Lsystem: 1\nAxiom: A(0)\nA(x) : x < 2 --> A(x+1)\nA(x) : x >= 2 --> B(x*10)\nA(x) --> C\nendlsystem\n";
        let (ls, m) = derive(t, 3);
        assert_eq!(ls.format(&m), "B(20)");
    }

    #[test]
    fn arity_must_match() {
        let t = "Lsystem: 1\nAxiom: A(1,2) A\nA(x) --> X\nA --> Y\nendlsystem\n";
        let (ls, m) = derive(t, 1);
        assert_eq!(ls.format(&m), "A(1,2)Y");
    }

    #[test]
    fn stochastic_depends_on_seed() {
        let t = "Lsystem: 1\nAxiom: FFFFFFFFFFFFFFFFFFFFFFFFFFFFFF\nF --> A : 1\nF --> B : 1\nendlsystem\n";
        let ls = LSystem::parse("t.l", t, &[]).unwrap();
        let d = |seed| ls.format(&ls.derive(&DeriveOptions { steps: 1, budget: 1000, seed }).unwrap());
        assert_eq!(d(1), d(1));
        assert_ne!(d(1), d(2));
        let s = d(3);
        assert!(s.contains('A') && s.contains('B'));
    }

    #[test]
    fn budget_stops_explosions() {
        let t = "Lsystem: 1\nAxiom: F\nF --> FFFFFFFFFF\nendlsystem\n";
        let ls = LSystem::parse("t.l", t, &[]).unwrap();
        let e = ls.derive(&DeriveOptions { steps: 20, budget: 1_000_000, seed: 1 }).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Budget);
        assert!(e.message.contains("step 7 of 20"), "{}", e.message);
    }

    #[test]
    fn division_by_zero_names_the_production() {
        let t = "Lsystem: 1\nAxiom: A(1)\nA(x) --> A(x-1) B(1/(x-1))\nendlsystem\n";
        let ls = LSystem::parse("t.l", t, &[]).unwrap();
        let e = ls.derive(&DeriveOptions { steps: 2, budget: 100, seed: 1 }).unwrap_err();
        assert_eq!(e.kind, ErrorKind::DivisionByZero);
        assert!(e.message.starts_with("t.l:3:"), "{}", e.message);
        assert!(e.message.contains("module `B`") && e.message.contains("A(1)"), "{}", e.message);
    }

    #[test]
    fn homomorphism_is_for_interpretation_only() {
        let t = "Lsystem: 1\nAxiom: a\na --> b[a]a\nb --> bb\nhomomorphism\na --> F(0.5)\nb --> F(1)\nendlsystem\n";
        let (ls, m) = derive(t, 1);
        assert_eq!(ls.format(&m), "b[a]a");
        let i = ls.interpretation(&m, 1, 100).unwrap();
        assert_eq!(ls.format(&i), "F(1)[F(0.5)]F(0.5)");
        let t = "Lsystem: 1\nAxiom: a\nhomomorphism\nmaximum depth: 3\na --> aa\nendlsystem\n";
        let (ls, m) = derive(t, 0);
        assert_eq!(ls.interpretation(&m, 1, 100).unwrap().len(), 8);
    }

    #[test]
    fn empty_successor() {
        let (ls, m) = derive("Lsystem: 1\nAxiom: A B A\nA --> *\nendlsystem\n", 1);
        assert_eq!(ls.format(&m), "B");
    }
}
