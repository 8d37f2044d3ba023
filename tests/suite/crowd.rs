//! `gpu::Crowd` on a real adapter (lavapipe in CI), against `LodObject`s and the runtime. The
//! drawing tests run on both paths ([`paths`]): first instance (vertex buffers) where the device
//! has `INDIRECT_FIRST_INSTANCE`, and the base-vertex fallback (vertex pulling), forced.
//!
//! * `crowd_draws_the_pixels_of_lod_objects`: instances of four assets (two grids, the head's
//!   weight animation without a surface, the face's with its surface and texture; so every
//!   path draws with and without a surface, without and with the 8-slot sum) at mixed times, LODs, transforms and colours draw pixel
//!   for pixel what the same number of `LodObject`s draw (sharing one `GpuAsset` per asset),
//!   over frames with moves, removes and adds; the `Recorder` sees exactly one multi-draw per
//!   asset, of that asset's records, with its index buffer bound.
//! * `crowd_buffers_decode_to_each_instance_mesh`: over a walk with frame switches, LOD jumps,
//!   removes and adds (freed slots reused, old ids refused), the index and indirect buffers read
//!   back from the GPU draw, per live instance, exactly the triangles of its runtime's strips
//!   (the reference mesh of its frame and LOD, which tests/oracle_deform.rs checks), the records
//!   carry the slot where the path says, lie in its slot range, start and end at live
//!   indices, and free records draw nothing.
//!   Where a moved instance's live strips fit its compact area (`CrowdRecords`), its record
//!   reads their packed copy: the live indices and one restart between two strips, nothing else;
//!   records go from the compact copy back to the regions (patched only when read again).
//! * `crowd_records_read_only_live_indices`: the same walk with a compact area as large as the
//!   regions (every moved instance's record reads only its live indices and the restarts
//!   between strips) and without one (every record reads the regions).
//! * `patches_past_one_binding_go_in_chunks`: on a device whose storage bindings just hold the
//!   index buffer, frames whose patches need several scatter chunks (all recorded in one
//!   command buffer per prepare) still leave buffers that draw each instance's mesh.
//! * `index_patches_name_each_word_once`: over a random walk, a frame's index patches number
//!   exactly the distinct words the instances' dirty logs name (no word sent twice); where
//!   instances moved twice between two prepares, at most those of both moves.
//! * `instances_sharing_a_frame_draw_their_reference_meshes`: most of 40 instances switching
//!   to one `(frame, LOD)` together (rebuilt in runs of that frame, in several pieces of
//!   slots), one at another LOD of it, one at another frame, one left alone: each instance's
//!   buffers read back draw the reference mesh of its frame and LOD.
//! * `fewer_weight_slots_draw_the_pixels_of_the_8_slot_sum`: on both paths, for the head and
//!   for the face (without and with a surface): drawn by the entry point without the target
//!   sum (uploaded without targets) and by the 8-slot one at zero weights they give the same
//!   pixels; with the 4 targets of the largest weights (4-slot entry point) and with all
//!   targets but those zeroed (8-slot) they give the same pixels mid-animation (those targets
//!   exaggerated so that the sum moves pixels, checked); and both paths draw the same pixels
//!   there.
//! * `gpu_weight_blending_equals_the_cpu_sum`: the head's weight animation (8 targets) and the
//!   face's (10 driven targets, one active at a time), the positions the crowd's vertex stage
//!   blends (read back by the same WGSL function) equal the CPU sum `V(0) + Σ c_k(t) D_k` within
//!   the bound of [`blend_bound`]; with all 10 of the face's targets active, the sum of the 8
//!   largest weights, the 2 smallest dropped.
//! * `bad_input_is_refused_and_changes_nothing`: NaN transform or colour, NaN time in a batch,
//!   removed and unknown instances, a full asset, a model of another asset, an asset of another
//!   device, the first-instance path on a device without the feature: typed errors, and the
//!   buffers and states are as before.
//! * The host bytes a body instance holds are measured by a counting allocator in a binary of
//!   their own (tests/crowd_alloc.rs).
//! * `discrete_lods_draw_each_instance_level`: the bench's discrete-LOD renderer (levels of one
//!   shared sequence, one instanced draw per level): its index buffer read back holds each
//!   level's reference mesh (recomputed here from the sequence, at the first step within the
//!   level's fraction), and instances at mixed levels and times draw pixel for pixel what
//!   crowd instances at those levels' steps draw.
//! * `discrete_level_choice_is_monotone_in_distance`: by the same screen error, farther
//!   instances never get a finer level, each level is the coarsest within the bound.

use crate::common;

use std::sync::Arc;

use common::gpu::{draw_indexed_indirect, Call, Gpu, Recorder};
use common::strip_draw;

use morphlod::build::Sequences;
use morphlod::collapse::canonical_multiset;
use morphlod::gpu::{
    self, AssetId, Crowd, CrowdError, CrowdPath, CrowdRecords, DiscreteCrowd, DiscreteLevels,
    DrawnFrom, GpuAsset, GpuError, InstanceId, LodObject, RenderTarget,
};
use morphlod::simplify::PoseError;
use morphlod::{Asset, Builder, DeformingModel, DeformingState, Lod};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// A grid asset of `side²` vertices whose `V(1)` bulges by `height`, built with `frames` frames.
fn grid_asset(side: u32, frames: usize, height: f32) -> Asset {
    let morph = common::grid_morph(side, |x, y| {
        let (fx, fy) = (x as f32 / (side - 1) as f32, y as f32 / (side - 1) as f32);
        // Uneven heights so the simplifier's errors are not all tied.
        height * (3.0 * fx).sin() * (2.0 * fy + 0.3).sin() + 0.1 * (7.0 * fx * fy).sin()
    });
    Builder::new(&morph)
        .frames(frames)
        .build()
        .expect("grid asset builds")
        .0
}

/// A grid asset as [`grid_asset`] with one sequence shared by `poses` sampled poses (the
/// export's), so every level is one connectivity for every `t`.
fn shared_grid_asset(side: u32, poses: usize, height: f32) -> Asset {
    let morph = common::grid_morph(side, |x, y| {
        let (fx, fy) = (x as f32 / (side - 1) as f32, y as f32 / (side - 1) as f32);
        height * (3.0 * fx).sin() * (2.0 * fy + 0.3).sin() + 0.1 * (7.0 * fx * fy).sin()
    });
    let asset = Builder::new(&morph)
        .frames(poses)
        .sequences(Sequences::Shared(PoseError::Max))
        .build()
        .expect("grid asset builds")
        .0;
    assert_eq!(asset.frames.len(), 1, "a shared build has one frame");
    asset
}

/// makehuman_head's weight animation (8 targets, no surface), built with 3 frames.
fn head_asset() -> Asset {
    let asset = common::animated_asset("makehuman_head.glb", "morph", 3);
    assert!(asset.surface.is_none(), "the head is faceted");
    asset
}

/// makehuman_face's weight animation (52 targets with normal deltas, a textured surface),
/// built with 3 frames.
fn face_asset() -> Asset {
    let asset = common::animated_asset("makehuman_face.glb", "expressions", 3);
    assert!(asset.surface.is_some(), "the face has a surface");
    asset
}

/// One asset of a test crowd: its data, GPU upload and model.
struct Kind {
    asset: Asset,
    gpu: Arc<GpuAsset>,
    model: Arc<DeformingModel>,
}

impl Kind {
    fn new(ctx: &Gpu, asset: Asset) -> Result<Kind> {
        let gpu = GpuAsset::from_asset(ctx.device(), &asset)?;
        let model = Arc::new(DeformingModel::new(&asset)?);
        Ok(Kind { asset, gpu, model })
    }

    /// The asset's bounding box over both poses.
    fn bounds(&self) -> (glam::Vec3, glam::Vec3) {
        let both: Vec<[f32; 3]> = self
            .asset
            .v0
            .iter()
            .chain(&self.asset.v1)
            .copied()
            .collect();
        let (lo, hi) = morphlod::mesh::bounds(&both).expect("vertices");
        (lo.into(), hi.into())
    }

    /// A transform that fits the asset into a unit box centred at `at`, turned by `angle`.
    fn place(&self, at: glam::Vec3, angle: f32) -> glam::Mat4 {
        let (lo, hi) = self.bounds();
        let scale = 0.9 / (hi - lo).max_element();
        glam::Mat4::from_translation(at)
            * glam::Mat4::from_rotation_z(angle)
            * glam::Mat4::from_scale(glam::Vec3::splat(scale))
            * glam::Mat4::from_translation(-(lo + hi) * 0.5)
    }
}

/// The paths the drawing tests run on: first instance where the device has
/// `INDIRECT_FIRST_INSTANCE` (lavapipe does: under CI a device without it fails), and the
/// base-vertex fallback everywhere.
fn paths(ctx: &Gpu) -> Vec<CrowdPath> {
    let mut paths = vec![CrowdPath::BaseVertex];
    if ctx.ctx.first_instance_enabled() {
        paths.insert(0, CrowdPath::FirstInstance);
    } else {
        assert!(
            !morphlod::ci::is_ci(),
            "no INDIRECT_FIRST_INSTANCE under CI: the first-instance path must be tested"
        );
        eprintln!("no INDIRECT_FIRST_INSTANCE: the first-instance path is not tested");
    }
    paths
}

/// Adds `kind` to `crowd` with room for `count` instances and fills it at the identity.
fn fill(
    ctx: &Gpu,
    crowd: &mut Crowd,
    kind: &Kind,
    count: u32,
) -> Result<(AssetId, Vec<InstanceId>)> {
    let asset = crowd.add_asset(
        ctx.device(),
        Arc::clone(&kind.gpu),
        Arc::clone(&kind.model),
        count,
    )?;
    let ids = (0..count)
        .map(|_| crowd.add(asset, glam::Mat4::IDENTITY))
        .collect::<std::result::Result<_, _>>()?;
    Ok((asset, ids))
}

/// An empty crowd on `path` drawing into a `RenderTarget`.
fn crowd_on(ctx: &Gpu, path: CrowdPath) -> Result<Crowd> {
    let crowd = Crowd::with_path(
        ctx.device(),
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
        path,
    )?;
    assert_eq!(crowd.path(), path);
    Ok(crowd)
}

/// The images and draw calls of one pass over `draw`.
fn render(
    ctx: &Gpu,
    target: &RenderTarget,
    draw: impl FnOnce(&mut Recorder),
) -> (image::RgbaImage, Vec<Call>) {
    let encoder = ctx.device().create_command_encoder(&Default::default());
    render_in(ctx, target, encoder, draw)
}

/// [`render`] after what `encoder` holds already (the scatters of a `prepare_with`).
fn render_in(
    ctx: &Gpu,
    target: &RenderTarget,
    mut encoder: wgpu::CommandEncoder,
    draw: impl FnOnce(&mut Recorder),
) -> (image::RgbaImage, Vec<Call>) {
    let calls = {
        let mut pass = target.begin_pass(&mut encoder);
        let mut recorder = Recorder {
            pass: &mut pass,
            calls: Vec::new(),
        };
        draw(&mut recorder);
        recorder.calls
    };
    ctx.queue().submit([encoder.finish()]);
    let image = target
        .read_image(ctx.device(), ctx.queue())
        .expect("the image reads back");
    (image, calls)
}

/// Exactly one multi-draw per asset and page with records, each over that page's records
/// from offset 0, with the page's index buffer bound.
fn assert_one_multi_draw_per_asset(crowd: &Crowd, assets: &[AssetId], calls: &[Call]) {
    let drawn: Vec<(AssetId, usize)> = (assets.iter())
        .flat_map(|&a| (0..crowd.pages(a)).map(move |p| (a, p)))
        .filter(|&(a, p)| crowd.drawn_records(a, p) > 0)
        .collect();
    let draws: Vec<(usize, &Call)> = calls
        .iter()
        .enumerate()
        .filter(|(_, c)| matches!(c, Call::MultiDrawIndexedIndirect { .. }))
        .collect();
    assert_eq!(
        draws.len(),
        drawn.len(),
        "one multi-draw per asset and page: {calls:?}"
    );
    for (&(at, draw), &(asset, page)) in draws.iter().zip(&drawn) {
        let expected = Call::MultiDrawIndexedIndirect {
            indirect: crowd.indirect_buffer(asset, page).expect("page").clone(),
            offset: 0,
            count: crowd.drawn_records(asset, page),
        };
        assert_eq!(*draw, expected);
        let bound = calls[..at]
            .iter()
            .rev()
            .find(|c| matches!(c, Call::SetIndexBuffer(..)));
        assert_eq!(
            bound,
            Some(&Call::SetIndexBuffer(
                crowd.index_buffer(asset, page).expect("page").clone(),
                wgpu::IndexFormat::Uint32
            ))
        );
    }
}

/// One instance of the pixel test: which kind, where, and its state.
struct Placed {
    kind: usize,
    id: InstanceId,
    object: LodObject,
    t: f32,
    lod: f32,
}

#[test]
fn crowd_draws_the_pixels_of_lod_objects() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let kinds = [
        Kind::new(&ctx, grid_asset(12, 5, 0.4))?,
        Kind::new(&ctx, grid_asset(9, 3, -0.3))?,
        Kind::new(&ctx, head_asset())?,
        Kind::new(&ctx, face_asset())?,
    ];
    for path in paths(&ctx) {
        draws_the_pixels_of_lod_objects(&ctx, &kinds, path)?;
    }
    Ok(())
}

/// The camera of the pixel tests: a 3 x 3 field of unit cells around the origin, seen from the
/// front, z towards the camera.
fn field_view_proj() -> Result<glam::Mat4> {
    Ok(gpu::camera::fit_to_bounds(
        [-1.5, -1.5, -0.6],
        [1.5, 1.5, 0.6],
        glam::Vec3::new(0.05, -0.08, -1.0),
        1.0,
        gpu::camera::Projection::Perspective { vertical_fov: 0.9 },
    )?
    .view_proj())
}

fn draws_the_pixels_of_lod_objects(ctx: &Gpu, kinds: &[Kind], path: CrowdPath) -> Result<()> {
    let (device, queue) = (ctx.device(), ctx.queue());
    let mut crowd = crowd_on(ctx, path)?;
    let assets: Vec<AssetId> = kinds
        .iter()
        .map(|k| crowd.add_asset(device, Arc::clone(&k.gpu), Arc::clone(&k.model), 4))
        .collect::<std::result::Result<_, _>>()?;
    let view_proj = field_view_proj()?;
    crowd.set_view_proj(view_proj);
    let target = ctx.target(160, 160, wgpu::Color::BLUE);

    let cell = |i: usize| glam::Vec3::new((i % 3) as f32 - 1.0, (i / 3) as f32 - 1.0, 0.0);
    let add = |crowd: &mut Crowd, placed: &mut Vec<Placed>, kind: usize, at: usize| -> Result<()> {
        let k = &kinds[kind];
        let model = k.place(cell(at), 0.3 * at as f32);
        let id = crowd.add(assets[kind], model)?;
        let color = [0.3 + 0.08 * at as f32, 0.9 - 0.07 * at as f32, 0.5, 1.0];
        crowd.set_color(id, color)?;
        let mut object = LodObject::with_asset(
            device,
            &ctx.pipeline,
            Arc::clone(&k.gpu),
            Arc::clone(&k.model),
        )?;
        object.set_model(model);
        object.set_color(color);
        object.set_view_proj(view_proj);
        placed.push(Placed {
            kind,
            id,
            object,
            t: 0.0,
            lod: 0.0,
        });
        Ok(())
    };
    let mut placed = Vec::new();
    for (at, kind) in [0, 1, 2, 3, 1, 2, 0, 3].into_iter().enumerate() {
        add(&mut crowd, &mut placed, kind, at)?;
    }
    // Time and LOD per frame and instance; the head and the face stay at t = 0, where their
    // weights are 0 and the GPU sum equals the CPU's bit for bit
    // (gpu_weight_blending_equals_the_cpu_sum bounds it elsewhere).
    for frame in 0..5 {
        if frame == 2 {
            // Remove two, add one of another kind in the freed slot and one at a new cell.
            let gone = placed.remove(3);
            crowd.remove(gone.id)?;
            let gone = placed.remove(0);
            crowd.remove(gone.id)?;
            add(&mut crowd, &mut placed, 1, 0)?;
            add(&mut crowd, &mut placed, 0, 8)?;
        }
        // Odd frames prepare with `prepare_with`: the scatters go in the encoder of the pass.
        let with = frame % 2 == 1;
        let mut objects_pass = device.create_command_encoder(&Default::default());
        let mut crowd_pass = device.create_command_encoder(&Default::default());
        let mut moves = Vec::new();
        for (i, p) in placed.iter_mut().enumerate() {
            p.t = if p.kind >= 2 {
                0.0
            } else {
                ((frame * 3 + i) % 7) as f32 / 6.0
            };
            p.lod = ((frame * 5 + i * 3) % 9) as f32 / 8.0;
            p.object.set(p.t, Lod::Fraction(p.lod))?;
            if with {
                p.object.prepare_with(queue, &mut objects_pass);
            } else {
                p.object.prepare(queue);
            }
            moves.push((p.id, p.t, Lod::Fraction(p.lod)));
        }
        crowd.set(&moves)?;
        if with {
            crowd.prepare_with(device, queue, &mut crowd_pass);
        } else {
            crowd.prepare(device, queue);
        }
        let (expected, _) = render_in(ctx, &target, objects_pass, |pass| {
            for p in &placed {
                p.object.render(pass);
            }
        });
        let (image, calls) = render_in(ctx, &target, crowd_pass, |pass| crowd.render(pass));
        assert_one_multi_draw_per_asset(&crowd, &assets, &calls);
        for p in &placed {
            assert_eq!(crowd.at(p.id)?.triangles, p.object.state().triangle_count());
        }
        if image != expected {
            common::gpu::fail_with_images(
                &format!("crowd frame {frame}, {path:?}"),
                &image,
                &expected,
            );
        }
        let background = image.pixels().filter(|p| p.0 == [0, 0, 255, 255]).count();
        assert!(
            background < image.pixels().len() * 9 / 10,
            "frame {frame}, {path:?}: the instances cover too little of the image to compare"
        );
    }
    Ok(())
}

/// What one instance slot's record draws, from the buffers read back.
#[derive(Clone, Debug, Default)]
struct SlotDraw {
    /// The triangles, mapped back to the asset's vertex numbers.
    triangles: Vec<[u32; 3]>,
    /// Indices the record reads (0: it draws nothing, or it has none).
    read: u32,
    /// Its record as read back, with its page.
    record: Option<(usize, [u32; 5])>,
}

/// Every page's index and indirect buffers of `asset`, read back.
fn read_pages(ctx: &Gpu, crowd: &Crowd, asset: AssetId) -> Vec<(Vec<u32>, Vec<u32>)> {
    (0..crowd.pages(asset))
        .map(|p| {
            let indices = ctx.read_words(crowd.index_buffer(asset, p).expect("page"));
            let records = ctx.read_words(crowd.indirect_buffer(asset, p).expect("page"));
            (indices, records)
        })
        .collect()
}

/// Per slot (`slots` of them), what its record draws from the buffers read back, found by
/// the slot each record carries (in `first_instance` or `base_vertex`, where the path says;
/// each slot in one record at most); checks that each drawing record starts and ends at a
/// live index and that no two records of a page read the same words, but for those reading
/// the one shared `S0` (instances not moved yet), which read it whole.
fn drawn_per_slot(ctx: &Gpu, crowd: &Crowd, asset: AssetId, n: u32, slots: usize) -> Vec<SlotDraw> {
    let mut out = vec![SlotDraw::default(); slots];
    for (page, (indices, words)) in read_pages(ctx, crowd, asset).iter().enumerate() {
        let drawn = crowd.drawn_records(asset, page) as usize;
        assert!(
            words.len() >= drawn * 5,
            "page {page}: records past the buffer"
        );
        let mut spans: Vec<(u32, u32, usize)> = Vec::new();
        for r in 0..drawn {
            let w = &words[r * 5..r * 5 + 5];
            let record = [w[0], w[1], w[2], w[3], w[4]];
            if record == [0; 5] {
                continue;
            }
            let slot = match crowd.path() {
                CrowdPath::BaseVertex => {
                    assert_eq!(record[4], 0, "page {page}, record {r}: first_instance");
                    assert_eq!(record[3] % n, 0, "page {page}, record {r}: base_vertex");
                    record[3] / n
                }
                CrowdPath::FirstInstance => {
                    assert_eq!(record[3], 0, "page {page}, record {r}: base_vertex");
                    record[4]
                }
            } as usize;
            assert!(slot < slots, "page {page}, record {r}: slot {slot}");
            assert!(out[slot].record.is_none(), "slot {slot} in two records");
            let (count, first) = (record[0] * record[1].min(1), record[2]);
            if count > 0 {
                let read = &indices[first as usize..(first + count) as usize];
                assert!(
                    read[0] != gpu::RESTART && read[read.len() - 1] != gpu::RESTART,
                    "slot {slot}: a record starts or ends with a restart"
                );
                spans.push((first, first + count, slot));
            }
            let base = record[3];
            out[slot] = SlotDraw {
                triangles: draw_indexed_indirect(indices, &[record], n * slots as u32)
                    .into_iter()
                    .map(|t| t.map(|v| v - base))
                    .collect(),
                read: count,
                record: Some((page, record)),
            };
        }
        // Areas of one page are disjoint: only records reading the shared S0 meet.
        spans.sort_unstable();
        for pair in spans.windows(2) {
            let ((a0, a1, a), (b0, b1, b)) = (pair[0], pair[1]);
            assert!(
                a1 <= b0 || (a0, a1) == (b0, b1),
                "page {page}: slots {a} and {b} read overlapping words {a0}..{a1}, {b0}..{b1}"
            );
        }
    }
    out
}

#[test]
fn crowd_buffers_decode_to_each_instance_mesh() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let kinds = [
        Kind::new(&ctx, grid_asset(11, 6, 0.5))?,
        Kind::new(&ctx, grid_asset(8, 4, 0.2))?,
    ];
    let copies_only = CrowdRecords {
        tail_triangles: 0,
        ..CrowdRecords::default()
    };
    for path in paths(&ctx) {
        for records in [CrowdRecords::default(), copies_only] {
            buffers_decode_to_each_instance_mesh(&ctx, &kinds, path, records)?;
        }
    }
    Ok(())
}

/// The record of an instance whose live strips fit its compact area reads its compact copy:
/// the live strips, a restart between two and the restarts of the places strips left, at
/// most 1.5× the packed count: with a compact area as large as the regions every moved
/// instance's record does (a record that read the regions' restart tails reads more);
/// without one none does, and the regions still decode to each instance's mesh.
#[test]
fn crowd_records_read_only_live_indices() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let kinds = [
        Kind::new(&ctx, grid_asset(11, 6, 0.5))?,
        Kind::new(&ctx, grid_asset(8, 4, 0.2))?,
    ];
    let path = paths(&ctx)[0];
    for (compact_share, tail_triangles) in [(1.0, 0), (0.0, 256), (1.0, 256)] {
        let records = CrowdRecords {
            compact_share,
            tail_triangles,
        };
        buffers_decode_to_each_instance_mesh(&ctx, &kinds, path, records)?;
    }
    Ok(())
}

fn buffers_decode_to_each_instance_mesh(
    ctx: &Gpu,
    kinds: &[Kind],
    path: CrowdPath,
    records: CrowdRecords,
) -> Result<()> {
    let (device, queue) = (ctx.device(), ctx.queue());
    let mut crowd = crowd_on(ctx, path)?;
    crowd.set_records(records);
    let capacity = 5;
    let assets: Vec<AssetId> = kinds
        .iter()
        .map(|k| crowd.add_asset(device, Arc::clone(&k.gpu), Arc::clone(&k.model), capacity))
        .collect::<std::result::Result<_, _>>()?;
    let mut rng = common::Rng(0x5eed_c0de);
    let mut live: Vec<InstanceId> = Vec::new();
    let mut removed: Vec<InstanceId> = Vec::new();
    // Instances moved since they were added (the others still draw S0 from their regions).
    let mut moved: Vec<InstanceId> = Vec::new();
    // Instances whose record read the compact copy at the last check, and how many went back
    // to their regions after it (the regions are patched only when read again).
    let mut compact: Vec<InstanceId> = Vec::new();
    let mut returns = 0;
    // Instances drawn from their frame's tail list at the last check, and how many checks
    // found one there and one that had left it.
    let mut in_tail: Vec<InstanceId> = Vec::new();
    let (mut tail_draws, mut tail_exits) = (0, 0);
    let triangles: Vec<Vec<[u32; 3]>> = (kinds.iter())
        .map(|k| {
            (0..k.asset.s0.len())
                .filter_map(|i| k.asset.s0.strip(i))
                .flat_map(strip_draw)
                .collect()
        })
        .collect();
    for step in 0..40 {
        // Adds and removes: keep between 2 and all slots busy.
        if step % 4 == 0 || live.len() < 2 {
            let asset = assets[rng.below(2)];
            if live.iter().filter(|id| id.asset() == asset).count() < capacity as usize {
                let id = crowd.add(asset, glam::Mat4::IDENTITY)?;
                assert!(live.iter().all(|l| l != &id));
                live.push(id);
            }
        }
        if step % 5 == 3 && live.len() > 2 {
            let id = live.swap_remove(rng.below(live.len()));
            crowd.remove(id)?;
            removed.push(id);
            // The next add of this asset takes the freed slot (lowest free first).
            let again = crowd.add(id.asset(), glam::Mat4::IDENTITY)?;
            assert_eq!(again.slot(), id.slot(), "a freed slot is reused");
            assert_ne!(again, id, "with a new id");
            live.push(again);
        }
        // Moves, some instances twice, some not at all; frame switches on most; a third to
        // the last tenth of the LODs, where the tail lists are.
        let mut moves: Vec<(InstanceId, f32, Lod)> = Vec::new();
        for &id in &live {
            if rng.below(4) != 0 {
                let coarse = rng.below(3) == 0;
                let f = if coarse {
                    0.9 + 0.1 * rng.unit()
                } else {
                    rng.unit()
                };
                moves.push((id, rng.unit(), Lod::Fraction(f)));
            }
        }
        crowd.set(&moves)?;
        moved.extend(moves.iter().map(|&(id, _, _)| id));
        if step % 3 == 0 {
            let again: Vec<_> = moves
                .iter()
                .map(|&(id, t, _)| (id, 1.0 - t, Lod::Fraction(0.2)))
                .collect();
            crowd.set(&again)?;
        }
        // An instance removed after its move (its patches made, a new area taken where its
        // need changed, with the contents it waits for) and its slot taken at once by a new
        // instance, moved or not, before the prepare: none of the old patches, copies or
        // fills may land on the new instance's slots, and the new one has nothing to wait for.
        if step % 7 == 2 && live.len() > 2 {
            let at = (live.iter())
                .position(|id| moves.iter().any(|m| m.0 == *id))
                .unwrap_or_else(|| rng.below(live.len()));
            let id = live[at];
            crowd.remove(id)?;
            removed.push(id);
            let again = crowd.add(id.asset(), glam::Mat4::IDENTITY)?;
            assert_eq!(again.slot(), id.slot(), "a freed slot is reused");
            live[at] = again;
            if step % 2 == 0 {
                crowd.set(&[(again, rng.unit(), Lod::Fraction(rng.unit()))])?;
                moved.push(again);
            }
        }
        crowd.prepare(device, queue);
        for id in &removed {
            assert!(matches!(
                crowd.state(*id),
                Err(CrowdError::UnknownInstance(_))
            ));
        }
        for (k, &asset) in assets.iter().enumerate() {
            let n = kinds[k].gpu.vertex_count();
            let drawn = drawn_per_slot(ctx, &crowd, asset, n, capacity as usize);
            let mut busy = vec![false; capacity as usize];
            for id in live.iter().filter(|id| id.asset() == asset) {
                busy[id.slot() as usize] = true;
                let slot = &drawn[id.slot() as usize];
                let at = crowd.at(*id)?;
                let from_tail = at.from == DrawnFrom::Tail;
                let was_in_tail = in_tail.contains(id);
                in_tail.retain(|c| c != id);
                // Its area holds what it draws, and not much more: at most three times what
                // it needs (but 1.5 times and 32 words), 4 words a triangle in a tail, the
                // copy's packed count (at most what its record reads), the regions close up,
                // none before its first move.
                let most = |need: u32| (3 * need).max(need + need / 2 + 32).next_multiple_of(16);
                let most = match at.from {
                    DrawnFrom::S0 => 0,
                    DrawnFrom::Tail => most(4 * at.triangles as u32),
                    DrawnFrom::Copy => most(slot.read),
                    DrawnFrom::Regions => u32::MAX,
                };
                assert!(
                    at.words <= most && (at.from == DrawnFrom::S0) == (at.words == 0),
                    "{records:?}, step {step}, {id:?}: {at:?} holds more than it draws"
                );
                let Some(state) = crowd.state(*id)? else {
                    // Not moved yet (the shared S0), or from its frame's tail list: the
                    // reference mesh of its frame and LOD (the DESIGN's oracle), there one
                    // triangle and a restart each, in its area.
                    assert!(from_tail || !moved.contains(id));
                    assert!(!from_tail || records.tail_triangles > 0);
                    let reference =
                        kinds[k].asset.frames[at.frame].reference_mesh(&triangles[k], at.lod);
                    let why = format!("{records:?}, step {step}, {id:?}: {at:?}");
                    assert_eq!(
                        canonical_multiset(slot.triangles.iter().copied()),
                        canonical_multiset(reference.iter().copied()),
                        "{why}"
                    );
                    assert_eq!(at.triangles, reference.len(), "{why}");
                    if !from_tail {
                        assert_eq!((at.frame, at.lod), (0, 0), "{why}");
                        assert_eq!(at.from, DrawnFrom::S0, "{why}");
                        continue;
                    }
                    assert!(at.triangles <= records.tail_triangles as usize, "{why}");
                    assert!(slot.read + 1 == 4 * at.triangles as u32 || at.triangles == 0);
                    in_tail.push(*id);
                    tail_draws += 1;
                    continue;
                };
                tail_exits += usize::from(was_in_tail);
                let mut expected: Vec<[u32; 3]> = (0..state.lengths().len())
                    .flat_map(|s| strip_draw(state.strip(s).unwrap_or_default()))
                    .collect();
                // In any order (a compact copy keeps moved strips at its end), each triangle
                // as drawn (its winding).
                let mut got = slot.triangles.clone();
                got.sort_unstable();
                expected.sort_unstable();
                assert_eq!(got, expected, "{path:?}, step {step}, {id:?}");
                assert_eq!(expected.len(), state.triangle_count());
                // Where the live strips fit the compact share, the record reads their copy:
                // them and one restart between two (CrowdRecords).
                let indices: u32 = state.lengths().iter().sum();
                let strips = state.lengths().iter().filter(|&&len| len > 0).count() as u32;
                let packed = indices + strips.saturating_sub(1);
                let fits = packed > 0 && packed <= crowd.compact_slots(asset);
                let why = format!(
                    "{records:?}, step {step}, {id:?}: {indices} live indices, {strips} strips, record reads {}",
                    slot.read
                );
                let was_compact = compact.contains(id);
                compact.retain(|c| c != id);
                let copy = at.from == DrawnFrom::Copy;
                if copy {
                    compact.push(*id);
                } else if was_compact {
                    returns += 1;
                }
                if fits && moved.contains(id) {
                    assert!(copy, "{why}");
                    // Strips keep their places: a few restarts more, at most 1.5× packed.
                    assert!(slot.read >= packed && slot.read <= packed * 3 / 2, "{why}");
                } else {
                    assert!(!copy || packed == 0, "{why}");
                    assert!(slot.read >= packed, "{why}");
                }
                if records.compact_share >= 1.0 && moved.contains(id) {
                    assert!(fits || packed == 0, "{why}");
                }
            }
            for (slot, drawn) in drawn.iter().enumerate() {
                if !busy[slot] {
                    assert_eq!(drawn.read, 0, "step {step}: free slot {slot} draws");
                }
            }
        }
    }
    if records.compact_share > 0.0 && records.compact_share < 1.0 && records.tail_triangles == 0 {
        assert!(
            returns > 0,
            "no record went from the compact copy back to the regions"
        );
    }
    // The default's tail lists hold the grids' last few LODs: instances go in and out.
    if records == CrowdRecords::default() {
        assert!(
            tail_draws > 10 && tail_exits > 2,
            "{tail_draws} tail draws, {tail_exits} exits"
        );
    }
    if records.tail_triangles == 0 {
        assert_eq!(tail_draws, 0);
    }
    Ok(())
}

/// A frame whose patches pass what one scatter may bind goes in chunks, each written to the
/// patch buffer after the previous chunk's dispatch was submitted (a chunk that reused the
/// buffer before that submission would overwrite the previous chunk's patches). On a device
/// whose storage bindings hold the regions of two instances, the index memory takes several
/// pages (records move with their instances' areas to other pages), and without a compact
/// share, instances jumping between full detail and their coarsest LOD (most region words
/// patched) need several chunks; after every prepare the buffers read back draw each
/// instance's mesh, with `prepare` and with `prepare_with` (the last chunk in the caller's
/// encoder).
#[test]
fn patches_past_one_binding_go_in_chunks() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let asset = grid_asset(11, 6, 0.5);
    let capacity = 5;
    let regions_only = CrowdRecords {
        compact_share: 0.0,
        tail_triangles: 0,
    };
    // The regions: S0 and one separator per strip.
    let regions = {
        let model = DeformingModel::new(&asset)?;
        (model.layout().s0().len() + model.layout().strip_count()) as u64
    };
    // Storage bindings of two instances' regions (rounded up to 256 bytes), no more.
    let binding = (2 * regions * 4 + 64).next_multiple_of(256);
    let small = small_device(&ctx, binding)?;
    let kind = Kind::new(&small, asset)?;
    let n = kind.gpu.vertex_count();
    let (device, queue) = (small.device(), small.queue());
    for path in paths(&small) {
        let mut crowd = crowd_on(&small, path)?;
        crowd.set_records(regions_only);
        let (id, instances) = fill(&small, &mut crowd, &kind, capacity)?;
        // Most dispatches of one frame, by `prepare` and by `prepare_with`, and most pages.
        let (mut most, mut pages) = ([0; 2], 0);
        for step in 0..8 {
            // The coarsest LOD at one frame, full detail, the coarsest at another frame...
            let (t, lod) = match step % 2 {
                0 => (step as f32 / 8.0, Lod::Fraction(1.0)),
                _ => (0.0, Lod::Steps(0)),
            };
            let moves: Vec<_> = instances.iter().map(|&i| (i, t, lod)).collect();
            crowd.set(&moves)?;
            let with = step / 2 % 2;
            let upload = if with == 1 {
                let mut encoder = device.create_command_encoder(&Default::default());
                let upload = crowd.prepare_with(device, queue, &mut encoder);
                queue.submit([encoder.finish()]);
                upload
            } else {
                crowd.prepare(device, queue)
            };
            most[with] = most[with].max(upload.dispatches);
            pages = pages.max(crowd.pages(id));
            let drawn = drawn_per_slot(&small, &crowd, id, n, capacity as usize);
            for &i in &instances {
                let state = crowd
                    .state(i)?
                    .expect("no tail lists without a compact share");
                let expected: Vec<[u32; 3]> = (0..state.lengths().len())
                    .flat_map(|s| strip_draw(state.strip(s).unwrap_or_default()))
                    .collect();
                assert_eq!(
                    drawn[i.slot() as usize].triangles,
                    expected,
                    "{path:?}, step {step}, prepare_with {with}, {i:?}"
                );
            }
        }
        // One dispatch for the records, more than one for the index patches.
        assert!(
            most[0] > 2 && most[1] > 2,
            "{path:?}: no frame needed more than one chunk: {most:?} dispatches at most"
        );
        assert!(
            pages >= 3,
            "{path:?}: {pages} pages for 5 instances' regions and S0"
        );
    }
    Ok(())
}

/// A second device of `ctx`'s adapter whose storage bindings hold at most `binding` bytes.
fn small_device(ctx: &Gpu, binding: u64) -> Result<Gpu> {
    let adapter = ctx.ctx.adapter.clone();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: adapter.features() & gpu::Context::FEATURES,
        required_limits: wgpu::Limits {
            max_storage_buffer_binding_size: binding,
            ..adapter.limits()
        },
        ..Default::default()
    }))?;
    let pipeline = gpu::MorphPipeline::new(
        &device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    Ok(Gpu {
        ctx: gpu::Context {
            instance: ctx.ctx.instance.clone(),
            adapter,
            device,
            queue,
        },
        pipeline,
    })
}

/// Each index word a `prepare` patches is named once: over a random walk (frame switches, LOD
/// jumps) the frame's index patches number exactly the distinct words the instances' dirty
/// logs name: per strip the dirty range within its live length and every position between
/// its uploaded and its live length (every live position at an instance's first move, into
/// new regions that hold restarts), counted here from a copy of each instance's runtime
/// moved the same way. Where every instance moved twice between two prepares (patches are
/// made by each `set`), at most the words of both moves, and at least one. Without a compact
/// share, so the region patches are all a frame sends. (A dirty range and a strip's growth
/// overlap: before, the words in both were sent twice.)
#[test]
fn index_patches_name_each_word_once() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (ctx.device(), ctx.queue());
    let kind = Kind::new(&ctx, grid_asset(11, 6, 0.5))?;
    for path in paths(&ctx) {
        let mut crowd = crowd_on(&ctx, path)?;
        crowd.set_records(CrowdRecords {
            compact_share: 0.0,
            tail_triangles: 0,
        });
        let count = 4;
        let (_, ids) = fill(&ctx, &mut crowd, &kind, count)?;
        // Each instance's copy and the lengths its regions hold on the GPU (none before its
        // first move: it draws the shared S0).
        let mut copies: Vec<(DeformingState, Option<Vec<u32>>)> = ids
            .iter()
            .map(|_| (DeformingState::new(&kind.model), None))
            .collect();
        crowd.prepare(device, queue);
        let mut rng = common::Rng(0xd_1571_11c7);
        let (mut patches, mut overlapping) = (0, 0);
        for step in 0..30 {
            let rounds = 1 + usize::from(step % 3 == 0);
            let mut words = 0;
            for round in 0..rounds {
                let mut moves: Vec<(InstanceId, f32, Lod)> = Vec::new();
                for &id in &ids {
                    if round == 1 || rng.below(4) != 0 {
                        moves.push((id, rng.unit(), Lod::Fraction(rng.unit())));
                    }
                }
                crowd.set(&moves)?;
                for &(id, t, lod) in &moves {
                    copies[id.slot() as usize].0.set(&kind.model, t, lod)?;
                }
                for (&id, (state, uploaded)) in ids.iter().zip(&mut copies) {
                    // No tail lists without a compact area: no runtime only before a first move.
                    match crowd.state(id)? {
                        Some(crowd_state) => {
                            assert_eq!(
                                state.indices(),
                                crowd_state.indices(),
                                "{path:?}, step {step}"
                            )
                        }
                        None => assert_eq!(
                            (state.frame(), state.lod()),
                            (0, 0),
                            "{path:?}, step {step}"
                        ),
                    }
                    let dirty = state.take_dirty();
                    let lengths = state.lengths();
                    let mut named = std::collections::BTreeSet::new();
                    let Some(regions) = uploaded.as_mut() else {
                        if crowd.state(id)?.is_some() {
                            // Its first move: every live word, into regions of restarts.
                            for (strip, &len) in (0u32..).zip(lengths) {
                                named.extend((0..len).map(|i| (strip, i)));
                            }
                            *uploaded = Some(lengths.to_vec());
                            words += named.len() as u64;
                        }
                        continue;
                    };
                    for range in &dirty.ranges {
                        let live = lengths[range.strip as usize];
                        named.extend((range.start..range.end.min(live)).map(|i| (range.strip, i)));
                    }
                    for &strip in &dirty.lengths {
                        let (old, new) = (regions[strip as usize], lengths[strip as usize]);
                        let grown = (old.min(new)..old.max(new)).map(|i| (strip, i));
                        overlapping += grown.clone().filter(|w| named.contains(w)).count();
                        named.extend(grown);
                        regions[strip as usize] = new;
                    }
                    words += named.len() as u64;
                }
            }
            let upload = crowd.prepare(device, queue);
            if rounds == 1 {
                assert_eq!(
                    upload.patches, words,
                    "{path:?}, step {step}: index patches against words"
                );
            } else {
                assert!(
                    upload.patches <= words && (words == 0 || upload.patches > 0),
                    "{path:?}, step {step}: {} index patches against {words} words of both moves",
                    upload.patches
                );
            }
            patches += words;
        }
        // The walk does overlap ranges and growths, so the count can tell.
        assert!(
            overlapping > 0,
            "{path:?}: {patches} words patched, none overlapping"
        );
    }
    Ok(())
}

/// A crowd's frame switches are rebuilt in runs of one frame sharing its survivors, in
/// ascending LOD: over a walk where most instances move together to one `(frame, LOD)` each
/// step (many rebuilds of one frame at one LOD), one moves to the same frame at another LOD
/// (finer or coarser than the herd, so a run meets both orders), one to another frame, and one
/// stays, the buffers read back draw, per instance, exactly the reference mesh of its frame
/// and LOD (computed here from the frame's sequence, not from the runtime).
#[test]
fn instances_sharing_a_frame_draw_their_reference_meshes() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (ctx.device(), ctx.queue());
    let frames = 6;
    let kind = Kind::new(&ctx, grid_asset(12, frames, 0.5))?;
    let s0 = &kind.asset.s0;
    let triangles: Vec<[u32; 3]> = (0..s0.len())
        .filter_map(|i| s0.strip(i))
        .flat_map(strip_draw)
        .collect();
    for path in paths(&ctx) {
        let mut crowd = crowd_on(&ctx, path)?;
        // Enough instances for several pieces of `set`'s parallel pass (at least 16 slots each)
        // and several runs of one frame's rebuilds.
        let count = 40;
        let (asset, ids) = fill(&ctx, &mut crowd, &kind, count)?;
        let mut rng = common::Rng(0xc0ffee);
        let frame_t = |k: usize| k as f32 / (frames - 1) as f32;
        for step in 0..24 {
            let k = (step + rng.below(2)) % frames;
            let herd = Lod::Fraction(0.2 + 0.6 * rng.unit());
            let other_lod = Lod::Fraction(if step % 2 == 0 { 0.05 } else { 0.95 });
            let mut moves: Vec<(InstanceId, f32, Lod)> = Vec::new();
            for (i, &id) in ids.iter().enumerate() {
                match i {
                    0 => moves.push((id, frame_t(k), other_lod)),
                    1 => moves.push((id, frame_t((k + 3) % frames), herd)),
                    2 if step % 3 != 0 => {}
                    _ => moves.push((id, frame_t(k), herd)),
                }
            }
            crowd.set(&moves)?;
            crowd.prepare(device, queue);
            let drawn = drawn_per_slot(&ctx, &crowd, asset, kind.gpu.vertex_count(), ids.len());
            for &id in &ids {
                let at = crowd.at(id)?;
                let (frame, lod) = (at.frame, at.lod);
                let reference = kind.asset.frames[frame].reference_mesh(&triangles, lod);
                assert_eq!(
                    canonical_multiset(drawn[id.slot() as usize].triangles.iter().copied()),
                    canonical_multiset(reference),
                    "{path:?}, step {step}, {id:?} at frame {frame}, LOD {lod}"
                );
            }
            // Every moved instance is where it was asked to be.
            for &(id, t, lod) in &moves {
                let at = crowd.at(id)?;
                let frame = kind.model.frame_at(t)?;
                assert_eq!(at.frame, frame, "{path:?}, step {step}, {id:?}");
                assert_eq!(
                    at.lod,
                    kind.model.resolve(frame, lod)?,
                    "{path:?}, step {step}, {id:?}"
                );
            }
        }
    }
    Ok(())
}

/// Three versions of a head at time `t`, its 4 largest weights' targets there exaggerated 16
/// times (its expressions move it by less than a pixel of the test image): `four` has only
/// those 4 targets, `zeroed` all with the others zeroed (at `t` its 8-slot sum holds those 4
/// among its 8 largest weights and adds the same nonzero terms in the same order as the
/// 4-slot sum of `four`), `still` all zeroed.
fn head_versions(head: &Asset, t: f32) -> [Asset; 3] {
    let blend = head.blend.as_ref().expect("targets");
    let mut weights = Vec::new();
    blend.track.offsets_at(t, &mut weights);
    let mut keep: Vec<usize> = (0..blend.deltas.len()).collect();
    // As the weight slots pick them: largest magnitude first, lower target first on ties.
    keep.sort_by(|&a, &b| {
        weights[b]
            .abs()
            .total_cmp(&weights[a].abs())
            .then(a.cmp(&b))
    });
    keep.truncate(4);
    // (Fewer than 4 may move at t: a zero weight takes no slot in either sum.)
    assert!(weights[keep[0]] != 0.0, "a target moves at t");
    keep.sort_unstable();
    let mut zeroed = head.clone();
    let mut still = head.clone();
    for (asset, scale) in [(&mut zeroed, 16.0f32), (&mut still, 0.0)] {
        let kept = |k: usize| if keep.contains(&k) { scale } else { 0.0 };
        let deltas = asset.blend.iter_mut().flat_map(|b| b.deltas.iter_mut());
        for (k, target) in deltas.enumerate() {
            let scale = kept(k);
            target.iter_mut().flatten().for_each(|c| *c *= scale);
        }
        // Normal deltas kept as they are, zeroed with their targets.
        let normals = asset
            .surface
            .iter_mut()
            .flat_map(|s| s.normal_deltas.iter_mut());
        for (k, target) in normals.enumerate() {
            let scale = kept(k).min(1.0);
            target.iter_mut().flatten().for_each(|c| *c *= scale);
        }
    }
    let mut four = zeroed.clone();
    if let Some(blend) = four.blend.as_mut() {
        blend.deltas = keep.iter().map(|&k| blend.deltas[k].clone()).collect();
        blend.track = blend.track.select(&keep);
    }
    if let Some(surface) = four
        .surface
        .as_mut()
        .filter(|s| !s.normal_deltas.is_empty())
    {
        let normals = keep.iter().map(|&k| surface.normal_deltas[k].clone());
        surface.normal_deltas = normals.collect();
    }
    [four, zeroed, still]
}

#[test]
fn fewer_weight_slots_draw_the_pixels_of_the_8_slot_sum() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    // The head without a surface (the _plain entry points), the face with one (_surface).
    for asset in [head_asset(), face_asset()] {
        fewer_slots_draw_the_pixels_of_8(&ctx, Kind::new(&ctx, asset)?)?;
    }
    Ok(())
}

fn fewer_slots_draw_the_pixels_of_8(ctx: &Gpu, head: Kind) -> Result<()> {
    let (device, queue) = (ctx.device(), ctx.queue());
    assert!(head.gpu.target_count() >= 8);
    // The same poses and surface without the targets: drawn without the sum.
    let poses = (head.asset.v0.as_slice(), head.asset.v1.as_slice());
    let plain = Arc::new(GpuAsset::new(device, poses, head.asset.surface.as_ref())?);
    let t = 0.45;
    let [four, zeroed, still] = head_versions(&head.asset, t);
    let four = GpuAsset::from_asset(device, &four)?;
    let zeroed = GpuAsset::from_asset(device, &zeroed)?;
    let still = GpuAsset::from_asset(device, &still)?;
    assert_eq!(four.target_count(), 4);
    let view_proj = gpu::camera::fit_to_bounds(
        [-0.8, -0.8, -0.5],
        [0.8, 0.8, 0.5],
        glam::Vec3::new(0.05, -0.08, -1.0),
        1.0,
        gpu::camera::Projection::Perspective { vertical_fov: 0.9 },
    )?
    .view_proj();
    let target = ctx.target(128, 128, wgpu::Color::BLUE);
    // Four heads at mixed LODs and angles, one per quadrant, all at time `t`: the image and
    // the entry point that drew it.
    let draw = |path: CrowdPath, gpu: &Arc<GpuAsset>, t: f32| -> Result<_> {
        let mut crowd = crowd_on(ctx, path)?;
        let asset = crowd.add_asset(device, Arc::clone(gpu), Arc::clone(&head.model), 4)?;
        crowd.set_view_proj(view_proj);
        let mut moves = Vec::new();
        for i in 0..4 {
            let at = glam::Vec3::new(
                if i % 2 == 0 { -0.45 } else { 0.45 },
                if i < 2 { -0.45 } else { 0.45 },
                0.0,
            );
            let id = crowd.add(asset, head.place(at, 0.4 * i as f32))?;
            moves.push((id, t, Lod::Fraction(i as f32 / 4.0)));
        }
        crowd.set(&moves)?;
        crowd.prepare(device, queue);
        let (image, _) = render(ctx, &target, |pass| crowd.render(pass));
        Ok((image, crowd.vertex_entry_point(asset).expect("asset")))
    };
    let same = |what: &str,
                (image, entry): (image::RgbaImage, &str),
                (expected, by): (image::RgbaImage, &str)| {
        assert_ne!(entry, by, "{what}: two entry points");
        if image != expected {
            common::gpu::fail_with_images(
                &format!("{what}: {entry} against {by}"),
                &image,
                &expected,
            );
        }
        image
    };
    let mut moving = Vec::new();
    for path in paths(ctx) {
        // At t = 0 the head's weights are all 0: the 8-slot sum adds exact zeros.
        let rest = same(
            "t = 0",
            draw(path, &plain, 0.0)?,
            draw(path, &head.gpu, 0.0)?,
        );
        let background = rest.pixels().filter(|p| p.0 == [0, 0, 255, 255]).count();
        assert!(
            background < rest.pixels().len() * 9 / 10,
            "the heads cover too little"
        );
        let mid = same("t = 0.45", draw(path, &four, t)?, draw(path, &zeroed, t)?);
        let (unmoved, _) = draw(path, &still, t)?;
        assert_ne!(mid, unmoved, "{path:?}: the 4 targets changed no pixel");
        moving.push(draw(path, &zeroed, t)?);
    }
    // At nonzero weights the two paths' 8-slot sums (same terms, same order) draw the same
    // pixels.
    if let [first, base] = moving.as_slice() {
        if first.0 != base.0 {
            common::gpu::fail_with_images("t = 0.45, both paths", &first.0, &base.0);
        }
    }
    Ok(())
}

/// The bound of the GPU weight sum against the CPU's, per coordinate: the CPU adds the
/// products left to right in target order, the shader in the same order; a driver may fuse a
/// multiply and an add (one rounding fewer), so each of the 8 additions and the blend with the
/// pose may round differently once: `10 ε (|p| + Σ_k |c_k D_k|)`.
fn blend_bound(pose: f32, magnitude: f32) -> f32 {
    10.0 * f32::EPSILON * (pose.abs() + magnitude)
}

/// The weights the crowd blends, written from its contract, not its code: every nonzero
/// weight when at most [`gpu::WEIGHT_SLOTS`] are, else the `WEIGHT_SLOTS` of largest magnitude
/// (the lower target first on ties); the others are dropped (0 here).
fn kept_weights(weights: &[f32]) -> Vec<f32> {
    let mut active: Vec<usize> = (0..weights.len()).filter(|&k| weights[k] != 0.0).collect();
    active.sort_by(|&a, &b| {
        weights[b]
            .abs()
            .total_cmp(&weights[a].abs())
            .then(a.cmp(&b))
    });
    let mut kept = vec![0.0; weights.len()];
    for &k in active.iter().take(gpu::WEIGHT_SLOTS) {
        kept[k] = weights[k];
    }
    kept
}

/// What [`check_blending`] saw over its times.
#[derive(Default)]
struct Blended {
    /// Most targets with a nonzero weight at one time.
    most_active: usize,
    /// Largest distance of the drawn position from `V(0)` (the animation moved).
    moved: f32,
    /// Largest distance of the drawn position from the sum over every target (what the
    /// dropped weights would have added).
    dropped: f32,
}

/// Three instances of `kind` at the times of each row of `times` (LOD 0.3): every coordinate
/// the crowd's vertex stage blends (read back through the same WGSL function) equals the CPU
/// sum `V(0) + Σ c_k(t) D_k` over the [`kept_weights`], in target order, within
/// [`blend_bound`].
fn check_blending(ctx: &Gpu, kind: &Kind, times: &[[f32; 3]]) -> Result<Blended> {
    let (device, queue) = (ctx.device(), ctx.queue());
    let blend = kind.asset.blend.as_ref().expect("targets");
    let mut crowd = Crowd::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    let (_, ids) = fill(ctx, &mut crowd, kind, 3)?;
    let mut seen = Blended::default();
    for &ts in times {
        let moves: Vec<_> = ids
            .iter()
            .zip(ts)
            .map(|(&id, t)| (id, t, Lod::Fraction(0.3)))
            .collect();
        crowd.set(&moves)?;
        crowd.prepare(device, queue);
        for (&id, t) in ids.iter().zip(ts) {
            let gpu = crowd.blended_positions(device, queue, id)?;
            let mut weights = Vec::new();
            blend.track.offsets_at(t, &mut weights);
            let kept = kept_weights(&weights);
            seen.most_active = seen
                .most_active
                .max(weights.iter().filter(|&&w| w != 0.0).count());
            for (v, p) in gpu.iter().enumerate() {
                for (c, &drawn) in p.iter().enumerate() {
                    let (mut sum, mut magnitude, mut full) = (0.0f32, 0.0f32, 0.0f32);
                    for (k, (&w, &kept)) in weights.iter().zip(&kept).enumerate() {
                        full += w * blend.deltas[k][v][c];
                        if kept != 0.0 {
                            sum += kept * blend.deltas[k][v][c];
                            magnitude += (kept * blend.deltas[k][v][c]).abs();
                        }
                    }
                    let pose = kind.asset.v0[v][c];
                    let cpu = pose + sum;
                    seen.moved = seen.moved.max((drawn - pose).abs());
                    seen.dropped = seen.dropped.max((drawn - (pose + full)).abs());
                    let bound = blend_bound(pose, magnitude);
                    assert!(
                        (drawn - cpu).abs() <= bound,
                        "t {t}, vertex {v}, axis {c}: GPU {drawn} CPU {cpu} (bound {bound})"
                    );
                }
            }
        }
    }
    Ok(seen)
}

/// Times of three instances over a whole animation: `rows` rows, the instances a third apart.
fn times_over_the_animation(rows: usize) -> Vec<[f32; 3]> {
    (0..rows)
        .map(|r| {
            let t = r as f32 / rows as f32;
            [t, (t + 1.0 / 3.0).fract(), (t + 2.0 / 3.0).fract()]
        })
        .collect()
}

#[test]
fn gpu_weight_blending_equals_the_cpu_sum() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    // The head: 8 targets, each with a slot: the whole sum, exact.
    let head = Kind::new(&ctx, head_asset())?;
    assert_eq!(head.asset.blend.as_ref().expect("targets").deltas.len(), 8);
    let seen = check_blending(&ctx, &head, &times_over_the_animation(8))?;
    assert!(
        seen.moved > 1e-3,
        "the animation moved the head by only {}",
        seen.moved
    );

    // The face of face_to_face: 52 targets, of which its `expressions` animation drives 10
    // (the asset keeps those), one at a time: at most one nonzero weight at any t, so every
    // target the animation uses has a slot and the sum is the whole sum here too.
    let mut face = face_asset();
    let targets = face.blend.as_ref().expect("targets").deltas.len();
    assert_eq!(
        targets, 10,
        "the face's animation drives 10 of its 52 targets"
    );
    let kind = Kind::new(&ctx, face.clone())?;
    // 20 expressions over the loop: 40 rows put each instance on every rise and fall.
    let seen = check_blending(&ctx, &kind, &times_over_the_animation(40))?;
    assert!(seen.most_active >= 1 && seen.most_active <= gpu::WEIGHT_SLOTS);
    assert!(
        seen.moved > 1e-3,
        "the animation moved the face by only {}",
        seen.moved
    );

    // The same face with all 10 targets active at once (a track made for the test, weights
    // 0.1 … 1.0 with alternating signs at its end): the crowd keeps the 8 largest, drops the
    // two smallest (0.1 and -0.2), and draws exactly the sum of the 8 it kept.
    let last: Vec<f32> = (0..targets)
        .map(|k| (k + 1) as f32 * 0.1 * if k % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let values: Vec<f32> = std::iter::repeat_n(0.0, targets).chain(last).collect();
    face.blend.as_mut().expect("targets").track = morphlod::morph::WeightTrack::new(
        morphlod::morph::Interpolation::Linear,
        vec![0.0, 1.0],
        values,
        targets,
    )?;
    let all_on = Kind::new(&ctx, face)?;
    let seen = check_blending(&ctx, &all_on, &[[1.0, 0.5, 0.25]])?;
    assert_eq!(seen.most_active, targets);
    assert!(
        seen.dropped > 1e-4,
        "the two dropped weights changed nothing ({}): the test does not see them",
        seen.dropped
    );
    Ok(())
}

#[test]
fn bad_input_is_refused_and_changes_nothing() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (ctx.device(), ctx.queue());
    let kind = Kind::new(&ctx, grid_asset(8, 3, 0.3))?;
    let other = Kind::new(&ctx, grid_asset(6, 2, 0.3))?;
    let mut crowd = Crowd::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    let asset = crowd.add_asset(device, Arc::clone(&kind.gpu), Arc::clone(&kind.model), 2)?;
    let a = crowd.add(asset, glam::Mat4::IDENTITY)?;
    let b = crowd.add(asset, glam::Mat4::IDENTITY)?;
    crowd.set(&[(a, 0.5, Lod::Fraction(0.5)), (b, 1.0, Lod::Fraction(0.2))])?;
    crowd.prepare(device, queue);
    // What each slot draws (where its area lies may change: b's slot is taken again below).
    let n = kind.gpu.vertex_count();
    let snapshot = |crowd: &Crowd| {
        (
            (drawn_per_slot(&ctx, crowd, asset, n, 2).into_iter())
                .map(|d| canonical_multiset(d.triangles))
                .collect::<Vec<_>>(),
            crowd.pages(asset),
            crowd.at(a).map(|at| (at.frame, at.lod)).ok(),
            crowd.at(b).map(|at| (at.frame, at.lod)).ok(),
            crowd.stats(),
        )
    };
    let before = snapshot(&crowd);

    let nan = glam::Mat4::from_translation(glam::Vec3::new(f32::NAN, 0.0, 0.0));
    assert!(matches!(
        crowd.add(asset, nan),
        Err(CrowdError::NonFinite { .. })
    ));
    assert!(matches!(
        crowd.set_transform(a, nan),
        Err(CrowdError::NonFinite { .. })
    ));
    assert!(matches!(
        crowd.set_color(a, [0.0, f32::INFINITY, 0.0, 1.0]),
        Err(CrowdError::NonFinite { .. })
    ));
    assert!(matches!(
        crowd.set_velocity(a, glam::Vec3::new(0.0, f32::NAN, 0.0)),
        Err(CrowdError::NonFinite { .. })
    ));
    assert!(matches!(
        crowd.set_clock(f32::NEG_INFINITY),
        Err(CrowdError::NonFinite { .. })
    ));
    // No capacity wall: a third instance past the room reserved is added (and removed).
    let c = crowd.add(asset, glam::Mat4::IDENTITY)?;
    crowd.remove(c)?;
    // A batch with one NaN time moves nobody, not even the instances before it.
    let error = crowd.set(&[
        (a, 0.0, Lod::Fraction(1.0)),
        (b, f32::NAN, Lod::Fraction(0.0)),
    ]);
    assert!(matches!(error, Err(CrowdError::Set(_))), "{error:?}");
    let error = crowd.set(&[(a, 0.0, Lod::Fraction(f32::NAN))]);
    assert!(matches!(error, Err(CrowdError::Set(_))), "{error:?}");
    // A removed instance, then the one that reuses its slot: the old id stays refused.
    crowd.remove(b)?;
    let b2 = crowd.add(asset, glam::Mat4::IDENTITY)?;
    crowd.remove(b2)?;
    let b3 = crowd.add(asset, glam::Mat4::IDENTITY)?;
    crowd.set(&[(b3, 1.0, Lod::Fraction(0.2))])?;
    for gone in [b, b2] {
        assert!(matches!(
            crowd.remove(gone),
            Err(CrowdError::UnknownInstance(_))
        ));
        assert!(matches!(
            crowd.set(&[
                (a, 0.0, Lod::Fraction(1.0)),
                (gone, 0.0, Lod::Fraction(0.0))
            ]),
            Err(CrowdError::UnknownInstance(_))
        ));
        assert!(matches!(
            crowd.set_color(gone, [1.0; 4]),
            Err(CrowdError::UnknownInstance(_))
        ));
    }
    // Assets: a model of another asset, an asset of another device.
    let mismatch = crowd.add_asset(device, Arc::clone(&kind.gpu), Arc::clone(&other.model), 1);
    assert!(
        matches!(mismatch, Err(CrowdError::ModelMismatch { .. })),
        "{mismatch:?}"
    );
    // A second device of the same adapter (wgpu tells devices apart within one instance).
    let (second, _) = pollster::block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: ctx.adapter.limits(),
        ..Default::default()
    }))?;
    // Without INDIRECT_FIRST_INSTANCE (the second device asked for no feature) a crowd takes
    // the base-vertex path, and refuses the first-instance one.
    let formats = (RenderTarget::COLOR_FORMAT, Some(RenderTarget::DEPTH_FORMAT));
    assert_eq!(
        Crowd::new(&second, formats.0, formats.1).path(),
        CrowdPath::BaseVertex
    );
    let refused = Crowd::with_path(&second, formats.0, formats.1, CrowdPath::FirstInstance);
    assert!(matches!(refused, Err(CrowdError::NoFirstInstance)));
    let foreign = GpuAsset::from_asset(&second, &kind.asset)?;
    let error = crowd.add_asset(device, foreign, Arc::clone(&kind.model), 1);
    assert!(
        matches!(error, Err(CrowdError::Gpu(GpuError::OtherDevice))),
        "{error:?}"
    );
    crowd.prepare(device, queue);
    let after = snapshot(&crowd);
    assert_eq!(before.0, after.0, "each instance draws what it drew");
    assert_eq!(before.1, after.1, "pages unchanged");
    assert_eq!(before.2, after.2, "instance a unchanged");
    assert_eq!(before.3, crowd.at(b3).map(|at| (at.frame, at.lod)).ok());
    assert_eq!(before.4, after.4);
    Ok(())
}

/// The bench's library entry runs both modes on the same instances: full detail draws every
/// instance's `S0`, the LOD mode no more, and both report their uploads.
#[test]
fn crowd_bench_reports_both_modes() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let asset = grid_asset(10, 4, 0.4);
    let model = Arc::new(DeformingModel::new(&asset)?);
    let options = gpu::CrowdBenchOptions {
        instances: 9,
        frames: 4,
        period: 6,
        width: 96,
        height: 64,
        pixels: 4.0,
        ..Default::default()
    };
    let report = gpu::run_crowd_bench(&ctx.ctx, &asset, Arc::clone(&model), &options)?;
    let modes: Vec<&str> = report.modes.iter().map(|m| m.mode).collect();
    assert_eq!(modes, ["lod", "full"]);
    let full_detail = 9.0 * model.layout().triangle_count() as f64;
    assert_eq!(report.modes[1].triangles.mean, full_detail);
    // Each LOD frame draws what each instance should: at its phase's time and its distance's
    // screen error, the triangles of its frame at the LOD that resolves to (the grid's camera
    // sees every instance), recomputed here from the bench's definition.
    let both: Vec<[f32; 3]> = asset.v0.iter().chain(&asset.v1).copied().collect();
    let (lo, hi) = morphlod::mesh::bounds(&both).expect("vertices");
    let bounds = (glam::Vec3::from(lo), glam::Vec3::from(hi));
    let scene = gpu::CrowdBenchScene::new(gpu::CrowdScene::Grid, 9, bounds, 96.0 / 64.0)?;
    for (j, frame) in report.modes[0].frames.iter().enumerate() {
        let f = gpu::CROWD_BENCH_WARM_FRAMES + j;
        let (_, eye) = scene.camera(f);
        let mut expected = 0;
        for (i, centre) in scene.centres().iter().enumerate() {
            let phase = (i as f32 * 0.618_034).fract();
            let t = (f as f32 / 6.0 + phase).fract();
            let distance = (*centre - eye).length();
            let lod = Lod::screen_error(4.0, distance, scene.fov(), 64.0);
            let k = model.frame_at(t)?;
            let l = model.resolve(k, lod)?;
            expected += model.frame_changes(k).expect("frame").triangles_at(l);
        }
        assert_eq!(frame.triangles, expected as f64, "frame {f}");
    }
    assert!(report.modes[0].triangles.mean < full_detail);
    assert!(report.modes.iter().all(|m| m.uploaded_bytes.mean > 0.0));
    assert!(report.gpu_bytes_per_instance > 0.0 && report.host_bytes_per_instance > 0.0);
    let json: serde_json::Value = serde_json::from_str(&report.to_json())?;
    assert_eq!(json["modes"][1]["mode"], "full");
    // GPU time from timestamps where the device has them, said in the report.
    let features = ctx.device().features();
    let timing = if !features.contains(wgpu::Features::TIMESTAMP_QUERY) {
        "submit + wait"
    } else if features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS) {
        "timestamps (compute + render passes)"
    } else {
        "timestamps (render pass)"
    };
    assert_eq!(json["gpu_timing"], timing);
    // The frame's GPU time holds its render pass (both from timestamps, where there are any),
    // and, where the encoder's start is timed, the LOD mode's compute passes before it.
    if timing.starts_with("timestamps") {
        for m in &report.modes {
            let (gpu, pass) = (m.gpu_ms.mean, m.pass_ms.mean);
            assert!(pass > 0.0 && gpu >= pass, "{m:?}");
        }
    }
    if timing.contains("compute") {
        let lod = &report.modes[0];
        assert!(lod.gpu_ms.mean > lod.pass_ms.mean, "{lod:?}");
    }
    assert!(report.modes.iter().all(|m| m.wait_ms.mean > 0.0));
    let path = ["BaseVertex", "FirstInstance"][usize::from(ctx.ctx.first_instance_enabled())];
    assert!(report.path.starts_with(path), "{}", report.path);
    Ok(())
}

/// Levels at the export's fractions of a shared grid, and the sequence's own reference meshes
/// at the first step within each fraction (every step of a surface-free asset is a boundary).
#[test]
fn discrete_lods_draw_each_instance_level() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (ctx.device(), ctx.queue());
    let kind = Kind::new(&ctx, shared_grid_asset(12, 3, 0.4))?;
    let fractions = [0.5, 0.25, 0.1];
    let levels = DiscreteLevels::from_asset(&kind.asset, &fractions)?;
    let sequence = &kind.asset.frames[0];
    let triangles = kind.asset.s0.triangles();
    let count = |l: usize| sequence.reference_mesh(&triangles, l).len();
    assert_eq!(levels.levels().len(), 4);
    assert_eq!(levels.levels()[0].step, 0);
    for (level, f) in levels.levels()[1..].iter().zip(fractions) {
        let goal = (f64::from(f) * triangles.len() as f64).floor() as usize;
        assert!(count(level.step) <= goal && count(level.step - 1) > goal);
    }

    // Nine instances on a 3 x 3 field, levels and times mixed.
    let place = |i: usize| {
        kind.place(
            glam::Vec3::new((i % 3) as f32 - 1.0, (i / 3) as f32 - 1.0, 0.0),
            0.4 * i as f32,
        )
    };
    let transforms: Vec<glam::Mat4> = (0..9).map(place).collect();
    let mut discrete = DiscreteCrowd::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
        Arc::clone(&kind.gpu),
        levels.clone(),
        &transforms,
    )?;
    let mut crowd = Crowd::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    let asset = crowd.add_asset(device, Arc::clone(&kind.gpu), Arc::clone(&kind.model), 9)?;
    let ids: Vec<InstanceId> = transforms
        .iter()
        .map(|&m| crowd.add(asset, m))
        .collect::<std::result::Result<_, _>>()?;
    let view_proj = field_view_proj()?;
    crowd.set_view_proj(view_proj);
    discrete.set_view_proj(view_proj);
    let target = ctx.target(160, 160, wgpu::Color::BLUE);

    // The index buffer holds each level's reference mesh.
    let indices = ctx.read_words(discrete.index_buffer());
    for (l, range) in discrete.level_ranges().iter().enumerate() {
        let drawn: Vec<[u32; 3]> = indices[range.start as usize..range.end as usize]
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        let step = levels.levels()[l].step;
        assert_eq!(
            canonical_multiset(drawn),
            canonical_multiset(sequence.reference_mesh(&triangles, step)),
            "level {l}"
        );
    }

    for frame in 0..3 {
        let mut moves = Vec::new();
        let mut discrete_moves = Vec::new();
        for (i, &id) in ids.iter().enumerate() {
            let level = (i + frame) % 4;
            let t = ((i * 2 + frame) % 5) as f32 / 4.0;
            let lod = Lod::Steps(levels.levels()[level].step);
            moves.push((id, t, lod));
            discrete_moves.push((t, lod));
        }
        crowd.set(&moves)?;
        discrete.set(&discrete_moves)?;
        // All in view (the discrete crowd culls as a crowd does).
        let expected: Vec<Option<usize>> = (0..9).map(|i| Some((i + frame) % 4)).collect();
        assert_eq!(discrete.instance_levels(), expected);
        assert_eq!(discrete.triangles(), crowd.stats().triangles);
        assert_eq!(discrete.draws(), 4);
        crowd.prepare(device, queue);
        discrete.prepare(device, queue);
        let (reference, _) = render(&ctx, &target, |pass| crowd.render(pass));
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = target.begin_pass(&mut encoder);
            discrete.render(&mut pass);
        }
        queue.submit([encoder.finish()]);
        let image = target.read_image(device, queue)?;
        if image != reference {
            common::gpu::fail_with_images(&format!("discrete frame {frame}"), &image, &reference);
        }
        let background = image.pixels().filter(|p| p.0 == [0, 0, 255, 255]).count();
        assert!(background < image.pixels().len() * 9 / 10);
    }
    Ok(())
}

/// By one screen error, a farther instance never gets a finer level; each is the coarsest
/// level within the bound the runtime computes (`Lod::screen_error`), as the crowd's LOD mode.
#[test]
fn discrete_level_choice_is_monotone_in_distance() -> Result<()> {
    let asset = shared_grid_asset(10, 2, 0.3);
    let levels = DiscreteLevels::from_asset(&asset, &DiscreteLevels::FRACTIONS)?;
    let errors: Vec<f32> = levels.levels().iter().map(|l| l.error).collect();
    assert!(errors.windows(2).all(|w| w[0] <= w[1]) && errors[0] == 0.0);
    let mut last = 0;
    let mut seen = Vec::new();
    for i in 0..400 {
        let distance = 0.01 * 1.04f32.powi(i);
        let lod = Lod::screen_error(1.0, distance, 0.8, 1080.0);
        let Lod::MaxError(bound) = lod else {
            unreachable!("screen_error is a MaxError")
        };
        let level = levels.level_for(lod)?;
        assert!(
            level >= last,
            "distance {distance}: level {level} after {last}"
        );
        assert!(errors[level] <= bound);
        if let Some(&next) = errors.get(level + 1) {
            assert!(
                next > bound,
                "level {level} is not the coarsest within {bound}"
            );
        }
        last = level;
        seen.push(level);
    }
    seen.dedup();
    assert_eq!(seen.first(), Some(&0));
    assert_eq!(seen.last(), Some(&(levels.levels().len() - 1)));
    assert!(levels.level_for(Lod::MaxError(f32::NAN)).is_err());
    // Per-frame sequences have no one connectivity: refused with a typed error.
    let per_frame = grid_asset(10, 3, 0.3);
    assert!(matches!(
        DiscreteLevels::from_asset(&per_frame, &DiscreteLevels::FRACTIONS),
        Err(gpu::LevelsError::NotShared { .. })
    ));
    Ok(())
}

/// The bench runs discrete LODs on the same instances, and leaves out full detail when asked.
#[test]
fn crowd_bench_runs_discrete_lods() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let asset = shared_grid_asset(10, 2, 0.4);
    let model = Arc::new(DeformingModel::new(&asset)?);
    let levels = DiscreteLevels::from_asset(&asset, &DiscreteLevels::FRACTIONS)?;
    let options = gpu::CrowdBenchOptions {
        instances: 9,
        frames: 3,
        period: 6,
        width: 96,
        height: 64,
        pixels: 4.0,
        full_detail: false,
        discrete: Some(gpu::DiscreteOptions {
            sequence: gpu::SharedSequence::from_asset(&asset)?,
            levels: gpu::DiscreteChoice::Fractions(DiscreteLevels::FRACTIONS.to_vec()),
        }),
        ..Default::default()
    };
    let report = gpu::run_crowd_bench(&ctx.ctx, &asset, model, &options)?;
    let modes: Vec<&str> = report.modes.iter().map(|m| m.mode).collect();
    assert_eq!(modes, ["lod", "discrete"]);
    let discrete = &report.modes[1];
    assert_eq!(discrete.frames.len(), 3);
    assert_eq!(discrete.frame_switches.mean, 0.0);
    assert!(discrete.uploaded_bytes.mean > 0.0 && discrete.draws.mean >= 1.0);
    // The triangles drawn are the levels' counts times the instances at each.
    assert_eq!(report.levels.len(), levels.levels().len());
    let instances: f64 = report.levels.iter().map(|l| l.instances).sum();
    assert_eq!(instances, 9.0);
    let triangles: f64 = report
        .levels
        .iter()
        .map(|l| l.instances * l.triangles as f64)
        .sum();
    assert_eq!(discrete.triangles.mean, triangles);
    let json: serde_json::Value = serde_json::from_str(&report.to_json())?;
    assert_eq!(json["modes"][1]["mode"], "discrete");
    assert_eq!(json["levels"].as_array().map(Vec::len), Some(4));
    Ok(())
}

/// The walk-through: with discrete levels chosen by error (each half the next's error, down to
/// what the nearest instance needs), both modes draw at most the asked screen error at every
/// instance in view (the bench measures it from `DeformingModel::error_at` and the levels'
/// errors), both cull the same instances (the same sphere test), and the LOD mode draws fewer
/// triangles than the discrete levels.
#[test]
fn walk_through_bench_draws_within_its_error() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let asset = shared_grid_asset(10, 2, 0.4);
    let model = Arc::new(DeformingModel::new(&asset)?);
    let options = gpu::CrowdBenchOptions {
        instances: 64,
        scene: gpu::CrowdScene::WalkThrough,
        frames: 3,
        period: 30,
        width: 128,
        height: 96,
        pixels: 1.0,
        full_detail: false,
        discrete: Some(gpu::DiscreteOptions {
            sequence: gpu::SharedSequence::from_asset(&asset)?,
            levels: gpu::DiscreteChoice::ByError,
        }),
        ..Default::default()
    };
    let report = gpu::run_crowd_bench(&ctx.ctx, &asset, model, &options)?;
    let [lod, discrete] = &report.modes[..] else {
        panic!("two modes: {:?}", report.modes);
    };
    for m in [lod, discrete] {
        assert!(
            m.max_error_px <= 1.0 + 1e-4,
            "{}: {}",
            m.mode,
            m.max_error_px
        );
        assert!(m.error_px.mean > 0.0, "{}: nothing drawn coarse", m.mode);
    }
    assert!(lod.culled.mean > 0.0 && lod.culled.mean < 64.0, "{lod:?}");
    assert_eq!(lod.culled.mean, discrete.culled.mean);
    assert!(lod.triangles.mean < discrete.triangles.mean);
    // Levels by error: full detail, then each at most half the next one's error.
    let errors: Vec<f32> = report.levels.iter().map(|l| l.error).collect();
    assert!(errors.len() >= 3 && errors[0] == 0.0, "{errors:?}");
    assert!(errors.windows(2).all(|w| w[0] < w[1]), "{errors:?}");
    Ok(())
}

/// Culling (on by default): a record draws nothing on the GPU (instance count 0) only where
/// its instance lies out of view, every instance with a blended vertex in the clip volume
/// draws, and the image is the one drawn with culling off; views that pan across a row of
/// instances of two assets (one with 8 weighted targets) cull some, bring them back and
/// restore every record as it was.
#[test]
fn culling_skips_only_instances_out_of_view() -> Result<()> {
    let Some(ctx) = Gpu::new() else {
        return Ok(());
    };
    let (device, queue) = (ctx.device(), ctx.queue());
    let kinds = [
        Kind::new(&ctx, grid_asset(9, 3, 0.4))?,
        Kind::new(&ctx, head_asset())?,
    ];
    let target = RenderTarget::new(device, 64, 48, wgpu::Color::BLUE)?;
    for path in paths(&ctx) {
        let mut crowd = crowd_on(&ctx, path)?;
        // Two rows of unit boxes along x, from -6 to 6, 0.24 apart at depths in -0.5..0.5, so
        // that some lie across each side of every view, and a view sees about half of them.
        let row = 51;
        let mut placed = Vec::new();
        for (k, kind) in kinds.iter().enumerate() {
            let asset =
                crowd.add_asset(device, Arc::clone(&kind.gpu), Arc::clone(&kind.model), row)?;
            for i in 0..row {
                let depth = (0.618 * (i + 7 * k as u32) as f32).fract() - 0.5;
                let at = glam::Vec3::new(0.24 * i as f32 - 6.0, 1.2 * k as f32 - 0.6, depth);
                let model = kind.place(at, 0.2 * i as f32);
                placed.push((asset, crowd.add(asset, model)?, model));
            }
        }
        let row = row as usize;
        for (view, pan) in [0.0f32, 4.5, -3.0, 0.0].into_iter().enumerate() {
            // A view of x in about pan - 2 .. pan + 2.
            let view_proj = gpu::camera::fit_to_bounds(
                [pan - 2.0, -1.0, -0.6],
                [pan + 2.0, 1.0, 0.6],
                -glam::Vec3::Z,
                64.0 / 48.0,
                gpu::camera::Projection::Perspective { vertical_fov: 0.8 },
            )?
            .view_proj();
            crowd.set_view_proj(view_proj);
            let moves: Vec<(InstanceId, f32, Lod)> = (placed.iter().enumerate())
                .map(|(i, &(_, id, _))| {
                    (id, (0.37 * (i + view) as f32).fract(), Lod::Fraction(0.4))
                })
                .collect();
            crowd.set(&moves)?;
            let mut images = Vec::new();
            let mut words = Vec::new();
            for culling in [true, false] {
                crowd.set_culling(culling);
                crowd.prepare(device, queue);
                images.push(render(&ctx, &target, |pass| crowd.render(pass)).0);
                // Each instance's record, found by the slot it carries.
                let drawn: Vec<Vec<SlotDraw>> = (kinds.iter().enumerate())
                    .map(|(k, kind)| {
                        let n = kind.gpu.vertex_count();
                        drawn_per_slot(&ctx, &crowd, placed[k * row].0, n, row)
                    })
                    .collect();
                let records: Vec<[u32; 5]> = (placed.iter().enumerate())
                    .map(|(i, &(_, id, _))| {
                        drawn[i / row][id.slot() as usize]
                            .record
                            .expect("a record")
                            .1
                    })
                    .collect();
                if culling {
                    assert_eq!(
                        crowd.stats().culled,
                        records.iter().filter(|r| r[1] == 0).count(),
                        "{path:?}, view {view}: the stats count the zeroed records"
                    );
                }
                words.push(records);
            }
            assert!(
                images[0] == images[1],
                "{path:?}, view {view}: culling changed the image"
            );
            let mut culled = 0;
            let mut edge = 0;
            for (i, &(_, id, model)) in placed.iter().enumerate() {
                let (on, off) = (&words[0][i], &words[1][i]);
                assert_eq!(
                    off[1], 1,
                    "{path:?}, view {view}, instance {i}: drawn without culling"
                );
                // Only the instance count differs, and only to 0.
                for w in [0, 2, 3, 4] {
                    assert_eq!(on[w], off[w], "{path:?}, view {view}, instance {i}");
                }
                let blended = crowd.blended_positions(device, queue, id)?;
                let inside = |p: &[f32; 3]| {
                    let clip = view_proj * model * glam::Vec3::from(*p).extend(1.0);
                    clip.x.abs() <= clip.w
                        && clip.y.abs() <= clip.w
                        && (0.0..=clip.w).contains(&clip.z)
                };
                let seen = blended.iter().filter(|p| inside(p)).count();
                edge += usize::from(seen > 0 && seen < blended.len());
                // Out of view at `set`, an instance is parked at its frame's coarsest LOD; in
                // view it is at the LOD asked.
                let kind = &kinds[i / row];
                let at = crowd.at(id)?;
                let asked = if on[1] == 1 { 0.4 } else { 1.0 };
                let lod = kind.model.resolve(at.frame, Lod::Fraction(asked))?;
                assert_eq!(at.lod, lod, "{path:?}, view {view}, instance {i}: {at:?}");
                if on[1] == 1 {
                    continue;
                }
                culled += 1;
                // The oracle: no vertex of what it draws is in the clip volume.
                assert_eq!(
                    seen, 0,
                    "{path:?}, view {view}: instance {i} culled with a vertex in view"
                );
            }
            // Instances across the view's sides: where a test that is not conservative fails.
            assert!(
                edge >= 4,
                "{path:?}, view {view}: {edge} instances across the sides"
            );
            assert!(
                (10..placed.len() - 10).contains(&culled),
                "{path:?}, view {view}: {culled} of {} culled",
                placed.len()
            );
            // On again: the next view's prepare starts from every record drawn.
            crowd.set_culling(true);
        }
    }
    Ok(())
}
