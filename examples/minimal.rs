//! The smallest complete use of morphlod: build a LOD asset from a morph, put it on a GPU
//! without a window, pick a time and a level of detail, draw it once and save a PNG.
//!
//! `cargo run --example minimal` writes `out/minimal.png` and prints where.
//! The README's library example is this file; CI compiles it (`clippy --all-targets`).

use std::path::Path;
use std::sync::Arc;

use morphlod::gpu::camera::{fit_to_bounds, Projection};
use morphlod::gpu::{save_png, Context, LodObject, MorphPipeline, RenderTarget};
use morphlod::io::LoadOptions;
use morphlod::io::MorphSource;
use morphlod::{Builder, DeformingModel, Lod};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // A morph: the head's triangulation T with V(0) = the neutral face and V(1) = the face with
    // the `jawOpen` target applied (glTF morph target; two meshes or an animation work too).
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_head.glb");
    let source = MorphSource::Target("jawOpen".into());
    let morph = morphlod::io::load_morph(&file, &LoadOptions::default(), &source)?;

    // The offline step: strips S0 over T, and one collapse sequence per sampled frame (4 poses
    // at t = 0, 1/3, 2/3, 1). `asset.save("head.mlod")` would write it, `Asset::load` read it.
    let (asset, _report) = Builder::new(&morph).frames(4).build()?;

    // The runtime model: every frame's change lists over the shared S0. Read-only; a crowd of
    // objects of this asset shares one through the Arc.
    let model = Arc::new(DeformingModel::new(&asset)?);

    // A device and queue without a window (an application passes its own instead).
    let ctx = Context::headless()?;

    // The render pipelines for the target's formats; one serves any number of objects.
    let pipeline = MorphPipeline::new(
        &ctx.device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );

    // The object: V(0), V(1) and S0 uploaded once, at t = 0 and full detail.
    let mut object = LodObject::new(&ctx.device, &pipeline, &asset, model)?;

    // A camera that frames both poses, looking at the face.
    let both: Vec<[f32; 3]> = asset.v0.iter().chain(&asset.v1).copied().collect();
    let (min, max) = morphlod::mesh::bounds(&both).ok_or("the mesh has no vertices")?;
    let direction = glam::Vec3::new(0.3, -0.2, -1.0);
    let camera = fit_to_bounds(
        min,
        max,
        direction,
        1.0,
        Projection::Perspective { vertical_fov: 0.7 },
    )?;
    object.set_view_proj(camera.view_proj());

    // Every frame of an application: the CPU moves to (t, LOD) by editing indices...
    object.set(0.5, Lod::Fraction(0.8))?;
    // ...`prepare` uploads only the words that changed...
    let upload = object.prepare(&ctx.queue);
    // ...and `render` records exactly one multi_draw_indexed_indirect in the caller's pass.
    let target = RenderTarget::new(&ctx.device, 512, 512, wgpu::Color::BLACK)?;
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = target.begin_pass(&mut encoder); // clears colour and depth
        object.render(&mut pass);
    }
    ctx.queue.submit([encoder.finish()]);

    // Copy the picture back from the GPU and save it.
    let image = target.read_image(&ctx.device, &ctx.queue)?;
    let out = Path::new("out/minimal.png");
    std::fs::create_dir_all("out")?;
    save_png(&image, out)?;
    let state = object.state();
    println!(
        "wrote {} (frame {} of {}, {} triangles, {} bytes uploaded)",
        out.display(),
        state.frame(),
        asset.frames.len(),
        state.triangle_count(),
        upload.bytes()
    );
    Ok(())
}
