//! Entry points of the expression compiler: an expression or a `{ … }` statement block
//! to bytecode, constant folding, and the names a block declares (Mech2004).

use super::parse::Parser;
use super::vm::Evaluator;
use super::{Expr, Func, Op, Scope};
use crate::lsystem::source::{ErrorKind, LsystemError, Source};

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
    let mut e = Expr { ops: p.ops, at: start as u32, len: (end - start) as u32, strings: p.strings };
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
    Ok(Expr { ops: p.ops, at: start as u32, len: (end - start) as u32, strings: p.strings })
}

/// Assignment targets (`x = …`, `x += …`, `fscanf`'s `&x`) and array declarations in a
/// statement block's text, in order:
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
        // `&x` in `fscanf(f, "%lf", &x)` assigns x too (not `&&x`).
        let address = st > 0 && b[st - 1] == '&' && (st < 2 || b[st - 2] != '&');
        if (assign || address) && !params.contains(&name) && !out.iter().any(|(n, _)| *n == name) {
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
                | Op::Fopen { .. }
                | Op::Fclose
                | Op::Fflush
                | Op::Fscanf { .. }
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
