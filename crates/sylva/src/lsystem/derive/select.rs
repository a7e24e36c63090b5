//! Choosing the production that rewrites a module: arity, conditions and statement
//! blocks, left and right contexts with branch skipping (ABOP §1.8), ring L-systems, and
//! stochastic choice weighted by the probabilities (ABOP §1.7); then writing its
//! successor (McLoughlin2021 §2, Mech2004).

use crate::lsystem::expr::Evaluator;
use crate::lsystem::parse::{ContextItem, LSystem, Production};
use crate::lsystem::source::{ErrorKind, LsystemError};
use crate::lsystem::string::ModuleString;

/// Where a production is being matched: the whole current string, the module's index
/// and the bracket partners (for contexts). `None` for decomposition and homomorphism.
type Site<'a> = Option<(&'a ModuleString, usize, &'a [u32])>;

impl LSystem {
    /// The production of `list` that rewrites a module in a derivation step, as
    /// [`LSystem::select`] chooses it, except with cpfg's generator: an L-system with a
    /// `seed:` line then chooses as cpfg does ([`LSystem::select_cpfg`], one draw of the
    /// choice stream whatever matched), one without chooses the first match (cpfg
    /// ignores probabilities there).
    pub(super) fn select_rewrite(
        &self,
        list: &[Production],
        prods: &[u32],
        params: &[f64],
        site: Site,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
    ) -> Result<Option<(usize, bool)>, Box<LsystemError>> {
        if ev.rng.is_cpfg() && self.cpfg_seed.is_some() {
            return self.select_cpfg(list, prods, params, site, ev, buf);
        }
        self.select(list, prods, params, site, ev, buf)
    }

    /// cpfg's stochastic choice (its `FindApplProductions` and `SelectProd`): every
    /// production of the module, in file order, whose contexts match runs its
    /// pre-condition statements and condition; each that holds adds its probability
    /// (1 without `: p`) to a 32-bit sum. Then one draw u of the choice stream, even when
    /// none holds: x = sum·u (32-bit), and the first candidate after which x − the
    /// probabilities so far is ≤ 0 is chosen (none when rounding leaves x above 0). Only
    /// the chosen one runs its post-condition statements, with the locals it bound.
    pub(super) fn select_cpfg(
        &self,
        list: &[Production],
        prods: &[u32],
        params: &[f64],
        site: Site,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
    ) -> Result<Option<(usize, bool)>, Box<LsystemError>> {
        // (production, probability, locals in `saved` from..to when they are buffered)
        type Candidate = (usize, f32, Option<(usize, usize)>);
        let mut cands: Vec<Candidate> = Vec::new();
        let mut saved: Vec<f64> = Vec::new();
        let mut total = 0f32;
        for &k in prods {
            let p = &list[k as usize];
            let Some(uses_buf) = self.try_match_with(p, params, site, ev, buf, false)? else { continue };
            let locals: &[f64] = if uses_buf { buf } else { params };
            let w = match &p.prob {
                Some(pe) => ev
                    .eval(pe, locals)
                    .map_err(|e| self.eval_error(e, "evaluating the probability", Some((p, params))))?,
                None => 1.0,
            };
            if w < 0.0 {
                return Err(self.negative_probability(p, w));
            }
            let w = w as f32;
            total += w;
            let span = uses_buf.then(|| {
                let from = saved.len();
                saved.extend_from_slice(buf);
                (from, saved.len())
            });
            cands.push((k as usize, w, span));
        }
        let mut x = (total as f64 * ev.uniform()) as f32;
        for &(k, w, span) in &cands {
            x -= w;
            if x <= 0.0 {
                let p = &list[k];
                if let Some((from, to)) = span {
                    buf.clear();
                    buf.extend_from_slice(&saved[from..to]);
                }
                if let Some(post) = &p.post {
                    ev.exec(post, buf)
                        .map_err(|e| self.eval_error(e, "running the statements", Some((p, params))))?;
                }
                return Ok(Some((k, span.is_some())));
            }
        }
        Ok(None)
    }

    /// The error of a negative production probability.
    fn negative_probability(&self, p: &Production, w: f64) -> Box<LsystemError> {
        let pe = p.prob.as_ref().expect("only a given probability can be negative");
        self.source.error(
            ErrorKind::NonFinite,
            pe.at as usize,
            pe.len as usize,
            &format!("production probability is negative ({w})"),
            "negative probability",
        )
    }

    /// The production of `list` to apply to a module, if any: its index and whether its
    /// locals are in `buf` (true) or are the module's parameters in place (false). With
    /// sylva's generator, when the first matching production has a probability, every
    /// matching production with one is weighed and one draw chooses; with cpfg's, the
    /// first matching production applies (decomposition and homomorphism never choose
    /// by probability in cpfg; for derivation steps see [`LSystem::select_rewrite`]).
    pub(super) fn select(
        &self,
        list: &[Production],
        prods: &[u32],
        params: &[f64],
        site: Site,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
    ) -> Result<Option<(usize, bool)>, Box<LsystemError>> {
        let cpfg = ev.rng.is_cpfg();
        for (n, &k) in prods.iter().enumerate() {
            let p = &list[k as usize];
            let Some(uses_buf) = self.try_match(p, params, site, ev, buf)? else { continue };
            if p.prob.is_none() || cpfg {
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
                    return Err(self.negative_probability(q, w));
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

    /// Tests one production; `Some(uses_buf)` when it applies (its post-condition
    /// statements have then run).
    #[inline]
    fn try_match(
        &self,
        p: &Production,
        params: &[f64],
        site: Site,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
    ) -> Result<Option<bool>, Box<LsystemError>> {
        self.try_match_with(p, params, site, ev, buf, true)
    }

    /// [`LSystem::try_match`], running the post-condition statements only with `post`.
    #[inline]
    fn try_match_with(
        &self,
        p: &Production,
        params: &[f64],
        site: Site,
        ev: &mut Evaluator,
        buf: &mut Vec<f64>,
        post: bool,
    ) -> Result<Option<bool>, Box<LsystemError>> {
        if p.arity != params.len() {
            return Ok(None);
        }
        if !p.needs_buffer() {
            return Ok(self.condition_holds(p, params, params, ev)?.then_some(false));
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
        if !self.condition_holds(p, buf, params, ev)? {
            return Ok(None);
        }
        if let Some(block) = p.post.as_ref().filter(|_| post) {
            ev.exec(block, buf)
                .map_err(|e| self.eval_error(e, "running the statements", Some((p, params))))?;
        }
        Ok(Some(true))
    }

    /// Whether the condition of `p` holds for the locals `locals` (true when it has
    /// none); `params` are the module's, for messages.
    #[inline]
    fn condition_holds(
        &self,
        p: &Production,
        locals: &[f64],
        params: &[f64],
        ev: &mut Evaluator,
    ) -> Result<bool, Box<LsystemError>> {
        let Some(c) = &p.cond else { return Ok(true) };
        let v = ev
            .eval(c, locals)
            .map_err(|e| self.eval_error(e, "evaluating the condition", Some((p, params))))?;
        Ok(v != 0.0)
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
    pub(super) fn emit(
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
                    Ok(v) => args.push(crate::lsystem::string::cpfg_param(v)),
                    Err(e) => {
                        return Err(self.successor_error(e, p, m, &locals[..p.arity.min(locals.len())]))
                    }
                }
            }
            out.try_push(m.sym, args).map_err(|e| self.memory_error(e, ev, "the derived string"))?;
        }
        Ok(())
    }
}
