//! Parallel rewriting of module strings with compiled productions.
//!
//! Each step replaces every module by the successor of the first production (in file
//! order) whose predecessor symbol and parameter count match and whose condition
//! holds; modules without a matching production are copied. Stochastic productions
//! (a probability after the successor) are chosen among all matching stochastic
//! productions of the module, weighted by their probabilities, with draws from the
//! recipe's seed. McLoughlin2021 §2 (D0L and parametric L-systems), ABOP ch. 1.
//!
//! A module budget is enforced while writing each step, so an exploding grammar stops
//! with a clear message instead of running out of memory.

use super::expr::{EvalError, Evaluator, Expr, ModelFunctions};
use super::parse::{ContextItem, LSystem, ModuleTemplate, Production, RuleSet};
use super::source::{ErrorKind, LsystemError};
pub use super::string::ModuleString;
use super::string::{try_room, OutOfMemory, BYTES_PER_MODULE, BYTES_PER_PARAMETER};

/// The words for an evaluation error kind.
fn error_words(kind: ErrorKind) -> &'static str {
    match kind {
        ErrorKind::DivisionByZero => "division by zero",
        ErrorKind::OutOfRange => "an array index or loop count out of range",
        ErrorKind::UndefinedName => "a function that the model does not define",
        ErrorKind::Budget => "the derivation's work budget is used up",
        _ => "the result is not a finite number",
    }
}

/// Default limit on the number of modules in a derived string.
pub const DEFAULT_MODULE_BUDGET: usize = 50_000_000;

/// Most bytes a derivation step holds per module of the module budget, in the worst
/// case (issue 39): three strings (the one being rewritten, the one being written and,
/// with multi-module decomposition predecessors, the step's string before its
/// decomposition), each [`BYTES_PER_MODULE`] (6) plus [`PARAMS_PER_MODULE`] (4)
/// parameters of [`BYTES_PER_PARAMETER`] (8) per module, so 38 bytes each; plus the
/// bracket partners of a context L-system (4) and, with sub-L-systems, the owner of
/// each module, its stack and the owners before decomposition (2 each): 124 bytes.
/// A derivation without parameters, contexts or sub-L-systems holds 12 bytes per module.
pub const PEAK_BYTES_PER_MODULE: usize =
    3 * (BYTES_PER_MODULE + PARAMS_PER_MODULE * BYTES_PER_PARAMETER) + 10;

/// Largest module budget (`generator.max_modules`) a derivation accepts: 500 million
/// modules (ten times the default), whose worst case at [`PEAK_BYTES_PER_MODULE`] is
/// 62 GB (57.7 GiB), within 64 GiB; a string of as many modules without parameters
/// takes 3 GB. Larger values are an error naming the key. Under the cap, a derivation
/// that outgrows the machine's memory still stops with an error naming the key and the
/// size asked, never an abort: every string grows fallibly, and each step reserves
/// its estimated size before it writes.
pub const MAX_MODULE_BUDGET: usize = 500_000_000;

/// The module budget against [`MAX_MODULE_BUDGET`]: above it, why (the words that
/// follow the key `generator.max_modules` in a message).
pub fn check_module_budget(budget: usize) -> Result<(), String> {
    if budget > MAX_MODULE_BUDGET {
        return Err(format!(
            "is {budget}, more than the largest module budget {MAX_MODULE_BUDGET}: a derivation step may \
             hold up to {PEAK_BYTES_PER_MODULE} bytes per module of the budget ({} GB at the largest)",
            (MAX_MODULE_BUDGET * PEAK_BYTES_PER_MODULE) as f64 / 1e9
        ));
    }
    Ok(())
}

/// Work allowed per module of the module budget (issue 27): a derivation, with its
/// decomposition, homomorphism, query passes and environmental program, may do at most
/// `WORK_PER_MODULE × budget` units of work (each rewritten or written module counts
/// [`MODULE_WORK`], each module of a query pass [`QUERY_WORK`], each expression
/// operation, loop iteration of a block and context scan step one, each step
/// [`STEP_WORK`]), so a grammar that would derive for
/// minutes stops with an error naming `generator.max_modules`, which raises both.
pub const WORK_PER_MODULE: u64 = 64;

/// Work charged for each module a step reads or writes.
pub const MODULE_WORK: u64 = 4;

/// Work charged for each module of a query pass (the turtle runs over the whole string
/// after every step of a model with `?P`, `?H`, `?U`, `?L` or `?E` modules; a turtle
/// step costs about ten times a rewritten module).
pub const QUERY_WORK: u64 = 64;

/// Work charged for each derivation step, whatever its length (a short string derived
/// for billions of steps runs out of budget too).
pub const STEP_WORK: u64 = 256;

/// Most parameters a derived string may hold per module of the module budget (its
/// parameters are one `f64` array with `u32` offsets, so also at most `u32::MAX`).
pub const PARAMS_PER_MODULE: usize = 4;

/// The work budget of a module budget.
pub fn work_budget(module_budget: usize) -> u64 {
    (module_budget as u64).saturating_mul(WORK_PER_MODULE)
}

/// The parameter budget of a module budget.
pub fn param_budget(module_budget: usize) -> usize {
    module_budget.saturating_mul(PARAMS_PER_MODULE).min(u32::MAX as usize)
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

/// Where a production is being matched: the whole current string, the module's index
/// and the bracket partners (for contexts). `None` for decomposition and homomorphism.
type Site<'a> = Option<(&'a ModuleString, usize, &'a [u32])>;

/// Partner index of every bracket in `m` (`u32::MAX` for other modules); an unmatched
/// `[` points past the end, an unmatched `]` to 0.
fn bracket_partners(
    m: &ModuleString,
    open: Option<u16>,
    close: Option<u16>,
) -> Result<Vec<u32>, OutOfMemory> {
    use crate::geometry::NONE;
    let mut out = Vec::new();
    try_room(&mut out, m.len(), m.len())?;
    out.resize(m.len(), NONE);
    // The open brackets waiting for their partner form a stack linked through `out`
    // (each points at the one opened before it), so no memory beyond `out` is needed.
    let mut top = NONE;
    for (i, &s) in m.syms.iter().enumerate() {
        if Some(s) == open {
            out[i] = top;
            top = i as u32;
        } else if Some(s) == close {
            if top == NONE {
                out[i] = 0;
            } else {
                let o = top as usize;
                top = out[o];
                out[o] = i as u32;
                out[i] = o as u32;
            }
        }
    }
    while top != NONE {
        let o = top as usize;
        top = out[o];
        out[o] = m.len() as u32;
    }
    Ok(out)
}

/// Empties a module string, keeping its allocations.
fn clear_string(m: &mut ModuleString) {
    m.syms.clear();
    m.params.clear();
    m.pofs.clear();
    m.pofs.push(0);
}

/// The modules a decomposition or homomorphism has still to rewrite (the last on top),
/// each with its depth and its group: the successor it belongs to (a multi-module
/// predecessor matches modules of one group only).
struct Pending {
    /// The modules, last on top.
    modules: ModuleString,
    /// Depth of each module.
    depths: Vec<u32>,
    /// Group of each module.
    groups: Vec<u32>,
    /// The group the next successor gets.
    next_group: u32,
}

impl Pending {
    fn new() -> Self {
        Self { modules: ModuleString::new(), depths: Vec::new(), groups: Vec::new(), next_group: 1 }
    }

    fn push(&mut self, sym: u16, params: &[f64], depth: u32, group: u32) -> Result<(), OutOfMemory> {
        let n = self.depths.len();
        try_room(&mut self.depths, 1, n)?;
        try_room(&mut self.groups, 1, n)?;
        self.modules.try_push(sym, params)?;
        self.depths.push(depth);
        self.groups.push(group);
        Ok(())
    }

    /// Pushes the modules of a successor as a new group at `depth`, its first on top.
    fn push_successor(&mut self, succ: &ModuleString, depth: u32) -> Result<(), OutOfMemory> {
        let group = self.next_group;
        self.next_group = self.next_group.wrapping_add(1);
        for j in (0..succ.len()).rev() {
            let (s, p) = succ.module(j);
            self.push(s, p, depth, group)?;
        }
        Ok(())
    }

    /// Takes the top module: its symbol, depth and group, its parameters into `params`.
    fn pop(&mut self, params: &mut Vec<f64>) -> Option<(u16, u32, u32)> {
        let depth = self.depths.pop()?;
        let group = self.groups.pop().expect("one group per depth");
        let sym = self.modules.syms.pop().expect("one module per depth");
        self.modules.pofs.pop();
        let from = *self.modules.pofs.last().expect("pofs starts with 0") as usize;
        params.clear();
        params.extend_from_slice(&self.modules.params[from..]);
        self.modules.params.truncate(from);
        Some((sym, depth, group))
    }

    /// Drops the top module.
    fn drop_top(&mut self) {
        if self.depths.pop().is_some() {
            self.groups.pop();
            self.modules.syms.pop();
            self.modules.pofs.pop();
            let from = *self.modules.pofs.last().expect("pofs starts with 0") as usize;
            self.modules.params.truncate(from);
        }
    }
}

impl LSystem {
    /// An evaluator for a derivation: globals initialised, the `define:` and `Start:`
    /// blocks run, `functions` available to `func(id, x)`.
    pub fn evaluator(&self, seed: u64, functions: ModelFunctions) -> Result<Evaluator, Box<LsystemError>> {
        self.evaluator_within(seed, functions, usize::MAX)
    }

    /// [`LSystem::evaluator`] whose work and strings are limited by the module budget
    /// `budget` ([`work_budget`]).
    pub fn evaluator_within(
        &self,
        seed: u64,
        functions: ModelFunctions,
        budget: usize,
    ) -> Result<Evaluator, Box<LsystemError>> {
        let mut ev = Evaluator::new(seed);
        if budget != usize::MAX {
            ev.work_limit = work_budget(budget);
            ev.module_limit = budget;
        }
        ev.globals = self.globals.init.clone();
        ev.functions = functions;
        for (block, what) in [(&self.define_block, "the define: block"), (&self.start, "the Start: block")] {
            self.run_block(block, &mut ev, what)?;
        }
        Ok(ev)
    }

    fn run_block(
        &self,
        block: &Option<Expr>,
        ev: &mut Evaluator,
        what: &str,
    ) -> Result<(), Box<LsystemError>> {
        if let Some(b) = block {
            ev.exec(b, &mut []).map_err(|e| self.eval_error(e, &format!("running {what}"), None))?;
        }
        Ok(())
    }

    /// The axiom as a module string (its expressions evaluated, decomposition applied).
    pub fn axiom_string(&self, ev: &mut Evaluator) -> Result<ModuleString, Box<LsystemError>> {
        let mut out = ModuleString::new();
        let mut buf = Vec::new();
        let mut scratch = Vec::new();
        // With multi-module predecessors the axiom is decomposed as a whole string.
        let whole = self.decomposition.lookahead > 0;
        for m in &self.axiom {
            buf.clear();
            for a in &m.args {
                let v = ev.eval(a, &[]).map_err(|e| self.eval_error(e, "evaluating the axiom", None))?;
                buf.push(v);
            }
            if whole {
                out.try_push(m.sym, &buf).map_err(|e| self.memory_error(e, ev, "the axiom"))?;
            } else {
                self.expand(
                    &self.decomposition,
                    "decomposition",
                    m.sym,
                    &buf,
                    0,
                    &mut out,
                    ev,
                    &mut scratch,
                )?;
            }
            self.charge_module(ev, &out)?;
        }
        if whole {
            let raw = std::mem::take(&mut out);
            out = ModuleString::try_with_capacity(raw.len(), raw.params.len())
                .map_err(|e| self.memory_error(e, ev, "the axiom"))?;
            self.expand_run(
                &self.decomposition,
                "decomposition",
                &raw,
                0..raw.len(),
                &mut out,
                ev,
                &mut scratch,
            )?;
            self.charge_module(ev, &out)?;
        }
        Ok(out)
    }

    /// Derives `opts.steps` steps from the axiom.
    pub fn derive(&self, opts: &DeriveOptions) -> Result<ModuleString, Box<LsystemError>> {
        self.derive_with(opts, ModelFunctions::default())
    }

    /// Derives with the model's functions (`func(id, x)`) available.
    pub fn derive_with(
        &self,
        opts: &DeriveOptions,
        functions: ModelFunctions,
    ) -> Result<ModuleString, Box<LsystemError>> {
        self.derive_full(opts, functions, None, None).map(|(m, _)| m)
    }

    /// Derives and also returns the evaluator (global variables as the derivation left
    /// them, the generator's state, [`Evaluator::steps_done`]), which the homomorphism
    /// then uses. With `turtle`, query modules (`?P`, `?H`, `?U`, `?L`) are answered
    /// after the axiom and after every step by interpreting the string (without the
    /// homomorphism), and so are communication modules `?E`, by `env`. A model that uses
    /// `?E` without an environment is an `unsupported` error at its first `?E`. The
    /// derivation ends early after a step in which `stop(x)` was called with x ≠ 0.
    pub fn derive_full(
        &self,
        opts: &DeriveOptions,
        functions: ModelFunctions,
        turtle: Option<&super::turtle::TurtleOptions>,
        env: Option<&super::environment::Environment>,
    ) -> Result<(ModuleString, Evaluator), Box<LsystemError>> {
        if let (Some(at), None) = (self.environment_at, env) {
            return Err(self
                .source
                .error(
                    ErrorKind::Unsupported,
                    at,
                    2,
                    "unsupported: `?E` without an environmental program",
                    "communication module",
                )
                .with_help(format!(
                    "give one with `[generator.environment] program = \"…\"` (sylva has: {}), or put the \
                     model's `.e` file (`executable: …`) next to it",
                    super::environment::PROGRAMS.join(", ")
                )));
        }
        check_module_budget(opts.budget).map_err(|m| {
            self.source.error_nowhere(ErrorKind::Budget, &format!("`generator.max_modules` {m}")).with_help(
                "lower it with --set generator.max_modules=N; larger strings would not fit in memory",
            )
        })?;
        let env = if self.environment_at.is_some() { env } else { None };
        if let Some(e) = env {
            // A derivation starts from the program's initial state (clover's leaves).
            e.reset();
        }
        let queries = |m: &mut ModuleString, ev: &mut Evaluator| match turtle {
            Some(t) if self.has_queries || env.is_some() => {
                // A query pass runs the turtle over the whole string.
                ev.charge(QUERY_WORK.saturating_mul(m.len() as u64), 0)
                    .map_err(|e| self.eval_error(e, "answering the query modules", None))?;
                let left = ev.work_limit.saturating_sub(ev.work);
                let used =
                    super::turtle::answer_queries_within(&self.symbols, m, t, &self.source, env, left)?;
                ev.charge(used, 0).map_err(|e| self.eval_error(e, "running the environmental program", None))
            }
            _ => Ok(()),
        };
        let mut ev =
            self.evaluator_within(opts.seed, functions, opts.budget).map_err(|e| self.work_note(e, opts))?;
        let result = (|| {
            let mut cur = self.axiom_string(&mut ev)?;
            if cur.len() > opts.budget {
                return Err(self.budget_error(0, opts, cur.len()));
            }
            queries(&mut cur, &mut ev)?;
            let mut next = ModuleString::new();
            for step in 1..=opts.steps {
                // A cancelled session ([`crate::cancel`]) stops between steps; it drops the
                // partial string.
                if crate::cancel::cancelled() {
                    break;
                }
                ev.charge(STEP_WORK, 0)
                    .map_err(|e| self.eval_error(e, &format!("starting step {step}"), None))?;
                self.run_block(&self.start_each, &mut ev, "the StartEach: block")?;
                self.step(&cur, &mut next, &mut ev, opts, step)?;
                std::mem::swap(&mut cur, &mut next);
                queries(&mut cur, &mut ev)?;
                self.run_block(&self.end_each, &mut ev, "the EndEach: block")?;
                ev.steps_done = step;
                if ev.stopped {
                    break;
                }
            }
            self.run_block(&self.end, &mut ev, "the End: block")?;
            Ok(cur)
        })();
        match result {
            Ok(cur) => Ok((cur, ev)),
            Err(e) => Err(self.work_note(e, opts)),
        }
    }

    /// Adds the numbers and the key to an exhausted work budget's message.
    fn work_note(&self, mut e: Box<LsystemError>, opts: &DeriveOptions) -> Box<LsystemError> {
        if e.kind == ErrorKind::Budget && e.message.contains("work budget") {
            e.message = format!(
                "{}: more than {} units of work ({WORK_PER_MODULE} per module of the module budget \
                 generator.max_modules = {})",
                e.message,
                work_budget(opts.budget),
                opts.budget
            );
            e.with_help(
                "the grammar does too much work (an endless loop, a string that is rewritten for \
                 very many steps, or quadratic context matching): derive fewer steps (-n) or raise the \
                 budget with --set generator.max_modules=N",
            )
        } else {
            e
        }
    }

    /// Charges one written module and checks the string against the module and
    /// parameter budgets of `ev`.
    #[inline]
    fn charge_module(&self, ev: &mut Evaluator, out: &ModuleString) -> Result<(), Box<LsystemError>> {
        ev.charge(MODULE_WORK, 0).map_err(|e| self.eval_error(e, "writing the string", None))?;
        if out.syms.len() > ev.module_limit {
            return Err(self.size_error(
                ev,
                "the derived string",
                out.syms.len(),
                "modules",
                ev.module_limit,
            ));
        }
        let params = param_budget(ev.module_limit);
        if out.params.len() > params {
            return Err(self.size_error(ev, "the derived string", out.params.len(), "parameters", params));
        }
        Ok(())
    }

    fn size_error(
        &self,
        ev: &Evaluator,
        what: &str,
        len: usize,
        unit: &str,
        limit: usize,
    ) -> Box<LsystemError> {
        let per = if unit == "parameters" {
            format!(" ({PARAMS_PER_MODULE} per module of the module budget)")
        } else {
            String::new()
        };
        self.source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "{what} exceeds the module budget after {} step(s): more than {limit} {unit}{per} (reached {len})",
                    ev.steps_done
                ),
            )
            .with_help("derive fewer steps (-n) or raise the limit with --set generator.max_modules=N")
    }

    /// A string that could not grow (issue 39): a budget error naming
    /// `generator.max_modules` and the allocation that failed.
    #[cold]
    fn memory_error(&self, e: OutOfMemory, ev: &Evaluator, what: &str) -> Box<LsystemError> {
        let limit = if ev.module_limit == usize::MAX {
            "no module budget".to_string()
        } else {
            format!("generator.max_modules = {}", ev.module_limit)
        };
        self.source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "{what} outgrows the memory available after {} step(s): allocating {} bytes for a \
                     string of {} modules failed ({limit}; a module takes {BYTES_PER_MODULE} bytes plus \
                     {BYTES_PER_PARAMETER} per parameter, and a step holds two strings)",
                    ev.steps_done, e.bytes, e.modules
                ),
            )
            .with_help(
                "derive fewer steps (-n), or lower the module budget with --set generator.max_modules=N so \
                 that the derivation stops at the budget before memory runs out",
            )
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
        // Fallibly (issue 39): a step that does not fit in memory is an error naming
        // `generator.max_modules`, not an abort.
        let what = format!("derivation step {step}");
        let oom = |e: OutOfMemory, ev: &Evaluator| self.memory_error(e, ev, &what);
        let estimate = self.growth_bound(cur).min(opts.budget + 1);
        // Parameters as many per module as now (rounded up), within the budget's.
        let params = (estimate as u128 * cur.params.len() as u128).div_ceil(cur.len().max(1) as u128);
        let params = params.min(param_budget(opts.budget) as u128) as usize;
        out.try_reserve_exact(estimate, params).map_err(|e| oom(e, ev))?;
        let context = self.has_context || self.subsystems.iter().any(|s| s.lsystem.has_context);
        let brackets = if context {
            bracket_partners(cur, self.symbols.get("["), self.symbols.get("]")).map_err(|e| oom(e, ev))?
        } else {
            Vec::new()
        };
        let owner = self.owners_in(cur, Some(ev))?;
        let (open, close) = (self.symbols.get("["), self.symbols.get("]"));
        let cut = self.symbols.get("%");
        let mut args: Vec<f64> = Vec::with_capacity(16);
        let mut buf: Vec<f64> = Vec::with_capacity(32);
        let mut tmp = ModuleString::new();
        let mut scratch = Vec::new();
        let mut next = 0;
        // With multi-module predecessors in a decomposition, the step first writes the
        // rewritten string and then decomposes it as a whole (each run of modules one
        // L-system rewrites, `raw_owner`), so a predecessor can match modules that
        // different productions wrote. Otherwise each successor is decomposed as it is
        // written.
        let whole = self.decomposition.lookahead > 0
            || self.subsystems.iter().any(|s| s.lsystem.decomposition.lookahead > 0);
        let mut raw_owner: Vec<u16> = Vec::new();
        while next < cur.len() {
            let i = next;
            next += 1;
            ev.charge(MODULE_WORK, 0)
                .map_err(|e| self.eval_error(e, &format!("rewriting step {step}"), None))?;
            let (sym, params) = cur.module(i);
            // The L-system whose rules apply here: a sub-L-system between `?(n, s)`
            // and its `$`, else this one.
            let sys = match owner.get(i) {
                Some(&k) if k > 0 => &self.subsystems[k as usize - 1].lsystem,
                _ => self,
            };
            let decompose = !whole && !sys.decomposition.productions.is_empty();
            if Some(sym) == cut && sys.by_symbol[sym as usize].is_empty() {
                // cpfg's cut: `%` and the rest of its branch are erased (the closing
                // `]` stays), one step after the `%` appeared.
                let mut depth = 0usize;
                while next < cur.len() {
                    let s = cur.syms[next];
                    if Some(s) == open {
                        depth += 1;
                    } else if Some(s) == close {
                        if depth == 0 {
                            break;
                        }
                        depth -= 1;
                    }
                    next += 1;
                }
                continue;
            }
            let prods = &sys.by_symbol[sym as usize];
            let chosen = if prods.is_empty() {
                None
            } else {
                sys.select(&sys.productions, prods, params, Some((cur, i, &brackets)), ev, &mut buf)?
            };
            match chosen {
                None if decompose => {
                    sys.expand(&sys.decomposition, "decomposition", sym, params, 0, out, ev, &mut scratch)?
                }
                None => out.try_push(sym, params).map_err(|e| oom(e, ev))?,
                Some((k, uses_buf)) => {
                    let p = &sys.productions[k];
                    // A multi-module predecessor consumes its following modules too.
                    next = i + 1 + p.rest.len();
                    let locals = if uses_buf { &buf[..] } else { params };
                    if decompose {
                        tmp.syms.clear();
                        tmp.params.clear();
                        tmp.pofs.clear();
                        tmp.pofs.push(0);
                        sys.emit(p, locals, &mut tmp, ev, &mut args)?;
                        for j in 0..tmp.len() {
                            let (s2, p2) = tmp.module(j);
                            sys.expand(
                                &sys.decomposition,
                                "decomposition",
                                s2,
                                p2,
                                0,
                                out,
                                ev,
                                &mut scratch,
                            )?;
                        }
                    } else {
                        sys.emit(p, locals, out, ev, &mut args)?;
                    }
                }
            }
            if whole && raw_owner.len() < out.len() {
                let more = out.len() - raw_owner.len();
                try_room(&mut raw_owner, more, out.len()).map_err(|e| oom(e, ev))?;
                raw_owner.resize(out.len(), owner.get(i).copied().unwrap_or(0));
            }
            self.check_step_size(out, opts, step)?;
        }
        if whole {
            let raw = std::mem::take(out);
            *out = ModuleString::try_with_capacity(raw.len(), raw.params.len()).map_err(|e| oom(e, ev))?;
            let mut a = 0;
            while a < raw.len() {
                let k = raw_owner.get(a).copied().unwrap_or(0);
                let mut b = a + 1;
                while b < raw.len() && raw_owner.get(b).copied().unwrap_or(0) == k {
                    b += 1;
                }
                let sys = if k > 0 { &self.subsystems[k as usize - 1].lsystem } else { self };
                sys.expand_run(&sys.decomposition, "decomposition", &raw, a..b, out, ev, &mut scratch)?;
                self.check_step_size(out, opts, step)?;
                a = b;
            }
        }
        ev.charge(MODULE_WORK.saturating_mul(out.len() as u64), 0)
            .map_err(|e| self.eval_error(e, &format!("writing step {step}"), None))?;
        Ok(())
    }

    /// A step's string against the module budget `opts.budget` and its parameter budget.
    fn check_step_size(
        &self,
        out: &ModuleString,
        opts: &DeriveOptions,
        step: u32,
    ) -> Result<(), Box<LsystemError>> {
        if out.syms.len() > opts.budget {
            return Err(self.budget_error(step, opts, out.syms.len()));
        }
        let params_limit = param_budget(opts.budget);
        if out.params.len() > params_limit {
            let e = self.source.error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "derivation step {step} of {} exceeds the module budget: more than {params_limit} \
                     parameters ({PARAMS_PER_MODULE} per module of generator.max_modules = {}; reached {})",
                    opts.steps,
                    opts.budget,
                    out.params.len()
                ),
            );
            return Err(
                e.with_help("derive fewer steps (-n) or raise the limit with --set generator.max_modules=N")
            );
        }
        Ok(())
    }

    /// For every module of `m`, which L-system rewrites it: 0 for this one, k for
    /// `self.subsystems[k - 1]`. Empty when there are no sub-L-systems. A `?(n, s)`
    /// module belongs to the L-system around it and opens sub-L-system n; the `$` that
    /// closes it belongs to the sub-L-system. A `$` with no sub-L-system open is the
    /// turtle's roll-to-horizontal and belongs to whatever is around it.
    pub fn owners(&self, m: &ModuleString) -> Result<Vec<u16>, Box<LsystemError>> {
        self.owners_in(m, None)
    }

    /// [`LSystem::owners`]; a failed allocation names the budget of `ev`.
    fn owners_in(&self, m: &ModuleString, ev: Option<&Evaluator>) -> Result<Vec<u16>, Box<LsystemError>> {
        if self.subsystems.is_empty() {
            return Ok(Vec::new());
        }
        let (call, end) = (self.symbols.get("?"), self.symbols.get("$"));
        let mut stack: Vec<u16> = Vec::new();
        let mut out = Vec::new();
        let oom = |e| match ev {
            Some(ev) => self.memory_error(e, ev, "the derived string"),
            None => self.memory_error(e, &Evaluator::new(0), "the derived string"),
        };
        try_room(&mut out, m.len(), m.len()).map_err(oom)?;
        for i in 0..m.len() {
            let (sym, params) = m.module(i);
            out.push(stack.last().copied().unwrap_or(0));
            if Some(sym) == call && !params.is_empty() {
                let n = params[0];
                let Some(k) = self.subsystems.iter().position(|s| s.number as f64 == n) else {
                    let have: Vec<String> = self.subsystems.iter().map(|s| s.number.to_string()).collect();
                    return Err(self.source.error_nowhere(
                        ErrorKind::UndefinedName,
                        &format!(
                            "module {i} of the derived string, `?({n}, …)`, calls sub-L-system {n}, \
                             but the file's sub-L-systems are {}",
                            if have.is_empty() { "none".to_string() } else { have.join(", ") }
                        ),
                    ));
                };
                try_room(&mut stack, 1, m.len()).map_err(oom)?;
                stack.push(k as u16 + 1);
            } else if Some(sym) == end && !stack.is_empty() {
                stack.pop();
            }
        }
        Ok(out)
    }

    /// Upper bound of the next string's length (before decomposition).
    fn growth_bound(&self, cur: &ModuleString) -> usize {
        let longest: Vec<usize> = self
            .by_symbol
            .iter()
            .map(|ps| ps.iter().map(|&k| self.productions[k as usize].succ.len()).max().unwrap_or(1))
            .collect();
        cur.syms.iter().map(|&s| longest[s as usize]).sum()
    }

    /// The production of `list` to apply to a module, if any: its index and whether its
    /// locals are in `buf` (true) or are the module's parameters in place (false).
    fn select(
        &self,
        list: &[Production],
        prods: &[u32],
        params: &[f64],
        site: Site,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
    ) -> Result<Option<(usize, bool)>, Box<LsystemError>> {
        for (n, &k) in prods.iter().enumerate() {
            let p = &list[k as usize];
            let Some(uses_buf) = self.try_match(p, params, site, ev, buf)? else { continue };
            if p.prob.is_none() {
                return Ok(Some((k as usize, uses_buf)));
            }
            // Stochastic: weigh every matching stochastic production of this module.
            let mut cands: Vec<(usize, f64)> = Vec::new();
            let mut total = 0.0;
            for (m, &k2) in prods.iter().enumerate().skip(n) {
                let q = &list[k2 as usize];
                if m > n && self.try_match(q, params, site, ev, buf)?.is_none() {
                    continue;
                }
                let Some(pe) = &q.prob else { continue };
                let locals: &[f64] = if q.needs_buffer() { buf } else { params };
                let w = ev
                    .eval(pe, locals)
                    .map_err(|e| self.eval_error(e, "evaluating the probability", Some((q, params))))?;
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
                cands.push((k2 as usize, w));
            }
            if total <= 0.0 {
                return Ok(None);
            }
            let mut x = ev.uniform() * total;
            let mut pick = cands[cands.len() - 1].0;
            for &(k2, w) in &cands {
                if x < w {
                    pick = k2;
                    break;
                }
                x -= w;
            }
            let q = &list[pick];
            // Re-bind the chosen production's locals (its statements run again).
            let uses_buf = self.try_match(q, params, site, ev, buf)?.unwrap_or(false);
            return Ok(Some((pick, uses_buf)));
        }
        Ok(None)
    }

    /// Tests one production; `Some(uses_buf)` when it applies.
    #[inline]
    fn try_match(
        &self,
        p: &Production,
        params: &[f64],
        site: Site,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
    ) -> Result<Option<bool>, Box<LsystemError>> {
        if p.arity != params.len() {
            return Ok(None);
        }
        if !p.needs_buffer() {
            if let Some(c) = &p.cond {
                let v = ev
                    .eval(c, params)
                    .map_err(|e| self.eval_error(e, "evaluating the condition", Some((p, params))))?;
                if v == 0.0 {
                    return Ok(None);
                }
            }
            return Ok(Some(false));
        }
        buf.clear();
        buf.extend_from_slice(params);
        if !p.left.is_empty() || !p.right.is_empty() || !p.rest.is_empty() {
            let Some((cur, i, brackets)) = site else { return Ok(None) };
            for (k, &(sym, ar)) in p.rest.iter().enumerate() {
                let j = i + 1 + k;
                if j >= cur.len() {
                    return Ok(None);
                }
                let (s, q) = cur.module(j);
                if s != sym || q.len() != ar {
                    return Ok(None);
                }
                buf.extend_from_slice(q);
            }
            let mut scanned = 0u64;
            let left_ok = p.left.is_empty() || self.match_left(&p.left, i, cur, brackets, buf, &mut scanned);
            let after = i + 1 + p.rest.len();
            let ok = left_ok
                && (p.right.is_empty()
                    || self.match_right(&p.right, 0, after, cur, brackets, buf, &mut scanned));
            ev.charge(scanned, p.at)
                .map_err(|e| self.eval_error(e, "matching the context", Some((p, params))))?;
            if !ok {
                return Ok(None);
            }
        }
        if let Some(pre) = &p.pre {
            ev.exec(pre, buf).map_err(|e| self.eval_error(e, "running the statements", Some((p, params))))?;
        }
        if let Some(c) = &p.cond {
            let v = ev
                .eval(c, buf)
                .map_err(|e| self.eval_error(e, "evaluating the condition", Some((p, params))))?;
            if v == 0.0 {
                return Ok(None);
            }
        }
        if let Some(post) = &p.post {
            ev.exec(post, buf)
                .map_err(|e| self.eval_error(e, "running the statements", Some((p, params))))?;
        }
        Ok(Some(true))
    }

    /// Left context (ABOP §1.8): scanning left, `[` steps out of the branch, a complete
    /// branch `[...]` is skipped, ignored modules are skipped. Binds parameters in
    /// string order.
    fn match_left(
        &self,
        left: &[(u16, usize)],
        i: usize,
        cur: &ModuleString,
        brackets: &[u32],
        buf: &mut Vec<f64>,
        scanned: &mut u64,
    ) -> bool {
        let open = self.symbols.get("[");
        let close = self.symbols.get("]");
        let mut pos = i as isize - 1;
        let mut found = [0usize; 16];
        if left.len() > found.len() {
            return false;
        }
        let mut wrapped = false;
        for (k, &(sym, ar)) in left.iter().enumerate().rev() {
            loop {
                *scanned += 1;
                if pos < 0 {
                    // A ring L-system's string is circular: wrap once, never onto i.
                    if !self.ring || wrapped {
                        return false;
                    }
                    wrapped = true;
                    pos = cur.len() as isize - 1;
                }
                if wrapped && pos as usize <= i {
                    return false;
                }
                let s = cur.syms[pos as usize];
                if Some(s) == open {
                    pos -= 1;
                } else if Some(s) == close {
                    pos = brackets[pos as usize] as isize - 1;
                } else if self.context_skip.get(s as usize).copied().unwrap_or(false) {
                    pos -= 1;
                } else {
                    break;
                }
            }
            let (s, p) = cur.module(pos as usize);
            if s != sym || p.len() != ar {
                return false;
            }
            found[k] = pos as usize;
            pos -= 1;
        }
        for &f in &found[..left.len()] {
            buf.extend_from_slice(cur.module(f).1);
        }
        true
    }

    /// Right context (ABOP §1.8): scanning right, branches not named by the context are
    /// skipped, the end of the current branch stops the match; a `[` in the context
    /// descends into a following branch (any sibling may match) and a `]` in the context
    /// continues after the end of the current branch.
    #[allow(clippy::too_many_arguments)]
    fn match_right(
        &self,
        ctx: &[ContextItem],
        k: usize,
        pos: usize,
        cur: &ModuleString,
        brackets: &[u32],
        buf: &mut Vec<f64>,
        scanned: &mut u64,
    ) -> bool {
        if k == ctx.len() {
            return true;
        }
        let open = self.symbols.get("[");
        let close = self.symbols.get("]");
        let n = cur.len();
        let skip = |s: u16| self.context_skip.get(s as usize).copied().unwrap_or(false);
        match ctx[k] {
            ContextItem::Open => {
                let mut p = pos;
                loop {
                    while p < n && skip(cur.syms[p]) {
                        p += 1;
                        *scanned += 1;
                    }
                    *scanned += 1;
                    if p >= n || Some(cur.syms[p]) != open {
                        return false;
                    }
                    let mark = buf.len();
                    if self.match_right(ctx, k + 1, p + 1, cur, brackets, buf, scanned) {
                        return true;
                    }
                    buf.truncate(mark);
                    p = brackets[p] as usize + 1;
                }
            }
            ContextItem::Close => {
                let mut p = pos;
                while p < n {
                    *scanned += 1;
                    let s = cur.syms[p];
                    if Some(s) == open {
                        p = brackets[p] as usize + 1;
                    } else if Some(s) == close {
                        return self.match_right(ctx, k + 1, p + 1, cur, brackets, buf, scanned);
                    } else {
                        p += 1;
                    }
                }
                false
            }
            ContextItem::Module(sym, ar) => {
                let mut p = pos;
                let mut wrapped = false;
                loop {
                    *scanned += 1;
                    if p >= n {
                        // A ring L-system's string is circular: the first context module
                        // may wrap around once, never onto the predecessor.
                        if self.ring && k == 0 && !wrapped && pos > 0 {
                            wrapped = true;
                            p = 0;
                            continue;
                        }
                        return false;
                    }
                    if wrapped && p + 1 >= pos {
                        return false;
                    }
                    let s = cur.syms[p];
                    if Some(s) == open {
                        p = brackets[p] as usize + 1;
                    } else if Some(s) == close {
                        return false;
                    } else if skip(s) {
                        p += 1;
                    } else {
                        break;
                    }
                }
                let (s, params) = cur.module(p);
                if s != sym || params.len() != ar {
                    return false;
                }
                let mark = buf.len();
                buf.extend_from_slice(params);
                if self.match_right(ctx, k + 1, p + 1, cur, brackets, buf, scanned) {
                    return true;
                }
                buf.truncate(mark);
                false
            }
        }
    }

    /// Writes the successor of `p` with the given locals.
    #[inline]
    fn emit(
        &self,
        p: &Production,
        locals: &[f64],
        out: &mut ModuleString,
        ev: &mut Evaluator,
        args: &mut Vec<f64>,
    ) -> Result<(), Box<LsystemError>> {
        for m in &p.succ {
            if m.args.is_empty() {
                out.try_push(m.sym, &[]).map_err(|e| self.memory_error(e, ev, "the derived string"))?;
                continue;
            }
            args.clear();
            for a in &m.args {
                match ev.eval(a, locals) {
                    Ok(v) => args.push(v),
                    Err(e) => {
                        return Err(self.successor_error(e, p, m, &locals[..p.arity.min(locals.len())]))
                    }
                }
            }
            out.try_push(m.sym, args).map_err(|e| self.memory_error(e, ev, "the derived string"))?;
        }
        Ok(())
    }

    /// Writes a module rewritten by `rules` recursively (decomposition, homomorphism);
    /// `depth` is the module's depth (0 for a module of the derived string). The
    /// modules of each successor are rewritten in turn, and a multi-module predecessor
    /// matches consecutive modules of one successor; a string of several modules at
    /// depth 0 goes through [`LSystem::expand_run`] instead.
    #[allow(clippy::too_many_arguments)]
    fn expand(
        &self,
        rules: &RuleSet,
        what: &str,
        sym: u16,
        params: &[f64],
        depth: u32,
        out: &mut ModuleString,
        ev: &mut Evaluator,
        scratch: &mut Vec<f64>,
    ) -> Result<(), Box<LsystemError>> {
        if rules.by_symbol.get(sym as usize).is_none_or(|p| p.is_empty()) {
            out.try_push(sym, params).map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
            return self.charge_expanded(what, ev, out);
        }
        let mut pending = Pending::new();
        pending.push(sym, params, depth, 0).map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
        self.drain(rules, what, &mut pending, out, ev, scratch)
    }

    /// Writes the modules `range` of `src` rewritten by `rules` as one string
    /// (decomposition, homomorphism): left to right, the production chosen for a module
    /// (its predecessor may span it and the modules after it, within `range`) replaces
    /// the modules it matches by its successor, which is rewritten the same way as a
    /// string of its own (depth first, one level deeper, up to the maximum depth) before
    /// the scan goes on after the matched modules. A multi-module predecessor therefore
    /// matches consecutive modules of `range` or of one successor, never across the end
    /// of either. Modules no production matches are written as they are.
    #[allow(clippy::too_many_arguments)]
    fn expand_run(
        &self,
        rules: &RuleSet,
        what: &str,
        src: &ModuleString,
        range: std::ops::Range<usize>,
        out: &mut ModuleString,
        ev: &mut Evaluator,
        scratch: &mut Vec<f64>,
    ) -> Result<(), Box<LsystemError>> {
        let mut pending = Pending::new();
        let mut look = ModuleString::new();
        let mut buf = Vec::new();
        let mut tmp = ModuleString::new();
        let end = range.end.min(src.len());
        let mut i = range.start;
        while i < end {
            let (sym, params) = src.module(i);
            let prods = match rules.by_symbol.get(sym as usize) {
                Some(p) if !p.is_empty() => p,
                _ => {
                    out.try_push(sym, params)
                        .map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
                    self.charge_expanded(what, ev, out)?;
                    i += 1;
                    continue;
                }
            };
            clear_string(&mut look);
            for j in i..(i + 1 + rules.lookahead).min(end) {
                let (s2, p2) = src.module(j);
                look.push(s2, p2);
            }
            let Some((k, uses_buf)) =
                self.choose(rules, what, prods, sym, params, Some(&look), 0, ev, &mut buf)?
            else {
                out.try_push(sym, params).map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
                self.charge_expanded(what, ev, out)?;
                i += 1;
                continue;
            };
            let p = &rules.productions[k];
            i += 1 + p.rest.len();
            let locals: &[f64] = if uses_buf { &buf } else { params };
            clear_string(&mut tmp);
            self.emit(p, locals, &mut tmp, ev, scratch)?;
            pending.push_successor(&tmp, 1).map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
            self.check_pending(what, &pending, ev)?;
            self.drain(rules, what, &mut pending, out, ev, scratch)?;
        }
        Ok(())
    }

    /// Rewrites the modules of `pending` until none is left, writing the results to
    /// `out` (see [`LSystem::expand`] and [`LSystem::expand_run`]). Depth first with an
    /// explicit stack: `maximum depth: 10000` must not overflow the thread's stack.
    fn drain(
        &self,
        rules: &RuleSet,
        what: &str,
        pending: &mut Pending,
        out: &mut ModuleString,
        ev: &mut Evaluator,
        scratch: &mut Vec<f64>,
    ) -> Result<(), Box<LsystemError>> {
        let mut cur: Vec<f64> = Vec::new();
        let mut buf = Vec::new();
        let mut tmp = ModuleString::new();
        let mut look = ModuleString::new();
        while let Some((sym, depth, group)) = pending.pop(&mut cur) {
            let prods = match rules.by_symbol.get(sym as usize) {
                Some(p) if !p.is_empty() => p,
                _ => {
                    out.try_push(sym, &cur).map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
                    self.charge_expanded(what, ev, out)?;
                    continue;
                }
            };
            // For multi-module predecessors: the module and the modules after it in its
            // successor (those below it on the stack with its group).
            let site = if rules.lookahead > 0 {
                clear_string(&mut look);
                look.push(sym, &cur);
                let n = pending.depths.len();
                for j in (n.saturating_sub(rules.lookahead)..n).rev() {
                    if pending.groups[j] != group {
                        break;
                    }
                    let (s2, p2) = pending.modules.module(j);
                    look.push(s2, p2);
                }
                Some(&look)
            } else {
                None
            };
            let Some((k, uses_buf)) =
                self.choose(rules, what, prods, sym, &cur, site, depth, ev, &mut buf)?
            else {
                out.try_push(sym, &cur).map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
                self.charge_expanded(what, ev, out)?;
                continue;
            };
            let p = &rules.productions[k];
            // The further modules of a multi-module predecessor are consumed too (their
            // parameters are in `buf`).
            for _ in 0..p.rest.len() {
                pending.drop_top();
            }
            let locals: &[f64] = if uses_buf { &buf } else { &cur };
            clear_string(&mut tmp);
            self.emit(p, locals, &mut tmp, ev, scratch)?;
            pending
                .push_successor(&tmp, depth + 1)
                .map_err(|e| self.memory_error(e, ev, &format!("the {what}")))?;
            self.check_pending(what, pending, ev)?;
        }
        Ok(())
    }

    /// The production of `rules` (`prods`: those of `sym`) that rewrites the module
    /// `sym(params)` at `depth`, as [`LSystem::select`] gives it; `look` is the module
    /// followed by the modules after it in its string, for multi-module predecessors
    /// (`None` when `rules` has none). At the maximum depth none applies, and one that
    /// would is an error when the file gave `maximum depth:`.
    #[allow(clippy::too_many_arguments)]
    fn choose(
        &self,
        rules: &RuleSet,
        what: &str,
        prods: &[u32],
        sym: u16,
        params: &[f64],
        look: Option<&ModuleString>,
        depth: u32,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
    ) -> Result<Option<(usize, bool)>, Box<LsystemError>> {
        const NO_BRACKETS: &[u32] = &[];
        ev.charge(MODULE_WORK, 0).map_err(|e| self.eval_error(e, &format!("applying the {what}"), None))?;
        let site = look.map(|l| (l, 0, NO_BRACKETS));
        let Some((k, uses_buf)) = self.select(&rules.productions, prods, params, site, ev, buf)? else {
            return Ok(None);
        };
        if depth >= rules.max_depth {
            if rules.depth_explicit {
                let p = &rules.productions[k];
                return Err(self.source.error(
                    ErrorKind::OutOfRange,
                    p.at as usize,
                    p.len as usize,
                    &format!(
                        "module {} still has a {what} production at the maximum depth {} (line {})",
                        self.format_module(sym, params),
                        rules.max_depth,
                        p.line
                    ),
                    "applies past the maximum depth",
                ));
            }
            return Ok(None);
        }
        Ok(Some((k, uses_buf)))
    }

    /// The pending modules of a decomposition or homomorphism against the module and
    /// parameter budgets.
    fn check_pending(&self, what: &str, pending: &Pending, ev: &Evaluator) -> Result<(), Box<LsystemError>> {
        let m = &pending.modules;
        if m.params.len() > param_budget(ev.module_limit) || m.len() > ev.module_limit {
            return Err(self.size_error(
                ev,
                &format!("the {what}"),
                m.len(),
                "pending modules",
                ev.module_limit,
            ));
        }
        Ok(())
    }

    /// After `expand` wrote a module: the module and parameter budgets, checked while
    /// a decomposition or homomorphism writes, so a recursive rule cannot run away
    /// inside one module.
    #[inline]
    fn charge_expanded(
        &self,
        what: &str,
        ev: &mut Evaluator,
        out: &ModuleString,
    ) -> Result<(), Box<LsystemError>> {
        if out.syms.len() > ev.module_limit || out.params.len() > param_budget(ev.module_limit) {
            let (len, unit, limit) = if out.syms.len() > ev.module_limit {
                (out.syms.len(), "modules", ev.module_limit)
            } else {
                (out.params.len(), "parameters", param_budget(ev.module_limit))
            };
            return Err(self.size_error(ev, &format!("the {what}"), len, unit, limit));
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
        let what = error_words(e.kind);
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
        prod: Option<(&Production, &[f64])>,
    ) -> Box<LsystemError> {
        let what = error_words(e.kind);
        let context = match prod {
            Some((p, params)) => format!(
                " of the production of line {} for {}",
                p.line,
                self.format_module(p.pred, &params[..p.arity.min(params.len())])
            ),
            None => String::new(),
        };
        if e.kind == ErrorKind::Budget && e.at == 0 && prod.is_none() {
            // Work charged for the string as a whole has no place in the file.
            return self.source.error_nowhere(e.kind, &format!("{what} while {doing}{context}"));
        }
        self.source.error(e.kind, e.at as usize, 1, &format!("{what} while {doing}{context}"), what)
    }

    fn budget_error(&self, step: u32, opts: &DeriveOptions, len: usize) -> Box<LsystemError> {
        let e = self.source.error_nowhere(
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
        ev: &mut Evaluator,
        budget: usize,
    ) -> Result<std::borrow::Cow<'m, ModuleString>, Box<LsystemError>> {
        let empty = |l: &LSystem| l.homomorphism.productions.is_empty();
        if empty(self) && self.subsystems.iter().all(|s| empty(&s.lsystem)) {
            return Ok(std::borrow::Cow::Borrowed(m));
        }
        check_module_budget(budget).map_err(|m| {
            self.source.error_nowhere(ErrorKind::Budget, &format!("`generator.max_modules` {m}"))
        })?;
        let owner = self.owners_in(m, Some(ev))?;
        let mut out =
            ModuleString::try_with_capacity(m.len().min(budget), m.params.len().min(param_budget(budget)))
                .map_err(|e| self.memory_error(e, ev, "the homomorphism"))?;
        let mut scratch = Vec::new();
        // The homomorphism has a work budget of its own, as large as the derivation's.
        let saved = (ev.module_limit, ev.work_limit);
        ev.module_limit = budget;
        ev.work_limit = ev.work.saturating_add(work_budget(budget));
        let r = self.interpret_into(m, ev, budget, &owner, &mut out, &mut scratch);
        (ev.module_limit, ev.work_limit) = saved;
        r?;
        Ok(std::borrow::Cow::Owned(out))
    }

    #[allow(clippy::too_many_arguments)]
    fn interpret_into(
        &self,
        m: &ModuleString,
        ev: &mut Evaluator,
        budget: usize,
        owner: &[u16],
        out: &mut ModuleString,
        scratch: &mut Vec<f64>,
    ) -> Result<(), Box<LsystemError>> {
        let sys_of = |k: u16| if k > 0 { &self.subsystems[k as usize - 1].lsystem } else { self };
        // With multi-module predecessors each run of modules one L-system interprets is
        // rewritten as a whole string.
        let whole = self.homomorphism.lookahead > 0
            || self.subsystems.iter().any(|s| s.lsystem.homomorphism.lookahead > 0);
        let mut i = 0;
        while i < m.len() {
            let k = owner.get(i).copied().unwrap_or(0);
            let sys = sys_of(k);
            let r = if whole {
                let mut b = i + 1;
                while b < m.len() && owner.get(b).copied().unwrap_or(0) == k {
                    b += 1;
                }
                let r = sys.expand_run(&sys.homomorphism, "homomorphism", m, i..b, out, ev, scratch);
                i = b;
                r
            } else {
                let (sym, params) = m.module(i);
                i += 1;
                sys.expand(&sys.homomorphism, "homomorphism", sym, params, 0, out, ev, scratch)
            };
            r.map_err(|e| self.work_note(e, &DeriveOptions { steps: 0, budget, seed: 0 }))?;
            if out.len() > budget {
                let e = self.source.error_nowhere(
                    ErrorKind::Budget,
                    &format!("the homomorphism makes more than {budget} modules"),
                );
                return Err(e.with_help("raise the limit with --set generator.max_modules=N"));
            }
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

    /// Writes the whole string as text, as [`LSystem::format`] makes it, in pieces of
    /// about 64 KiB: a string of hundreds of millions of modules is printed without
    /// its text ever being held whole in memory (issue 39).
    pub fn write_to(&self, m: &ModuleString, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let mut s = String::with_capacity(1 << 16);
        for i in 0..m.len() {
            let (sym, params) = m.module(i);
            self.write_module(&mut s, sym, params);
            if s.len() >= (1 << 16) - 256 {
                w.write_all(s.as_bytes())?;
                s.clear();
            }
        }
        w.write_all(s.as_bytes())
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

    /// A main L-system calling sub-L-system 2 (scale 0.5); both have rules for `B` and
    /// `A`, and each applies only to its own modules.
    const SUBS: &str = "Lsystem: 1\nderivation length: 2\nAxiom: A\nA --> F?(2,0.5)B$A\nB --> Z\n\
                        endlsystem\n\nLsystem: 2\nAxiom: B\nB --> BC\nA --> X\nhomomorphism\nC --> F\n\
                        endlsystem\n";

    #[test]
    fn sub_lsystems_rewrite_their_own_segments() {
        let (ls, m) = derive(SUBS, 2);
        assert_eq!(ls.subsystems.len(), 1);
        assert_eq!(ls.subsystems[0].number, 2);
        assert_eq!(ls.format(&m), "F?(2,0.5)BC$F?(2,0.5)B$A");
        // The sub-L-system's homomorphism applies inside its segments only.
        let mut ev = Evaluator::new(0);
        let shown = ls.interpretation(&m, &mut ev, 1000).unwrap();
        assert_eq!(ls.format(&shown), "F?(2,0.5)BF$F?(2,0.5)B$A");
        // The turtle: `?(2, 0.5)` saves the state and halves lengths until `$`.
        let sk = crate::lsystem::interpret(&ls.symbols, &shown, &Default::default(), &ls.source).unwrap();
        let top = sk.position.iter().map(|p| p.y).fold(f32::MIN, f32::max);
        assert_eq!(top, 2.0, "the sub-L-system's F is half a step and does not move the main axis");
        assert!((sk.stats().total_length - 2.5).abs() < 1e-5);
    }

    #[test]
    fn sub_lsystem_errors() {
        let bad = SUBS.replace("?(2,0.5)", "?(7,0.5)");
        let ls = LSystem::parse("t.l", &bad, &[]).unwrap();
        let e = ls.derive(&DeriveOptions { steps: 2, budget: 1000, seed: 0 }).unwrap_err();
        assert!(e.message.contains("calls sub-L-system 7") && e.message.contains("are 2"), "{}", e.message);
        let twice = SUBS.replace("Lsystem: 2", "Lsystem: 1");
        let e = LSystem::parse("t.l", &twice, &[]).unwrap_err();
        assert!(e.message.contains("two `Lsystem: 1` blocks"), "{}", e.message);
    }

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
        let i = ls.interpretation(&m, &mut Evaluator::new(1), 100).unwrap();
        assert_eq!(ls.format(&i), "F(1)[F(0.5)]F(0.5)");
        // Depth 3: a -> bb -> cccc -> FFFF.
        let t =
            "Lsystem: 1\nAxiom: a\nhomomorphism\nmaximum depth: 3\na --> bb\nb --> cc\nc --> F\nendlsystem\n";
        let (ls, m) = derive(t, 0);
        assert_eq!(ls.format(&ls.interpretation(&m, &mut Evaluator::new(1), 100).unwrap()), "FFFF");
        // Depth 2 is too shallow: an error naming the module.
        let (ls, m) = derive(&t.replace("depth: 3", "depth: 2"), 0);
        let e = ls.interpretation(&m, &mut Evaluator::new(1), 100).unwrap_err();
        assert!(
            e.message.contains("module c still has a homomorphism production at the maximum depth 2"),
            "{}",
            e.message
        );
        // Without `maximum depth:` the homomorphism is a single substitution.
        let t = "Lsystem: 1\nAxiom: a\nhomomorphism\na --> aa\nendlsystem\n";
        let (ls, m) = derive(t, 0);
        assert_eq!(ls.format(&ls.interpretation(&m, &mut Evaluator::new(1), 100).unwrap()), "aa");
    }

    #[test]
    fn decomposition_depth_three() {
        // Decomposition runs on the axiom and after every step, recursively.
        let t = "Lsystem: 1\nAxiom: A\nA --> B\ndecomposition\nmaximum depth: 3\nA --> X[Y]\nB --> CC\nC --> DE\nD --> G\nendlsystem\n";
        let (ls, m) = derive(t, 0);
        assert_eq!(ls.format(&m), "X[Y]");
        let (ls, m) = derive(t, 1);
        assert_eq!(ls.format(&m), "X[Y]");
        let t2 = t.replace("Axiom: A", "Axiom: B");
        let (ls, m) = derive(&t2, 0);
        assert_eq!(ls.format(&m), "GEGE");
        let t3 = t2.replace("depth: 3", "depth: 2");
        let ls = LSystem::parse("t.l", &t3, &[]).unwrap();
        let e = ls.derive(&DeriveOptions { steps: 0, budget: 100, seed: 1 }).unwrap_err();
        assert!(e.message.contains("module D still has a decomposition production"), "{}", e.message);
    }

    #[test]
    fn multi_module_predecessors() {
        let t = "Lsystem: 1\nAxiom: A(1)B(2)A(3)C\nA(x)B(y) --> D(x+y)\nendlsystem\n";
        let (ls, m) = derive(t, 1);
        assert_eq!(ls.format(&m), "D(3)A(3)C");
    }

    #[test]
    fn empty_successor() {
        let (ls, m) = derive("Lsystem: 1\nAxiom: A B A\nA --> *\nendlsystem\n", 1);
        assert_eq!(ls.format(&m), "B");
    }
}
