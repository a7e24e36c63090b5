//! Arithmetic expressions of the cpfg language, compiled once to a small stack bytecode.
//!
//! C precedence: `?:`, `||`, `&&`, `== !=`, `< <= > >=`, `+ -`, `* / %`, unary `- + !`,
//! then `^` (power, right-associative, binding tighter than unary minus so `-2^2 = -4`).
//! Functions as in cpfg: trigonometry in **degrees** (`sin cos tan` take degrees,
//! `asin acos atan atan2` return degrees), `sqrt exp log log10 pow floor ceil trunc abs
//! fabs sign min max`, and the random functions `ran(x)` (uniform in [0, x)) and
//! `nran(mean, sd)` (normal), drawn from the derivation's seeded generator.
//! Seed 002 §2.4 (parametric productions) and ABOP ch. 1.10 define the use.

use super::source::{ErrorKind, LsystemError, Source};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

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
    /// Call a function (its arguments are on the stack).
    Call(Func),
}

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

/// The mutable state of evaluation: the operand stack and the seeded generator.
#[derive(Debug, Clone)]
pub struct Evaluator {
    stack: Vec<f64>,
    /// The generator behind `ran`, `nran` and stochastic productions.
    pub rng: Pcg64,
}

impl Evaluator {
    /// An evaluator whose random draws come from `seed`.
    pub fn new(seed: u64) -> Self {
        Evaluator { stack: Vec::with_capacity(64), rng: Pcg64::seed_from_u64(seed) }
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
        if v.is_finite() {
            Ok(v)
        } else {
            Err(EvalError { kind: ErrorKind::NonFinite, at: e.at })
        }
    }

    fn run(&mut self, e: &Expr, locals: &[f64]) -> Result<f64, EvalError> {
        let st = &mut self.stack;
        st.clear();
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
                Op::Load(k) => st.push(locals[k as usize]),
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
                Op::Call(f) => {
                    let v = call(f, st, &mut self.rng);
                    st.push(v);
                }
            }
            pc += 1;
        }
        Ok(st.pop().unwrap_or(0.0))
    }
}

/// `a^b` with 0^0 = 1 (seed 002 test 15 needs 0⁰ = 1; Rust's powf agrees).
fn pow(a: f64, b: f64) -> f64 {
    if b == 0.5 {
        a.sqrt()
    } else if b == b.trunc() && b.abs() <= 64.0 {
        a.powi(b as i32)
    } else {
        a.powf(b)
    }
}

fn call(f: Func, st: &mut Vec<f64>, rng: &mut Pcg64) -> f64 {
    use Func::*;
    let mut pop = || st.pop().unwrap_or(0.0);
    let d = std::f64::consts::PI / 180.0;
    match f {
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
            // Box–Muller; 1 − u keeps the logarithm's argument in (0, 1].
            let u1 = 1.0 - rng.random::<f64>();
            let u2 = rng.random::<f64>();
            mean + sd * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        }
    }
}

/// Compiles the expression text `src.text[start..end]`, resolving identifiers against
/// `params` (formal parameter names, loaded by position).
pub fn compile(src: &Source, start: usize, end: usize, params: &[String]) -> Result<Expr, Box<LsystemError>> {
    let mut p = Parser { src, s: src.text.as_bytes(), pos: start, end, params, ops: Vec::new() };
    p.skip_ws();
    if p.pos >= end {
        return Err(src.error(ErrorKind::Syntax, start, 1, "empty expression", "expected a value"));
    }
    p.ternary()?;
    p.skip_ws();
    if p.pos < end {
        return Err(src.error(
            ErrorKind::Syntax,
            p.pos,
            1,
            &format!("unexpected `{}` in expression", p.s[p.pos] as char),
            "unexpected",
        ));
    }
    let mut e = Expr { ops: p.ops, at: start as u32, len: (end - start) as u32 };
    fold_constants(&mut e);
    Ok(e)
}

/// Replaces an expression without parameters or random calls by its value.
fn fold_constants(e: &mut Expr) {
    let pure = e.ops.iter().all(|op| !matches!(op, Op::Load(_) | Op::Call(Func::Ran) | Op::Call(Func::Nran)));
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
    params: &'a [String],
    ops: Vec<Op>,
}

type PResult = Result<(), Box<LsystemError>>;

impl Parser<'_> {
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
        match self.peek() {
            Some(b'-') => {
                self.pos += 1;
                self.unary()?;
                self.ops.push(Op::Neg);
                Ok(())
            }
            Some(b'+') => {
                self.pos += 1;
                self.unary()
            }
            Some(b'!') if self.s.get(self.pos + 1) != Some(&b'=') => {
                self.pos += 1;
                self.unary()?;
                self.ops.push(Op::Not);
                Ok(())
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> PResult {
        self.primary()?;
        if self.peek() == Some(b'^') {
            self.pos += 1;
            self.unary()?;
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
            let name = std::str::from_utf8(&self.s[start..self.pos]).unwrap_or("");
            if self.peek() == Some(b'(') {
                return self.call(name, start);
            }
            if let Some(k) = self.params.iter().position(|p| p == name) {
                self.ops.push(Op::Load(k as u16));
                return Ok(());
            }
            let what = if self.params.is_empty() {
                format!("undefined name `{name}`: not a constant (#define) here")
            } else {
                format!(
                    "undefined parameter `{name}`: the predecessor's parameters are {}",
                    self.params.join(", ")
                )
            };
            return Err(self.src.error(ErrorKind::UndefinedName, start, name.len(), &what, "undefined"));
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

    fn call(&mut self, name: &str, start: usize) -> PResult {
        let Some((f, arity)) = Func::lookup(name) else {
            return Err(self.src.error(
                ErrorKind::UndefinedName,
                start,
                name.len(),
                &format!("unknown function `{name}`"),
                "unknown function",
            ));
        };
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
        if n != arity {
            return Err(self.src.error(
                ErrorKind::Arity,
                start,
                name.len(),
                &format!("function `{name}` takes {arity} argument(s), got {n}"),
                "wrong number of arguments",
            ));
        }
        self.ops.push(Op::Call(f));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(text: &str) -> f64 {
        let src = Source::new("t.l", text, &[]).unwrap();
        let e = compile(&src, 0, src.text.trim_end().len(), &["x".into(), "y".into()]).unwrap();
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
        let e = compile(&src, 0, src.text.len(), &["x".into(), "y".into()]).unwrap();
        let err = Evaluator::new(1).eval(&e, &[1.0, 3.0]).unwrap_err();
        assert_eq!(err.kind, ErrorKind::DivisionByZero);
        assert_eq!(err.at, 2);
        let src = Source::new("t.l", "q + 1", &[]).unwrap();
        let err = compile(&src, 0, src.text.len(), &["x".into()]).unwrap_err();
        assert_eq!(err.kind, ErrorKind::UndefinedName);
        let src = Source::new("t.l", "sin(1, 2)", &[]).unwrap();
        assert_eq!(compile(&src, 0, src.text.len(), &[]).unwrap_err().kind, ErrorKind::Arity);
        let src = Source::new("t.l", "sqrt(x - 5)", &[]).unwrap();
        let e = compile(&src, 0, src.text.len(), &["x".into()]).unwrap();
        assert_eq!(Evaluator::new(1).eval(&e, &[1.0]).unwrap_err().kind, ErrorKind::NonFinite);
    }

    #[test]
    fn constants_fold() {
        let src = Source::new("t.l", "2 * 3 + sin(90)", &[]).unwrap();
        let e = compile(&src, 0, src.text.len(), &[]).unwrap();
        assert_eq!(e.ops, vec![Op::Const(7.0)]);
    }
}
