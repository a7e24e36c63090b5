//! Issue 40 item 4, through the `sylva` binary: errors name what the user typed (`-n` on
//! a Weber–Penn tree, a bad `generator.levels`), `--help` says what sylva is, the shared
//! flags are the same on every subcommand, and the value parsers of `--size`, `--wind`
//! and `--lod` name the flag and the form they accept. Tests run without a terminal, so
//! no progress bar shows.

mod common;

use common::{assert_says, sylva, tempdir};

#[test]
fn n_on_weber_penn_says_what_n_is_and_what_to_use_instead() {
    let d = tempdir("cli-thin", "n-weber-penn");
    let r = sylva(&["grow", "wp-quaking-aspen", "-n", "5", "-o", "aspen.glb"], &d);
    assert_eq!(r.code, 1, "{}", r.stderr);
    let says = [
        "-n 5",
        "derivation steps",
        "L-system",
        "`wp-quaking-aspen` is a Weber–Penn tree",
        "--set generator.levels=N",
    ];
    assert_says("-n 5", &r.stderr, &says);
    assert!(!r.stderr.contains("unknown key"), "{}", r.stderr);
    assert!(!r.stderr.contains("generator.iterations"), "a key the user never typed: {}", r.stderr);
    assert!(!d.join("aspen.glb").exists() && !d.join("aspen.png").exists());
    // The same words from the other subcommands that take -n, and for other generators.
    let r = sylva(&["lsys", "derive", "wp-quaking-aspen", "-n", "2"], &d);
    assert!(r.code == 1 && r.stderr.contains("is a Weber–Penn tree"), "{}", r.stderr);
    let r = sylva(&["grow", "colonize-shrub", "-n", "3", "-o", "c.glb"], &d);
    assert!(r.code == 1 && r.stderr.contains("space-colonization tree"), "{}", r.stderr);
    assert!(r.stderr.contains("generator.max_iterations"), "{}", r.stderr);
    // An L-system still takes -n.
    let r = sylva(&["grow", "lsys-binary-tree", "-n", "2", "-o", "b.glb", "--no-preview"], &d);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("derived 2 steps"), "{}", r.stdout);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_bad_generator_levels_names_the_key_and_the_value() {
    let d = tempdir("cli-thin", "levels");
    let r = sylva(&["grow", "wp-quaking-aspen", "--set", "generator.levels=abc", "-o", "a.glb"], &d);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("`generator.levels`"), "{}", r.stderr);
    assert!(r.stderr.contains("abc"), "{}", r.stderr);
    let r = sylva(&["grow", "wp-quaking-aspen", "--set", "generator.levels=9", "-o", "a.glb"], &d);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("levels") && r.stderr.contains("1..=4"), "{}", r.stderr);
    assert!(!d.join("a.glb").exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn help_says_what_sylva_is() {
    let d = tempdir("cli-thin", "help");
    let r = sylva(&["--help"], &d);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("sylva grows trees and plants"), "{}", r.stdout);
    assert_says("--help", &r.stdout, &["L-system", "Weber & Penn", "space\ncolonization", "glTF", "wind"]);
    assert!(!r.stdout.contains("The sylva command-line tool"), "{}", r.stdout);
    let r = sylva(&["-h"], &d);
    assert!(r.stdout.starts_with("sylva grows trees and plants"), "{}", r.stdout);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_shared_flags_are_the_same_on_every_subcommand() {
    let d = tempdir("cli-thin", "shared");
    let shared = [
        "[WHAT]",
        "-n, --iterations",
        "--seed <SEED>",
        "--set <KEY=VALUE>",
        "-q, --quiet",
        "Derivation steps of an L-system",
    ];
    for sub in [&["grow"][..], &["render"], &["lsys", "derive"]] {
        let r = sylva(&[sub, &["--help"][..]].concat(), &d);
        assert_eq!(r.code, 0, "{sub:?}: {}", r.stderr);
        assert_says(&format!("{sub:?}"), &r.stdout, &shared);
    }
    let r = sylva(&["lsys", "derive", "lsys-binary-tree", "-n", "2", "--seed", "3", "-q"], &d);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout.trim(), "bb[b[a]a]b[a]a");
    // Without a terminal, no progress bar: a quiet grow prints nothing at all.
    let r = sylva(&["grow", "lsys-binary-tree", "-q", "-o", "t.glb", "--no-preview"], &d);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.is_empty() && r.stderr.is_empty(), "{:?} {:?}", r.stdout, r.stderr);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn value_parsers_name_the_flag_what_was_typed_and_the_form() {
    let d = tempdir("cli-thin", "parsers");
    let cases: &[(&[&str], &[&str])] = &[
        (&["render", "--size", "12by5", "-o", "r.png"], &["--size 12by5", "WIDTHxHEIGHT"]),
        (&["render", "--size", "0x5", "-o", "r.png"], &["--size 0x5", "1..=8192"]),
        (&["render", "--wind", "gale", "-o", "r.png"], &["--wind gale", "none, calm, breeze or storm"]),
        (&["grow", "--wind", "hurricane", "-o", "g.glb"], &["--wind hurricane", "wind.preset"]),
        (&["grow", "--lod", "3000,lots", "-o", "g.glb"], &["--lod 3000,lots", "`lots`", "12..=10000000"]),
        (&["render", "--lod", "impostor,300", "-o", "r.png"], &["--lod impostor,300", "must come last"]),
    ];
    for (args, wants) in cases {
        let r = sylva(args, &d);
        assert_eq!(r.code, 1, "{args:?}: {}", r.stderr);
        assert_says(&format!("{args:?}"), &r.stderr, wants);
    }
    let written: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
    assert!(written.is_empty(), "bad flags wrote {written:?}");
    let r = sylva(
        &["grow", "lsys-binary-tree", "--wind", "calm", "--lod", "3000,300", "-o", "w.glb", "--no-preview"],
        &d,
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("LOD1"), "{}", r.stdout);
    let _ = std::fs::remove_dir_all(&d);
}
