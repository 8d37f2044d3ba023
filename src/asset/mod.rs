//! The `.mlod` asset: everything the runtime needs for one deforming object,
//! and its file format.
//!
//! It stores the two GPU poses `V(0)`, `V(1)`, the common strips `S0` and one
//! collapse sequence per sampled frame. The change lists are not stored: they
//! are a deterministic function of `S0` and a frame's sequence, and replaying
//! a sequence at load time is cheap next to the storage the change lists would
//! take (see BENCHMARKS.md, "Memory", for both figures).
//!
//! # File layout (version 1, all integers little-endian)
//!
//! ```text
//! header (32 bytes)  magic "\x89MLD\r\n\x1a\n" | version u16 | flags u16 (0) |
//!                    section count u32 | body length u64 | CRC-32 of the body u32 | 0 u32
//! body               section table: per section  tag [u8; 4] | 0 u32 | offset u64 | length u64
//!                    (offsets from the body's start), then the sections:
//!   "V0  ", "V1  "   the poses, raw f32 x, y, z per vertex
//!   "S0  "           index count, offset count (strips + 1), offsets as LEB128
//!                    deltas, indices as zigzag LEB128 deltas to the previous index
//!   "FRMS"           frame count, then per frame its byte length and its bytes
//!   "TGTS"           optional, only for weight animations (see [`TargetBlend`]):
//!                    interpolation u8 (0 STEP, 1 LINEAR, 2 CUBICSPLINE) | target count K
//!                    LEB128 | keyframe count N LEB128 | N f32 times | the track's f32
//!                    values (N × K, × 3 for CUBICSPLINE) | K × vertices f32 x, y, z deltas
//!   "SURF", "TEXR"   optional, only for assets with a [`Surface`]: its shading attributes and
//!                    the material's texture, each with a version byte and its own CRC-32
//!                    (layout in `surface.rs`; validation below)
//! ```
//!
//! The magic is PNG's trick: the high byte catches 7-bit transfers, the
//! CR LF / LF pair catches newline translation, `^Z` stops DOS `type`.
//! Sections are found through the table, so a later minor addition (an extra
//! section) is skipped by this reader; an incompatible change bumps the version.
//! "TGTS" is such an addition: a reader that predates it draws the two-pose blend; so are
//! "SURF" and "TEXR": a reader that predates them draws the asset faceted and untextured.
//!
//! # Frame coding
//!
//! A frame is either `0` (the same sequence as the previous frame: animations
//! that hold a pose cost one byte per frame) or `1` followed by a bit stream.
//! Each collapse `u → w` costs
//! * `u` in a fixed width (the bits of the largest vertex index): collapse
//!   orders are close to random permutations, which no cheap model predicts;
//! * `w` as the position, in `u`'s neighbour list in `S0`, of the first
//!   neighbour whose current survivor is `w` (exp-Golomb): the collapsed
//!   vertex `w` is almost always the survivor of one of `u`'s original
//!   neighbours, so this takes a few bits instead of a vertex index. The decoder
//!   tracks survivors with a union-find, which also keeps `w` alive by
//!   construction. When no neighbour leads to `w`, an escape symbol (the
//!   neighbour count) is followed by `w` in the fixed width;
//! * the error as bfloat16 (the top 16 bits of the f32: full exponent range,
//!   8 significant bits), zigzag delta to the previous collapse's error
//!   (exp-Golomb): greedy orders make errors grow slowly.
//!
//! Both exp-Golomb orders are chosen per frame (the smallest stream) and
//! stored in the frame's first bytes. The bytes per collapse this gives on the
//! bundled meshes are in docs/benchmarks-log.md, "Build and asset size".
//!
//! # Where the code is
//!
//! This file: the [`Asset`] type and the container (header, section table, checksum,
//! load and save). `sections.rs`: the section codecs. `frame_codec.rs`: the bit-level
//! frame coder. `inspect.rs`: the report of where a file's bytes go.
//!
//! # Validation
//!
//! [`Asset::from_bytes`] checks the magic, version, flags, body length and
//! checksum before reading anything else, then every count against the bytes
//! left before allocating, every index against the vertex count, the strip
//! offsets, every collapse (in range, alive, not onto itself: the rules of
//! [`CollapseSequence::validate`]) and every error (finite, not negative). A surface is
//! checked for its own CRC and version, counts, finite values, topology entries in range,
//! copies of one topology vertex at one position in both poses and in every target, and
//! every frame moving whole topology vertices ([`crate::seams::check_steps`]); a texture
//! without a surface is refused.
//! Every failure is a typed [`AssetError`]; no input panics.

mod error;
mod frame_codec;
mod inspect;
mod reader;
mod sections;
mod skin;
mod surface;

pub use error::AssetError;
pub use frame_codec::quantize_error;
pub use inspect::{inspect, inspect_with, AssetInfo, FrameInfo, SectionInfo, SkinInfo};
pub use skin::SKIN_VERSION;
pub use surface::SURFACE_VERSION;

use crate::collapse::CollapseSequence;
use crate::morph::TargetBlend;
use crate::skin::Skinning;
use crate::strip::Strips;
use frame_codec::Neighbours;
use sections::{
    decode_frames, decode_pose, decode_strips, decode_targets, encode_frames, encode_strips,
    encode_targets, frame_parts, pose_bytes, FramePart,
};
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

/// One deforming object's LOD data, as built by the per-frame builder and
/// stored in a `.mlod` file. Frame `k` of `frames.len()` samples `t_k = k / (|r| - 1)`, or
/// `t_k = k / |r|` when the asset loops ([`Asset::looping`]: a skinned clip that ends where
/// it starts, whose frame after the last is the first).
///
/// Equal frames share one sequence: the builder and the loader give every frame that
/// equals an earlier one a clone of that frame's [`Arc`], so memory grows with the
/// [`distinct_frames`](Asset::distinct_frames), not with the frame count (a repeated frame
/// costs 2 bytes in the file). To edit one frame, `Arc::make_mut(&mut asset.frames[k])`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Asset {
    pub v0: Vec<[f32; 3]>,
    pub v1: Vec<[f32; 3]>,
    pub s0: Strips,
    pub frames: Vec<Arc<CollapseSequence>>,
    /// For an asset made from a weight animation: the targets the GPU adds to `V(0)` so it
    /// draws the animation, not only the blend of its end poses. `None` for two-pose morphs.
    pub blend: Option<TargetBlend>,
    /// Vertex attributes for shading, for an asset built from a morph with vertex attributes
    /// (normals, UVs or colours); `None` for position-only sources, drawn faceted.
    pub surface: Option<Surface>,
    /// For a skinned asset: the skin and the clip that pose `V(0)` (plus the blended targets)
    /// at every `t` ([`Asset::pose_at`]); `V(0)`, `V(1)` and the targets are in bind space.
    /// `None` otherwise.
    pub skin: Option<Skinning>,
}

/// What the renderer shades an asset's vertices with, beside the positions.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Per vertex its topology vertex ([`crate::morph::TopologyMap::of_vertex`]): vertices
    /// sharing one are copies split at a seam, and every LOD moves them together.
    pub topology: Vec<u32>,
    /// Normals at `t = 0` and `t = 1` before normalisation (`base + Σ w_k(0) D_k`, and at 1),
    /// one per vertex: a two-pose asset draws `normalize(mix(n0, n1, t))`.
    pub n0: Vec<[f32; 3]>,
    pub n1: Vec<[f32; 3]>,
    /// For an asset with a weight animation ([`Asset::blend`]): per blended target, in the
    /// order of `blend.deltas`, its normal deltas; the drawn normal is
    /// `normalize(n0 + Σ_k c_k(t) D_k)`. Empty otherwise.
    pub normal_deltas: Vec<Vec<[f32; 3]>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub colors: Option<Vec<[f32; 4]>>,
    pub material: crate::morph::Material,
}

impl Surface {
    /// Bytes the surface holds on the heap (capacities not counted).
    pub fn heap_bytes(&self) -> usize {
        let n = self.topology.len();
        let per_vertex = 4
            + 24
            + 12 * self.normal_deltas.len()
            + self.uvs.as_ref().map_or(0, |_| 8)
            + self.colors.as_ref().map_or(0, |_| 16);
        let texture = self.material.texture.as_ref().map_or(0, |t| t.bytes.len());
        n * per_vertex + texture
    }
}

/// Most morph targets an asset may blend on the GPU (the uniform block holds one weight per
/// target). More than any animation of one mesh drives; a file asking for more is refused.
pub const MAX_TARGETS: usize = 64;

/// The first 8 bytes of every `.mlod` file.
pub const MAGIC: [u8; 8] = *b"\x89MLD\r\n\x1a\n";
/// The newest format version this build reads and writes. Version 2 marks files with a
/// surface (`SURF`): their frames are attribute-level sequences whose LODs must snap to step
/// boundaries, which a version-1 reader would not do (it would show seams torn open), so such
/// a reader must refuse them. Files without a surface are still written as version 1.
pub const VERSION: u16 = 2;
/// The version of files without a surface (what every earlier build wrote).
pub const VERSION_PLAIN: u16 = 1;
/// Most frames a file may hold: far more than any animation needs. It does not bound
/// memory by itself (a repeated frame costs two bytes in the file); what does is that
/// equal frames share one sequence and the [`AssetLoadOptions::max_bytes`] budget.
pub const MAX_FRAMES: usize = 4096;

/// The memory budget [`AssetLoadOptions::default`] (and `DeformingModel::new`) uses: 4 GiB.
pub const DEFAULT_MAX_BYTES: u64 = 4 << 30;

/// How [`Asset::load_with`] and [`Asset::from_bytes_with`] read a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AssetLoadOptions {
    /// Most bytes the load may allocate (the file image included), estimated from the
    /// header, the section sizes and the frames' framing before anything large is
    /// allocated (see [`Asset::load_with`]); more gives [`AssetError::OverBudget`].
    /// Default [`DEFAULT_MAX_BYTES`] (4 GiB).
    pub max_bytes: u64,
}

impl Default for AssetLoadOptions {
    fn default() -> Self {
        AssetLoadOptions {
            max_bytes: DEFAULT_MAX_BYTES,
        }
    }
}
/// Size of the fixed header.
pub const HEADER_LEN: usize = 32;

pub(super) const TAG_V0: [u8; 4] = *b"V0  ";
pub(super) const TAG_V1: [u8; 4] = *b"V1  ";
pub(super) const TAG_S0: [u8; 4] = *b"S0  ";
pub(super) const TAG_FRAMES: [u8; 4] = *b"FRMS";
pub(super) const TAG_TARGETS: [u8; 4] = *b"TGTS";
pub(super) const TAG_SURFACE: [u8; 4] = *b"SURF";
pub(super) const TAG_TEXTURE: [u8; 4] = *b"TEXR";
pub(super) const TAG_SKIN: [u8; 4] = *b"SKIN";
pub(super) const SECTION_ENTRY_LEN: usize = 24;
/// More sections than any version will define: bounds the table before it is read.
pub(super) const MAX_SECTIONS: u32 = 64;

impl Asset {
    /// The format version [`Asset::to_bytes`] writes for this asset: [`VERSION`] with a
    /// surface, [`VERSION_PLAIN`] without (so such files stay readable by older builds).
    pub fn format_version(&self) -> u16 {
        if self.surface.is_some() {
            VERSION
        } else {
            VERSION_PLAIN
        }
    }

    /// The file bytes. Never fails: an asset that breaks the format's rules
    /// (a collapse out of range, decreasing strip offsets, ...) is written as
    /// is and refused by [`Asset::from_bytes`] with the matching error. Errors
    /// are kept at bfloat16 precision (see [`quantize_error`]); frames store
    /// the vertex count of `v0`.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut sections: Vec<([u8; 4], Vec<u8>)> = vec![
            (TAG_V0, pose_bytes(&self.v0)),
            (TAG_V1, pose_bytes(&self.v1)),
            (TAG_S0, encode_strips(&self.s0)),
            (
                TAG_FRAMES,
                encode_frames(&self.frames, &self.s0, self.v0.len()),
            ),
        ];
        if let Some(blend) = &self.blend {
            sections.push((TAG_TARGETS, encode_targets(blend)));
        }
        if let Some(surface) = &self.surface {
            sections.push((TAG_SURFACE, surface::encode_surface(surface)));
            if let Some(texture) = &surface.material.texture {
                sections.push((TAG_TEXTURE, surface::encode_texture(texture)));
            }
        }
        if let Some(skinning) = &self.skin {
            sections.push((TAG_SKIN, skin::encode_skin(skinning)));
        }

        let mut body = Vec::new();
        let mut offset = (sections.len() * SECTION_ENTRY_LEN) as u64;
        for (tag, data) in &sections {
            body.extend_from_slice(tag);
            body.extend_from_slice(&0u32.to_le_bytes());
            body.extend_from_slice(&offset.to_le_bytes());
            body.extend_from_slice(&(data.len() as u64).to_le_bytes());
            offset += data.len() as u64;
        }
        for (_, data) in &sections {
            body.extend_from_slice(data);
        }
        let mut out = Vec::with_capacity(HEADER_LEN + body.len());
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&self.format_version().to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out.extend_from_slice(&(sections.len() as u32).to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&body);
        out
    }

    /// Reads and validates a whole file image (see the module docs) under the default
    /// memory budget ([`AssetLoadOptions::default`]); see [`Asset::load_with`] for the
    /// memory the result takes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Asset, AssetError> {
        Asset::from_bytes_with(bytes, &AssetLoadOptions::default())
    }

    /// [`from_bytes`](Asset::from_bytes) under `options.max_bytes` (counting `bytes`
    /// themselves): see [`Asset::load_with`].
    pub fn from_bytes_with(bytes: &[u8], options: &AssetLoadOptions) -> Result<Asset, AssetError> {
        Ok(decode(bytes, options)?.0)
    }

    /// Number of distinct frame sequences (frames sharing one [`Arc`] count once):
    /// what the frames' memory grows with.
    pub fn distinct_frames(&self) -> usize {
        let mut seen: Vec<*const CollapseSequence> = self.frames.iter().map(Arc::as_ptr).collect();
        seen.sort_unstable();
        seen.dedup();
        seen.len()
    }

    /// Drops the decoded collapse sequences ([`frames`](Asset::frames)) and keeps the
    /// poses, the strips and the targets. A [`DeformingModel`](crate::DeformingModel) built
    /// from the asset holds everything the runtime needs from the sequences, and
    /// [`LodObject::new`](crate::gpu::LodObject) (and the contact sheets and the bench) read
    /// only the poses, strips and targets, so a renderer that keeps the asset for its GPU
    /// objects need not keep the sequences twice: 12 bytes per collapse of every distinct
    /// frame. Afterwards the asset has no frames: building a model from it fails with
    /// `DeformError::NoFrames` and it must not be saved.
    pub fn release_frames(&mut self) {
        self.frames = Vec::new();
    }

    /// Bytes the asset holds on the heap: poses, strips, each distinct frame once, the
    /// frame table and the targets' deltas (capacities and the small weight track are not
    /// counted).
    pub fn heap_bytes(&self) -> usize {
        let mut seen: Vec<&Arc<CollapseSequence>> = self.frames.iter().collect();
        seen.sort_unstable_by_key(|f| Arc::as_ptr(f));
        seen.dedup_by_key(|f| Arc::as_ptr(f));
        let frames: usize = seen
            .iter()
            .map(|f| std::mem::size_of::<CollapseSequence>() + 16 + f.collapses.len() * 12)
            .sum();
        let blend = self
            .blend
            .as_ref()
            .map_or(0, |b| b.deltas.iter().map(|d| d.len() * 12).sum::<usize>());
        (self.v0.len() + self.v1.len()) * 12
            + (self.s0.indices.len() + self.s0.offsets.len()) * 4
            + self.frames.len() * std::mem::size_of::<Arc<CollapseSequence>>()
            + frames
            + blend
            + self.surface.as_ref().map_or(0, Surface::heap_bytes)
            + self.skin.as_ref().map_or(0, |s| {
                let channels: usize = s.clip.channels.iter().map(|c| c.track.values.len()).sum();
                8 * s.skin.joints.len() + 4 * (s.skin.inverse_binds.len() + channels)
            })
    }

    /// Whether the asset loops: a skinned clip that ends where it starts. Its frames sample
    /// `t_k = k / |r|` and [`crate::DeformingModel::frame_at`] wraps from the last to the first.
    pub fn looping(&self) -> bool {
        self.skin.as_ref().is_some_and(|s| s.clip.looping)
    }

    /// The pose the runtime draws at `t ∈ [0, 1]` (clamped; NaN reads as 0), on the CPU: the
    /// two poses blended, `mix(V(0), V(1), t)`, or with targets `V(0) + Σ_k c_k(t) D_k`
    /// ([`TargetBlend`]); then for a skinned asset that pose skinned at the clip's time
    /// `t · duration` ([`Skinning::pose_at`]). The reference a GPU's pose is checked against.
    pub fn pose_at(&self, t: f32) -> Vec<[f32; 3]> {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let morphed: Vec<[f32; 3]> = match &self.blend {
            None => self
                .v0
                .iter()
                .zip(&self.v1)
                .map(|(a, b)| std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t))
                .collect(),
            Some(blend) => {
                let mut c = Vec::new();
                blend.track.offsets_at(t, &mut c);
                let mut out = self.v0.clone();
                for (deltas, &w) in blend.deltas.iter().zip(&c) {
                    for (p, d) in out.iter_mut().zip(deltas) {
                        for i in 0..3 {
                            p[i] += w * d[i];
                        }
                    }
                }
                out
            }
        };
        match &self.skin {
            None => morphed,
            Some(skinning) => skinning.pose_at(&morphed, t * skinning.clip.duration),
        }
    }

    /// Writes the file atomically (see [`save_bytes`]).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), AssetError> {
        save_bytes(path.as_ref(), &self.to_bytes())
    }

    /// Reads and validates a `.mlod` file under the default memory budget
    /// ([`DEFAULT_MAX_BYTES`]); see [`Asset::load_with`].
    pub fn load(path: impl AsRef<Path>) -> Result<Asset, AssetError> {
        Asset::load_with(path, &AssetLoadOptions::default())
    }

    /// Reads and validates a `.mlod` file, refusing with [`AssetError::OverBudget`]
    /// (before reading it, or before decoding anything large) a file whose load would
    /// allocate more than `options.max_bytes`.
    ///
    /// # Memory
    ///
    /// Equal frames share one sequence (a repeated frame, and any frame whose coded
    /// bytes equal an earlier frame's, is decoded once), so the loaded asset holds,
    /// with `F` the frame count, `D` the distinct frames and `n` the vertices,
    ///
    /// ```text
    /// heap bytes  ≤  4 · file bytes  +  12 · D · n  +  8 · F
    /// ```
    ///
    /// (poses and targets as stored, strip indices widened to `u32` from at least one
    /// byte each, at most `n − 1` collapses of 12 bytes per distinct frame, one pointer
    /// per frame). While loading, the file image and the decoder's scratch (neighbour
    /// lists, about 12 bytes per strip byte, and 8 · n bytes per decoding thread) come
    /// on top. The budget check uses the worse of these, computed from the section sizes
    /// and the frames' lengths before they are decoded (a frame of `b` bytes holds at
    /// most `8 · b / 3` collapses). `tests/asset_budget.rs` holds a crafted file to it (figures
    /// in BENCHMARKS.md, "Memory").
    pub fn load_with(
        path: impl AsRef<Path>,
        options: &AssetLoadOptions,
    ) -> Result<Asset, AssetError> {
        let path = path.as_ref();
        let io = |source| AssetError::Io {
            path: path.to_path_buf(),
            source,
        };
        let length = std::fs::metadata(path).map_err(io)?.len();
        if length > options.max_bytes {
            return Err(AssetError::OverBudget {
                needed: length,
                budget: options.max_bytes,
            });
        }
        let bytes = std::fs::read(path).map_err(io)?;
        Asset::from_bytes_with(&bytes, options)
    }
}

/// Writes `bytes` atomically: a temporary file in the same directory,
/// flushed, then renamed over `path`, so readers see the old file or the
/// whole new one, never a half-written one.
pub fn save_bytes(path: &Path, bytes: &[u8]) -> Result<(), AssetError> {
    let name = path
        .file_name()
        .map_or_else(|| "asset".into(), |n| n.to_string_lossy().into_owned());
    let temp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let written = std::fs::File::create(&temp).and_then(|mut file| {
        file.write_all(bytes)?;
        file.sync_all()
    });
    if let Err(source) = written.and_then(|()| std::fs::rename(&temp, path)) {
        // Best effort: the temporary may not exist if creating it failed.
        let _ = std::fs::remove_file(&temp);
        return Err(AssetError::Io {
            path: path.to_path_buf(),
            source,
        });
    }
    Ok(())
}

/// Reads and validates a file image (see the module docs): the asset, its section table
/// and its frames' sizes (what [`inspect`] reports).
fn decode(
    bytes: &[u8],
    options: &AssetLoadOptions,
) -> Result<(Asset, Vec<Section>, Vec<FrameInfo>), AssetError> {
    let (count, body) = check_header(bytes)?;
    let table = read_section_table(body, count)?;
    let section = |tag: [u8; 4]| -> Result<&[u8], AssetError> {
        table
            .iter()
            .find(|s| s.tag == tag)
            .map(|s| &body[s.start..s.end])
            .ok_or_else(|| AssetError::MissingSection { tag: tag_name(tag) })
    };
    // The frames' framing (count, lengths) first: with the section sizes it bounds
    // what the rest allocates, checked against the budget before any of it is.
    // (A missing or malformed "FRMS" is reported below, in its place among the checks.)
    if let Ok(parts) = section(TAG_FRAMES).and_then(frame_parts) {
        let needed = load_bytes_needed(bytes.len(), &table, &parts);
        if needed > options.max_bytes {
            return Err(AssetError::OverBudget {
                needed,
                budget: options.max_bytes,
            });
        }
    }
    let v0 = decode_pose(section(TAG_V0)?, "V0")?;
    let v1 = decode_pose(section(TAG_V1)?, "V1")?;
    if v0.len() != v1.len() {
        return Err(AssetError::PoseSizeMismatch {
            v0: v0.len(),
            v1: v1.len(),
        });
    }
    let n = v0.len();
    if n >= u32::MAX as usize {
        return Err(AssetError::TooManyVertices { vertices: n });
    }
    let s0 = decode_strips(section(TAG_S0)?, n)?;
    let neighbours = Neighbours::new(&s0, n);
    let parts = frame_parts(section(TAG_FRAMES)?)?;
    let (frames, frame_infos) = decode_frames(&parts, n, &neighbours)?;
    let blend = match section(TAG_TARGETS) {
        Ok(data) => Some(decode_targets(data, n)?),
        Err(_) => None,
    };
    let targets = blend.as_ref().map_or(0, |b| b.deltas.len());
    let surface = match (section(TAG_SURFACE), section(TAG_TEXTURE)) {
        (Ok(data), texture) => {
            let mut surface = surface::decode_surface(data, n, targets)?;
            if let Ok(texture) = texture {
                surface.material.texture = Some(surface::decode_texture(texture)?);
            }
            Some(surface)
        }
        (Err(_), Ok(_)) => return Err(AssetError::TextureWithoutSurface),
        (Err(_), Err(_)) => None,
    };
    let skin = match section(TAG_SKIN) {
        Ok(data) => Some(skin::decode_skin(data, n)?),
        Err(_) => None,
    };

    let mut asset = Asset {
        v0,
        v1,
        s0,
        frames,
        blend,
        surface: None,
        skin,
    };
    if let Some(surface) = surface {
        surface::check_surface(&asset, &surface)?;
        asset.surface = Some(surface);
    }
    Ok((asset, table, frame_infos))
}
/// Upper bound of the bytes [`decode`] allocates for a file of `file` bytes with this
/// section table and frame framing (see [`Asset::load_with`], "Memory").
fn load_bytes_needed(file: usize, table: &[Section], parts: &[FramePart]) -> u64 {
    let length = |tag: [u8; 4]| {
        table
            .iter()
            .find(|s| s.tag == tag)
            .map_or(0, |s| (s.end - s.start) as u64)
    };
    let n = length(TAG_V0) / 12;
    let poses = length(TAG_V0) + length(TAG_V1);
    // Strips: at most one index or offset per byte, 4 bytes each; the neighbour lists
    // (triangles, fans, offsets) about 40 bytes per index and 24 per vertex at most.
    let strips = 44 * length(TAG_S0) + 24 * n;
    let targets = 2 * length(TAG_TARGETS);
    // A skin: its joint indices widened to u32 (at most 4 bytes per stored byte).
    let skin = 4 * length(TAG_SKIN);
    // A surface: at most 4 bytes per stored byte (topology entries widened to u32), plus
    // the seam check's wedges (8 bytes per vertex) and the texture as stored.
    let surface = match length(TAG_SURFACE) {
        0 => 0,
        bytes => 4 * bytes + 8 * n + length(TAG_TEXTURE),
    };
    let mut distinct: Vec<&[u8]> = parts.iter().map(|p| p.bytes).collect();
    distinct.sort_unstable();
    distinct.dedup();
    // A collapse takes at least 3 bits (an index of at least one bit, two codes).
    let frames: u64 = distinct
        .iter()
        .map(|b| 12 * n.min(8 * b.len() as u64 / 3) + 64)
        .sum();
    let threads = (rayon::current_num_threads() as u64).min(distinct.len() as u64);
    let scratch = threads * 8 * n;
    let table_bytes = parts.len() as u64 * 64;
    file as u64 + poses + strips + targets + surface + skin + frames + scratch + table_bytes
}

pub(super) fn tag_name(tag: [u8; 4]) -> String {
    String::from_utf8_lossy(&tag).into_owned()
}

pub(super) fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

pub(super) fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

pub(super) fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from(u32_at(b, at)) | (u64::from(u32_at(b, at + 4)) << 32)
}
/// Magic, version, flags, length and checksum; returns the section count
/// and the body.
fn check_header(bytes: &[u8]) -> Result<(u32, &[u8]), AssetError> {
    let magic_len = bytes.len().min(MAGIC.len());
    if bytes[..magic_len] != MAGIC[..magic_len] {
        return Err(AssetError::WrongMagic {
            found: bytes[..magic_len].to_vec(),
        });
    }
    if bytes.len() < HEADER_LEN {
        return Err(AssetError::TruncatedHeader {
            length: bytes.len(),
        });
    }
    let version = u16_at(bytes, 8);
    if version > VERSION {
        return Err(AssetError::NewerVersion { found: version });
    }
    if version == 0 {
        return Err(AssetError::UnknownVersion { found: version });
    }
    let flags = u16_at(bytes, 10);
    if flags != 0 {
        return Err(AssetError::UnknownFlags { flags });
    }
    let expected = u64_at(bytes, 16);
    let found = (bytes.len() - HEADER_LEN) as u64;
    if found < expected {
        return Err(AssetError::TruncatedBody { expected, found });
    }
    if found > expected {
        return Err(AssetError::TrailingBytes { expected, found });
    }
    let body = &bytes[HEADER_LEN..];
    let stored = u32_at(bytes, 24);
    let computed = crc32fast::hash(body);
    if stored != computed {
        return Err(AssetError::Checksum { stored, computed });
    }
    Ok((u32_at(bytes, 12), body))
}

/// One entry of the section table: the tag and the byte range in the body.
pub(super) struct Section {
    pub(super) tag: [u8; 4],
    pub(super) start: usize,
    pub(super) end: usize,
}

/// The section table: each section's tag and byte range in the body, all
/// after the table. Unknown tags are kept (and skipped by the caller).
fn read_section_table(body: &[u8], count: u32) -> Result<Vec<Section>, AssetError> {
    let table_len = count as usize * SECTION_ENTRY_LEN;
    if count > MAX_SECTIONS || table_len > body.len() {
        return Err(AssetError::SectionTable {
            count,
            body: body.len() as u64,
        });
    }
    let mut table: Vec<Section> = Vec::with_capacity(count as usize);
    for entry in body[..table_len].chunks_exact(SECTION_ENTRY_LEN) {
        let tag = [entry[0], entry[1], entry[2], entry[3]];
        let offset = u64_at(entry, 8);
        let length = u64_at(entry, 16);
        let end = offset.checked_add(length);
        if offset < table_len as u64 || end.is_none_or(|e| e > body.len() as u64) {
            return Err(AssetError::SectionOutOfRange {
                tag: tag_name(tag),
                offset,
                length,
                start: table_len as u64,
                body: body.len() as u64,
            });
        }
        if table.iter().any(|s| s.tag == tag) {
            return Err(AssetError::DuplicateSection { tag: tag_name(tag) });
        }
        // Both fit in the body, so in usize.
        table.push(Section {
            tag,
            start: offset as usize,
            end: (offset + length) as usize,
        });
    }
    Ok(table)
}
