//! The GPU branch deformer against the engine's CPU reference `sylva::deform` (issue 25
//! item 1; Skjermo2008-spec §10 property 19: "WGSL output matches the Rust reference (1e-4)"),
//! through both WGSL paths: the compute sample pass (`GpuDeformer`) and the drawing
//! vertex shader (`BranchRenderer::capture`, which draws each vertex of an instanced grid
//! as a point into float targets). Positions must agree within 1e-4 of the branch's base
//! radius, unit normals within 1e-4 absolute. Also: the GPU's LOD selection equals its CPU
//! mirror, GpuWind's buffer drives the drawn branches without a copy, and a lit cylinder
//! shows its outside. Each GPU test skips with a printed reason where no adapter exists,
//! unless `SYLVA_REQUIRE_GPU=1`.

use glam::{Quat, Vec3};
use std::f32::consts::TAU;
use sylva::deform::{
    branch_records, control_polygon, deform, sloan_frames, BranchRecord, FlareMode, NO_AXIS,
};
use sylva::model::BranchCurves;
use sylva::wind::{WindOptions, WindRig};
use sylva_gpu::branches::{
    lod_of, select_lod, texture_mapping, BranchRenderer, Frame, LodSettings, Offscreen, TargetFormat,
};
use sylva_gpu::deform::{DeformSample, GpuDeformer};
use sylva_gpu::{Gpu, GpuWind};

/// Position tolerance as a fraction of the branch's base radius, and the normals'.
const TOL: f32 = 1e-4;

/// SplitMix64: a small seeded generator, so the branches are the same on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
    }
    fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[(self.next() % xs.len() as u64) as usize]
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

/// `n` seeded random branches: bent control polygons (bends below 80°) turned and placed
/// within 1 m of the origin, base radius 0.03–0.4 m, every taper kind (t = 0, 0 < t < 1,
/// 1, up to 10; tip radius 0 or not), both flare forms, up to 5 bulges and 7 lobes; every
/// seventh branch hangs on a parent parallel to its first leg (the L₀ ∥ O fallback) and
/// every eleventh on none (O = 0).
fn random_branches(n: usize, seed: u64) -> Vec<BranchRecord> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|i| {
            let length = rng.range(0.5, 3.0);
            let bend = 80f32.to_radians();
            let angles =
                [rng.range(-3.0, 3.0), rng.range(-bend, bend), rng.range(-3.0, 3.0), rng.range(-bend, bend)];
            let local = control_polygon(length, angles).expect("bends below 90°");
            let turn = Quat::from_axis_angle(rng.unit(), rng.range(0.0, TAU));
            let shift = rng.unit() * rng.range(0.0, 1.0);
            let points = local.map(|p| turn * p + shift);
            let parent = if i % 7 == 3 {
                (points[1] - points[0]).normalize() * if i % 2 == 0 { 1.0 } else { -1.0 }
            } else if i % 11 == 5 {
                Vec3::ZERO
            } else {
                rng.unit()
            };
            let mut r = BranchRecord::new(points, parent, rng.range(0.03, 0.4));
            r.taper = rng.pick(&[0.0, 0.3, 0.7, 1.0, 2.0, 3.0, 10.0]);
            r.tip_radius = if rng.next().is_multiple_of(2) { 0.0 } else { r.radius * rng.range(0.1, 0.9) };
            r.flare = rng.pick(&[0.0, 0.1, 0.33, 1.0]);
            r.flare_mode =
                if rng.next().is_multiple_of(2) { FlareMode::WeberPenn } else { FlareMode::Printed };
            r.bulge_count = rng.pick(&[0.0, 1.0, 3.0, 5.0]);
            r.bulge_depth = rng.pick(&[0.0, 0.05, 0.1]);
            r.lobe_count = rng.pick(&[0.0, 3.0, 5.0, 7.0]);
            r.lobe_depth = rng.pick(&[0.0, 0.1, 0.2]);
            r.lobe_fade = rng.pick(&[0.0, 0.5, 1.0]);
            r.order = (i % 4) as u32;
            r
        })
        .collect()
}

/// Largest position error over the branch's radius and largest normal error.
fn compare(records: &[BranchRecord], samples: &[DeformSample], got: &[(Vec3, Vec3)]) -> (f32, f32) {
    let (mut dp, mut dn) = (0.0f32, 0.0f32);
    for (s, &(p, n)) in samples.iter().zip(got) {
        let r = &records[s.branch as usize];
        let (cp, cn) = deform(r, s.v, s.theta);
        let e = (p - cp).length() / r.radius;
        let f = (n - cn).length();
        assert!(e.is_finite() && f.is_finite(), "non-finite result at {s:?}: {p} {n} vs {cp} {cn}");
        dp = dp.max(e);
        dn = dn.max(f);
    }
    (dp, dn)
}

/// Prints `what` with the largest errors `(dp, dn)` of [`compare`] and fails unless
/// both are within [`TOL`].
fn assert_within_tol(what: &str, (dp, dn): (f32, f32)) {
    eprintln!("{what}: max |ΔX| / r = {dp:.2e}, max |ΔN| = {dn:.2e}");
    assert!(dp <= TOL, "{what}: positions differ by {dp:e} of the radius");
    assert!(dn <= TOL, "{what}: normals differ by {dn:e}");
}

#[test]
fn property_19_compute_pass_equals_the_cpu_reference_on_1000_random_branches() {
    let Some(gpu) = Gpu::or_skip("property_19 compute") else { return };
    let records = random_branches(1000, 19);
    let fallbacks = records.iter().filter(|r| sloan_frames(&r.points(), r.parent_dir).fallback).count();
    assert!(fallbacks >= 100, "the L₀ ∥ O and O = 0 fallback is exercised ({fallbacks} branches)");
    let mut rng = Rng(1919);
    let mut samples = Vec::new();
    for (b, _) in records.iter().enumerate() {
        // The ends, the flare's kink, the middle, and random points.
        for v in [0.0, 0.125, 0.5, 1.0] {
            for j in 0..4 {
                samples.push(DeformSample::new(b as u32, v, j as f32 * TAU / 4.0 + 0.3));
            }
        }
        for _ in 0..16 {
            samples.push(DeformSample::new(b as u32, rng.range(0.0, 1.0), rng.range(0.0, TAU)));
        }
    }
    let got = GpuDeformer::new(&gpu).deform(&records, &samples);
    assert_eq!(got.len(), samples.len());
    let what = format!(
        "property 19 (compute): {} samples on {} branches ({fallbacks} with the frame fallback)",
        samples.len(),
        records.len()
    );
    assert_within_tol(&what, compare(&records, &samples, &got));
}

/// The renderer's vertex shader, captured, against the CPU over a level's grid.
fn capture_matches(renderer: &BranchRenderer, records: &[BranchRecord], ids: &[u32]) -> (f32, f32) {
    let grids = renderer.grids();
    let (mut dp, mut dn) = (0.0f32, 0.0f32);
    for level in 0..grids.lods.len() {
        let got = renderer.capture(level, ids);
        let verts = grids.lod_vertices(level);
        assert_eq!(got.len(), ids.len() * verts.len());
        let samples: Vec<DeformSample> =
            ids.iter().flat_map(|&b| verts.iter().map(move |g| DeformSample::new(b, g.v, g.theta))).collect();
        let (p, n) = compare(records, &samples, &got);
        dp = dp.max(p);
        dn = dn.max(n);
    }
    (dp, dn)
}

#[test]
fn property_19_vertex_shader_equals_the_cpu_reference_at_every_level() {
    let Some(gpu) = Gpu::or_skip("property_19 vertex shader") else { return };
    let records = random_branches(300, 1919);
    let renderer =
        BranchRenderer::new(&gpu, &records, None, [0.5; 3], TargetFormat::default()).expect("fits");
    // A scrambled subset: instance k must draw branch ids[k], not branch k.
    let ids: Vec<u32> = (0..records.len() as u32).rev().step_by(3).collect();
    let what = format!(
        "property 19 (vertex shader): {} branches × {} levels",
        ids.len(),
        renderer.grids().lods.len()
    );
    assert_within_tol(&what, capture_matches(&renderer, &records, &ids));
}

#[test]
fn gpu_lod_selection_equals_its_cpu_mirror() {
    let Some(gpu) = Gpu::or_skip("lod selection") else { return };
    // Branches spread over a 60 m field, seen from its edge: every level and culling.
    let mut records = random_branches(2000, 7);
    let mut rng = Rng(77);
    for r in &mut records {
        let shift = Vec3::new(rng.range(-30.0, 30.0), 0.0, rng.range(-60.0, 0.0));
        r.set_points(r.points().map(|p| p + shift));
    }
    let mut renderer =
        BranchRenderer::new(&gpu, &records, None, [0.5; 3], TargetFormat::default()).expect("fits");
    renderer.use_rest_points();
    let frame = Frame::look_at(Vec3::new(0.0, 2.0, 5.0), Vec3::new(0.0, 1.0, -10.0), 0.9, 1920, 1080, 0.0);
    let settings = LodSettings::default();
    renderer.set_frame(&frame);
    renderer.set_lod(&settings);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    renderer.prepare(&mut encoder);
    gpu.queue.submit([encoder.finish()]);
    let levels = renderer.grids().lods.len();
    let mut gpu_level = vec![None; records.len()];
    for level in 0..levels {
        for id in renderer.lod_ids(level) {
            assert!(gpu_level[id as usize].is_none(), "branch {id} listed twice");
            gpu_level[id as usize] = Some(level);
        }
    }
    let counts = renderer.lod_counts();
    let (mut borderline, mut per_level) = (0, vec![0usize; levels]);
    for (i, r) in records.iter().enumerate() {
        let cpu = select_lod(r, r.points(), &frame, &settings, levels);
        if let Some(l) = gpu_level[i] {
            per_level[l] += 1;
        }
        if cpu != gpu_level[i] {
            // Only a projected size within 0.1 % of a threshold may round the other way.
            let nudged = |f: f32| LodSettings { thresholds: settings.thresholds.map(|t| t * f), ..settings };
            let (lo, hi) = (
                select_lod(r, r.points(), &frame, &nudged(0.999), levels),
                select_lod(r, r.points(), &frame, &nudged(1.001), levels),
            );
            assert!(lo != hi, "branch {i}: GPU level {:?}, CPU level {cpu:?}", gpu_level[i]);
            borderline += 1;
        }
    }
    eprintln!("lod selection: {counts:?} branches per level of {}, {borderline} borderline", records.len());
    assert_eq!(counts.iter().map(|&c| c as usize).collect::<Vec<_>>(), per_level);
    assert!(counts.iter().all(|&c| c > 0), "every level is used: {counts:?}");
    assert!(counts.iter().sum::<u32>() < records.len() as u32, "some branches are culled");
    assert_eq!(
        renderer.vertices_drawn(),
        counts
            .iter()
            .zip(&renderer.grids().lods)
            .map(|(&n, l)| n as u64 * l.vertex_count as u64)
            .sum::<u64>()
    );
}

#[test]
fn lod_thresholds_map_projected_size_to_levels() {
    let s = LodSettings::default();
    assert_eq!(lod_of(100.0, &s, 4), 0);
    assert_eq!(lod_of(12.0, &s, 4), 0);
    assert_eq!(lod_of(11.9, &s, 4), 1);
    assert_eq!(lod_of(4.0, &s, 4), 1);
    assert_eq!(lod_of(2.0, &s, 4), 2);
    assert_eq!(lod_of(0.1, &s, 4), 3);
    assert_eq!(lod_of(0.1, &s, 2), 1);
    assert_eq!(lod_of(100.0, &s, 1), 0);
}

#[test]
fn texture_v_runs_on_across_the_segments_of_an_axis() {
    let mut a = BranchRecord::new([Vec3::ZERO, Vec3::Y, Vec3::Y * 2.0, Vec3::Y * 3.0], Vec3::X, 0.5);
    a.axis = 0;
    let mut b = a;
    b.set_points(a.points().map(|p| p + Vec3::Y * 3.0));
    b.segment = 1;
    let mut c = a;
    c.axis = NO_AXIS;
    let t = texture_mapping(&[a, b, c]);
    assert_eq!(t[0][0], 0.0);
    assert!((t[0][1] - 3.0).abs() < 1e-6, "a straight segment's arc length is its chord");
    assert_eq!(t[1][0], t[0][0] + t[0][1], "the second segment starts where the first ends");
    assert_eq!(t[1][2], t[0][2], "one circumference per axis");
    assert!((t[0][2] - 1.0 / (TAU * 0.5)).abs() < 1e-6);
    assert_eq!(t[2][0], 0.0, "a record without an axis starts its own");
}

/// `lsys-honda-a`'s fitted branch curves.
fn honda_curves() -> BranchCurves {
    let loaded = sylva::recipe::load("lsys-honda-a", &[]).expect("preset loads");
    let mut report = sylva::pipeline::Report::default();
    let generated = sylva::pipeline::skeleton(&loaded, &mut report).expect("preset grows");
    generated.curves.unwrap_or_else(|| BranchCurves::fit(&generated.skeleton))
}

#[test]
fn the_wind_buffer_drives_the_drawn_branches() {
    let Some(gpu) = Gpu::or_skip("wind drives the renderer") else { return };
    let curves = honda_curves();
    let records = branch_records(&curves);
    let rig = WindRig::new(&curves);
    assert_eq!(rig.branches.len(), records.len());
    let mut wind = GpuWind::new(&gpu, &rig, &WindOptions::preset("storm").unwrap());
    let mut renderer =
        BranchRenderer::new(&gpu, &records, None, [0.5; 3], TargetFormat::default()).expect("fits");
    renderer.use_wind(&wind).expect("same branch count");
    for _ in 0..60 {
        wind.step(1.0 / 30.0);
    }
    // The CPU deforms the records with the points read back from the wind's buffer.
    let moved: Vec<BranchRecord> = records
        .iter()
        .zip(wind.points())
        .map(|(r, p)| {
            let mut r = *r;
            r.set_points(p.map(|x| x.as_vec3()));
            r
        })
        .collect();
    let sway = records.iter().zip(&moved).map(|(a, b)| a.p3.distance(b.p3)).fold(0.0f32, f32::max);
    assert!(sway > 1e-3, "the storm moved the branches ({sway} m)");
    let ids: Vec<u32> = (0..records.len() as u32).collect();
    let (dp, dn) = capture_matches(&renderer, &moved, &ids);
    eprintln!("wind-driven draw: {} branches, tip sway up to {sway:.3} m, max |ΔX| / r = {dp:.2e}, max |ΔN| = {dn:.2e}", ids.len());
    assert!(dp <= TOL && dn <= TOL, "the drawn branches follow the wind's points ({dp:e}, {dn:e})");
}

#[test]
fn a_lit_cylinder_shows_its_outside() {
    let Some(gpu) = Gpu::or_skip("lit cylinder") else { return };
    // A vertical cylinder of radius 1, lit from the camera's side: with outward normals
    // and back faces culled, the middle of the image is lit (Lambert ≈ 1); drawn inside
    // out it would show only the ambient.
    let rec = BranchRecord::new(
        [
            Vec3::new(0.0, -3.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 3.0, 0.0),
        ],
        Vec3::X,
        1.0,
    );
    let renderer = BranchRenderer::new(&gpu, &[rec], None, [0.5; 3], TargetFormat::default()).expect("fits");
    let (w, h) = (64, 64);
    let mut frame = Frame::look_at(Vec3::new(0.0, 0.0, 8.0), Vec3::ZERO, 0.9, w, h, 0.0);
    frame.light_dir = [0.0, 0.0, 1.0, 0.0];
    frame.light_color = [1.0, 1.0, 1.0, 1.0];
    frame.sky = [0.0; 4];
    frame.ground = [0.0; 4];
    renderer.set_frame(&frame);
    let target = Offscreen::new(&gpu, w, h, TargetFormat::default());
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    renderer.prepare(&mut encoder);
    {
        let mut pass = target.begin(&mut encoder, [0.0, 0.0, 0.0]);
        renderer.draw(&mut pass);
    }
    gpu.queue.submit([encoder.finish()]);
    assert_eq!(renderer.lod_counts()[0], 1, "a big branch near the camera takes the finest level");
    let rgba = target.read_rgba(&gpu);
    let px = |x: u32, y: u32| rgba[((y * w + x) * 4) as usize];
    // Linear 0.5 × Lambert 1 = sRGB ≈ 188.
    let centre = px(w / 2, h / 2);
    assert!(centre > 170, "the cylinder's front is lit: {centre}");
    assert!(px(w / 2 + 12, h / 2) < centre, "its sides turn away from the light");
    assert_eq!(px(2, h / 2), 0, "outside it the clear colour stays");
}

#[test]
fn for_model_draws_the_models_curves_with_its_bark() {
    use sylva::image::Image;
    use sylva::model::{Model, ModelImage};
    use sylva_gpu::branches::model_bark;
    let mut model = Model { curves: honda_curves(), ..Default::default() };
    assert!(model_bark(&model).is_none(), "no texture stage, no bark");
    let bark = Image { width: 4, height: 2, channels: 3, data: (0..24).collect() };
    model.images.push(ModelImage { name: "bark_albedo".into(), image: bark.clone().into(), repeat: true });
    assert_eq!(model_bark(&model), Some(&bark));
    let Some(gpu) = Gpu::or_skip("for_model") else { return };
    let renderer = BranchRenderer::for_model(&gpu, &model, TargetFormat::default()).expect("fits");
    assert_eq!(renderer.len(), branch_records(&model.curves).len());
    renderer.set_frame(&Frame::look_at(
        Vec3::new(0.0, 5.0, 30.0),
        Vec3::new(0.0, 5.0, 0.0),
        0.8,
        320,
        240,
        0.0,
    ));
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    renderer.prepare(&mut encoder);
    gpu.queue.submit([encoder.finish()]);
    assert_eq!(
        renderer.lod_counts().iter().sum::<u32>() as usize,
        renderer.len(),
        "the whole tree is in view"
    );
}
