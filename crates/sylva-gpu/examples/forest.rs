//! Skjermo2008's forest scene (D Fig. 14: 20 trees of 2 species, Black Tupelo and Quaking
//! Aspen) drawn with the GPU branch deformer (`BranchRenderer`), lit and bark-textured,
//! with GPU wind stepping every frame, into an offscreen 1920 × 1080 target with 4×
//! MSAA; prints frames per second (issue 25's benchmark).
//!
//! ```text
//! cargo run -p sylva-gpu --example forest                       # the 20-tree scene
//! cargo run -p sylva-gpu --example forest -- --branches 100000  # scaling: ≈ N branches
//! options: --frames N (default 20)  --width W --height H  --no-wind  --png out.png
//!          --full (the presets as shipped: several Bézier segments per stem, 4 levels)
//! ```
//!
//! Each species is grown once per seed (`wp-quaking-aspen` seeds 1–10 and
//! `wp-black-tupelo` seeds 1–10, the generators' own Bézier curves, no meshing) with one
//! Bézier per stem (`generator.n_curve_res = [1, 1, 1, 1]`: the seed's branch is one
//! cubic) and at most 3 levels (the tupelo ships with 4), turned
//! and placed on a jittered 5 × 4 grid 14 m apart; one `GpuWind` (`breeze`) and one
//! renderer per species, both drawn into one render pass. With `--branches N` the scene's
//! trees are repeated on a wider grid until the branch count reaches N (then cut at N),
//! and the camera backs off to keep the forest in view. Each frame: wind step, LOD pass,
//! render pass, submit, wait; the time of `--frames` frames after 3 warm-up frames gives
//! the fps. The adapter's name is printed.

use glam::{Quat, Vec3};
use std::time::Instant;
use sylva::deform::{branch_records, BranchRecord};
use sylva::model::BranchCurves;
use sylva::texture::bark::{bark_maps, BarkStyle};
use sylva::wind::{WindOptions, WindRig};
use sylva_gpu::branches::{BranchRenderer, Frame, Offscreen, TargetFormat};
use sylva_gpu::{Gpu, GpuWind};

struct Args {
    frames: usize,
    width: u32,
    height: u32,
    branches: Option<usize>,
    wind: bool,
    full: bool,
    png: Option<String>,
}

fn args() -> Args {
    let mut a =
        Args { frames: 20, width: 1920, height: 1080, branches: None, wind: true, full: false, png: None };
    let mut it = std::env::args().skip(1);
    while let Some(k) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{k} needs a value"));
        match k.as_str() {
            "--frames" => a.frames = value().parse().expect("--frames N"),
            "--width" => a.width = value().parse().expect("--width W"),
            "--height" => a.height = value().parse().expect("--height H"),
            "--branches" => a.branches = Some(value().parse().expect("--branches N")),
            "--no-wind" => a.wind = false,
            "--full" => a.full = true,
            "--png" => a.png = Some(value()),
            other => panic!("unknown option {other}"),
        }
    }
    a
}

/// The branch curves of preset `name` grown with `seed` (no meshing); unless `full`, one
/// Bézier per stem (`n_curve_res = 1`, the seed's branch: one cubic each) and at most 3
/// levels.
fn curves(name: &str, seed: i64, full: bool) -> BranchCurves {
    let mut sets = vec![("seed".to_string(), toml::Value::Integer(seed))];
    if !full {
        let ones = toml::Value::Array(vec![toml::Value::Integer(1); 4]);
        sets.push(("generator.n_curve_res".to_string(), ones));
        sets.push(("generator.levels".to_string(), toml::Value::Integer(3)));
    }
    let loaded = sylva::recipe::load(name, &sets).expect("preset loads");
    let mut report = sylva::pipeline::Report::default();
    let generated = sylva::pipeline::skeleton(&loaded, &mut report).expect("preset grows");
    generated.curves.unwrap_or_else(|| BranchCurves::fit(&generated.skeleton))
}

/// `c` turned by `angle` about +Y and moved to `at`.
fn placed(c: &BranchCurves, angle: f32, at: Vec3) -> BranchCurves {
    let q = Quat::from_rotation_y(angle);
    let mut c = c.clone();
    for axis in &mut c.axes {
        for s in &mut axis.segments {
            s.points = s.points.map(|p| q * p + at);
        }
    }
    c
}

/// One species' trees: branch records and one wind rig, parents first per tree.
#[derive(Default)]
struct Species {
    records: Vec<BranchRecord>,
    rig: Option<WindRig>,
}

impl Species {
    fn push(&mut self, c: &BranchCurves) {
        let rig = WindRig::new(c);
        let records = branch_records(c);
        assert_eq!(rig.branches.len(), records.len());
        self.records.extend(records);
        match &mut self.rig {
            None => self.rig = Some(rig),
            Some(all) => {
                let n = all.branches.len();
                for mut b in rig.branches {
                    b.parent = b.parent.map(|p| p + n);
                    all.branches.push(b);
                }
                all.points.extend(rig.points);
            }
        }
    }

    fn truncate(&mut self, n: usize) {
        self.records.truncate(n);
        if let Some(rig) = &mut self.rig {
            rig.branches.truncate(n);
            rig.points.truncate(n);
        }
    }
}

fn main() {
    let a = args();
    let Some(gpu) = Gpu::or_skip("forest") else { return };
    let t0 = Instant::now();
    let species = [("wp-quaking-aspen", BarkStyle::Birch), ("wp-black-tupelo", BarkStyle::Furrowed)];
    let trees: Vec<Vec<BranchCurves>> =
        species.iter().map(|(name, _)| (1..=10).map(|seed| curves(name, seed, a.full)).collect()).collect();
    let per_scene: usize =
        trees.iter().flatten().map(|c| c.axes.iter().map(|x| x.segments.len()).sum::<usize>()).sum();
    let want = a.branches.unwrap_or(per_scene);
    let copies = want.div_ceil(per_scene.max(1));
    let side_x = (copies as f64 * 20.0 / 4.0).sqrt().ceil().max(5.0) as usize; // trees per row
    let spacing = 14.0f32;
    let mut sets = [Species::default(), Species::default()];
    let mut jitter = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        jitter ^= jitter << 13;
        jitter ^= jitter >> 7;
        jitter ^= jitter << 17;
        (jitter >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut slot = 0usize;
    'fill: for _ in 0..copies {
        for (aspen, tupelo) in trees[0].iter().zip(&trees[1]) {
            for (s, tree) in [aspen, tupelo].into_iter().enumerate() {
                if a.branches.is_some() && sets[0].records.len() + sets[1].records.len() >= want {
                    break 'fill;
                }
                let at = Vec3::new(
                    (slot % side_x) as f32 * spacing + (rand() - 0.5) * 6.0,
                    0.0,
                    -((slot / side_x) as f32) * spacing + (rand() - 0.5) * 6.0,
                );
                slot += 1;
                sets[s].push(&placed(tree, rand() * std::f32::consts::TAU, at));
            }
        }
    }
    // Cut the scaling scenes at exactly N branches (the later species keeps the rest).
    if let Some(n) = a.branches {
        let first = sets[0].records.len().min(n);
        sets[0].truncate(first);
        sets[1].truncate(n - first);
    }
    let total: usize = sets.iter().map(|s| s.records.len()).sum();
    let rows = slot.div_ceil(side_x);
    let (w, d) = (side_x as f32 * spacing, rows as f32 * spacing);
    eprintln!(
        "forest: {slot} trees ({} aspen + {} tupelo branch records), {total} branches, built in {:.1} s",
        sets[0].records.len(),
        sets[1].records.len(),
        t0.elapsed().as_secs_f64()
    );

    let target = TargetFormat::default();
    let fov = 50f32.to_radians();
    let centre = Vec3::new(0.5 * w - 0.5 * spacing, 6.0, -0.5 * d + 0.5 * spacing);
    let eye = centre + Vec3::new(0.0, 0.35 * w.max(d) + 4.0, 0.75 * w.max(d) + 10.0);
    let breeze = WindOptions::preset("breeze").expect("wind preset");
    let mut winds = Vec::new();
    let mut renderers = Vec::new();
    for (s, set) in sets.iter().enumerate() {
        if set.records.is_empty() {
            continue;
        }
        let bark = bark_maps(species[s].1, 256, 3 + s as u64).albedo;
        let mut r =
            BranchRenderer::new(&gpu, &set.records, Some(&bark), [1.0; 3], target).expect("fits the device");
        if a.wind {
            let w = GpuWind::new(&gpu, set.rig.as_ref().expect("rig"), &breeze);
            r.use_wind(&w).expect("same branches");
            winds.push(w);
        }
        renderers.push(r);
    }
    let out = Offscreen::new(&gpu, a.width, a.height, target);
    let dt = 1.0 / 30.0;
    let mut time = 0.0f32;
    let frame = |winds: &mut Vec<GpuWind>, time: &mut f32| {
        *time += dt as f32;
        for w in winds.iter_mut() {
            w.step(dt);
        }
        let f = Frame::look_at(eye, centre, fov, a.width, a.height, *time);
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        for r in &renderers {
            r.set_frame(&f);
            r.prepare(&mut encoder);
        }
        {
            let mut pass = out.begin(&mut encoder, [0.45, 0.55, 0.7]);
            for r in &renderers {
                r.draw(&mut pass);
            }
        }
        gpu.queue.submit([encoder.finish()]);
        gpu.wait();
    };
    for _ in 0..3 {
        frame(&mut winds, &mut time);
    }
    let start = Instant::now();
    for _ in 0..a.frames {
        frame(&mut winds, &mut time);
    }
    let secs = start.elapsed().as_secs_f64();
    let counts: Vec<Vec<u32>> = renderers.iter().map(|r| r.lod_counts()).collect();
    let vertices: u64 = renderers.iter().map(|r| r.vertices_drawn()).sum();
    let drawn: u32 = counts.iter().flatten().sum();
    println!(
        "{total} branches ({drawn} drawn; per LOD {counts:?}), {vertices} vertices, {}×{} MSAA 4×, wind {}: {:.2} fps ({:.1} ms/frame over {} frames) on {}",
        a.width,
        a.height,
        if a.wind { "on" } else { "off" },
        a.frames as f64 / secs,
        1e3 * secs / a.frames.max(1) as f64,
        a.frames,
        gpu.describe()
    );
    if let Some(path) = a.png {
        let rgba = out.read_rgba(&gpu);
        let img = sylva::image::Image::from_rgba(a.width, a.height, rgba);
        std::fs::write(&path, img.to_png().expect("png encodes")).expect("png written");
        eprintln!("wrote {path}");
    }
}
