//! An offscreen render target (colour + depth) and its readback into an image.

use std::path::Path;

use super::{GpuError, Object};

/// An offscreen colour texture (`Rgba8Unorm`) with a `Depth32Float` depth buffer.
///
/// The colour format is linear `Rgba8Unorm`, not sRGB: the bytes read back are the shader's
/// output times 255, which tests can predict exactly.
pub struct RenderTarget {
    width: u32,
    height: u32,
    clear: wgpu::Color,
    color: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
}

impl RenderTarget {
    /// The colour format pipelines drawing into a target must use.
    pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
    /// The depth format pipelines drawing into a target must use.
    pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

    /// A `width` x `height` target cleared to `clear` at the start of every pass.
    pub fn new(
        device: &wgpu::Device,
        width: u32,
        height: u32,
        clear: wgpu::Color,
    ) -> Result<RenderTarget, GpuError> {
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GpuError::RenderTargetSize { width, height, max });
        }
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = texture(
            "morphlod target colour",
            RenderTarget::COLOR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture(
            "morphlod target depth",
            RenderTarget::DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        Ok(RenderTarget {
            width,
            height,
            clear,
            color_view: color.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color,
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// Begins a render pass on this target, clearing colour and depth (depth to 1.0).
    pub fn begin_pass<'e>(&self, encoder: &'e mut wgpu::CommandEncoder) -> wgpu::RenderPass<'e> {
        self.begin_timed_pass(encoder, None)
    }

    /// [`begin_pass`](Self::begin_pass) that also writes the pass's timestamps (the device
    /// needs `TIMESTAMP_QUERY`): how benchmarks time the GPU.
    pub fn begin_timed_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("morphlod target pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(self.clear),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Renders `objects` in one pass (each with its one multi-draw), submits, and reads the
    /// image back. Call [`Object::prepare`] on each object first.
    pub fn render(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        objects: &[&Object],
    ) -> Result<image::RgbaImage, GpuError> {
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = self.begin_pass(&mut encoder);
            for object in objects {
                object.render(&mut pass);
            }
        }
        queue.submit([encoder.finish()]);
        self.read_image(device, queue)
    }

    /// Copies the colour texture into a mappable buffer and returns it as an image (waits for
    /// the GPU).
    pub fn read_image(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<image::RgbaImage, GpuError> {
        // Texture-to-buffer copies need rows padded to 256 bytes.
        let row_bytes = self.width * 4;
        let padded_row_bytes = row_bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("morphlod readback"),
            size: u64::from(padded_row_bytes) * u64::from(self.height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row_bytes),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
        queue.submit([encoder.finish()]);

        super::readback::wait_mapped(device, &buffer)?;
        let mut pixels = Vec::with_capacity((row_bytes * self.height) as usize);
        {
            let view = buffer
                .get_mapped_range(..)
                .map_err(|error| GpuError::Map(error.to_string()))?;
            for row in view.chunks_exact(padded_row_bytes as usize) {
                pixels.extend_from_slice(&row[..row_bytes as usize]);
            }
        }
        buffer.unmap();
        image::RgbaImage::from_raw(self.width, self.height, pixels).ok_or_else(|| {
            GpuError::Map("the readback buffer is smaller than the image".to_string())
        })
    }
}

/// Writes `image` as a PNG file.
pub fn save_png(image: &image::RgbaImage, path: &Path) -> Result<(), GpuError> {
    image
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|source| GpuError::Png {
            path: path.to_path_buf(),
            source,
        })
}
