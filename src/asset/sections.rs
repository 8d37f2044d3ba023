//! The section codecs of the `.mlod` file: poses ("V0", "V1"), strips ("S0"), the frames
//! section's framing ("FRMS": count, lengths, repeats; each coded frame is
//! `frame_codec.rs`'s) and the GPU targets ("TGTS"); sections are read with the
//! bounds-checked [`Reader`](super::reader::Reader).

use super::frame_codec::{decode_frame, encode_frame, Neighbours, FRAME_CODED, FRAME_REPEAT};
use super::inspect::FrameInfo;
use super::reader::Reader;
use super::{u32_at, AssetError, MAX_FRAMES, MAX_TARGETS};
use crate::collapse::CollapseSequence;
use crate::morph::{Interpolation, TargetBlend, WeightTrack};
use crate::strip::Strips;
use crate::varint;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;

pub(super) fn pose_bytes(pose: &[[f32; 3]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(pose.len() * 12);
    for p in pose {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

pub(super) fn decode_pose(data: &[u8], pose: &'static str) -> Result<Vec<[f32; 3]>, AssetError> {
    if !data.len().is_multiple_of(12) {
        return Err(AssetError::SectionSize {
            tag: pose.to_string(),
            length: data.len() as u64,
            unit: 12,
        });
    }
    data.chunks_exact(12)
        .enumerate()
        .map(|(vertex, c)| {
            let value = [0, 4, 8].map(|at| f32::from_bits(u32_at(c, at)));
            if value.iter().all(|x| x.is_finite()) {
                Ok(value)
            } else {
                Err(AssetError::NonFinitePosition {
                    pose,
                    vertex,
                    value,
                })
            }
        })
        .collect()
}

pub(super) fn encode_targets(blend: &TargetBlend) -> Vec<u8> {
    let track = &blend.track;
    let mut out = vec![match track.interpolation() {
        Interpolation::Step => 0,
        Interpolation::Linear => 1,
        Interpolation::CubicSpline => 2,
    }];
    varint::put(&mut out, blend.deltas.len() as u64);
    varint::put(&mut out, track.keyframes() as u64);
    for v in track.times().iter().chain(track.values()) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for deltas in &blend.deltas {
        out.extend_from_slice(&pose_bytes(deltas));
    }
    out
}

/// The "TGTS" section: every size is fixed by the two counts and the vertex count, so the
/// whole length is checked before anything is allocated.
pub(super) fn decode_targets(data: &[u8], n: usize) -> Result<TargetBlend, AssetError> {
    let mut r = Reader::new(data, "TGTS");
    let interpolation = match r.byte(&|| "the interpolation".into())? {
        0 => Interpolation::Step,
        1 => Interpolation::Linear,
        2 => Interpolation::CubicSpline,
        code => return Err(AssetError::TargetInterpolation { code }),
    };
    let targets = r.count(&|| "the target count".into(), MAX_TARGETS)?;
    if targets == 0 {
        return Err(AssetError::TargetCount { targets });
    }
    let keyframes = r.count(&|| "the keyframe count".into(), r.remaining() / 4)?;
    let per_key = if interpolation == Interpolation::CubicSpline {
        3 * targets
    } else {
        targets
    };
    // keyframes ≤ bytes / 4 and targets ≤ 64 keep these products far below u64's range.
    let floats = keyframes as u64 * (1 + per_key as u64) + targets as u64 * n as u64 * 3;
    if floats * 4 != r.remaining() as u64 {
        return Err(AssetError::TargetSize {
            length: data.len(),
            targets,
            keyframes,
            vertices: n,
            expected: (data.len() - r.remaining()) as u64 + floats * 4,
        });
    }
    let mut floats = |count: usize, what: &'static str| -> Result<Vec<f32>, AssetError> {
        let bytes = r.bytes(count * 4, &|| what.into())?;
        Ok(bytes
            .chunks_exact(4)
            .map(|c| f32::from_bits(u32_at(c, 0)))
            .collect())
    };
    let times = floats(keyframes, "the keyframe times")?;
    let values = floats(keyframes * per_key, "the track values")?;
    let track = WeightTrack::new(interpolation, times, values, targets)
        .map_err(|source| AssetError::TargetTrack { source })?;
    let deltas = (0..targets)
        .map(|target| {
            let bytes = r.bytes(n * 12, &|| format!("the deltas of target {target}"))?;
            decode_pose(bytes, "TGTS").map_err(|e| match e {
                AssetError::NonFinitePosition { vertex, value, .. } => AssetError::NonFiniteDelta {
                    target,
                    vertex,
                    value,
                },
                other => other,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    r.finish()?;
    Ok(TargetBlend { deltas, track })
}

/// The "FRMS" section: the frame count, then per frame its byte length and its bytes
/// (a frame equal to the previous one is the single byte `FRAME_REPEAT`). Frames are
/// coded in parallel; the bytes do not depend on the thread count.
pub(super) fn encode_frames(frames: &[Arc<CollapseSequence>], s0: &Strips, n: usize) -> Vec<u8> {
    let neighbours = Neighbours::new(s0, n);
    let coded: Vec<Vec<u8>> = frames
        .par_iter()
        .enumerate()
        .map(|(k, seq)| {
            if k > 0 && (Arc::ptr_eq(&frames[k - 1], seq) || frames[k - 1] == *seq) {
                vec![FRAME_REPEAT]
            } else {
                encode_frame(seq, n, &neighbours)
            }
        })
        .collect();
    let mut out = Vec::new();
    varint::put(&mut out, coded.len() as u64);
    for f in &coded {
        varint::put(&mut out, f.len() as u64);
        out.extend_from_slice(f);
    }
    out
}

/// One frame of "FRMS" as stored: its bytes (mode byte first) and the bytes it takes
/// in the section, its length included.
pub(super) struct FramePart<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) stored: usize,
}

/// The framing of "FRMS": the frame count and each frame's bytes, nothing decoded.
/// Allocates one small entry per frame (at most [`MAX_FRAMES`]).
pub(super) fn frame_parts(data: &[u8]) -> Result<Vec<FramePart<'_>>, AssetError> {
    let mut r = Reader::new(data, "FRMS");
    // Each frame takes at least its length byte and its mode byte.
    let count = r.count(
        &|| "the frame count".into(),
        (data.len() / 2).min(MAX_FRAMES),
    )?;
    if count == 0 {
        return Err(AssetError::NoFrames);
    }
    let mut parts = Vec::with_capacity(count);
    for frame in 0..count {
        let start = r.pos;
        // The limit is what remains before the length itself is read, so the
        // read of the frame's bytes below checks again.
        let len = r.count(&|| format!("frame {frame}'s length"), r.remaining())?;
        let bytes = r.bytes(len, &|| format!("frame {frame}'s {len} bytes"))?;
        parts.push(FramePart {
            bytes,
            stored: r.pos - start,
        });
    }
    r.finish()?;
    Ok(parts)
}

/// Decodes the frames of [`frame_parts`]. A repeat shares the previous frame's
/// sequence, and a coded frame whose bytes equal an earlier coded frame's shares that
/// frame's sequence (decoding is a function of the bytes), so each distinct frame is
/// decoded and held once.
pub(super) fn decode_frames(
    parts: &[FramePart<'_>],
    n: usize,
    neighbours: &Neighbours,
) -> Result<(Vec<Arc<CollapseSequence>>, Vec<FrameInfo>), AssetError> {
    // `first[k]`: the first frame whose bytes equal frame k's.
    let mut seen: HashMap<&[u8], usize> = HashMap::new();
    let first: Vec<usize> = parts
        .iter()
        .enumerate()
        .map(|(k, p)| *seen.entry(p.bytes).or_insert(k))
        .collect();
    let decoded: Vec<Result<Option<Arc<CollapseSequence>>, AssetError>> = parts
        .par_iter()
        .enumerate()
        .map(|(frame, part)| {
            let bytes = part.bytes;
            match bytes.split_first() {
                Some((&FRAME_REPEAT, [])) => Ok(None),
                Some((&FRAME_CODED, _)) if first[frame] != frame => Ok(None),
                Some((&FRAME_CODED, rest)) => {
                    decode_frame(rest, frame, n, neighbours).map(|s| Some(Arc::new(s)))
                }
                Some((&FRAME_REPEAT, _)) => Err(AssetError::FrameLength {
                    frame,
                    declared: bytes.len(),
                    used: 1,
                }),
                Some((&mode, _)) => Err(AssetError::FrameMode { frame, mode }),
                None => Err(AssetError::Truncated {
                    tag: "FRMS",
                    what: format!("frame {frame}'s mode"),
                }),
            }
        })
        .collect();
    let mut frames: Vec<Arc<CollapseSequence>> = Vec::with_capacity(parts.len());
    let mut infos = Vec::with_capacity(parts.len());
    for (k, (result, part)) in decoded.into_iter().zip(parts).enumerate() {
        let repeat = part.bytes.first() == Some(&FRAME_REPEAT);
        let sequence = match result? {
            Some(sequence) => sequence,
            None if repeat => frames.last().cloned().ok_or(AssetError::RepeatFirstFrame)?,
            // A coded frame equal to an earlier one: that one decoded (or failed first).
            None => frames[first[k]].clone(),
        };
        infos.push(FrameInfo {
            collapses: sequence.len(),
            bytes: part.stored,
            repeat,
        });
        frames.push(sequence);
    }
    Ok((frames, infos))
}

/// Offsets as deltas (wrapping, so any `Strips` encodes; the decoder refuses
/// decreasing ones), indices as zigzag deltas: consecutive strip indices are
/// neighbours, usually numbered close together.
pub(super) fn encode_strips(s0: &Strips) -> Vec<u8> {
    let mut out = Vec::with_capacity(s0.indices.len() * 2);
    varint::put(&mut out, s0.indices.len() as u64);
    varint::put(&mut out, s0.offsets.len() as u64);
    let mut prev = 0u32;
    for &o in &s0.offsets {
        varint::put(&mut out, u64::from(o.wrapping_sub(prev)));
        prev = o;
    }
    let mut prev = 0i64;
    for &i in &s0.indices {
        varint::put(&mut out, varint::zigzag(i64::from(i) - prev));
        prev = i64::from(i);
    }
    out
}

pub(super) fn decode_strips(data: &[u8], n: usize) -> Result<Strips, AssetError> {
    let mut r = Reader::new(data, "S0");
    // Every index and offset takes at least one byte.
    let index_count = r.count(&|| "the index count".into(), data.len())?;
    let offset_count = r.count(&|| "the offset count".into(), r.remaining())?;
    let mut offsets = Vec::with_capacity(offset_count);
    let mut prev = 0u64;
    for strip in 0..offset_count {
        let delta = r.varint(&|| format!("offset {strip}"))?;
        // Deltas wrap at 32 bits (see `encode_strips`): undo that to report the offset written.
        let offset = (prev + delta) & 0xFFFF_FFFF;
        let first_nonzero = strip == 0 && offset != 0;
        if delta > u64::from(u32::MAX)
            || offset < prev
            || offset > index_count as u64
            || first_nonzero
        {
            return Err(AssetError::StripOffsets {
                strip,
                offset,
                previous: prev,
                indices: index_count,
            });
        }
        offsets.push(offset as u32);
        prev = offset;
    }
    if prev != index_count as u64 {
        return Err(AssetError::StripOffsets {
            strip: offset_count,
            offset: prev,
            previous: prev,
            indices: index_count,
        });
    }
    if index_count > r.remaining() {
        return Err(AssetError::CountTooLarge {
            tag: "S0",
            what: "the index count".into(),
            count: index_count as u64,
            limit: r.remaining() as u64,
        });
    }
    let mut indices = Vec::with_capacity(index_count);
    let mut prev = 0i64;
    for position in 0..index_count {
        let delta = varint::unzigzag(r.varint(&|| format!("index {position}"))?);
        let index = prev.wrapping_add(delta);
        if index < 0 || index >= n as i64 {
            return Err(AssetError::StripIndex {
                position,
                index: index as u64,
                vertices: n,
            });
        }
        indices.push(index as u32);
        prev = index;
    }
    r.finish()?;
    Ok(Strips { indices, offsets })
}
