//! The stack machine that runs compiled expressions and statement blocks: the
//! [`Evaluator`] with its operand stack, seeded generator (`ran`, `nran`, `bran`,
//! `biran`: sylva's or cpfg's, [`super::random`]), globals, loop and work budgets, and
//! the built-in functions of the cpfg language (Mech2004, McLoughlin2021 §2.4).

use super::files::OpenFiles;
use super::random::{CpfgRandom, Draws, RandomGenerator};
use super::{EvalError, Expr, Func, ModelFunctions, Op, LOOP_LIMIT};
use crate::lsystem::source::ErrorKind;

/// Access to the local slots during evaluation: read-only for plain expressions,
/// writable for statement blocks.
trait Slots {
    fn get(&self, k: usize) -> f64;
    fn set(&mut self, k: usize, v: f64);
}

impl Slots for &[f64] {
    #[inline]
    fn get(&self, k: usize) -> f64 {
        self[k]
    }
    #[inline]
    fn set(&mut self, _: usize, _: f64) {}
}

impl Slots for &mut [f64] {
    #[inline]
    fn get(&self, k: usize) -> f64 {
        self[k]
    }
    #[inline]
    fn set(&mut self, k: usize, v: f64) {
        self[k] = v;
    }
}

/// The mutable state of evaluation: the operand stack, the seeded generator, the
/// global variables and the function table.
#[derive(Clone)]
pub struct Evaluator {
    stack: Vec<f64>,
    /// The generator behind `ran`, `nran` and stochastic productions.
    pub rng: Draws,
    /// Current values of the global variables.
    pub globals: Vec<f64>,
    /// Functions for `func(id, x)` and curves for `curveX(id, t)`, ids 1-based.
    pub functions: ModelFunctions,
    /// Set by `stop(x)` with x ≠ 0: the derivation ends after the current step.
    pub stopped: bool,
    /// The files the model's statements opened (cpfg's 25 slots).
    pub files: OpenFiles,
    /// Derivation steps applied so far.
    pub steps_done: u32,
    loops: u64,
    /// Work done so far (issue 27): expression operations, loop iterations and, counted
    /// by the derivation, rewritten modules, context scan steps and turtle passes.
    pub work: u64,
    /// The work budget: evaluation fails with [`ErrorKind::Budget`] past it
    /// (`u64::MAX`, no limit, unless a derivation sets one).
    pub work_limit: u64,
    /// Most modules a string written through this evaluator (derivation, decomposition,
    /// homomorphism) may hold: the module budget, `usize::MAX` unless a derivation sets it.
    pub module_limit: usize,
}

impl std::fmt::Debug for Evaluator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Evaluator")
            .field("globals", &self.globals)
            .field("functions", &self.functions.functions.len())
            .field("curves", &self.functions.curves.len())
            .finish()
    }
}

impl Evaluator {
    /// An evaluator whose random draws come from sylva's generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self::with_draws(Draws::sylva(seed))
    }

    /// An evaluator drawing from `generator`: sylva's seeded with `seed`, or cpfg's with
    /// the main L-system's `seed:` value `file_seed` ([`CpfgRandom::new`]).
    pub fn with_generator(generator: RandomGenerator, seed: u64, file_seed: Option<i64>) -> Self {
        Self::with_draws(match generator {
            RandomGenerator::Sylva => Draws::sylva(seed),
            RandomGenerator::Cpfg { seed } => Draws::Cpfg(CpfgRandom::new(file_seed, seed)),
        })
    }

    /// An evaluator drawing from `rng`.
    pub fn with_draws(rng: Draws) -> Self {
        Evaluator {
            stack: Vec::with_capacity(64),
            rng,
            globals: Vec::new(),
            functions: ModelFunctions::default(),
            stopped: false,
            files: OpenFiles::default(),
            steps_done: 0,
            loops: 0,
            work: 0,
            work_limit: u64::MAX,
            module_limit: usize::MAX,
        }
    }

    /// Runs a statement block, which may assign to `locals` and to globals.
    pub fn exec(&mut self, e: &Expr, locals: &mut [f64]) -> Result<(), EvalError> {
        self.loops = 0;
        self.run(e, locals).map(|_| ())
    }

    /// A uniform number in [0, 1) for choosing a stochastic production.
    pub fn uniform(&mut self) -> f64 {
        self.rng.choice()
    }

    /// Evaluates `e` with the given local parameters. The result is always finite.
    #[inline]
    pub fn eval(&mut self, e: &Expr, locals: &[f64]) -> Result<f64, EvalError> {
        // Fast paths for the most common shapes.
        let v = match e.ops.as_slice() {
            [Op::Const(c)] => return Ok(*c),
            [Op::Load(k)] => locals[*k as usize],
            _ => self.run(e, locals)?,
        };
        let _ = &self.loops;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(EvalError { kind: ErrorKind::NonFinite, at: e.at })
        }
    }

    /// Counts `units` of work; an error past [`Evaluator::work_limit`].
    #[inline]
    pub fn charge(&mut self, units: u64, at: u32) -> Result<(), EvalError> {
        self.work = self.work.saturating_add(units);
        if self.work > self.work_limit {
            return Err(EvalError { kind: ErrorKind::Budget, at });
        }
        Ok(())
    }

    fn run<S: Slots>(&mut self, e: &Expr, mut locals: S) -> Result<f64, EvalError> {
        self.charge(e.ops.len() as u64, e.at)?;
        let st = &mut self.stack;
        st.clear();
        let globals = &mut self.globals;
        let ops = &e.ops;
        let mut pc = 0usize;
        macro_rules! bin {
            ($f:expr) => {{
                let b = st.pop().unwrap_or(0.0);
                let a = st.last_mut().expect("compiled expressions keep the stack balanced");
                *a = $f(*a, b);
            }};
        }
        let b2f = |b: bool| if b { 1.0 } else { 0.0 };
        while pc < ops.len() {
            match ops[pc] {
                Op::Const(c) => st.push(c),
                Op::Load(k) => st.push(locals.get(k as usize)),
                Op::Neg => {
                    if let Some(a) = st.last_mut() {
                        *a = -*a
                    }
                }
                Op::Not => {
                    if let Some(a) = st.last_mut() {
                        *a = b2f(*a == 0.0)
                    }
                }
                Op::ToBool => {
                    if let Some(a) = st.last_mut() {
                        *a = b2f(*a != 0.0)
                    }
                }
                Op::Add => bin!(|a, b| a + b),
                Op::Sub => bin!(|a, b| a - b),
                Op::Mul => bin!(|a, b| a * b),
                Op::Div(at) => {
                    let b = st.pop().unwrap_or(0.0);
                    if b == 0.0 {
                        return Err(EvalError { kind: ErrorKind::DivisionByZero, at });
                    }
                    let a = st.last_mut().expect("balanced stack");
                    *a /= b;
                }
                Op::Mod(at) => {
                    // cpfg's `%` is C's on ints: both operands truncated to `int` first
                    // (issue 46), so `5.5 % 2` is 1.
                    let b = st.pop().unwrap_or(0.0) as i32;
                    if b == 0 {
                        return Err(EvalError { kind: ErrorKind::DivisionByZero, at });
                    }
                    let a = st.last_mut().expect("balanced stack");
                    *a = (*a as i32).wrapping_rem(b) as f64;
                }
                Op::Pow => bin!(pow),
                Op::Lt => bin!(|a, b| b2f(a < b)),
                Op::Le => bin!(|a, b| b2f(a <= b)),
                Op::Gt => bin!(|a, b| b2f(a > b)),
                Op::Ge => bin!(|a, b| b2f(a >= b)),
                Op::Eq => bin!(|a, b| b2f(a == b)),
                Op::Ne => bin!(|a, b| b2f(a != b)),
                Op::AndJump(t) => {
                    if st.last().copied().unwrap_or(0.0) == 0.0 {
                        if let Some(a) = st.last_mut() {
                            *a = 0.0
                        }
                        pc = t as usize;
                        continue;
                    }
                    st.pop();
                }
                Op::OrJump(t) => {
                    if st.last().copied().unwrap_or(0.0) != 0.0 {
                        if let Some(a) = st.last_mut() {
                            *a = 1.0
                        }
                        pc = t as usize;
                        continue;
                    }
                    st.pop();
                }
                Op::JumpIfFalse(t) => {
                    if st.pop().unwrap_or(0.0) == 0.0 {
                        pc = t as usize;
                        continue;
                    }
                }
                Op::Jump(t) => {
                    pc = t as usize;
                    continue;
                }
                Op::Call(Func::Stop, _) => {
                    if st.pop().unwrap_or(0.0) != 0.0 {
                        self.stopped = true;
                    }
                    st.push(0.0);
                }
                Op::Call(f, at) => {
                    if f == Func::Biran {
                        // biran(n, p) draws n times.
                        let n = st.len().checked_sub(2).map_or(0.0, |k| st[k]).clamp(0.0, 1e6) as u64;
                        self.work = self.work.saturating_add(n);
                        if self.work > self.work_limit {
                            return Err(EvalError { kind: ErrorKind::Budget, at });
                        }
                    }
                    let v = call(f, st, &mut self.rng, &self.functions)
                        .ok_or(EvalError { kind: ErrorKind::UndefinedName, at })?;
                    st.push(v);
                }
                Op::LoadGlobal(k) => st.push(globals.get(k as usize).copied().unwrap_or(0.0)),
                Op::StoreGlobal(k) => {
                    let v = st.pop().unwrap_or(0.0);
                    if let Some(g) = globals.get_mut(k as usize) {
                        *g = v;
                    }
                }
                Op::StoreLocal(k) => {
                    let v = st.pop().unwrap_or(0.0);
                    locals.set(k as usize, v);
                }
                Op::LoadGlobalAt { base, len, at } => {
                    let i = st.pop().unwrap_or(0.0).floor();
                    if !(0.0..len as f64).contains(&i) {
                        return Err(EvalError { kind: ErrorKind::OutOfRange, at });
                    }
                    st.push(globals.get(base as usize + i as usize).copied().unwrap_or(0.0));
                }
                Op::StoreGlobalAt { base, len, at } => {
                    let v = st.pop().unwrap_or(0.0);
                    let i = st.pop().unwrap_or(0.0).floor();
                    if !(0.0..len as f64).contains(&i) {
                        return Err(EvalError { kind: ErrorKind::OutOfRange, at });
                    }
                    if let Some(g) = globals.get_mut(base as usize + i as usize) {
                        *g = v;
                    }
                }
                Op::Pop => {
                    st.pop();
                }
                Op::Dup => {
                    let v = st.last().copied().unwrap_or(0.0);
                    st.push(v);
                }
                Op::Swap => {
                    let n = st.len();
                    if n >= 2 {
                        st.swap(n - 1, n - 2);
                    }
                }
                Op::Fopen { name, mode } => {
                    let (name, mode) = (&e.strings[name as usize], &e.strings[mode as usize]);
                    let data = self.functions.data.get(&**name).cloned();
                    st.push(self.files.open(data, mode));
                }
                Op::Fclose => {
                    let h = st.pop().unwrap_or(-1.0);
                    st.push(self.files.close(h));
                }
                Op::Fflush => {
                    let h = st.pop().unwrap_or(-1.0);
                    st.push(self.files.flush(h));
                }
                Op::AddressAt { base, len, at } => {
                    let i = st.pop().unwrap_or(0.0).floor();
                    if !(0.0..len as f64).contains(&i) {
                        return Err(EvalError { kind: ErrorKind::OutOfRange, at });
                    }
                    st.push(base as f64 + i);
                }
                Op::Fscanf { format, targets, at } => {
                    let n = targets as usize;
                    let addrs = st.split_off(st.len().saturating_sub(n));
                    let h = st.pop().unwrap_or(-1.0);
                    let get = |a: f64, locals: &S, globals: &[f64]| {
                        if a < 0.0 {
                            locals.get((-a - 1.0) as usize)
                        } else {
                            globals.get(a as usize).copied().unwrap_or(0.0)
                        }
                    };
                    let old: Vec<f64> = addrs.iter().map(|&a| get(a, &locals, globals)).collect();
                    let (v, new) = self
                        .files
                        .scan(h, &e.strings[format as usize], &old)
                        .map_err(|_| EvalError { kind: ErrorKind::Unsupported, at })?;
                    self.work = self.work.saturating_add(new.len() as u64);
                    for (&a, &x) in addrs.iter().zip(&new) {
                        if a < 0.0 {
                            locals.set((-a - 1.0) as usize, x);
                        } else if let Some(g) = globals.get_mut(a as usize) {
                            *g = x;
                        }
                    }
                    st.push(v);
                }
                Op::LoopGuard(at) => {
                    self.loops += 1;
                    if self.loops > LOOP_LIMIT {
                        return Err(EvalError { kind: ErrorKind::OutOfRange, at });
                    }
                    // A loop iteration runs its body again: charge the whole block.
                    self.work = self.work.saturating_add(ops.len() as u64);
                    if self.work > self.work_limit {
                        return Err(EvalError { kind: ErrorKind::Budget, at });
                    }
                }
            }
            pc += 1;
        }
        Ok(st.pop().unwrap_or(0.0))
    }
}

/// `a^b` with 0^0 = 1 (McLoughlin2021 test 15 needs 0⁰ = 1; Rust's powf agrees).
fn pow(a: f64, b: f64) -> f64 {
    if b == 0.5 {
        a.sqrt()
    } else if b == b.trunc() && b.abs() <= 64.0 {
        a.powi(b as i32)
    } else {
        a.powf(b)
    }
}

/// Calls a built-in; `None` when `func` names a function the model does not have.
pub(super) fn call(f: Func, st: &mut Vec<f64>, rng: &mut Draws, ext: &ModelFunctions) -> Option<f64> {
    use Func::*;
    let mut pop = || st.pop().unwrap_or(0.0);
    let d = std::f64::consts::PI / 180.0;
    Some(match f {
        Sin => (pop() * d).sin(),
        Cos => (pop() * d).cos(),
        Tan => (pop() * d).tan(),
        Asin => pop().asin() / d,
        Acos => pop().acos() / d,
        Atan => pop().atan() / d,
        Atan2 => {
            let x = pop();
            let y = pop();
            y.atan2(x) / d
        }
        Sqrt => pop().sqrt(),
        Exp => pop().exp(),
        Log => pop().ln(),
        Log10 => pop().log10(),
        Pow => {
            let b = pop();
            let a = pop();
            pow(a, b)
        }
        Floor => pop().floor(),
        Ceil => pop().ceil(),
        // cpfg's `trunc` rounds: floor(x + 0.5) (vlab `cpfg/generate.c`, issue 46).
        Trunc => (pop() + 0.5).floor(),
        Abs => pop().abs(),
        Sign => {
            let a = pop();
            if a > 0.0 {
                1.0
            } else if a < 0.0 {
                -1.0
            } else {
                0.0
            }
        }
        Min => {
            let b = pop();
            pop().min(b)
        }
        Max => {
            let b = pop();
            pop().max(b)
        }
        Ran => pop() * rng.uniform(),
        Nran => {
            let sd = pop();
            let mean = pop();
            rng.normal(mean, sd)
        }
        Bran => {
            let b = pop();
            let a = pop();
            rng.beta(a, b)
        }
        Biran => {
            let p = pop();
            let n = pop().clamp(0.0, 1e6) as u64;
            rng.binomial(n, p)
        }
        Srand => {
            let s = pop();
            rng.srand(s);
            0.0
        }
        UserFunc => {
            let x = pop();
            let id = pop();
            // Saturating: `func(-1e308, x)` is no function, not an overflow.
            let k = (id as i64).saturating_sub(1);
            if k < 0 || k as usize >= ext.functions.len() {
                return None;
            }
            (ext.functions[k as usize])(x)
        }
        CurveX | CurveY | CurveZ | CurveGal => {
            let t = if f == CurveGal { 0.0 } else { pop() };
            let id = (pop() as i64).saturating_sub(1);
            let c = ext.curves.get(usize::try_from(id).ok()?)?;
            match f {
                CurveX => c.at(t).x,
                CurveY => c.at(t).y,
                CurveZ => c.at(t).z,
                _ => c.length(),
            }
        }
        // Handled by the evaluator (it sets a flag); never reaches here.
        Stop => {
            pop();
            0.0
        }
    })
}
