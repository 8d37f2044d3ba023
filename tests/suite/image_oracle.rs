//! The image oracle on a real adapter (lavapipe in CI): what the LOD runtime draws through a
//! `gpu::Object` must look exactly like the reference mesh of DESIGN.md drawn as a triangle
//! list, pixel for pixel, with the same shader, camera, `t` and depth test.
//!
//! * `strips_render_like_reference_lists`: every asset, ≥ 20 `(t, lod)` states reached by a
//!   random walk of `set_lod` whose dirty logs reach the object only through
//!   `Object::apply_dirty`, so a wrong dirty range shows as a wrong image. The reference
//!   triangles are drawn in the rotation the strip draw gives them (see `ReferenceLists`).
//! * `back_face_culling_hides_nothing`: culled and unculled strip renders of closed meshes are
//!   identical, and the comparison catches one triangle with flipped parity.
//! * `one_draw_per_frame_and_upload_bytes`: one draw per object per frame over linear and
//!   exponential LOD sweeps; bytes uploaded per frame against a full index re-upload.
//! * `two_objects_share_one_pipeline`: a crowd of two in one pass, two draws, both visible.
//! * `apply_dirty_rejects_bad_input`: typed errors, nothing changed on error.
//!
//! Every test gets its device from `common::gpu::Gpu::new`: it fails when no adapter exists and
//! `CI` is set (`morphlod::ci::is_ci`), and skips with a printed reason elsewhere.

use crate::common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use common::gpu::{
    assert_one_multi_draw_each, differences, fail_with_images, reference_lists, Gpu, Recorder,
};
use common::Rng;
use glam::{Mat4, Vec3};
use morphlod::collapse::CollapseSequence;
use morphlod::gpu::camera::{self, Projection};
use morphlod::gpu::{
    self, Draws, GpuError, MorphPipeline, Object, RenderTarget, Topology, RESTART,
};
use morphlod::io::MorphSource;
use morphlod::io::{load_mesh, LoadOptions};
use morphlod::lodstrips::{Indices, LodStrips, StripsState};
use morphlod::simplify::{simplify, SimplifyOptions};
use morphlod::strip::stripify;

const SIZE: u32 = 160;
/// Pure blue: the base colour below has no blue, so every drawn pixel differs from it.
const CLEAR: wgpu::Color = wgpu::Color {
    r: 0.0,
    g: 0.0,
    b: 1.0,
    a: 1.0,
};
const CLEAR_RGBA: [u8; 4] = [0, 0, 255, 255];
const BASE: [f32; 4] = [1.0, 0.6, 0.0, 1.0];
/// Number of `(t, lod)` states rendered per asset.
const STATES: usize = 22;

/// A mesh with two poses over one triangulation.
struct Input {
    name: &'static str,
    triangles: Vec<[u32; 3]>,
    v0: Vec<[f32; 3]>,
    v1: Vec<[f32; 3]>,
}

/// The LOD model of an input: S0, a QEM sequence on the `t = 0` pose, the change lists.
struct Lod {
    seq: CollapseSequence,
    model: LodStrips,
}

fn asset_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name)
}

fn load_static(name: &'static str) -> Input {
    let mesh = load_mesh(&asset_path(name), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    Input {
        name,
        triangles: mesh.triangles,
        v1: mesh.positions.clone(),
        v0: mesh.positions,
    }
}

fn load_morph(name: &'static str, file: &str, source: MorphSource) -> Input {
    let morph = morphlod::io::load_morph(&asset_path(file), &LoadOptions::default(), &source)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    Input {
        name,
        triangles: morph.triangles().to_vec(),
        v0: morph.v0(),
        v1: morph.v1(),
    }
}

fn inputs() -> Vec<Input> {
    vec![
        load_static("cow.off"),
        load_static("bunny.obj"),
        load_static("man.off"),
        load_morph(
            "makehuman_head.glb 'morph'",
            "makehuman_head.glb",
            MorphSource::Animation("morph".into()),
        ),
        load_morph(
            "makehuman_body.glb 'caucasian-male-baby'",
            "makehuman_body.glb",
            MorphSource::Target("caucasian-male-baby".into()),
        ),
        load_morph(
            "AnimatedMorphCube",
            "AnimatedMorphCube-glTF/AnimatedMorphCube.gltf",
            MorphSource::Animation("0".into()),
        ),
    ]
}

fn build_lod(input: &Input) -> (morphlod::strip::Strips, Lod) {
    let strips = stripify(&input.triangles, input.v0.len());
    let seq = simplify(&input.v0, &input.triangles, &SimplifyOptions::default());
    let model = LodStrips::build(&strips, &seq).unwrap_or_else(|e| panic!("{}: {e}", input.name));
    (strips, Lod { seq, model })
}

/// The current strips of `state` as object regions (capacity = live length).
fn regions(model: &LodStrips, state: &StripsState) -> Vec<Vec<u32>> {
    (0..model.strip_count())
        .map(|s| state.strip(s).unwrap_or_default().to_vec())
        .collect()
}

/// A perspective camera fitted to both poses, looking down -z from slightly above and right.
fn fitted_camera(input: &Input) -> Mat4 {
    let both: Vec<[f32; 3]> = input.v0.iter().chain(&input.v1).copied().collect();
    let (min, max) = morphlod::mesh::bounds(&both).expect("meshes have vertices");
    let direction = Vec3::new(-0.3, -0.25, -1.0);
    camera::fit_to_bounds(
        min,
        max,
        direction,
        1.0,
        Projection::Perspective { vertical_fov: 0.7 },
    )
    .expect("finite bounds")
    .view_proj()
}

fn setup(object: &mut Object, view_proj: Mat4) -> Result<(), GpuError> {
    object.set_view_proj(view_proj);
    object.set_color(BASE);
    object.set_light(Vec3::new(0.3, 0.5, 1.0), 0.2)
}

fn coverage(image: &image::RgbaImage) -> usize {
    image.pixels().filter(|p| p.0 != CLEAR_RGBA).count()
}

#[test]
fn strips_render_like_reference_lists() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    eprintln!("adapter: {:?}", ctx.adapter_info());
    let started = Instant::now();
    let pipeline = &ctx.pipeline;
    let target = ctx.target(SIZE, SIZE, CLEAR);
    let pixels = (SIZE * SIZE) as usize;
    for (k, input) in inputs().iter().enumerate() {
        let asset_started = Instant::now();
        let (_, Lod { seq, model }) = build_lod(input);
        let max = model.max_lod();
        let full = seq.reference_mesh(&input.triangles, 0).len();
        let view_proj = fitted_camera(input);
        // Every mode of drawing the same regions: the default (the whole object one record
        // behind restarts), small groups (many records, restart tails inside each), and one
        // record per strip.
        for draws in [
            Draws::Grouped {
                max_indices: gpu::GROUP_INDICES,
            },
            Draws::Grouped { max_indices: 256 },
            Draws::PerRegion,
        ] {
            let mut state = StripsState::new(&model);
            let mut strips = Object::new(
                device,
                pipeline,
                Topology::Strip,
                &input.v0,
                &input.v1,
                &regions(&model, &state),
            )?;
            setup(&mut strips, view_proj)?;
            strips.set_draws(draws)?;
            let records = strips.indirect_args().len();

            // LOD targets spread evenly over [0, max] (both ends included) in shuffled order;
            // t runs over a permutation of the same grid on [0, 1].
            let mut rng = Rng(0x1A9E ^ k as u64);
            let mut lods: Vec<usize> = (0..STATES).map(|i| max * i / (STATES - 1)).collect();
            for i in (1..STATES).rev() {
                lods.swap(i, rng.below(i + 1));
            }
            let mut min_coverage = pixels;
            // (pixels where the raw reference differs from the strips, largest channel step).
            let mut raw = (0usize, 0u8);
            for (i, &lod) in lods.iter().enumerate() {
                let t = ((i * 5) % STATES) as f32 / (STATES - 1) as f32;
                // A few random moves first; their dirty logs are either applied on the way or
                // left to accumulate into the final one.
                for _ in 0..rng.below(4) {
                    state
                        .set_lod(&model, rng.below(max + 1))
                        .expect("same model");
                    if rng.below(2) == 0 {
                        let dirty = state.take_dirty();
                        strips.apply_dirty(&dirty, state.indices(), state.lengths())?;
                    }
                }
                state.set_lod(&model, lod).expect("same model");
                let dirty = state.take_dirty();
                strips.apply_dirty(&dirty, state.indices(), state.lengths())?;
                for s in 0..model.strip_count() {
                    assert_eq!(
                        strips.live_indices(s).map(Indices::from),
                        state.strip(s),
                        "{}: object region {s} at LOD {lod}",
                        input.name
                    );
                }
                strips.set_t(t)?;
                strips.prepare(queue);
                let drawn = ctx.render_one(&target, &strips);

                let reference = seq.reference_mesh(&input.triangles, lod);
                let lists = reference_lists(&reference, &state, model.strip_count());
                let mut images = Vec::with_capacity(2);
                for list in [lists.rotated, lists.raw] {
                    let mut listed = Object::new(
                        device,
                        pipeline,
                        Topology::List,
                        &input.v0,
                        &input.v1,
                        &[list],
                    )?;
                    setup(&mut listed, view_proj)?;
                    listed.set_t(t)?;
                    listed.prepare(queue);
                    images.push(ctx.render_one(&target, &listed));
                }
                if drawn != images[0] {
                    let what = format!("{} t={t} lod={lod} of {max}", input.name);
                    fail_with_images(&what, &drawn, &images[0]);
                }
                // Evidence for the rotation: how the strips differ from the reference drawn in
                // its own rotation (printed, not asserted).
                for (_, _, a, b) in differences(&drawn, &images[1]) {
                    let step = a.iter().zip(b).map(|(x, y)| x.abs_diff(y)).max();
                    raw = (raw.0 + 1, raw.1.max(step.unwrap_or(0)));
                }
                let covered = coverage(&drawn);
                // A blank or nearly blank image must not pass: while at least a quarter of the
                // triangles remain, the fitted mesh covers at least 1% of the view (the thinnest
                // case, the body shrunk to the baby pose at t near 1, covers about 1.5%).
                if reference.len() * 4 >= full {
                    assert!(
                        covered * 100 >= pixels,
                        "{} t={t} lod={lod}: only {covered} of {pixels} pixels covered",
                        input.name
                    );
                    min_coverage = min_coverage.min(covered);
                }
            }
            eprintln!(
                "{} ({draws:?}, {} records at LOD 0): {} triangles, {} strips, {max} LODs, \
                 {STATES} states identical; min coverage {min_coverage} px of {pixels} (states with >= 1/4 of the triangles); \
                 reference in its own rotation differs in {} px (max channel step {}); {:.2} s",
                input.name,
                records,
                full,
                model.strip_count(),
                raw.0,
                raw.1,
                asset_started.elapsed().as_secs_f64()
            );
        }
    }
    eprintln!(
        "image oracle: {:.2} s total",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Strips of closed meshes rendered with back-face culling and without are identical at every
/// LOD tried: no strip triangle is flipped. Then one triangle's parity is flipped on purpose
/// (its strip gets a leading duplicate index, `[a, a, b, c]` draws `(b, a, c)`) and the same
/// comparison must see the hole.
#[test]
fn back_face_culling_hides_nothing() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let started = Instant::now();
    let formats = (RenderTarget::COLOR_FORMAT, Some(RenderTarget::DEPTH_FORMAT));
    let culled = MorphPipeline::new(device, formats.0, formats.1);
    let unculled = MorphPipeline::with_cull_mode(device, formats.0, formats.1, None);
    let target = ctx.target(SIZE, SIZE, CLEAR);
    let render = |pipeline: &MorphPipeline, input: &Input, view_proj, regions: &[Vec<u32>]| {
        let mut object = Object::new(
            device,
            pipeline,
            Topology::Strip,
            &input.v0,
            &input.v1,
            regions,
        )?;
        setup(&mut object, view_proj)?;
        object.prepare(queue);
        Ok::<_, GpuError>(ctx.render_one(&target, &object))
    };
    for input in [load_static("cow.off"), load_static("bunny.obj")] {
        let (_, Lod { seq, model }) = build_lod(&input);
        let view_proj = fitted_camera(&input);
        let mut state = StripsState::new(&model);
        for percent in [0, 20, 40, 60] {
            let lod = model.max_lod() * percent / 100;
            state.set_lod(&model, lod).expect("same model");
            let regions = regions(&model, &state);
            let a = render(&culled, &input, view_proj, &regions)?;
            let b = render(&unculled, &input, view_proj, &regions)?;
            assert!(
                coverage(&a) * 20 >= (SIZE * SIZE) as usize,
                "{}: coverage",
                input.name
            );
            if a != b {
                let what = format!("{} culled vs unculled at lod {lod}", input.name);
                fail_with_images(&what, &a, &b);
            }
        }

        // The deliberate flip, on strips made here: one strip per reference triangle at 40%,
        // the largest front-facing one (in screen space) drawn with flipped parity.
        let lod = model.max_lod() * 40 / 100;
        let reference = seq.reference_mesh(&input.triangles, lod);
        let screen = |v: u32| view_proj.project_point3(Vec3::from(input.v0[v as usize]));
        let area = |t: &[u32; 3]| {
            let (a, b, c) = (screen(t[0]), screen(t[1]), screen(t[2]));
            (b - a).truncate().perp_dot((c - a).truncate())
        };
        let flipped = (0..reference.len())
            .max_by(|&i, &j| area(&reference[i]).total_cmp(&area(&reference[j])))
            .expect("the reference at 40% has triangles");
        let mut regions: Vec<Vec<u32>> = reference.iter().map(|t| t.to_vec()).collect();
        let [a, b, c] = reference[flipped];
        regions[flipped] = vec![a, a, b, c];
        let with_flip_culled = render(&culled, &input, view_proj, &regions)?;
        let with_flip_unculled = render(&unculled, &input, view_proj, &regions)?;
        let holes = differences(&with_flip_culled, &with_flip_unculled).len();
        assert!(
            holes > 0,
            "{}: a flipped triangle must make the culled render differ",
            input.name
        );
        eprintln!(
            "{}: culled == unculled at 0/20/40/60% LOD; one flipped triangle shows as {holes} differing pixels",
            input.name
        );
    }
    eprintln!("culling test: {:.2} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// LOD at frame `f` of `frames` for a sweep from full detail to `max`.
fn sweep_lod(max: usize, f: usize, frames: usize, exponential: bool) -> usize {
    let x = f as f64 / (frames - 1) as f64;
    // Exponential, as in the LodStrips paper's test: large LOD changes near the viewer (the
    // start, full detail), ever smaller ones as the object moves away.
    const K: f64 = 5.0;
    let s = if exponential {
        (1.0 - (-K * x).exp()) / (1.0 - (-K).exp())
    } else {
        x
    };
    (s * max as f64).round() as usize
}

/// The LOD runtime drives an object over linear and exponential sweeps: exactly one draw per
/// frame, and `apply_dirty` uploads exactly what a full diff of every dirty strip would
/// (`write_region` on a second object), without reading whole regions. Bytes per frame are
/// printed against re-uploading the whole index buffer (issue 5 goal: ≤ 5% on average over
/// the exponential sweep).
#[test]
fn one_draw_per_frame_and_upload_bytes() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let pipeline = &ctx.pipeline;
    let target = ctx.target(SIZE, SIZE, CLEAR);
    const FRAMES: usize = 500;
    for input in [
        load_morph(
            "makehuman_body.glb 'caucasian-male-baby'",
            "makehuman_body.glb",
            MorphSource::Target("caucasian-male-baby".into()),
        ),
        load_static("cow.off"),
    ] {
        let (strips, Lod { model, .. }) = build_lod(&input);
        let full_bytes = strips.indices.len() as u64 * 4;
        let view_proj = fitted_camera(&input);
        for (exponential, gap) in [
            (false, gpu::MERGE_GAP_BYTES),
            (true, gpu::MERGE_GAP_BYTES),
            (true, 0),
            (true, 256),
        ] {
            let started = Instant::now();
            let mut state = StripsState::new(&model);
            let regions = regions(&model, &state);
            let new_object = || -> Result<Object, GpuError> {
                let mut object = Object::new(
                    device,
                    pipeline,
                    Topology::Strip,
                    &input.v0,
                    &input.v1,
                    &regions,
                )?;
                setup(&mut object, view_proj)?;
                object.set_merge_gap(gap);
                Ok(object)
            };
            let (mut object, mut diffed) = (new_object()?, new_object()?);
            object.prepare(queue);
            diffed.prepare(queue);
            let (mut bytes, mut peak, mut writes) = (0u64, 0u64, 0usize);
            let mut touched = Vec::new();
            for f in 0..FRAMES {
                state
                    .set_lod(&model, sweep_lod(model.max_lod(), f, FRAMES, exponential))
                    .expect("same model");
                let dirty = state.take_dirty();
                object.apply_dirty(&dirty, state.indices(), state.lengths())?;
                touched.clear();
                touched.extend(dirty.ranges.iter().map(|r| r.strip as usize));
                touched.extend(dirty.lengths.iter().map(|&s| s as usize));
                touched.sort_unstable();
                touched.dedup();
                for &s in &touched {
                    diffed.write_region(s, state.strip(s).unwrap_or_default())?;
                }
                let t = f as f32 / (FRAMES - 1) as f32;
                object.set_t(t)?;
                let upload = object.prepare(queue);
                let reference = diffed.prepare(queue);
                assert_eq!(
                    (&upload.index_ranges, &upload.indirect_ranges),
                    (&reference.index_ranges, &reference.indirect_ranges),
                    "{} frame {f}: apply_dirty must upload what a full diff uploads",
                    input.name
                );
                let lod_bytes = upload.bytes() - upload.uniform_bytes;
                bytes += lod_bytes;
                peak = peak.max(lod_bytes);
                writes += upload.writes();
                let mut encoder = device.create_command_encoder(&Default::default());
                let calls = {
                    let mut pass = target.begin_pass(&mut encoder);
                    let mut recorder = Recorder {
                        pass: &mut pass,
                        calls: Vec::new(),
                    };
                    object.render(&mut recorder);
                    recorder.calls
                };
                queue.submit([encoder.finish()]);
                assert_one_multi_draw_each(&calls, &[&object]);
            }
            // The last frame's image is the object at max LOD, drawn.
            let image = target.read_image(device, queue)?;
            assert_eq!(state.lod(), model.max_lod());
            let average = bytes as f64 / FRAMES as f64;
            eprintln!(
                "{} {} sweep over {FRAMES} frames, merge gap {gap} B: {} draws; index+indirect bytes per frame: \
                 average {average:.0} ({:.2}% of the {full_bytes}-byte index buffer), peak {peak} \
                 ({:.1}%), {:.1} write_buffer calls per frame; last frame covers {} px; {:.2} s",
                input.name,
                if exponential { "exponential" } else { "linear" },
                FRAMES,
                100.0 * average / full_bytes as f64,
                100.0 * peak as f64 / full_bytes as f64,
                writes as f64 / FRAMES as f64,
                coverage(&image),
                started.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}

/// Two objects (one asset, two LODs, two colours, side by side) share one pipeline and are
/// drawn in one pass: two draw calls in all, and the pass shows exactly what each object
/// renders alone.
#[test]
fn two_objects_share_one_pipeline() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let pipeline = &ctx.pipeline;
    let target = ctx.target(2 * SIZE, SIZE, CLEAR);
    let input = load_static("bunny.obj");
    let (_, Lod { model, .. }) = build_lod(&input);
    let (min, max) = morphlod::mesh::bounds(&input.v0).expect("bunny has vertices");
    let width = max[0] - min[0];
    // Side by side along x, a gap of a quarter width between them.
    let shift = Vec3::X * (width * 0.625);
    let (both_min, both_max) = (
        (Vec3::from(min) - shift).to_array(),
        (Vec3::from(max) + shift).to_array(),
    );
    let view_proj = camera::fit_to_bounds(
        both_min,
        both_max,
        Vec3::NEG_Z,
        2.0,
        Projection::Orthographic,
    )?
    .view_proj();
    let mut state = StripsState::new(&model);
    let mut crowd = Vec::new();
    for (lod_percent, offset, color) in [
        (0, -shift, [1.0, 0.6, 0.0, 1.0]),
        (50, shift, [0.0, 1.0, 0.4, 1.0]),
    ] {
        state
            .set_lod(&model, model.max_lod() * lod_percent / 100)
            .expect("same model");
        let mut object = Object::new(
            device,
            pipeline,
            Topology::Strip,
            &input.v0,
            &input.v1,
            &regions(&model, &state),
        )?;
        setup(&mut object, view_proj)?;
        object.set_model(Mat4::from_translation(offset));
        object.set_color(color);
        object.prepare(queue);
        crowd.push(object);
    }
    let [a, b] = &mut crowd[..] else {
        unreachable!("two objects were pushed");
    };
    let alone_a = ctx.render_one(&target, a);
    let alone_b = ctx.render_one(&target, b);
    let (together, calls) = ctx.render_recorded(&target, &[&*a, &*b]);
    // Two objects in one pass: two draw calls, each of its own records.
    assert_one_multi_draw_each(&calls, &[&*a, &*b]);
    let (covered_a, covered_b) = (coverage(&alone_a), coverage(&alone_b));
    assert!(
        covered_a > 2000 && covered_b > 1000,
        "{covered_a} {covered_b}"
    );
    let mut seen = (0, 0);
    for ((pa, pb), pt) in alone_a
        .pixels()
        .zip(alone_b.pixels())
        .zip(together.pixels())
    {
        let expected = match (pa.0 != CLEAR_RGBA, pb.0 != CLEAR_RGBA) {
            (true, true) => panic!("the two objects must not overlap on screen"),
            (true, false) => {
                seen.0 += 1;
                pa
            }
            (false, true) => {
                seen.1 += 1;
                pb
            }
            (false, false) => pa,
        };
        assert_eq!(
            pt, expected,
            "the crowd pass must show each object as alone"
        );
    }
    assert_eq!(seen, (covered_a, covered_b));
    eprintln!("crowd of 2: {covered_a} + {covered_b} px, 2 draws in one pass");
    Ok(())
}

/// `apply_dirty` checks everything before it changes anything: wrong layouts, ranges past a
/// region, lengths past a capacity and bad indices are typed errors and leave the object as
/// it was.
#[test]
fn apply_dirty_rejects_bad_input() -> Result<(), GpuError> {
    use morphlod::lodstrips::{Dirty, DirtyRange};
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let pipeline = MorphPipeline::new(&ctx.device, RenderTarget::COLOR_FORMAT, None);
    let v = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let regions = [vec![0, 1, 2, 3], vec![3, 2, 1]];
    let mut object = Object::new(&ctx.device, &pipeline, Topology::Strip, &v, &v, &regions)?;
    let buffer = [0, 1, 2, 3, 3, 2, 1];
    let range = |strip, start, end| DirtyRange { strip, start, end };
    let dirty = |ranges: Vec<DirtyRange>, lengths: Vec<u32>| Dirty { ranges, lengths };

    let err = object.apply_dirty(&dirty(vec![], vec![]), &buffer[..6], &[4, 3]);
    assert!(matches!(
        err,
        Err(GpuError::LayoutMismatch {
            indices: 6,
            capacity: 7,
            ..
        })
    ));
    let err = object.apply_dirty(&dirty(vec![], vec![]), &buffer, &[4]);
    assert!(matches!(
        err,
        Err(GpuError::LayoutMismatch {
            strips: 1,
            regions: 2,
            ..
        })
    ));
    let err = object.apply_dirty(&dirty(vec![range(2, 0, 1)], vec![]), &buffer, &[4, 3]);
    assert!(matches!(
        err,
        Err(GpuError::NoSuchRegion {
            region: 2,
            regions: 2
        })
    ));
    let err = object.apply_dirty(&dirty(vec![range(1, 1, 4)], vec![]), &buffer, &[4, 3]);
    assert!(matches!(
        err,
        Err(GpuError::DirtyRange {
            region: 1,
            end: 4,
            capacity: 3,
            ..
        })
    ));
    let err = object.apply_dirty(&dirty(vec![range(1, 2, 1)], vec![]), &buffer, &[4, 3]);
    assert!(matches!(
        err,
        Err(GpuError::DirtyRange {
            start: 2,
            end: 1,
            ..
        })
    ));
    let err = object.apply_dirty(&dirty(vec![], vec![0]), &buffer, &[5, 3]);
    assert!(matches!(
        err,
        Err(GpuError::RegionOverflow {
            region: 0,
            len: 5,
            capacity: 4
        })
    ));
    // A bad index in the range is rejected even though a valid range precedes it.
    let bad = [0, 1, 2, 3, 9, 2, 1];
    let err = object.apply_dirty(
        &dirty(vec![range(0, 0, 1), range(1, 0, 1)], vec![]),
        &bad,
        &[4, 3],
    );
    assert!(matches!(
        err,
        Err(GpuError::IndexOutOfRange {
            region: 1,
            index: 9,
            ..
        })
    ));
    assert_eq!(
        object.prepare(&ctx.queue),
        gpu::Upload::default(),
        "errors change nothing"
    );

    // A valid update: region 0 shrinks to [0, 1, 3] (one changed index, one length), region 1
    // is marked dirty but unchanged. Object slots: region 0 at 0..4, separator 4, region 1 at
    // 5..8, separator 8. Slot 2 changes and slot 3 becomes a restart: bytes 8..16. The one
    // record ends at region 1, which did not move, so no record goes up.
    let next = [0, 1, 3, 3, 3, 2, 1];
    object.apply_dirty(
        &dirty(vec![range(0, 2, 4), range(1, 0, 3)], vec![0]),
        &next,
        &[3, 3],
    )?;
    let upload = object.prepare(&ctx.queue);
    assert_eq!(upload.index_ranges, vec![8..16]);
    assert!(upload.indirect_ranges.is_empty());
    assert_eq!(object.live_indices(0), Some(&[0, 1, 3][..]));
    assert_eq!(
        object.index_mirror(),
        [0, 1, 3, RESTART, RESTART, 3, 2, 1, RESTART]
    );
    // Growing back reads the slot the strip grows by (not in any range) from the runtime.
    let back = [0, 1, 3, 2, 3, 2, 1];
    object.apply_dirty(&dirty(vec![], vec![0]), &back, &[4, 3])?;
    assert_eq!(object.live_indices(0), Some(&[0, 1, 3, 2][..]));
    assert_eq!(object.prepare(&ctx.queue).index_ranges, vec![12..16]);
    Ok(())
}
