//! The 3D turtle (ABOP ch. 1.5, McLoughlin2021 §4): interprets a module string into a
//! [`Skeleton`]. The frame is heading H, left L and up U with H × L = U, starting at
//! H = +Y, L = +Z (cpfg `.str` strings: L = −X, MacMurchy2004 property 10,
//! [`TurtleOptions::left`]); positive angles rotate right-handed, in degrees. `F` draws
//! an internode (one skeleton node per end point), `[`/`]` push and pop the state, the
//! width `!(w)` is a diameter; tropism (ABOP §2.2), polygons, organs, sub-L-systems,
//! query modules and contour-swept generalized cylinders (Mech2004) follow cpfg. Every
//! module, the conventions and the errors: `docs/lsystem.md` ("The turtle", "Contours
//! and generalized cylinders"). Here: the options and the entry points; the commands,
//! the run, the sweeps and the queries are in the files below.

use super::parse::Symbols;
use super::source::{LsystemError, Source};
use super::string::ModuleString;
use crate::skeleton::Skeleton;
use glam::DVec3;

mod commands;
pub mod movements;
mod queries;
mod run;
mod sweep;

pub use self::queries::{answer_queries, answer_queries_within};
use self::run::run;

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
    /// Tropisms, at most [`MAX_TROPISMS`], bent by ABOP §2.2's rule after each `F`;
    /// ignored when [`TurtleOptions::cpfg_tropisms`] is set.
    pub tropisms: Vec<Tropism>,
    /// A cpfg view file's tropisms, bent as cpfg bends ([`movements`], issue 46): the
    /// pipeline sets these for a model folder's view file.
    pub cpfg_tropisms: Option<movements::CpfgTropisms>,
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
            cpfg_tropisms: None,
            elasticity_increment: 0.0,
            max_nodes: crate::skeleton::DEFAULT_MAX_NODES,
            left: [0.0, 0.0, 1.0],
            contours: Vec::new(),
            contour_sides: 8,
            twist_of_cylinders: true,
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lsystem::derive::DeriveOptions;
    use crate::lsystem::parse::LSystem;
    use crate::skeleton::{OrganKind, NO_PARENT};

    /// The turtle's skeleton of the axiom `axiom` (no derivation step) with `opts`.
    fn turtle(axiom: &str, opts: &TurtleOptions) -> Result<Skeleton, Box<LsystemError>> {
        let text = format!("Lsystem: 1\nAxiom: {axiom}\nendlsystem\n");
        let ls = LSystem::parse("t.l", &text, &[]).unwrap();
        let m = ls.derive(&DeriveOptions { steps: 0, budget: 10_000, seed: 0 }).unwrap();
        interpret(&ls.symbols, &m, opts, &ls.source)
    }

    fn run(axiom: &str) -> Skeleton {
        turtle(axiom, &TurtleOptions { angle: 90.0, ..Default::default() }).unwrap()
    }

    fn run_with(axiom: &str, opts: &TurtleOptions) -> Skeleton {
        turtle(axiom, opts).unwrap()
    }

    fn close(a: glam::Vec3, b: [f32; 3]) -> bool {
        a.distance(glam::Vec3::from(b)) < 1e-5
    }

    #[test]
    fn heading_and_sign_conventions() {
        for (axiom, want, why) in [
            ("F", [0.0, 1.0, 0.0], "initial heading is +Y"),
            ("+F", [0.0, 0.0, 1.0], "+ turns H toward L = +Z"),
            ("-F", [0.0, 0.0, -1.0], "- turns H away from L"),
            ("&F", [-1.0, 0.0, 0.0], "& pitches H toward -U = -X"),
            ("^F", [1.0, 0.0, 0.0], "^ pitches H toward U"),
            ("/+F", [-1.0, 0.0, 0.0], "/ rolls L away from U, U toward L (cpfg)"),
            ("\\+F", [1.0, 0.0, 0.0], "\\ rolls L toward U"),
            ("|F", [0.0, -1.0, 0.0], "| turns around"),
        ] {
            assert!(close(run(axiom).position[1], want), "{axiom}: {why}");
        }
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
        let s = run_with("&(30)/(40)$F", &TurtleOptions::default());
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
        // Answers are in cpfg's frame: the heading turned toward +Z is cpfg's −X.
        assert!(s.starts_with("F(2)A(2)+(90)?H(-1,"), "{s}");
        assert!(s.ends_with(",0)"), "heading turned toward +Z (cpfg's −X): {s}");
    }

    #[test]
    fn unbalanced_pop_is_an_error() {
        let e = turtle("F]F", &TurtleOptions::default()).unwrap_err();
        assert!(e.message.contains("without a matching"));
    }

    #[test]
    fn contour_module_is_one_symbol_and_needs_a_declared_contour() {
        // `@#(0)` selects the circle; read as `@` `#(0)` it would set the width to 0.
        let s = run("@#(0)F");
        assert!((s.radius[1] - 0.05).abs() < 1e-9, "{}", s.radius[1]);
        let e = turtle("@#(3)F", &TurtleOptions::default()).unwrap_err();
        assert!(
            e.message.contains("selects contour 3") && e.message.contains("declared: none"),
            "{}",
            e.message
        );
        let opts = TurtleOptions {
            contours: vec![TurtleContour::unusable(3, "x.con:2:1: bad")],
            ..Default::default()
        };
        let e = turtle("@#(3)F", &opts).unwrap_err();
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
        // `/(90)` turns U (+X) to +Z (cpfg's roll), so with twist the contour's −x end
        // moves from −X to −Z.
        for (twist, want) in [(true, [0.0, 1.0, -0.5]), (false, [-0.5, 1.0, 0.0])] {
            let opts =
                TurtleOptions { contours: vec![flat()], twist_of_cylinders: twist, ..Default::default() };
            let s = run_with("@#(1)!(1)@Gs f /(90) @Ge", &opts);
            let w = swept(&s);
            assert!(close(w[0].rings[1][0], want), "twist {twist}: {:?}", w[0].rings[1]);
        }
    }

    #[test]
    fn negative_width_is_an_error() {
        let e = turtle("!(-1)F", &TurtleOptions::default()).unwrap_err();
        assert!(e.message.contains("negative width"));
    }
}
