//! Issue 39, items 10–13, in the library: the files of an export (model, `.mtl`,
//! textures) and whatever else a run stages with them are one result
//! ([`sylva::fsutil::OutputSet`]).

#[path = "common/folders.rs"]
mod folders;
#[path = "common/tmpfs.rs"]
mod tmpfs;

use folders::{leftovers, snapshot};
use std::path::{Path, PathBuf};
use sylva::export::{stage_with_options, write_with_options, ExportOptions};
use sylva::fsutil::OutputSet;
use tmpfs::Tmpfs;

/// An empty folder for one test.
fn tempdir(name: &str) -> PathBuf {
    folders::tempdir("robust-outputs", name)
}

/// `preset` grown with `sets` (`key=value`).
fn grow(preset: &str, sets: &[&str]) -> sylva::Model {
    let sets: Vec<_> = sets.iter().map(|s| sylva::recipe::parse_set(s).unwrap()).collect();
    let loaded = sylva::recipe::load(preset, &sets).unwrap();
    sylva::pipeline::grow(&loaded).unwrap().model
}

/// OBJ options: texture files beside the model.
fn obj_options(path: &Path) -> ExportOptions {
    ExportOptions {
        textures: sylva::export::TextureMode::for_output("files", path).unwrap(),
        ..Default::default()
    }
}

#[test]
fn item10_stale_temporaries_of_a_dead_process_are_removed_by_the_next_export() {
    let d = tempdir("stale");
    let path = d.join("t.obj");
    // What a run killed with SIGKILL leaves: its temporaries (PID 4194305 is above Linux's
    // PID_MAX_LIMIT, so that process never exists) — and one of a live process (init).
    for name in [".t.obj.tmp-4194305", ".t.mtl.tmp-4194305-12", ".t.obj.tmp-4194305-3.old", ".t.obj.tmp-1-1"]
    {
        std::fs::write(d.join(name), b"left behind").unwrap();
    }
    let model = grow("lsys-honda-a", &[]);
    write_with_options(&model, &path, &obj_options(&path)).unwrap();
    assert_eq!(leftovers(&d), [".t.obj.tmp-1-1"], "only the live process's temporary stays");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn item11_a_failed_commit_puts_the_earlier_export_back() {
    let d = tempdir("rollback");
    let path = d.join("t.obj");
    let model = grow("lsys-honda-a", &[]);
    write_with_options(&model, &path, &obj_options(&path)).unwrap();
    let before = snapshot(&d);
    assert!(before.keys().filter(|n| n.ends_with(".png")).count() >= 2, "{:?}", before.keys());
    // A different tree over it, with one more file in the set whose rename fails after
    // the .mtl and the textures were renamed.
    let other = grow("lsys-honda-a", &["seed=9", "generator.iterations=4"]);
    let mut set = OutputSet::new(&path);
    stage_with_options(&other, &path, &obj_options(&path), &mut set).unwrap();
    set.stage(&d.join("extra.txt"), |w| w.write_all(b"extra")).unwrap();
    std::fs::create_dir(d.join("extra.txt")).unwrap();
    let e = set.commit().unwrap_err().to_string();
    assert!(e.contains("extra.txt"), "{e}");
    std::fs::remove_dir(d.join("extra.txt")).unwrap();
    assert_eq!(snapshot(&d), before, "the earlier .obj, .mtl and textures are put back byte for byte");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn item11_an_obj_export_that_fills_the_disk_leaves_the_earlier_export_whole() {
    // The case: the textures and the .mtl fit, the larger .obj does not.
    let small = grow("lsys-honda-a", &["generator.iterations=3"]);
    let large = grow("lsys-honda-a", &[]);
    let probe = tempdir("full-probe");
    let size_of = |model: &sylva::Model| {
        let p = probe.join("t.obj");
        write_with_options(model, &p, &obj_options(&p)).unwrap();
        let total: u64 =
            std::fs::read_dir(&probe).unwrap().map(|e| e.unwrap().metadata().unwrap().len()).sum();
        let obj = std::fs::metadata(&p).unwrap().len();
        for e in std::fs::read_dir(&probe).unwrap() {
            std::fs::remove_file(e.unwrap().path()).unwrap();
        }
        (total, obj)
    };
    let (small_total, _) = size_of(&small);
    let (large_total, large_obj) = size_of(&large);
    let _ = std::fs::remove_dir_all(&probe);
    // Room for the small export and the large one's side files, not its .obj.
    let page = 4096;
    let room = (small_total + large_total - large_obj).div_ceil(page) * page + 16 * page;
    assert!(large_obj > 20 * page, "the large .obj ({large_obj} bytes) must not fit");
    let Some(fs) = Tmpfs::mount("full-disk", tempdir("full-disk"), room) else { return };
    let path = fs.0.join("t.obj");
    write_with_options(&small, &path, &obj_options(&path)).unwrap();
    let before = snapshot(&fs.0);
    let e = write_with_options(&large, &path, &obj_options(&path)).unwrap_err().to_string();
    assert!(e.contains("No space left"), "{e}");
    assert_eq!(snapshot(&fs.0), before, "the earlier .obj, .mtl and textures are untouched");
}

#[test]
fn item13_concurrent_commits_into_one_name_leave_one_whole_set() {
    let d = tempdir("concurrent");
    let (model, preview) = (d.join("t.glb"), d.join("t.png"));
    for round in 0..40 {
        let threads: Vec<_> = [b'a', b'b']
            .map(|tag| {
                let (model, preview) = (model.clone(), preview.clone());
                std::thread::spawn(move || {
                    let mut set = OutputSet::new(&model);
                    set.stage(&model, |w| w.write_all(&[tag; 64])).unwrap();
                    set.stage(&preview, |w| w.write_all(&[tag; 8])).unwrap();
                    set.commit().unwrap();
                })
            })
            .into();
        for t in threads {
            t.join().unwrap();
        }
        let (m, p) = (std::fs::read(&model).unwrap(), std::fs::read(&preview).unwrap());
        assert_eq!(m[0], p[0], "round {round}: the model and the preview come from different runs");
        assert_eq!(leftovers(&d), Vec::<String>::new());
    }
    let _ = std::fs::remove_dir_all(&d);
}
