//! The report of a `.mlod` file (`morphlod info`): its sections, frames and sizes, and
//! how they compare with the plain indexed mesh.

use super::{decode, tag_name, Asset, AssetError, AssetLoadOptions, HEADER_LEN, SECTION_ENTRY_LEN};
use crate::strip::strip_triangles;
use std::fmt;

/// One section of a file, for [`AssetInfo`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SectionInfo {
    pub tag: String,
    pub bytes: usize,
}

/// One frame of a file, for [`AssetInfo`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameInfo {
    /// LOD steps (collapses).
    pub collapses: usize,
    /// Encoded bytes, including its length prefix.
    pub bytes: usize,
    /// Stored as "same as the previous frame".
    pub repeat: bool,
}

/// What a `.mlod` file holds and where its bytes go.
#[derive(Clone, Debug, PartialEq)]
pub struct AssetInfo {
    pub version: u16,
    pub file_bytes: usize,
    pub header_bytes: usize,
    /// The section table itself.
    pub table_bytes: usize,
    pub sections: Vec<SectionInfo>,
    pub vertices: usize,
    /// Triangles drawn by `S0` at full detail.
    pub triangles: usize,
    pub strips: usize,
    pub strip_indices: usize,
    pub frames: Vec<FrameInfo>,
    /// Morph targets blended on the GPU (0 for a two-pose asset).
    pub targets: usize,
    /// For a skinned asset: its skin and clip.
    pub skin: Option<SkinInfo>,
}

/// A skinned asset's skin and clip, for [`AssetInfo`].
#[derive(Clone, Debug, PartialEq)]
pub struct SkinInfo {
    pub joints: usize,
    /// Skeleton nodes: the joints and their ancestors.
    pub nodes: usize,
    /// Joint and weight pairs per vertex.
    pub influences: usize,
    pub clip: String,
    /// Seconds.
    pub duration: f32,
    pub channels: usize,
    pub looping: bool,
}

impl AssetInfo {
    /// Frame bytes (all frames) per vertex per frame: the per-frame CPU data figure.
    pub fn frame_bytes_per_vertex(&self) -> f64 {
        let bytes: usize = self.frames.iter().map(|f| f.bytes).sum();
        bytes as f64 / (self.vertices.max(1) * self.frames.len().max(1)) as f64
    }

    /// Size of the plain indexed mesh (one f32x3 pose, u32 triangle list).
    pub fn indexed_mesh_bytes(&self) -> usize {
        self.vertices * 12 + self.triangles * 12
    }
}

impl fmt::Display for AssetInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let collapses: Vec<usize> = self.frames.iter().map(|f| f.collapses).collect();
        let repeats = self.frames.iter().filter(|f| f.repeat).count();
        writeln!(f, "  format version    {}", self.version)?;
        writeln!(
            f,
            "  mesh              {} vertices, {} triangles, {} strips ({} indices, {:.3} per triangle)",
            self.vertices,
            self.triangles,
            self.strips,
            self.strip_indices,
            self.strip_indices as f64 / self.triangles.max(1) as f64
        )?;
        writeln!(
            f,
            "  frames            {} ({} stored as repeats)",
            self.frames.len(),
            repeats
        )?;
        if self.targets > 0 {
            writeln!(
                f,
                "  GPU targets       {} (weight animation blended on the GPU)",
                self.targets
            )?;
        }
        if let Some(s) = &self.skin {
            writeln!(
                f,
                "  skin              {} joints ({} nodes), {} influences a vertex; clip '{}', {} s, {} channels{}",
                s.joints,
                s.nodes,
                s.influences,
                s.clip,
                s.duration,
                s.channels,
                if s.looping { ", a loop (frames at t = k/|r|)" } else { "" }
            )?;
        }
        writeln!(
            f,
            "  LODs per frame    min {}, max {}, mean {:.1}",
            collapses.iter().min().map_or(0, |&c| c + 1),
            collapses.iter().max().map_or(0, |&c| c + 1),
            collapses.iter().sum::<usize>() as f64 / collapses.len().max(1) as f64 + 1.0
        )?;
        writeln!(f, "  sizes")?;
        writeln!(f, "    header          {:>10} B", self.header_bytes)?;
        writeln!(f, "    section table   {:>10} B", self.table_bytes)?;
        for s in &self.sections {
            writeln!(f, "    {:<15} {:>10} B", s.tag.trim_end(), s.bytes)?;
        }
        writeln!(f, "    total           {:>10} B", self.file_bytes)?;
        writeln!(
            f,
            "  frame data        {:.3} B per vertex per frame, {:.3} B per collapse",
            self.frame_bytes_per_vertex(),
            self.frames.iter().map(|f| f.bytes).sum::<usize>() as f64
                / collapses.iter().sum::<usize>().max(1) as f64
        )?;
        write!(
            f,
            "  vs indexed mesh   {:.2}x the plain indexed mesh ({} B: f32 positions + u32 triangles)",
            self.file_bytes as f64 / self.indexed_mesh_bytes().max(1) as f64,
            self.indexed_mesh_bytes()
        )
    }
}

/// Reads and validates a file image like [`Asset::from_bytes`], and says
/// where its bytes went (under the default memory budget).
pub fn inspect(bytes: &[u8]) -> Result<(Asset, AssetInfo), AssetError> {
    inspect_with(bytes, &AssetLoadOptions::default())
}

/// [`inspect`] under `options`' memory budget (see [`Asset::load_with`]).
pub fn inspect_with(
    bytes: &[u8],
    options: &AssetLoadOptions,
) -> Result<(Asset, AssetInfo), AssetError> {
    let (asset, table, frame_infos) = decode(bytes, options)?;
    let (n, s0, blend) = (asset.v0.len(), &asset.s0, &asset.blend);
    let info = AssetInfo {
        version: u16::from_le_bytes([bytes[8], bytes[9]]),
        file_bytes: bytes.len(),
        header_bytes: HEADER_LEN,
        table_bytes: table.len() * SECTION_ENTRY_LEN,
        sections: table
            .iter()
            .map(|s| SectionInfo {
                tag: tag_name(s.tag),
                bytes: s.end - s.start,
            })
            .collect(),
        vertices: n,
        triangles: (0..s0.len())
            .filter_map(|i| s0.strip(i))
            .map(|s| strip_triangles(s).count())
            .sum(),
        strips: s0.len(),
        strip_indices: s0.indices.len(),
        frames: frame_infos,
        targets: blend.as_ref().map_or(0, |b| b.deltas.len()),
        skin: asset.skin.as_ref().map(|s| SkinInfo {
            joints: s.skin.joint_count(),
            nodes: s.skin.skeleton.node_count(),
            influences: s.skin.influences,
            clip: s.clip.name.clone(),
            duration: s.clip.duration,
            channels: s.clip.channels.len(),
            looping: s.clip.looping,
        }),
    };
    Ok((asset, info))
}
