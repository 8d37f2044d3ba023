//! `prepare`: the pages grown and the areas that moved copied, the index and record patches
//! (scattered on the GPU), the tail expansions, the instance blocks, the scene block and
//! textures.

use super::cull::Frustum;
use super::member::Arrival;
use super::patches::{each_word_once, keep_last_per_word, PatchRuns, Span};
use super::pipeline::{CrowdPipeline, InstanceBlock, PoseBlock};
use super::pool::Move;
use super::tail::TailJob;
use super::types::CrowdUpload;
use super::{Crowd, CrowdAsset, PageBinds};
use crate::gpu::scatter::{encode_runs, Dispatches, Scatter, RUN_GROUP};

/// Which buffer of a page a scatter patches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Patched {
    Indices,
    Records,
}

/// The runs of one page, each its first word and its values.
type Runs<'a> = Vec<(u32, &'a [u32])>;

impl Crowd {
    /// Uploads what changed since the last call: per asset its pages grown and the areas that
    /// moved copied on the GPU, the index patches `set` made (per page one write and one
    /// scatter dispatch, submitted here on `queue`), the changed records, the tail expansions
    /// and the changed instance blocks (one contiguous write); the scene block and textures.
    /// Call before submitting the pass that renders the crowd.
    pub fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> CrowdUpload {
        let mut dispatches = Dispatches::Own(None);
        let upload = self.upload(device, queue, &mut dispatches);
        dispatches.submit_own(queue);
        upload
    }

    /// [`prepare`](Self::prepare), with the scatter dispatches recorded into `encoder` instead
    /// of submitted on their own, so that the crowd's uploads and the frame's passes go in one
    /// submission (a frame whose patches pass one binding still submits its full lists here).
    /// Rules for the caller, as for egui-wgpu's `update_buffers`: record the pass that renders
    /// the crowd into `encoder` after this call, and submit `encoder` on `queue` before the
    /// crowd's next `prepare` or `prepare_with` (that call rewrites the patch lists the
    /// recorded dispatches read).
    pub fn prepare_with(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) -> CrowdUpload {
        self.upload(device, queue, &mut Dispatches::Caller(encoder))
    }

    /// Both `prepare`s: every write, and the copies and dispatches recorded in `dispatches`.
    fn upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        dispatches: &mut Dispatches,
    ) -> CrowdUpload {
        let mut upload = CrowdUpload::default();
        if std::mem::take(&mut self.white_pending) {
            queue.write_texture(
                self.white.0.as_image_copy(),
                &[255; 4],
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4),
                    rows_per_image: Some(1),
                },
                self.white.0.size(),
            );
        }
        if std::mem::take(&mut self.scene_dirty) {
            upload.write(
                queue,
                &self.scene_buffer,
                0,
                bytemuck::bytes_of(&self.scene),
            );
        }
        self.grow_instance_buffers(device, queue, &mut upload);
        let view_proj = glam::Mat4::from_cols_array_2d(&self.scene.view_proj);
        let frustum = self
            .culling
            .then(|| Frustum::new(view_proj, self.scene.clock));
        // A frame that moves many instances far (the first LOD frame of a crowd) can pass one
        // binding's or one dispatch's limit: then its patches go in lists of at most `chunk`
        // words, each full one submitted on its own (`scatter`). A word takes at most 8 bytes
        // of a run list, plus the headers' padding.
        let chunk = ((Scatter::max_run_list_bytes(device) / 8) as usize)
            .saturating_sub(RUN_GROUP as usize)
            .max(1);
        for a in &mut self.assets {
            let texture = a.gpu.upload(queue);
            upload.bytes += texture;
            upload.writes += usize::from(texture > 0);
            a.prepares += 1;
            // pageRuns: this frame's index patches as words of each page, less the withdrawn
            // ones; where an instance was patched by two `set`s, each word with its last value.
            let lists = std::mem::take(&mut a.waiting.index_runs);
            let merged = a.waiting.overlap.then(|| a.merged_runs(&lists));
            let pages: Vec<Runs> = match &merged {
                Some(merged) => (merged.iter())
                    .map(|page| page.iter().map(|(_, first, v)| (first, v)).collect())
                    .collect(),
                None => a.page_runs(&lists),
            };
            a.waiting.withdrawn.clear();
            a.waiting.overlap = false;
            let words = |runs: &Runs| runs.iter().map(|(_, v)| v.len()).sum::<usize>();
            upload.patches += pages.iter().map(|r| words(r) as u64).sum::<u64>();
            // growPages and arrive: the pages' buffers made or grown and the areas that moved
            // or were made for regions given their contents, before any patch lands on them;
            // submitted first where a page's patches go in several submissions.
            let chunked = pages.iter().any(|r| words(r) > chunk);
            let mut early = Dispatches::Own(None);
            {
                let target = if chunked {
                    &mut early
                } else {
                    &mut *dispatches
                };
                let encoder = target.encoder(device);
                upload.copies += a.pool.grow(device, encoder);
                upload.copies += a.arrive(device, encoder);
            }
            early.submit_own(queue);
            a.write_s0(queue, &mut upload);
            a.fit_binds();
            // scatterIndices: the scatter's invocations run in any order on a real GPU
            // (lavapipe runs them in order, NVIDIA does not), so a word may get only one value
            // a frame. Index patches name each word once by construction
            // (`SlotLayout::upload`; merged above where an instance was patched by two
            // `set`s); a record can change several times between two prepares (removed, then
            // added again), so its words keep their last value. Both checked in debug builds,
            // which the tests run on lavapipe.
            for (p, runs) in pages.iter().enumerate() {
                debug_assert!(
                    each_word_once(runs.iter().flat_map(|&(f, v)| f..f + v.len() as u32)),
                    "index words patched twice"
                );
                let page = (p, Patched::Indices);
                a.scatter(
                    device,
                    queue,
                    &self.pipeline,
                    page,
                    runs,
                    chunk,
                    dispatches,
                    &mut upload,
                );
            }
            // scatterRecords: after the moves' records, the culled instances' counts.
            a.cull(frustum.as_ref());
            for p in 0..a.pool.pages.len() {
                let mut patches = std::mem::take(&mut a.pool.pages[p].record_patches);
                keep_last_per_word(&mut patches);
                let runs = PatchRuns::of(&patches, &[(0, patches.len())]);
                let runs: Runs = runs.iter().map(|(_, first, v)| (first, v)).collect();
                let page = (p, Patched::Records);
                a.scatter(
                    device,
                    queue,
                    &self.pipeline,
                    page,
                    &runs,
                    chunk,
                    dispatches,
                    &mut upload,
                );
                patches.clear();
                a.pool.pages[p].record_patches = patches;
            }
            // expandTails: after the index scatter, which may have patched an area before its
            // instance moved into a tail list.
            a.expand_tails(device, queue, &self.pipeline, dispatches, &mut upload);
            // writeInstances: the changed placements in runs, the moved poses in one range.
            let (placements, poses) = a.instance_buffers.as_ref().expect("grown above");
            for range in a.dirty_blocks.take_runs() {
                let blocks = &a.blocks[range.start as usize..range.end as usize];
                let offset = u64::from(range.start) * size_of::<InstanceBlock>() as u64;
                upload.write(queue, placements, offset, bytemuck::cast_slice(blocks));
            }
            if let Some(range) = a.dirty_poses.take() {
                let blocks = &a.poses[range.start as usize..range.end as usize];
                let offset = u64::from(range.start) * size_of::<PoseBlock>() as u64;
                upload.write(queue, poses, offset, bytemuck::cast_slice(blocks));
            }
            // The areas freed since the last prepare were read by its copies at most: free.
            a.pool.release();
        }
        upload
    }

    /// Makes the instance buffers (placements and poses) that no longer hold their assets'
    /// instances anew (doubling), with every instance written (a copy of the old buffers
    /// would land after this frame's writes), and the bind groups over them.
    fn grow_instance_buffers(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        upload: &mut CrowdUpload,
    ) {
        let sizes = [size_of::<InstanceBlock>(), size_of::<PoseBlock>()].map(|s| s as u64);
        let binding = device.limits().max_storage_buffer_binding_size;
        for i in 0..self.assets.len() {
            let a = &self.assets[i];
            let count = a.blocks.len().max(1) as u64;
            let held = a
                .instance_buffers
                .as_ref()
                .map_or(0, |(b, _)| b.size() / sizes[0]);
            if held >= count {
                continue;
            }
            // Doubling, from 64 instances, within one binding (`add` keeps `count` there).
            let room = count
                .next_power_of_two()
                .max(64)
                .min(binding / sizes[0])
                .max(count);
            let [placements, poses] = [("crowd placements", sizes[0]), ("crowd poses", sizes[1])]
                .map(|(label, size)| {
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some(label),
                        size: room * size,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    })
                });
            let group =
                self.bind_group(device, (&a.gpu, a.variant), &a.mesh, (&placements, &poses));
            let a = &mut self.assets[i];
            upload.write(queue, &placements, 0, bytemuck::cast_slice(&a.blocks));
            upload.write(queue, &poses, 0, bytemuck::cast_slice(&a.poses));
            a.dirty_blocks.clear();
            a.dirty_poses = Span::EMPTY;
            a.instance_buffers = Some((placements, poses));
            a.bind_group = Some(group);
        }
    }
}

impl CrowdAsset {
    /// The runs of `lists` as words of each page (each run moved by its owner's area), less
    /// the runs of withdrawn slots.
    fn page_runs<'l>(&self, lists: &'l [PatchRuns]) -> Vec<Runs<'l>> {
        let mut pages: Vec<Runs> = vec![Vec::new(); self.pool.pages.len()];
        for (list, runs) in lists.iter().enumerate() {
            for (slot, first, values) in runs.iter() {
                if self.waiting.is_withdrawn(slot, list) {
                    continue;
                }
                let area = self.members[slot as usize]
                    .as_ref()
                    .and_then(|m| m.area)
                    .expect("a patched instance holds an area");
                debug_assert!(first + values.len() as u32 <= area.words, "past its area");
                pages[area.page as usize].push((area.offset + first, values));
            }
        }
        pages
    }

    /// [`page_runs`](Self::page_runs) with each word once, at its last value (an instance
    /// patched by two `set`s since the last prepare).
    fn merged_runs(&self, lists: &[PatchRuns]) -> Vec<PatchRuns> {
        (self.page_runs(lists).into_iter())
            .map(|runs| {
                let mut patches: Vec<[u32; 2]> = (runs.iter())
                    .flat_map(|&(first, values)| (first..).zip(values).map(|(w, &v)| [w, v]))
                    .collect();
                keep_last_per_word(&mut patches);
                PatchRuns::of(&patches, &[(0, patches.len())])
            })
            .collect()
    }

    /// Records the contents of the areas made since the last prepare that need them: a
    /// grown compact copy's kept words (copied from its old area) and new regions' restarts
    /// (copied from the template). Returns the copies recorded.
    fn arrive(&mut self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder) -> usize {
        let mut slots = std::mem::take(&mut self.arriving);
        slots.sort_unstable();
        slots.dedup();
        let mut moves = Vec::new();
        let mut fills = Vec::new();
        for &slot in &slots {
            let Some(member) = self.members[slot as usize].as_mut() else {
                continue;
            };
            // A slot emptied and given to a new instance since its move has nothing to
            // arrive: the new instance's arrival is its own (`Nothing` until it moves).
            let arrival = std::mem::replace(&mut member.arrival, Arrival::Nothing);
            if matches!(arrival, Arrival::Nothing) {
                continue;
            }
            let to = member.area.expect("an arrival comes with its area");
            match arrival {
                Arrival::Nothing => {}
                Arrival::Copy { from, words } => moves.push(Move { from, to, words }),
                Arrival::Restarts => fills.push(to),
            }
        }
        slots.clear();
        self.arriving = slots;
        self.pool.record_moves(device, encoder, &moves);
        let bytes = u64::from(self.layout.regions()) * 4;
        for to in &fills {
            let page = self.pool.pages[to.page as usize].indices.as_ref();
            let page = page.expect("grown before the fills");
            encoder.copy_buffer_to_buffer(&self.restarts, 0, page, u64::from(to.offset) * 4, bytes);
        }
        moves.len() + fills.len()
    }

    /// Writes the asset's shared `S0` into its area, once.
    fn write_s0(&mut self, queue: &wgpu::Queue, upload: &mut CrowdUpload) {
        if std::mem::replace(&mut self.s0_written, true) {
            return;
        }
        let page = self.pool.pages[self.s0.page as usize].indices.as_ref();
        let page = page.expect("grown before S0 is written");
        let s0 = bytemuck::cast_slice(self.layout.s0());
        upload.write(queue, page, u64::from(self.s0.offset) * 4, s0);
    }

    /// One [`PageBinds`] per page, those made for an older generation of its buffers emptied.
    fn fit_binds(&mut self) {
        let pages = &self.pool.pages;
        self.binds.resize_with(pages.len(), PageBinds::default);
        for (binds, page) in self.binds.iter_mut().zip(pages) {
            if binds.generation != page.generation {
                *binds = PageBinds {
                    generation: page.generation,
                    ..PageBinds::default()
                };
            }
        }
    }

    /// Writes the tail lists of the instances that moved in them since the last prepare and
    /// are still there (once each), into their areas: per page the jobs in one write, one
    /// dispatch of a workgroup per job recorded in `dispatches`.
    fn expand_tails(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let mut slots = std::mem::take(&mut self.waiting.tails);
        slots.sort_unstable();
        slots.dedup();
        let mut jobs: Vec<Vec<TailJob>> = vec![Vec::new(); self.pool.pages.len()];
        for &slot in &slots {
            let Some(member) = &mut self.members[slot as usize] else {
                continue;
            };
            if let (Some((k, l)), false) = (member.tail, member.expanded) {
                member.expanded = true;
                let area = member.area.expect("a tail member holds an area");
                let job = self.tails.job(k as usize, l as usize, area.offset);
                let job = job.expect("a tail member's LOD is in its frame's tail");
                jobs[area.page as usize].push(job);
            }
        }
        slots.clear();
        self.waiting.tails = slots;
        let Some(words) = &self.tail_words else {
            return;
        };
        for (p, mut jobs) in jobs.into_iter().enumerate() {
            let Some(&last) = jobs.last() else {
                continue;
            };
            upload.tail_jobs += jobs.len();
            // Workgroups in a rectangle of at most the device's per-dimension limit, the jobs
            // padded to fill it with the last one (the same writes again).
            let wide = device.limits().max_compute_workgroups_per_dimension as usize;
            let x = jobs.len().min(wide);
            let y = jobs.len().div_ceil(x);
            jobs.resize(x * y, last);
            let bytes = (jobs.len() * size_of::<TailJob>()) as u64;
            let binds = &mut self.binds[p];
            if binds
                .tail_jobs
                .as_ref()
                .is_none_or(|(b, _)| b.size() < bytes)
            {
                let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("crowd tail jobs"),
                    size: bytes.next_power_of_two(),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let page = self.pool.pages[p].indices.as_ref().expect("grown");
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("crowd tails"),
                    layout: &pipeline.tail_layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: buffer.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: words.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: page.as_entire_binding(),
                        },
                    ],
                });
                binds.tail_jobs = Some((buffer, group));
            }
            let (buffer, group) = binds.tail_jobs.as_ref().expect("made above");
            upload.write(queue, buffer, 0, bytemuck::cast_slice(&jobs));
            let mut pass =
                dispatches
                    .encoder(device)
                    .begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("crowd tails"),
                        timestamp_writes: None,
                    });
            pass.set_pipeline(&pipeline.tail);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(x as u32, y as u32, 1);
            upload.dispatches += 1;
        }
    }

    /// Applies this frame's patches of page `p`'s buffer `what` (`runs`): written to its
    /// patch buffer and scattered by one dispatch, recorded in `dispatches` (one submission
    /// for every asset, page and both kinds of patches: each has its own patch buffer). Runs
    /// of more than `chunk` words go in lists of `chunk` (runs cut where a list fills), each
    /// full one written and submitted in a command buffer of its own before the next reuses
    /// the buffer; the last goes with the frame's other dispatches.
    #[allow(clippy::too_many_arguments)]
    fn scatter(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        (p, what): (usize, Patched),
        runs: &Runs,
        chunk: usize,
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let page = (p, what);
        let words: usize = runs.iter().map(|(_, v)| v.len()).sum();
        if words <= chunk {
            let all = runs.iter().copied();
            self.dispatch_runs(device, queue, pipeline, page, all, dispatches, upload);
            return;
        }
        let mut list: Runs = Vec::new();
        let mut listed = 0;
        for &(first, values) in runs {
            let mut at = 0;
            while at < values.len() {
                let take = (chunk - listed).min(values.len() - at);
                list.push((first + at as u32, &values[at..at + take]));
                (at, listed) = (at + take, listed + take);
                if listed == chunk {
                    let full = list.iter().copied();
                    let mut own = Dispatches::Own(None);
                    self.dispatch_runs(device, queue, pipeline, page, full, &mut own, upload);
                    own.submit_own(queue);
                    list.clear();
                    listed = 0;
                }
            }
        }
        let rest = list.iter().copied();
        self.dispatch_runs(device, queue, pipeline, page, rest, dispatches, upload);
    }

    /// Encodes `runs` as one run list, writes it to page `p`'s patch buffer of `what` and
    /// records its dispatch in `dispatches`.
    #[allow(clippy::too_many_arguments)]
    fn dispatch_runs<'a>(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        (p, what): (usize, Patched),
        runs: impl Iterator<Item = (u32, &'a [u32])> + Clone,
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let headers = encode_runs(runs, &mut self.run_list);
        if headers == 0 {
            return;
        }
        let bytes = 4 * self.run_list.len() as u64;
        let page = &self.pool.pages[p];
        let (kind, target) = match what {
            Patched::Indices => (0, page.indices.as_ref()),
            Patched::Records => (1, page.indirect.as_ref()),
        };
        let target = target.expect("grown before the scatter");
        let patches = (pipeline.scatter).patch_buffer(
            device,
            &mut self.binds[p].patches[kind],
            "crowd patches",
            target,
            bytes,
        );
        upload.write(
            queue,
            &patches.buffer,
            0,
            bytemuck::cast_slice(&self.run_list),
        );
        pipeline
            .scatter
            .record(device, dispatches, patches, headers);
        upload.dispatches += 1;
    }
}
