//! `sylva render` end to end (issue 25 item 5): four presets drawn on the GPU agree with
//! the CPU preview of the same camera (silhouette overlap ≥ 95 %), `--wind` frames
//! differ, `--forest` draws instanced, bad input is refused without writing a file.
//!
//! Silhouette metric: a pixel belongs to the silhouette when any of its RGB channels
//! differs by more than 6 from the background gradient both renderers paint (the CPU
//! preview's, recomputed per row); overlap is the intersection over union of the two
//! silhouettes' pixel sets.
//!
//! Where no GPU adapter exists the binary must say so (exit code ≠ 0, naming
//! `sylva grow --preview` as the CPU alternative, writing nothing) and the GPU checks are
//! skipped with a printed reason, unless `SYLVA_REQUIRE_GPU=1` makes that a failure.

use std::path::{Path, PathBuf};
use sylva::preview::{iou, Image};

mod common;
use common::{sylva, Run};

fn tempdir(name: &str) -> PathBuf {
    common::tempdir("render", name)
}

fn gpu_required() -> bool {
    std::env::var("SYLVA_REQUIRE_GPU").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// Runs `sylva render …`; `None` (after checking the fallback message and printing why
/// the test is skipped) where the binary finds no GPU adapter.
fn render_or_skip(what: &str, args: &[&str], cwd: &Path) -> Option<Run> {
    let r = sylva(args, cwd);
    let no_gpu = r.stderr.contains("no GPU adapter") || r.stderr.contains("without GPU support");
    if r.code != 0 && no_gpu {
        assert!(r.stderr.contains("sylva grow") && r.stderr.contains("--preview"), "{}", r.stderr);
        let written: Vec<_> = std::fs::read_dir(cwd).unwrap().collect();
        assert!(written.is_empty(), "nothing is written without an adapter");
        if gpu_required() {
            panic!("{what}: {} (SYLVA_REQUIRE_GPU is set)", r.stderr.trim());
        }
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "skipping {what}: {} (set SYLVA_REQUIRE_GPU=1 to make this a failure)",
            r.stderr.trim()
        );
        return None;
    }
    assert_eq!(r.code, 0, "{what}: {}", r.stderr);
    Some(r)
}

/// An RGBA PNG as an image.
fn read_png(p: &Path) -> Image {
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    buf.truncate(info.buffer_size());
    Image::from_rgba(info.width, info.height, buf)
}

/// The silhouette (see the module docs) of a picture over the preview background.
fn silhouette(image: &Image) -> Vec<bool> {
    let d = sylva::preview::PreviewOptions::default();
    sylva::preview::silhouette(image, d.background, d.background_top, 6)
}

#[test]
fn four_presets_match_the_cpu_preview_silhouette() {
    let d = tempdir("presets");
    let size = 512;
    for preset in ["lsys-honda-a", "wp-quaking-aspen", "colonize-shrub", "mig-a"] {
        let out = format!("{preset}.png");
        let args = ["render", preset, "-o", &out, "--size", "512x512", "--camera", "orbit:30,15", "-q"];
        let Some(_) = render_or_skip("sylva render (four presets)", &args, &d) else { return };
        let gpu = read_png(&d.join(&out));
        assert_eq!((gpu.width, gpu.height), (size, size));
        let loaded = sylva::recipe::load(preset, &[]).unwrap();
        let model = sylva::pipeline::grow(&loaded).unwrap().model;
        let opts = sylva::preview::PreviewOptions {
            width: size,
            height: size,
            view: Some(sylva::preview::ViewAngles { azimuth_deg: 30.0, elevation_deg: 15.0 }),
            ..Default::default()
        };
        let cpu = sylva::preview::render(&model, &opts).unwrap();
        let (a, b) = (silhouette(&gpu), silhouette(&cpu));
        let overlap = iou(&a, &b);
        let filled = a.iter().filter(|&&x| x).count() as f64 / a.len() as f64;
        eprintln!("{preset}: silhouette IoU {overlap:.4}, GPU coverage {filled:.3}");
        assert!(filled > 0.02, "{preset}: the GPU picture is not empty ({filled})");
        assert!(overlap >= 0.95, "{preset}: silhouette IoU with the CPU preview {overlap:.4} < 0.95");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn wind_frames_move_and_animations_are_written() {
    let d = tempdir("wind");
    let args = [
        "render",
        "lsys-honda-a",
        "--wind",
        "storm",
        "--frames",
        "2",
        "--fps",
        "4",
        "--size",
        "200x160",
        "-o",
        "f_%02d.png",
        "-q",
    ];
    let Some(_) = render_or_skip("sylva render --wind", &args, &d) else { return };
    let (a, b) = (read_png(&d.join("f_00.png")), read_png(&d.join("f_01.png")));
    assert_eq!((a.width, a.height), (200, 160));
    let changed = a.data.chunks(4).zip(b.data.chunks(4)).filter(|(p, q)| p != q).count();
    assert!(changed > 50, "only {changed} pixels changed between wind frames");
    let r = sylva(
        &["render", "lsys-honda-a", "--wind", "breeze", "--frames", "3", "--size", "64x64", "-o", "w.gif"],
        &d,
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("3 frame(s)"), "{}", r.stdout);
    assert_eq!(&std::fs::read(d.join("w.gif")).unwrap()[..6], b"GIF89a");
    let r = sylva(
        &["render", "lsys-honda-a", "--wind", "breeze", "--frames", "3", "--size", "64x64", "-o", "w.png"],
        &d,
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(std::fs::read(d.join("w.png")).unwrap().windows(4).any(|w| w == b"acTL"), "an APNG");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_forest_is_drawn_instanced() {
    let d = tempdir("forest");
    let args = ["render", "lsys-honda-a", "--forest", "12", "--size", "320x200", "-o", "forest.png"];
    let Some(r) = render_or_skip("sylva render --forest", &args, &d) else { return };
    assert!(r.stdout.contains("12 tree(s)"), "{}", r.stdout);
    // One draw per (level, part, material) however many trees: honda has one bark part.
    assert!(r.stdout.contains(" 1 draw call(s) per frame"), "{}", r.stdout);
    let filled = silhouette(&read_png(&d.join("forest.png"))).iter().filter(|&&x| x).count();
    assert!(filled > 1000, "{filled} pixels of trees");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_render_input_is_refused_and_writes_nothing() {
    let d = tempdir("bad");
    let cases: &[(&[&str], &str)] = &[
        (&["--size", "0x100"], "--size"),
        (&["--size", "12by5"], "WIDTHxHEIGHT"),
        (&["--size", "9000x10"], "1..=8192"),
        (&["--camera", "orbit:30"], "orbit:AZ,EL"),
        (&["--camera", "orbit:0,120"], "elevation"),
        (&["--forest", "0"], "--forest"),
        (&["--forest", "1000000"], "--forest"),
        (&["--frames", "0"], "--frames"),
        (&["--wind", "hurricane"], "wind"),
        (&["-o", "x.bmp"], ".bmp"),
        (&["-o", "x_%3d.png"], "%0Nd"),
    ];
    for (extra, says) in cases {
        let mut args = vec!["render", "lsys-honda-a"];
        if extra[0] != "-o" {
            args.extend(["-o", "out.png"]);
        }
        args.extend_from_slice(extra);
        let r = sylva(&args, &d);
        assert_ne!(r.code, 0, "{extra:?} is refused");
        assert!(r.stderr.contains(says), "{extra:?}: {}", r.stderr);
        let written: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
        assert!(written.is_empty(), "{extra:?} wrote {written:?}");
    }
    let _ = std::fs::remove_dir_all(&d);
}
