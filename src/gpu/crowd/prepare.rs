//! `prepare`: the new instances' `S0`, the index and record patches (scattered on the GPU),
//! the tail expansions, the instance blocks, the scene block and textures.

use super::cull::Frustum;
use super::patches::{each_word_once, keep_last_per_word, PatchRuns};
use super::pipeline::{CrowdPipeline, InstanceBlock};
use super::tail::TailJob;
use super::types::CrowdUpload;
use super::{Crowd, CrowdAsset};
use crate::gpu::scatter::{encode_runs, Dispatches, Scatter, RUN_GROUP};

/// Which buffer of an asset a scatter patches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Patched {
    Indices,
    Records,
}

impl Crowd {
    /// Uploads what changed since the last call: per asset the new instances' `S0` (one write
    /// each), the index patches `set` made (one write and one scatter dispatch,
    /// submitted here on `queue`), the changed records and instance blocks (one contiguous
    /// write each); the scene block and textures. Call before submitting the pass that
    /// renders the crowd.
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

    /// Both `prepare`s: every write, and the scatter dispatches recorded in `dispatches`.
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
        let view_proj = glam::Mat4::from_cols_array_2d(&self.scene.view_proj);
        let frustum = self.culling.then(|| Frustum::new(view_proj));
        for a in &mut self.assets {
            let texture = a.gpu.upload(queue);
            upload.bytes += texture;
            upload.writes += usize::from(texture > 0);
            // New instances' regions get S0 (written before this frame's scatter runs, so
            // patches made since their add land on it).
            // A slot removed and added to again is listed twice and written once.
            let per = a.layout.per_instance();
            a.fresh.sort_unstable();
            a.fresh.dedup();
            for slot in a.fresh.drain(..) {
                if a.members[slot as usize].is_some() {
                    let offset = u64::from(slot * per) * 4;
                    upload.write(
                        queue,
                        &a.index_buffer,
                        offset,
                        bytemuck::cast_slice(a.layout.s0()),
                    );
                }
            }
            if a.waiting.overlap {
                a.waiting.merge(per);
            }
            a.prepares += 1;
            let index_runs = std::mem::take(&mut a.waiting.index_runs);
            upload.patches += index_runs
                .iter()
                .map(|r| r.values.len() as u64)
                .sum::<u64>();
            // The scatter's invocations run in any order on a real GPU (lavapipe runs them in
            // order, NVIDIA does not), so a word may get only one value a frame. Index patches
            // name each word once by construction (`SlotLayout::upload`; merged above where an
            // instance was patched by two `set`s); a slot's record can
            // change several times between two prepares (removed, then added again), so its
            // words keep their last value. Both checked in debug builds, which the tests run
            // on lavapipe.
            a.cull(frustum.as_ref());
            keep_last_per_word(&mut a.waiting.records);
            let mut record_runs = std::mem::take(&mut a.record_runs);
            record_runs.refill(&a.waiting.records);
            a.waiting.records.clear();
            for (what, runs) in [
                (Patched::Indices, &index_runs[..]),
                (Patched::Records, std::slice::from_ref(&record_runs)),
            ] {
                debug_assert!(
                    each_word_once(
                        runs.iter()
                            .flat_map(|r| r.iter())
                            .flat_map(|(first, values)| first..first + values.len() as u32)
                    ),
                    "{what:?}: a word patched twice"
                );
                a.scatter(
                    device,
                    queue,
                    &self.pipeline,
                    what,
                    runs,
                    dispatches,
                    &mut upload,
                );
            }
            a.record_runs = record_runs;
            // After the index scatter, which may have patched a slot range before its
            // instance moved into a tail list.
            a.expand_tails(device, queue, &self.pipeline, dispatches, &mut upload);
            if let Some(range) = a.dirty_blocks.take() {
                let blocks = &a.blocks[range.start as usize..range.end as usize];
                let offset = u64::from(range.start) * size_of::<InstanceBlock>() as u64;
                upload.write(
                    queue,
                    &a.instance_buffer,
                    offset,
                    bytemuck::cast_slice(blocks),
                );
            }
        }
        upload
    }
}

impl CrowdAsset {
    /// Writes the tail lists of the instances that moved in them since the last prepare and
    /// are still there (once each), into their compact areas: the jobs in one write, one
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
        self.jobs.clear();
        let per = self.layout.per_instance();
        let compact = self.layout.tail_record(0).first;
        for &slot in &slots {
            let Some(member) = &mut self.members[slot as usize] else {
                continue;
            };
            if let (Some((k, l)), false) = (member.tail, member.expanded) {
                member.expanded = true;
                let dst = slot * per + compact;
                let job = self.tails.job(k as usize, l as usize, dst);
                self.jobs
                    .push(job.expect("a tail member's LOD is in its frame's tail"));
            }
        }
        slots.clear();
        self.waiting.tails = slots;
        let (Some(last), Some(words)) = (self.jobs.last().copied(), &self.tail_words) else {
            return;
        };
        upload.tail_jobs += self.jobs.len();
        // Workgroups in a rectangle of at most the device's per-dimension limit, the jobs
        // padded to fill it with the last one (the same writes again).
        let wide = device.limits().max_compute_workgroups_per_dimension as usize;
        let x = self.jobs.len().min(wide);
        let y = self.jobs.len().div_ceil(x);
        self.jobs.resize(x * y, last);
        let bytes = (self.jobs.len() * size_of::<TailJob>()) as u64;
        if self
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
                        resource: self.index_buffer.as_entire_binding(),
                    },
                ],
            });
            self.tail_jobs = Some((buffer, group));
        }
        let (buffer, group) = self.tail_jobs.as_ref().expect("made above");
        upload.write(queue, buffer, 0, bytemuck::cast_slice(&self.jobs));
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

    /// Applies this frame's patches of `what` (the runs of each piece in turn): written to its
    /// patch buffer and scattered by one dispatch, recorded in `dispatches` (one submission
    /// for every asset and both kinds of patches: each kind has its own patch buffer).
    #[allow(clippy::too_many_arguments)]
    fn scatter(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        what: Patched,
        pieces: &[PatchRuns],
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let runs = pieces.iter().flat_map(PatchRuns::iter);
        // A frame that moves many instances far (the first LOD frame of a crowd) can pass one
        // binding's or one dispatch's limit: then it goes in lists of at most `chunk` words
        // (runs cut where a list fills), each full one written and submitted in a command
        // buffer of its own before the next reuses the buffer; the last goes with the frame's
        // other dispatches. A word takes at most 8 bytes of a run list, plus the headers'
        // padding.
        let chunk = ((Scatter::max_run_list_bytes(device) / 8) as usize)
            .saturating_sub(RUN_GROUP as usize)
            .max(1);
        let words: usize = pieces.iter().map(|p| p.values.len()).sum();
        if words <= chunk {
            self.dispatch_runs(device, queue, pipeline, what, runs, dispatches, upload);
            return;
        }
        let mut list: Vec<(u32, &[u32])> = Vec::new();
        let mut listed = 0;
        for (first, values) in runs {
            let mut at = 0;
            while at < values.len() {
                let take = (chunk - listed).min(values.len() - at);
                list.push((first + at as u32, &values[at..at + take]));
                (at, listed) = (at + take, listed + take);
                if listed == chunk {
                    let full = list.iter().copied();
                    let mut own = Dispatches::Own(None);
                    self.dispatch_runs(device, queue, pipeline, what, full, &mut own, upload);
                    own.submit_own(queue);
                    list.clear();
                    listed = 0;
                }
            }
        }
        if !list.is_empty() {
            let rest = list.iter().copied();
            self.dispatch_runs(device, queue, pipeline, what, rest, dispatches, upload);
        }
    }

    /// Encodes `runs` as one run list, writes it to the patch buffer of `what` and records its
    /// dispatch in `dispatches`.
    #[allow(clippy::too_many_arguments)]
    fn dispatch_runs<'a>(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &CrowdPipeline,
        what: Patched,
        runs: impl Iterator<Item = (u32, &'a [u32])> + Clone,
        dispatches: &mut Dispatches,
        upload: &mut CrowdUpload,
    ) {
        let headers = encode_runs(runs, &mut self.run_list);
        if headers == 0 {
            return;
        }
        let bytes = 4 * self.run_list.len() as u64;
        let (slot, target) = match what {
            Patched::Indices => (0, &self.index_buffer),
            Patched::Records => (1, &self.indirect_buffer),
        };
        let patches = (pipeline.scatter).patch_buffer(
            device,
            &mut self.patch_buffers[slot],
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
