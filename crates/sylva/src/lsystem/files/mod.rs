//! The sibling files of a cpfg (vlab) model folder: view, functions, surfaces and
//! colour maps or materials.
//!
//! This implements the model-folder support of issue 3: a vlab object folder holds
//! the L-system (`*.l`) and the files cpfg reads next to it. Each format has its own
//! reader, and [`load_folder`] finds and reads them the way cpfg is started on them.
//!
//! | file | module | what sylva keeps |
//! |---|---|---|
//! | `*.v` view file | [`view`] | angle, colour and width settings, tropisms, the surface, function and contour lists; viewing keys are listed as ignored |
//! | `*.func` function, `*.fset` function set | [`func`] | the B-spline curve, evaluated as y(x) on \[0, 1\] |
//! | `*.s` surface | [`surface`] | the bicubic Bézier patches, tessellated to a [`crate::Mesh`] |
//! | `*.con` curve (`curve:` lines) | [`curve`] | the B-spline, tabulated by arc length for `curveX/Y/Z` and `curveGAL` |
//! | `*.con` contour (`contour:` lines) | [`contour`] | the B-spline cross-section of generalized cylinders (`@#(n)`) |
//! | `*.map` colour map, `*.mat` materials | [`colormap`] | one RGB colour per colour or material index |
//!
//! The formats follow cpfg's own readers (vlab 5, `interpret.c`, `movements.c`,
//! `splinefun.cpp`, `patches.c`, medit) and were checked on the fifty models of the
//! vlab CPFG manual and course corpus; each module's documentation gives the format and
//! every place where sylva differs from cpfg.
//!
//! # Finding the files
//!
//! cpfg is started as `cpfg [options] file.l file.v [file.a] …` with `-m map` (colour
//! map; `-m1`/`-m2` load a first and second map at indices 0 and 256), `-M mat`
//! (materials) and `-e file` (environment). vlab folders declare that command line in
//! their `specifications` file (for example `cpfg -M material.mat plant.l plant.v
//! plant.a`). [`load_folder`] therefore:
//!
//! 1. reads `specifications` in the L-system's folder, if any, and takes the first
//!    `cpfg …` command whose `.l` argument has the L-system's file name; its `.v`
//!    argument is the view file and its `-m`/`-m1`/`-m2`/`-M` arguments the colours;
//! 2. otherwise takes the `.v` file with the L-system's stem, or the only `.v` file in
//!    the folder; and the `.map` with the stem, the only `.map`, the `.mat` with the
//!    stem or the only `.mat` (in that order);
//! 3. reads the functions the view file lists, in the order it lists them: cpfg's
//!    `func(id, x)` refers to the `id`-th function, counted from 1, so function `id` is
//!    `functions[id - 1]`. A `function set:` line replaces the functions listed before
//!    it by the set's functions, as in cpfg. When the view file lists no function (or
//!    there is no view file), sylva reads every `*.func` file of the folder in file-name
//!    order and then every `*.fset` file; that order is a sylva convention. A listed
//!    function whose file is missing gets cpfg's default function (y = 0), so the ids
//!    of the following ones do not shift;
//! 4. reads the surfaces the view file names (`surface:` and `line:` lines); a missing
//!    surface file is skipped, as cpfg skips it.
//!
//! The environment file (`-e file.e`) is read for the program its `executable:` line
//! starts and for the spec file it names (its unknown keys are listed as ignored); the
//! program answers the model's `?E` modules when sylva has it built in
//! ([`crate::lsystem::environment`]).
//!
//! Everything found but not used (the animation file, contour files, viewing keys,
//! missing files) is listed in [`ModelFolder::ignored`]. Paths in
//! the view file and in `specifications` are relative to the folder.
//!
//! # Confinement (issue 39)
//!
//! Model folders are shared and downloaded, so the files they name are read only from
//! inside the folder: every name in `specifications` (`.v`, `-e`, `-m`, `-M`), in the
//! view file (`function:`, `function set:`, `surface:`, `line:`, `contour:`,
//! `curve:`) and in the `.e` file (its spec file) must resolve, as the system resolves
//! it (symbolic links and `..` included), inside the model folder or a folder of the
//! recipe's `generator.allow_paths` ([`crate::input::SideFiles`]). Anything else is an
//! error naming the entry, where it is written (`plant.v:7: \`function:\``), the
//! resolved path and the key; so is a named file that is not a regular file or is over
//! `input.max_bytes`. Names and text from these files are quoted in notes and
//! messages clipped to [`crate::input::MAX_EXCERPT`] characters.

pub mod colormap;
pub mod contour;
pub mod curve;
pub mod func;
pub mod surface;
pub mod view;

use crate::input::SideFiles;
use crate::lsystem::comments::{blank_comments, CommentStyle};
use crate::lsystem::source::{ErrorKind, LsystemError};
use colormap::ColorMap;
use func::Function;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use surface::Surface;
use view::View;

/// Everything sylva reads from a cpfg model folder next to its L-system.
#[derive(Debug, Clone)]
pub struct ModelFolder {
    /// The L-system file the folder was loaded for.
    pub lsystem: PathBuf,
    /// The view file, when one was found.
    pub view: Option<View>,
    /// Where the view file was read from.
    pub view_file: Option<PathBuf>,
    /// The functions, in cpfg id order: `func(id, x)` is `functions[id - 1]`. Each
    /// name is the function's `name:` or, without one, its file stem.
    pub functions: Vec<(String, Function)>,
    /// The surfaces named in the view file, by their one-character id (`~l` draws
    /// surface `"l"`).
    pub surfaces: Vec<(String, Surface)>,
    /// The curves of the view file's `curve:` lines, in order: `curveX(id, t)` reads
    /// `curves[id - 1]`. Named by file stem.
    pub curves: Vec<(String, curve::Curve)>,
    /// The contours of the view file's `contour: id file` lines, by id, in file order
    /// (`@#(id)` selects one for generalized cylinders); a repeated id keeps the first,
    /// as cpfg's lookup does.
    pub contours: Vec<(i32, contour::Contour)>,
    /// The `contour:` lines whose file is missing or malformed, by id, with the error
    /// (file, line and why). They do not stop the folder from loading (a model may list
    /// contours it never uses), but `@#(id)` selecting one is that error.
    pub contour_errors: Vec<(i32, String)>,
    /// The colour map (`-m`) or material colours (`-M`), when one was found.
    pub colormap: Option<ColorMap>,
    /// The colour map or material files that were read, in load order.
    pub colormap_files: Vec<PathBuf>,
    /// The environment file of the cpfg command line (`-e file.e`), when it names one.
    pub environment_file: Option<PathBuf>,
    /// The environmental program that file starts (its `executable:` line's command,
    /// without path or arguments), when the file exists and names one.
    pub environment_program: Option<String>,
    /// The program's spec file, the last plain argument of the `executable:` line
    /// (`executable: honda81 density.spec`), when it names one; read by the pipeline
    /// (`crate::lsystem::environment::Spec`).
    pub environment_spec: Option<PathBuf>,
    /// What was found but not used, one human-readable note each.
    pub ignored: Vec<String>,
}

impl ModelFolder {
    /// The names cpfg defines for `func(NAME, x)` when the view file's functions come
    /// from a function set (its last function line is `function set:`): each function's
    /// name, without a `.suffix`, as its 1-based id, as cpfg's preprocessor command line
    /// does (`-DNAME=id`, vlab `cpfg/generate.c`). Names that are not identifiers are left
    /// out. Empty otherwise.
    pub fn gallery_names(&self) -> Vec<(String, String)> {
        let gallery = self.view.as_ref().and_then(|v| v.functions.last()).is_some_and(|r| r.is_set);
        if !gallery {
            return Vec::new();
        }
        let ident = |n: &str| {
            n.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        };
        self.functions
            .iter()
            .enumerate()
            .map(|(k, (name, _))| (name.split('.').next().unwrap_or_default().to_string(), k))
            .filter(|(n, _)| ident(n))
            .map(|(n, k)| (n, (k + 1).to_string()))
            .collect()
    }
}

/// Finds and reads the view, function, surface and colour files of the cpfg model
/// folder that holds `lsystem_path` (see the [module documentation](self) for how),
/// confined to that folder with the default input limit: [`load_folder_in`] with
/// [`SideFiles::new`]`(folder, &[], DEFAULT_MAX_BYTES)`.
///
/// Errors: a file that exists but cannot be read ([`crate::Error::Read`]) or does not
/// parse ([`crate::Error::Lsystem`], located in that file). Missing optional files are
/// not errors; they are listed in [`ModelFolder::ignored`].
pub fn load_folder(lsystem_path: &Path) -> Result<ModelFolder, crate::Error> {
    let side = SideFiles::new(&folder_of(lsystem_path), &[], crate::input::DEFAULT_MAX_BYTES);
    load_folder_in(lsystem_path, &side)
}

/// The folder of a model file (`.` for a bare file name).
pub fn folder_of(lsystem_path: &Path) -> PathBuf {
    match lsystem_path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// [`load_folder`] reading through `side`: every file the folder's `specifications`,
/// view and `.e` files name must resolve inside `side`'s folders (symbolic links
/// included) and be a regular file within its input limit. A file that breaks that is
/// an error whose [`crate::input::is_refusal`] is true, naming the entry, the file and
/// line that names it, the resolved path and the key `generator.allow_paths`.
pub fn load_folder_in(lsystem_path: &Path, side: &SideFiles) -> Result<ModelFolder, crate::Error> {
    let dir = side.dir().to_path_buf();
    let lsystem_name = lsystem_path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let stem = lsystem_path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut folder = ModelFolder {
        lsystem: lsystem_path.to_path_buf(),
        view: None,
        view_file: None,
        functions: Vec::new(),
        surfaces: Vec::new(),
        curves: Vec::new(),
        contours: Vec::new(),
        contour_errors: Vec::new(),
        colormap: None,
        colormap_files: Vec::new(),
        environment_file: None,
        environment_program: None,
        environment_spec: None,
        ignored: Vec::new(),
    };
    let listing = list_dir(&dir);
    // Names from the folder's files are quoted clipped (they are not the user's).
    let q = crate::input::excerpt;

    // 1. The cpfg command line of `specifications`, if it names this L-system.
    let spec_path = side.resolve("specifications", "the model folder's `specifications`")?;
    let command = if spec_path.exists() {
        let text = side.read_text(&spec_path, "the model folder's `specifications`")?;
        find_cpfg_command(&text, &lsystem_name)
    } else {
        None
    };
    let at_spec = |opt: &str, line: usize| format!("specifications:{line}: `{opt}`");

    let view_name: Option<(String, String)>; // (file, where it is named)
    let mut colour_files: Vec<(usize, String, bool, String)> = Vec::new(); // (base, file, is_material, where)
    if let Some(cmd) = &command {
        view_name = cmd.view.clone().map(|v| (v, at_spec("cpfg … file.v", cmd.line)));
        for (base, file) in &cmd.maps {
            colour_files.push((*base, file.clone(), false, at_spec("-m", cmd.line)));
        }
        if let Some(m) = &cmd.materials {
            colour_files.push((0, m.clone(), true, at_spec("-M", cmd.line)));
        }
        for other in &cmd.other_files {
            folder.ignored.push(format!("{} (named on the cpfg command line; not used)", q(other)));
        }
        if let Some(e) = &cmd.environment {
            let at = at_spec("-e", cmd.line);
            let path = side.resolve(e, &at)?;
            if path.exists() {
                let text = side.read_text(&path, &at)?;
                folder.environment_program = environment_program(&text);
                folder.environment_spec =
                    crate::lsystem::environment::spec_file_in(side, e, &text, &mut folder.ignored)?;
                if folder.environment_program.is_none() {
                    folder
                        .ignored
                        .push(format!("{}: no `executable:` line, so no environmental program", q(e)));
                }
            } else {
                folder.ignored.push(format!("missing environment file {} (its program is unknown)", q(e)));
            }
            folder.environment_file = Some(path);
        }
    } else {
        view_name = pick(&listing, &stem, "v").map(|v| (v, "the model folder".to_string()));
        if view_name.is_none() && listing.iter().any(|f| has_ext(f, "v")) {
            folder
                .ignored
                .push(format!("several .v files and none named {}.v: no view file chosen", q(&stem)));
        }
        if let Some(m) = pick(&listing, &stem, "map") {
            colour_files.push((0, m, false, "the model folder".into()));
        } else if let Some(m) = pick(&listing, &stem, "mat") {
            colour_files.push((0, m, true, "the model folder".into()));
        }
    }

    // 2. The view file.
    if let Some((v, at)) = view_name {
        let path = side.resolve(&v, &at)?;
        if path.exists() {
            let text = side.read_text(&path, &at)?;
            let view = view::parse(&display_name(&path), &text)?;
            for key in &view.ignored {
                folder.ignored.push(format!("{}: {key}", q(&v)));
            }
            folder.view = Some(view);
            folder.view_file = Some(path);
        } else {
            folder.ignored.push(format!("missing view file {}", q(&v)));
        }
    }
    let view_shown = folder.view_file.as_deref().map(display_name).unwrap_or_default();
    let at_view = |key: &str, line: usize| format!("{view_shown}:{line}: `{key}:`");

    // 3. Functions.
    let listed = folder.view.as_ref().map(|v| !v.functions.is_empty()).unwrap_or(false);
    if listed {
        let refs = folder.view.as_ref().map(|v| v.functions.clone()).unwrap_or_default();
        for r in refs {
            let at = at_view(if r.is_set { "function set" } else { "function" }, r.line);
            let path = side.resolve(&r.file, &at)?;
            if r.is_set {
                folder.functions.clear();
                if path.exists() {
                    let text = side.read_text(&path, &at)?;
                    let set = func::parse_set(&display_name(&path), &text)?;
                    folder.functions.extend(set.functions);
                } else {
                    folder.ignored.push(format!("missing function set {}", q(&r.file)));
                }
            } else if path.exists() {
                let text = side.read_text(&path, &at)?;
                let mut f = func::parse(&display_name(&path), &text)?;
                if f.format == func::FunctionFormat::Range {
                    f.set_samples(r.samples);
                }
                let name = f.name.clone().unwrap_or_else(|| file_stem(&r.file));
                folder.functions.push((name, f));
            } else {
                folder.ignored.push(format!(
                    "missing function file {} (function {} is y = 0, as in cpfg)",
                    q(&r.file),
                    folder.functions.len() + 1
                ));
                folder.functions.push((file_stem(&r.file), Function::cpfg_default()));
            }
        }
    } else {
        for f in listing.iter().filter(|f| has_ext(f, "func")) {
            let path = dir.join(f);
            let text = side.read_text(&path, "the model folder")?;
            let fun = func::parse(&display_name(&path), &text)?;
            let name = fun.name.clone().unwrap_or_else(|| file_stem(f));
            folder.functions.push((name, fun));
        }
        for f in listing.iter().filter(|f| has_ext(f, "fset")) {
            let path = dir.join(f);
            let text = side.read_text(&path, "the model folder")?;
            let set = func::parse_set(&display_name(&path), &text)?;
            folder.functions.extend(set.functions);
        }
    }

    // 3b. Curves (`curve:` lines), for curveX/Y/Z and curveGAL.
    let curve_refs = folder.view.as_ref().map(|v| v.curves.clone()).unwrap_or_default();
    for r in curve_refs {
        let at = at_view("curve", r.line);
        let path = side.resolve(&r.file, &at)?;
        if path.exists() {
            let text = side.read_text(&path, &at)?;
            let samples = r.samples.map_or(curve::DEFAULT_SAMPLES, |n| n as usize);
            let c = curve::parse_with_samples(&display_name(&path), &text, samples)?;
            folder.curves.push((file_stem(&r.file), c));
        } else {
            folder.ignored.push(format!(
                "missing curve file {} (curve {})",
                q(&r.file),
                folder.curves.len() + 1
            ));
        }
    }

    // 3c. Contours (`contour:` lines), for `@#(id)`: a missing or bad file is recorded
    // as an error that selecting the contour raises.
    let contour_refs = folder.view.as_ref().map(|v| v.contours.clone()).unwrap_or_default();
    for r in contour_refs {
        let seen = |id: i32| {
            folder.contours.iter().any(|(i, _)| *i == id)
                || folder.contour_errors.iter().any(|(i, _)| *i == id)
        };
        if seen(r.id) {
            folder.ignored.push(format!("contour id {} used twice: {} ignored", r.id, q(&r.file)));
            continue;
        }
        let at = at_view("contour", r.line);
        let path = side.resolve(&r.file, &at)?;
        let read = if path.exists() {
            let text = side.read_text(&path, &at)?;
            contour::parse(&display_name(&path), &text).map_err(|e| e.message)
        } else {
            Err(format!(
                "{view_shown}: `contour: {} {}`: the contour file {} does not exist",
                r.id,
                q(&r.file),
                path.display()
            ))
        };
        match read {
            Ok(c) => folder.contours.push((r.id, c)),
            Err(why) => {
                folder.ignored.push(format!("contour {} not usable: {why}", r.id));
                folder.contour_errors.push((r.id, why));
            }
        }
    }

    // 4. Surfaces.
    let surface_refs: Vec<view::SurfaceRef> = folder
        .view
        .as_ref()
        .map(|v| v.surfaces.iter().chain(v.line_surface.iter()).cloned().collect())
        .unwrap_or_default();
    for r in surface_refs {
        let id = r.id.to_string();
        if folder.surfaces.iter().any(|(n, _)| *n == id) {
            folder.ignored.push(format!("surface id {id} used twice: {} ignored, as in cpfg", q(&r.file)));
            continue;
        }
        let at = at_view("surface", r.line);
        let path = side.resolve(&r.file, &at)?;
        if path.exists() {
            let text = side.read_text(&path, &at)?;
            let s = surface::parse(&display_name(&path), &text)?;
            folder.surfaces.push((id, s));
        } else {
            folder.ignored.push(format!("missing surface file {} (surface {id})", q(&r.file)));
        }
    }

    // 5. Colour maps and materials.
    for (base, file, is_material, at) in colour_files {
        let path = side.resolve(&file, &at)?;
        if !path.exists() {
            folder.ignored.push(format!("missing colour file {}", q(&file)));
            continue;
        }
        let bytes = side.read(&path, &at)?;
        let parsed = if is_material { colormap::parse_materials(&bytes) } else { colormap::parse(&bytes) };
        let map = parsed.map_err(|why| plain_error(&display_name(&path), &why))?;
        match folder.colormap.as_mut() {
            Some(existing) => existing.insert_at(base, &map),
            None => {
                let mut m = ColorMap { colors: Vec::new(), materials: None };
                m.insert_at(base, &map);
                folder.colormap = Some(m);
            }
        }
        folder.colormap_files.push(path);
    }
    Ok(folder)
}

/// The parts of a `cpfg …` command line that matter here.
#[derive(Debug, Clone, Default, PartialEq)]
struct CpfgCommand {
    /// The line of `specifications` it is on, from 1.
    line: usize,
    lsystem: Option<String>,
    view: Option<String>,
    /// Colour maps with the colour index they start at.
    maps: Vec<(usize, String)>,
    materials: Option<String>,
    environment: Option<String>,
    other_files: Vec<String>,
}

/// The program an environment file (`.e`) starts: the first word of its
/// `executable:` line, without directories (`executable: /bin/honda81 -e x.spec` →
/// `honda81`).
fn environment_program(text: &str) -> Option<String> {
    let line = text.lines().find_map(|l| l.trim().strip_prefix("executable:"))?;
    let word = line.split_whitespace().next()?;
    Path::new(word).file_name().map(|n| n.to_string_lossy().into_owned())
}

/// Parses the `cpfg …` lines of a vlab `specifications` file and returns the first
/// whose `.l` argument is `lsystem` (compared by file name).
fn find_cpfg_command(spec: &str, lsystem: &str) -> Option<CpfgCommand> {
    for (n, line) in spec.lines().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some(at) = words.iter().position(|w| *w == "cpfg" || w.ends_with("/cpfg")) else {
            continue;
        };
        let mut cmd = CpfgCommand { line: n + 1, ..CpfgCommand::default() };
        let mut k = at + 1;
        while k < words.len() {
            let w = words[k];
            if matches!(w, "|" | ";" | "&&" | "||" | "&") {
                break;
            }
            if let Some(opt) = w.strip_prefix('-') {
                let arg = words.get(k + 1).map(|s| s.to_string());
                match opt {
                    "m" | "m1" => {
                        if let Some(a) = arg {
                            cmd.maps.push((0, a));
                        }
                        k += 2;
                    }
                    "m2" => {
                        if let Some(a) = arg {
                            cmd.maps.push((256, a));
                        }
                        k += 2;
                    }
                    "M" => {
                        cmd.materials = arg;
                        k += 2;
                    }
                    "e" => {
                        cmd.environment = arg;
                        k += 2;
                    }
                    "w" | "wp" | "wr" => k += 3,
                    _ => k += 1,
                }
                continue;
            }
            let name = Path::new(w).file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            if has_ext(w, "l") && cmd.lsystem.is_none() {
                cmd.lsystem = Some(name);
            } else if has_ext(w, "v") && cmd.view.is_none() {
                cmd.view = Some(w.to_string());
            } else {
                cmd.other_files.push(w.to_string());
            }
            k += 1;
        }
        if cmd.lsystem.as_deref() == Some(lsystem) {
            return Some(cmd);
        }
    }
    None
}

/// File names (not paths) of the plain files in `dir`, sorted.
fn list_dir(dir: &Path) -> Vec<String> {
    let mut out: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .filter(|e| e.path().is_file())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    out.sort();
    out
}

/// `stem.ext` if present, else the only `*.ext` file.
fn pick(listing: &[String], stem: &str, ext: &str) -> Option<String> {
    let same = format!("{stem}.{ext}");
    if listing.contains(&same) {
        return Some(same);
    }
    let mut all = listing.iter().filter(|f| has_ext(f, ext));
    match (all.next(), all.next()) {
        (Some(one), None) => Some(one.clone()),
        _ => None,
    }
}

fn has_ext(file: &str, ext: &str) -> bool {
    Path::new(file).extension().map(|e| e.eq_ignore_ascii_case(ext)).unwrap_or(false)
}

fn file_stem(file: &str) -> String {
    Path::new(file).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

fn display_name(path: &Path) -> String {
    path.display().to_string()
}

/// An [`LsystemError`] with no place in a file (for binary files).
fn plain_error(name: &str, what: &str) -> Box<LsystemError> {
    LsystemError::nowhere(ErrorKind::Syntax, name, what)
}

/// A text file being read, for located errors: the original text is kept as is (no
/// preprocessing), so offsets are offsets into the file.
#[derive(Debug, Clone)]
pub(crate) struct TextFile {
    name: String,
    text: Arc<str>,
}

impl TextFile {
    pub(crate) fn new(name: &str, text: &str) -> Self {
        TextFile { name: name.to_string(), text: Arc::from(text) }
    }

    /// A syntax error at byte `offset` spanning `len` bytes.
    pub(crate) fn error(&self, offset: usize, len: usize, what: &str, label: &str) -> Box<LsystemError> {
        LsystemError::located(ErrorKind::Syntax, &self.name, &self.text, offset, len, what, label)
    }
}

/// Splits `s` into tokens separated by characters for which `sep` is true; each token
/// comes with its byte offset in the file (`base` is the offset of `s`).
pub(crate) fn tokens(s: &str, base: usize, sep: impl Fn(char) -> bool) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for (i, c) in s.char_indices() {
        if sep(c) {
            if let Some(st) = start.take() {
                out.push((base + st, &s[st..i]));
            }
        } else if start.is_none() {
            start = Some(i);
        }
    }
    if let Some(st) = start {
        out.push((base + st, &s[st..]));
    }
    out
}

/// Parses a finite floating-point number as C's `%f` would accept it whole.
pub(crate) fn number(s: &str) -> Option<f64> {
    s.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Replaces `/* … */` and `//` comments by spaces, keeping newlines and every byte
/// offset (the C preprocessor's comment removal, which cpfg runs on view files).
pub(crate) fn strip_comments(s: &str) -> String {
    blank_comments(s, CommentStyle::Data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpfg_command_lines() {
        let spec = "plant.l\nmodel:\n\tgenerate:\n\t\tcpfg -w 300 500 -m plant.map -e plant.e plant.l plant.v plant.a\n";
        let c = find_cpfg_command(spec, "plant.l").unwrap();
        assert_eq!(c.view.as_deref(), Some("plant.v"));
        assert_eq!(c.maps, vec![(0, "plant.map".to_string())]);
        assert_eq!(c.environment.as_deref(), Some("plant.e"));
        assert_eq!(c.other_files, vec!["plant.a".to_string()]);
        assert_eq!(
            environment_program("# x\nexecutable: /usr/bin/honda81 -e d.spec\n").as_deref(),
            Some("honda81")
        );
        assert_eq!(environment_program("communication type: pipes\n"), None);
        assert!(find_cpfg_command(spec, "other.l").is_none());
        let sedge = "\t\tcpfg -m1 sedge.map -m2 sedge.map2 sedge.l sedge.v sedge.a\n\t\tcpfg -m2 sedge.map2 male.l male.v male.a\n";
        let c = find_cpfg_command(sedge, "male.l").unwrap();
        assert_eq!(c.view.as_deref(), Some("male.v"));
        assert_eq!(c.maps, vec![(256, "sedge.map2".to_string())]);
        let c = find_cpfg_command("cpfg -M material.mat spiral.l spiral.v", "spiral.l").unwrap();
        assert_eq!(c.materials.as_deref(), Some("material.mat"));
    }

    #[test]
    fn comments_keep_offsets() {
        let s = "a: 1 /* x\ny */ b // c\nd: 2";
        let t = strip_comments(s);
        assert_eq!(t.len(), s.len());
        assert_eq!(t.lines().map(str::trim).collect::<Vec<_>>(), vec!["a: 1", "b", "d: 2"]);
        // Unterminated comments and non-ASCII text do not panic.
        assert_eq!(strip_comments("é /* ü").len(), "é /* ü".len());
    }

    #[test]
    fn located_errors() {
        let f = TextFile::new("x.v", "a: 1\nbb: ?\n");
        let e = f.error(9, 1, "bad", "here");
        assert!(e.message.starts_with("x.v:2:5: bad"), "{}", e.message);
        // Offsets past the end are clamped.
        let e = f.error(1000, 5, "eof", "here");
        assert!(e.message.starts_with("x.v:3:1"), "{}", e.message);
    }

    #[test]
    fn tokens_with_offsets() {
        let t = tokens(" T: 0,1 ,0", 10, |c| c.is_whitespace() || c == ',' || c == ':');
        assert_eq!(t, vec![(11, "T"), (14, "0"), (16, "1"), (19, "0")]);
    }
}
