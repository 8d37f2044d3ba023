//! The index scatter (`shaders/scatter.wgsl`): a list of runs of consecutive words, uploaded
//! with one write, applied by one compute dispatch ([`encode_runs`], [`Scatter::record`]). An
//! [`super::Object`] sends a frame's index edits this way ([`super::Object::prepare`]); a
//! [`super::Crowd`] its assets' index slots and records.

/// The WGSL source of the index scatter (`shaders/scatter.wgsl`).
pub const SCATTER_WGSL: &str = include_str!("../../shaders/scatter.wgsl");

/// Run headers one `scatter_runs` workgroup applies (its `@workgroup_size`): small, since the
/// list is padded to whole workgroups and an object's frame may have few runs.
pub(crate) const RUN_GROUP: u32 = 16;

/// The most words one run header covers (the stores one `scatter_runs` invocation makes).
pub(crate) const RUN_WORDS: u32 = 16;

/// The scatter's compute pipeline and the layout of its bind group (binding 0: the run list,
/// read-only storage of `[u32; 2]`; binding 1: the patched buffer, read-write storage of `u32`).
#[derive(Clone, Debug)]
pub(crate) struct Scatter {
    pub(crate) layout: wgpu::BindGroupLayout,
    /// Runs of up to [`RUN_WORDS`] words, one invocation each.
    pub(crate) runs: wgpu::ComputePipeline,
}

impl Scatter {
    pub(crate) fn new(device: &wgpu::Device) -> Scatter {
        // Headers are [u32; 2]: 8 bytes each.
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("morphlod scatter"),
            entries: &[compute_storage(0, true, 8), compute_storage(1, false, 4)],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("scatter.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SCATTER_WGSL.into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("morphlod scatter"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let runs = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("scatter_runs"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("scatter_runs"),
            compilation_options: Default::default(),
            cache: None,
        });
        Scatter { runs, layout }
    }

    /// The bind group that applies the run list in `patches` to `target`.
    pub(crate) fn bind_group(
        &self,
        device: &wgpu::Device,
        label: &str,
        patches: &wgpu::Buffer,
        target: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: patches.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: target.as_entire_binding(),
                },
            ],
        })
    }

    /// `patches` made or grown (to the next power of two) to hold at least `bytes` of run
    /// list, bound over `target`. The caller keeps `bytes` within
    /// [`max_run_list_bytes`](Self::max_run_list_bytes); so does the rounding.
    pub(crate) fn patch_buffer<'p>(
        &self,
        device: &wgpu::Device,
        patches: &'p mut Option<PatchBuffer>,
        label: &str,
        target: &wgpu::Buffer,
        bytes: u64,
    ) -> &'p PatchBuffer {
        if patches.as_ref().is_none_or(|p| p.buffer.size() < bytes) {
            let max = device.limits().max_storage_buffer_binding_size;
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.next_power_of_two().min(max).max(bytes),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let group = self.bind_group(device, label, &buffer, target);
            *patches = Some(PatchBuffer { buffer, group });
        }
        patches.as_ref().expect("made above")
    }

    /// Records the dispatch that applies the run list of `headers` padded headers
    /// ([`encode_runs`]) just written to `patches`, in `dispatches`.
    pub(crate) fn record(
        &self,
        device: &wgpu::Device,
        dispatches: &mut Dispatches,
        patches: &PatchBuffer,
        headers: u32,
    ) {
        let mut pass =
            dispatches
                .encoder(device)
                .begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("morphlod scatter"),
                    timestamp_writes: None,
                });
        pass.set_pipeline(&self.runs);
        pass.set_bind_group(0, &patches.group, &[]);
        pass.dispatch_workgroups(headers / RUN_GROUP, 1, 1);
    }

    /// The most bytes one `scatter_runs` list may have on this device: one storage binding,
    /// and no more headers (8 bytes each) than one dimension of workgroups dispatches.
    pub(crate) fn max_run_list_bytes(device: &wgpu::Device) -> u64 {
        let limits = device.limits();
        let by_dispatch =
            u64::from(limits.max_compute_workgroups_per_dimension) * u64::from(RUN_GROUP) * 8;
        limits.max_storage_buffer_binding_size.min(by_dispatch)
    }
}

/// A run list's buffer and the bind group that applies it to the patched buffer.
#[derive(Debug)]
pub(crate) struct PatchBuffer {
    pub(crate) buffer: wgpu::Buffer,
    group: wgpu::BindGroup,
}

/// Where a `prepare`'s scatter dispatches are recorded: an encoder of `prepare`'s own, made on
/// the first dispatch and submitted by [`submit_own`](Self::submit_own) (a frame without runs
/// submits nothing), or the application's (`prepare_with`).
pub(crate) enum Dispatches<'e> {
    Own(Option<wgpu::CommandEncoder>),
    Caller(&'e mut wgpu::CommandEncoder),
}

impl Dispatches<'_> {
    pub(crate) fn encoder(&mut self, device: &wgpu::Device) -> &mut wgpu::CommandEncoder {
        match self {
            Dispatches::Own(own) => own.get_or_insert_with(|| {
                device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("morphlod scatter"),
                })
            }),
            Dispatches::Caller(encoder) => encoder,
        }
    }

    /// Submits the own encoder, if one was made; the caller's is the caller's.
    pub(crate) fn submit_own(self, queue: &wgpu::Queue) {
        if let Dispatches::Own(Some(encoder)) = self {
            queue.submit([encoder.finish()]);
        }
    }
}

/// Encodes `runs` (each a first word below 2³¹ and its values, at least one; disjoint) as a
/// `scatter_runs` list in `list` (cleared first): one header per [`RUN_WORDS`] words of a run,
/// a single word with its value inline, the headers padded to whole workgroups by repeating
/// the last one; then the longer runs' values, and a zero to whole `[u32; 2]` elements.
/// Returns the padded header count (the dispatch is that over [`RUN_GROUP`] workgroups), 0
/// for no runs (and an empty list).
pub(crate) fn encode_runs<'a, I>(runs: I, list: &mut Vec<u32>) -> u32
where
    I: Iterator<Item = (u32, &'a [u32])> + Clone,
{
    list.clear();
    let headers: usize = runs
        .clone()
        .map(|(_, values)| values.len().div_ceil(RUN_WORDS as usize))
        .sum();
    if headers == 0 {
        return 0;
    }
    let padded = headers.next_multiple_of(RUN_GROUP as usize);
    // Values start after the padded headers, in u32s of the list.
    let mut value_at = 2 * padded as u32;
    for (first, values) in runs.clone() {
        debug_assert!(first < 1 << 31, "word {first} does not fit a run header");
        if let [value] = values {
            list.extend([first | 1 << 31, *value]);
            continue;
        }
        for (k, chunk) in values.chunks(RUN_WORDS as usize).enumerate() {
            let len = chunk.len() as u32;
            list.extend([first + k as u32 * RUN_WORDS, value_at << 4 | (len - 1)]);
            value_at += len;
        }
    }
    let last = [list[list.len() - 2], list[list.len() - 1]];
    for _ in headers..padded {
        list.extend(last);
    }
    for (_, values) in runs.filter(|(_, values)| values.len() > 1) {
        list.extend_from_slice(values);
    }
    if list.len() % 2 == 1 {
        list.push(0);
    }
    padded as u32
}

/// A storage buffer binding of a compute stage, at least `size` bytes.
pub(crate) fn compute_storage(
    binding: u32,
    read_only: bool,
    size: u64,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size),
        },
        count: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `scatter_runs` does with `list` (its first `headers` pairs), written from the
    /// shader's comment: each header stores 16 words, the k-th clamped to the run's last.
    fn apply(list: &[u32], headers: u32, buffer: &mut [u32]) {
        for h in 0..headers as usize {
            let (x, y) = (list[2 * h], list[2 * h + 1]);
            let single = x >= 1 << 31;
            for k in 0..RUN_WORDS {
                let i = k.min(if single { 0 } else { y & 15 });
                let value = if single {
                    y
                } else {
                    list[((y >> 4) + i) as usize]
                };
                buffer[((x & 0x7fff_ffff) + i) as usize] = value;
            }
        }
    }

    #[test]
    fn encoded_runs_store_exactly_their_words() {
        // Runs of 1, 2, 16, 17 and 40 words with gaps, one of them at word 0.
        let lengths = [1usize, 2, 16, 17, 40, 1, 3];
        let mut runs = Vec::new();
        let mut values = Vec::new();
        let mut at = 0u32;
        for (r, &len) in lengths.iter().enumerate() {
            let start = values.len();
            values.extend((0..len as u32).map(|k| 1000 * (r as u32 + 1) + k));
            runs.push((at, start..values.len()));
            at += len as u32 + 1 + r as u32;
        }
        let mut list = Vec::new();
        let headers = encode_runs(
            runs.iter().map(|(f, r)| (*f, &values[r.clone()])),
            &mut list,
        );
        assert_eq!(headers % RUN_GROUP, 0);
        assert_eq!(list.len() % 2, 0);
        // Lone words ride in their header: 8 bytes; longer runs 8 a header plus 4 a word.
        let words: usize = lengths.iter().sum();
        assert!(4 * list.len() <= 8 * words + 8 * RUN_GROUP as usize);
        let mut buffer = vec![u32::MAX; at as usize + 16];
        apply(&list, headers, &mut buffer);
        let mut expected = vec![u32::MAX; buffer.len()];
        for (first, range) in &runs {
            let f = *first as usize;
            expected[f..f + range.len()].copy_from_slice(&values[range.clone()]);
        }
        assert_eq!(buffer, expected);
        assert_eq!(encode_runs(std::iter::empty(), &mut list), 0);
        assert!(list.is_empty());
    }
}
