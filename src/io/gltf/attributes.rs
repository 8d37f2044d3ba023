//! The appearance of a glTF mesh: per-vertex NORMAL, TEXCOORD and COLOR_0 and the targets'
//! NORMAL deltas, concatenated over the primitives like the positions, and the material's base
//! colour factor and texture (image bytes kept encoded; their header is checked here).
//!
//! A morph has one set of attributes over all its vertices, but glTF lets every primitive
//! choose its own. Where primitives disagree:
//! * NORMAL and TEXCOORD are kept only when every primitive has them; otherwise the normals
//!   are computed for the whole mesh ([`crate::morph::Morph::normals`]) and the mesh is drawn
//!   untextured, since a vertex without coordinates has nothing to sample;
//! * COLOR_0 is kept when any primitive has it, the others reading as opaque white (glTF's
//!   meaning of an absent COLOR_0);
//! * a target's NORMAL deltas are kept when any primitive gives them, the others reading as
//!   zero (the target leaves their normals alone, as a target without POSITION leaves their
//!   positions);
//! * the material is the first primitive's.

use super::document::{read_uri, Document, UriError};
use crate::io::image_header::image_size;
use crate::io::LoadError;
use crate::morph::{Material, Sampler, Texture};
use gltf::accessor::Dimensions;

/// One attribute concatenated over the primitives, with how many gave it.
#[derive(Default)]
struct Column<const N: usize> {
    values: Vec<[f32; N]>,
    given: usize,
    primitives: usize,
}

impl<const N: usize> Column<N> {
    /// Appends one primitive's values, or `fill` for each of its `vertices` when it has none.
    fn push(&mut self, values: Option<Vec<[f32; N]>>, vertices: usize, fill: [f32; N]) {
        self.primitives += 1;
        match values {
            Some(values) => {
                self.given += 1;
                self.values.extend(values);
            }
            None => self.values.extend(std::iter::repeat_n(fill, vertices)),
        }
    }

    /// The values when every primitive gave them.
    fn if_all_gave(self) -> Option<Vec<[f32; N]>> {
        (self.given > 0 && self.given == self.primitives).then_some(self.values)
    }

    /// The values when any primitive gave them (the others filled).
    fn if_any_gave(self) -> Option<Vec<[f32; N]>> {
        (self.given > 0).then_some(self.values)
    }
}

/// The vertex attributes of a mesh's primitives while they are read
/// ([`Document::append_attributes`]), then [`MeshAttributes::finish`]ed.
#[derive(Default)]
pub(super) struct MeshAttributes {
    normals: Column<3>,
    uvs: Column<2>,
    colors: Column<4>,
    target_normals: Vec<Column<3>>,
    /// The first primitive's material, and the TEXCOORD set its base-colour texture samples.
    material: Option<usize>,
    uv_set: u32,
}

/// The attributes of a mesh, one entry per vertex of the concatenated primitives.
#[derive(Default)]
pub(super) struct VertexAttributes {
    pub(super) normals: Option<Vec<[f32; 3]>>,
    pub(super) uvs: Option<Vec<[f32; 2]>>,
    pub(super) colors: Option<Vec<[f32; 4]>>,
    /// Per target; `None` where no primitive gives the target NORMAL deltas.
    pub(super) target_normals: Vec<Option<Vec<[f32; 3]>>>,
    pub(super) material: Option<usize>,
}

impl MeshAttributes {
    pub(super) fn finish(self) -> VertexAttributes {
        VertexAttributes {
            normals: self.normals.if_all_gave(),
            uvs: self.uvs.if_all_gave(),
            colors: self.colors.if_any_gave(),
            target_normals: self
                .target_normals
                .into_iter()
                .map(Column::if_any_gave)
                .collect(),
            material: self.material,
        }
    }
}

impl Document {
    /// Reads one primitive's NORMAL, TEXCOORD, COLOR_0 and target NORMAL deltas into `out`
    /// (`vertices`: its POSITION count, which each must match). The first primitive read
    /// fixes the material and with it the TEXCOORD set.
    pub(super) fn append_attributes(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        vertices: usize,
        out: &mut MeshAttributes,
    ) -> Result<(), LoadError> {
        // No primitive read yet: this one fixes the material, TEXCOORD set and targets.
        if out.normals.primitives == 0 {
            let material = primitive.material();
            out.material = material.index();
            out.uv_set = material
                .pbr_metallic_roughness()
                .base_color_texture()
                .map_or(0, |info| info.tex_coord());
            out.target_normals = (0..primitive.morph_targets().len())
                .map(|_| Column::default())
                .collect();
        }
        // The flat components of an attribute and how many make an element.
        let read = |semantic: gltf::Semantic, dimensions: &[Dimensions]| {
            let Some(accessor) = primitive.get(&semantic) else {
                return Ok(None);
            };
            let element = format!("{element} {}", semantic.to_string());
            let flat = self.read_attribute(&accessor, &element, dimensions, vertices)?;
            Ok::<_, LoadError>(Some((flat, accessor.dimensions().multiplicity())))
        };
        let normals = read(gltf::Semantic::Normals, &[Dimensions::Vec3])?;
        out.normals.push(
            normals.map(|(f, _)| f.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()),
            vertices,
            [0.0; 3],
        );
        let uvs = read(gltf::Semantic::TexCoords(out.uv_set), &[Dimensions::Vec2])?;
        out.uvs.push(
            uvs.map(|(f, _)| f.chunks_exact(2).map(|c| [c[0], c[1]]).collect()),
            vertices,
            [0.0; 2],
        );
        let colors = read(
            gltf::Semantic::Colors(0),
            &[Dimensions::Vec3, Dimensions::Vec4],
        )?
        .map(|(flat, n)| {
            // RGB colours are opaque.
            flat.chunks_exact(n)
                .map(|c| [c[0], c[1], c[2], c.get(3).copied().unwrap_or(1.0)])
                .collect()
        });
        out.colors.push(colors, vertices, [1.0; 4]);
        // `append_targets` checked that every primitive has the first one's target count.
        for (t, (target, column)) in primitive
            .morph_targets()
            .zip(out.target_normals.iter_mut())
            .enumerate()
        {
            let deltas = match target.normals() {
                Some(accessor) => Some(
                    self.read_attribute(
                        &accessor,
                        &format!("{element} target {t} NORMAL"),
                        &[Dimensions::Vec3],
                        vertices,
                    )?
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]])
                    .collect(),
                ),
                None => None,
            };
            column.push(deltas, vertices, [0.0; 3]);
        }
        Ok(())
    }

    /// A per-vertex attribute: one of `dimensions`, float or normalized integer components
    /// (`read_floats`: decoded per glTF, finite), exactly `vertices` elements.
    fn read_attribute(
        &self,
        accessor: &gltf::Accessor,
        element: &str,
        dimensions: &[Dimensions],
        vertices: usize,
    ) -> Result<Vec<f32>, LoadError> {
        if !dimensions.contains(&accessor.dimensions()) {
            return Err(self.data_error(
                &format!("accessor {} ({element})", accessor.index()),
                format!(
                    "has type {:?}, expected {}",
                    accessor.dimensions(),
                    dimensions
                        .iter()
                        .map(|d| format!("{d:?}"))
                        .collect::<Vec<_>>()
                        .join(" or ")
                ),
            ));
        }
        if accessor.count() != vertices {
            return Err(self.data_error(
                &format!("accessor {} ({element})", accessor.index()),
                format!(
                    "has {} elements but POSITION has {vertices}: every attribute needs one value per vertex",
                    accessor.count()
                ),
            ));
        }
        self.read_floats(accessor, element, accessor.dimensions())
    }

    /// The morph's material: glTF's default (opaque white, untextured) for `None`, else the
    /// base colour factor and texture of material `index`. A texture without a `source`
    /// (its image supplied by an extension morphlod does not read) leaves the material
    /// untextured; an image that cannot be read or is not a PNG or JPEG is an error.
    pub(super) fn material(&self, index: Option<usize>) -> Result<Material, LoadError> {
        let Some(material) = index.and_then(|i| self.document.materials().nth(i)) else {
            return Ok(Material::default());
        };
        let pbr = material.pbr_metallic_roughness();
        let texture = match pbr.base_color_texture() {
            Some(info) => self.texture(&info.texture())?,
            None => None,
        };
        Ok(Material {
            name: material.name().map(str::to_string),
            base_color: pbr.base_color_factor(),
            texture,
        })
    }

    fn texture(&self, texture: &gltf::Texture) -> Result<Option<Texture>, LoadError> {
        let json = &self.document.as_json().textures[texture.index()];
        // `validate` let an absent source through (the spec allows it); the crate's
        // `Texture::source` would unwrap it.
        let image = json.source.value();
        if image == u32::MAX as usize {
            return Ok(None);
        }
        let bytes = self.image_bytes(image)?;
        let (format, _, _) = image_size(&bytes).map_err(|message| LoadError::GltfImage {
            path: self.path.clone(),
            image,
            message,
        })?;
        let sampler = texture.sampler();
        Ok(Some(Texture {
            format,
            bytes,
            sampler: Sampler {
                mag_filter: sampler.mag_filter().map(|f| f.as_gl_enum()),
                min_filter: sampler.min_filter().map(|f| f.as_gl_enum()),
                wrap_s: sampler.wrap_s().as_gl_enum(),
                wrap_t: sampler.wrap_t().as_gl_enum(),
            },
        }))
    }

    /// The encoded bytes of image `index`: a buffer view, a data URI, or a file relative to
    /// the glTF file. The format is taken from the bytes, not `mimeType`.
    pub(super) fn image_bytes(&self, index: usize) -> Result<Vec<u8>, LoadError> {
        let image = &self.document.as_json().images[index];
        let element = format!("image {index}");
        if let Some(view) = image.buffer_view {
            // The index was validated.
            let view = self
                .document
                .views()
                .nth(view.value())
                .ok_or_else(|| self.data_error(&element, "has no buffer view".to_string()))?;
            return Ok(self.view_bytes(&view, &element)?.to_vec());
        }
        let Some(uri) = &image.uri else {
            return Err(self.data_error(
                &element,
                "has neither a uri nor a bufferView: glTF requires one".to_string(),
            ));
        };
        read_uri(&self.path, uri).map_err(|e| match e {
            UriError::External { file, source } => LoadError::GltfImageExternal {
                path: self.path.clone(),
                image: index,
                file,
                source,
            },
            UriError::Unsupported(what) => self.unsupported(&element, what),
            UriError::Data(message) => self.data_error(&element, message),
        })
    }
}
