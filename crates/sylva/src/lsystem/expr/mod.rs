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
//! (accepted, prints nothing); cpfg's file functions (`fopen`, `fscanf`, `fprintf`,
//! `fflush`, `fclose`) as [`files`] describes: reading only files of the model folder
//! read beforehand, output discarded.
//!
//! Statements (cpfg's `{ ... }` blocks) compile to the same bytecode: assignments to
//! parameters or global variables (`x = e;`, `a[i][j] = e;`, `+= -= *= /=`),
//! `if (c) s else s`, `while (c) s`, `do s while (c);`, expression statements and
//! `array name[n][m] = { ... };` declarations (collected beforehand by the parser).
//! McLoughlin2021 §2.4 (parametric productions) and ABOP ch. 1.10 define the use.

use super::source::ErrorKind;
use std::collections::HashMap;
use std::sync::Arc;

mod compile;
pub mod files;
mod parse;
pub mod random;
mod vm;

pub use self::compile::{compile, compile_block, declared_names, ArrayDecl};
pub use self::random::RandomGenerator;
pub use self::vm::Evaluator;

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
    /// The files `fopen(name, "r")` reads, by name, read from the model folder
    /// beforehand ([`files`]).
    pub data: files::DataFiles,
}

impl From<Vec<Function>> for ModelFunctions {
    fn from(functions: Vec<Function>) -> Self {
        ModelFunctions { functions, curves: Vec::new(), data: files::DataFiles::new() }
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
    /// cpfg's `trunc`: rounds half up, floor(x + 0.5) (despite its name).
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
    /// `fopen(name, mode)`: push a handle; payloads index [`Expr::strings`].
    Fopen {
        /// The file name.
        name: u32,
        /// The mode.
        mode: u32,
    },
    /// `fclose(h)`: pop a handle, push 0.
    Fclose,
    /// `fflush(h)`: pop a handle, push cpfg's value.
    Fflush,
    /// `fscanf(h, format, &x, …)`: pop `targets` variable addresses (a global slot g
    /// as g, a local slot k as −k − 1) and the handle, assign, push the count.
    Fscanf {
        /// The format, an index into [`Expr::strings`].
        format: u32,
        /// How many addresses were given.
        targets: u32,
        /// Source offset of the call, for errors.
        at: u32,
    },
    /// `&a[i]`: pop an index i; push the address of global slot base + i.
    AddressAt {
        /// First slot of the array.
        base: u32,
        /// Number of elements.
        len: u32,
        /// Source offset, for the error.
        at: u32,
    },
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
    /// The string literals the file functions use (names, modes, formats).
    pub strings: Vec<Arc<str>>,
}

/// An evaluation failure, before it is given a place and a message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalError {
    /// Division by zero or a non-finite result.
    pub kind: ErrorKind,
    /// Source offset of the failing operator (or the expression start).
    pub at: u32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lsystem::source::Source;

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
