//! The one GPU set-up of the test suite, and the read-back of what a `gpu::Object` holds.
//!
//! * [`Gpu::new`]: a headless device, the default morph pipeline and the skip/fail rule: with
//!   no adapter, a test fails under CI ([`morphlod::ci::is_ci`]: CI must not pass by skipping
//!   every GPU test) and skips with a printed reason elsewhere ([`super::skip_outside_ci`]).
//! * [`Gpu::read_words`]: copies a buffer back from the GPU (`copy_buffer_to_buffer` into a
//!   `MAP_READ` staging buffer).
//! * [`Gpu::drawn_by`]: the triangles one `multi_draw_indexed_indirect` of an object draws,
//!   decoded from the index and indirect buffers as they are on the GPU.
//! * [`Gpu::render_recorded`]: renders through a [`Recorder`] that forwards every command to
//!   the real pass and keeps it, so [`assert_one_multi_draw_each`] sees the draw calls really
//!   issued and their arguments (not a counter the object keeps about itself).
//! * [`reference_lists`], [`differences`], [`fail_with_images`]: the image oracle's comparison
//!   of strips with the reference list (tests/suite/image_oracle.rs, tests/suite/textured.rs).

use std::sync::mpsc;

use morphlod::gpu::{Context, GpuError, MorphPipeline, Object, RenderCommands, RenderTarget};

use std::collections::HashMap;
use std::path::Path;

use morphlod::collapse::canonical;
use morphlod::gpu;
use morphlod::lodstrips::StripsState;

use super::strip_draw;

/// A headless device, its queue and the default pipeline (colour + depth, back faces culled).
pub struct Gpu {
    pub ctx: Context,
    pub pipeline: MorphPipeline,
}

impl Gpu {
    /// The device every GPU test uses. No adapter: panics under CI ([`morphlod::ci::is_ci`]),
    /// otherwise prints why and returns `None` so the test returns early
    /// ([`super::skip_outside_ci`]). An adapter that cannot make a device is a failure
    /// everywhere.
    pub fn new() -> Option<Gpu> {
        let ctx = match Context::headless() {
            Ok(ctx) => ctx,
            Err(error @ GpuError::NoAdapter { .. }) => {
                super::skip_outside_ci(&format!("GPU test without an adapter: {error}"));
                return None;
            }
            Err(error) => panic!("GPU test failed: {error}"),
        };
        let pipeline = MorphPipeline::new(
            &ctx.device,
            RenderTarget::COLOR_FORMAT,
            Some(RenderTarget::DEPTH_FORMAT),
        );
        Some(Gpu { ctx, pipeline })
    }

    pub fn device(&self) -> &wgpu::Device {
        &self.ctx.device
    }

    pub fn queue(&self) -> &wgpu::Queue {
        &self.ctx.queue
    }

    /// An offscreen colour + depth target of the pipeline's formats.
    pub fn target(&self, width: u32, height: u32, clear: wgpu::Color) -> RenderTarget {
        RenderTarget::new(self.device(), width, height, clear)
            .expect("a small target fits any device")
    }

    /// The whole contents of `buffer` (created with `COPY_SRC`, size a multiple of 4) as the
    /// GPU holds it once every submitted command has run.
    pub fn read_words(&self, buffer: &wgpu::Buffer) -> Vec<u32> {
        let (device, queue) = (self.device(), self.queue());
        let size = buffer.size();
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("test read-back"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        queue.submit([encoder.finish()]);
        let (sender, receiver) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |result| {
            let _ = sender.send(result);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("the device answers");
        receiver
            .recv()
            .expect("the map callback ran")
            .expect("the read-back buffer maps");
        let words = {
            let view = staging.get_mapped_range(..).expect("mapped");
            bytemuck::cast_slice::<u8, u32>(&view).to_vec()
        };
        staging.unmap();
        words
    }

    /// Renders `object` alone through a [`Recorder`] and checks that it issued exactly one
    /// multi-draw of its own records ([`assert_one_multi_draw_each`]).
    pub fn render_one(&self, target: &RenderTarget, object: &Object) -> image::RgbaImage {
        let (image, calls) = self.render_recorded(target, &[object]);
        assert_one_multi_draw_each(&calls, &[object]);
        image
    }

    /// Renders `objects` in one pass through a [`Recorder`] wrapped around the real render
    /// pass, submits, reads the image back and returns it with every recorded command.
    pub fn render_recorded(
        &self,
        target: &RenderTarget,
        objects: &[&Object],
    ) -> (image::RgbaImage, Vec<Call>) {
        let mut encoder = self.device().create_command_encoder(&Default::default());
        let calls = {
            let mut pass = target.begin_pass(&mut encoder);
            let mut recorder = Recorder {
                pass: &mut pass,
                calls: Vec::new(),
            };
            for object in objects {
                object.render(&mut recorder);
            }
            recorder.calls
        };
        self.queue().submit([encoder.finish()]);
        let image = target
            .read_image(self.device(), self.queue())
            .expect("the image reads back");
        (image, calls)
    }

    /// The index buffer and the drawn indirect records of `object` as the GPU holds them, and
    /// the triangles one render of it draws: `multi_draw_indexed_indirect` over the first
    /// `indirect_args().len()` records (the count `render` passes), decoded with
    /// [`draw_indexed_indirect`]; `vertices` is the object's vertex count.
    pub fn drawn_by(&self, object: &Object, vertices: usize) -> Drawn {
        let indices = self.read_words(object.index_buffer());
        let words = self.read_words(object.indirect_buffer());
        let count = object.indirect_args().len();
        assert!(
            words.len() >= count * 5,
            "the indirect buffer holds {} records, render draws {count}",
            words.len() / 5
        );
        let records: Vec<[u32; 5]> = words
            .chunks_exact(5)
            .take(count)
            .map(|r| [r[0], r[1], r[2], r[3], r[4]])
            .collect();
        let triangles = draw_indexed_indirect(&indices, &records, vertices as u32);
        Drawn {
            indices,
            records,
            triangles,
        }
    }
}

/// A `Gpu` is used like the `Context` it holds (`ctx.device`, `ctx.adapter_info()`, ...).
impl std::ops::Deref for Gpu {
    type Target = Context;
    fn deref(&self) -> &Context {
        &self.ctx
    }
}

/// What the GPU holds for one object and what it draws from it.
pub struct Drawn {
    /// The whole index buffer.
    pub indices: Vec<u32>,
    /// The drawn records: index_count, instance_count, first_index, base_vertex,
    /// first_instance.
    pub records: Vec<[u32; 5]>,
    /// Every triangle drawn, in draw order, once per instance.
    pub triangles: Vec<[u32; 3]>,
}

/// The triangles `DrawIndexedIndirectArgs` records draw from a `Uint32` triangle-strip index
/// buffer with primitive restart, following the GPU's rules: record `r` reads
/// `indices[first_index .. first_index + index_count]`, a restart value (compared before
/// `base_vertex` is added) restarts the strip, every other index is offset by `base_vertex`,
/// and the strip is drawn `instance_count` times. Panics when a record reads past the buffer
/// or names a vertex `>= vertices` (the GPU would read garbage or nothing: a bug either way).
pub fn draw_indexed_indirect(
    indices: &[u32],
    records: &[[u32; 5]],
    vertices: u32,
) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for (r, &[index_count, instance_count, first_index, base_vertex, _]) in
        records.iter().enumerate()
    {
        let span = first_index as usize..first_index as usize + index_count as usize;
        let read = indices.get(span.clone()).unwrap_or_else(|| {
            panic!(
                "record {r} reads indices {span:?} of a {}-index buffer",
                indices.len()
            )
        });
        let offset: Vec<u32> = read
            .iter()
            .map(|&i| {
                if i == super::RESTART {
                    i
                } else {
                    let v = i as i64 + base_vertex as i32 as i64;
                    assert!(
                        (0..vertices as i64).contains(&v),
                        "record {r} draws vertex {v} of {vertices}"
                    );
                    v as u32
                }
            })
            .collect();
        let triangles = strip_draw(&offset);
        for _ in 0..instance_count {
            out.extend_from_slice(&triangles);
        }
    }
    out
}

/// One command `Object::render` issued, as [`Recorder`] saw it.
#[derive(Clone, Debug, PartialEq)]
pub enum Call {
    SetPipeline,
    SetBindGroup(u32),
    SetVertexBuffer(u32, wgpu::Buffer),
    SetIndexBuffer(wgpu::Buffer, wgpu::IndexFormat),
    MultiDrawIndexedIndirect {
        indirect: wgpu::Buffer,
        offset: u64,
        count: u32,
    },
}

/// A render pass that keeps every command and forwards it to the real pass.
pub struct Recorder<'a, 'p> {
    pub pass: &'a mut wgpu::RenderPass<'p>,
    pub calls: Vec<Call>,
}

impl RenderCommands for Recorder<'_, '_> {
    fn set_pipeline(&mut self, pipeline: &wgpu::RenderPipeline) {
        self.calls.push(Call::SetPipeline);
        self.pass.set_pipeline(pipeline);
    }

    fn set_bind_group(&mut self, index: u32, bind_group: &wgpu::BindGroup) {
        self.calls.push(Call::SetBindGroup(index));
        self.pass.set_bind_group(index, bind_group, &[]);
    }

    fn set_vertex_buffer(&mut self, slot: u32, buffer: &wgpu::Buffer) {
        self.calls.push(Call::SetVertexBuffer(slot, buffer.clone()));
        self.pass.set_vertex_buffer(slot, buffer.slice(..));
    }

    fn set_index_buffer(&mut self, buffer: &wgpu::Buffer, format: wgpu::IndexFormat) {
        self.calls
            .push(Call::SetIndexBuffer(buffer.clone(), format));
        self.pass.set_index_buffer(buffer.slice(..), format);
    }

    fn multi_draw_indexed_indirect(&mut self, indirect: &wgpu::Buffer, offset: u64, count: u32) {
        self.calls.push(Call::MultiDrawIndexedIndirect {
            indirect: indirect.clone(),
            offset,
            count,
        });
        self.pass
            .multi_draw_indexed_indirect(indirect, offset, count);
    }
}

/// `calls` are exactly one draw per object, in order: each object's draw is one
/// `multi_draw_indexed_indirect` of its own indirect buffer from offset 0 over all its
/// records, issued while its own index buffer (u32) is bound; nothing else draws.
pub fn assert_one_multi_draw_each(calls: &[Call], objects: &[&Object]) {
    let draws: Vec<(usize, &Call)> = calls
        .iter()
        .enumerate()
        .filter(|(_, call)| matches!(call, Call::MultiDrawIndexedIndirect { .. }))
        .collect();
    assert_eq!(
        draws.len(),
        objects.len(),
        "one multi-draw per object expected, the pass recorded {calls:?}"
    );
    for (&(at, draw), object) in draws.iter().zip(objects) {
        let expected = Call::MultiDrawIndexedIndirect {
            indirect: object.indirect_buffer().clone(),
            offset: 0,
            count: object.indirect_args().len() as u32,
        };
        assert_eq!(
            *draw, expected,
            "the draw of an object reads its own records"
        );
        let bound = calls[..at]
            .iter()
            .rev()
            .find(|call| matches!(call, Call::SetIndexBuffer(..)));
        assert_eq!(
            bound,
            Some(&Call::SetIndexBuffer(
                object.index_buffer().clone(),
                wgpu::IndexFormat::Uint32
            )),
            "the object's index buffer is bound when it draws"
        );
    }
}

/// Pixels where the images differ, as (x, y, a, b).
pub fn differences(
    a: &image::RgbaImage,
    b: &image::RgbaImage,
) -> Vec<(u32, u32, [u8; 4], [u8; 4])> {
    a.enumerate_pixels()
        .zip(b.pixels())
        .filter(|((_, _, pa), pb)| pa != pb)
        .map(|((x, y, pa), pb)| (x, y, pa.0, pb.0))
        .collect()
}

/// Saves both images beside the test binary's scratch directory and fails with the first
/// differences, so a failure can be looked at.
pub fn fail_with_images(what: &str, a: &image::RgbaImage, b: &image::RgbaImage) -> ! {
    let diffs = differences(a, b);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let stem: String = what
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let (pa, pb) = (
        dir.join(format!("{stem}_a.png")),
        dir.join(format!("{stem}_b.png")),
    );
    let saved = gpu::save_png(a, &pa).and(gpu::save_png(b, &pb));
    panic!(
        "{what}: {} pixels differ (first: {:?}); images {} and {} ({saved:?})",
        diffs.len(),
        &diffs[..diffs.len().min(8)],
        pa.display(),
        pb.display()
    );
}

/// The reference list drawn two ways, the same multiset of oriented triangles in the same
/// order: `raw` as `reference_mesh` gives it, and `rotated` with each triangle starting at the
/// vertex the strip draw starts it at (a reference triangle the strips lack keeps its own
/// rotation, so any disagreement still shows in the image).
///
/// Why rotation matters: the rasterizer interpolates every vertex output (world position,
/// normal, UV) from the triangle's first vertex, so `(a, b, c)` and `(b, c, a)` interpolate
/// with different rounding; the shader's derivative normal `cross(dpdy(p), dpdx(p))` amplifies
/// that into a ±1 step of an 8-bit channel on rare pixels. The test prints, per asset, how many pixels differ from the
/// strips with `raw` (a few, all ±1) and asserts none differ with `rotated`: rotation is the
/// whole difference; draw order (a tie in depth) is not needed to explain any pixel.
pub struct ReferenceLists {
    pub raw: Vec<u32>,
    pub rotated: Vec<u32>,
}

pub fn reference_lists(
    reference: &[[u32; 3]],
    state: &StripsState,
    strips: usize,
) -> ReferenceLists {
    // The triangles in the vertex order the GPU rasterizes them (`common::strip_draw`).
    let drawn: Vec<[u32; 3]> = (0..strips)
        .flat_map(|s| strip_draw(state.strip(s).unwrap_or_default()))
        .collect();
    // Canonical form -> the strip triangles of that form.
    let mut by_form: HashMap<[u32; 3], Vec<[u32; 3]>> = HashMap::new();
    for &t in &drawn {
        by_form.entry(canonical(t)).or_default().push(t);
    }
    let mut rotated = Vec::with_capacity(reference.len() * 3);
    for &t in reference {
        let as_drawn = by_form.get_mut(&canonical(t)).and_then(Vec::pop);
        rotated.extend(as_drawn.unwrap_or(t));
    }
    ReferenceLists {
        raw: reference.iter().flatten().copied().collect(),
        rotated,
    }
}
