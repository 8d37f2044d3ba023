//! What [`Object::render`](super::Object::render) records into: the commands it issues, as a
//! trait that `wgpu::RenderPass` implements, so a test double can see every call and its
//! arguments and a profiler can count draws without the object counting for it.

/// The render-pass commands an [`Object`](super::Object) issues. Buffers are bound whole.
///
/// `wgpu::RenderPass` implements it by forwarding each call; [`DrawCounter`] wraps any
/// implementation and counts the draw calls that pass through it.
pub trait RenderCommands {
    fn set_pipeline(&mut self, pipeline: &wgpu::RenderPipeline);
    fn set_bind_group(&mut self, index: u32, bind_group: &wgpu::BindGroup);
    /// Binds the whole of `buffer` to vertex buffer slot `slot`.
    fn set_vertex_buffer(&mut self, slot: u32, buffer: &wgpu::Buffer);
    /// Binds the whole of `buffer` as the index buffer.
    fn set_index_buffer(&mut self, buffer: &wgpu::Buffer, format: wgpu::IndexFormat);
    /// Draws `count` indexed indirect records read from `indirect` at byte `offset`.
    fn multi_draw_indexed_indirect(&mut self, indirect: &wgpu::Buffer, offset: u64, count: u32);
}

impl RenderCommands for wgpu::RenderPass<'_> {
    fn set_pipeline(&mut self, pipeline: &wgpu::RenderPipeline) {
        wgpu::RenderPass::set_pipeline(self, pipeline);
    }

    fn set_bind_group(&mut self, index: u32, bind_group: &wgpu::BindGroup) {
        wgpu::RenderPass::set_bind_group(self, index, bind_group, &[]);
    }

    fn set_vertex_buffer(&mut self, slot: u32, buffer: &wgpu::Buffer) {
        wgpu::RenderPass::set_vertex_buffer(self, slot, buffer.slice(..));
    }

    fn set_index_buffer(&mut self, buffer: &wgpu::Buffer, format: wgpu::IndexFormat) {
        wgpu::RenderPass::set_index_buffer(self, buffer.slice(..), format);
    }

    fn multi_draw_indexed_indirect(&mut self, indirect: &wgpu::Buffer, offset: u64, count: u32) {
        wgpu::RenderPass::multi_draw_indexed_indirect(self, indirect, offset, count);
    }
}

/// Forwards every command to `inner` and counts the draw calls (`multi_draw_indexed_indirect`
/// calls, whatever their record count).
pub struct DrawCounter<'a, P: RenderCommands + ?Sized> {
    pub inner: &'a mut P,
    pub draw_calls: u64,
}

impl<'a, P: RenderCommands + ?Sized> DrawCounter<'a, P> {
    pub fn new(inner: &'a mut P) -> Self {
        DrawCounter {
            inner,
            draw_calls: 0,
        }
    }
}

impl<P: RenderCommands + ?Sized> RenderCommands for DrawCounter<'_, P> {
    fn set_pipeline(&mut self, pipeline: &wgpu::RenderPipeline) {
        self.inner.set_pipeline(pipeline);
    }

    fn set_bind_group(&mut self, index: u32, bind_group: &wgpu::BindGroup) {
        self.inner.set_bind_group(index, bind_group);
    }

    fn set_vertex_buffer(&mut self, slot: u32, buffer: &wgpu::Buffer) {
        self.inner.set_vertex_buffer(slot, buffer);
    }

    fn set_index_buffer(&mut self, buffer: &wgpu::Buffer, format: wgpu::IndexFormat) {
        self.inner.set_index_buffer(buffer, format);
    }

    fn multi_draw_indexed_indirect(&mut self, indirect: &wgpu::Buffer, offset: u64, count: u32) {
        self.draw_calls += 1;
        self.inner
            .multi_draw_indexed_indirect(indirect, offset, count);
    }
}
