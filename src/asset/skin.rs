//! The skin section of the `.mlod` file: a skinned asset's skin and clip ([`Skinning`]),
//! versioned and with its own CRC-32, stored once (the frames' poses are not: the runtime
//! skins `V(0)` plus the blended targets with the clip's joint matrices).
//!
//! ```text
//! "SKIN"  version u8 (1) | flags u8 (bit 0: the clip loops)
//!         | nodes N LEB128 | per node: parent + 1 LEB128 (0: a root) | rest 10 × f32
//!           (translation, rotation x y z w, scale) | name: byte length LEB128, UTF-8
//!         | joints J LEB128 | per joint its node LEB128 | J × 16 f32 inverse binds
//!           (column-major)
//!         | influences I u8 | joint index bytes W u8 (1 or 2) | vertices × I joint indices
//!           (W bytes each) | vertices × I f32 weights
//!         | clip name: byte length LEB128, UTF-8 | duration f32 | channels C LEB128
//!         | per channel: node LEB128 | property u8 (0 translation, 1 rotation, 2 scale)
//!           | interpolation u8 (0 STEP, 1 LINEAR, 2 CUBICSPLINE) | keys K LEB128
//!           | K × f32 times | K × (3 or 4) × (1, or 3 for CUBICSPLINE) f32 values
//!         | CRC-32 of everything before it, u32
//! ```
//!
//! Loading checks the CRC and the version, every count against the bytes left, and then the
//! skin and clip as [`Skinning::validate`] does (parents before children, finite unit
//! rotations, joints and channels on nodes that exist, invertible inverse binds, joint
//! indices in range, weights that sum to 1, strictly increasing key times).

use super::reader::Reader;
use super::surface::{floats, seal, unseal};
use super::{u32_at, AssetError};
use crate::morph::Interpolation;
use crate::skin::{
    Clip, JointChannel, NodeProperty, NodeTrack, Skeleton, Skin, Skinning, MAX_INFLUENCES,
    NO_PARENT, TRS,
};
use crate::varint;

/// The version of the "SKIN" section this build writes and the newest it reads.
pub const SKIN_VERSION: u8 = 1;

const LOOPING: u8 = 1;

const PROPERTIES: [NodeProperty; 3] = [
    NodeProperty::Translation,
    NodeProperty::Rotation,
    NodeProperty::Scale,
];
const INTERPOLATIONS: [Interpolation; 3] = [
    Interpolation::Step,
    Interpolation::Linear,
    Interpolation::CubicSpline,
];

fn text(out: &mut Vec<u8>, s: &str) {
    varint::put(out, s.len() as u64);
    out.extend_from_slice(s.as_bytes());
}

pub(super) fn encode_skin(skinning: &Skinning) -> Vec<u8> {
    let (skin, clip) = (&skinning.skin, &skinning.clip);
    let flags = if clip.looping { LOOPING } else { 0 };
    let mut out = vec![SKIN_VERSION, flags];
    let skeleton = &skin.skeleton;
    varint::put(&mut out, skeleton.node_count() as u64);
    for (node, &parent) in skeleton.parents.iter().enumerate() {
        let parent = if parent == NO_PARENT {
            0
        } else {
            parent as u64 + 1
        };
        varint::put(&mut out, parent);
        floats(
            &mut out,
            skeleton.rest[node * TRS..(node + 1) * TRS].iter().copied(),
        );
        text(&mut out, &skeleton.names[node]);
    }
    varint::put(&mut out, skin.joint_count() as u64);
    for &node in &skin.joint_nodes {
        varint::put(&mut out, u64::from(node));
    }
    floats(&mut out, skin.inverse_binds.iter().copied());
    let width: u8 = if skin.joint_count() <= 256 { 1 } else { 2 };
    out.extend_from_slice(&[skin.influences as u8, width]);
    for &j in &skin.joints {
        out.extend_from_slice(&j.to_le_bytes()[..width as usize]);
    }
    floats(&mut out, skin.weights.iter().copied());
    text(&mut out, &clip.name);
    floats(&mut out, [clip.duration]);
    varint::put(&mut out, clip.channels.len() as u64);
    for c in &clip.channels {
        let t = &c.track;
        varint::put(&mut out, u64::from(c.node));
        let property = PROPERTIES.iter().position(|&p| p == t.property);
        let interpolation = INTERPOLATIONS.iter().position(|&i| i == t.interpolation);
        out.extend_from_slice(&[property, interpolation].map(|code| code.unwrap_or(0) as u8));
        varint::put(&mut out, t.times.len() as u64);
        floats(&mut out, t.times.iter().chain(&t.values).copied());
    }
    seal(out)
}

/// `count` raw `f32`s.
fn read_floats(r: &mut Reader<'_>, count: usize, what: &str) -> Result<Vec<f32>, AssetError> {
    let bytes = r.bytes(count * 4, &|| what.to_string())?;
    Ok(bytes
        .chunks_exact(4)
        .map(|c| f32::from_bits(u32_at(c, 0)))
        .collect())
}

fn read_text(r: &mut Reader<'_>, what: &str) -> Result<String, AssetError> {
    let len = r.count(&|| format!("{what}'s length"), r.remaining())?;
    let bytes = r.bytes(len, &|| what.to_string())?;
    String::from_utf8(bytes.to_vec()).map_err(|_| AssetError::SkinName {
        what: what.to_string(),
    })
}

/// A code among `values` (its index).
fn code<T: Copy>(r: &mut Reader<'_>, values: &[T], what: &'static str) -> Result<T, AssetError> {
    let code = r.byte(&|| what.into())?;
    values
        .get(code as usize)
        .copied()
        .ok_or(AssetError::SkinCode { what, code })
}

/// Reads "SKIN" for an asset of `n` vertices, checked ([`Skinning::validate`]).
pub(super) fn decode_skin(data: &[u8], n: usize) -> Result<Skinning, AssetError> {
    let content = unseal(data, "SKIN", SKIN_VERSION)?;
    let mut r = Reader::new(content, "SKIN");
    let flags = r.byte(&|| "the flags".into())?;
    if flags & !LOOPING != 0 {
        return Err(AssetError::SkinFlags { flags });
    }
    // A node takes at least 42 bytes, a joint 65, a channel 3 and a key 8.
    let nodes = r.count(&|| "the node count".into(), r.remaining() / 42)?;
    let mut skeleton = Skeleton::default();
    for node in 0..nodes {
        let parent = r.count(&|| format!("node {node}'s parent"), nodes)?;
        skeleton.parents.push(match parent {
            0 => NO_PARENT,
            p => p as u32 - 1,
        });
        let rest = read_floats(&mut r, TRS, &format!("node {node}'s rest transform"))?;
        skeleton.rest.extend(rest);
        skeleton
            .names
            .push(read_text(&mut r, &format!("node {node}'s name"))?);
    }
    let joints = r.count(&|| "the joint count".into(), r.remaining() / 65)?;
    let joint_nodes = (0..joints)
        .map(|j| {
            r.count(&|| format!("joint {j}'s node"), u32::MAX as usize)
                .map(|v| v as u32)
        })
        .collect::<Result<Vec<u32>, AssetError>>()?;
    let inverse_binds = read_floats(&mut r, 16 * joints, "the inverse bind matrices")?;
    let influences = r.byte(&|| "the influence count".into())? as usize;
    let width = r.byte(&|| "the joint index width".into())?;
    if !(1..=2).contains(&width) {
        return Err(AssetError::SkinCode {
            what: "the joint index width",
            code: width,
        });
    }
    let slots = n * influences.min(MAX_INFLUENCES);
    if (r.remaining() as u64) < slots as u64 * (width as u64 + 4) {
        return Err(AssetError::Truncated {
            tag: "SKIN",
            what: format!("{influences} joints and weights of {n} vertices"),
        });
    }
    let indices = r.bytes(slots * width as usize, &|| "the vertices' joints".into())?;
    let vertex_joints = match width {
        1 => indices.iter().map(|&j| u32::from(j)).collect(),
        _ => indices
            .chunks_exact(2)
            .map(|c| u32::from(u16::from_le_bytes([c[0], c[1]])))
            .collect(),
    };
    let weights = read_floats(&mut r, slots, "the vertices' weights")?;
    let name = read_text(&mut r, "the clip's name")?;
    let duration = read_floats(&mut r, 1, "the clip's duration")?[0];
    let count = r.count(&|| "the channel count".into(), r.remaining() / 3)?;
    let mut channels = Vec::with_capacity(count);
    for channel in 0..count {
        let node = r.count(&|| format!("channel {channel}'s node"), u32::MAX as usize)? as u32;
        let property = code(&mut r, &PROPERTIES, "a channel's property")?;
        let interpolation = code(&mut r, &INTERPOLATIONS, "a channel's interpolation")?;
        let keys = r.count(&|| format!("channel {channel}'s keys"), r.remaining() / 8)?;
        let per_key = property.components()
            * if interpolation == Interpolation::CubicSpline {
                3
            } else {
                1
            };
        let times = read_floats(&mut r, keys, &format!("channel {channel}'s times"))?;
        let values = read_floats(
            &mut r,
            keys * per_key,
            &format!("channel {channel}'s values"),
        )?;
        channels.push(JointChannel {
            node,
            track: NodeTrack {
                property,
                interpolation,
                times,
                values,
            },
        });
    }
    r.finish()?;
    let skinning = Skinning {
        skin: Skin {
            skeleton,
            joint_nodes,
            inverse_binds,
            influences,
            joints: vertex_joints,
            weights,
        },
        clip: Clip {
            name,
            duration,
            looping: flags & LOOPING != 0,
            channels,
        },
    };
    skinning
        .validate(n)
        .map_err(|source| AssetError::Skin { source })?;
    Ok(skinning)
}
