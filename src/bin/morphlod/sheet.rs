//! Contact sheets: one deforming object rendered headless at a grid of `(t, lod)` states, the
//! way the papers' figures show a morph (columns: time, rows: level of detail).
//!
//! The object is driven exactly as an application would drive it — a [`LodObject`]:
//! `set(t, lod)`, `prepare`, one multi-draw — so a sheet also reports what each state cost:
//! triangles and indices drawn, bytes uploaded.

use std::sync::Arc;

use glam::Vec3;
use image::RgbaImage;

use morphlod::asset::Asset;
use morphlod::deform::{DeformingModel, Lod};
use morphlod::gpu::camera::frame_both_poses;
use morphlod::gpu::{Context, LodObject, MorphPipeline, RenderTarget, ShadeMode};
use morphlod::Error;

/// How a sheet looks.
#[derive(Clone, Copy, Debug)]
pub struct SheetOptions {
    /// Width and height of one cell, in pixels.
    pub cell: u32,
    /// How the object is shaded (smooth and textured need a surface; without one they draw
    /// faceted).
    pub shade: ShadeMode,
    /// The direction the camera looks along (the object is framed whole for every pose).
    pub direction: Vec3,
}

impl Default for SheetOptions {
    fn default() -> Self {
        SheetOptions {
            cell: 256,
            shade: ShadeMode::Textured,
            direction: Vec3::new(-0.35, -0.15, -1.0),
        }
    }
}

/// What one cell showed and cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub t: f32,
    pub lod: Lod,
    /// The sampled frame whose collapse sequence was used.
    pub frame: usize,
    /// The LOD as a collapse count in that frame.
    pub steps: usize,
    pub triangles: usize,
    pub indices: usize,
    /// Index and indirect bytes written to reach this state from the previous cell.
    pub upload_bytes: u64,
}

/// Background of every cell: a dark grey that no lit surface colour matches.
const CLEAR: wgpu::Color = wgpu::Color {
    r: 0.08,
    g: 0.08,
    b: 0.1,
    a: 1.0,
};

/// Renders `asset` (with its runtime `model`) at every `(t, lod)` of the grid `ts × lods`:
/// row `r` is `lods[r]`, column `c` is `ts[c]`. Returns the sheet and one [`Cell`] per state,
/// row by row.
pub fn render_sheet(
    context: &Context,
    asset: &Asset,
    model: &Arc<DeformingModel>,
    ts: &[f32],
    lods: &[Lod],
    options: &SheetOptions,
) -> Result<(RgbaImage, Vec<Cell>), Error> {
    let device = &context.device;
    let queue = &context.queue;
    let target = RenderTarget::new(device, options.cell, options.cell, CLEAR)?;
    let pipeline = MorphPipeline::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    let mut object = LodObject::new(device, &pipeline, asset, Arc::clone(model))?;
    let camera = frame_both_poses(asset, options.direction)?;
    object.set_view_proj(camera.view_proj());
    object.set_color([0.85, 0.62, 0.5, 1.0]);
    object.set_light(-options.direction + Vec3::Y * 0.5, 0.25)?;
    object.set_shade_mode(options.shade);

    let (w, h) = (options.cell, options.cell);
    let mut sheet = RgbaImage::new(w * ts.len() as u32, h * lods.len() as u32);
    let mut cells = Vec::with_capacity(ts.len() * lods.len());
    for (row, &lod) in lods.iter().enumerate() {
        for (col, &t) in ts.iter().enumerate() {
            object.set(t, lod)?;
            let upload = object.prepare(queue);
            let image = target.render(device, queue, &[object.object()])?;
            image::imageops::replace(
                &mut sheet,
                &image,
                i64::from(col as u32 * w),
                i64::from(row as u32 * h),
            );
            let state = object.state();
            cells.push(Cell {
                t,
                lod,
                frame: state.frame(),
                steps: state.lod(),
                triangles: state.triangle_count(),
                indices: state.index_count(),
                upload_bytes: upload.geometry_bytes(),
            });
        }
    }
    Ok((sheet, cells))
}
