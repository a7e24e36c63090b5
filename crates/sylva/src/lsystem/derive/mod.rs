//! Parallel rewriting of module strings with compiled productions.
//!
//! Each step replaces every module by the successor of the first production (in file
//! order) whose predecessor symbol and parameter count match and whose condition
//! holds; modules without a matching production are copied. Stochastic productions
//! are chosen among all matching ones, weighted by their probabilities, with draws from
//! the recipe's seed (McLoughlin2021 §2, ABOP ch. 1). A module budget is enforced while
//! writing each step, so an exploding grammar stops with a clear message instead of
//! running out of memory. Here: the budgets, the evaluator and the derivation loop; the
//! step, production choice, decomposition, errors and text are in the files below.

use super::expr::{Evaluator, Expr, ModelFunctions};
use super::parse::LSystem;
use super::source::{ErrorKind, LsystemError};
pub use super::string::ModuleString;
use super::string::{BYTES_PER_MODULE, BYTES_PER_PARAMETER};

mod errors;
mod expand;
mod select;
mod step;
mod text;

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
/// 32 (64 until issue 39's round 2): at the default budget 1.6·10⁹ units, about 4.5 s
/// on a 2-core machine; every corpus model and preset derives within 16.
pub const WORK_PER_MODULE: u64 = 32;

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
    /// Seed of `ran`, `nran` and stochastic productions with sylva's generator (cpfg's
    /// is seeded as [`super::RandomGenerator::Cpfg`] says; [`LSystem::random`] chooses).
    pub seed: u64,
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
        let mut ev = Evaluator::with_generator(self.random, seed, self.cpfg_seed);
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

    /// What the random generator does differently from what the file may lead one to
    /// expect: with cpfg's generator, probabilities of an L-system without a `seed:`
    /// line are ignored (cpfg derives such an L-system deterministically).
    pub fn random_notes(&self) -> Vec<String> {
        if !self.random.is_cpfg() {
            return Vec::new();
        }
        let mut out = Vec::new();
        for (n, l) in
            std::iter::once((self.number, self)).chain(self.subsystems.iter().map(|s| (s.number, &s.lsystem)))
        {
            if l.cpfg_seed.is_none() {
                if let Some(p) = l.productions.iter().find(|p| p.prob.is_some()) {
                    out.push(format!(
                        "L-system {n} has production probabilities (line {}) but no `seed:` line: as in cpfg, its \
                         first matching production applies; give it a `seed:` line, or set \
                         generator.random = \"sylva\" to choose by probability without one",
                        p.line
                    ));
                }
            }
        }
        out
    }

    /// The axiom as a module string, its expressions evaluated. As in real cpfg it is not
    /// decomposed (issue 46 item 5): decomposition follows each derivation step, so the
    /// first step rewrites the axiom as written, and a derivation of 0 steps is the
    /// axiom itself.
    pub fn axiom_string(&self, ev: &mut Evaluator) -> Result<ModuleString, Box<LsystemError>> {
        let mut out = ModuleString::new();
        let mut buf = Vec::new();
        for m in &self.axiom {
            buf.clear();
            for a in &m.args {
                let v = ev.eval(a, &[]).map_err(|e| self.eval_error(e, "evaluating the axiom", None))?;
                buf.push(crate::lsystem::string::cpfg_param(v));
            }
            out.try_push(m.sym, &buf).map_err(|e| self.memory_error(e, ev, "the axiom"))?;
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
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derive(text: &str, n: u32) -> (LSystem, ModuleString) {
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: n, budget: DEFAULT_MODULE_BUDGET, seed: 1 }).unwrap();
        (ls, m)
    }

    /// `m` with the homomorphism of `ls` applied, as text.
    fn interpreted(ls: &LSystem, m: &ModuleString) -> Result<String, Box<LsystemError>> {
        ls.interpretation(m, &mut Evaluator::new(1), 100).map(|i| ls.format(&i))
    }

    /// The error of deriving `text` for `steps` steps within `budget` modules.
    fn derive_err(text: &str, steps: u32, budget: usize) -> Box<LsystemError> {
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        ls.derive(&DeriveOptions { steps, budget, seed: 1 }).unwrap_err()
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
        let e = derive_err(&bad, 2, 1000);
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

    /// Small grammars and the strings they derive: the first matching production with
    /// its condition, arity, multi-module predecessors, the empty successor.
    #[test]
    fn derived_strings() {
        let cases = [
            (
                "first match and conditions",
                "Axiom: A(0)\nA(x) : x < 2 --> A(x+1)\nA(x) : x >= 2 --> B(x*10)\nA(x) --> C",
                3,
                "B(20)",
            ),
            ("arity must match", "Axiom: A(1,2) A\nA(x) --> X\nA --> Y", 1, "A(1,2)Y"),
            ("multi-module predecessors", "Axiom: A(1)B(2)A(3)C\nA(x)B(y) --> D(x+y)", 1, "D(3)A(3)C"),
            ("empty successor", "Axiom: A B A\nA --> *", 1, "B"),
        ];
        for (what, rules, steps, want) in cases {
            let (ls, m) = derive(&format!("Lsystem: 1\n{rules}\nendlsystem\n"), steps);
            assert_eq!(ls.format(&m), want, "{what}");
        }
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

    /// Errors say what went wrong and where: the module budget stops an exploding
    /// grammar at its step; a division by zero names the line, the module being written
    /// and the module rewritten.
    #[test]
    fn errors_name_the_step_and_the_production() {
        let cases = [
            ("Axiom: F\nF --> FFFFFFFFFF", 20, 1_000_000, ErrorKind::Budget, &["step 7 of 20"][..]),
            (
                "Axiom: A(1)\nA(x) --> A(x-1) B(1/(x-1))",
                2,
                100,
                ErrorKind::DivisionByZero,
                &["t.l:3:", "module `B`", "A(1)"][..],
            ),
        ];
        for (rules, steps, budget, kind, words) in cases {
            let e = derive_err(&format!("Lsystem: 1\n{rules}\nendlsystem\n"), steps, budget);
            assert_eq!(e.kind, kind, "{}", e.message);
            assert!(words.iter().all(|w| e.message.contains(w)), "{}", e.message);
        }
    }

    #[test]
    fn homomorphism_is_for_interpretation_only() {
        let t = "Lsystem: 1\nAxiom: a\na --> b[a]a\nb --> bb\nhomomorphism\na --> F(0.5)\nb --> F(1)\nendlsystem\n";
        let (ls, m) = derive(t, 1);
        assert_eq!(ls.format(&m), "b[a]a");
        assert_eq!(interpreted(&ls, &m).unwrap(), "F(1)[F(0.5)]F(0.5)");
        // Depth 3: a -> bb -> cccc -> FFFF.
        let t =
            "Lsystem: 1\nAxiom: a\nhomomorphism\nmaximum depth: 3\na --> bb\nb --> cc\nc --> F\nendlsystem\n";
        let (ls, m) = derive(t, 0);
        assert_eq!(interpreted(&ls, &m).unwrap(), "FFFF");
        // Depth 2 is too shallow: an error naming the module.
        let (ls, m) = derive(&t.replace("depth: 3", "depth: 2"), 0);
        let e = interpreted(&ls, &m).unwrap_err();
        assert!(
            e.message.contains("module c still has a homomorphism production at the maximum depth 2"),
            "{}",
            e.message
        );
        // Without `maximum depth:` the homomorphism is a single substitution.
        let t = "Lsystem: 1\nAxiom: a\nhomomorphism\na --> aa\nendlsystem\n";
        let (ls, m) = derive(t, 0);
        assert_eq!(interpreted(&ls, &m).unwrap(), "aa");
    }

    #[test]
    fn decomposition_depth_three() {
        // Decomposition runs after every step, recursively; not on the axiom (cpfg).
        let t = "Lsystem: 1\nAxiom: A\nA --> B\ndecomposition\nmaximum depth: 3\nA --> X[Y]\nB --> CC\nC --> DE\nD --> G\nendlsystem\n";
        let (ls, m) = derive(t, 0);
        assert_eq!(ls.format(&m), "A");
        let (ls, m) = derive(t, 1);
        assert_eq!(ls.format(&m), "GEGE");
        let t2 = t.replace("Axiom: A", "Axiom: A B");
        let (ls, m) = derive(&t2, 1);
        assert_eq!(ls.format(&m), "GEGEGEGE");
        let t3 = t2.replace("depth: 3", "depth: 2");
        let e = derive_err(&t3, 1, 100);
        assert!(e.message.contains("module D still has a decomposition production"), "{}", e.message);
    }
}
