//! Issue 39, items 9 and 14: what sylva reads.
//!
//! - Item 9: every input is read only from a regular file, within `input.max_bytes`: a
//!   link to `/dev/zero` or `/dev/urandom`, a FIFO or a directory behind any reader's
//!   extension (or an `#include`) is refused at once with "not a regular file" instead
//!   of being read to 4 GB; an over-limit file is refused naming its size and the key.
//! - Item 14: a cpfg model folder's files may name only files inside the folder
//!   (absolute, `../` and symlinked names are refused with the entry, its file and line,
//!   the resolved path and `generator.allow_paths`), unless the recipe allows the
//!   folder; and a spec file's lines are never quoted back.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use sylva::pipeline;
use sylva::recipe::{self, Generator};

/// A fresh folder for one test.
fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sylva-robust-inputs-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    // Resolved, so paths compare with the resolved paths messages name.
    std::fs::canonicalize(&d).unwrap()
}

fn write(path: &Path, text: &str) {
    if let Some(p) = path.parent() {
        std::fs::create_dir_all(p).unwrap();
    }
    std::fs::write(path, text).unwrap();
}

fn link(target: &Path, at: &Path) {
    std::os::unix::fs::symlink(target, at).unwrap();
}

fn sets(kv: &[&str]) -> Vec<(String, toml::Value)> {
    kv.iter().map(|s| recipe::parse_set(s).unwrap()).collect()
}

/// Every way an error is shown: its message, its debug form and miette's report (with
/// the source excerpts).
fn shown(e: sylva::Error) -> String {
    let plain = format!("{e}\n{e:?}");
    format!("{plain}\n{:?}", miette::Report::new(e))
}

/// Loads and grows `what`; `Err` is every way the error is shown.
fn grow(what: &Path, kv: &[&str]) -> Result<pipeline::Grown, String> {
    let loaded = recipe::load(what.to_str().unwrap(), &sets(kv)).map_err(shown)?;
    pipeline::grow(&loaded).map_err(shown)
}

/// Derives an L-system model: its warnings and the model folder's notes, or the error.
fn derive(what: &Path, kv: &[&str]) -> Result<Vec<String>, String> {
    let loaded = recipe::load(what.to_str().unwrap(), &sets(kv)).map_err(shown)?;
    let Generator::Lsystem(g) = &loaded.recipe.generator else { panic!("not an L-system") };
    let d = pipeline::derive_lsystem(&loaded, g).map_err(shown)?;
    let mut notes = d.warnings.clone();
    if let Some(f) = &d.folder {
        notes.extend(f.ignored.iter().cloned());
        notes.extend(f.view_file.iter().map(|p| format!("view file {}", p.display())));
    }
    Ok(notes)
}

const PLANT: &str = "Lsystem: 1\nderivation length: 2\nAxiom: FA\nA --> F[+A][-A]\nendlsystem\n";

/// Item 9: `/dev/zero`, `/dev/urandom`, a FIFO and a directory behind every reader's
/// extension are refused before anything is read.
#[test]
fn item9_special_files_are_refused_on_every_reader() {
    let d = temp("special");
    let zero = Path::new("/dev/zero");
    for name in ["x.l", "x.lst", "x.str", "x.skel.json", "x.obj", "x.glb", "x.gltf", "recipe.toml"] {
        link(zero, &d.join(name));
    }
    link(Path::new("/dev/urandom"), &d.join("r.lst"));
    let fifo = d.join("f.lst");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0, "mkfifo");
    std::fs::create_dir_all(d.join("dir.l")).unwrap();

    let refused = |m: &str, what: &str| {
        assert!(m.contains("not a regular file"), "{what}: {m}");
    };
    for name in ["x.l", "x.lst", "x.str", "x.skel.json", "r.lst", "f.lst", "dir.l"] {
        match grow(&d.join(name), &[]) {
            Ok(_) => panic!("{name} grew"),
            Err(m) => refused(&m, name),
        }
    }
    let m = grow(&d.join("f.lst"), &[]).unwrap_err();
    assert!(m.contains("FIFO"), "{m}");
    let m = grow(&d.join("x.lst"), &[]).unwrap_err();
    assert!(m.contains("character device") && m.contains("x.lst"), "{m}");
    let e = sylva::mesh::obj_read::read_obj(&d.join("x.obj")).unwrap_err().to_string();
    refused(&e, "x.obj");
    for name in ["x.glb", "x.gltf"] {
        let e = sylva::import::gltf_read::read_gltf(&d.join(name)).unwrap_err();
        refused(&shown(e), name);
    }
    let e = recipe::load(d.join("recipe.toml").to_str().unwrap(), &[]).unwrap_err();
    refused(&shown(e), "recipe.toml");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Item 9: a file over `input.max_bytes` is refused before it is read, naming the file,
/// its size and the key; the recipe file itself obeys `--set input.max_bytes`.
#[test]
fn item9_over_limit_files_name_size_and_key() {
    let d = temp("limit");
    let lst = d.join("big.lst");
    write(&lst, &format!("# {}\n", "x".repeat(3000)));
    let m = grow(&lst, &["input.max_bytes=1000"]).unwrap_err();
    assert!(
        m.contains("big.lst")
            && m.contains("3003 bytes")
            && m.contains("1000")
            && m.contains("input.max_bytes"),
        "{m}"
    );
    let l = d.join("big.l");
    write(&l, &format!("/* {} */\n{PLANT}", "y".repeat(3000)));
    let m = grow(&l, &["input.max_bytes=2000"]).unwrap_err();
    assert!(m.contains("big.l") && m.contains("input.max_bytes"), "{m}");
    assert!(grow(&l, &[]).is_ok(), "the default limit is generous");
    let toml = d.join("r.toml");
    write(&toml, "[generator]\ntype = \"lsystem\"\nfile = \"big.l\"\n");
    let m = grow(&toml, &["input.max_bytes=10"]).unwrap_err();
    assert!(m.contains("r.toml") && m.contains("input.max_bytes"), "{m}");
    let m = grow(&toml, &["input.max_bytes=0"]).unwrap_err();
    assert!(m.contains("input.max_bytes") && m.contains("at least 1"), "{m}");
    let m = grow(&toml, &["input.bogus=1"]).unwrap_err();
    assert!(m.contains("bogus"), "{m}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Items 9 and 14: `#include` reads only regular files inside the model folder (or an
/// allowed one).
#[test]
fn item9_item14_includes_are_regular_and_confined() {
    let d = temp("include");
    let outside = d.join("outside");
    write(&outside.join("leaf.l"), "#define N 2\n");
    let m = d.join("model");
    write(&m.join("inside.l"), "#define N 2\n");
    link(Path::new("/dev/zero"), &m.join("zero.l"));
    link(&outside.join("leaf.l"), &m.join("linked.l"));
    let model = |inc: &str| {
        let p = m.join("plant.l");
        write(&p, &format!("#include \"{inc}\"\nLsystem: 1\nderivation length: N\nAxiom: FA\nA --> F[+A][-A]\nendlsystem\n"));
        p
    };
    assert!(derive(&model("inside.l"), &[]).is_ok());
    // A link to a device is outside the folder; allowed, it is still not a regular file.
    let e = derive(&model("zero.l"), &[]).unwrap_err();
    assert!(e.contains("generator.allow_paths") && e.contains("plant.l:1"), "{e}");
    let e = derive(&model("zero.l"), &["generator.allow_paths=[\"/dev\"]"]).unwrap_err();
    assert!(e.contains("not a regular file") && e.contains("plant.l:1"), "{e}");
    let fifo = std::ffi::CString::new(m.join("fifo.l").to_str().unwrap()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0, "mkfifo");
    let e = derive(&model("fifo.l"), &[]).unwrap_err();
    assert!(e.contains("not a regular file (a FIFO") && e.contains("plant.l:1"), "{e}");
    let abs = outside.join("leaf.l");
    for inc in ["../outside/leaf.l", abs.to_str().unwrap(), "linked.l"] {
        let e = derive(&model(inc), &[]).unwrap_err();
        assert!(
            e.contains("generator.allow_paths")
                && e.contains("#include")
                && e.contains("outside the model folder"),
            "{inc}: {e}"
        );
        assert!(e.contains(&outside.join("leaf.l").display().to_string()), "names the resolved path: {e}");
        let allow = format!("generator.allow_paths=[\"{}\"]", outside.display());
        assert!(derive(&model(inc), &[&allow]).is_ok(), "{inc} allowed");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// Item 14: every entry of a model folder that names a file outside it is refused
/// (absolute, `../`, symlinked), naming the entry, where it is, the resolved path and
/// the key; the key allows it.
#[test]
fn item14_model_folder_entries_are_confined() {
    let d = temp("confine");
    let out = d.join("elsewhere");
    write(&out.join("v.v"), "angle increment: 30\n");
    write(
        &out.join("f.func"),
        "fver 1 1\nname: f\nsamples: 10\nflip: off\npoints: 4\n0 0 1\n0.3 0.1 1\n0.6 0.2 1\n1 0.3 1\n",
    );
    write(&out.join("x.e"), "executable: honda81\n");
    write(&out.join("d.spec"), "radius: 0.1\n");
    write(&out.join("c.map"), &"\u{1}".repeat(3 * 4));
    let allow = format!("generator.allow_paths=[\"{}\"]", out.display());
    let outside_abs = |f: &str| out.join(f).display().to_string();

    // (folder files, the entry's place in messages)
    type Case = (Vec<(&'static str, String)>, &'static str);
    let cases: Vec<Case> = vec![
        (vec![("specifications", format!("cpfg {} plant.l\n", outside_abs("v.v")))], "specifications:1"),
        (vec![("specifications", "cpfg ../elsewhere/v.v plant.l\n".into())], "specifications:1"),
        (
            vec![("specifications", format!("cpfg -e {} plant.l\n", outside_abs("x.e")))],
            "specifications:1: `-e`",
        ),
        (vec![("specifications", "cpfg -m ../elsewhere/c.map plant.l\n".into())], "specifications:1: `-m`"),
        (
            vec![("specifications", format!("cpfg -M {} plant.l\n", outside_abs("c.map")))],
            "specifications:1: `-M`",
        ),
        (
            vec![("plant.v", format!("angle increment: 30\nfunction: {}\n", outside_abs("f.func")))],
            "plant.v:2: `function:`",
        ),
        (vec![("plant.v", "function set: ../elsewhere/f.fset\n".into())], "plant.v:1: `function set:`"),
        (vec![("plant.v", "surface: l ../elsewhere/l.s 1\n".into())], "plant.v:1: `surface:`"),
        (vec![("plant.v", format!("contour: 1 {}\n", outside_abs("c.con")))], "plant.v:1: `contour:`"),
        (vec![("plant.v", "curve: ../elsewhere/c.con\n".into())], "plant.v:1: `curve:`"),
        (
            vec![
                ("specifications", "cpfg -e plant.e plant.l plant.v\n".into()),
                ("plant.e", format!("executable: honda81 {}\n", outside_abs("d.spec"))),
            ],
            "plant.e: `executable:`",
        ),
        (
            vec![
                ("specifications", "cpfg -e plant.e plant.l plant.v\n".into()),
                ("plant.e", "executable: honda81 ../elsewhere/d.spec\n".into()),
            ],
            "plant.e: `executable:`",
        ),
    ];
    for (k, (files, place)) in cases.iter().enumerate() {
        let m = d.join(format!("m{k}"));
        write(&m.join("plant.l"), PLANT);
        for (name, text) in files {
            write(&m.join(name), text);
        }
        let e = derive(&m.join("plant.l"), &[]).expect_err(place);
        assert!(
            e.contains(place)
                && e.contains("generator.allow_paths")
                && e.contains("outside the model folder")
                && e.contains(&out.display().to_string()),
            "case {k} ({place}): {e}"
        );
        // Allowed, the same folder loads (missing files are notes, as before).
        let notes = derive(&m.join("plant.l"), &[&allow]);
        assert!(notes.is_ok(), "case {k} ({place}) allowed: {notes:?}");
    }
    // The view file comes from the allowed folder.
    let notes = derive(&d.join("m0/plant.l"), &[&allow]).unwrap();
    assert!(notes.iter().any(|n| n.contains("elsewhere/v.v")), "{notes:?}");

    // Symbolic links out of the folder: the view file found by its stem, a listed
    // function, a linked sub-folder.
    let m = d.join("links");
    write(&m.join("plant.l"), PLANT);
    link(&out.join("v.v"), &m.join("plant.v"));
    let e = derive(&m.join("plant.l"), &[]).unwrap_err();
    assert!(e.contains("generator.allow_paths") && e.contains(&outside_abs("v.v")), "{e}");
    assert!(derive(&m.join("plant.l"), &[&allow]).is_ok());
    let m = d.join("links2");
    write(&m.join("plant.l"), PLANT);
    link(&out, &m.join("sub"));
    write(&m.join("plant.v"), "function: sub/f.func\n");
    let e = derive(&m.join("plant.l"), &[]).unwrap_err();
    assert!(e.contains("plant.v:1: `function:`") && e.contains("generator.allow_paths"), "{e}");
    assert!(derive(&m.join("plant.l"), &[&allow]).is_ok());
    // Inside the folder, `..` that stays inside is fine.
    let m = d.join("inside");
    write(&m.join("plant.l"), PLANT);
    write(&m.join("funcs/f.func"), &std::fs::read_to_string(out.join("f.func")).unwrap());
    write(&m.join("plant.v"), "function: funcs/../funcs/f.func\n");
    assert!(derive(&m.join("plant.l"), &[]).is_ok());
    std::fs::remove_dir_all(&d).unwrap();
}

/// Item 14: lines of a spec file (a file the user did not name) never come back in a
/// message: not as warnings, not in errors, not in excerpts.
#[test]
fn item14_spec_file_lines_are_never_quoted() {
    let d = temp("secret");
    let m = d.join("model");
    write(&m.join("plant.l"), PLANT);
    write(&m.join("specifications"), "cpfg -e plant.e plant.l\n");
    write(&m.join("plant.e"), "executable: honda81 key.spec\n");
    let secret = "PRIVATE-KEY-LINE-XYZ";
    let key: String = (0..40).map(|i| format!("{secret}{i}AAAAB3NzaC1yc2EAAAADAQABAAABAQ\n")).collect();
    write(&m.join("key.spec"), &format!("-----BEGIN OPENSSH PRIVATE KEY-----\n{key}radius: 0.1\n"));
    let notes = derive(&m.join("plant.l"), &[]).unwrap();
    let all = notes.join("\n");
    assert!(!all.contains(secret), "{all}");
    assert!(all.contains("key.spec") && all.contains("41 lines are not `key: value`"), "{all}");
    let grown = grow(&m.join("plant.l"), &[]).unwrap();
    let all = grown.report.warnings.join("\n");
    assert!(!all.contains(secret), "{all}");

    // The same key outside the folder, named by the `.e` file or linked: refused and
    // not read.
    let private = d.join("id_rsa");
    write(&private, &key);
    write(&m.join("plant.e"), &format!("executable: honda81 {}\n", private.display()));
    let e = derive(&m.join("plant.l"), &[]).unwrap_err();
    assert!(!e.contains(secret) && e.contains("generator.allow_paths"), "{e}");
    std::fs::remove_file(m.join("key.spec")).unwrap();
    link(&private, &m.join("key.spec"));
    write(&m.join("plant.e"), "executable: honda81 key.spec\n");
    let e = derive(&m.join("plant.l"), &[]).unwrap_err();
    assert!(!e.contains(secret) && e.contains("generator.allow_paths"), "{e}");
    // Allowed explicitly, its lines are still only counted.
    let allow = format!("generator.allow_paths=[\"{}\"]", d.display());
    let all = derive(&m.join("plant.l"), &[&allow]).unwrap().join("\n");
    assert!(!all.contains(secret) && all.contains("40 lines"), "{all}");
    // A view file of key-like lines: notes quote at most a short excerpt.
    write(&m.join("plant.e"), "executable: honda81\n");
    let long = "Z".repeat(500);
    write(&m.join("plant.v"), &format!("{long}\n{long}: 1\n"));
    write(&m.join("specifications"), "cpfg -e plant.e plant.l plant.v\n");
    let all = derive(&m.join("plant.l"), &[]).unwrap().join("\n").to_lowercase();
    assert!(!all.contains(&"z".repeat(61)) && all.contains("zzzz"), "{all}");
    std::fs::remove_dir_all(&d).unwrap();
}
