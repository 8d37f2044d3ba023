//! The crowd bench's GPU timer: timestamps at the start of the frame's encoder (where the device
//! has `TIMESTAMP_QUERY_INSIDE_ENCODERS`) and around its render pass, read back per frame.

/// The frame's timestamps, resolved and read back after each frame: the start of its encoder
/// (where the device has `TIMESTAMP_QUERY_INSIDE_ENCODERS`), the render pass's start and end.
pub(super) struct FrameTimer {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period: f64,
    /// Whether the encoder's start is timed (query 0).
    pub(super) encoder_start: bool,
}

impl FrameTimer {
    /// A timer where the device has `TIMESTAMP_QUERY`, else `None`.
    pub(super) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Option<FrameTimer> {
        let features = device.features();
        if !features.contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("crowd bench frame"),
            ty: wgpu::QueryType::Timestamp,
            count: 3,
        });
        let resolved = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("crowd bench timestamps"),
            size: 3 * wgpu::QUERY_SIZE as u64,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(FrameTimer {
            queries,
            resolved,
            period: f64::from(queue.get_timestamp_period()),
            encoder_start: features.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS),
        })
    }

    /// Times the start of the frame's encoder, before anything is recorded in it. (Vulkan
    /// writes it once the commands before it, the frame's buffer writes included, are done.)
    pub(super) fn start(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.encoder_start {
            encoder.write_timestamp(&self.queries, 0);
        }
    }

    pub(super) fn writes(&self) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(1),
            end_of_pass_write_index: Some(2),
        }
    }

    /// Resolves the frame's timestamps (recorded after the pass, in the same encoder).
    pub(super) fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..3, &self.resolved, 0);
    }

    /// The frame's GPU milliseconds (from the encoder's start where it is timed, else from the
    /// pass's) and the render pass's, read back once the frame has run.
    pub(super) fn read_ms(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<(f64, f64), crate::gpu::GpuError> {
        let encoder = device.create_command_encoder(&Default::default());
        let bytes = crate::gpu::readback::read_back(device, queue, encoder, &self.resolved)?;
        let [start, pass_start, end]: [u64; 3] = bytemuck::pod_read_unaligned(&bytes);
        let ms = |from: u64| end.saturating_sub(from) as f64 * self.period / 1e6;
        let frame = if self.encoder_start {
            start
        } else {
            pass_start
        };
        Ok((ms(frame), ms(pass_start)))
    }
}
