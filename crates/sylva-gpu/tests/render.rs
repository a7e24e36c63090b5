//! The GPU renderer (issue 25 item 4; Skjermo2008 §4, Skjermo2008-spec §10): pictures not empty and
//! matching the CPU preview's silhouette, MSAA edges, alpha-cut leaves, GPU skinning
//! against `sylva::wind::posed`, instanced forests with one draw per (level, part,
//! material), determinism. Each test skips with a printed reason where no adapter exists,
//! unless `SYLVA_REQUIRE_GPU=1`.

use glam::{Mat4, Quat, Vec2, Vec3};
use sylva::geometry::{FaceVarying, Mesh};
use sylva::model::{Clip, Joint, Lod, Material, Model, ModelImage, Part, Rig, SkinWeights};
use sylva::preview::{Image, PreviewOptions};
use sylva_gpu::render::{forest, iou, silhouette, Lines, Orbit, RenderOptions, Renderer};
use sylva_gpu::Gpu;

/// An axis-aligned box `lo..hi` of `rings + 1` levels of four vertices along y, with
/// outward quads (sides, caps) and flat per-corner normals.
fn column(lo: Vec3, hi: Vec3, rings: usize) -> Mesh {
    let mut m = Mesh::new();
    let mut normals = FaceVarying::default();
    let corner = |k: usize, y: f32| {
        let (x, z) = [(lo.x, lo.z), (hi.x, lo.z), (hi.x, hi.z), (lo.x, hi.z)][k % 4];
        Vec3::new(x, y, z)
    };
    for r in 0..=rings {
        let y = lo.y + (hi.y - lo.y) * r as f32 / rings as f32;
        m.positions.extend((0..4).map(|k| corner(k, y)));
    }
    let mut quad = |m: &mut Mesh, mut f: [u32; 4], outward: Vec3| {
        let p = |i: u32| m.positions[i as usize];
        if (p(f[1]) - p(f[0])).cross(p(f[2]) - p(f[0])).dot(outward) < 0.0 {
            f.reverse();
        }
        let n = normals.values.len() as u32;
        normals.values.push(outward);
        m.face_indices.extend(f);
        normals.indices.extend([n; 4]);
        m.face_offsets.push(m.face_indices.len() as u32);
    };
    let centre = (lo + hi) * 0.5;
    for r in 0..rings as u32 {
        for k in 0..4u32 {
            let (a, b) = (r * 4 + k, r * 4 + (k + 1) % 4);
            let mid = (m.positions[a as usize] + m.positions[b as usize]) * 0.5;
            let out = Vec3::new(mid.x - centre.x, 0.0, mid.z - centre.z).normalize();
            let out =
                if out.x.abs() > out.z.abs() { Vec3::X * out.x.signum() } else { Vec3::Z * out.z.signum() };
            quad(&mut m, [a, b, b + 4, a + 4], out);
        }
    }
    let top = rings as u32 * 4;
    quad(&mut m, [0, 1, 2, 3], -Vec3::Y);
    quad(&mut m, [top, top + 1, top + 2, top + 3], Vec3::Y);
    m.normals = Some(normals);
    m
}

/// A box standing on the ground, 1 × 2 × 0.6 m.
fn box_model() -> Model {
    let mesh = column(Vec3::new(-0.5, 0.0, -0.3), Vec3::new(0.5, 2.0, 0.3), 1);
    Model::from_parts(vec![Part::new("bark", mesh, Material::bark())])
}

/// A 1 m square card in the x–y plane whose colour map is opaque on its right half and
/// transparent on its left half, alpha-cut at 0.5.
fn card_model() -> Model {
    let mut m = Mesh::new();
    m.positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    m.face_indices = vec![0, 1, 2, 3];
    m.face_offsets = vec![0, 4];
    m.uvs = Some(FaceVarying {
        values: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        indices: vec![0, 1, 2, 3],
    });
    let mut material = Material::leaf();
    material.maps.base_color = Some(0);
    material.alpha_cutoff = Some(0.5);
    let mut image = Image::new(8, 8, 4);
    for y in 0..8 {
        for x in 0..8 {
            let i = (y * 8 + x) * 4;
            image.data[i..i + 4].copy_from_slice(&[40, 140, 30, if x >= 4 { 255 } else { 0 }]);
        }
    }
    let mut model = Model::from_parts(vec![Part::new("leaves", m, material)]);
    model.images = vec![ModelImage { name: "leaf_atlas".into(), image: image.into(), repeat: false }];
    model
}

/// A 3 m column of 12 rings on two joints (the base at y = 0, the second at y = 1.5),
/// each vertex bound to the joint below it, with a clip that bends the upper joint about
/// z and back over 2 s.
fn swaying_model() -> Model {
    let mesh = column(Vec3::new(-0.15, 0.0, -0.15), Vec3::new(0.15, 3.0, 0.15), 12);
    let skin = SkinWeights {
        joints: mesh.positions.iter().map(|p| [u16::from(p.y > 1.5), 0, 0, 0]).collect(),
        weights: vec![[1.0, 0.0, 0.0, 0.0]; mesh.positions.len()],
    };
    let mut part = Part::new("bark", mesh, Material::bark());
    part.skin = Some(skin);
    let mut model = Model::from_parts(vec![part]);
    model.rig = Some(Rig {
        joints: vec![
            Joint { node: 0, parent: None, head: Vec3::ZERO },
            Joint { node: 1, parent: Some(0), head: Vec3::new(0.0, 1.5, 0.0) },
        ],
    });
    let bend = Quat::from_rotation_z(0.7);
    model.clip = Some(Clip {
        name: "wind".into(),
        times: vec![0.0, 1.0, 2.0],
        rotations: vec![vec![Quat::IDENTITY; 3], vec![Quat::IDENTITY, bend, Quat::IDENTITY]],
    });
    model
}

fn opts(w: u32, h: u32, az: f32, el: f32) -> RenderOptions {
    RenderOptions {
        width: w,
        height: h,
        orbit: Some(Orbit { azimuth_deg: az, elevation_deg: el }),
        ..Default::default()
    }
}

fn shape(image: &Image) -> Vec<bool> {
    let d = PreviewOptions::default();
    silhouette(image, d.background, d.background_top, 6)
}

/// The engine's CPU preview of `model` at the size and from the orbit of `o`.
fn cpu_preview(model: &Model, o: &RenderOptions) -> Image {
    let view = PreviewOptions {
        width: o.width,
        height: o.height,
        view: Some(o.orbit.expect("an orbit view").to_preview()),
        ..Default::default()
    };
    sylva::preview::render(model, &view).unwrap()
}

fn covered(s: &[bool]) -> f64 {
    s.iter().filter(|&&x| x).count() as f64 / s.len() as f64
}

#[test]
fn a_box_is_drawn_over_the_background_with_the_preview_silhouette() {
    let Some(gpu) = Gpu::or_skip("render: box") else { return };
    let model = box_model();
    let r = Renderer::new(&gpu, &model).unwrap();
    let o = opts(320, 240, 30.0, 15.0);
    let out = r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    assert_eq!((out.image.width, out.image.height, out.image.data.len()), (320, 240, 320 * 240 * 4));
    let gpu_shape = shape(&out.image);
    let c = covered(&gpu_shape);
    assert!((0.1..0.9).contains(&c), "the box covers {c} of the picture");
    // Corners show the background gradient; the centre shows the box.
    assert!(!gpu_shape[0] && !gpu_shape[319] && !gpu_shape[320 * 239]);
    assert!(gpu_shape[120 * 320 + 160]);
    assert_eq!(out.image.pixel(0, 0).unwrap(), [190, 208, 226, 255], "the preview's sky colour at the top");
    assert_eq!(out.stats.draw_calls, 1);
    assert_eq!(out.stats.triangles, 12);
    let cpu = cpu_preview(&model, &o);
    let overlap = iou(&gpu_shape, &shape(&cpu));
    assert!(overlap >= 0.97, "silhouette IoU with the CPU preview {overlap}");
    // The lit colours agree with the preview's too (same light and ambient).
    let (g, p) = (out.image.pixel(160, 120).unwrap(), cpu.pixel(160, 120).unwrap());
    assert!((0..3).all(|k| g[k].abs_diff(p[k]) <= 6), "{g:?} vs {p:?}");
}

#[test]
fn msaa_softens_edges_and_rendering_is_deterministic() {
    let Some(gpu) = Gpu::or_skip("render: msaa") else { return };
    let r = Renderer::new(&gpu, &box_model()).unwrap();
    if !r.msaa_supported() {
        eprintln!("skipping the MSAA half: the adapter has no 4× MSAA for the formats");
    }
    let mut o = opts(200, 200, 37.0, 21.0);
    let a = r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    let b = r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    assert_eq!(a.image, b.image, "the same render twice gives the same bytes");
    o.msaa = false;
    let aliased = r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    assert_eq!(aliased.stats.samples, 1);
    // Edge pixels: ones whose colour is neither the background's nor a neighbour's face
    // colour; with MSAA many edge pixels take in-between colours, without none do.
    let distinct = |im: &Image| {
        let mut colours = std::collections::HashSet::new();
        for p in im.data.chunks(4) {
            colours.insert([p[0], p[1], p[2]]);
        }
        colours.len()
    };
    if r.msaa_supported() {
        assert_eq!(a.stats.samples, 4);
        assert!(
            distinct(&a.image) > distinct(&aliased.image) + 20,
            "MSAA blends edges: {} colours vs {} without",
            distinct(&a.image),
            distinct(&aliased.image)
        );
    }
    let overlap = iou(&shape(&a.image), &shape(&aliased.image));
    assert!(overlap > 0.95, "{overlap}");
}

#[test]
fn alpha_cut_leaves_show_only_their_opaque_half() {
    let Some(gpu) = Gpu::or_skip("render: alpha cut") else { return };
    let model = card_model();
    let r = Renderer::new(&gpu, &model).unwrap();
    let o = opts(200, 200, 0.0, 0.0);
    let out = r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    let s = shape(&out.image);
    // The card fills the view's middle 90 %: its left half is cut away.
    let row = 100 * 200;
    assert!(!s[row + 40], "the transparent half shows the background");
    assert!(s[row + 160], "the opaque half is drawn");
    let px = out.image.pixel(160, 100).unwrap();
    assert!(px[1] > px[0] && px[1] > px[2], "leaf green from the colour map: {px:?}");
    let cpu = cpu_preview(&model, &o);
    let overlap = iou(&s, &shape(&cpu));
    assert!(overlap >= 0.95, "silhouette IoU with the CPU preview {overlap}");
}

#[test]
fn gpu_skinning_matches_the_cpu_posed_model() {
    let Some(gpu) = Gpu::or_skip("render: skinning") else { return };
    let model = swaying_model();
    let r = Renderer::new(&gpu, &model).unwrap();
    assert!(r.animated());
    // The joint matrices move vertices where `wind::posed` moves them.
    let m = r.joint_matrices(1.0);
    let part = &model.parts[0];
    for v in [0, 20, 47, part.mesh.positions.len() - 1] {
        let j = part.skin.as_ref().unwrap().joints[v][0] as usize;
        let ours = m[j].transform_point3(part.mesh.positions[v]);
        let cpu = sylva::wind::clip::posed_vertex(&model, 0, v, 1.0).unwrap();
        assert!(ours.distance(cpu) < 1e-5, "vertex {v}: {ours} vs {cpu}");
    }
    // The picture of the skinned model at t = 1 equals the picture of the CPU-posed one.
    let frame = (Vec3::new(-3.0, -0.5, -1.0), Vec3::new(3.0, 3.5, 1.0));
    let o = RenderOptions { frame: Some(frame), ..opts(240, 160, 0.0, 0.0) };
    let skinned = r.render(&o, &[Mat4::IDENTITY], 1.0).unwrap();
    let rest = r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    let posed = Renderer::new(&gpu, &sylva::wind::posed(&model, 1.0)).unwrap();
    assert!(!posed.animated());
    let cpu_posed = posed.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    let (a, b, c) = (shape(&skinned.image), shape(&cpu_posed.image), shape(&rest.image));
    assert!(iou(&a, &b) > 0.98, "GPU skinning vs CPU posing: IoU {}", iou(&a, &b));
    assert!(iou(&a, &c) < 0.8, "the column bends between t = 0 and t = 1: IoU {}", iou(&a, &c));
}

#[test]
fn a_forest_is_one_draw_per_level_part_and_material() {
    let Some(gpu) = Gpu::or_skip("render: forest") else { return };
    let mut model = box_model();
    // LOD1: a thinner box; LOD2 (the impostor's place): a card.
    let lod1 =
        Part::new("bark", column(Vec3::new(-0.4, 0.0, -0.2), Vec3::new(0.4, 2.0, 0.2), 1), Material::bark());
    let card = card_model();
    model.images = card.images.clone();
    model.lod0_coverage = 0.25;
    model.lods = vec![
        Lod { parts: vec![lod1], screen_coverage: 0.08 },
        Lod { parts: card.parts.clone(), screen_coverage: 0.0 },
    ];
    let r = Renderer::new(&gpu, &model).unwrap();
    assert_eq!(r.level_count(), 3);
    let bounds = r.bounds().unwrap();
    let o = opts(400, 300, 20.0, 20.0);
    for n in [1usize, 30, 400] {
        let trees = forest::grid(n, 11, bounds);
        let out = r.render(&o, &trees, 0.0).unwrap();
        let s = &out.stats;
        assert_eq!(s.instances_per_level.iter().sum::<u32>() as usize, n);
        let expected: u32 = s
            .instances_per_level
            .iter()
            .enumerate()
            .filter(|(_, &k)| k > 0)
            .map(|(l, _)| r.draws_per_level(l))
            .sum();
        assert_eq!(s.draw_calls, expected, "one draw per used level's part and material");
        assert!(s.draw_calls <= 3, "{n} trees: {} draws, never one per tree", s.draw_calls);
        let c = covered(&shape(&out.image));
        assert!(c > 0.02, "{n} trees cover {c}");
        if n == 400 {
            assert!(
                s.instances_per_level[2] > 0,
                "far trees use the last level: {:?}",
                s.instances_per_level
            );
            assert!(s.instances_per_level[0] + s.instances_per_level[1] > 0, "{:?}", s.instances_per_level);
        }
    }
    assert!(r.render(&o, &[], 0.0).is_err(), "no trees");
    assert!(r.render(&RenderOptions { width: 0, ..o.clone() }, &[Mat4::IDENTITY], 0.0).is_err());
    assert!(r.render(&RenderOptions { height: 9000, ..o }, &[Mat4::IDENTITY], 0.0).is_err());
}

// The viewer's options (issue 41 item 2): ground, wireframe, fixed level, overlays.

/// Relative luminance-ish brightness of an RGBA pixel (sum of its channels).
fn brightness(p: [u8; 4]) -> u32 {
    p[0] as u32 + p[1] as u32 + p[2] as u32
}

/// The pixel at `p`'s projection in `out`.
fn at(out: &sylva_gpu::render::Rendered, p: Vec3) -> [u8; 4] {
    let q = out.camera.pixel(p);
    out.image.pixel(q.x as u32, q.y as u32).unwrap()
}

/// A tree-like model: a thin 1.5 m trunk under a 2 × 1.5 × 2 m crown.
fn lollipop_model() -> Model {
    let trunk = column(Vec3::new(-0.1, 0.0, -0.1), Vec3::new(0.1, 1.5, 0.1), 1);
    let crown = column(Vec3::new(-1.0, 1.5, -1.0), Vec3::new(1.0, 3.0, 1.0), 1);
    Model::from_parts(vec![
        Part::new("bark", trunk, Material::bark()),
        Part::new("leaves", crown, Material::leaf()),
    ])
}

#[test]
fn the_ground_darkens_the_floor_most_under_the_crown() {
    let Some(gpu) = Gpu::or_skip("render: ground") else { return };
    let r = Renderer::new(&gpu, &lollipop_model()).unwrap();
    let plain = opts(320, 240, 0.0, 12.0);
    let off = r.render(&plain, &[Mat4::IDENTITY], 0.0).unwrap();
    let on = r.render(&RenderOptions { ground: true, ..plain.clone() }, &[Mat4::IDENTITY], 0.0).unwrap();
    assert_eq!(off.camera, r.render(&plain, &[Mat4::IDENTITY], 0.0).unwrap().camera);
    assert_eq!(on.stats.draw_calls, off.stats.draw_calls, "the ground is not a tree's draw");
    // Under the crown, in front of the trunk: the ground is drawn there, darker than the
    // background it replaces and darker than the open ground beside the crown.
    let under = Vec3::new(0.0, 0.0, 0.4);
    let beside = Vec3::new(1.5, 0.0, 0.0);
    let (b_off, b_on, b_beside) =
        (brightness(at(&off, under)), brightness(at(&on, under)), brightness(at(&on, beside)));
    assert!(b_on + 60 < b_off, "the ground under the tree is darker than the sky behind: {b_on} vs {b_off}");
    assert!(b_on + 40 < b_beside, "the contact shadow: {b_on} under the crown vs {b_beside} beside it");
    assert!(
        brightness(at(&on, beside)) < brightness(at(&off, beside)),
        "the floor is drawn beside the tree too"
    );
    // The sky above is untouched, and the tree itself still covers the same pixels.
    assert_eq!(on.image.pixel(5, 5), off.image.pixel(5, 5));
    let top = Vec3::new(0.0, 2.9, 1.0);
    assert_eq!(at(&on, top), at(&off, top), "the crown's front is drawn as before");
}

#[test]
fn the_wireframe_draws_each_unique_triangle_edge_once() {
    let Some(gpu) = Gpu::or_skip("render: wireframe") else { return };
    let r = Renderer::new(&gpu, &box_model()).unwrap();
    let plain = RenderOptions { msaa: false, ..opts(240, 200, 30.0, 20.0) };
    let off = r.render(&plain, &[Mat4::IDENTITY], 0.0).unwrap();
    let on = r.render(&RenderOptions { wireframe: true, ..plain.clone() }, &[Mat4::IDENTITY], 0.0).unwrap();
    assert_eq!(off.stats.lines, 0);
    // Six quads, twelve triangles: the box's 12 edges and one diagonal per face.
    assert_eq!(on.stats.lines, 18);
    assert_eq!(on.stats.triangles, off.stats.triangles, "the shaded box is still drawn");
    assert_ne!(on.image, off.image);
    let dark = |im: &Image| im.data.chunks(4).filter(|p| brightness([p[0], p[1], p[2], 255]) < 120).count();
    assert!(
        dark(&on.image) > dark(&off.image) + 100,
        "edges: {} dark pixels vs {}",
        dark(&on.image),
        dark(&off.image)
    );
    // A forest draws the edges once per tree, still one draw per part.
    let trees = forest::grid(3, 1, r.bounds().unwrap());
    let o = RenderOptions { wireframe: true, lod: Some(0), ..plain };
    assert_eq!(r.render(&o, &trees, 0.0).unwrap().stats.lines, 54);
}

#[test]
fn a_fixed_level_of_detail_draws_that_level() {
    let Some(gpu) = Gpu::or_skip("render: fixed lod") else { return };
    let mut model = box_model();
    let lod1 =
        Part::new("bark", column(Vec3::new(-0.4, 0.0, -0.2), Vec3::new(0.4, 2.0, 0.2), 3), Material::bark());
    let card = card_model();
    model.images = card.images.clone();
    model.lod0_coverage = 0.25;
    model.lods = vec![
        Lod { parts: vec![lod1], screen_coverage: 0.08 },
        Lod { parts: card.parts.clone(), screen_coverage: 0.0 },
    ];
    let r = Renderer::new(&gpu, &model).unwrap();
    let tris: Vec<u64> = (0..3).map(|l| r.level_triangles(l)).collect();
    assert_eq!(tris, [12, 28, 2]);
    let o = opts(200, 200, 20.0, 10.0);
    let auto = r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap();
    assert_eq!(
        (auto.stats.instances_per_level.clone(), auto.stats.triangles),
        (vec![1, 0, 0], 12),
        "close up: LOD0"
    );
    let mut images = vec![auto.image];
    for level in 0..3 {
        let out = r.render(&RenderOptions { lod: Some(level), ..o.clone() }, &[Mat4::IDENTITY], 0.0).unwrap();
        let mut per = vec![0; 3];
        per[level] = 1;
        assert_eq!(out.stats.instances_per_level, per);
        assert_eq!(out.stats.triangles, tris[level], "level {level}");
        images.push(out.image);
    }
    assert_eq!(images[0], images[1], "level 0 fixed is the automatic choice here");
    assert_ne!(images[1], images[3], "the card is another picture");
    let e = r.render(&RenderOptions { lod: Some(3), ..o }, &[Mat4::IDENTITY], 0.0).unwrap_err().to_string();
    assert!(e.contains("lod is 3") && e.contains("0..=2"), "{e}");
}

#[test]
fn overlay_lines_show_on_top_or_behind_the_tree() {
    let Some(gpu) = Gpu::or_skip("render: overlays") else { return };
    let r = Renderer::new(&gpu, &box_model()).unwrap();
    let plain = RenderOptions { msaa: false, ..opts(240, 200, 0.0, 0.0) };
    let red = |im: &Image| im.data.chunks(4).filter(|p| p[0] > 200 && p[1] < 80 && p[2] < 80).count();
    let base = r.render(&plain, &[Mat4::IDENTITY], 0.0).unwrap();
    assert_eq!(red(&base.image), 0);
    // A horizontal segment 0.5 m behind the box, wider than it: on top, all of it shows;
    // depth-tested, the box hides its middle.
    let behind = Lines::new(vec![[Vec3::new(-0.9, 1.0, -0.8), Vec3::new(0.9, 1.0, -0.8)]], [255, 0, 0]);
    let top = Lines { on_top: true, ..behind.clone() };
    let with = |l: Lines| {
        r.render(&RenderOptions { overlays: vec![l], ..plain.clone() }, &[Mat4::IDENTITY], 0.0).unwrap()
    };
    let (shown, hidden) = (with(top), with(behind.clone()));
    assert_eq!(shown.stats.lines, 1);
    let (n_top, n_tested) = (red(&shown.image), red(&hidden.image));
    assert!(n_top > 60, "the line on top crosses the picture: {n_top} red pixels");
    assert!(n_tested > 10 && n_tested + 30 < n_top, "the box hides the middle: {n_tested} vs {n_top}");
    let front = Lines::new(vec![[Vec3::new(-0.9, 1.0, 0.8), Vec3::new(0.9, 1.0, 0.8)]], [255, 0, 0]);
    assert!(red(&with(front).image) + 5 >= n_top, "in front, depth-tested lines show whole");
    let bad = Lines::new(vec![[Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0)]], [0, 0, 0]);
    let e = r
        .render(&RenderOptions { overlays: vec![behind, bad], ..plain }, &[Mat4::IDENTITY], 0.0)
        .unwrap_err();
    assert!(e.to_string().contains("overlay 1: segment 0"), "{e}");
}

/// The box beside the alpha-cut card: two parts, one image.
fn box_and_card() -> Model {
    let mut model = card_model();
    let mesh = column(Vec3::new(1.2, 0.0, -0.3), Vec3::new(1.8, 1.0, 0.3), 1);
    model.parts.push(Part::new("bark", mesh, Material::bark()));
    model
}

/// Issue 41's leaf-change latency: a renderer replacing another on the same device keeps
/// the buffers of the parts and the textures of the images that did not change, uploads
/// the rest, and draws exactly what a renderer made from scratch draws.
#[test]
fn a_replacing_renderer_reuses_what_did_not_change_and_draws_the_same() {
    let Some(gpu) = Gpu::or_skip("render: reuse") else { return };
    let (a, d, q) = (&gpu.adapter, &gpu.device, &gpu.queue);
    let o = opts(160, 160, 0.3, 0.2);
    let draw = |r: &Renderer| r.render(&o, &[Mat4::IDENTITY], 0.0).unwrap().image;
    let fresh = |m: &Model| draw(&Renderer::with_device(a, d, q, m).unwrap());

    let first_model = box_and_card();
    let first = Renderer::with_device_reusing(a, d, q, &first_model, None).unwrap();
    let r = first.reuse();
    assert_eq!((r.parts_uploaded, r.parts_reused, r.textures_uploaded, r.textures_reused), (2, 0, 1, 0));

    // A material change (the leaf's cut-off): nothing uploaded but the uniforms.
    let mut cut = box_and_card();
    cut.parts[0].material.alpha_cutoff = Some(0.95);
    let second = Renderer::with_device_reusing(a, d, q, &cut, Some(&first)).unwrap();
    let r = second.reuse();
    assert_eq!((r.parts_uploaded, r.parts_reused, r.textures_uploaded, r.textures_reused), (0, 2, 0, 1));
    let (old, new) = (draw(&first), draw(&second));
    assert_eq!(new.data, fresh(&cut).data, "the reusing renderer draws as a fresh one");
    assert_ne!(new.data, old.data, "the cut-off change shows");

    // The box moved and the leaf image recoloured: those two are uploaded again.
    let mut moved = cut.clone();
    for p in &mut moved.parts[1].mesh.positions {
        p.y += 0.5;
    }
    for px in std::sync::Arc::make_mut(&mut moved.images[0].image).data.chunks_exact_mut(4) {
        px[0] = 200;
    }
    let third = Renderer::with_device_reusing(a, d, q, &moved, Some(&second)).unwrap();
    let r = third.reuse();
    assert_eq!((r.parts_uploaded, r.parts_reused, r.textures_uploaded, r.textures_reused), (1, 1, 1, 0));
    assert_eq!(draw(&third).data, fresh(&moved).data);
}
