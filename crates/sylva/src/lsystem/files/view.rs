//! cpfg view files (`*.v`): drawing parameters, tropisms and the lists of surfaces,
//! functions and contours a model uses.
//!
//! Part of the model-folder support of issue 3. A view file is a list of `key: value`
//! lines (cpfg `ReadViewData`). cpfg runs it through the C preprocessor first; sylva
//! removes `/* */` and `//` comments the same way and ignores `#` lines (no macro
//! expansion). Keys are matched case-insensitively with runs of blanks collapsed to one
//! space. Values are separated by blanks or commas.
//!
//! # Keys sylva reads
//!
//! | key | value | field |
//! |---|---|---|
//! | `angle factor: n` | the turn angle is 360/n degrees | [`View::angle_increment`] |
//! | `angle increment: d` | the turn angle in degrees | [`View::angle_increment`] |
//! | `initial color: i [j]` | colour index (front, back) | [`View::initial_color`], [`View::initial_color_back`] |
//! | `color increment: i [j]` | change of `;` and `,` | [`View::color_increment`], [`View::color_increment_back`] |
//! | `initial line width: w [pixels]` | width; sets the line style to polygon, or to pixel when a word starting with `p` follows (cylinder with `s…`) | [`View::initial_line_width`], [`View::line_style`] |
//! | `line width increment: d` | change of `!` and `#` | [`View::width_increment`] |
//! | `line style: pixel\|polygon\|cylinder` (or `1`–`3`) | how `F` is drawn; another word keeps the previous style, as in cpfg (models write `wireframe`) | [`View::line_style`] |
//! | `tapered lines: on\|off` | | [`View::tapered_lines`] |
//! | `contour sides: n` | sides of cylinders (at least 3) | [`View::contour_sides`] |
//! | `polygonization level: k` | cylinder sides 2^(k+1) (old form of `contour sides`) | [`View::contour_sides`] |
//! | `twist of cylinders: on\|off` | generalized cylinders twist | [`View::twist_of_cylinders`] |
//! | `contour: id file` | a contour (`*.con`) for generalized cylinders | [`View::contours`] |
//! | `initial scale: s`, `scale multiplier: m` | turtle scale | [`View::initial_scale`], [`View::scale_multiplier`] |
//! | `tropism direction: x,y,z`, `initial elasticity: e`, `elasticity increment: d` | the old single tropism | [`View::old_tropism`] |
//! | `tropism: T: x y z [A: a] [I: i] [E: e] [S: s]` | a tropism (cpfg `movements.c`) | [`View::tropisms`] |
//! | `torque: T: x y z [E: e] [S: s]` | a torque (twist towards a vector) | [`View::tropisms`] |
//! | `surface: c file [scale [s t [texture]]]` | a Bézier surface drawn by `~c` | [`View::surfaces`] |
//! | `line: c file scale [s t [texture]]` | the surface that replaces lines | [`View::line_surface`] |
//! | `function: file [samples]` | a function `func(id, x)` | [`View::functions`] |
//! | `function set: file` | a set of functions (replaces the ones before) | [`View::functions`] |
//! | `curve: file [samples]` | a curve for `curveX/Y/Z` and `curveGAL` (read by [`super::load_folder`]) | [`View::curves`] |
//!
//! Every other key (`viewpoint`, `projection`, `render mode`, `light`, `z buffer`,
//! `scale factor`, `box`, `texture`, …: cpfg has dozens that only affect viewing) is
//! recorded in [`View::ignored`] and is not an error. A value of a key sylva reads that
//! cannot be parsed is an error located at the value; cpfg would print a warning and
//! keep the default. As in cpfg, later lines override earlier ones, and the line style
//! is whatever the last of `initial line width` and `line style` set.
//!
//! Tropisms follow `movements.c`: the fields are single letters after which the rest of
//! the token is ignored (`E:` and `Elasticity:` both mean elasticity); `T` takes three
//! numbers; a zero `T` vector or an unknown letter is an error (cpfg drops the line).
//! Defaults match cpfg's `InitializeParameters`.

use super::{number, strip_comments, tokens, TextFile};
use crate::input::excerpt;
use crate::lsystem::source::LsystemError;

/// How `F` segments are drawn (cpfg `line style:`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// Lines of a width in pixels (cpfg's default).
    #[default]
    Pixel,
    /// Flat polygons of a width in world units.
    Polygon,
    /// Cylinders of a width in world units.
    Cylinder,
}

/// Whether a [`Tropism`] line was `tropism:` or `torque:`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MovementKind {
    /// `tropism:` bends the heading towards (angle 0) or away from the direction.
    Tropism,
    /// `torque:` rolls the turtle about its heading so that up turns towards the direction.
    Torque,
}

/// One `tropism:` or `torque:` line (cpfg `movements.c`).
#[derive(Debug, Clone, PartialEq)]
pub struct Tropism {
    /// Tropism or torque.
    pub kind: MovementKind,
    /// `T:` the direction, normalized to unit length.
    pub direction: [f64; 3],
    /// `I:` intensity (default 1); cpfg scales the unit direction by it, clamped to \[-1, 1\].
    pub intensity: f64,
    /// `A:` the angle in degrees between the direction and the heading the tropism
    /// tends to (0: towards the direction, orthotropism; 90: perpendicular, plagiotropism).
    pub angle: f64,
    /// `E:` initial elasticity (default 0).
    pub elasticity: f64,
    /// `S:` elasticity step, the change applied by `@Ts`/`@Ti` modules (default 0).
    pub elasticity_step: f64,
    /// 1-based line in the view file.
    pub line: usize,
}

/// The old single tropism of `tropism direction:`, `initial elasticity:` and
/// `elasticity increment:` (cpfg `bend()`).
#[derive(Debug, Clone, PartialEq)]
pub struct OldTropism {
    /// The tropism direction, normalized (default +Y).
    pub direction: [f64; 3],
    /// Initial elasticity (default 0).
    pub elasticity: f64,
    /// Change of elasticity per `_` module / branch level (default 0).
    pub elasticity_increment: f64,
}

impl Default for OldTropism {
    fn default() -> Self {
        OldTropism { direction: [0.0, 1.0, 0.0], elasticity: 0.0, elasticity_increment: 0.0 }
    }
}

/// A `surface:` or `line:` line: a Bézier surface file drawn by `~id`.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceRef {
    /// The one-character surface id.
    pub id: char,
    /// The surface file, relative to the folder.
    pub file: String,
    /// Size multiplier (cpfg: the surface's SIZE is scaled to this); ≤ 0 becomes 1.
    pub scale: f64,
    /// Patch subdivisions in s, when given (cpfg clamps to 1..=10).
    pub s_precision: Option<u32>,
    /// Patch subdivisions in t, when given.
    pub t_precision: Option<u32>,
    /// Texture number, when given.
    pub texture: Option<i32>,
    /// 1-based line in the view file.
    pub line: usize,
}

/// A `function:` or `function set:` line.
#[derive(Debug, Clone, PartialEq)]
pub struct FunctionRef {
    /// The `.func` or `.fset` file, relative to the folder.
    pub file: String,
    /// Samples for precomputation (used by the old `range:` format only; cpfg reads
    /// the `samples:` of `fver` files from the file itself).
    pub samples: Option<u32>,
    /// `true` for `function set:`, which replaces the functions listed before it.
    pub is_set: bool,
    /// 1-based line in the view file.
    pub line: usize,
}

/// A `contour:` line (generalized-cylinder cross sections).
#[derive(Debug, Clone, PartialEq)]
pub struct ContourRef {
    /// Contour id, used by `@#(id)`.
    pub id: i32,
    /// The contour file (`*.con`), relative to the folder.
    pub file: String,
    /// 1-based line in the view file.
    pub line: usize,
}

/// The parsed view file. Defaults are cpfg's.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// Turn angle of `+ - & ^ / \` without parameters, in degrees (default 45).
    pub angle_increment: f64,
    /// Initial colour index (default 128, cpfg's).
    pub initial_color: i32,
    /// Initial back-face colour index, when given (two-sided colouring).
    pub initial_color_back: Option<i32>,
    /// Colour index change of `;` and `,` (default 1).
    pub color_increment: i32,
    /// Back-face colour index change, when given.
    pub color_increment_back: Option<i32>,
    /// Initial line width (default 1); in pixels when [`View::line_style`] is `Pixel`.
    pub initial_line_width: f64,
    /// Line width change of `!` and `#` without parameters (default 0).
    pub width_increment: f64,
    /// How lines are drawn.
    pub line_style: LineStyle,
    /// Tapered lines (default on).
    pub tapered_lines: bool,
    /// Number of sides of cylinders (default 8).
    pub contour_sides: u32,
    /// Twist of generalized cylinders (default off).
    pub twist_of_cylinders: bool,
    /// Initial turtle scale (default 1).
    pub initial_scale: f64,
    /// Scale multiplier (default 1).
    pub scale_multiplier: f64,
    /// The old single tropism, when any of its three keys is present.
    pub old_tropism: Option<OldTropism>,
    /// Tropisms and torques in file order (cpfg's movement index order).
    pub tropisms: Vec<Tropism>,
    /// Surfaces in file order.
    pub surfaces: Vec<SurfaceRef>,
    /// The `line:` surface, when given.
    pub line_surface: Option<SurfaceRef>,
    /// Functions and function sets in file order.
    pub functions: Vec<FunctionRef>,
    /// Contours in file order.
    pub contours: Vec<ContourRef>,
    /// `curve:` files (recorded, not read).
    pub curves: Vec<FunctionRef>,
    /// Keys (and other lines) that sylva does not use, as `line N: key`.
    pub ignored: Vec<String>,
}

impl Default for View {
    fn default() -> Self {
        View {
            angle_increment: 45.0,
            initial_color: 128,
            initial_color_back: None,
            color_increment: 1,
            color_increment_back: None,
            initial_line_width: 1.0,
            width_increment: 0.0,
            line_style: LineStyle::Pixel,
            tapered_lines: true,
            contour_sides: 8,
            twist_of_cylinders: false,
            initial_scale: 1.0,
            scale_multiplier: 1.0,
            old_tropism: None,
            tropisms: Vec::new(),
            surfaces: Vec::new(),
            line_surface: None,
            functions: Vec::new(),
            contours: Vec::new(),
            curves: Vec::new(),
            ignored: Vec::new(),
        }
    }
}

/// The values of one `key: value` line, with offsets for errors.
struct Line<'a> {
    file: &'a TextFile,
    key: String,
    /// Offset of the end of the line.
    end: usize,
    toks: Vec<(usize, &'a str)>,
}

impl<'a> Line<'a> {
    fn missing(&self, what: &str) -> Box<LsystemError> {
        self.file.error(self.end, 1, &format!("`{}:` needs {what}", self.key), "value missing here")
    }

    fn bad(&self, i: usize, what: &str) -> Box<LsystemError> {
        let (at, tok) = self.toks[i];
        self.file.error(
            at,
            tok.len(),
            &format!(
                "invalid value for `{}:`: expected {what}, found `{}`",
                excerpt(&self.key),
                excerpt(tok)
            ),
            &format!("expected {what}"),
        )
    }

    fn number(&self, i: usize) -> Result<f64, Box<LsystemError>> {
        match self.toks.get(i) {
            None => Err(self.missing("a number")),
            Some((_, t)) => number(t).ok_or_else(|| self.bad(i, "a number")),
        }
    }

    /// An integer as C's `%d` reads one: a number with its fraction dropped.
    fn int(&self, i: usize) -> Result<i32, Box<LsystemError>> {
        match self.toks.get(i) {
            None => Err(self.missing("an integer")),
            Some((_, t)) => match t.parse::<i64>() {
                Ok(v) if i32::try_from(v).is_ok() => Ok(v as i32),
                _ => match number(t) {
                    Some(v) if v.abs() < 2.0e9 => Ok(v.trunc() as i32),
                    _ => Err(self.bad(i, "an integer")),
                },
            },
        }
    }

    fn optional_int(&self, i: usize) -> Option<i32> {
        self.toks.get(i).and_then(|(_, t)| t.parse::<i32>().ok())
    }

    fn word(&self, i: usize) -> Result<&'a str, Box<LsystemError>> {
        self.toks.get(i).map(|(_, t)| *t).ok_or_else(|| self.missing("a value"))
    }

    fn on_off(&self) -> Result<bool, Box<LsystemError>> {
        let w = self.word(0)?;
        match w.to_ascii_lowercase().as_str() {
            "on" => Ok(true),
            "off" => Ok(false),
            _ => Err(self.bad(0, "`on` or `off`")),
        }
    }

    fn vector(&self, first: usize) -> Result<[f64; 3], Box<LsystemError>> {
        Ok([self.number(first)?, self.number(first + 1)?, self.number(first + 2)?])
    }

    fn unit(&self, first: usize, what: &str) -> Result<[f64; 3], Box<LsystemError>> {
        let v = self.vector(first)?;
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if !(len > 0.0 && len.is_finite()) {
            let (at, _) = self.toks[first];
            let (end_at, end_tok) = self.toks[first + 2];
            return Err(self.file.error(
                at,
                end_at + end_tok.len() - at,
                &format!("`{}:` {what} is the zero vector", self.key),
                "zero vector",
            ));
        }
        Ok([v[0] / len, v[1] / len, v[2] / len])
    }

    fn surface(&self, id_line: usize, is_line: bool) -> Result<SurfaceRef, Box<LsystemError>> {
        let id_tok = self.word(0)?;
        let mut chars = id_tok.chars();
        let id = match (chars.next(), chars.next()) {
            (Some(c), None) => c,
            _ => return Err(self.bad(0, "a one-character surface id")),
        };
        let file = self.word(1)?.to_string();
        let scale = if is_line || self.toks.len() > 2 { self.number(2)? } else { 1.0 };
        let scale = if scale <= 0.0 { 1.0 } else { scale };
        let a = self.optional_int(3);
        let b = self.optional_int(4);
        let (s_precision, t_precision, texture) = match (a, b) {
            (Some(s), Some(t)) => (u32::try_from(s).ok(), u32::try_from(t).ok(), self.optional_int(5)),
            // `surface:` with one number after the scale: it is the texture (cpfg).
            (Some(x), None) if !is_line => (None, None, Some(x)),
            _ => (None, None, None),
        };
        Ok(SurfaceRef { id, file, scale, s_precision, t_precision, texture, line: id_line })
    }

    fn movement(&self, kind: MovementKind, line: usize) -> Result<Tropism, Box<LsystemError>> {
        let mut t = Tropism {
            kind,
            direction: [0.0; 3],
            intensity: 1.0,
            angle: 0.0,
            elasticity: 0.0,
            elasticity_step: 0.0,
            line,
        };
        let mut have_dir = false;
        let mut i = 0;
        while i < self.toks.len() {
            let (_, tok) = self.toks[i];
            match tok.chars().next() {
                Some('T') => {
                    t.direction = self.unit(i + 1, "direction T")?;
                    have_dir = true;
                    i += 4;
                }
                Some('I') => {
                    t.intensity = self.number(i + 1)?;
                    if t.intensity == 0.0 {
                        return Err(self.bad(i + 1, "a non-zero intensity"));
                    }
                    i += 2;
                }
                Some('A') => {
                    t.angle = self.number(i + 1)?;
                    i += 2;
                }
                Some('E') => {
                    t.elasticity = self.number(i + 1)?;
                    i += 2;
                }
                Some('S') => {
                    t.elasticity_step = self.number(i + 1)?;
                    i += 2;
                }
                _ => return Err(self.bad(i, "one of the fields T:, A:, I:, E:, S:")),
            }
        }
        if !have_dir {
            return Err(self.missing("a direction `T: x y z`"));
        }
        Ok(t)
    }
}

/// Parses a cpfg view file. `name` is used in error messages.
pub fn parse(name: &str, text: &str) -> Result<View, Box<LsystemError>> {
    let file = TextFile::new(name, text);
    let clean = strip_comments(text);
    let mut view = View::default();
    let mut offset = 0;
    for (n, raw) in clean.split_inclusive('\n').enumerate() {
        let line_no = n + 1;
        let start = offset;
        offset += raw.len();
        let line = raw.trim_end_matches(['\n', '\r']);
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        if trimmed.starts_with('#') {
            view.ignored.push(format!("line {line_no}: preprocessor line `{}`", excerpt(trimmed)));
            continue;
        }
        let Some(colon) = line.find(':') else {
            view.ignored.push(format!("line {line_no}: `{}` (no key)", excerpt(trimmed)));
            continue;
        };
        let key: String = line[..colon].split_whitespace().collect::<Vec<_>>().join(" ").to_ascii_lowercase();
        let value = &line[colon + 1..];
        let value_at = start + colon + 1;
        let l = Line {
            file: &file,
            key: key.clone(),
            end: start + line.len(),
            toks: tokens(value, value_at, |c| c.is_whitespace() || c == ','),
        };
        match key.as_str() {
            "angle factor" => {
                let f = l.number(0)?;
                if f == 0.0 {
                    return Err(l.bad(0, "a non-zero number"));
                }
                view.angle_increment = 360.0 / f;
            }
            "angle increment" => view.angle_increment = l.number(0)?,
            "initial color" => {
                view.initial_color = l.int(0)?;
                view.initial_color_back = l.optional_int(1);
            }
            "color increment" => {
                view.color_increment = l.int(0)?;
                view.color_increment_back = l.optional_int(1);
            }
            "initial line width" => {
                view.initial_line_width = l.number(0)?;
                view.line_style = match l.toks.get(1).and_then(|(_, w)| w.chars().next()) {
                    Some('p') | Some('P') => LineStyle::Pixel,
                    Some('s') | Some('S') => LineStyle::Cylinder,
                    _ => LineStyle::Polygon,
                };
            }
            "line width increment" => view.width_increment = l.number(0)?,
            "line style" => {
                let word = l.word(0)?;
                match word.to_ascii_lowercase().as_str() {
                    "pixel" | "1" => view.line_style = LineStyle::Pixel,
                    "polygon" | "2" => view.line_style = LineStyle::Polygon,
                    "cylinder" | "3" => view.line_style = LineStyle::Cylinder,
                    // cpfg keeps the previous style (models write `wireframe` here).
                    _ => view.ignored.push(format!(
                        "line {line_no}: line style `{}` (unknown; the previous style is kept)",
                        excerpt(word)
                    )),
                }
            }
            "tapered lines" => view.tapered_lines = l.on_off()?,
            "contour sides" => view.contour_sides = l.int(0)?.max(3) as u32,
            "polygonization level" => {
                let k = l.int(0)?.clamp(0, 10);
                view.contour_sides = (1u32 << (k + 1)).max(3);
            }
            "twist of cylinders" => view.twist_of_cylinders = l.on_off()?,
            "contour" => {
                let id = l.int(0)?;
                let file = l.word(1)?.to_string();
                view.contours.push(ContourRef { id, file, line: line_no });
            }
            "initial scale" => {
                let s = l.number(0)?;
                view.initial_scale = if s == 0.0 { 1.0 } else { s };
            }
            "scale multiplier" => {
                let s = l.number(0)?;
                view.scale_multiplier = if s == 0.0 { 1.0 } else { s };
            }
            "tropism direction" => {
                let d = l.unit(0, "direction")?;
                view.old_tropism.get_or_insert_with(OldTropism::default).direction = d;
            }
            "initial elasticity" => {
                let e = l.number(0)?;
                view.old_tropism.get_or_insert_with(OldTropism::default).elasticity = e;
            }
            "elasticity increment" => {
                let e = l.number(0)?;
                view.old_tropism.get_or_insert_with(OldTropism::default).elasticity_increment = e;
            }
            "tropism" | "torque" => {
                let l = Line {
                    toks: tokens(value, value_at, |c| c.is_whitespace() || c == ',' || c == ':'),
                    ..l
                };
                let kind = if key == "tropism" { MovementKind::Tropism } else { MovementKind::Torque };
                view.tropisms.push(l.movement(kind, line_no)?);
            }
            "surface" => {
                let s = l.surface(line_no, false)?;
                view.surfaces.push(s);
            }
            "line" => view.line_surface = Some(l.surface(line_no, true)?),
            "function" | "curve" => {
                let file = l.word(0)?.to_string();
                let samples = match l.toks.get(1) {
                    Some(_) => {
                        let s = l.int(1)?;
                        u32::try_from(s).ok().filter(|&s| s > 2)
                    }
                    None => None,
                };
                let r = FunctionRef { file, samples, is_set: false, line: line_no };
                if key == "function" {
                    view.functions.push(r);
                } else {
                    view.curves.push(r);
                }
            }
            "function set" => {
                let file = l.word(0)?.to_string();
                view.functions.push(FunctionRef { file, samples: None, is_set: true, line: line_no });
            }
            _ => view.ignored.push(format!("line {line_no}: {}", excerpt(&key))),
        }
    }
    Ok(view)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_colours_widths() {
        let v = parse(
            "t.v",
            "angle factor: 12\ninitial color: 1 2\ncolor increment: 3\ninitial line width: 4 pixels\n\
             line width increment: .5\n",
        )
        .unwrap();
        assert!((v.angle_increment - 30.0).abs() < 1e-12);
        assert_eq!((v.initial_color, v.initial_color_back), (1, Some(2)));
        assert_eq!(v.color_increment, 3);
        assert_eq!(v.initial_line_width, 4.0);
        assert_eq!(v.line_style, LineStyle::Pixel);
        assert_eq!(v.width_increment, 0.5);
        let v = parse("t.v", "initial line width: 0.1\nangle increment: 20\n").unwrap();
        assert_eq!(v.line_style, LineStyle::Polygon);
        assert_eq!(v.angle_increment, 20.0);
        let v = parse("t.v", "initial line width: 2\nline style: cylinder /* c */\n").unwrap();
        assert_eq!(v.line_style, LineStyle::Cylinder);
    }

    #[test]
    fn tropisms_both_syntaxes() {
        let v = parse(
            "t.v",
            "tropism: T: 0,1,0 E: 0.2\ntropism: T: 0.0  0.0 2.0  A:90\ntorque:  T: 0.0  1.0 0.0\n\
             tropism direction: 1.0,-3.0,0.0\ninitial elasticity: 0.4\nelasticity increment: -0.06\n",
        )
        .unwrap();
        assert_eq!(v.tropisms.len(), 3);
        assert_eq!(v.tropisms[0].direction, [0.0, 1.0, 0.0]);
        assert_eq!(v.tropisms[0].elasticity, 0.2);
        assert_eq!(v.tropisms[1].direction, [0.0, 0.0, 1.0]);
        assert_eq!(v.tropisms[1].angle, 90.0);
        assert_eq!(v.tropisms[2].kind, MovementKind::Torque);
        let old = v.old_tropism.unwrap();
        assert!((old.direction[1] + 3.0 / 10f64.sqrt()).abs() < 1e-12);
        assert_eq!((old.elasticity, old.elasticity_increment), (0.4, -0.06));
    }

    #[test]
    fn surfaces_functions_and_ignored_keys() {
        let v = parse(
            "t.v",
            "surface: l leaf.s 1 8 4\nsurface: c chaff.s  1.2\nsurface: t x.s 2 5\nline: L line.s .01\n\
             function: internode.func 100\nfunction: rho.func\nfunction set: f.fset\n\
             viewpoint: 0,0,1\nz buffer: on\n",
        )
        .unwrap();
        assert_eq!(v.surfaces.len(), 3);
        assert_eq!(v.surfaces[0].id, 'l');
        assert_eq!((v.surfaces[0].s_precision, v.surfaces[0].t_precision), (Some(8), Some(4)));
        assert_eq!(v.surfaces[1].scale, 1.2);
        assert_eq!(v.surfaces[2].texture, Some(5));
        assert_eq!(v.line_surface.as_ref().unwrap().id, 'L');
        assert_eq!(v.functions.len(), 3);
        assert_eq!(v.functions[0].samples, Some(100));
        assert_eq!(v.functions[1].samples, None);
        assert!(v.functions[2].is_set);
        assert_eq!(v.ignored, vec!["line 8: viewpoint".to_string(), "line 9: z buffer".to_string()]);
    }

    #[test]
    fn malformed_values_are_located() {
        let e = parse("f.v", "initial color: 1\nangle increment: ?\n").unwrap_err();
        assert!(e.message.starts_with("f.v:2:18:"), "{}", e.message);
        let e = parse("f.v", "angle factor: 0\n").unwrap_err();
        assert!(e.message.contains("non-zero"), "{}", e.message);
        let e = parse("f.v", "tropism: T: 0 0 0\n").unwrap_err();
        assert!(e.message.contains("zero vector"), "{}", e.message);
        let e = parse("f.v", "tropism: T: 0 1 0 Q: 3\n").unwrap_err();
        assert!(e.message.starts_with("f.v:1:19"), "{}", e.message);
        let e = parse("f.v", "surface: leaf leaf.s 1\n").unwrap_err();
        assert!(e.message.contains("one-character"), "{}", e.message);
        let v = parse("f.v", "line style: cylinder\nline style: wireframe\n").unwrap();
        assert_eq!(v.line_style, LineStyle::Cylinder);
        assert!(v.ignored[0].contains("wireframe"), "{:?}", v.ignored);
        let e = parse("f.v", "initial elasticity:\n").unwrap_err();
        assert!(e.message.contains("needs a number"), "{}", e.message);
    }

    #[test]
    fn garbage_does_not_panic() {
        for text in ["", ":", "::::\n", "tropism: T", "tropism: T: 1", "surface:", "é: ü", "/*", "a\u{0}b: c"]
        {
            let _ = parse("g.v", text);
        }
    }
}
