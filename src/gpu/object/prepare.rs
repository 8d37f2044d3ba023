//! `prepare`: the changed index words by writes or through the scatter, the changed
//! indirect records, the uniforms and offsets, the texture.

use std::ops::Range;

use super::Object;
use crate::gpu::records::ARGS_BYTES;
use crate::gpu::scatter::{encode_runs, Dispatches};
use crate::gpu::upload::{coalesce, plan_upload, run_list_bytes};
use crate::gpu::Upload;
#[allow(unused_imports)] // named in the docs
use crate::gpu::{MERGE_GAP_BYTES, WRITE_CALL_BYTES};

impl Object {
    /// Sets how far apart (in bytes of one buffer) two changed spans may lie and still be
    /// sent as one write when [`prepare`](Self::prepare) sends a frame by writes only (a frame
    /// of few spans, or an index buffer larger than one storage binding), and two changed
    /// indirect records ([`MERGE_GAP_BYTES`] by default). 0 sends exactly the changed bytes in
    /// more calls; larger values send fewer, bigger writes.
    pub fn set_merge_gap(&mut self, bytes: u64) {
        self.mirror.set_merge_gap(bytes);
    }

    /// Uploads everything changed since the last call: the changed index words, the changed
    /// indirect records (coalesced by the merge gap, one `queue.write_buffer` each) and the
    /// uniforms. Call before the render pass that draws this object is submitted.
    ///
    /// The index words go by the cheaper of two plans under the cost model of
    /// [`WRITE_CALL_BYTES`]: a frame of few changed spans as writes (spans closer than the
    /// merge gap joined); a frame of many through the index scatter (`shaders/scatter.wgsl`,
    /// `scatter_runs`): runs of consecutive changed words (neighbouring spans joined where the
    /// words between them cost less than a run's header) listed as one header per run of up to
    /// 16 words and their values, uploaded with one write and applied by one compute dispatch,
    /// with only runs of more than ~16 k words still written directly. That dispatch is
    /// recorded here and **submitted on `queue`** in a small command buffer of its own, so
    /// queue order keeps every frame's edits in order whatever the caller submits next. Such a
    /// frame costs a few calls and O(changed words) of CPU whatever the number of spans, and
    /// sends at most about twice the changed words' bytes (a single word: 8 bytes). The
    /// [`Upload`] lists what was actually sent: the ranges written, the words sent through the
    /// scatter and the list's bytes.
    ///
    /// [`prepare_with`](Self::prepare_with) records the dispatch into the caller's encoder
    /// instead, saving the submission.
    pub fn prepare(&mut self, queue: &wgpu::Queue) -> Upload {
        let mut dispatches = Dispatches::Own(None);
        let upload = self.upload(queue, &mut dispatches);
        dispatches.submit_own(queue);
        upload
    }

    /// [`prepare`](Self::prepare), with the index scatter's dispatch (on a frame that has
    /// one) recorded into `encoder` instead of submitted on its own, so that any number of
    /// objects and the frame's passes go in one submission. Rules for the caller, as for
    /// egui-wgpu's `update_buffers`: record the render pass that draws this object into
    /// `encoder` after this call, and submit `encoder` on `queue` before this object's next
    /// `prepare` or `prepare_with` (that call rewrites the run list the recorded dispatch
    /// reads).
    pub fn prepare_with(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Upload {
        self.upload(queue, &mut Dispatches::Caller(encoder))
    }

    /// Both `prepare`s: every write, and the scatter's dispatch (on a frame that sends runs)
    /// recorded in `dispatches`.
    fn upload(&mut self, queue: &wgpu::Queue, dispatches: &mut Dispatches) -> Upload {
        let mut upload = Upload::default();
        let gap = u32::try_from(self.mirror.merge_gap_bytes() / 4).unwrap_or(u32::MAX);
        let spans = self.mirror.take_spans();
        let plan = plan_upload(&spans, gap, self.scatter.max_list_bytes);
        for span in plan.writes {
            let data = &self.mirror.indices[span.start as usize..span.end as usize];
            let bytes = u64::from(span.start) * 4..u64::from(span.end) * 4;
            queue.write_buffer(&self.index_buffer, bytes.start, bytemuck::cast_slice(data));
            upload.index_ranges.push(bytes);
        }
        if !plan.runs.is_empty() {
            self.scatter_runs(queue, &plan.runs, dispatches, &mut upload);
        }
        let args_gap =
            u32::try_from(self.mirror.merge_gap_bytes() / ARGS_BYTES).unwrap_or(u32::MAX);
        for span in coalesce(&mut self.records.dirty, args_gap) {
            let data = &self.records.args[span.start as usize..span.end as usize];
            let bytes = u64::from(span.start) * ARGS_BYTES..u64::from(span.end) * ARGS_BYTES;
            queue.write_buffer(
                &self.indirect_buffer,
                bytes.start,
                bytemuck::cast_slice(data),
            );
            upload.indirect_ranges.push(bytes);
        }
        let pose = self.pose.upload(queue);
        upload.uniform_bytes = pose.uniform_bytes;
        upload.offset_bytes = pose.offset_bytes;
        upload.offset_writes = pose.offset_writes;
        upload.texture_bytes = self.asset.upload(queue);
        upload
    }

    /// Writes the run list of `runs` (disjoint, their list within `max_list_bytes`; the list:
    /// [`encode_runs`]) for the scatter and records its dispatch in `dispatches`.
    fn scatter_runs(
        &mut self,
        queue: &wgpu::Queue,
        runs: &[Range<u32>],
        dispatches: &mut Dispatches,
        upload: &mut Upload,
    ) {
        let s = &mut self.scatter;
        let indices = &self.mirror.indices;
        let headers = encode_runs(
            runs.iter()
                .map(|r| (r.start, &indices[r.start as usize..r.end as usize])),
            &mut s.list,
        );
        // `plan_upload` priced this list with `run_list_bytes`; the encoding is its length.
        let bytes = s.list.len() as u64 * 4;
        debug_assert_eq!(bytes, run_list_bytes(runs));
        upload.scattered_words += runs.iter().map(|r| u64::from(r.end - r.start)).sum::<u64>();
        let patches = s.scatter.patch_buffer(
            &s.device,
            &mut s.patch_buffer,
            "morphlod index runs",
            &self.index_buffer,
            bytes,
        );
        queue.write_buffer(&patches.buffer, 0, bytemuck::cast_slice(&s.list));
        s.scatter.record(&s.device, dispatches, patches, headers);
        upload.scatter_bytes = bytes;
        upload.scatters = 1;
    }
}
