//! One parallel rewriting step (McLoughlin2021 §2, ABOP ch. 1): each module rewritten
//! by the first matching production of the L-system that owns it (this one or a
//! sub-L-system), cpfg's cut `%`, and decomposition of what each step writes; with the
//! bracket partners that context matching needs.

use super::{param_budget, DeriveOptions, MODULE_WORK};
use crate::lsystem::expr::Evaluator;
use crate::lsystem::parse::{LSystem, NO_BASE};
use crate::lsystem::source::{ErrorKind, LsystemError};
use crate::lsystem::string::{try_room, ModuleString, OutOfMemory};

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

impl LSystem {
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
        // cpfg's generator in a stochastic L-system (one with a `seed:` line): every
        // module of cpfg's string (one per character of a sylva module's name: `@o` is
        // `@` and `o` in cpfg) draws once from the choice stream, whether or not a
        // production applies; the draws of `@`, `~` and `?` before the module's letter come
        // first.
        let cpfg_chars: Vec<u8> = if ev.rng.is_cpfg() {
            (0..self.symbols.len())
                .map(|s| self.symbols.name(s as u16).chars().count().clamp(1, 255) as u8)
                .collect()
        } else {
            Vec::new()
        };
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
            let cpfg_draws =
                if sys.cpfg_seed.is_some() { cpfg_chars.get(sym as usize).copied() } else { None };
            if let Some(n) = cpfg_draws {
                for _ in 1..n {
                    ev.uniform();
                }
            }
            if Some(sym) == cut && sys.by_symbol[sym as usize].is_empty() {
                if cpfg_draws.is_some() {
                    ev.uniform();
                }
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
                sys.select_rewrite(&sys.productions, prods, params, Some((cur, i, &brackets)), ev, &mut buf)?
            };
            let base = sys.prefix_base.get(sym as usize).copied().unwrap_or(NO_BASE);
            let based = chosen.is_none() && base != NO_BASE;
            if cpfg_draws.is_some() && prods.is_empty() && !based {
                // cpfg draws for a module without productions too.
                ev.uniform();
            }
            if based {
                // cpfg keeps `@`/`~` as symbols of their own: X's productions rewrite the X
                // of `@X(…)`, and the prefix stays before the successor (issue 46 item 4).
                let bprods = &sys.by_symbol[base as usize];
                let site = Some((cur, i, &brackets[..]));
                if let Some((k, uses_buf)) =
                    sys.select_rewrite(&sys.productions, bprods, params, site, ev, &mut buf)?
                {
                    let p = &sys.productions[k];
                    if p.rest.is_empty() {
                        let locals = if uses_buf { &buf[..] } else { params };
                        tmp.syms.clear();
                        tmp.params.clear();
                        tmp.pofs.clear();
                        tmp.pofs.push(0);
                        sys.emit(p, locals, &mut tmp, ev, &mut args)?;
                        let lead = tmp.syms.first().and_then(|&y| self.prefixed_lead(sym, y));
                        let Some(lead) = lead else {
                            let name = self.symbols.name(sym);
                            return Err(self.source.error(
                                ErrorKind::Unsupported,
                                p.at as usize,
                                p.len as usize,
                                &format!(
                                    "unsupported: this production rewrites the `{}` of `{name}` (cpfg keeps `{}` \
                                     as a module of its own), and its successor does not start with a letter or \
                                     digit that `{}` can prefix",
                                    &name[1..],
                                    &name[..1],
                                    &name[..1]
                                ),
                                "production",
                            ));
                        };
                        tmp.syms[0] = lead;
                        for j in 0..tmp.len() {
                            let (s2, p2) = tmp.module(j);
                            if decompose {
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
                            } else {
                                out.try_push(s2, p2).map_err(|e| oom(e, ev))?;
                            }
                        }
                        if whole && raw_owner.len() < out.len() {
                            let more = out.len() - raw_owner.len();
                            try_room(&mut raw_owner, more, out.len()).map_err(|e| oom(e, ev))?;
                            raw_owner.resize(out.len(), owner.get(i).copied().unwrap_or(0));
                        }
                        self.check_step_size(out, opts, step)?;
                        continue;
                    }
                }
            }
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

    /// For every module of `m`, which L-system rewrites it: 0 for this one, k for
    /// `self.subsystems[k - 1]`. Empty when there are no sub-L-systems. A `?(n, s)`
    /// module belongs to the L-system around it and opens sub-L-system n; the `$` that
    /// closes it belongs to the sub-L-system. A `$` with no sub-L-system open is the
    /// turtle's roll-to-horizontal and belongs to whatever is around it.
    pub fn owners(&self, m: &ModuleString) -> Result<Vec<u16>, Box<LsystemError>> {
        self.owners_in(m, None)
    }

    /// [`LSystem::owners`]; a failed allocation names the budget of `ev`.
    pub(super) fn owners_in(
        &self,
        m: &ModuleString,
        ev: Option<&Evaluator>,
    ) -> Result<Vec<u16>, Box<LsystemError>> {
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
}
