//! The derivation's budgets as it runs (work, modules and parameters written, a step's
//! size) and its error messages: what was being done, which production and module, and
//! the key `generator.max_modules` to raise or lower (Mech2004).

use super::{param_budget, work_budget, DeriveOptions, MODULE_WORK, PARAMS_PER_MODULE, WORK_PER_MODULE};
use crate::lsystem::expr::{EvalError, Evaluator};
use crate::lsystem::parse::{LSystem, ModuleTemplate, Production};
use crate::lsystem::source::{ErrorKind, LsystemError};
use crate::lsystem::string::{ModuleString, OutOfMemory, BYTES_PER_MODULE, BYTES_PER_PARAMETER};

/// The words for an evaluation error kind.
fn error_words(kind: ErrorKind) -> &'static str {
    match kind {
        ErrorKind::DivisionByZero => "division by zero",
        ErrorKind::OutOfRange => "an array index or loop count out of range",
        ErrorKind::UndefinedName => "a function that the model does not define",
        ErrorKind::Budget => "the derivation's work budget is used up",
        ErrorKind::Unsupported => {
            "fscanf of a file that is not open for reading (its fopen gave -1: the model folder does not \
             hold the file, or it was closed)"
        }
        _ => "the result is not a finite number",
    }
}

impl LSystem {
    /// Adds the numbers and the key to an exhausted work budget's message.
    pub(super) fn work_note(&self, mut e: Box<LsystemError>, opts: &DeriveOptions) -> Box<LsystemError> {
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
    pub(super) fn charge_module(
        &self,
        ev: &mut Evaluator,
        out: &ModuleString,
    ) -> Result<(), Box<LsystemError>> {
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

    pub(super) fn size_error(
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
    pub(super) fn memory_error(&self, e: OutOfMemory, ev: &Evaluator, what: &str) -> Box<LsystemError> {
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

    /// A step's string against the module budget `opts.budget` and its parameter budget.
    pub(super) fn check_step_size(
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

    /// After `expand` wrote a module: the module and parameter budgets, checked while
    /// a decomposition or homomorphism writes, so a recursive rule cannot run away
    /// inside one module.
    #[inline]
    pub(super) fn charge_expanded(
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

    pub(super) fn successor_error(
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

    pub(super) fn eval_error(
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

    pub(super) fn budget_error(&self, step: u32, opts: &DeriveOptions, len: usize) -> Box<LsystemError> {
        let e = self.source.error_nowhere(
            ErrorKind::Budget,
            &format!(
                "derivation step {step} of {} exceeds the module budget: more than {} modules (reached {len})",
                opts.steps, opts.budget
            ),
        );
        e.with_help("derive fewer steps (-n) or raise the limit with --set generator.max_modules=N")
    }
}
