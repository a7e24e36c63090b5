//! Open L-systems (issue 3): communication modules `?E` answered by the built-in
//! environmental program `honda81`, the model folder's `.e` file, and the cpfg
//! statements models use around them (`stop`, file output, the cut `%`).

#[path = "common/folders.rs"]
mod folders;
#[path = "common/recipes.rs"]
mod recipes;

use recipes::derive;
use std::path::PathBuf;
use sylva::lsystem::ErrorKind;

/// A fresh folder under the system temp dir holding `files`.
fn folder(tag: &str, files: &[(&str, &str)]) -> PathBuf {
    folders::with_files("open", tag, files)
}

fn derive_err(file: &std::path::Path, kv: &[&str]) -> sylva::Error {
    match derive(file, kv) {
        Ok(_) => panic!("{} should not derive", file.display()),
        Err(e) => e,
    }
}

/// The Sierpinski gasket of vlab's `07-Open` folder: tips grow while no other tip
/// reaches the same point.
const SIERPINSKI: &str = "Lsystem: 1\nderivation length: 15\nAxiom: |+(30) ?E(0)\n\
                          ?E(x) : x==1 --> ;[F?E(0)]-(60)/(180)[F?E(0)]\nendlsystem\n";

#[test]
fn honda81_grows_pascals_triangle_mod_two() {
    // Tips of level k sit at the points i = 0..=k of a triangular lattice, C(k, i)
    // of them; pairs at one point stop each other, so a tip survives exactly where
    // C(k, i) is odd: 2^popcount(k) live tips, each drawing two lines.
    let dir = folder("sierpinski", &[("fractal.l", SIERPINSKI)]);
    for n in 1..=12u32 {
        let d = derive(
            dir.join("fractal.l"),
            &["generator.environment.program=\"honda81\"", &format!("generator.iterations={n}")],
        )
        .unwrap();
        let text = d.lsystem.format(&d.string);
        let lines = text.matches('F').count();
        let expect: u32 = (0..n).map(|k| 2 * (1u32 << k.count_ones())).sum();
        assert_eq!(lines as u32, expect, "lines after {n} steps");
        // The environment answers after every step: live tips hold ?E(1), stopped ?E(0).
        let live = text.matches("?E(1)").count() as u32;
        assert_eq!(live, 1 << n.count_ones(), "live tips after {n} steps");
    }
}

#[test]
fn honda81_stronger_primordium_wins() {
    // Vogel's spiral of 200 primordia with increasing vigor; a primordium becomes a
    // ray floret (drawn as a polygon) when no primordium within the radius is stronger.
    // Two steps, as cpfg needs: the first decomposes A(0) into the primordia (cpfg does
    // not decompose the axiom), the second rewrites each C by its ?E's answer.
    let model = "#define N 200\nLsystem: 1\nderivation length: 2\nAxiom: A(0)\n\
                 C(n) > ?E(x) : x==0 --> @c(1)\nC(n) > ?E(x) : x==1 --> {.+F.}\n\
                 decomposition\nmaximum depth: 1000\n\
                 A(n) : n < N --> [+(n*137.5)f(0.5*n^0.5)C(n)?E(n)]A(n+1)\nendlsystem\n";
    let dir = folder("vogel", &[("plant.l", model)]);
    for radius in [0.8, 0.91, 1.1] {
        let d = derive(
            dir.join("plant.l"),
            &["generator.environment.program=\"honda81\"", &format!("generator.environment.radius={radius}")],
        )
        .unwrap();
        let text = d.lsystem.format(&d.string);
        // Independent count: positions in the plane, brute force.
        let p: Vec<(f64, f64)> = (0..200)
            .map(|n| {
                let (r, a) = (0.5 * (n as f64).sqrt(), (n as f64 * 137.5).to_radians());
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let rays = (0..200)
            .filter(|&i| {
                (0..200).all(|j| {
                    j <= i || ((p[i].0 - p[j].0).powi(2) + (p[i].1 - p[j].1).powi(2)).sqrt() >= radius
                })
            })
            .count();
        assert_eq!(text.matches('{').count(), rays, "ray florets at radius {radius}");
        assert_eq!(text.matches("@c").count(), 200 - rays);
        assert!(rays > 0 && rays < 200);
    }
}

#[test]
fn the_model_folders_environment_file_names_the_program() {
    let spec = "fractal.l\nfractal.e\n*\nmodel:\n\tgenerate:\n\t\tcpfg -e fractal.e fractal.l fractal.v\n";
    let dir = folder(
        "efile",
        &[
            ("fractal.l", SIERPINSKI),
            ("specifications", spec),
            ("fractal.e", "executable: honda81 -e density.spec\ncommunication type: pipes\n"),
        ],
    );
    let d = derive(dir.join("fractal.l"), &["generator.iterations=4"]).unwrap();
    assert_eq!(d.folder.as_ref().unwrap().environment_program.as_deref(), Some("honda81"));
    assert_eq!(d.lsystem.format(&d.string).matches('F').count(), 2 * (1 + 2 + 2 + 4));
    // A program sylva does not have is unsupported, named, at the model's `?E`.
    std::fs::write(dir.join("fractal.e"), "executable: lightning light.spec\n").unwrap();
    let e = derive_err(&dir.join("fractal.l"), &[]);
    let msg = e.to_string();
    assert!(matches!(&e, sylva::Error::Lsystem(l) if l.kind == ErrorKind::Unsupported), "{msg}");
    assert!(msg.contains("fractal.l:3:") && msg.contains("`lightning`") && msg.contains("honda81"), "{msg}");
    // Without any environment, `?E` is unsupported at its line.
    std::fs::remove_file(dir.join("fractal.e")).unwrap();
    let e = derive_err(&dir.join("fractal.l"), &[]);
    let msg = e.to_string();
    assert!(matches!(&e, sylva::Error::Lsystem(l) if l.kind == ErrorKind::Unsupported), "{msg}");
    assert!(msg.contains("fractal.l:3:") && msg.contains("?E") && msg.contains("`fractal.e`"), "{msg}");
    // A bad radius is a recipe error.
    let e = derive_err(
        &dir.join("fractal.l"),
        &["generator.environment.program=\"honda81\"", "generator.environment.radius=-1"],
    );
    assert!(e.to_string().contains("radius"), "{e}");
}

#[test]
fn stop_ends_the_derivation_after_its_step() {
    let model = "Lsystem: 1\nderivation length: 50\nAxiom: A(0)\n\
                 A(n) : n < 100 {stop(n >= 6);} --> FA(n+1)\nendlsystem\n";
    let dir = folder("stop", &[("p.l", model)]);
    let d = derive(dir.join("p.l"), &[]).unwrap();
    // stop(1) is called while rewriting A(6) in step 7: that step completes.
    assert_eq!(d.steps, 7);
    assert_eq!(d.lsystem.format(&d.string), "FFFFFFFA(7)");
}

#[test]
fn file_output_is_accepted_discarded_and_reported() {
    let model = "Lsystem: 1\nderivation length: 3\n\
                 Start: {fp = fopen(\"out.txt\", \"w\");}\n\
                 EndEach: {fprintf(fp, \"%f\\n\", 1); fflush(fp);}\nEnd: {fclose(fp);}\n\
                 Axiom: A\nA --> FA\nendlsystem\n";
    let dir = folder("fopen", &[("p.l", model)]);
    let d = derive(dir.join("p.l"), &[]).unwrap();
    assert_eq!(d.lsystem.format(&d.string), "FFFA");
    assert!(d.warnings.iter().any(|w| w.contains("fopen")), "{:?}", d.warnings);
    assert!(!dir.join("out.txt").exists(), "sylva writes no file for the model");
}

#[test]
fn cut_erases_the_rest_of_the_branch_one_step_later() {
    let model = "Lsystem: 1\nderivation length: 2\nAxiom: F[FX[F]F]FX\nX --> %\nendlsystem\n";
    let dir = folder("cut", &[("p.l", model)]);
    let one = derive(dir.join("p.l"), &["generator.iterations=1"]).unwrap();
    assert_eq!(one.lsystem.format(&one.string), "F[F%[F]F]F%");
    let two = derive(dir.join("p.l"), &[]).unwrap();
    assert_eq!(two.lsystem.format(&two.string), "F[F]F");
}
