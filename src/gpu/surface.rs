//! The GPU side of an asset's [`Surface`]: the per-vertex normals, UVs and colours in one
//! interleaved vertex buffer, the base-colour texture and its sampler.
//!
//! Everything here is static: uploaded once (the vertex buffer when the object is made, the
//! texture on the object's first [`prepare`](super::Object::prepare), which has the queue).
//! What moves with the pose, the normal offsets of a weight animation, lives with the position
//! offsets in `pose.rs`.
//!
//! The texture is decoded here (PNG or JPEG, the `image` crate) into RGBA8 and uploaded as
//! `Rgba8UnormSrgb`, so the shader samples linear values, as glTF defines base-colour
//! textures. It has no mipmaps: minification reads level 0 with the sampler's min filter
//! (linear unless the source asks for nearest), which aliases a little when a detailed texture
//! covers few pixels; the demos draw faces that fill the view.
//!
//! A texture that does not decode is an error ([`GpuError::TextureDecode`]), not a silent
//! fallback: the caller decides, e.g. by clearing `material.texture` to draw untextured.

use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::pipeline::SURFACE_STRIDE;
use super::GpuError;
use crate::asset::Surface;
use crate::morph::{ImageFormat, Sampler, Texture};

/// A surface on the GPU, ready to bind.
pub(super) struct GpuSurface {
    /// Per vertex: n0, n1, uv, colour (see [`SURFACE_STRIDE`]).
    pub(super) buffer: wgpu::Buffer,
    pub(super) view: wgpu::TextureView,
    pub(super) sampler: wgpu::Sampler,
    pub(super) base_color: [f32; 4],
    /// Whether the material has a texture (a 1x1 white one stands in otherwise).
    pub(super) textured: bool,
    texture: wgpu::Texture,
    /// Decoded texels waiting for the first upload; `None` once uploaded. Behind a mutex
    /// because the surface is shared ([`super::GpuAsset`]) and whichever user prepares first
    /// uploads it.
    pending: std::sync::Mutex<Option<image::RgbaImage>>,
}

impl GpuSurface {
    /// Checks `surface` against `vertex_count`, decodes its texture and makes the buffers.
    pub(super) fn new(
        device: &wgpu::Device,
        surface: &Surface,
        vertex_count: usize,
    ) -> Result<GpuSurface, GpuError> {
        check_attribute("n0", &surface.n0, vertex_count)?;
        check_attribute("n1", &surface.n1, vertex_count)?;
        if let Some(uvs) = &surface.uvs {
            check_attribute("uvs", uvs, vertex_count)?;
        }
        if let Some(colors) = &surface.colors {
            check_attribute("colors", colors, vertex_count)?;
        }
        let base_color = surface.material.base_color;
        if !base_color.iter().all(|c| c.is_finite()) {
            return Err(GpuError::InvalidParameter {
                what: "base colour factor",
                value: format!("{base_color:?}"),
                expected: "the factor must be finite",
            });
        }
        let interleaved = interleave(surface, vertex_count);
        let bytes: &[u8] = bytemuck::cast_slice(&interleaved);
        let limits = device.limits();
        super::checks::check_size("surface", bytes.len() as u64, limits.max_buffer_size)?;
        let buffer = device.create_buffer_init(&BufferInitDescriptor {
            label: Some("morphlod surface"),
            contents: bytes,
            // STORAGE: a crowd pulls the attributes by vertex index (`shaders/crowd.wgsl`).
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
        });

        let (texels, sampler) = match &surface.material.texture {
            Some(texture) => (decode_texture(texture)?, texture.sampler),
            None => (
                image::RgbaImage::from_pixel(1, 1, image::Rgba([255; 4])),
                Sampler::default(),
            ),
        };
        let max = limits.max_texture_dimension_2d;
        if texels.width() > max || texels.height() > max {
            return Err(GpuError::TextureSize {
                width: texels.width(),
                height: texels.height(),
                max,
            });
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("morphlod base colour"),
            size: extent(&texels),
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        Ok(GpuSurface {
            buffer,
            view: texture.create_view(&Default::default()),
            sampler: device.create_sampler(&sampler_descriptor(sampler)?),
            base_color,
            textured: surface.material.texture.is_some(),
            texture,
            pending: std::sync::Mutex::new(Some(texels)),
        })
    }

    /// Uploads the texture the first time; returns the bytes written (0 afterwards).
    pub(super) fn upload(&self, queue: &wgpu::Queue) -> u64 {
        // A poisoned lock only means another thread panicked while uploading; the texels
        // are still whatever it left.
        let mut pending = self.pending.lock().unwrap_or_else(|p| p.into_inner());
        let Some(texels) = pending.take() else {
            return 0;
        };
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            texels.as_raw(),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * texels.width()),
                rows_per_image: Some(texels.height()),
            },
            extent(&texels),
        );
        texels.as_raw().len() as u64
    }
}

impl GpuSurface {
    /// GPU bytes: the attribute buffer and the texture (RGBA8, one level).
    pub(super) fn gpu_bytes(&self) -> u64 {
        let size = self.texture.size();
        self.buffer.size() + 4 * u64::from(size.width) * u64::from(size.height)
    }
}

fn extent(texels: &image::RgbaImage) -> wgpu::Extent3d {
    wgpu::Extent3d {
        width: texels.width(),
        height: texels.height(),
        depth_or_array_layers: 1,
    }
}

/// One entry per vertex, finite.
fn check_attribute<const N: usize>(
    attribute: &'static str,
    values: &[[f32; N]],
    vertices: usize,
) -> Result<(), GpuError> {
    if values.len() != vertices {
        return Err(GpuError::SurfaceLength {
            attribute,
            len: values.len(),
            vertices,
        });
    }
    match values.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
        Some(vertex) => Err(GpuError::NonFiniteAttribute { attribute, vertex }),
        None => Ok(()),
    }
}

/// The vertex buffer's contents: n0, n1, uv, colour per vertex, as 12 floats. Missing UVs are
/// 0 (they then sample the one texel of the white stand-in, or one texel of a texture) and
/// missing colours are white, the neutral element of the product the shader takes.
fn interleave(surface: &Surface, vertex_count: usize) -> Vec<f32> {
    const FLOATS: usize = SURFACE_STRIDE as usize / 4;
    let mut data = Vec::with_capacity(vertex_count * FLOATS);
    for v in 0..vertex_count {
        data.extend_from_slice(&surface.n0[v]);
        data.extend_from_slice(&surface.n1[v]);
        data.extend_from_slice(&surface.uvs.as_ref().map_or([0.0; 2], |uvs| uvs[v]));
        data.extend_from_slice(&surface.colors.as_ref().map_or([1.0; 4], |c| c[v]));
    }
    data
}

/// The texture's texels as RGBA8 (grey, RGB and 16-bit sources converted), as the renderer
/// uploads them. Asset pipelines call it to refuse a texture that does not decode before
/// they write anything ([`GpuError::TextureDecode`]).
pub fn decode_texture(texture: &Texture) -> Result<image::RgbaImage, GpuError> {
    let format = match texture.format {
        ImageFormat::Png => image::ImageFormat::Png,
        ImageFormat::Jpeg => image::ImageFormat::Jpeg,
    };
    image::load_from_memory_with_format(&texture.bytes, format)
        .map(|decoded| decoded.to_rgba8())
        .map_err(|source| GpuError::TextureDecode {
            mime_type: texture.format.mime_type(),
            source,
        })
}

/// glTF sampler codes as wgpu filters and address modes. The mipmap part of a min filter is
/// moot (the texture has one level); its base filter is kept. Absent filters are linear.
fn sampler_descriptor(sampler: Sampler) -> Result<wgpu::SamplerDescriptor<'static>, GpuError> {
    let filter = |what, code: Option<u32>| match code {
        None | Some(9729) | Some(9985) | Some(9987) => Ok(wgpu::FilterMode::Linear),
        Some(9728) | Some(9984) | Some(9986) => Ok(wgpu::FilterMode::Nearest),
        Some(code) => Err(GpuError::InvalidParameter {
            what,
            value: code.to_string(),
            expected: "glTF filters are 9728, 9729 or 9984 to 9987",
        }),
    };
    let wrap = |what, code: u32| match code {
        10497 => Ok(wgpu::AddressMode::Repeat),
        33071 => Ok(wgpu::AddressMode::ClampToEdge),
        33648 => Ok(wgpu::AddressMode::MirrorRepeat),
        code => Err(GpuError::InvalidParameter {
            what,
            value: code.to_string(),
            expected: "glTF wrap modes are 10497 (repeat), 33071 (clamp) or 33648 (mirror)",
        }),
    };
    Ok(wgpu::SamplerDescriptor {
        label: Some("morphlod base colour"),
        address_mode_u: wrap("sampler wrapS", sampler.wrap_s)?,
        address_mode_v: wrap("sampler wrapT", sampler.wrap_t)?,
        mag_filter: filter("sampler magFilter", sampler.mag_filter)?,
        min_filter: filter("sampler minFilter", sampler.min_filter)?,
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gltf_sampler_codes_map_to_wgpu_and_unknown_codes_are_refused() {
        let sampler = Sampler {
            mag_filter: Some(9728),
            min_filter: Some(9987),
            wrap_s: 33071,
            wrap_t: 33648,
        };
        let d = sampler_descriptor(sampler).expect("valid codes");
        assert_eq!(d.mag_filter, wgpu::FilterMode::Nearest);
        assert_eq!(d.min_filter, wgpu::FilterMode::Linear);
        assert_eq!(d.address_mode_u, wgpu::AddressMode::ClampToEdge);
        assert_eq!(d.address_mode_v, wgpu::AddressMode::MirrorRepeat);
        let d = sampler_descriptor(Sampler::default()).expect("defaults");
        assert_eq!(d.mag_filter, wgpu::FilterMode::Linear);
        assert_eq!(d.address_mode_u, wgpu::AddressMode::Repeat);
        for bad in [
            Sampler {
                wrap_s: 1,
                ..Sampler::default()
            },
            Sampler {
                min_filter: Some(9730),
                ..Sampler::default()
            },
        ] {
            assert!(matches!(
                sampler_descriptor(bad),
                Err(GpuError::InvalidParameter { .. })
            ));
        }
    }

    #[test]
    fn a_texture_that_does_not_decode_is_a_typed_error() {
        let texture = Texture {
            format: ImageFormat::Jpeg,
            bytes: b"\xff\xd8 not really a jpeg".to_vec(),
            sampler: Sampler::default(),
        };
        let error = decode_texture(&texture).expect_err("garbage does not decode");
        assert!(matches!(
            error,
            GpuError::TextureDecode {
                mime_type: "image/jpeg",
                ..
            }
        ));
        assert!(error.to_string().contains("untextured"), "{error}");
    }
}
