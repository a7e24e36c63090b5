//! LST skeleton files (Pieterse2012 §4.1.5 "LST file format", Table 4.2, and §4.1.6 "LST
//! Parser and Graph construction"; Pieterse2012-spec §2.1–2.2).
//!
//! An LST file is a depth-first walk of a tree written by an L-system compiler: a header
//! line `LST <version>` followed by turtle operations. Table 4.2 lists all of them:
//!
//! | operation | effect |
//! |---|---|
//! | `SB()` | push the state (position, orientation, current node) |
//! | `EB()` | pop it |
//! | `MovRel3f(x, y, z)` | move by (x, y, z) **in the current frame**: p ← p + R·(x, y, z) |
//! | `RotRel3f(angle, x, y, z)` | turn by `angle` **radians**, right-handed, about the axis (x, y, z) **of the current frame**: R ← R·Rot(axis/‖axis‖, angle) |
//! | `Cylinder(r0, r1, length)` | a truncated cone from p along R·(0, 1, 0): radius r0 at its base, r1 at its top; the turtle does **not** move |
//!
//! **Conventions** (the seed leaves these open; Pieterse2012-spec §2.1 assumptions A1–A5):
//!
//! - **Units**: LST lengths and radii are metres times [`LstOptions::scale`] (default 1).
//!   The frame is sylva's: +Y up, right-handed. The turtle starts at the origin with
//!   R = I, so a cylinder's axis is R·(0, 1, 0) (A1: every `Cylinder(.., L)` of the
//!   sample is followed by `MovRel3f(0, L, 0)`).
//! - **Angles are radians** (A2; the sample turns by 0.3–1.0, which would be invisible in
//!   degrees), positive angles turn right-handed about the axis.
//! - **Rotations compose in the local frame** (A3, OpenGL matrix-stack semantics):
//!   R ← R·Rot. **Moves are in the rotated frame** (A4).
//! - **Tokens** (A5): operations are `Name(arg, …)` separated by any whitespace, several
//!   to a line if wanted; the argument list closes on its own line; arguments are
//!   decimal numbers (`1`, `-0.5`, `1e-3`). Names are case-sensitive. Blank lines are
//!   ignored anywhere; leading blank lines before the header too.
//! - **Errors** (`file:line:column` with an excerpt): a missing header, an unknown
//!   operation, a missing `(` or `)`, a wrong number of arguments, a non-number, NaN or
//!   infinity, a negative radius or length, a zero rotation axis, `EB()` without `SB()`,
//!   an `SB()` never closed, a position that overflows, and (per policy) gaps.
//!
//! **From cylinders to skeleton nodes.** A skeleton node is the end point of one
//! internode with one radius, so each `Cylinder` becomes the node at its top (radius r1,
//! orientation reference `up` = R·(1, 0, 0), perpendicular to the axis; branch `order`
//! = the `SB` nesting depth). Where the cylinder starts decides its parent node:
//!
//! 1. at the **current node** (the top of the last cylinder, as restored by `EB()`): a
//!    child of it, as in the seed's sample;
//! 2. else at the **base of the current cylinder** (its parent node): a sibling of it,
//!    because `Cylinder` does not move the turtle (`Cylinder … RotRel3f … Cylinder`);
//! 3. with no current node (at the start, or after an `EB()` back to it): a child of a
//!    root made earlier at the same place (one of the 64 most recent roots), so
//!    `SB() … EB() SB() … EB()` from one point is one plant; else a **new root** node at
//!    the cylinder's base with radius r0: the first one always, further ones only under
//!    [`GapPolicy::NewRoot`] (Pieterse2012-spec §2.2: a second root is an error);
//! 4. anywhere else is a **gap**, handled by [`LstOptions::gap`]: a bridging internode
//!    from the current node to the cylinder's base (radius r0 there, the default,
//!    "lenient"), an error ("strict"), or a new root.
//!
//! "The same place" means within [`LstOptions::tolerance`] × max(1, |coordinates|) in
//! every coordinate. A node keeps the radius it was made with (r1, or r0 for a root);
//! every cylinder's r0 (for a bridge: its parent node's radius) is kept as the **start
//! radius** of the internode ending at its top node ([`Skeleton::start_radius()`]), so
//! the meshers build each cylinder as the truncated cone r0 → r1 even where r0 differs
//! from the radius of the node it starts at. It is also in [`LstBranch::start_radius`].
//!
//! The seed's sample (Fig. 4.6) gives 6 cylinders and, under the lenient policy, one
//! bridge: after its last `EB()` it moves 5 units up the trunk before the last cylinder.

use super::{located, nowhere, parse_number, NumberError};
use crate::lsystem::source::{ErrorKind, LsystemError};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{DMat3, DVec3};

type LResult<T> = Result<T, Box<LsystemError>>;

/// What to do when a cylinder starts away from the current node (Pieterse2012-spec §2.2;
/// `generator.gap`: `bridge`, `strict` or `new-root`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GapPolicy {
    /// Insert a bridging internode from the current node to the cylinder's base, with
    /// the cylinder's start radius at its end ("lenient", the default).
    #[default]
    Bridge,
    /// Reject the file with an error at the cylinder.
    Strict,
    /// Start a new root axis at the cylinder's base (the skeleton becomes a forest, as
    /// after cpfg's `f`). Files written by `export::skeleton::to_lst` for skeletons
    /// with several roots need this policy.
    NewRoot,
}

/// Options of the LST reader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LstOptions {
    /// Gap policy (default [`GapPolicy::Bridge`]).
    pub gap: GapPolicy,
    /// Relative tolerance for "a cylinder starts at a node": every coordinate within
    /// `tolerance × max(1, largest coordinate magnitude)` in LST units (default 1e-6).
    pub tolerance: f64,
    /// Metres per LST unit, applied to positions, lengths and radii (default 1).
    pub scale: f64,
    /// Most skeleton nodes the file may make (issue 27; default
    /// [`crate::skeleton::DEFAULT_MAX_NODES`]).
    pub max_nodes: usize,
}

impl Default for LstOptions {
    fn default() -> Self {
        LstOptions {
            gap: GapPolicy::Bridge,
            tolerance: 1e-6,
            scale: 1.0,
            max_nodes: crate::skeleton::DEFAULT_MAX_NODES,
        }
    }
}

/// One internode of the parsed tree: a `Cylinder` of the file, or a bridge the gap
/// policy inserted before one.
#[derive(Debug, Clone, PartialEq)]
pub struct LstBranch {
    /// Skeleton node at the base.
    pub start_node: u32,
    /// Skeleton node at the top (made for this branch).
    pub end_node: u32,
    /// Base radius in metres (the cylinder's r0; for a bridge, its parent node's radius).
    pub start_radius: f64,
    /// Top radius in metres (r1; for a bridge, the next cylinder's r0).
    pub end_radius: f64,
    /// Length in metres.
    pub length: f64,
    /// The frame the branch was drawn in: column 1 is its unit axis, column 0 the `up`
    /// reference stored at its top node.
    pub frame: DMat3,
    /// True for a bridge inserted by [`GapPolicy::Bridge`].
    pub bridge: bool,
    /// 1-based line of the `Cylinder` (for a bridge, of the cylinder after it).
    pub line: usize,
}

/// A parsed LST file: the skeleton and the branches that made it.
#[derive(Debug, Clone, PartialEq)]
pub struct LstTree {
    /// The version from the header (`0.1` in the seed's sample).
    pub version: String,
    /// The skeleton, parent-first in file order.
    pub skeleton: Skeleton,
    /// One entry per cylinder or bridge, in file order (depth first).
    pub branches: Vec<LstBranch>,
}

/// Parses an LST file into a skeleton. `name` is used in error messages.
pub fn parse(name: &str, text: &str, opts: &LstOptions) -> LResult<Skeleton> {
    parse_tree(name, text, opts).map(|t| t.skeleton)
}

/// Parses an LST file into a skeleton plus its list of branches (cylinders and bridges).
pub fn parse_tree(name: &str, text: &str, opts: &LstOptions) -> LResult<LstTree> {
    let err = |kind, at, len, what: &str, label: &str| located(name, text, kind, at, len, what, label);
    if !(opts.tolerance.is_finite() && opts.tolerance >= 0.0) {
        let what = format!("LST tolerance {} must be a finite number ≥ 0", opts.tolerance);
        return Err(nowhere(name, text, ErrorKind::NonFinite, &what));
    }
    if !(opts.scale.is_finite() && opts.scale > 0.0) {
        let what = format!("LST scale {} must be a finite number > 0", opts.scale);
        return Err(nowhere(name, text, ErrorKind::NonFinite, &what));
    }
    let (version, body) = header(text).map_err(|(at, len, what, label)| {
        err(ErrorKind::Syntax, at, len, &what, label)
            .with_help("an LST file starts with a line such as `LST 0.1`")
    })?;
    let mut b = Builder::new(opts);
    let mut ops = Ops { text, i: body };
    while let Some(op) = ops.next_op().map_err(|e| e.into_error(name, text))? {
        b.apply(&op, text).map_err(|e| e.into_error(name, text))?;
    }
    if let Some(&(_, at)) = b.stack.last() {
        let what = format!("`SB()` is never closed by an `EB()` ({} still open at the end)", b.stack.len());
        return Err(err(ErrorKind::Syntax, at, 4, &what, "opened here"));
    }
    Ok(LstTree { version, skeleton: b.sk, branches: b.branches })
}

/// A problem found while reading or applying an operation, located later.
struct OpError {
    kind: ErrorKind,
    at: usize,
    len: usize,
    what: String,
    label: &'static str,
    help: Option<String>,
}

impl OpError {
    fn new(kind: ErrorKind, at: usize, len: usize, what: String, label: &'static str) -> Self {
        OpError { kind, at, len, what, label, help: None }
    }

    fn into_error(self, name: &str, text: &str) -> Box<LsystemError> {
        let e = located(name, text, self.kind, self.at, self.len, &self.what, self.label);
        match self.help {
            Some(h) => e.with_help(h),
            None => e,
        }
    }
}

/// Reads the header line; returns the version and the byte offset after the line.
#[allow(clippy::type_complexity)]
fn header(text: &str) -> Result<(String, usize), (usize, usize, String, &'static str)> {
    let mut off = 0;
    for line in text.split_inclusive('\n') {
        let start = off;
        off += line.len();
        let content = line.trim_start_matches('\u{feff}');
        let lead = line.len() - content.len() + (content.len() - content.trim_start().len());
        let content = content.trim();
        if content.is_empty() {
            continue;
        }
        let at = start + lead;
        let mut words = content.split_whitespace();
        let first = words.next().unwrap_or("");
        if first != "LST" {
            let what = format!("missing `LST <version>` header: the file starts with `{}`", clip(first));
            return Err((at, first.len(), what, "expected `LST`"));
        }
        let Some(version) = words.next() else {
            return Err((at, 3, "missing version after `LST`".into(), "expected e.g. `LST 0.1`"));
        };
        let v_at = at + content.find(version).unwrap_or(0);
        let numeric = version.bytes().all(|c| c.is_ascii_digit() || c == b'.')
            && version.bytes().any(|c| c.is_ascii_digit());
        if !numeric {
            let what = format!("LST version `{}` is not a number", clip(version));
            return Err((v_at, version.len(), what, "expected e.g. `0.1`"));
        }
        if let Some(extra) = words.next() {
            let e_at = v_at + version.len() + content[v_at - at + version.len()..].find(extra).unwrap_or(0);
            let what = format!("unexpected `{}` after the LST version", clip(extra));
            return Err((e_at, extra.len(), what, "the header is `LST <version>` alone on its line"));
        }
        return Ok((version.to_string(), off));
    }
    Err((text.len(), 1, "missing `LST <version>` header: the file is empty".into(), "expected `LST 0.1`"))
}

/// At most 40 characters of a token, for messages.
fn clip(s: &str) -> String {
    match s.char_indices().nth(40) {
        Some((k, _)) => format!("{}…", &s[..k]),
        None => s.to_string(),
    }
}

/// The operations of Table 4.2.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Sb,
    Eb,
    MovRel3f,
    RotRel3f,
    Cylinder,
}

const OPS: [(&str, Kind, usize, &str); 5] = [
    ("SB", Kind::Sb, 0, "SB()"),
    ("EB", Kind::Eb, 0, "EB()"),
    ("MovRel3f", Kind::MovRel3f, 3, "MovRel3f(x, y, z)"),
    ("RotRel3f", Kind::RotRel3f, 4, "RotRel3f(angle, x, y, z)"),
    ("Cylinder", Kind::Cylinder, 3, "Cylinder(startRadius, endRadius, length)"),
];

/// One argument: its value and where it is.
#[derive(Debug, Clone, Copy, Default)]
struct Arg {
    v: f64,
    at: usize,
    len: usize,
}

/// One operation with its (at most four) arguments.
struct Op {
    kind: Kind,
    at: usize,
    len: usize,
    args: [Arg; 4],
}

/// The operation tokenizer.
struct Ops<'a> {
    text: &'a str,
    i: usize,
}

impl Ops<'_> {
    fn next_op(&mut self) -> Result<Option<Op>, OpError> {
        let text = self.text;
        let b = text.as_bytes();
        while let Some(c) = text[self.i..].chars().next() {
            if !c.is_whitespace() {
                break;
            }
            self.i += c.len_utf8();
        }
        if self.i >= text.len() {
            return Ok(None);
        }
        let at = self.i;
        let name_len = text[at..]
            .find(|c: char| c.is_whitespace() || c == '(' || c == ')' || c == ',')
            .unwrap_or(text.len() - at);
        if name_len == 0 {
            let c = b[at] as char;
            return Err(OpError::new(
                ErrorKind::Syntax,
                at,
                1,
                format!("unexpected `{c}`: expected an LST operation"),
                "unexpected",
            ));
        }
        let name = &text[at..at + name_len];
        let Some(&(_, kind, arity, usage)) = OPS.iter().find(|o| o.0 == name) else {
            let mut e = OpError::new(
                ErrorKind::Syntax,
                at,
                name_len,
                format!("unknown LST operation `{}`", clip(name)),
                "unknown operation",
            );
            e.help = Some(match suggest(name) {
                Some(s) => format!("did you mean `{s}`? (names are case-sensitive)"),
                None => "LST operations are SB, EB, MovRel3f, RotRel3f and Cylinder".into(),
            });
            return Err(e);
        };
        // Spaces (not newlines) may separate the name from its `(`.
        let mut j = at + name_len;
        while j < b.len() && (b[j] == b' ' || b[j] == b'\t') {
            j += 1;
        }
        if j >= b.len() || b[j] != b'(' {
            return Err(OpError::new(
                ErrorKind::Syntax,
                at,
                name_len,
                format!("expected `(` after `{name}`: write `{usage}`"),
                "needs an argument list",
            ));
        }
        let open = j;
        let rest = &text[open + 1..];
        let close = match rest.find([')', '(', '\n']) {
            Some(k) if rest.as_bytes()[k] == b')' => open + 1 + k,
            Some(k) if rest.as_bytes()[k] == b'(' => {
                return Err(OpError::new(
                    ErrorKind::Syntax,
                    open + 1 + k,
                    1,
                    "unexpected `(` inside an argument list".into(),
                    "unexpected",
                ));
            }
            _ => {
                return Err(OpError::new(
                    ErrorKind::Syntax,
                    open,
                    1,
                    format!("unclosed `(` after `{name}`: the argument list must end on its line"),
                    "opened here",
                ));
            }
        };
        let mut args = [Arg::default(); 4];
        let mut count = 0;
        let inner = &text[open + 1..close];
        if !inner.trim().is_empty() {
            let mut a = open + 1;
            for piece in inner.split(',') {
                let lead = piece.len() - piece.trim_start().len();
                let tok = piece.trim();
                let t_at = a + lead;
                a += piece.len() + 1;
                if tok.is_empty() {
                    return Err(OpError::new(
                        ErrorKind::Syntax,
                        (a - piece.len() - 1).min(close),
                        1,
                        format!("missing number in the arguments of `{name}`"),
                        "expected a number",
                    ));
                }
                let v = parse_number(tok).map_err(|e| {
                    let what = match e {
                        NumberError::NonFinite => {
                            format!("`{}` is not a finite number (argument of `{name}`)", clip(tok))
                        }
                        NumberError::Syntax => {
                            format!("expected a number, found `{}` (argument of `{name}`)", clip(tok))
                        }
                    };
                    let (kind, label) = e.kind_label();
                    OpError::new(kind, t_at, tok.len(), what, label)
                })?;
                if count < args.len() {
                    args[count] = Arg { v, at: t_at, len: tok.len() };
                }
                count += 1;
            }
        }
        self.i = close + 1;
        if count != arity {
            return Err(OpError::new(
                ErrorKind::Arity,
                at,
                close + 1 - at,
                format!("`{name}` takes {arity} argument(s), got {count}: write `{usage}`"),
                "wrong number of arguments",
            ));
        }
        Ok(Some(Op { kind, at, len: close + 1 - at, args }))
    }
}

/// The Table 4.2 name closest to `name` (same letters ignoring case, or at most two
/// edits away), for "did you mean".
fn suggest(name: &str) -> Option<&'static str> {
    if name.chars().count() > 32 {
        return None;
    }
    let mut best: Option<(usize, &'static str)> = None;
    for &(op, ..) in &OPS {
        let d = if op.eq_ignore_ascii_case(name) { 0 } else { edit_distance(op, name) };
        if d <= 2 && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, op));
        }
    }
    best.map(|(_, op)| op)
}

/// Levenshtein distance over characters (both strings are short).
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The LST turtle state: position, orientation and the node the turtle stands on.
/// Shared with the LST writer, which replays it to stay bit-exact with this reader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Turtle {
    /// Position in LST units.
    pub p: DVec3,
    /// Orientation: columns are the frame's X, Y (the cylinder axis) and Z.
    pub r: DMat3,
    /// The current node, [`NO_PARENT`] for none.
    pub current: u32,
}

impl Turtle {
    /// At the origin, unrotated, on no node.
    pub const START: Turtle = Turtle { p: DVec3::ZERO, r: DMat3::IDENTITY, current: NO_PARENT };

    /// `MovRel3f(x, y, z)`: p ← p + R·(x, y, z).
    pub fn mov(&mut self, x: f64, y: f64, z: f64) {
        self.p += self.r * DVec3::new(x, y, z);
    }

    /// `RotRel3f(angle, x, y, z)`: R ← R·Rot(axis/‖axis‖, angle). `None` for a zero
    /// axis.
    pub fn rot(&mut self, angle: f64, x: f64, y: f64, z: f64) -> Option<()> {
        let axis = DVec3::new(x, y, z);
        let m = axis.abs().max_element();
        if !(m > 0.0 && m.is_finite()) {
            return None;
        }
        let axis = axis / m;
        let axis = axis / axis.length();
        self.r *= DMat3::from_axis_angle(axis, angle);
        Some(())
    }

    /// The top of `Cylinder(_, _, length)` drawn from here.
    pub fn top(&self, length: f64) -> DVec3 {
        self.p + self.r * DVec3::new(0.0, length, 0.0)
    }
}

/// How many of the most recent roots a cylinder with no current node is compared with.
const ROOT_SCAN: usize = 64;

/// Builds the skeleton while operations are applied.
struct Builder<'o> {
    opts: &'o LstOptions,
    t: Turtle,
    /// Saved states and the offset of their `SB()`.
    stack: Vec<(Turtle, usize)>,
    sk: Skeleton,
    /// Unscaled f64 node positions, for "starts at" tests.
    pos: Vec<DVec3>,
    roots: Vec<u32>,
    branches: Vec<LstBranch>,
    /// Line counting for [`LstBranch::line`]: the offset reached and its line.
    line_at: (usize, usize),
}

impl<'o> Builder<'o> {
    fn new(opts: &'o LstOptions) -> Self {
        Builder {
            opts,
            t: Turtle::START,
            stack: Vec::new(),
            sk: Skeleton::new(),
            pos: Vec::new(),
            roots: Vec::new(),
            branches: Vec::new(),
            line_at: (0, 1),
        }
    }

    fn line_of(&mut self, text: &str, at: usize) -> usize {
        let (off, line) = self.line_at;
        let at = at.min(text.len());
        if at >= off {
            let line = line + text.as_bytes()[off..at].iter().filter(|&&c| c == b'\n').count();
            self.line_at = (at, line);
            line
        } else {
            1 + text.as_bytes()[..at].iter().filter(|&&c| c == b'\n').count()
        }
    }

    fn near(&self, a: DVec3, b: DVec3) -> bool {
        let scale = 1f64.max(a.abs().max_element()).max(b.abs().max_element());
        a == b || (a - b).abs().max_element() <= self.opts.tolerance * scale
    }

    fn depth(&self) -> u16 {
        u16::try_from(self.stack.len()).unwrap_or(u16::MAX)
    }

    fn apply(&mut self, op: &Op, text: &str) -> Result<(), OpError> {
        let a = &op.args;
        match op.kind {
            Kind::Sb => self.stack.push((self.t, op.at)),
            Kind::Eb => match self.stack.pop() {
                Some((t, _)) => self.t = t,
                None => {
                    return Err(OpError::new(
                        ErrorKind::Syntax,
                        op.at,
                        op.len,
                        "`EB()` without a matching `SB()`".into(),
                        "nothing to pop",
                    ))
                }
            },
            Kind::MovRel3f => {
                self.t.mov(a[0].v, a[1].v, a[2].v);
                if !self.t.p.is_finite() {
                    return Err(OpError::new(
                        ErrorKind::NonFinite,
                        op.at,
                        op.len,
                        "this move takes the position past the largest finite number".into(),
                        "overflow",
                    ));
                }
            }
            Kind::RotRel3f => {
                if self.t.rot(a[0].v, a[1].v, a[2].v, a[3].v).is_none() {
                    let at = a[1].at;
                    return Err(OpError::new(
                        ErrorKind::Syntax,
                        at,
                        a[3].at + a[3].len - at,
                        "`RotRel3f` has a zero rotation axis".into(),
                        "axis (0, 0, 0)",
                    ));
                }
            }
            Kind::Cylinder => self.cylinder(op, text)?,
        }
        Ok(())
    }

    fn cylinder(&mut self, op: &Op, text: &str) -> Result<(), OpError> {
        let [r0, r1, len, _] = op.args;
        for (arg, what) in [(r0, "start radius"), (r1, "end radius"), (len, "length")] {
            if arg.v < 0.0 {
                return Err(OpError::new(
                    ErrorKind::Syntax,
                    arg.at,
                    arg.len,
                    format!("negative cylinder {what} {}", arg.v),
                    "must be ≥ 0",
                ));
            }
        }
        let fail = |what: String| OpError::new(ErrorKind::NonFinite, op.at, op.len, what, "here");
        let start = self.t.p;
        let top = self.t.top(len.v);
        if !top.is_finite() {
            return Err(fail("the cylinder's top overflows the largest finite number".into()));
        }
        let line = self.line_of(text, op.at);
        let depth = self.depth();
        let frame = self.t.r;
        let up = frame.x_axis;
        // Where does it start? (module docs, rules 1–4)
        let cur = self.t.current;
        let base = if cur != NO_PARENT && self.near(start, self.pos[cur as usize]) {
            cur
        } else if cur != NO_PARENT
            && self.sk.parent[cur as usize] != NO_PARENT
            && self.near(start, self.pos[self.sk.parent[cur as usize] as usize])
        {
            self.sk.parent[cur as usize]
        } else if cur == NO_PARENT {
            let found = self
                .roots
                .iter()
                .rev()
                .take(ROOT_SCAN)
                .copied()
                .find(|&r| self.near(start, self.pos[r as usize]));
            match found {
                Some(r) => r,
                None if self.roots.is_empty() || self.opts.gap == GapPolicy::NewRoot => {
                    let r = self.node(start, r0.v, NO_PARENT, up, depth).map_err(fail)?;
                    self.roots.push(r);
                    r
                }
                None => {
                    let mut e = OpError::new(
                        ErrorKind::Syntax,
                        op.at,
                        op.len,
                        format!(
                            "a second root: this cylinder starts at {} with no current branch and no root there",
                            fmt_point(start)
                        ),
                        "second root",
                    );
                    e.help = Some("read forests with the gap policy `NewRoot`".into());
                    return Err(e);
                }
            }
        } else {
            let from = self.pos[cur as usize];
            match self.opts.gap {
                GapPolicy::Strict => {
                    let mut e = OpError::new(
                        ErrorKind::Syntax,
                        op.at,
                        op.len,
                        format!(
                            "gap: this cylinder starts at {}, {} away from the end of the current branch {}",
                            fmt_point(start),
                            fmt_num((start - from).length()),
                            fmt_point(from)
                        ),
                        "does not start at the current node",
                    );
                    e.help =
                        Some("the gap policy is strict; `Bridge` joins such cylinders with a bridge".into());
                    return Err(e);
                }
                GapPolicy::NewRoot => {
                    let r = self.node(start, r0.v, NO_PARENT, up, depth).map_err(fail)?;
                    self.roots.push(r);
                    r
                }
                GapPolicy::Bridge => {
                    let d = start - from;
                    let axis = d.normalize_or(frame.y_axis);
                    let bup = perpendicular(axis, [frame.x_axis, frame.z_axis, frame.y_axis]);
                    let bridge = self.node(start, r0.v, cur, bup, depth).map_err(fail)?;
                    self.sk.set_start_radius(bridge as usize, Some(self.sk.radius[cur as usize]));
                    let s = self.opts.scale;
                    self.branches.push(LstBranch {
                        start_node: cur,
                        end_node: bridge,
                        start_radius: f64::from(self.sk.radius[cur as usize]),
                        end_radius: r0.v * s,
                        length: d.length() * s,
                        frame: DMat3::from_cols(bup, axis, bup.cross(axis)),
                        bridge: true,
                        line,
                    });
                    bridge
                }
            }
        };
        let r0s = r0.v * self.opts.scale;
        if !(r0s.is_finite() && r0s <= f64::from(crate::skeleton::MAX_COORDINATE)) {
            return Err(fail(format!("radius {} is beyond the range of skeleton radii", fmt_num(r0s))));
        }
        let node = self.node(top, r1.v, base, up, depth).map_err(fail)?;
        self.sk.set_start_radius(node as usize, Some(r0s as f32));
        let s = self.opts.scale;
        self.branches.push(LstBranch {
            start_node: base,
            end_node: node,
            start_radius: r0.v * s,
            end_radius: r1.v * s,
            length: len.v * s,
            frame,
            bridge: false,
            line,
        });
        self.t.current = node;
        Ok(())
    }

    /// Appends a skeleton node at `p` (LST units) with radius `r` (LST units).
    fn node(&mut self, p: DVec3, r: f64, parent: u32, up: DVec3, order: u16) -> Result<u32, String> {
        if self.sk.len() >= (u32::MAX - 1) as usize {
            return Err("more skeleton nodes than u32 indices allow".into());
        }
        if self.sk.len() >= self.opts.max_nodes {
            return Err(format!(
                "this cylinder makes more than {} skeleton nodes, the node budget ({})",
                self.opts.max_nodes,
                crate::skeleton::NODE_BUDGET_HELP
            ));
        }
        let s = self.opts.scale;
        let (ps, rs) = (p * s, r * s);
        let max = f64::from(crate::skeleton::MAX_COORDINATE);
        if !ps.is_finite() || ps.abs().max_element() > max {
            return Err(format!("position {} is beyond the range of skeleton coordinates", fmt_point(ps)));
        }
        if !rs.is_finite() || rs > max {
            return Err(format!("radius {} is beyond the range of skeleton radii", fmt_num(rs)));
        }
        let i = self.sk.push(ps.as_vec3(), rs as f32, parent, up.as_vec3(), order);
        self.pos.push(p);
        Ok(i)
    }
}

/// A unit vector perpendicular to the unit `axis`: the first of `candidates` with a
/// usable component orthogonal to it, else any perpendicular.
pub(crate) fn perpendicular(axis: DVec3, candidates: [DVec3; 3]) -> DVec3 {
    for c in candidates {
        let u = c - axis * axis.dot(c);
        if u.length() > 1e-6 * c.length() {
            return u.normalize();
        }
    }
    axis.any_orthonormal_vector()
}

fn fmt_num(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

fn fmt_point(p: DVec3) -> String {
    format!("({}, {}, {})", fmt_num(p.x), fmt_num(p.y), fmt_num(p.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(text: &str) -> LResult<LstTree> {
        parse_tree("t.lst", text, &LstOptions::default())
    }

    #[test]
    fn a_chain() {
        let t = p("LST 0.1\nCylinder(2, 1, 3) MovRel3f(0, 3, 0)\nCylinder(1, 0.5, 2)\n").unwrap();
        let s = &t.skeleton;
        assert_eq!(t.version, "0.1");
        assert_eq!(s.parent, vec![NO_PARENT, 0, 1]);
        assert_eq!(s.radius, vec![2.0, 1.0, 0.5]);
        assert_eq!(s.position[2], glam::Vec3::new(0.0, 5.0, 0.0));
        assert_eq!(s.up[1], glam::Vec3::X);
        assert_eq!(t.branches.len(), 2);
        assert_eq!(t.branches[1].line, 3);
        s.validate().unwrap();
    }

    #[test]
    fn siblings_from_one_base() {
        // Cylinder does not move the turtle: the second cylinder shares the base.
        let t =
            p("LST 0.1\nCylinder(1,1,1) MovRel3f(0,1,0) Cylinder(1,1,1) RotRel3f(1,0,0,1) Cylinder(1,1,1)")
                .unwrap();
        assert_eq!(t.skeleton.parent, vec![NO_PARENT, 0, 1, 1]);
    }

    #[test]
    fn branches_from_the_root_point_share_the_root() {
        let t = p("LST 0.1\nSB() RotRel3f(0.5,0,0,1) Cylinder(1,1,1) EB() SB() RotRel3f(-0.5,0,0,1) Cylinder(1,1,1) EB()")
            .unwrap();
        assert_eq!(t.skeleton.parent, vec![NO_PARENT, 0, 0]);
        assert_eq!(t.skeleton.order, vec![1, 1, 1]);
    }

    #[test]
    fn second_root_needs_new_root_policy() {
        let text = "LST 0.1\nSB() Cylinder(1,1,1) EB() MovRel3f(5,0,0) Cylinder(1,1,1)";
        let e = p(text).unwrap_err();
        assert!(e.message.starts_with("t.lst:2:43: a second root"), "{}", e.message);
        let opts = LstOptions { gap: GapPolicy::NewRoot, ..Default::default() };
        let s = parse("t.lst", text, &opts).unwrap();
        assert_eq!(s.parent, vec![NO_PARENT, 0, NO_PARENT, 2]);
    }

    #[test]
    fn gap_policies() {
        let text = "LST 0.1\nCylinder(1,1,1) MovRel3f(0,3,0) Cylinder(0.5,0.5,1)";
        let t = p(text).unwrap();
        assert_eq!(t.skeleton.parent, vec![NO_PARENT, 0, 1, 2]);
        assert_eq!(t.skeleton.radius, vec![1.0, 1.0, 0.5, 0.5]);
        assert!(t.branches[1].bridge && !t.branches[2].bridge);
        assert!((t.branches[1].length - 2.0).abs() < 1e-12);
        let strict = LstOptions { gap: GapPolicy::Strict, ..Default::default() };
        let e = parse("t.lst", text, &strict).unwrap_err();
        assert!(
            e.message.starts_with("t.lst:2:33: gap: this cylinder starts at (0, 3, 0), 2 away"),
            "{}",
            e.message
        );
        let roots = LstOptions { gap: GapPolicy::NewRoot, ..Default::default() };
        let s = parse("t.lst", text, &roots).unwrap();
        assert_eq!(s.parent, vec![NO_PARENT, 0, NO_PARENT, 2]);
    }

    #[test]
    fn scale_and_options() {
        let opts = LstOptions { scale: 0.01, ..Default::default() };
        let s = parse("t.lst", "LST 0.1\nCylinder(2, 1, 300)", &opts).unwrap();
        assert_eq!(s.radius, vec![0.02, 0.01]);
        assert!((s.position[1].y - 3.0).abs() < 1e-6);
        let bad = LstOptions { scale: 0.0, ..Default::default() };
        assert!(parse("t.lst", "LST 0.1\n", &bad).unwrap_err().message.contains("scale"));
        let bad = LstOptions { tolerance: f64::NAN, ..Default::default() };
        assert!(parse("t.lst", "LST 0.1\n", &bad).unwrap_err().message.contains("tolerance"));
    }

    #[test]
    fn suggestions() {
        assert_eq!(suggest("MovRel3t"), Some("MovRel3f"));
        assert_eq!(suggest("cylinder"), Some("Cylinder"));
        assert_eq!(suggest("Sphere"), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }

    #[test]
    fn overflow_is_an_error_not_a_panic() {
        let e = p("LST 0.1\nMovRel3f(1e308,0,0) MovRel3f(1e308,0,0)").unwrap_err();
        assert_eq!(e.kind, ErrorKind::NonFinite);
        let e = p("LST 0.1\nMovRel3f(1e300,0,0) Cylinder(1,1,1)").unwrap_err();
        assert!(e.message.contains("beyond the range"), "{}", e.message);
        let e = p("LST 0.1\nCylinder(1e300,1,1)").unwrap_err();
        assert!(e.message.contains("radius"), "{}", e.message);
        assert!(p("LST 0.1\nRotRel3f(1e300, 1e300, 1e300, 0) Cylinder(1,1,1)").is_ok());
    }
}
