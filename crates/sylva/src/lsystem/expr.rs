//! Arithmetic expressions of the cpfg language, compiled once to a small stack bytecode.
//!
//! C precedence: `?:`, `||`, `&&`, `== !=`, `< <= > >=`, `+ -`, `* / %`, unary `- + !`,
//! then `^` (power, right-associative, binding tighter than unary minus so `-2^2 = -4`).
//! Functions as in cpfg: trigonometry in **degrees** (`sin cos tan` take degrees,
//! `asin acos atan atan2` return degrees), `sqrt exp log log10 pow floor ceil trunc abs
//! fabs sign min max`, and the random functions `ran(x)` (uniform in [0, x)) and
//! `nran(mean, sd)` (normal), `bran(a, b)` (beta), `biran(n, p)` (binomial), `srand(s)`,
//! drawn from the derivation's seeded generator, `func(id, x)` (cpfg function files),
//! `stop(x)` (ends the derivation after the current step when x ≠ 0), and `printf(...)`
//! (accepted, prints nothing); file output (`fopen`, `fprintf`, `fflush`, `fclose`) is
//! accepted and discarded the same way.
//!
//! Statements (cpfg's `{ ... }` blocks) compile to the same bytecode: assignments to
//! parameters or global variables (`x = e;`, `a[i][j] = e;`, `+= -= *= /=`),
//! `if (c) s else s`, `while (c) s`, `do s while (c);`, expression statements and
//! `array name[n][m] = { ... };` declarations (collected beforehand by the parser).
//! McLoughlin2021 §2.4 (parametric productions) and ABOP ch. 1.10 define the use.

use super::source::{ErrorKind, LsystemError, Source};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::collections::HashMap;
use std::sync::Arc;

/// A global variable or array of the L-system (`Define:` arrays, variables assigned in
/// statement blocks).
#[derive(Debug, Clone, PartialEq)]
pub struct Global {
    /// First slot in the global table.
    pub index: u32,
    /// Array dimensions (empty for a scalar).
    pub dims: Vec<u32>,
}

/// Most numbers all global variables and arrays of an L-system hold together (2²⁵, so
/// 256 MiB): several arrays of the 2²⁴ elements one may have cannot add up to gigabytes.
pub const MAX_GLOBAL_SLOTS: u64 = 1 << 25;

/// The global variables of an L-system: names, slots and initial values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Globals {
    /// Name → slot(s).
    pub names: HashMap<String, Global>,
    /// Initial values of every slot.
    pub init: Vec<f64>,
}

impl Globals {
    /// Declares a scalar (no-op if it exists) and returns it.
    pub fn scalar(&mut self, name: &str) -> &Global {
        let n = self.init.len() as u32;
        self.names.entry(name.to_string()).or_insert_with(|| Global { index: n, dims: Vec::new() });
        if self.names[name].index == n && self.names[name].dims.is_empty() && self.init.len() as u32 == n {
            self.init.push(0.0);
        }
        &self.names[name]
    }

    /// Declares an array with the given dimensions and initial values (zero-padded).
    pub fn array(&mut self, name: &str, dims: Vec<u32>, values: &[f64]) -> Result<(), String> {
        let len: u64 = dims.iter().map(|&d| d as u64).product();
        if len == 0 || len > 1 << 24 {
            return Err(format!("array `{name}` has {len} elements (allowed 1..16777216)"));
        }
        if self.init.len() as u64 + len > MAX_GLOBAL_SLOTS {
            return Err(format!(
                "array `{name}` has {len} elements: with the L-system's other globals that is more than \
                 {MAX_GLOBAL_SLOTS} numbers, the limit on all of its arrays together"
            ));
        }
        if values.len() as u64 > len {
            return Err(format!("array `{name}` has {len} elements but {} initial values", values.len()));
        }
        let index = self.init.len() as u32;
        self.init.extend_from_slice(values);
        self.init.resize(index as usize + len as usize, 0.0);
        self.names.insert(name.to_string(), Global { index, dims });
        Ok(())
    }
}

/// What names an expression can see.
#[derive(Debug, Clone, Copy, Default)]
pub struct Scope<'a> {
    /// Formal parameter names, loaded by position.
    pub locals: &'a [String],
    /// Global variables, if the L-system has any.
    pub globals: Option<&'a Globals>,
}

impl<'a> Scope<'a> {
    /// A scope of formal parameters and globals.
    pub fn new(locals: &'a [String], globals: &'a Globals) -> Self {
        Scope { locals, globals: Some(globals) }
    }
}

/// A function of one variable from a cpfg function file, for `func(id, x)`.
pub type Function = Arc<dyn Fn(f64) -> f64 + Send + Sync>;

/// What a model folder's files give its expressions: functions for `func(id, x)` and
/// curves for `curveX/Y/Z(id, t)` and `curveGAL(id)` (ids 1-based, in view-file order).
#[derive(Clone, Default)]
pub struct ModelFunctions {
    /// `func(id, x)` is `functions[id - 1](x)`.
    pub functions: Vec<Function>,
    /// `curveX(id, t)` is `curves[id - 1].at(t).x`.
    pub curves: Vec<Arc<crate::lsystem::files::curve::Curve>>,
}

impl From<Vec<Function>> for ModelFunctions {
    fn from(functions: Vec<Function>) -> Self {
        ModelFunctions { functions, curves: Vec::new() }
    }
}

/// Built-in functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Func {
    /// sin of degrees.
    Sin,
    /// cos of degrees.
    Cos,
    /// tan of degrees.
    Tan,
    /// asin in degrees.
    Asin,
    /// acos in degrees.
    Acos,
    /// atan in degrees.
    Atan,
    /// atan2(y, x) in degrees.
    Atan2,
    /// Square root.
    Sqrt,
    /// e^x.
    Exp,
    /// Natural logarithm.
    Log,
    /// Base-10 logarithm.
    Log10,
    /// x^y.
    Pow,
    /// Round down.
    Floor,
    /// Round up.
    Ceil,
    /// Round toward zero.
    Trunc,
    /// Absolute value.
    Abs,
    /// −1, 0 or 1.
    Sign,
    /// Smaller of two.
    Min,
    /// Larger of two.
    Max,
    /// Uniform random number in [0, x).
    Ran,
    /// Normal random number with mean and standard deviation.
    Nran,
    /// Beta-distributed random number in [0, 1] with shape parameters a, b.
    Bran,
    /// Binomial random number: successes in n trials of probability p.
    Biran,
    /// Reseed the generator; returns 0.
    Srand,
    /// `func(id, x)`: function `id` (1-based) of the model's function files at x.
    UserFunc,
    /// `curveX(id, t)`: x of curve `id` at normalised arc length t.
    CurveX,
    /// `curveY(id, t)`.
    CurveY,
    /// `curveZ(id, t)`.
    CurveZ,
    /// `curveGAL(id)`: the arc length of curve `id`.
    CurveGal,
    /// `stop(x)`: when x ≠ 0, the derivation ends after the current step; returns 0.
    Stop,
}

impl Func {
    fn lookup(name: &str) -> Option<(Func, usize)> {
        use Func::*;
        Some(match name {
            "sin" => (Sin, 1),
            "cos" => (Cos, 1),
            "tan" => (Tan, 1),
            "asin" => (Asin, 1),
            "acos" => (Acos, 1),
            "atan" => (Atan, 1),
            "atan2" => (Atan2, 2),
            "sqrt" => (Sqrt, 1),
            "exp" => (Exp, 1),
            "log" => (Log, 1),
            "log10" => (Log10, 1),
            "pow" => (Pow, 2),
            "floor" => (Floor, 1),
            "ceil" => (Ceil, 1),
            "trunc" => (Trunc, 1),
            "abs" | "fabs" => (Abs, 1),
            "sign" => (Sign, 1),
            "min" => (Min, 2),
            "max" => (Max, 2),
            "ran" => (Ran, 1),
            "nran" => (Nran, 2),
            "bran" => (Bran, 2),
            "biran" => (Biran, 2),
            "srand" => (Srand, 1),
            "func" => (UserFunc, 2),
            "curveX" => (CurveX, 2),
            "curveY" => (CurveY, 2),
            "curveZ" => (CurveZ, 2),
            "curveGAL" => (CurveGal, 1),
            "stop" => (Stop, 1),
            _ => return None,
        })
    }
}

/// One bytecode instruction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    /// Push a constant.
    Const(f64),
    /// Push local parameter k.
    Load(u16),
    /// Negate the top.
    Neg,
    /// Logical not of the top.
    Not,
    /// a + b.
    Add,
    /// a − b.
    Sub,
    /// a · b.
    Mul,
    /// a / b; the payload is the operator's source offset, for the division-by-zero error.
    Div(u32),
    /// C `fmod(a, b)`; payload as for `Div`.
    Mod(u32),
    /// a ^ b.
    Pow,
    /// a < b.
    Lt,
    /// a ≤ b.
    Le,
    /// a > b.
    Gt,
    /// a ≥ b.
    Ge,
    /// a == b.
    Eq,
    /// a ≠ b.
    Ne,
    /// `&&`: if the top is false, replace it by 0 and jump; else pop it.
    AndJump(u32),
    /// `||`: if the top is true, replace it by 1 and jump; else pop it.
    OrJump(u32),
    /// Pop; jump if it was false.
    JumpIfFalse(u32),
    /// Jump unconditionally.
    Jump(u32),
    /// Replace the top by 0 or 1.
    ToBool,
    /// Call a function (its arguments are on the stack); payload: source offset.
    Call(Func, u32),
    /// Push global slot k.
    LoadGlobal(u32),
    /// Pop into global slot k.
    StoreGlobal(u32),
    /// Pop into local (parameter) slot k.
    StoreLocal(u16),
    /// Pop an index i; push global slot base + i (bounds-checked against len).
    LoadGlobalAt {
        /// First slot of the array.
        base: u32,
        /// Number of elements.
        len: u32,
        /// Source offset, for the error.
        at: u32,
    },
    /// Pop a value, then an index i; store into global slot base + i.
    StoreGlobalAt {
        /// First slot of the array.
        base: u32,
        /// Number of elements.
        len: u32,
        /// Source offset, for the error.
        at: u32,
    },
    /// Discard the top of the stack.
    Pop,
    /// Count a loop iteration; error past the limit (payload: source offset).
    LoopGuard(u32),
    /// Duplicate the top of the stack.
    Dup,
    /// Swap the two top values.
    Swap,
}

/// Where an assignment stores.
#[derive(Debug, Clone, Copy)]
enum Target {
    Local(u16),
    Global(u32),
    GlobalAt { base: u32, len: u32, at: u32 },
}

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

/// Most iterations one statement block's loops may run.
pub const LOOP_LIMIT: u64 = 10_000_000;

/// Deepest nesting an expression or statement block may have (issue 39): every
/// parenthesis, unary operator (`-`, `+`, `!`), exponent (`^`), function argument, array
/// index, branch of `?:` and nested statement (`{ }`, `if`, `else`, `while`, `do`) is one
/// level. The compiler recurses once per level, so the limit bounds its stack use
/// (about 10 frames, a few kilobytes in a debug build, per parenthesis) on any thread,
/// whatever the input. Real models nest a handful of levels (the cpfg corpus at most
/// 3 parentheses and 2 braces); deeper input is a located syntax error naming the
/// limit.
pub const MAX_NESTING: u32 = 256;

/// A compiled expression with its place in the source.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    /// The bytecode.
    pub ops: Vec<Op>,
    /// Offset of the expression in the preprocessed source.
    pub at: u32,
    /// Length of the expression text.
    pub len: u32,
}

/// An evaluation failure, before it is given a place and a message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalError {
    /// Division by zero or a non-finite result.
    pub kind: ErrorKind,
    /// Source offset of the failing operator (or the expression start).
    pub at: u32,
}

/// The mutable state of evaluation: the operand stack, the seeded generator, the
/// global variables and the function table.
#[derive(Clone)]
pub struct Evaluator {
    stack: Vec<f64>,
    /// The generator behind `ran`, `nran` and stochastic productions.
    pub rng: Pcg64,
    /// Current values of the global variables.
    pub globals: Vec<f64>,
    /// Functions for `func(id, x)` and curves for `curveX(id, t)`, ids 1-based.
    pub functions: ModelFunctions,
    /// Set by `stop(x)` with x ≠ 0: the derivation ends after the current step.
    pub stopped: bool,
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
    /// An evaluator whose random draws come from `seed`.
    pub fn new(seed: u64) -> Self {
        Evaluator {
            stack: Vec::with_capacity(64),
            rng: Pcg64::seed_from_u64(seed),
            globals: Vec::new(),
            functions: ModelFunctions::default(),
            stopped: false,
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

    /// A uniform number in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.rng.random::<f64>()
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
                Op::Div(at) | Op::Mod(at) => {
                    let b = st.pop().unwrap_or(0.0);
                    if b == 0.0 {
                        return Err(EvalError { kind: ErrorKind::DivisionByZero, at });
                    }
                    let a = st.last_mut().expect("balanced stack");
                    *a = if matches!(ops[pc], Op::Div(_)) { *a / b } else { *a % b };
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

/// A standard normal draw (Box–Muller; 1 − u keeps the logarithm's argument in (0, 1]).
fn normal(rng: &mut Pcg64) -> f64 {
    let u1 = 1.0 - rng.random::<f64>();
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A Gamma(k, 1) draw (Marsaglia–Tsang), k > 0.
fn gamma(k: f64, rng: &mut Pcg64) -> f64 {
    if k < 1.0 {
        let u = 1.0 - rng.random::<f64>();
        return gamma(k + 1.0, rng) * u.powf(1.0 / k);
    }
    let d = k - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    for _ in 0..1000 {
        let x = normal(rng);
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u = 1.0 - rng.random::<f64>();
        if u.ln() < 0.5 * x * x + d - d * v + d * v.ln() {
            return d * v;
        }
    }
    d
}

/// Calls a built-in; `None` when `func` names a function the model does not have.
fn call(f: Func, st: &mut Vec<f64>, rng: &mut Pcg64, ext: &ModelFunctions) -> Option<f64> {
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
        Trunc => pop().trunc(),
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
        Ran => pop() * rng.random::<f64>(),
        Nran => {
            let sd = pop();
            let mean = pop();
            mean + sd * normal(rng)
        }
        Bran => {
            let b = pop();
            let a = pop();
            if !(a > 0.0 && b > 0.0) {
                return Some(f64::NAN);
            }
            let x = gamma(a, rng);
            let y = gamma(b, rng);
            x / (x + y)
        }
        Biran => {
            let p = pop();
            let n = pop().clamp(0.0, 1e6) as u64;
            (0..n).filter(|_| rng.random::<f64>() < p).count() as f64
        }
        Srand => {
            let s = pop();
            *rng = Pcg64::seed_from_u64(s as i64 as u64);
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

/// Compiles the expression text `src.text[start..end]`, resolving identifiers against
/// `scope` (formal parameters by position, then globals).
pub fn compile(src: &Source, start: usize, end: usize, scope: &Scope) -> Result<Expr, Box<LsystemError>> {
    let mut p = Parser::new(src, start, end, scope);
    p.skip_ws();
    if p.pos >= end {
        return Err(src.error(ErrorKind::Syntax, start, 1, "empty expression", "expected a value"));
    }
    p.ternary()?;
    p.expect_end()?;
    let mut e = Expr { ops: p.ops, at: start as u32, len: (end - start) as u32 };
    fold_constants(&mut e);
    Ok(e)
}

/// An array declaration's dimension texts and initial value texts.
pub type ArrayDecl = (Vec<String>, Vec<String>);

/// Compiles a statement block `{ ... }` (braces included) on `src.text[start..end]`.
pub fn compile_block(
    src: &Source,
    start: usize,
    end: usize,
    scope: &Scope,
) -> Result<Expr, Box<LsystemError>> {
    let mut p = Parser::new(src, start, end, scope);
    p.statement()?;
    p.expect_end()?;
    Ok(Expr { ops: p.ops, at: start as u32, len: (end - start) as u32 })
}

/// Assignment targets and array declarations in a statement block's text, in order:
/// (name, `Some(dims, values)` for arrays). Used by the parser to declare globals
/// before compiling. `params` are excluded (assigning to them stays local).
pub fn declared_names(text: &str, params: &[String]) -> Vec<(String, Option<ArrayDecl>)> {
    let b: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    let ident_at = |i: usize| i < b.len() && (b[i].is_ascii_alphabetic() || b[i] == '_');
    while i < b.len() {
        if b[i] == '"' {
            i += 1;
            while i < b.len() && b[i] != '"' {
                i += 1;
            }
            i += 1;
            continue;
        }
        if !ident_at(i) || (i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == '_' || b[i - 1] == '.'))
        {
            i += 1;
            continue;
        }
        let st = i;
        while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == '_') {
            i += 1;
        }
        let name: String = b[st..i].iter().collect();
        let skip_ws = |mut j: usize| {
            while j < b.len() && b[j].is_whitespace() {
                j += 1;
            }
            j
        };
        if name == "array" {
            let j = skip_ws(i);
            let ns = j;
            let mut k = j;
            while k < b.len() && (b[k].is_ascii_alphanumeric() || b[k] == '_') {
                k += 1;
            }
            let aname: String = b[ns..k].iter().collect();
            let mut dims = Vec::new();
            let mut k2 = skip_ws(k);
            while k2 < b.len() && b[k2] == '[' {
                let close = (k2..b.len()).find(|&q| b[q] == ']').unwrap_or(b.len());
                dims.push(b[k2 + 1..close.min(b.len())].iter().collect::<String>());
                k2 = skip_ws(close + 1);
            }
            let mut values = Vec::new();
            if k2 < b.len() && b[k2] == '=' {
                let open = (k2..b.len()).find(|&q| b[q] == '{');
                if let Some(open) = open {
                    let close = (open..b.len()).find(|&q| b[q] == '}').unwrap_or(b.len());
                    let body: String = b[open + 1..close.min(b.len())].iter().collect();
                    values =
                        body.split(',').map(|v| v.trim().to_string()).filter(|v| !v.is_empty()).collect();
                    k2 = close + 1;
                }
            }
            out.push((aname, Some((dims, values))));
            i = k2;
            continue;
        }
        // name, optional [..] indices, then `=` (not `==`) or an op-assign.
        let mut j = skip_ws(i);
        while j < b.len() && b[j] == '[' {
            let mut depth = 0;
            while j < b.len() {
                if b[j] == '[' {
                    depth += 1;
                } else if b[j] == ']' {
                    depth -= 1;
                    if depth == 0 {
                        break;
                    }
                }
                j += 1;
            }
            j = skip_ws(j + 1);
        }
        let assign = j < b.len()
            && ((b[j] == '=' && b.get(j + 1) != Some(&'='))
                || (matches!(b[j], '+' | '-' | '*' | '/') && b.get(j + 1) == Some(&'=')));
        if assign && !params.contains(&name) && !out.iter().any(|(n, _)| *n == name) {
            out.push((name, None));
        }
    }
    out
}

/// Replaces an expression without parameters, globals or random calls by its value.
fn fold_constants(e: &mut Expr) {
    let pure = e.ops.iter().all(|op| {
        !matches!(
            op,
            Op::Load(_)
                | Op::LoadGlobal(_)
                | Op::LoadGlobalAt { .. }
                | Op::Call(
                    Func::Ran
                        | Func::Nran
                        | Func::Bran
                        | Func::Biran
                        | Func::Srand
                        | Func::UserFunc
                        | Func::Stop,
                    _
                )
        )
    });
    if pure && e.ops.len() > 1 {
        if let Ok(v) = Evaluator::new(0).eval(e, &[]) {
            e.ops = vec![Op::Const(v)];
        }
    }
}

struct Parser<'a> {
    src: &'a Source,
    s: &'a [u8],
    pos: usize,
    end: usize,
    scope: &'a Scope<'a>,
    ops: Vec<Op>,
    /// Current nesting level ([`MAX_NESTING`]).
    depth: u32,
}

type PResult = Result<(), Box<LsystemError>>;

impl<'a> Parser<'a> {
    fn new(src: &'a Source, start: usize, end: usize, scope: &'a Scope<'a>) -> Self {
        Parser { src, s: src.text.as_bytes(), pos: start, end, scope, ops: Vec::new(), depth: 0 }
    }

    /// Enters one level of nesting at `at`; an error past [`MAX_NESTING`]. Every
    /// recursive call of the compiler goes through here (and [`Parser::leave`]).
    fn enter(&mut self, at: usize) -> PResult {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(self
                .src
                .error(
                    ErrorKind::Syntax,
                    at.min(self.end.saturating_sub(1)),
                    1,
                    &format!(
                        "the expression or statement block nests more than {MAX_NESTING} levels deep (parentheses, unary \
                         operators, exponents, function arguments, `?:` branches and statements each count), \
                         sylva's limit on nesting"
                    ),
                    "too deep",
                )
                .with_help(format!(
                    "split the expression, or compute parts of it in a statement block; {MAX_NESTING} levels \
                     is far more than real models use"
                )));
        }
        Ok(())
    }

    /// Leaves a level entered with [`Parser::enter`].
    fn leave(&mut self) {
        self.depth -= 1;
    }

    fn expect_end(&mut self) -> PResult {
        self.skip_ws();
        if self.pos < self.end {
            return Err(self.src.error(
                ErrorKind::Syntax,
                self.pos,
                1,
                &format!("unexpected `{}`", self.s[self.pos] as char),
                "unexpected",
            ));
        }
        Ok(())
    }

    fn ident(&mut self) -> Option<(usize, &'a str)> {
        self.skip_ws();
        let start = self.pos;
        if start < self.end && (self.s[start].is_ascii_alphabetic() || self.s[start] == b'_') {
            let mut p = start;
            while p < self.end && (self.s[p].is_ascii_alphanumeric() || self.s[p] == b'_') {
                p += 1;
            }
            self.pos = p;
            let s: &'a [u8] = self.s;
            return Some((start, std::str::from_utf8(&s[start..p]).unwrap_or("")));
        }
        None
    }

    fn expect(&mut self, tok: &str, what: &str) -> PResult {
        if self.eat(tok) {
            Ok(())
        } else {
            Err(self.err(
                self.pos.min(self.end.saturating_sub(1)),
                &format!("expected `{tok}` {what}"),
                "here",
            ))
        }
    }

    fn peek_word(&mut self, w: &str) -> bool {
        self.skip_ws();
        let b = w.as_bytes();
        self.s[self.pos..self.end].starts_with(b)
            && self.s.get(self.pos + b.len()).is_none_or(|c| !(c.is_ascii_alphanumeric() || *c == b'_'))
    }

    /// Resolves an assignable name; for arrays, parses the indices and leaves the flat
    /// index on the stack. `None` when the name is not assignable (a function call).
    fn lvalue(&mut self, name: &str, at: usize) -> Result<Option<Target>, Box<LsystemError>> {
        if let Some(k) = self.scope.locals.iter().position(|p| p == name) {
            return Ok(Some(Target::Local(k as u16)));
        }
        let Some(g) = self.scope.globals.and_then(|g| g.names.get(name)).cloned() else {
            return Ok(None);
        };
        if g.dims.is_empty() {
            return Ok(Some(Target::Global(g.index)));
        }
        self.indices(name, &g.dims, at)?;
        let len = g.dims.iter().product();
        Ok(Some(Target::GlobalAt { base: g.index, len, at: at as u32 }))
    }

    /// Parses `[i][j]…` for an array of `dims` and pushes the flat index.
    fn indices(&mut self, name: &str, dims: &[u32], at: usize) -> PResult {
        for (k, _) in dims.iter().enumerate() {
            if !self.eat("[") {
                return Err(self.src.error(
                    ErrorKind::Syntax,
                    at,
                    name.len(),
                    &format!("array `{name}` needs {} index(es)", dims.len()),
                    "array",
                ));
            }
            self.ternary()?;
            self.expect("]", "closing the array index")?;
            self.ops.push(Op::Call(Func::Floor, at as u32));
            let _ = k;
        }
        // Combine: the indices i0..in are on the stack; fold them left to right.
        if dims.len() > 1 {
            // Re-emit as: ((i0 * d1 + i1) * d2 + i2) ...; done with a small shuffle:
            // the stack holds [i0, i1, ..., in]; fold from the top using Horner with
            // precomputed strides instead.
            let n = dims.len();
            let mut strides = vec![1u32; n];
            for k in (0..n - 1).rev() {
                strides[k] = strides[k + 1] * dims[k + 1];
            }
            // Stack: [i0, i1, ..., i_{n-1}] → multiply each by its stride and add.
            // Emit: for k from n-1 down to 1: (top * stride_k) then add to the one below
            // after scaling it... Simpler: Horner from the top requires reordering, so we
            // scale as we go: top = i_{n-1} * s_{n-1}; then Add with i_{n-2} scaled…
            self.ops.push(Op::Const(strides[n - 1] as f64));
            self.ops.push(Op::Mul);
            for k in (0..n - 1).rev() {
                // stack: [..., i_k, partial]; compute i_k * s_k + partial.
                self.ops.push(Op::Swap);
                self.ops.push(Op::Const(strides[k] as f64));
                self.ops.push(Op::Mul);
                self.ops.push(Op::Add);
            }
        }
        Ok(())
    }

    fn load_target(&mut self, t: &Target) {
        match *t {
            Target::Local(k) => self.ops.push(Op::Load(k)),
            Target::Global(i) => self.ops.push(Op::LoadGlobal(i)),
            Target::GlobalAt { base, len, at } => {
                self.ops.push(Op::Dup);
                self.ops.push(Op::LoadGlobalAt { base, len, at });
            }
        }
    }

    fn store_target(&mut self, t: Target) {
        self.ops.push(match t {
            Target::Local(k) => Op::StoreLocal(k),
            Target::Global(i) => Op::StoreGlobal(i),
            Target::GlobalAt { base, len, at } => Op::StoreGlobalAt { base, len, at },
        });
    }

    /// One statement (or a `{ }` block of them).
    fn statement(&mut self) -> PResult {
        self.skip_ws();
        self.enter(self.pos)?;
        let r = self.statement_inner();
        self.leave();
        r
    }

    fn statement_inner(&mut self) -> PResult {
        if self.eat("{") {
            loop {
                self.skip_ws();
                if self.pos >= self.end {
                    return Err(self.err(
                        self.end.saturating_sub(1),
                        "unclosed `{` in statement block",
                        "here",
                    ));
                }
                if self.eat("}") {
                    return Ok(());
                }
                self.statement()?;
            }
        }
        if self.eat(";") {
            return Ok(());
        }
        let save = self.pos;
        let Some((at, word)) = self.ident() else {
            self.ternary()?;
            self.ops.push(Op::Pop);
            return self.expect(";", "after the statement");
        };
        match word {
            "if" => {
                self.expect("(", "after `if`")?;
                self.ternary()?;
                self.expect(")", "closing the `if` condition")?;
                let jf = self.ops.len();
                self.ops.push(Op::JumpIfFalse(0));
                self.statement()?;
                if self.peek_word("else") {
                    self.ident();
                    let j = self.ops.len();
                    self.ops.push(Op::Jump(0));
                    self.ops[jf] = Op::JumpIfFalse(self.ops.len() as u32);
                    self.statement()?;
                    self.ops[j] = Op::Jump(self.ops.len() as u32);
                } else {
                    self.ops[jf] = Op::JumpIfFalse(self.ops.len() as u32);
                }
                Ok(())
            }
            "while" => {
                let top = self.ops.len();
                self.expect("(", "after `while`")?;
                self.ternary()?;
                self.expect(")", "closing the `while` condition")?;
                let jf = self.ops.len();
                self.ops.push(Op::JumpIfFalse(0));
                self.ops.push(Op::LoopGuard(at as u32));
                self.statement()?;
                self.ops.push(Op::Jump(top as u32));
                self.ops[jf] = Op::JumpIfFalse(self.ops.len() as u32);
                Ok(())
            }
            "do" => {
                let top = self.ops.len();
                self.ops.push(Op::LoopGuard(at as u32));
                self.statement()?;
                if !self.peek_word("while") {
                    return Err(self.err(self.pos, "expected `while` after a `do` block", "here"));
                }
                self.ident();
                self.expect("(", "after `while`")?;
                self.ternary()?;
                self.expect(")", "closing the `while` condition")?;
                self.ops.push(Op::Not);
                self.ops.push(Op::JumpIfFalse(top as u32));
                self.expect(";", "after `do ... while (...)`")
            }
            "array" => {
                // Declared (and initialised) by the parser beforehand; skip to `;`.
                while self.pos < self.end && self.s[self.pos] != b';' {
                    self.pos += 1;
                }
                self.expect(";", "after the array declaration")
            }
            _ => {
                // Assignment or expression statement.
                let name = word.to_string();
                let mark = self.ops.len();
                let target = self.lvalue(&name, at)?;
                self.skip_ws();
                let op =
                    [("+=", Op::Add), ("-=", Op::Sub), ("*=", Op::Mul), ("/=", Op::Div(self.pos as u32))]
                        .into_iter()
                        .find(|(t, _)| self.s[self.pos..self.end].starts_with(t.as_bytes()));
                let plain = self.pos < self.end
                    && self.s[self.pos] == b'='
                    && self.s.get(self.pos + 1) != Some(&b'=');
                match (target, op, plain) {
                    (Some(t), Some((tok, op)), _) => {
                        self.pos += tok.len();
                        self.load_target(&t);
                        self.ternary()?;
                        self.ops.push(op);
                        self.store_target(t);
                    }
                    (Some(t), None, true) => {
                        self.pos += 1;
                        self.ternary()?;
                        self.store_target(t);
                    }
                    _ => {
                        self.pos = save;
                        self.ops.truncate(mark);
                        self.ternary()?;
                        self.ops.push(Op::Pop);
                    }
                }
                self.expect(";", "after the statement")
            }
        }
    }

    fn skip_ws(&mut self) {
        while self.pos < self.end && (self.s[self.pos] as char).is_ascii_whitespace() {
            self.pos += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.skip_ws();
        (self.pos < self.end).then(|| self.s[self.pos])
    }

    fn eat(&mut self, tok: &str) -> bool {
        self.skip_ws();
        let t = tok.as_bytes();
        if self.pos + t.len() <= self.end && &self.s[self.pos..self.pos + t.len()] == t {
            self.pos += t.len();
            true
        } else {
            false
        }
    }

    fn err(&self, at: usize, what: &str, label: &str) -> Box<LsystemError> {
        self.src.error(ErrorKind::Syntax, at, 1, what, label)
    }

    fn ternary(&mut self) -> PResult {
        self.skip_ws();
        self.enter(self.pos)?;
        let r = self.ternary_inner();
        self.leave();
        r
    }

    fn ternary_inner(&mut self) -> PResult {
        self.or()?;
        if self.eat("?") {
            let jf = self.ops.len();
            self.ops.push(Op::JumpIfFalse(0));
            self.ternary()?;
            let j = self.ops.len();
            self.ops.push(Op::Jump(0));
            if !self.eat(":") {
                return Err(self.err(self.pos, "expected `:` in `a ? b : c`", "expected `:`"));
            }
            self.ops[jf] = Op::JumpIfFalse(self.ops.len() as u32);
            self.ternary()?;
            self.ops[j] = Op::Jump(self.ops.len() as u32);
        }
        Ok(())
    }

    fn or(&mut self) -> PResult {
        self.and()?;
        while self.eat("||") {
            let j = self.ops.len();
            self.ops.push(Op::OrJump(0));
            self.and()?;
            self.ops.push(Op::ToBool);
            self.ops[j] = Op::OrJump(self.ops.len() as u32);
        }
        Ok(())
    }

    fn and(&mut self) -> PResult {
        self.equality()?;
        while self.eat("&&") {
            let j = self.ops.len();
            self.ops.push(Op::AndJump(0));
            self.equality()?;
            self.ops.push(Op::ToBool);
            self.ops[j] = Op::AndJump(self.ops.len() as u32);
        }
        Ok(())
    }

    fn equality(&mut self) -> PResult {
        self.relational()?;
        loop {
            let op = if self.eat("==") {
                Op::Eq
            } else if self.eat("!=") {
                Op::Ne
            } else {
                return Ok(());
            };
            self.relational()?;
            self.ops.push(op);
        }
    }

    fn relational(&mut self) -> PResult {
        self.additive()?;
        loop {
            let op = if self.eat("<=") {
                Op::Le
            } else if self.eat(">=") {
                Op::Ge
            } else if self.eat("<") {
                Op::Lt
            } else if self.eat(">") {
                Op::Gt
            } else {
                return Ok(());
            };
            self.additive()?;
            self.ops.push(op);
        }
    }

    fn additive(&mut self) -> PResult {
        self.multiplicative()?;
        loop {
            let op = match self.peek() {
                Some(b'+') => Op::Add,
                Some(b'-') => Op::Sub,
                _ => return Ok(()),
            };
            self.pos += 1;
            self.multiplicative()?;
            self.ops.push(op);
        }
    }

    fn multiplicative(&mut self) -> PResult {
        self.unary()?;
        loop {
            let at = self.pos as u32;
            let op = match self.peek() {
                Some(b'*') => Op::Mul,
                Some(b'/') => Op::Div(at),
                Some(b'%') => Op::Mod(at),
                _ => return Ok(()),
            };
            let at = self.pos as u32;
            let op = match op {
                Op::Div(_) => Op::Div(at),
                Op::Mod(_) => Op::Mod(at),
                o => o,
            };
            self.pos += 1;
            self.unary()?;
            self.ops.push(op);
        }
    }

    fn unary(&mut self) -> PResult {
        let op = match self.peek() {
            Some(b'-') => Some(Op::Neg),
            Some(b'+') => None,
            Some(b'!') if self.s.get(self.pos + 1) != Some(&b'=') => Some(Op::Not),
            _ => return self.power(),
        };
        self.enter(self.pos)?;
        self.pos += 1;
        let r = self.unary();
        self.leave();
        r?;
        if let Some(op) = op {
            self.ops.push(op);
        }
        Ok(())
    }

    fn power(&mut self) -> PResult {
        self.primary()?;
        if self.peek() == Some(b'^') {
            self.enter(self.pos)?;
            self.pos += 1;
            let r = self.unary();
            self.leave();
            r?;
            self.ops.push(Op::Pow);
        }
        Ok(())
    }

    fn primary(&mut self) -> PResult {
        let start = match self.peek() {
            None => return Err(self.err(self.pos, "expression ends too early", "expected a value")),
            Some(_) => self.pos,
        };
        let c = self.s[start];
        if c == b'(' {
            self.pos += 1;
            self.ternary()?;
            if !self.eat(")") {
                return Err(self.err(start, "unclosed `(` in expression", "opened here"));
            }
            return Ok(());
        }
        if c.is_ascii_digit() || c == b'.' {
            return self.number();
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            while self.pos < self.end
                && (self.s[self.pos].is_ascii_alphanumeric() || self.s[self.pos] == b'_')
            {
                self.pos += 1;
            }
            let s: &'a [u8] = self.s;
            let name = std::str::from_utf8(&s[start..self.pos]).unwrap_or("");
            if self.peek() == Some(b'(') {
                return self.call(name, start);
            }
            if let Some(k) = self.scope.locals.iter().position(|p| p == name) {
                self.ops.push(Op::Load(k as u16));
                return Ok(());
            }
            if let Some(g) = self.scope.globals.and_then(|g| g.names.get(name)).cloned() {
                if g.dims.is_empty() {
                    self.ops.push(Op::LoadGlobal(g.index));
                } else {
                    self.indices(name, &g.dims, start)?;
                    let len = g.dims.iter().product();
                    self.ops.push(Op::LoadGlobalAt { base: g.index, len, at: start as u32 });
                }
                return Ok(());
            }
            let what = if self.scope.locals.is_empty() {
                format!("undefined name `{name}`: not a parameter, variable or constant (#define) here")
            } else {
                format!(
                    "undefined parameter `{name}`: the predecessor's parameters are {}",
                    self.scope.locals.join(", ")
                )
            };
            return Err(self.src.error(ErrorKind::UndefinedName, start, name.len(), &what, "undefined"));
        }
        if c == b'"' {
            // A string literal (printf's format): skipped, worth 0.
            self.pos += 1;
            while self.pos < self.end && self.s[self.pos] != b'"' {
                self.pos += 1;
            }
            if self.pos >= self.end {
                return Err(self.err(start, "unclosed string literal", "opened here"));
            }
            self.pos += 1;
            self.ops.push(Op::Const(0.0));
            return Ok(());
        }
        Err(self.err(start, &format!("unexpected `{}` in expression", c as char), "expected a value"))
    }

    fn number(&mut self) -> PResult {
        let start = self.pos;
        let s = self.s;
        while self.pos < self.end && (s[self.pos].is_ascii_digit() || s[self.pos] == b'.') {
            self.pos += 1;
        }
        if self.pos < self.end && (s[self.pos] == b'e' || s[self.pos] == b'E') {
            let save = self.pos;
            self.pos += 1;
            if self.pos < self.end && (s[self.pos] == b'+' || s[self.pos] == b'-') {
                self.pos += 1;
            }
            if self.pos < self.end && s[self.pos].is_ascii_digit() {
                while self.pos < self.end && s[self.pos].is_ascii_digit() {
                    self.pos += 1;
                }
            } else {
                self.pos = save;
            }
        }
        let text = std::str::from_utf8(&s[start..self.pos]).unwrap_or("");
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => {
                self.ops.push(Op::Const(v));
                Ok(())
            }
            _ => Err(self.src.error(
                ErrorKind::Syntax,
                start,
                text.len(),
                &format!("bad number `{text}`"),
                "not a number",
            )),
        }
    }

    /// Compiles the arguments of a call whose name ends at `self.pos` (at `(`);
    /// returns how many there were.
    fn arguments(&mut self, name: &str) -> Result<usize, Box<LsystemError>> {
        self.pos += 1; // (
        let mut n = 0;
        if !self.eat(")") {
            loop {
                self.ternary()?;
                n += 1;
                if self.eat(",") {
                    continue;
                }
                if self.eat(")") {
                    break;
                }
                return Err(self.err(self.pos, &format!("expected `,` or `)` in call of `{name}`"), "here"));
            }
        }
        Ok(n)
    }

    fn call(&mut self, name: &str, start: usize) -> PResult {
        if name == "printf" || name == "fprintf" {
            // Accepted for compatibility; prints nothing, evaluates to 0.
            let n = self.arguments(name)?;
            for _ in 0..n {
                self.ops.push(Op::Pop);
            }
            self.ops.push(Op::Const(0.0));
            return Ok(());
        }
        if matches!(name, "fopen" | "fclose" | "fflush") {
            // File output is discarded like printf's (the pipeline warns that the model
            // writes files): `fopen` returns a non-zero handle, the others 0.
            let n = self.arguments(name)?;
            for _ in 0..n {
                self.ops.push(Op::Pop);
            }
            self.ops.push(Op::Const(if name == "fopen" { 1.0 } else { 0.0 }));
            return Ok(());
        }
        const CPFG_ONLY: &[&str] = &[
            "curve", "tfunc", "inblob", "fscanf", "vvXmin", "vvXmax", "vvYmin", "vvYmax", "vvZmin", "vvZmax",
            "vvScale",
        ];
        if CPFG_ONLY.contains(&name) {
            return Err(self.src.error(
                ErrorKind::Unsupported,
                start,
                name.len(),
                &format!("unsupported: cpfg function `{name}`"),
                "not supported",
            ));
        }
        let Some((f, arity)) = Func::lookup(name) else {
            return Err(self.src.error(
                ErrorKind::UndefinedName,
                start,
                name.len(),
                &format!("unknown function `{name}`"),
                "unknown function",
            ));
        };
        let n = self.arguments(name)?;
        if n != arity {
            return Err(self.src.error(
                ErrorKind::Arity,
                start,
                name.len(),
                &format!("function `{name}` takes {arity} argument(s), got {n}"),
                "wrong number of arguments",
            ));
        }
        self.ops.push(Op::Call(f, start as u32));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(text: &str) -> f64 {
        let src = Source::new("t.l", text, &[]).unwrap();
        let names = ["x".to_string(), "y".to_string()];
        let e =
            compile(&src, 0, src.text.trim_end().len(), &Scope { locals: &names, globals: None }).unwrap();
        Evaluator::new(1).eval(&e, &[2.0, 3.0]).unwrap()
    }

    #[test]
    fn precedence_is_c_like() {
        assert_eq!(ev("1 + 2 * 3"), 7.0);
        assert_eq!(ev("(1 + 2) * 3"), 9.0);
        assert_eq!(ev("-2^2"), -4.0);
        assert_eq!(ev("2^3^2"), 512.0);
        assert_eq!(ev("x * y - 1"), 5.0);
        assert_eq!(ev("7 % 4"), 3.0);
        assert_eq!(ev("1 < 2 && 2 < 1 || 1"), 1.0);
        assert_eq!(ev("!(x == 2)"), 0.0);
        assert_eq!(ev("x != 2 ? 10 : 20"), 20.0);
        assert_eq!(ev("1 <= 1 == 1"), 1.0);
        assert_eq!(ev("0^0"), 1.0);
    }

    #[test]
    fn functions_use_degrees() {
        assert!((ev("sin(30)") - 0.5).abs() < 1e-12);
        assert!((ev("atan2(1, 1)") - 45.0).abs() < 1e-12);
        assert!((ev("acos(0)") - 90.0).abs() < 1e-12);
        assert_eq!(ev("max(x, y) + min(x, y)"), 5.0);
        assert_eq!(ev("pow(2, 10)"), 1024.0);
        assert_eq!(ev("floor(-1.5) + ceil(1.2) + abs(-3)"), 3.0);
        let r = ev("ran(5)");
        assert!((0.0..5.0).contains(&r));
    }

    #[test]
    fn errors_are_located() {
        let src = Source::new("t.l", "x / (y - 3)", &[]).unwrap();
        let xy = ["x".to_string(), "y".to_string()];
        let e = compile(&src, 0, src.text.len(), &Scope { locals: &xy, globals: None }).unwrap();
        let err = Evaluator::new(1).eval(&e, &[1.0, 3.0]).unwrap_err();
        assert_eq!(err.kind, ErrorKind::DivisionByZero);
        assert_eq!(err.at, 2);
        let src = Source::new("t.l", "q + 1", &[]).unwrap();
        let x = ["x".to_string()];
        let err = compile(&src, 0, src.text.len(), &Scope { locals: &x, globals: None }).unwrap_err();
        assert_eq!(err.kind, ErrorKind::UndefinedName);
        let src = Source::new("t.l", "sin(1, 2)", &[]).unwrap();
        assert_eq!(compile(&src, 0, src.text.len(), &Scope::default()).unwrap_err().kind, ErrorKind::Arity);
        let src = Source::new("t.l", "sqrt(x - 5)", &[]).unwrap();
        let e = compile(&src, 0, src.text.len(), &Scope { locals: &x, globals: None }).unwrap();
        assert_eq!(Evaluator::new(1).eval(&e, &[1.0]).unwrap_err().kind, ErrorKind::NonFinite);
    }

    #[test]
    fn constants_fold() {
        let src = Source::new("t.l", "2 * 3 + sin(90)", &[]).unwrap();
        let e = compile(&src, 0, src.text.len(), &Scope::default()).unwrap();
        assert_eq!(e.ops, vec![Op::Const(7.0)]);
    }

    #[test]
    fn statements_globals_and_arrays() {
        let text = "{ array a[2][3] = {1,2,3,4,5,6}; n = 0; i = 0; while (i < 3) { n += a[1][i]; i = i + 1; } \
                    if (n == 15) { x = 1; } else x = 2; do { i -= 1; } while (i > 0); a[0][2] = 9; srand(3); printf(\"%d\", n); }";
        let src = Source::new("t.l", text, &[]).unwrap();
        let mut g = Globals::default();
        for (name, arr) in declared_names(&src.text, &[]) {
            match arr {
                Some((dims, vals)) => {
                    let dims = dims.iter().map(|d| d.trim().parse().unwrap()).collect();
                    let vals: Vec<f64> = vals.iter().map(|v| v.parse().unwrap()).collect();
                    g.array(&name, dims, &vals).unwrap();
                }
                None => {
                    g.scalar(&name);
                }
            }
        }
        let e = compile_block(&src, 0, src.text.trim_end().len(), &Scope::new(&[], &g)).unwrap();
        let mut ev = Evaluator::new(1);
        ev.globals = g.init.clone();
        ev.exec(&e, &mut []).unwrap();
        let get = |n: &str| ev.globals[g.names[n].index as usize];
        assert_eq!(get("n"), 15.0);
        assert_eq!(get("x"), 1.0);
        assert_eq!(get("i"), 0.0);
        assert_eq!(ev.globals[g.names["a"].index as usize + 2], 9.0);
        // Out-of-range index and runaway loops are errors, not panics or hangs.
        let src = Source::new("t.l", "{ a[5][0] = 1; }", &[]).unwrap();
        let e = compile_block(&src, 0, src.text.len(), &Scope::new(&[], &g)).unwrap();
        assert_eq!(ev.exec(&e, &mut []).unwrap_err().kind, ErrorKind::OutOfRange);
        let src = Source::new("t.l", "{ while (1) { n = n + 1; } }", &[]).unwrap();
        let e = compile_block(&src, 0, src.text.len(), &Scope::new(&[], &g)).unwrap();
        assert_eq!(ev.exec(&e, &mut []).unwrap_err().kind, ErrorKind::OutOfRange);
    }

    #[test]
    fn parameters_can_be_assigned_in_blocks() {
        let src = Source::new("t.l", "{ t = t - 1; }", &[]).unwrap();
        let t = ["t".to_string()];
        let e = compile_block(&src, 0, src.text.len(), &Scope { locals: &t, globals: None }).unwrap();
        let mut locals = [5.0];
        Evaluator::new(1).exec(&e, &mut locals).unwrap();
        assert_eq!(locals[0], 4.0);
    }

    #[test]
    fn random_distributions() {
        let mut ev = Evaluator::new(7);
        let src = Source::new("t.l", "bran(2, 5)", &[]).unwrap();
        let e = compile(&src, 0, src.text.len(), &Scope::default()).unwrap();
        let mean: f64 = (0..4000).map(|_| ev.eval(&e, &[]).unwrap()).sum::<f64>() / 4000.0;
        assert!((mean - 2.0 / 7.0).abs() < 0.02, "beta(2,5) mean {mean}");
        let src = Source::new("t.l", "biran(20, 0.25)", &[]).unwrap();
        let e = compile(&src, 0, src.text.len(), &Scope::default()).unwrap();
        let mean: f64 = (0..4000).map(|_| ev.eval(&e, &[]).unwrap()).sum::<f64>() / 4000.0;
        assert!((mean - 5.0).abs() < 0.2, "binomial mean {mean}");
    }
}
