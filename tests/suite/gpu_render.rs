//! Renders small hand-made objects on the GPU and checks pixels against what the geometry
//! says must be covered. Every test gets its device from `common::gpu::Gpu::new`: it fails when
//! no adapter exists and `CI` is set (`morphlod::ci::is_ci`), and skips with a printed reason
//! elsewhere.

use crate::common;

use common::gpu::Gpu;
use glam::{Mat4, Vec3};
use morphlod::gpu::{self, GpuError, MorphPipeline, Object, RenderTarget, Topology, RESTART};

const SIZE: u32 = 64;
/// Pure blue: every channel is exactly 0 or 255, so "untouched" is an exact comparison.
const CLEAR: wgpu::Color = wgpu::Color {
    r: 0.0,
    g: 0.0,
    b: 1.0,
    a: 1.0,
};
const CLEAR_RGBA: [u8; 4] = [0, 0, 255, 255];
const BASE: [f32; 4] = [1.0, 0.5, 0.0, 1.0];
/// BASE fully lit: the quads face the camera and the light comes from the camera, so the
/// derivative normal gives diffuse = 1 and the ambient term drops out.
const LIT_RGBA: [u8; 4] = [255, 128, 0, 255];

/// A right-handed camera on +z looking at the origin; world x, y in [-1, 1] fill the target.
fn camera() -> Mat4 {
    let view = glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
    let proj = glam::camera::rh::proj::directx::orthographic(-1.0, 1.0, -1.0, 1.0, 0.1, 10.0);
    proj * view
}

/// The pixel whose centre is nearest to world point (x, y) under [`camera`].
fn pixel(image: &image::RgbaImage, x: f32, y: f32) -> [u8; 4] {
    let px = ((x + 1.0) * 0.5 * SIZE as f32) as u32;
    let py = ((1.0 - y) * 0.5 * SIZE as f32) as u32;
    image.get_pixel(px, py).0
}

fn assert_lit(image: &image::RgbaImage, x: f32, y: f32, what: &str) {
    let got = pixel(image, x, y);
    let close = got.iter().zip(LIT_RGBA).all(|(&g, e)| g.abs_diff(e) <= 1);
    assert!(
        close,
        "{what}: pixel at ({x}, {y}) is {got:?}, expected lit {LIT_RGBA:?}"
    );
}

fn assert_clear(image: &image::RgbaImage, x: f32, y: f32, what: &str) {
    let got = pixel(image, x, y);
    assert_eq!(
        got, CLEAR_RGBA,
        "{what}: pixel at ({x}, {y}) should be the clear colour"
    );
}

/// Corners of an axis-aligned quad in the z = 0 plane, in strip order: bottom-left,
/// bottom-right, top-left, top-right (the strip [a, b, c, d] is counter-clockwise).
fn quad(x0: f32, x1: f32, y0: f32, y1: f32) -> [[f32; 3]; 4] {
    [[x0, y0, 0.0], [x1, y0, 0.0], [x0, y1, 0.0], [x1, y1, 0.0]]
}

/// Region 0: quad A, x in [-0.9, -0.1] at t = 0 and [-0.5, 0.3] at t = 1, so [-0.7, 0.1] at
/// t = 0.5; y in [0.1, 0.9]. Region 1: static quad B, x in [-0.9, 0.9], y in [-0.9, -0.1].
fn two_quads(device: &wgpu::Device, pipeline: &MorphPipeline) -> Result<Object, GpuError> {
    let b = quad(-0.9, 0.9, -0.9, -0.1);
    let v0: Vec<[f32; 3]> = quad(-0.9, -0.1, 0.1, 0.9).into_iter().chain(b).collect();
    let v1: Vec<[f32; 3]> = quad(-0.5, 0.3, 0.1, 0.9).into_iter().chain(b).collect();
    let mut object = Object::new(
        device,
        pipeline,
        Topology::Strip,
        &v0,
        &v1,
        &[vec![0, 1, 2, 3], vec![4, 5, 6, 7]],
    )?;
    object.set_view_proj(camera());
    object.set_color(BASE);
    object.set_light(Vec3::Z, 0.2)?;
    Ok(object)
}

#[test]
fn blended_strips_one_multi_draw_and_partial_uploads() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    eprintln!("adapter: {:?}", ctx.adapter_info());
    let pipeline = &ctx.pipeline;
    let target = ctx.target(SIZE, SIZE, CLEAR);
    let mut object = two_quads(device, pipeline)?;

    object.set_t(0.5)?;
    let upload = object.prepare(queue);
    assert!(upload.index_ranges.is_empty() && upload.indirect_ranges.is_empty());
    assert_eq!(upload.uniform_bytes, size_of::<gpu::Uniforms>() as u64);
    let image = ctx.render_one(&target, &object);
    assert_lit(&image, -0.3, 0.5, "inside blended quad A");
    assert_lit(
        &image,
        0.05,
        0.5,
        "blended quad A near its t=0.5 right edge",
    );
    assert_clear(&image, -0.8, 0.5, "covered by quad A only at t = 0");
    assert_clear(&image, 0.2, 0.5, "covered by quad A only at t = 1");
    assert_clear(&image, 0.6, 0.5, "outside everything");
    assert_clear(&image, 0.0, 0.0, "between the quads");
    assert_lit(&image, -0.7, -0.7, "quad B, first strip triangle");
    assert_lit(&image, 0.7, -0.2, "quad B, second strip triangle");

    // The two "clear at t = 0.5" pixels are covered at the ends of the blend, so the checks
    // above test the blend, not a misplaced quad.
    for (t, x) in [(0.0, -0.8), (1.0, 0.2)] {
        object.set_t(t)?;
        object.prepare(queue);
        let image = ctx.render_one(&target, &object);
        assert_lit(&image, x, 0.5, "quad A at an end of the blend");
    }
    object.set_t(0.5)?;
    object.prepare(queue);

    // Layout: region 0 in slots 0..4, a restart separator at 4, region 1 in slots 5..9, a
    // separator at 9; one record draws both (slots 0..9).
    assert_eq!(object.indirect_args().len(), 1);
    assert_eq!(object.indirect_args()[0].index_count, 9);
    // Shrinking region 1 to its first triangle: same leading indices, so only the restart
    // written over its dropped slot 8 (bytes 32..36) and the one record, which now ends at
    // slot 8, are uploaded.
    object.write_region(1, &[4, 5, 6])?;
    let upload = object.prepare(queue);
    assert_eq!(upload.index_ranges, vec![32..36]);
    assert_eq!(upload.indirect_ranges, vec![0..20]);
    assert_eq!(upload.uniform_bytes, 0);
    assert_eq!(object.lengths(), [4, 3]);
    assert_eq!(object.indirect_args()[0].index_count, 8);
    assert_eq!(object.index_mirror()[8], RESTART);
    let image = ctx.render_one(&target, &object);
    assert_lit(&image, -0.7, -0.7, "quad B, kept triangle");
    assert_clear(&image, 0.7, -0.2, "quad B, dropped triangle");
    assert_lit(&image, -0.3, 0.5, "quad A, untouched region");

    // Rewriting region 1 as the other triangle (d, c, b), still counter-clockwise: three
    // indices change, the count does not. Only region 1's bytes [20, 32) may be written.
    object.write_region(1, &[7, 6, 5])?;
    let upload = object.prepare(queue);
    assert_eq!(upload.index_ranges, vec![20..32]);
    assert!(upload.indirect_ranges.is_empty());
    assert_eq!(upload.bytes(), 12);
    assert_eq!(upload.writes(), 1);
    assert_eq!(object.live_indices(1), Some(&[7, 6, 5][..]));
    let image = ctx.render_one(&target, &object);
    assert_clear(&image, -0.7, -0.7, "quad B, now dropped triangle");
    assert_lit(&image, 0.7, -0.2, "quad B, now drawn triangle");
    assert_lit(&image, -0.3, 0.5, "quad A, untouched region");

    // An empty region draws nothing: restarts over its slots, the record ends after region 0.
    object.write_region(1, &[])?;
    let upload = object.prepare(queue);
    assert_eq!(upload.index_ranges, vec![20..32]);
    assert_eq!(upload.indirect_ranges, vec![0..20]);
    assert_eq!(object.indirect_args()[0].index_count, 4);
    let image = ctx.render_one(&target, &object);
    assert_clear(&image, 0.7, -0.2, "quad B, emptied region");
    assert_clear(&image, -0.7, -0.7, "quad B, emptied region");
    Ok(())
}

#[test]
fn restart_and_culling() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let target = ctx.target(SIZE, SIZE, CLEAR);
    let v = quad(-0.9, 0.9, -0.9, 0.9);
    // Two strips in one region separated by a restart: (a, b, c), then (d, c, b); both are
    // counter-clockwise only if the restart resets the parity.
    let restarted = vec![0, 1, 2, RESTART, 3, 2, 1];
    // (b, c, d) is clockwise: back-face culling must hide it, cull mode None must not.
    let clockwise = vec![1, 2, 3];
    for (cull, clockwise_visible) in [(Some(wgpu::Face::Back), false), (None, true)] {
        let pipeline = MorphPipeline::with_cull_mode(
            device,
            RenderTarget::COLOR_FORMAT,
            Some(RenderTarget::DEPTH_FORMAT),
            cull,
        );
        for (strip, upper_right_lit) in [(&restarted, true), (&clockwise, clockwise_visible)] {
            let mut object = Object::new(
                device,
                &pipeline,
                Topology::Strip,
                &v,
                &v,
                std::slice::from_ref(strip),
            )?;
            object.set_view_proj(camera());
            object.set_color(BASE);
            object.set_light(Vec3::Z, 0.2)?;
            object.prepare(queue);
            let image = ctx.render_one(&target, &object);
            let what = format!("strip {strip:?} with cull {cull:?}");
            if strip == &restarted {
                assert_lit(&image, -0.5, -0.5, &what);
            }
            if upper_right_lit {
                // Derivative normals face the viewer whichever way a triangle winds.
                assert_lit(&image, 0.5, 0.5, &what);
            } else {
                assert_clear(&image, 0.5, 0.5, &what);
            }
        }
    }
    Ok(())
}

#[test]
fn triangle_list_matches_strip() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let pipeline = &ctx.pipeline;
    let target = ctx.target(SIZE, SIZE, CLEAR);
    let v = quad(-0.6, 0.6, -0.6, 0.6);
    // The strip [a, b, c, d] as the list of its triangles (a, b, c), (c, b, d).
    let mut images = Vec::new();
    for (topology, indices) in [
        (Topology::Strip, vec![0, 1, 2, 3]),
        (Topology::List, vec![0, 1, 2, 2, 1, 3]),
    ] {
        let mut object = Object::new(device, pipeline, topology, &v, &v, &[indices])?;
        object.set_view_proj(camera());
        object.set_color(BASE);
        object.prepare(queue);
        images.push(ctx.render_one(&target, &object));
    }
    assert_lit(&images[0], 0.0, 0.0, "strip quad");
    assert_clear(&images[0], 0.8, 0.8, "outside the strip quad");
    let differing = images[0]
        .pixels()
        .zip(images[1].pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(
        differing, 0,
        "list and strip renders of one quad must be identical"
    );
    Ok(())
}

#[test]
fn object_rejects_bad_input() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let device = &ctx.device;
    let pipeline = MorphPipeline::new(device, RenderTarget::COLOR_FORMAT, None);
    let v = quad(0.0, 1.0, 0.0, 1.0);
    let short = &v[..3];
    assert!(matches!(
        Object::new(device, &pipeline, Topology::Strip, &v, short, &[]),
        Err(GpuError::PoseSizeMismatch { v0: 4, v1: 3 })
    ));
    assert!(matches!(
        Object::new(device, &pipeline, Topology::Strip, &[], &[], &[]),
        Err(GpuError::VertexCount { count: 0, .. })
    ));
    assert!(matches!(
        Object::new(device, &pipeline, Topology::Strip, &v, &v, &[vec![0, 1, 4]]),
        Err(GpuError::IndexOutOfRange {
            region: 0,
            position: 2,
            index: 4,
            ..
        })
    ));
    assert!(matches!(
        Object::new(
            device,
            &pipeline,
            Topology::List,
            &v,
            &v,
            &[vec![0, 1, RESTART]]
        ),
        Err(GpuError::IndexOutOfRange {
            restart_allowed: false,
            ..
        })
    ));

    let mut object = Object::new(
        device,
        &pipeline,
        Topology::Strip,
        &v,
        &v,
        &[vec![0, 1, 2, 3]],
    )?;
    assert!(matches!(
        object.set_draws(gpu::Draws::Grouped { max_indices: 64 }),
        Ok(())
    ));
    let mut list = Object::new(device, &pipeline, Topology::List, &v, &v, &[vec![0, 1, 2]])?;
    assert!(matches!(
        list.set_draws(gpu::Draws::Grouped { max_indices: 64 }),
        Err(GpuError::GroupedList)
    ));
    assert_eq!(list.draws(), gpu::Draws::PerRegion);
    assert!(matches!(
        object.write_region(0, &[0, 1, 2, 3, 0]),
        Err(GpuError::RegionOverflow {
            region: 0,
            len: 5,
            capacity: 4
        })
    ));
    assert!(matches!(
        object.write_region(1, &[0]),
        Err(GpuError::NoSuchRegion {
            region: 1,
            regions: 1
        })
    ));
    match object.write_region(0, &[0, 9]) {
        Err(
            error @ GpuError::IndexOutOfRange {
                position: 1,
                index: 9,
                ..
            },
        ) => {
            let message = error.to_string();
            assert!(
                message.contains("index 9 at position 1 of region 0")
                    && message.contains("4 vertices"),
                "the message must say what and where: {message}"
            );
        }
        other => panic!("expected IndexOutOfRange, got {other:?}"),
    }
    assert!(matches!(object.set_t(f32::NAN), Err(GpuError::TimeNaN)));
    assert!(object.set_light(Vec3::ZERO, 0.2).is_err());
    assert!(object.set_light(Vec3::Z, 2.0).is_err());
    // Failed calls change nothing: the region still holds its strip and nothing is dirty.
    assert_eq!(object.live_indices(0), Some(&[0, 1, 2, 3][..]));
    assert_eq!(object.prepare(&ctx.queue), gpu::Upload::default());
    // t outside [0, 1] is clamped, not refused: the uniforms change.
    object.set_t(1.5)?;
    assert!(object.prepare(&ctx.queue).uniform_bytes > 0);
    assert!(matches!(
        RenderTarget::new(device, 0, 16, CLEAR),
        Err(GpuError::RenderTargetSize { width: 0, .. })
    ));
    Ok(())
}

#[test]
fn strip_colours_follow_first_instance() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    eprintln!(
        "INDIRECT_FIRST_INSTANCE enabled: {}",
        ctx.first_instance_enabled()
    );
    let pipeline = &ctx.pipeline;
    let target = ctx.target(SIZE, SIZE, CLEAR);
    let mut object = two_quads(device, pipeline)?;
    object.set_shade_mode(gpu::ShadeMode::StripColours);
    let first_instances: Vec<u32> = object
        .indirect_args()
        .iter()
        .map(|a| a.first_instance)
        .collect();
    object.prepare(queue);
    let image = ctx.render_one(&target, &object);
    // Quad A at t = 0 covers (-0.5, 0.5); quad B covers (0.0, -0.5).
    let (a, b) = (pixel(&image, -0.5, 0.5), pixel(&image, 0.0, -0.5));
    assert_ne!(a, CLEAR_RGBA);
    assert_ne!(b, CLEAR_RGBA);
    if ctx.first_instance_enabled() {
        assert_eq!(first_instances, [0, 1]);
        assert_ne!(a, b, "regions 0 and 1 must get different strip colours");
    } else {
        // wgpu requires first_instance = 0 without the feature: one colour for all strips.
        assert_eq!(first_instances, [0, 0]);
        assert_eq!(a, b);
    }

    // The PNG helper writes what was read back.
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("strip_colours.png");
    gpu::save_png(&image, &path)?;
    let reloaded = match image::open(&path) {
        Ok(reloaded) => reloaded.into_rgba8(),
        Err(error) => panic!("cannot reload {}: {error}", path.display()),
    };
    assert!(reloaded == image, "the PNG must round-trip the pixels");
    let bad = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("no/such/dir/x.png");
    assert!(matches!(
        gpu::save_png(&image, &bad),
        Err(GpuError::Png { .. })
    ));
    Ok(())
}

/// 256 regions in one object: one multi-draw must draw every one of them, grouped in one
/// record or one record per region; hiding every other region writes restarts over them in
/// one coalesced index write, and switching to per-region records uploads the records once.
#[test]
fn many_regions_one_draw() -> Result<(), GpuError> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (&ctx.device, &ctx.queue);
    let pipeline = &ctx.pipeline;
    let target = ctx.target(SIZE, SIZE, CLEAR);
    const CELLS: u32 = 16;
    let cell = 2.0 / CELLS as f32;
    let centre = |i: u32| -1.0 + (i as f32 + 0.5) * cell;
    let mut v = Vec::new();
    let mut regions = Vec::new();
    for j in 0..CELLS {
        for i in 0..CELLS {
            // Cells are 4 pixels wide; each quad covers the middle 2, leaving 2-pixel gaps.
            let (x, y, h) = (centre(i), centre(j), 0.25 * cell);
            let first = v.len() as u32;
            v.extend(quad(x - h, x + h, y - h, y + h));
            regions.push(vec![first, first + 1, first + 2, first + 3]);
        }
    }
    let mut object = Object::new(device, pipeline, Topology::Strip, &v, &v, &regions)?;
    object.set_view_proj(camera());
    object.set_color(BASE);
    object.prepare(queue);
    let image = ctx.render_one(&target, &object);
    for j in 0..CELLS {
        for i in 0..CELLS {
            assert_lit(&image, centre(i), centre(j), "every region drawn");
        }
    }
    // Pixel (3, 3): its centre lies between the quads of cells 0 and 1.
    let gap = -1.0 + 3.5 / (SIZE as f32 / 2.0);
    assert_clear(&image, gap, gap, "gap between cells");

    assert_eq!(object.indirect_args().len(), 1, "one record by default");

    for region in (0..regions.len()).step_by(2) {
        object.write_region(region, &[])?;
    }
    let upload = object.prepare(queue);
    // Regions take 5 slots (4 indices and a separator): restarts over slots 0..4, 10..14, ...,
    // 1270..1274, 24 bytes apart, merge into one write; the record still ends at region 255.
    assert_eq!(upload.index_ranges, vec![0..1274 * 4]);
    assert!(upload.indirect_ranges.is_empty());
    let check = |image: &image::RgbaImage| {
        for j in 0..CELLS {
            for i in 0..CELLS {
                let (x, y) = (centre(i), centre(j));
                if (j * CELLS + i).is_multiple_of(2) {
                    assert_clear(image, x, y, "hidden region");
                } else {
                    assert_lit(image, x, y, "kept region");
                }
            }
        }
    };
    check(&ctx.render_one(&target, &object));
    // One record per region: hidden regions get empty records; 256 records go up once.
    object.set_draws(gpu::Draws::PerRegion)?;
    let upload = object.prepare(queue);
    assert!(upload.index_ranges.is_empty());
    assert_eq!(upload.indirect_ranges, vec![0..256 * 20]);
    assert_eq!(object.indirect_args().len(), 256);
    assert_eq!(object.indirect_args()[2].index_count, 0);
    assert_eq!(object.indirect_args()[3].index_count, 4);
    check(&ctx.render_one(&target, &object));

    // An object without regions still renders (an empty multi-draw) and draws nothing.
    let mut empty = Object::new(device, pipeline, Topology::Strip, &v, &v, &[])?;
    empty.prepare(queue);
    let image = ctx.render_one(&target, &empty);
    assert!(image.pixels().all(|p| p.0 == CLEAR_RGBA));
    Ok(())
}
