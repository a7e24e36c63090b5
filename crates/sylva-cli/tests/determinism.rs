//! Same recipe and seed, same bytes, whatever the thread count (issue 27): `sylva grow`
//! runs with `RAYON_NUM_THREADS` = 1, 2 and 7 and must write byte-identical `.glb`
//! files, for one preset of every generator (L-system, Weber–Penn, space colonization,
//! least-cost MIG and MGV, an imported `.lst`) and for every mesher (tube, hull, sweep,
//! quad). The trees are kept small (fewer steps, points or graph nodes, 64-pixel
//! textures) so the test stays cheap in debug builds.

use std::path::{Path, PathBuf};
use std::process::Command;

const THREADS: [&str; 3] = ["1", "2", "7"];

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sylva-determinism-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// `sylva grow what -o out --no-preview` with `threads` worker threads.
fn grow(what: &str, sets: &[&str], out: &Path, threads: &str) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sylva"));
    cmd.args(["grow", what, "-o"]).arg(out).args(["--no-preview", "-q"]);
    cmd.args(["--set", "textures.bark_size=64", "--set", "textures.atlas_size=64"]);
    for s in sets {
        cmd.args(["--set", s]);
    }
    cmd.env("RAYON_NUM_THREADS", threads);
    let o = cmd.output().unwrap();
    assert!(
        o.status.success(),
        "sylva grow {what} {sets:?} with {threads} thread(s) failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Grows `what` with 1, 2 and 7 threads and compares the files byte for byte.
fn same_bytes(label: &str, what: &str, sets: &[&str]) {
    let mut first: Option<Vec<u8>> = None;
    for t in THREADS {
        let out = temp(&format!("{label}-{t}.glb"));
        grow(what, sets, &out, t);
        let bytes = std::fs::read(&out).unwrap();
        assert!(bytes.len() > 1000, "{label}: a tiny file ({} bytes)", bytes.len());
        match &first {
            None => first = Some(bytes),
            Some(f) => assert!(
                *f == bytes,
                "{label}: {t} threads wrote different bytes than 1 thread ({} vs {} bytes)",
                bytes.len(),
                f.len()
            ),
        }
        let _ = std::fs::remove_file(&out);
    }
}

#[test]
fn every_generator_writes_the_same_bytes_with_1_2_and_7_threads() {
    same_bytes("lsystem", "lsys-honda-a", &["generator.iterations=6"]);
    same_bytes("weber-penn", "wp-palm", &[]);
    same_bytes("colonize", "colonize-shrub", &["generator.points=1500"]);
    same_bytes("mig", "mig-a", &["generator.nodes=4000"]);
    same_bytes("mgv", "mgv-a", &["generator.nodes=4000"]);
    // An imported skeleton: the LST that `sylva grow … -o x.lst` writes.
    let lst = temp("import.lst");
    let o = Command::new(env!("CARGO_BIN_EXE_sylva"))
        .args(["grow", "lsys-binary-tree", "-n", "5", "-o"])
        .arg(&lst)
        .args(["--no-preview", "-q"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    same_bytes("import", lst.to_str().unwrap(), &[]);
}

#[test]
fn every_mesher_writes_the_same_bytes_with_1_2_and_7_threads() {
    for method in ["tube", "hull", "sweep", "quad"] {
        let set = format!("mesh.method={method}");
        same_bytes(method, "lsys-binary-tree", &["generator.iterations=4", &set]);
    }
}
