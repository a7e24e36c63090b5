//! The recursive-descent parser behind [`compile`](super::compile): C precedence,
//! `^` binding tighter than unary minus, statements, assignment targets; it emits the
//! stack bytecode directly and bounds its nesting by [`MAX_NESTING`] (Mech2004,
//! McLoughlin2021 §2.4).

use super::{Func, Op, Scope, MAX_NESTING};
use crate::lsystem::source::{ErrorKind, LsystemError, Source};

/// Where an assignment stores.
#[derive(Debug, Clone, Copy)]
enum Target {
    Local(u16),
    Global(u32),
    GlobalAt { base: u32, len: u32, at: u32 },
}

pub(super) struct Parser<'a> {
    src: &'a Source,
    s: &'a [u8],
    pub(super) pos: usize,
    end: usize,
    scope: &'a Scope<'a>,
    pub(super) ops: Vec<Op>,
    /// String literals of the file functions ([`super::Expr::strings`]).
    pub(super) strings: Vec<std::sync::Arc<str>>,
    /// Current nesting level ([`MAX_NESTING`]).
    depth: u32,
}

type PResult = Result<(), Box<LsystemError>>;

impl<'a> Parser<'a> {
    pub(super) fn new(src: &'a Source, start: usize, end: usize, scope: &'a Scope<'a>) -> Self {
        Parser {
            src,
            s: src.text.as_bytes(),
            pos: start,
            end,
            scope,
            ops: Vec::new(),
            strings: Vec::new(),
            depth: 0,
        }
    }

    /// Enters one level of nesting at `at`; an error past [`MAX_NESTING`]. Every
    /// recursive call of the compiler goes through here and [`Parser::leave`], by way
    /// of [`Parser::nested`].
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

    /// Runs `inner` one level of nesting deeper, entered at `at`.
    fn nested(&mut self, at: usize, inner: fn(&mut Self) -> PResult) -> PResult {
        self.enter(at)?;
        let r = inner(self);
        self.leave();
        r
    }

    pub(super) fn expect_end(&mut self) -> PResult {
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

    pub(super) fn expect(&mut self, tok: &str, what: &str) -> PResult {
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
    pub(super) fn statement(&mut self) -> PResult {
        self.skip_ws();
        self.nested(self.pos, Self::statement_inner)
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

    pub(super) fn skip_ws(&mut self) {
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

    pub(super) fn ternary(&mut self) -> PResult {
        self.skip_ws();
        self.nested(self.pos, Self::ternary_inner)
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
        self.short_circuit("||", Op::OrJump, Self::and)
    }

    fn and(&mut self) -> PResult {
        self.short_circuit("&&", Op::AndJump, Self::equality)
    }

    /// `||` or `&&` (`tok`): `next`, then for every `tok` that follows, a jump (`jump`,
    /// patched to the end) over another `next`, whose value becomes 0 or 1.
    fn short_circuit(&mut self, tok: &str, jump: fn(u32) -> Op, next: fn(&mut Self) -> PResult) -> PResult {
        next(self)?;
        while self.eat(tok) {
            let j = self.ops.len();
            self.ops.push(jump(0));
            next(self)?;
            self.ops.push(Op::ToBool);
            self.ops[j] = jump(self.ops.len() as u32);
        }
        Ok(())
    }

    fn equality(&mut self) -> PResult {
        self.binary(&[("==", Op::Eq), ("!=", Op::Ne)], Self::relational)
    }

    fn relational(&mut self) -> PResult {
        self.binary(&[("<=", Op::Le), (">=", Op::Ge), ("<", Op::Lt), (">", Op::Gt)], Self::additive)
    }

    /// One left-associative level of binary operators: `next` (the level that binds
    /// tighter), then for every operator of `ops` that follows (tried in order, so `<=`
    /// before `<`), another `next` and the operator's instruction.
    fn binary(&mut self, ops: &[(&str, Op)], next: fn(&mut Self) -> PResult) -> PResult {
        next(self)?;
        loop {
            let Some(&(_, op)) = ops.iter().find(|(tok, _)| self.eat(tok)) else { return Ok(()) };
            next(self)?;
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
        let at = self.pos;
        self.pos += 1;
        self.nested(at, Self::unary)?;
        if let Some(op) = op {
            self.ops.push(op);
        }
        Ok(())
    }

    fn power(&mut self) -> PResult {
        self.primary()?;
        if self.peek() == Some(b'^') {
            let at = self.pos;
            self.pos += 1;
            self.nested(at, Self::unary)?;
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

    /// A string literal argument of `what` (after white space): its index in
    /// [`Parser::strings`], escapes replaced.
    fn string_literal(&mut self, what: &str) -> Result<u32, Box<LsystemError>> {
        self.skip_ws();
        let start = self.pos;
        if self.peek() != Some(b'"') {
            return Err(self.err(
                start.min(self.end.saturating_sub(1)),
                &format!("`{what}` needs a string literal here (cpfg's grammar takes only \"...\")"),
                "expected a string",
            ));
        }
        self.pos += 1;
        while self.pos < self.end && self.s[self.pos] != b'"' {
            self.pos += 1;
        }
        if self.pos >= self.end {
            return Err(self.err(start, "unclosed string literal", "opened here"));
        }
        let text = std::str::from_utf8(&self.s[start + 1..self.pos]).unwrap_or("");
        self.pos += 1;
        self.strings.push(super::files::unescape(text).into());
        Ok(self.strings.len() as u32 - 1)
    }

    /// `fscanf(file, "format", &x, &a[i], …)`: the file expression, the format (checked:
    /// the conversions cpfg's double variables allow) and the variables' addresses.
    fn fscanf(&mut self, start: usize) -> PResult {
        self.pos += 1; // (
        self.ternary()?;
        self.expect(",", "after fscanf's file")?;
        self.skip_ws();
        let fmt_at = self.pos;
        let format = self.string_literal("fscanf")?;
        let wanted = super::files::check_format(&self.strings[format as usize]).map_err(|why| {
            self.src.error(
                ErrorKind::Unsupported,
                fmt_at,
                self.pos - fmt_at,
                &format!("unsupported: fscanf's format: {why}"),
                "this format",
            )
        })?;
        let mut targets = 0u32;
        while self.eat(",") {
            self.skip_ws();
            let at = self.pos;
            if !self.eat("&") {
                return Err(self.err(
                    at.min(self.end.saturating_sub(1)),
                    "fscanf needs the address of a variable here (`&x` or `&a[i]`), as in cpfg",
                    "expected `&`",
                ));
            }
            let Some((vat, var)) = self.ident() else {
                return Err(self.err(at, "expected a variable name after `&`", "here"));
            };
            let var = var.to_string();
            match self.lvalue(&var, vat)? {
                Some(Target::Local(k)) => self.ops.push(Op::Const(-(k as f64) - 1.0)),
                Some(Target::Global(g)) => self.ops.push(Op::Const(g as f64)),
                Some(Target::GlobalAt { base, len, at }) => self.ops.push(Op::AddressAt { base, len, at }),
                None => {
                    return Err(self.src.error(
                        ErrorKind::UndefinedName,
                        vat,
                        var.len(),
                        &format!("`&{var}`: not a variable or parameter fscanf can assign"),
                        "not a variable",
                    ))
                }
            }
            targets += 1;
        }
        self.expect(")", "closing fscanf")?;
        if (targets as usize) < wanted {
            return Err(self.src.error(
                ErrorKind::Arity,
                start,
                6,
                &format!("fscanf's format assigns {wanted} variable(s) but {targets} address(es) are given"),
                "too few variables",
            ));
        }
        self.ops.push(Op::Fscanf { format, targets, at: start as u32 });
        Ok(())
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
        if name == "fopen" {
            // fopen("name", "mode"): both string literals, as cpfg's grammar needs.
            self.pos += 1; // (
            let file = self.string_literal(name)?;
            self.expect(",", "between fopen's file name and mode")?;
            let mode = self.string_literal(name)?;
            self.expect(")", "closing fopen")?;
            self.ops.push(Op::Fopen { name: file, mode });
            return Ok(());
        }
        if name == "fclose" || name == "fflush" {
            let n = self.arguments(name)?;
            if n != 1 {
                return Err(self.src.error(
                    ErrorKind::Arity,
                    start,
                    name.len(),
                    &format!("function `{name}` takes 1 argument (a file), got {n}"),
                    "wrong number of arguments",
                ));
            }
            self.ops.push(if name == "fclose" { Op::Fclose } else { Op::Fflush });
            return Ok(());
        }
        if name == "fscanf" {
            return self.fscanf(start);
        }
        const CPFG_ONLY: &[&str] = &[
            "curve", "tfunc", "inblob", "vvXmin", "vvXmax", "vvYmin", "vvYmax", "vvZmin", "vvZmax", "vvScale",
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
