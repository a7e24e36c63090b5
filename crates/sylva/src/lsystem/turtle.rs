//! The 3D turtle (ABOP ch. 1.5, McLoughlin2021 §4): interprets a module string into a
//! [`Skeleton`].
//!
//! **Conventions** (McLoughlin2021 §4 "Decision"). The turtle frame is heading H, left L and
//! up U with H × L = U, starting at H = +Y, L = +Z, U = +X (right-handed, Y up);
//! cpfg `.str` strings start in cpfg's frame instead, H = +Y, L = −X, U = +Z (MacMurchy2004
//! property 10; [`TurtleOptions::left`]).
//! Positive angles rotate right-handed about the named axis, in degrees:
//!
//! | module | rotation | effect |
//! |---|---|---|
//! | `+(a)` | about U by +a | turn left: H toward L |
//! | `-(a)` | about U by −a | turn right |
//! | `&(a)` | about L by +a | pitch down: H toward −U |
//! | `^(a)` | about L by −a | pitch up |
//! | `/(a)` | about H by +a | roll right: L toward U |
//! | `\(a)` | about H by −a | roll left |
//! | `\|` | about U by 180° | turn around |
//! | `$` | — | roll so L is horizontal: L = (Y × H)/‖Y × H‖, U = H × L |
//!
//! So a tree whose rolls are all 0° or 180° lies in the y–z plane (McLoughlin2021 test 11).
//! `F(l)`/`G(l)` move by l (default: the step) and draw an internode; `f(l)`/`g(l)` move
//! without drawing. `!(w)` sets the line width, which is a **diameter**: skeleton radii
//! are width / 2. `!` and `#` without a parameter multiply / divide the width by the
//! width factor. `[`/`]` push and pop the state; each `[` raises the branch order by
//! one. `%` skips the rest of the current branch. `;(i)` / `,(i)` set (or step) the
//! material index. Other modules have no turtle meaning and are ignored, as in cpfg.
//!
//! One skeleton node is written per `F` end point; a root node is written where a
//! drawn axis starts (at the beginning, and after an `f` move). Axes that start
//! exactly where a root already is share it: `[&F…][^F…]` at the start of an axiom is
//! one plant with several stems (ABOP's bush, Fig. 1.25), not several plants whose
//! bases overlap.
//!
//! **Tropism** (ABOP §2.2, cpfg view files): after every drawn `F` the heading turns
//! toward each tropism vector T about H × T by α = e·‖H × T‖ (e the elasticity; T
//! normalised), never past T. With an angle A (`tropism: T: … A: …`, plagiotropism)
//! the heading turns toward the cone at angle A around T instead. `@Ts(i, e)` sets the
//! elasticity of tropism i (1-based); `_(e)` sets the elasticity of every tropism and a
//! bare `_` adds the elasticity increment.
//!
//! **More cpfg modules**: `@M(x,y,z)` moves to a point without drawing; `@R(hx,hy,hz
//! [,ux,uy,uz])` sets the heading (and up); `@v` rolls like `$`; `{` … `}` trace a
//! polygon whose vertices are the start point and every `f`/`F` end point (and `.`),
//! placed as an organ and not as branches; `~x(s)` places the named surface x scaled
//! by s; `@O(r)` a sphere, `@o(r)` / `@c(r)` a disc. Every axis is already one smooth
//! tube; the generalized-cylinder markers also trace one: `@Gs` starts a generalized cylinder at the turtle's
//! position, `@Gc` adds a node there and `@Ge` adds the last one, so models that move
//! with `f` between control points (cpfg's contour-swept stems) still get an axis.
//!
//! **Contours** (cpfg generalized cylinders, issue 26). `@#(n)` selects contour n of
//! the view file (`contour: n file.con`, [`TurtleOptions::contours`]); `@#(0)` (the
//! default) is the circle, and a generalized cylinder drawn with the circle traces
//! skeleton nodes as above. One whose `@Gs` comes while a contour is selected becomes a
//! [`OrganKind::Swept`] organ instead (no skeleton nodes): at every control point
//! (`@Gs`, `@Gc`, `@Ge`) the contour's sampled points (x, y) are placed at
//! `position + r·(x·U − y·L)` with r the turtle's width / 2 (the same radius as a tube)
//! — contour x along the turtle's up, y along its right, as cpfg's `make_contour` does,
//! so a leaf contour (wide in x) lies in the plane of H and U and bends out of its
//! plane with `+`/`-`. `@Gc(k)` / `@Ge(k)` ask for k rings from the previous control
//! point (default 1, at most 256): the k − 1 between are on the cubic Hermite curve
//! through the two points whose tangents are the turtle's headings times their
//! distance (cpfg's default tangent parameters), with the radius and the contour
//! interpolated linearly and the frame carried by the smallest rotation plus the share
//! of the twist between the two control points' frames. With `twist of cylinders: off`
//! ([`TurtleOptions::twist_of_cylinders`]) a control point's frame is the previous one
//! carried to its heading, ignoring the turtle's rolls, as in cpfg. A `[` branch that
//! adds control points forks the surface from its last point; an `@Gc` with no open
//! cylinder starts one, as cpfg's does. Errors: `@#(n)` for an undeclared or unreadable
//! contour; an open contour and a closed one (the circle included) in one cylinder, or
//! a contour selected inside a cylinder started with the circle, are `unsupported:`.

use super::environment::{Environment, Sensor};
use super::parse::Symbols;
use super::source::{ErrorKind, LsystemError, Source};
use super::string::ModuleString;
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DVec2, DVec3};

/// A tropism: a direction the branches bend toward (ABOP §2.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tropism {
    /// Direction T (normalised when used).
    pub direction: [f64; 3],
    /// Initial elasticity e (0 = no bending).
    pub elasticity: f64,
    /// Cone angle A in degrees for plagiotropism; `None` bends straight toward T.
    pub angle: Option<f64>,
}

/// Most tropisms a turtle carries.
pub const MAX_TROPISMS: usize = 8;

/// Turtle parameters: what modules without parameters use.
#[derive(Debug, Clone, PartialEq)]
pub struct TurtleOptions {
    /// Default turning angle in degrees (`+`, `-`, `&`, `^`, `/`, `\`).
    pub angle: f64,
    /// Default step length of `F`, `f`, `G`, `g`.
    pub step: f64,
    /// Initial line width (a diameter).
    pub width: f64,
    /// Factor applied by a bare `!` (and divided by a bare `#`), when no increment is set.
    pub width_factor: f64,
    /// Additive width change of a bare `!` / `#` (cpfg `line width increment`), if set.
    pub width_increment: Option<f64>,
    /// Tropisms, at most [`MAX_TROPISMS`].
    pub tropisms: Vec<Tropism>,
    /// Elasticity change of a bare `_`.
    pub elasticity_increment: f64,
    /// Most skeleton nodes the turtle may draw (issue 27): checked before the skeleton
    /// is allocated; default [`crate::skeleton::DEFAULT_MAX_NODES`].
    pub max_nodes: usize,
    /// The initial left vector L (the heading starts at +Y, and U = H × L): +Z for
    /// L-systems (McLoughlin2021's convention, the default), [`CPFG_LEFT`] = −X for cpfg's
    /// `.str` strings (MacMurchy2004 property 10: H = +Y, L = −X, U = +Z). Any vector
    /// perpendicular to +Y; others fall back to +Z.
    pub left: [f64; 3],
    /// The contours `@#(id)` selects for generalized cylinders (cpfg view file
    /// `contour: id file.con`), already sampled; id 0 is always the circle.
    pub contours: Vec<TurtleContour>,
    /// Points around the circle (and around every contour, which is sampled into as
    /// many pieces): the view file's `contour sides`, default 8.
    pub contour_sides: usize,
    /// cpfg's `twist of cylinders`: when on (the default here), each control point of a
    /// contour-swept generalized cylinder keeps its own turtle orientation (rolls between
    /// control points twist the surface); when off, the frame is carried from the
    /// previous control point by the smallest rotation, as cpfg does.
    pub twist_of_cylinders: bool,
}

/// A contour for `@#(id)`: its cross-section points (in the contour's x–y plane, before
/// scaling by the radius) and whether it is closed.
#[derive(Debug, Clone, PartialEq)]
pub struct TurtleContour {
    /// The id `@#(id)` selects (not 0, which is the circle).
    pub id: i32,
    /// The sampled cross-section: `contour_sides + 1` points when open, `contour_sides`
    /// when closed (the first not repeated).
    pub points: Vec<[f64; 2]>,
    /// Whether the cross-section is a closed loop.
    pub closed: bool,
    /// Why the contour cannot be used (its file is missing or malformed: file, line and
    /// why), if so; `@#(id)` selecting it is then that error.
    pub error: Option<String>,
}

impl TurtleContour {
    /// Samples a contour read from a `.con` file into `sides` pieces of equal arc length.
    pub fn from_contour(id: i32, contour: &super::files::contour::Contour, sides: usize) -> Self {
        TurtleContour {
            id,
            points: contour.sample(sides).into_iter().map(|p| p.to_array()).collect(),
            closed: contour.closed,
            error: None,
        }
    }

    /// A declared contour whose file could not be read, with why.
    pub fn unusable(id: i32, why: &str) -> Self {
        TurtleContour { id, points: Vec::new(), closed: false, error: Some(why.to_string()) }
    }
}

/// cpfg's initial left vector, −X (MacMurchy2004 property 10), used for `.str` input.
pub const CPFG_LEFT: [f64; 3] = [-1.0, 0.0, 0.0];

impl Default for TurtleOptions {
    fn default() -> Self {
        TurtleOptions {
            angle: 45.0,
            step: 1.0,
            width: 0.1,
            width_factor: 0.7,
            width_increment: None,
            tropisms: Vec::new(),
            elasticity_increment: 0.0,
            max_nodes: crate::skeleton::DEFAULT_MAX_NODES,
            left: [0.0, 0.0, 1.0],
            contours: Vec::new(),
            contour_sides: 8,
            twist_of_cylinders: true,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Cmd {
    None,
    Draw,
    Move,
    Turn(f64),
    Pitch(f64),
    Roll(f64),
    TurnAround,
    RollHorizontal,
    /// `$`: closes the innermost open sub-L-system, else rolls to horizontal.
    Dollar,
    /// `?(n, scale)`: opens a sub-L-system (saves the state, scales lengths).
    SubStart,
    Push,
    Pop,
    Width,
    WidthUp,
    Material(i32),
    Elasticity,
    SetElasticity,
    MoveTo,
    SetHeading,
    PolygonStart,
    PolygonEnd,
    Vertex,
    Surface,
    Sphere,
    Disc,
    CylinderStart,
    CylinderPoint,
    CylinderEnd,
    /// `@#(n)`: selects contour n for generalized cylinders.
    Contour,
    Query,
}

#[derive(Debug, Clone, Copy)]
struct State {
    pos: DVec3,
    h: DVec3,
    l: DVec3,
    u: DVec3,
    width: f64,
    node: u32,
    order: u16,
    material: u32,
    elasticity: [f64; MAX_TROPISMS],
    /// Last node of the open generalized cylinder (`@Gs` … `@Ge`), if any.
    gc: u32,
    /// Length scale of the open sub-L-systems (`?(n, scale)`), 1 outside them.
    scale: f64,
    /// The selected contour (`@#`): an index into the run's shapes, 0 the circle.
    contour: u32,
    /// The open contour-swept generalized cylinder (an index into the run's sweeps), or
    /// [`NO_PARENT`].
    sweep: u32,
    /// How many control points of that sweep this state has seen.
    sweep_seen: u32,
    /// Set in a branch (`[`) opened inside a sweep: its first control point forks the
    /// sweep from the last point seen, as cpfg's spline stack does.
    sweep_branch: bool,
}

/// A control point of a contour-swept generalized cylinder.
#[derive(Debug, Clone, Copy)]
struct SweepPoint {
    pos: DVec3,
    h: DVec3,
    u: DVec3,
    radius: f64,
    /// Index of the contour (shape) at this point.
    shape: u32,
    /// Rings drawn from the previous control point to this one (`@Gc(n)`).
    rings: u32,
}

/// A contour-swept generalized cylinder being traced.
#[derive(Debug, Clone)]
struct Sweep {
    points: Vec<SweepPoint>,
    node: u32,
    material: u32,
    /// The module that started it, for messages.
    module: usize,
}

/// Most rings one `@Gc(n)` / `@Ge(n)` segment may ask for.
const MAX_RINGS: u32 = 256;

/// True for the moves that record a polygon vertex (`F`, `f`; not `G`, `g`).
fn sym_is_recording(name: &str) -> bool {
    name == "F" || name == "f"
}

/// Bends the heading toward every tropism (ABOP §2.2: α = e·‖H × T‖ about H × T),
/// never past the target direction; then rebuilds an orthonormal frame.
fn apply_tropisms(st: &mut State, tropisms: &[(DVec3, Option<f64>)]) {
    for (k, &(t, cone)) in tropisms.iter().enumerate() {
        let e = st.elasticity[k];
        if e == 0.0 || t == DVec3::ZERO {
            continue;
        }
        let axis = st.h.cross(t);
        let sin = axis.length();
        if sin < 1e-12 {
            continue;
        }
        let theta = st.h.dot(t).clamp(-1.0, 1.0).acos();
        // Plagiotropism: the target is the cone at angle A around T.
        let (gap, strength) = match cone {
            None => (theta, sin),
            Some(a) => (theta - a, (theta - a).sin()),
        };
        let mut alpha = e * strength;
        // Never turn past the target direction.
        if gap >= 0.0 {
            alpha = alpha.clamp(0.0, gap);
        } else {
            alpha = alpha.clamp(gap, 0.0);
        }
        let q = glam::DQuat::from_axis_angle(axis / sin, alpha);
        st.h = (q * st.h).normalize();
        st.l = q * st.l;
        st.u = st.h.cross(st.l).normalize();
        st.l = st.u.cross(st.h).normalize();
    }
}

/// Rotates the pair (a, b) by angle (cos c, sin s): a' = a c + b s, b' = −a s + b c.
#[inline]
fn rotate(a: &mut DVec3, b: &mut DVec3, c: f64, s: f64) {
    let na = *a * c + *b * s;
    let nb = *b * c - *a * s;
    *a = na;
    *b = nb;
}

fn command(name: &str) -> Cmd {
    match name {
        "F" | "G" => Cmd::Draw,
        "f" | "g" => Cmd::Move,
        "+" => Cmd::Turn(1.0),
        "-" => Cmd::Turn(-1.0),
        "&" => Cmd::Pitch(1.0),
        "^" => Cmd::Pitch(-1.0),
        "/" => Cmd::Roll(1.0),
        "\\" => Cmd::Roll(-1.0),
        "|" => Cmd::TurnAround,
        "$" => Cmd::Dollar,
        "?" => Cmd::SubStart,
        "[" => Cmd::Push,
        "]" => Cmd::Pop,
        "!" => Cmd::Width,
        "#" => Cmd::WidthUp,
        ";" => Cmd::Material(1),
        "," => Cmd::Material(-1),
        "_" => Cmd::Elasticity,
        "@Ts" => Cmd::SetElasticity,
        "@M" => Cmd::MoveTo,
        "@R" => Cmd::SetHeading,
        "@v" => Cmd::RollHorizontal,
        "{" => Cmd::PolygonStart,
        "}" => Cmd::PolygonEnd,
        "." => Cmd::Vertex,
        "@O" => Cmd::Sphere,
        "@o" | "@c" => Cmd::Disc,
        "?P" | "?H" | "?U" | "?L" | "?E" => Cmd::Query,
        "@Gs" => Cmd::CylinderStart,
        "@Gc" => Cmd::CylinderPoint,
        "@Ge" => Cmd::CylinderEnd,
        "@#" => Cmd::Contour,
        n if n.starts_with('~') => Cmd::Surface,
        _ => Cmd::None,
    }
}

/// Deepest nesting of branches (`[`, and sub-L-systems `?(n)`) and of polygons (`{`)
/// the turtle follows (issue 39): each open level saves the turtle's state (about 220
/// bytes) or a polygon, so a string of millions of unclosed `[` would otherwise need
/// gigabytes. A million levels (about 220 MB of saved states) is far more than any
/// plant nests; deeper strings are a budget error naming the module.
pub const MAX_NESTING: usize = 1_000_000;

/// Interprets `string` (whose symbols are named by `symbols`) into a skeleton.
/// `source` is only used to name the file in error messages.
pub fn interpret(
    symbols: &Symbols,
    string: &ModuleString,
    opts: &TurtleOptions,
    source: &Source,
) -> Result<Skeleton, Box<LsystemError>> {
    interpret_with(symbols, string, opts, source, &mut |_, _| {})
}

/// Like [`interpret`], and also calls `on_draw(start, end)` with the exact `f64` end
/// points of every drawn internode (the skeleton stores `f32`), for measurements that
/// need double precision.
pub fn interpret_with(
    symbols: &Symbols,
    string: &ModuleString,
    opts: &TurtleOptions,
    source: &Source,
    on_draw: &mut dyn FnMut(DVec3, DVec3),
) -> Result<Skeleton, Box<LsystemError>> {
    run(symbols, string, opts, source, on_draw, &mut |_, _| {})
}

/// The turtle state a query module sees: position, heading, up, left.
pub type QueryState = [DVec3; 4];

/// Answers cpfg's query modules (`?P` position, `?H` heading, `?U` up, `?L` left): runs
/// the turtle over `string` and writes the turtle's state at each query module into its
/// parameters (x, y, z, as many as the module has). cpfg does this after every
/// derivation step, so productions can react to where a module is. With `env`, the
/// same run also collects the communication modules `?E` and lets the environmental
/// program answer them (their parameters are overwritten with its responses).
pub fn answer_queries(
    symbols: &Symbols,
    string: &mut ModuleString,
    opts: &TurtleOptions,
    source: &Source,
    env: Option<&Environment>,
) -> Result<(), Box<LsystemError>> {
    answer_queries_within(symbols, string, opts, source, env, u64::MAX).map(|_| ())
}

/// [`answer_queries`] whose environmental program may do at most `work` units of work
/// (neighbour tests); returns the work it did. Past the limit the error is a
/// [`ErrorKind::Budget`] naming the derivation's work budget.
pub fn answer_queries_within(
    symbols: &Symbols,
    string: &mut ModuleString,
    opts: &TurtleOptions,
    source: &Source,
    env: Option<&Environment>,
    work: u64,
) -> Result<u64, Box<LsystemError>> {
    // The query pass draws the whole string: the node budget does not apply to it.
    let opts = &TurtleOptions { max_nodes: usize::MAX, ..opts.clone() };
    let names = ["?P", "?H", "?U", "?L", "?E"];
    let which: Vec<Option<usize>> =
        (0..symbols.len()).map(|i| names.iter().position(|n| *n == symbols.name(i as u16))).collect();
    if which.iter().all(|w| w.is_none() || (env.is_none() && *w == Some(4))) {
        return Ok(0);
    }
    // Reserved fallibly before the run (issue 39): a string of hundreds of millions of
    // query modules is an error naming the module budget, not an abort.
    let queries = string.syms.iter().filter(|&&s| which[s as usize].is_some()).count();
    let mut found: Vec<(usize, QueryState)> = Vec::new();
    let (mut at, mut sensors): (Vec<usize>, Vec<Sensor>) = (Vec::new(), Vec::new());
    let sensed = if env.is_some() { queries } else { 0 };
    if found.try_reserve_exact(queries).is_err()
        || at.try_reserve_exact(sensed).is_err()
        || sensors.try_reserve_exact(sensed).is_err()
    {
        return Err(source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the string's {queries} query modules (`?P`, `?H`, `?U`, `?L`, `?E`) need more memory \
                     than is available to answer: {} bytes",
                    queries.saturating_mul(std::mem::size_of::<(usize, QueryState)>())
                ),
            )
            .with_help(
                "derive fewer steps (-n), or lower the module budget with --set generator.max_modules=N",
            ));
    }
    run(symbols, string, opts, source, &mut |_, _| {}, &mut |i, st| found.push((i, st)))?;
    // The `?E` modules: their indices in the string and what the environment sees.
    for (i, st) in found {
        let range = string.pofs[i] as usize..string.pofs[i + 1] as usize;
        match which[string.syms[i] as usize] {
            Some(4) if env.is_some() => {
                at.push(i);
                sensors.push(Sensor { position: st[0], values: string.params[range].to_vec() });
            }
            Some(4) => {}
            Some(k) => {
                let v = st[k];
                for (slot, c) in string.params[range].iter_mut().zip([v.x, v.y, v.z]) {
                    *slot = c;
                }
            }
            None => {}
        }
    }
    let mut used = 0;
    if let Some(env) = env {
        used = env.respond_within(&mut sensors, work).map_err(|limit| {
            source.error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the environmental program's work budget is used up: its {} sensors need more than {limit} \
                     neighbour tests (the derivation's work budget is left for them)",
                    sensors.len()
                ),
            )
        })?;
        for (&i, s) in at.iter().zip(sensors) {
            let range = string.pofs[i] as usize..string.pofs[i + 1] as usize;
            // The module keeps its arity: answers beyond it are dropped.
            for (slot, v) in string.params[range].iter_mut().zip(s.values) {
                *slot = v;
            }
        }
    }
    Ok(used)
}

fn run(
    symbols: &Symbols,
    string: &ModuleString,
    opts: &TurtleOptions,
    source: &Source,
    on_draw: &mut dyn FnMut(DVec3, DVec3),
    on_query: &mut dyn FnMut(usize, QueryState),
) -> Result<Skeleton, Box<LsystemError>> {
    let fail = |what: String| source.error_nowhere(ErrorKind::NonFinite, &what);
    // A branch or polygon opened past [`MAX_NESTING`] levels, or whose saved state
    // cannot be allocated.
    let too_deep = |i: usize, what: &str| {
        source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "module {i} of the derived string opens {what} more than {MAX_NESTING} levels deep, the \
                     turtle's limit on nesting (each open level keeps a saved state)"
                ),
            )
            .with_help("close the branches the grammar opens (`[` … `]`), or derive fewer steps (-n)")
    };
    for (name, v) in [
        ("angle", opts.angle),
        ("step", opts.step),
        ("width", opts.width),
        ("width factor", opts.width_factor),
    ] {
        if !v.is_finite() {
            return Err(fail(format!("turtle {name} is not a finite number")));
        }
    }
    if opts.width < 0.0 {
        return Err(fail(format!("turtle width {} is negative", opts.width)));
    }
    let cmds: Vec<Cmd> = (0..symbols.len()).map(|i| command(symbols.name(i as u16))).collect();
    let (dsin, dcos) = opts.angle.to_radians().sin_cos();
    let mut sk = Skeleton::new();
    let draws = string.syms.iter().filter(|&&s| cmds[s as usize] == Cmd::Draw).count();
    // Each `F` makes a node (and a branch from a new place a root too): at most 2 per draw.
    if draws > opts.max_nodes {
        return Err(source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the string draws {draws} internodes: more than the skeleton node budget of {} nodes \
                     (`generator.max_nodes`)",
                    opts.max_nodes
                ),
            )
            .with_help(crate::skeleton::NODE_BUDGET_HELP));
    }
    // Fallibly (issue 39): the query pass has no node budget, so its skeleton may be
    // as large as the string.
    if sk.position.try_reserve_exact(draws + 1).is_err()
        || sk.radius.try_reserve_exact(draws + 1).is_err()
        || sk.parent.try_reserve_exact(draws + 1).is_err()
        || sk.up.try_reserve_exact(draws + 1).is_err()
        || sk.order.try_reserve_exact(draws + 1).is_err()
        || sk.material.try_reserve_exact(draws + 1).is_err()
    {
        return Err(source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the string draws {draws} internodes: the turtle's skeleton of as many nodes needs more \
                     memory than is available"
                ),
            )
            .with_help(
                "derive fewer steps (-n), or lower the module budget with --set generator.max_modules=N",
            ));
    }
    let left = DVec3::from(opts.left)
        .try_normalize()
        .filter(|l| l.is_finite() && l.dot(DVec3::Y).abs() < 1e-9)
        .unwrap_or(DVec3::Z);
    let mut st = State {
        pos: DVec3::ZERO,
        h: DVec3::Y,
        l: left,
        u: DVec3::Y.cross(left),
        width: opts.width,
        node: NO_PARENT,
        order: 0,
        material: 0,
        elasticity: [0.0; MAX_TROPISMS],
        gc: NO_PARENT,
        scale: 1.0,
        contour: 0,
        sweep: NO_PARENT,
        sweep_seen: 0,
        sweep_branch: false,
    };
    // Shape 0 is the circle (cpfg's default contour: cos, sin from angle 0), then the
    // view file's contours in order.
    let sides = opts.contour_sides.clamp(3, super::files::contour::MAX_SIDES);
    let mut shapes: Vec<(Vec<DVec2>, bool, i32)> = vec![(
        (0..sides)
            .map(|k| {
                let (s, c) = (std::f64::consts::TAU * k as f64 / sides as f64).sin_cos();
                DVec2::new(c, s)
            })
            .collect(),
        true,
        0,
    )];
    for c in &opts.contours {
        shapes.push((c.points.iter().map(|p| DVec2::from_array(*p)).collect(), c.closed, c.id));
    }
    let mut sweeps: Vec<Sweep> = Vec::new();
    for (k, t) in opts.tropisms.iter().enumerate() {
        st.elasticity[k] = t.elasticity;
    }
    // Root nodes by exact position (see `Cmd::Draw`).
    let mut roots: std::collections::HashMap<[u64; 3], u32> = std::collections::HashMap::new();
    let tropisms: Vec<(DVec3, Option<f64>)> = opts
        .tropisms
        .iter()
        .map(|t| (DVec3::from_array(t.direction).normalize_or_zero(), t.angle.map(f64::to_radians)))
        .collect();
    let mut stack: Vec<State> = Vec::new();
    // Stack depths at which the open sub-L-systems saved their state.
    let mut subs: Vec<usize> = Vec::new();
    // Open polygons (a stack: `{` inside `{`), each a list of vertices.
    let mut polygons: Vec<Vec<DVec3>> = Vec::new();
    let mut i = 0;
    let n = string.len();
    while i < n {
        let (sym, p) = string.module(i);
        let arg = p.first().copied();
        match cmds[sym as usize] {
            Cmd::None => {}
            Cmd::Draw | Cmd::Move if !polygons.is_empty() => {
                // Inside a polygon, moves trace its outline instead of branches.
                st.pos += st.h * arg.unwrap_or(opts.step) * st.scale;
                if sym_is_recording(symbols.name(sym)) {
                    polygons.last_mut().expect("non-empty").push(st.pos);
                }
            }
            Cmd::Draw => {
                if st.node == NO_PARENT {
                    // Branches starting where a root already is share it (an axiom
                    // `[F…][F…]` is one plant with several stems, not several plants
                    // whose bases overlap).
                    let key = st.pos.to_array().map(|c| (c + 0.0).to_bits());
                    st.node = match roots.get(&key) {
                        Some(&r) => r,
                        None => {
                            let r = sk.push(
                                st.pos.as_vec3(),
                                (st.width * 0.5) as f32,
                                NO_PARENT,
                                st.u.as_vec3(),
                                st.order,
                            );
                            *sk.material.last_mut().expect("just pushed") = st.material;
                            roots.insert(key, r);
                            r
                        }
                    };
                }
                let start = st.pos;
                st.pos += st.h * arg.unwrap_or(opts.step) * st.scale;
                on_draw(start, st.pos);
                st.node =
                    sk.push(st.pos.as_vec3(), (st.width * 0.5) as f32, st.node, st.u.as_vec3(), st.order);
                *sk.material.last_mut().expect("just pushed") = st.material;
                if !tropisms.is_empty() {
                    apply_tropisms(&mut st, &tropisms);
                }
            }
            Cmd::Move => {
                st.pos += st.h * arg.unwrap_or(opts.step) * st.scale;
                st.node = NO_PARENT;
            }
            Cmd::Turn(sign) | Cmd::Pitch(sign) | Cmd::Roll(sign) => {
                let (s, c) = match arg {
                    Some(a) => a.to_radians().sin_cos(),
                    None => (dsin, dcos),
                };
                let s = s * sign;
                match cmds[sym as usize] {
                    Cmd::Turn(_) => rotate(&mut st.h, &mut st.l, c, s),
                    // Pitch down (+): H toward −U, i.e. U toward H.
                    Cmd::Pitch(_) => rotate(&mut st.u, &mut st.h, c, s),
                    _ => rotate(&mut st.l, &mut st.u, c, s),
                }
            }
            Cmd::TurnAround => {
                st.h = -st.h;
                st.l = -st.l;
            }
            Cmd::SubStart if !p.is_empty() => {
                // A sub-L-system is drawn like a branch, its lengths scaled.
                if stack.len() >= MAX_NESTING || stack.try_reserve(1).is_err() || subs.try_reserve(1).is_err()
                {
                    return Err(too_deep(i, "a sub-L-system (`?`)"));
                }
                subs.push(stack.len());
                stack.push(st);
                let s = p.get(1).copied().unwrap_or(1.0);
                if !(s.is_finite() && s > 0.0) {
                    return Err(fail(format!(
                        "module {i} (`?`) calls a sub-L-system with scale {s}; it must be > 0"
                    )));
                }
                st.scale *= s;
            }
            Cmd::SubStart => {}
            Cmd::Dollar if !subs.is_empty() => {
                let depth = subs.pop().expect("non-empty");
                if stack.len() <= depth {
                    return Err(source.error_nowhere(
                        ErrorKind::Syntax,
                        &format!("module {i} of the derived string (`$`) closes a sub-L-system across a `]`"),
                    ));
                }
                stack.truncate(depth + 1);
                st = stack.pop().expect("depth < len");
            }
            Cmd::RollHorizontal | Cmd::Dollar => {
                let l = DVec3::Y.cross(st.h);
                if l.length_squared() > 1e-24 {
                    st.l = l.normalize();
                    st.h = st.h.normalize();
                    st.u = st.h.cross(st.l);
                }
            }
            Cmd::Push => {
                if stack.len() >= MAX_NESTING || stack.try_reserve(1).is_err() {
                    return Err(too_deep(i, "a branch (`[`)"));
                }
                stack.push(st);
                st.order = st.order.saturating_add(1);
                st.sweep_branch = st.sweep != NO_PARENT;
            }
            Cmd::Pop => match stack.pop() {
                Some(s) => st = s,
                None => {
                    return Err(source.error_nowhere(
                        ErrorKind::Syntax,
                        &format!("module {i} of the derived string is a `]` without a matching `[`"),
                    ))
                }
            },
            Cmd::Width => {
                st.width = arg.unwrap_or(match opts.width_increment {
                    Some(d) => (st.width - d).max(0.0),
                    None => st.width * opts.width_factor,
                });
                if st.width < 0.0 {
                    return Err(fail(format!(
                        "module {i} of the derived string (`!({})`) sets a negative width",
                        st.width
                    )));
                }
            }
            Cmd::WidthUp => {
                st.width = arg.unwrap_or(match opts.width_increment {
                    Some(d) => st.width + d,
                    None => st.width / opts.width_factor.max(1e-9),
                });
                if st.width < 0.0 {
                    return Err(fail(format!("module {i} (`#`) sets a negative width {}", st.width)));
                }
            }
            Cmd::Material(step) => {
                st.material = match arg {
                    Some(v) => v.max(0.0) as u32,
                    None => st.material.saturating_add_signed(step),
                };
            }
            Cmd::Elasticity => {
                for k in 0..tropisms.len() {
                    st.elasticity[k] = arg.unwrap_or(st.elasticity[k] + opts.elasticity_increment);
                }
            }
            Cmd::SetElasticity => {
                // @Ts(i, e): tropism i (1-based); @Ts(e) sets the first.
                let (k, e) = match p {
                    [i, e, ..] => (*i as i64 - 1, *e),
                    [e] => (0, *e),
                    [] => (0, 0.0),
                };
                if k >= 0 && (k as usize) < tropisms.len() {
                    st.elasticity[k as usize] = e;
                }
            }
            Cmd::MoveTo => {
                if let [x, y, z, ..] = p {
                    st.pos = DVec3::new(*x, *y, *z);
                    st.node = NO_PARENT;
                }
            }
            Cmd::SetHeading => {
                if let [hx, hy, hz, rest @ ..] = p {
                    let h = DVec3::new(*hx, *hy, *hz).normalize_or_zero();
                    if h != DVec3::ZERO {
                        let up = match rest {
                            [ux, uy, uz, ..] => DVec3::new(*ux, *uy, *uz),
                            _ => st.u,
                        };
                        let mut u = (up - h * up.dot(h)).normalize_or_zero();
                        if u == DVec3::ZERO {
                            u = h.any_orthonormal_vector();
                        }
                        st.h = h;
                        st.u = u;
                        st.l = u.cross(h);
                    }
                }
            }
            Cmd::Query => on_query(i, [st.pos, st.h, st.u, st.l]),
            Cmd::Contour => {
                let n = arg.unwrap_or(0.0);
                if !n.is_finite() {
                    return Err(fail(format!(
                        "module {i} (`@#({n})`) selects a contour that is not a number"
                    )));
                }
                let id = n.round() as i64;
                st.contour = if id == 0 {
                    0
                } else {
                    match opts.contours.iter().position(|c| i64::from(c.id) == id) {
                        Some(k) if opts.contours[k].error.is_some() => {
                            return Err(source.error_nowhere(
                                ErrorKind::Syntax,
                                &format!(
                                    "module {i} of the derived string (`@#({id})`) selects contour {id}, which cannot \
                                     be used: {}",
                                    opts.contours[k].error.as_deref().unwrap_or("")
                                ),
                            ));
                        }
                        Some(k) => k as u32 + 1,
                        None => {
                            let declared: Vec<String> =
                                opts.contours.iter().map(|c| c.id.to_string()).collect();
                            return Err(source.error_nowhere(
                                ErrorKind::OutOfRange,
                                &format!(
                                    "module {i} of the derived string (`@#({id})`) selects contour {id}, but the view \
                                     file declares no `contour: {id} file.con` line (declared: {})",
                                    if declared.is_empty() { "none".to_string() } else { declared.join(", ") }
                                ),
                            ));
                        }
                    }
                };
            }
            Cmd::CylinderStart | Cmd::CylinderPoint | Cmd::CylinderEnd
                if st.contour != 0 || st.sweep != NO_PARENT =>
            {
                if st.gc != NO_PARENT {
                    let e = source.error_nowhere(
                        ErrorKind::Unsupported,
                        &format!(
                            "unsupported: module {i} of the derived string (`{}`) switches a generalized cylinder \
                             started with the circle to a contour (`@#` before its `@Gs`)",
                            symbols.name(sym)
                        ),
                    );
                    return Err(e);
                }
                let rings = match arg {
                    Some(r) if r.is_finite() => (r.round().max(1.0) as u32).min(MAX_RINGS),
                    _ => 1,
                };
                let point = SweepPoint {
                    pos: st.pos,
                    h: st.h,
                    u: st.u,
                    radius: st.width * 0.5,
                    shape: st.contour,
                    rings,
                };
                let kind = cmds[sym as usize];
                let open = st.sweep != NO_PARENT && kind != Cmd::CylinderStart;
                if open
                    && !st.sweep_branch
                    && sweeps[st.sweep as usize].points.len() == st.sweep_seen as usize
                {
                    sweeps[st.sweep as usize].points.push(point);
                    st.sweep_seen += 1;
                } else {
                    // A new sweep (`@Gs`, or `@Gc` with none open, as cpfg starts one), or a
                    // branch continuing its parent's: it starts from the last point it saw.
                    let mut points = Vec::new();
                    if open {
                        points.push(sweeps[st.sweep as usize].points[st.sweep_seen as usize - 1]);
                    }
                    points.push(point);
                    st.sweep_seen = points.len() as u32;
                    st.sweep_branch = false;
                    st.sweep = sweeps.len() as u32;
                    sweeps.push(Sweep { points, node: st.node, material: st.material, module: i });
                }
                if kind == Cmd::CylinderEnd {
                    st.sweep = NO_PARENT;
                    st.sweep_seen = 0;
                }
            }
            Cmd::CylinderStart => {
                st.gc =
                    sk.push(st.pos.as_vec3(), (st.width * 0.5) as f32, NO_PARENT, st.u.as_vec3(), st.order);
                *sk.material.last_mut().expect("just pushed") = st.material;
            }
            Cmd::CylinderPoint | Cmd::CylinderEnd => {
                if st.gc != NO_PARENT {
                    let prev = sk.position[st.gc as usize].as_dvec3();
                    on_draw(prev, st.pos);
                    st.gc =
                        sk.push(st.pos.as_vec3(), (st.width * 0.5) as f32, st.gc, st.u.as_vec3(), st.order);
                    *sk.material.last_mut().expect("just pushed") = st.material;
                    if matches!(cmds[sym as usize], Cmd::CylinderEnd) {
                        st.gc = NO_PARENT;
                    }
                }
            }
            Cmd::PolygonStart => {
                if polygons.len() >= MAX_NESTING || polygons.try_reserve(1).is_err() {
                    return Err(too_deep(i, "a polygon (`{`)"));
                }
                polygons.push(vec![st.pos]);
            }
            Cmd::Vertex => {
                if let Some(poly) = polygons.last_mut() {
                    if poly.last().is_none_or(|v| v.distance(st.pos) > 1e-12) {
                        poly.push(st.pos);
                    }
                }
            }
            Cmd::PolygonEnd => {
                if let Some(mut poly) = polygons.pop() {
                    if poly.len() > 3 && poly[0].distance(*poly.last().expect("non-empty")) < 1e-9 {
                        poly.pop();
                    }
                    if poly.len() >= 3 {
                        sk.organs.push(Organ {
                            kind: OrganKind::Polygon(poly.iter().map(|v| v.as_vec3()).collect()),
                            node: st.node,
                            position: poly[0].as_vec3(),
                            heading: st.h.as_vec3(),
                            up: st.u.as_vec3(),
                            size: 1.0,
                            material: st.material,
                        });
                    }
                }
            }
            Cmd::Surface | Cmd::Sphere | Cmd::Disc => {
                let name = symbols.name(sym);
                let (kind, size) = match cmds[sym as usize] {
                    Cmd::Surface => (OrganKind::Surface(name[1..].to_string()), arg.unwrap_or(1.0)),
                    Cmd::Sphere => (OrganKind::Sphere, arg.unwrap_or(st.width) * 0.5),
                    _ => (OrganKind::Disc, arg.unwrap_or(st.width) * 0.5),
                };
                let size = size * st.scale;
                if !size.is_finite() || size < 0.0 {
                    return Err(fail(format!(
                        "module {i} (`{name}`) has a negative or non-finite size {size}"
                    )));
                }
                sk.organs.push(Organ {
                    kind,
                    node: st.node,
                    position: st.pos.as_vec3(),
                    heading: st.h.as_vec3(),
                    up: st.u.as_vec3(),
                    size: size as f32,
                    material: st.material,
                });
            }
        }
        i += 1;
    }
    let budget = opts.max_nodes.saturating_mul(16);
    let mut used = 0usize;
    for sw in &sweeps {
        if let Some(organ) = sweep_organ(sw, &shapes, opts.twist_of_cylinders, source, &mut used, budget)? {
            sk.organs.push(organ);
        }
    }
    sk.validate().map_err(|e| fail(format!("the turtle produced an invalid skeleton: {e}")))?;
    Ok(sk)
}

/// The rotation-minimizing transport of `up` from heading `from` to heading `to`
/// (the smallest rotation taking `from` to `to`, applied to `up`), made perpendicular
/// to `to`.
fn transport(up: DVec3, from: DVec3, to: DVec3) -> DVec3 {
    let q = glam::DQuat::from_rotation_arc(from.normalize_or_zero(), to.normalize_or_zero());
    let u = q * up;
    (u - to * u.dot(to)).try_normalize().unwrap_or_else(|| to.any_orthonormal_vector())
}

/// Turns a traced contour-swept generalized cylinder into a [`OrganKind::Swept`] organ
/// (see the module docs and `docs/lsystem.md` for the placement and interpolation);
/// `None` when it has fewer than two control points or no length. `used` counts the
/// ring points made so far, which may not pass `budget`.
fn sweep_organ(
    sw: &Sweep,
    shapes: &[(Vec<DVec2>, bool, i32)],
    twist: bool,
    source: &Source,
    used: &mut usize,
    budget: usize,
) -> Result<Option<Organ>, Box<LsystemError>> {
    let closed = shapes[sw.points[0].shape as usize].1;
    if let Some(p) = sw.points.iter().find(|p| shapes[p.shape as usize].1 != closed) {
        let (a, b) = if closed { ("closed", "open") } else { ("open", "closed") };
        let e = source.error_nowhere(
            ErrorKind::Unsupported,
            &format!(
                "unsupported: the generalized cylinder started at module {} mixes {a} and {b} contours (contour {} \
                 is {b}); cpfg blends contours of the same kind only",
                sw.module,
                shapes[p.shape as usize].2
            ),
        );
        return Err(e);
    }
    if sw.points.len() < 2 {
        return Ok(None);
    }
    // Frames per control point: the turtle's own, or transported when twist is off.
    let mut pts = sw.points.clone();
    for k in 0..pts.len() {
        pts[k].h = pts[k].h.try_normalize().unwrap_or(DVec3::Y);
        pts[k].u = if twist || k == 0 {
            (pts[k].u - pts[k].h * pts[k].u.dot(pts[k].h))
                .try_normalize()
                .unwrap_or_else(|| pts[k].h.any_orthonormal_vector())
        } else {
            transport(pts[k - 1].u, pts[k - 1].h, pts[k].h)
        };
    }
    let ring =
        |pos: DVec3, h: DVec3, u: DVec3, r: f64, a: &[DVec2], b: &[DVec2], t: f64| -> Vec<glam::Vec3> {
            // Contour x along up, y along −left (cpfg's make_contour).
            let l = u.cross(h);
            a.iter()
                .zip(b)
                .map(|(p, q)| (pos + (u * p.lerp(*q, t).x - l * p.lerp(*q, t).y) * r).as_vec3())
                .collect()
        };
    let shape = |p: &SweepPoint| shapes[p.shape as usize].0.as_slice();
    let first = &pts[0];
    let mut rings = vec![ring(first.pos, first.h, first.u, first.radius, shape(first), shape(first), 0.0)];
    let mut centres = vec![first.pos];
    for w in pts.windows(2) {
        let (p0, p1) = (&w[0], &w[1]);
        let chord = p0.pos.distance(p1.pos);
        if chord < 1e-12 {
            continue; // coincident control points draw nothing (as in cpfg)
        }
        let (a, b) = (shape(p0), shape(p1));
        let b = if a.len() == b.len() { b } else { a };
        // The twist from p0's transported frame to p1's, shared out along the segment.
        let carried = transport(p0.u, p0.h, p1.h);
        let twist_angle = carried.cross(p1.u).dot(p1.h).atan2(carried.dot(p1.u));
        let (m0, m1) = (p0.h * chord, p1.h * chord);
        for k in 1..=p1.rings {
            let t = k as f64 / p1.rings as f64;
            let (pos, h, u) = if k == p1.rings {
                (p1.pos, p1.h, p1.u)
            } else {
                // Cubic Hermite through the two points with the turtle's headings as
                // tangents (scaled by the chord), as cpfg's `@Gc(n)` rings are.
                let (t2, t3) = (t * t, t * t * t);
                let pos = p0.pos * (2.0 * t3 - 3.0 * t2 + 1.0)
                    + m0 * (t3 - 2.0 * t2 + t)
                    + p1.pos * (-2.0 * t3 + 3.0 * t2)
                    + m1 * (t3 - t2);
                let d = (p0.pos - p1.pos) * (6.0 * t2 - 6.0 * t)
                    + m0 * (3.0 * t2 - 4.0 * t + 1.0)
                    + m1 * (3.0 * t2 - 2.0 * t);
                let h = d.try_normalize().unwrap_or(p0.h.lerp(p1.h, t).normalize_or(p1.h));
                let u = transport(p0.u, p0.h, h);
                let u = glam::DQuat::from_axis_angle(h, twist_angle * t) * u;
                (pos, h, u)
            };
            *used += a.len();
            if *used > budget {
                return Err(source
                    .error_nowhere(
                        ErrorKind::Budget,
                        &format!(
                            "the generalized cylinders draw more than {budget} contour points (16 per node of the \
                             skeleton node budget)"
                        ),
                    )
                    .with_help(crate::skeleton::NODE_BUDGET_HELP));
            }
            let r = p0.radius + (p1.radius - p0.radius) * t;
            rings.push(ring(pos, h, u, r, a, b, t));
            centres.push(pos);
        }
    }
    if rings.len() < 2 {
        return Ok(None);
    }
    let size: f64 = centres.windows(2).map(|w| w[0].distance(w[1])).sum();
    Ok(Some(Organ {
        kind: OrganKind::Swept(crate::skeleton::SweptSurface { rings, closed }),
        node: sw.node,
        position: first.pos.as_vec3(),
        heading: first.h.as_vec3(),
        up: first.u.as_vec3(),
        size: size as f32,
        material: sw.material,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lsystem::derive::DeriveOptions;
    use crate::lsystem::parse::LSystem;

    fn run(axiom: &str) -> Skeleton {
        let text = format!("Lsystem: 1\nAxiom: {axiom}\nendlsystem\n");
        let ls = LSystem::parse("t.l", &text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 0, budget: 1000, seed: 0 }).unwrap();
        interpret(&ls.symbols, &m, &TurtleOptions { angle: 90.0, ..Default::default() }, &ls.source).unwrap()
    }

    fn run_with(axiom: &str, opts: &TurtleOptions) -> Skeleton {
        let text = format!("Lsystem: 1\nAxiom: {axiom}\nendlsystem\n");
        let ls = LSystem::parse("t.l", &text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 0, budget: 10_000, seed: 0 }).unwrap();
        interpret(&ls.symbols, &m, opts, &ls.source).unwrap()
    }

    fn close(a: glam::Vec3, b: [f32; 3]) -> bool {
        a.distance(glam::Vec3::from(b)) < 1e-5
    }

    #[test]
    fn heading_and_sign_conventions() {
        let s = run("F");
        assert!(close(s.position[1], [0.0, 1.0, 0.0]), "initial heading is +Y");
        let s = run("+F");
        assert!(close(s.position[1], [0.0, 0.0, 1.0]), "+ turns H toward L = +Z");
        let s = run("-F");
        assert!(close(s.position[1], [0.0, 0.0, -1.0]));
        let s = run("&F");
        assert!(close(s.position[1], [-1.0, 0.0, 0.0]), "& pitches H toward -U = -X");
        let s = run("^F");
        assert!(close(s.position[1], [1.0, 0.0, 0.0]));
        let s = run("/+F");
        assert!(close(s.position[1], [1.0, 0.0, 0.0]), "/ rolls L toward U");
        let s = run("\\+F");
        assert!(close(s.position[1], [-1.0, 0.0, 0.0]));
        let s = run("|F");
        assert!(close(s.position[1], [0.0, -1.0, 0.0]));
    }

    #[test]
    fn branches_and_nodes() {
        let s = run("F[+F]F");
        assert_eq!(s.len(), 4);
        assert_eq!(s.parent, vec![NO_PARENT, 0, 1, 1]);
        assert_eq!(s.order, vec![0, 0, 1, 0]);
        let s = run("FfF");
        assert_eq!(s.parent, vec![NO_PARENT, 0, NO_PARENT, 2]);
        assert!(close(s.position[3], [0.0, 3.0, 0.0]));
        // Stems drawn from the same starting point share one root.
        let s = run("[+F][-F]fF");
        assert_eq!(s.parent, vec![NO_PARENT, 0, 0, NO_PARENT, 3]);
    }

    #[test]
    fn width_is_a_diameter() {
        let s = run("!(0.5)F!F");
        assert_eq!(s.radius[1], 0.25);
        assert!((s.radius[2] - 0.175).abs() < 1e-6);
    }

    #[test]
    fn cut_is_erased_by_the_next_step_not_by_the_turtle() {
        // cpfg: `%` erases the rest of its branch in the derivation step after it
        // appears; the turtle draws a string that still holds it unchanged.
        assert_eq!(run("F[F%FF[F]F]F").stats().segments, 7);
        let text = "Lsystem: 1\nAxiom: F[F%FF[F]F]F\nendlsystem\n";
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 1, budget: 100, seed: 0 }).unwrap();
        assert_eq!(ls.format(&m), "F[F]F");
        let s = interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source).unwrap();
        assert_eq!(s.stats().segments, 3);
    }

    #[test]
    fn roll_horizontal() {
        let text = "Lsystem: 1\nAxiom: &(30)/(40)$F\nendlsystem\n";
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 0, budget: 10, seed: 0 }).unwrap();
        let s = interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source).unwrap();
        // After `$`, U is H × L with L horizontal: U's y component is ≥ 0 and L.y = 0.
        assert!(s.up[1].y >= 0.0);
        let h = (s.position[1] - s.position[0]).normalize();
        assert!(h.dot(s.up[1]).abs() < 1e-5);
    }

    #[test]
    fn tropism_bends_monotonically_and_never_past() {
        let down = Tropism { direction: [0.0, -1.0, 0.0], elasticity: 0.3, angle: None };
        let opts = TurtleOptions { tropisms: vec![down], ..Default::default() };
        // A horizontal branch: turn the heading to +Z, then 60 segments.
        let axiom = format!("+(90){}", "F".repeat(60));
        let s = run_with(&axiom, &opts);
        let mut last = -2.0f32;
        for i in 2..s.len() {
            let d = (s.position[i] - s.position[i - 1]).normalize();
            let toward = -d.y; // cos of the angle to T = -Y
            assert!(toward >= last - 1e-6, "monotone toward T at segment {i}");
            assert!(toward <= 1.0 + 1e-6);
            last = toward;
        }
        assert!(last > 0.95, "ends nearly aligned with T: {last}");
        // Zero elasticity leaves it straight.
        let flat =
            TurtleOptions { tropisms: vec![Tropism { elasticity: 0.0, ..down }], ..Default::default() };
        let s = run_with(&axiom, &flat);
        assert!(s.position.iter().all(|p| p.y.abs() < 1e-6));
        // `@Ts(1, 0)` switches it off mid-branch; `_(e)` sets it.
        let s = run_with(&format!("+(90)@Ts(1,0){}", "F".repeat(10)), &opts);
        assert!(s.position.iter().all(|p| p.y.abs() < 1e-6));
        let s = run_with(&format!("+(90)@Ts(1,0)_(0.5){}", "F".repeat(10)), &opts);
        assert!(s.position.last().unwrap().y < -1.0);
    }

    #[test]
    fn organs_polygons_and_moves() {
        let s = run("F[{.-f+f+f-|-f+f+f}]@O(0.4)~l(2)@M(5,0,0)F");
        assert_eq!(s.organs.len(), 3);
        match &s.organs[0].kind {
            OrganKind::Polygon(v) => assert_eq!(v.len(), 6, "{v:?}"),
            k => panic!("{k:?}"),
        }
        assert_eq!(s.organs[1].kind, OrganKind::Sphere);
        assert!((s.organs[1].size - 0.2).abs() < 1e-6);
        assert_eq!(s.organs[2].kind, OrganKind::Surface("l".into()));
        assert_eq!(s.organs[2].size, 2.0);
        // The polygon did not draw branches; @M started a new root at (5,0,0).
        assert_eq!(s.stats().segments, 2);
        assert!(close(s.position[2], [5.0, 0.0, 0.0]));
        assert!(close(s.position[3], [5.0, 1.0, 0.0]));
        let s = run("@R(1,0,0)F");
        assert!(close(s.position[1], [1.0, 0.0, 0.0]));
    }

    #[test]
    fn query_modules_see_the_turtle() {
        let text = "Lsystem: 1\nAxiom: F(2)?P(0,0,0)+(90)?H(0,0,0)\n?P(x,y,z) : y > 1 --> A(y)\nendlsystem\n";
        let ls = LSystem::parse("q.l", text, &[]).unwrap();
        let opts = DeriveOptions { steps: 1, budget: 100, seed: 0 };
        let (m, _) =
            ls.derive_full(&opts, Default::default(), Some(&TurtleOptions::default()), None).unwrap();
        let s = ls.format(&m);
        assert!(s.starts_with("F(2)A(2)+(90)?H(0,"), "{s}");
        assert!(s.contains(",1)"), "heading turned toward +Z: {s}");
    }

    #[test]
    fn unbalanced_pop_is_an_error() {
        let text = "Lsystem: 1\nAxiom: F]F\nendlsystem\n";
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 0, budget: 10, seed: 0 }).unwrap();
        let e = interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source).unwrap_err();
        assert!(e.message.contains("without a matching"));
    }

    #[test]
    fn contour_module_is_one_symbol_and_needs_a_declared_contour() {
        // `@#(0)` selects the circle; read as `@` `#(0)` it would set the width to 0.
        let s = run("@#(0)F");
        assert!((s.radius[1] - 0.05).abs() < 1e-9, "{}", s.radius[1]);
        let text = "Lsystem: 1\nAxiom: @#(3)F\nendlsystem\n";
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 0, budget: 10, seed: 0 }).unwrap();
        let e = interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source).unwrap_err();
        assert!(
            e.message.contains("selects contour 3") && e.message.contains("declared: none"),
            "{}",
            e.message
        );
        let opts = TurtleOptions {
            contours: vec![TurtleContour::unusable(3, "x.con:2:1: bad")],
            ..Default::default()
        };
        let e = interpret(&ls.symbols, &m, &opts, &ls.source).unwrap_err();
        assert!(e.message.contains("cannot be used: x.con:2:1: bad"), "{}", e.message);
    }

    fn flat() -> TurtleContour {
        TurtleContour { id: 1, points: vec![[-1.0, 0.0], [0.0, 0.0], [1.0, 0.0]], closed: false, error: None }
    }

    fn swept(s: &Skeleton) -> Vec<&crate::skeleton::SweptSurface> {
        s.organs
            .iter()
            .filter_map(|o| match &o.kind {
                OrganKind::Swept(w) => Some(w),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn contour_cylinders_are_swept_organs_and_branches_fork_them() {
        let opts = TurtleOptions { contours: vec![flat()], ..Default::default() };
        let s = run_with("@#(1)!(1)@Gs f @Gc [+(90) f @Ge] f @Ge", &opts);
        assert_eq!(s.len(), 0, "no skeleton nodes");
        let w = swept(&s);
        assert_eq!(w.len(), 2);
        assert_eq!(w[0].rings.len(), 3, "main: @Gs, @Gc, @Ge");
        assert_eq!(w[1].rings.len(), 2, "branch: from the @Gc, then its @Ge");
        // Contour x along U (+X), scaled by the radius 0.5.
        assert!(close(w[0].rings[0][0], [-0.5, 0.0, 0.0]) && close(w[0].rings[0][2], [0.5, 0.0, 0.0]));
        assert!(close(w[0].rings[2][1], [0.0, 2.0, 0.0]));
        // The branch (a fork from the @Gc) turned toward L (+Z): its end ring is centred
        // at (0, 1, 1); the main surface went on to (0, 2, 0).
        assert!(close(w[1].rings[1][1], [0.0, 1.0, 1.0]), "{:?}", w[1].rings[1]);
        // Hermite rings between control points: @Gc(4) makes four rings per span, on
        // the curve and at equal parameter steps of a straight segment.
        let s = run_with("@#(1)@Gs f(2) @Ge(4)", &opts);
        let w = swept(&s);
        assert_eq!(w[0].rings.len(), 5);
        for (k, r) in w[0].rings.iter().enumerate() {
            assert!(close(r[1], [0.0, 0.5 * k as f32, 0.0]), "{k}: {r:?}");
        }
    }

    #[test]
    fn twist_of_cylinders_decides_whether_rolls_turn_the_contour() {
        for (twist, want) in [(true, [0.0, 1.0, 0.5]), (false, [-0.5, 1.0, 0.0])] {
            let opts =
                TurtleOptions { contours: vec![flat()], twist_of_cylinders: twist, ..Default::default() };
            let s = run_with("@#(1)!(1)@Gs f /(90) @Ge", &opts);
            let w = swept(&s);
            assert!(close(w[0].rings[1][0], want), "twist {twist}: {:?}", w[0].rings[1]);
        }
    }

    #[test]
    fn negative_width_is_an_error() {
        let text = "Lsystem: 1\nAxiom: !(-1)F\nendlsystem\n";
        let ls = LSystem::parse("t.l", text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 0, budget: 10, seed: 0 }).unwrap();
        let e = interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source).unwrap_err();
        assert!(e.message.contains("negative width"));
    }
}
