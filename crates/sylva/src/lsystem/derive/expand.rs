//! Decomposition and homomorphism (Mech2004, McLoughlin2021 §2): a module rewritten
//! recursively up to `maximum depth`, depth first with an explicit stack, multi-module
//! predecessors matched within one string or successor; and the homomorphism that makes
//! the string the turtle reads.

use super::{check_module_budget, param_budget, work_budget, DeriveOptions, MODULE_WORK};
use crate::lsystem::expr::Evaluator;
use crate::lsystem::parse::{LSystem, RuleSet};
use crate::lsystem::source::{ErrorKind, LsystemError};
use crate::lsystem::string::{try_room, ModuleString, OutOfMemory};

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
    /// Writes a module rewritten by `rules` recursively (decomposition, homomorphism);
    /// `depth` is the module's depth (0 for a module of the derived string). The
    /// modules of each successor are rewritten in turn, and a multi-module predecessor
    /// matches consecutive modules of one successor; a string of several modules at
    /// depth 0 goes through [`LSystem::expand_run`] instead.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn expand(
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
    pub(super) fn expand_run(
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
}
