//! The `.mlod` file: round trips of real built assets, one test per kind of
//! malformed file (asserting the error variant), and a proptest that mutates
//! the bytes of small real assets (with and without repairing the checksum, so
//! the deeper validation is reached) and asserts that decoding never panics.

use morphlod::asset::{inspect, AssetError, AssetLoadOptions, HEADER_LEN, MAGIC, VERSION};
use morphlod::build::Builder;
use morphlod::collapse::{Collapse, CollapseSequence, SequenceError};
use morphlod::io::LoadOptions;
use morphlod::io::{load_morph, MorphSource};
use morphlod::morph::{ImageFormat, Morph, Sampler, Texture};
use morphlod::strip::Strips;
use morphlod::Asset;
use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use crate::common;
use common::{cut_grid, fix_header, grid_morph};

fn asset_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name)
}

fn gltf_morph(name: &str, source: MorphSource) -> Morph {
    load_morph(&asset_path(name), &LoadOptions::default(), &source).unwrap()
}

/// AnimatedMorphCube's animation, 6 frames: small enough to mutate quickly.
fn cube() -> &'static (Asset, Vec<u8>) {
    static CUBE: OnceLock<(Asset, Vec<u8>)> = OnceLock::new();
    CUBE.get_or_init(|| {
        let morph = gltf_morph(
            "AnimatedMorphCube-glTF/AnimatedMorphCube.gltf",
            MorphSource::Animation("0".into()),
        );
        let (asset, _) = Builder::new(&morph).frames(6).build().unwrap();
        let bytes = asset.to_bytes();
        (asset, bytes)
    })
}

/// An 8×8 grid whose rows bend with `t`: interior vertices with full fans,
/// so the neighbour symbols of the frame coding are exercised.
fn grid() -> &'static (Asset, Vec<u8>) {
    static GRID: OnceLock<(Asset, Vec<u8>)> = OnceLock::new();
    GRID.get_or_init(|| {
        let morph = grid_morph(8, |x, y| ((x * x) as f32 * 0.1).sin() * y as f32);
        let (asset, _) = Builder::new(&morph).frames(4).build().unwrap();
        let bytes = asset.to_bytes();
        (asset, bytes)
    })
}

/// A file written by hand from raw sections: an independent writer of the
/// layout, for files the library's writer never makes.
fn file_with_sections(sections: &[(&[u8; 4], Vec<u8>)]) -> Vec<u8> {
    let mut body = Vec::new();
    let mut offset = (sections.len() * 24) as u64;
    for (tag, data) in sections {
        body.extend_from_slice(*tag);
        body.extend_from_slice(&[0; 4]);
        body.extend_from_slice(&offset.to_le_bytes());
        body.extend_from_slice(&(data.len() as u64).to_le_bytes());
        offset += data.len() as u64;
    }
    for (_, data) in sections {
        body.extend_from_slice(data);
    }
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&[0; 2]);
    out.extend_from_slice(&(sections.len() as u32).to_le_bytes());
    out.extend_from_slice(&[0; 12]);
    out.extend_from_slice(&[0; 4]);
    out.extend_from_slice(&body);
    fix_header(&mut out);
    out
}

/// The cut grid (a UV seam up its middle) with a texture: an asset with "SURF" and "TEXR".
fn seamed() -> &'static (Asset, Vec<u8>) {
    static SEAMED: OnceLock<(Asset, Vec<u8>)> = OnceLock::new();
    SEAMED.get_or_init(|| {
        let (mut asset, _) = Builder::new(&cut_grid(8)).frames(3).build().unwrap();
        let surface = asset.surface.as_mut().expect("UVs give a surface");
        surface.material.name = Some("skin".into());
        surface.material.texture = Some(Texture {
            format: ImageFormat::Png,
            bytes: b"\x89PNG not really an image: files carry the bytes as given".to_vec(),
            sampler: Sampler {
                mag_filter: Some(9729),
                ..Sampler::default()
            },
        });
        let bytes = asset.to_bytes();
        (asset, bytes)
    })
}

/// Recomputes the CRC-32 a surface section ends with, so an edit reaches the decoder.
fn reseal(section: &mut [u8]) {
    let len = section.len() - 4;
    let crc = crc32fast::hash(&section[..len]);
    section[len..].copy_from_slice(&crc.to_le_bytes());
}

fn tiny_asset() -> Asset {
    // Two triangles sharing the edge 0-2: one strip 1 0 2 3... as the stripifier would make it.
    let v = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    Asset {
        v0: v.clone(),
        v1: v,
        s0: Strips {
            indices: vec![1, 2, 0, 3],
            offsets: vec![0, 4],
        },
        frames: vec![Arc::new(CollapseSequence {
            vertex_count: 4,
            collapses: vec![Collapse {
                u: 3,
                w: 0,
                error: 0.5,
            }],
        })],
        blend: None,
        surface: None,
        skin: None,
    }
}

#[test]
fn real_assets_round_trip() {
    for (asset, bytes) in [cube(), grid()] {
        assert_eq!(&Asset::from_bytes(bytes).unwrap(), asset);
    }
    let head = gltf_morph("makehuman_head.glb", MorphSource::Target("jawOpen".into()));
    let (asset, report) = Builder::new(&head).frames(3).build().unwrap();
    assert_eq!(report.collapses.len(), 3);
    let bytes = asset.to_bytes();
    let (decoded, info) = inspect(&bytes).unwrap();
    assert_eq!(decoded, asset);
    assert_eq!(info.vertices, 4_437);
    assert_eq!(info.triangles, 8_818);
    assert_eq!(info.frames.len(), 3);
    assert_eq!(info.file_bytes, bytes.len());
    // The frame coding is the point of the format: well under the 4.8 B goal.
    assert!(
        info.frame_bytes_per_vertex() < 4.8,
        "{}",
        info.frame_bytes_per_vertex()
    );

    let path = std::env::temp_dir().join(format!("morphlod-test-{}.mlod", std::process::id()));
    asset.save(&path).unwrap();
    let loaded = Asset::load(&path);
    std::fs::remove_file(&path).unwrap();
    assert_eq!(loaded.unwrap(), asset);
}

#[test]
fn repeated_frames_are_stored_once() {
    let mut asset = grid().0.clone();
    let first = asset.frames[0].clone();
    asset.frames = vec![first.clone(), first.clone(), first];
    let bytes = asset.to_bytes();
    let (decoded, info) = inspect(&bytes).unwrap();
    assert_eq!(decoded, asset);
    let repeats: Vec<bool> = info.frames.iter().map(|f| f.repeat).collect();
    assert_eq!(repeats, [false, true, true]);
    assert_eq!(info.frames[1].bytes, 2);
}

#[test]
fn escapes_round_trip() {
    // 3 → 1 is not an edge of S0: w must be written through the escape.
    let mut asset = tiny_asset();
    Arc::make_mut(&mut asset.frames[0]).collapses = vec![
        Collapse {
            u: 3,
            w: 1,
            error: 0.25,
        },
        Collapse {
            u: 0,
            w: 2,
            error: 0.125,
        },
    ];
    assert_eq!(Asset::from_bytes(&asset.to_bytes()).unwrap(), asset);
}

#[test]
fn wrong_magic() {
    let mut bytes = cube().1.clone();
    bytes[1] = b'X';
    assert!(matches!(
        Asset::from_bytes(&bytes),
        Err(AssetError::WrongMagic { .. })
    ));
    assert!(matches!(
        Asset::from_bytes(b"solid cube\n"),
        Err(AssetError::WrongMagic { .. })
    ));
}

#[test]
fn newer_version_asks_for_an_upgrade() {
    let mut bytes = cube().1.clone();
    bytes[8..10].copy_from_slice(&(VERSION + 1).to_le_bytes());
    let err = Asset::from_bytes(&bytes).unwrap_err();
    assert!(
        matches!(err, AssetError::NewerVersion { found } if found == VERSION + 1),
        "{err}"
    );
    assert!(err.to_string().contains("upgrade morphlod"));
}

#[test]
fn unknown_flags() {
    let mut bytes = cube().1.clone();
    bytes[10] = 1;
    assert!(matches!(
        Asset::from_bytes(&bytes),
        Err(AssetError::UnknownFlags { flags: 1 })
    ));
}

#[test]
fn truncated_header() {
    let bytes = &cube().1[..20];
    assert!(matches!(
        Asset::from_bytes(bytes),
        Err(AssetError::TruncatedHeader { length: 20 })
    ));
    assert!(matches!(
        Asset::from_bytes(&MAGIC[..5]),
        Err(AssetError::TruncatedHeader { length: 5 })
    ));
}

#[test]
fn truncated_body_and_trailing_bytes() {
    let bytes = &cube().1;
    let cut = &bytes[..bytes.len() - 10];
    assert!(matches!(
        Asset::from_bytes(cut),
        Err(AssetError::TruncatedBody { expected, found }) if expected == found + 10
    ));
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(matches!(
        Asset::from_bytes(&longer),
        Err(AssetError::TrailingBytes { .. })
    ));
}

#[test]
fn checksum_mismatch() {
    let mut bytes = cube().1.clone();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x10;
    assert!(matches!(
        Asset::from_bytes(&bytes),
        Err(AssetError::Checksum { .. })
    ));
}

#[test]
fn strip_index_out_of_range_with_valid_checksum() {
    let mut asset = tiny_asset();
    asset.s0.indices[2] = 9;
    assert!(matches!(
        Asset::from_bytes(&asset.to_bytes()),
        Err(AssetError::StripIndex {
            position: 2,
            index: 9,
            vertices: 4
        })
    ));
}

#[test]
fn collapse_out_of_range_with_valid_checksum() {
    let mut asset = tiny_asset();
    Arc::make_mut(&mut asset.frames[0]).collapses[0].w = 7;
    assert!(matches!(
        Asset::from_bytes(&asset.to_bytes()),
        Err(AssetError::Sequence {
            frame: 0,
            source: SequenceError::VertexOutOfRange { vertex: 7, .. }
        })
    ));
}

#[test]
fn strip_offsets_decreasing() {
    let mut asset = tiny_asset();
    asset.s0.offsets = vec![0, 3, 2, 4];
    assert!(matches!(
        Asset::from_bytes(&asset.to_bytes()),
        Err(AssetError::StripOffsets {
            strip: 2,
            offset: 2,
            previous: 3,
            ..
        })
    ));
    // Offsets that stop short of the indices leave indices in no strip.
    asset.s0.offsets = vec![0, 3];
    assert!(matches!(
        Asset::from_bytes(&asset.to_bytes()),
        Err(AssetError::StripOffsets { .. })
    ));
}

#[test]
fn sequence_collapsing_a_vertex_twice() {
    let mut asset = tiny_asset();
    Arc::make_mut(&mut asset.frames[0]).collapses = vec![
        Collapse {
            u: 3,
            w: 0,
            error: 0.0,
        },
        Collapse {
            u: 3,
            w: 2,
            error: 0.0,
        },
    ];
    assert!(matches!(
        Asset::from_bytes(&asset.to_bytes()),
        Err(AssetError::Sequence {
            frame: 0,
            source: SequenceError::AlreadyCollapsed {
                step: 1,
                vertex: 3,
                earlier: 0
            }
        })
    ));
    // Onto a vertex that is gone is refused the same way.
    Arc::make_mut(&mut asset.frames[0]).collapses[1] = Collapse {
        u: 1,
        w: 3,
        error: 0.0,
    };
    assert!(matches!(
        Asset::from_bytes(&asset.to_bytes()),
        Err(AssetError::Sequence {
            source: SequenceError::AlreadyCollapsed { vertex: 3, .. },
            ..
        })
    ));
}

#[test]
fn huge_counts_in_tiny_bodies() {
    let pose = vec![0u8; 12 * 4];
    let strips = tiny_asset();
    let s0 = {
        // Take the library's S0 bytes from a real file's section.
        let bytes = strips.to_bytes();
        let table = &bytes[HEADER_LEN..];
        let offset = u64::from_le_bytes(table[48 + 8..48 + 16].try_into().unwrap()) as usize;
        let length = u64::from_le_bytes(table[48 + 16..48 + 24].try_into().unwrap()) as usize;
        table[offset..offset + length].to_vec()
    };
    // 2^62 frames in a 10-byte section.
    let huge = vec![0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x40];
    let file = file_with_sections(&[
        (b"V0  ", pose.clone()),
        (b"V1  ", pose.clone()),
        (b"S0  ", s0.clone()),
        (b"FRMS", huge.clone()),
    ]);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::CountTooLarge { tag: "FRMS", .. })
    ));
    // 2^62 strip indices.
    let file = file_with_sections(&[
        (b"V0  ", pose.clone()),
        (b"V1  ", pose.clone()),
        (b"S0  ", huge.clone()),
        (b"FRMS", vec![1, 1, 0]),
    ]);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::CountTooLarge { tag: "S0", .. })
    ));
    // A frame claiming 2^62 collapses over 4 vertices (with bits for 16).
    let mut frame = vec![1, 2, 0, 0];
    frame.extend_from_slice(&huge);
    frame.extend_from_slice(&[0; 8]);
    let mut frames = vec![1, frame.len() as u8];
    frames.extend_from_slice(&frame);
    let file = file_with_sections(&[
        (b"V0  ", pose.clone()),
        (b"V1  ", pose.clone()),
        (b"S0  ", s0),
        (b"FRMS", frames.clone()),
    ]);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::CountTooLarge { tag: "FRMS", count, limit: 4, .. }) if count == 1 << 62
    ));
    // 4 collapses claimed, bits for 1 only: refused before allocating.
    let mut frame = vec![1, 2, 0, 0, 4, 0];
    let mut frames = vec![1, frame.len() as u8];
    frames.append(&mut frame);
    let file = file_with_sections(&[
        (b"V0  ", vec![0u8; 48]),
        (b"V1  ", vec![0u8; 48]),
        (b"S0  ", vec![0, 0]),
        (b"FRMS", frames),
    ]);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::CountTooLarge {
            tag: "FRMS",
            count: 4,
            limit: 2,
            ..
        })
    ));
    // A section table of 2^32 - 1 entries.
    let mut file = file_with_sections(&[(b"V0  ", pose)]);
    file[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::SectionTable { .. })
    ));
}

#[test]
fn sections_missing_out_of_range_or_twice() {
    let pose = vec![0u8; 12];
    let file = file_with_sections(&[(b"V0  ", pose.clone()), (b"V1  ", pose.clone())]);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::MissingSection { tag }) if tag == "S0  "
    ));
    let file = file_with_sections(&[(b"V0  ", pose.clone()), (b"V0  ", pose.clone())]);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::DuplicateSection { .. })
    ));
    let mut file = file_with_sections(&[(b"V0  ", pose.clone())]);
    // The section's length (bytes 16..24 of its entry) past the body.
    file[HEADER_LEN + 16] = 200;
    fix_header(&mut file);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::SectionOutOfRange { .. })
    ));
    let file = file_with_sections(&[(b"V0  ", vec![0; 13])]);
    assert!(matches!(
        Asset::from_bytes(&file),
        Err(AssetError::SectionSize { unit: 12, .. })
    ));
}

#[test]
fn frames_repeat_nothing_or_are_missing() {
    let asset = tiny_asset();
    let s0 = {
        let bytes = asset.to_bytes();
        let table = &bytes[HEADER_LEN..];
        let offset = u64::from_le_bytes(table[48 + 8..48 + 16].try_into().unwrap()) as usize;
        let length = u64::from_le_bytes(table[48 + 16..48 + 24].try_into().unwrap()) as usize;
        table[offset..offset + length].to_vec()
    };
    let pose = vec![0u8; 48];
    let with_frames = |frames: Vec<u8>| {
        file_with_sections(&[
            (b"V0  ", pose.clone()),
            (b"V1  ", pose.clone()),
            (b"S0  ", s0.clone()),
            (b"FRMS", frames),
        ])
    };
    assert!(matches!(
        Asset::from_bytes(&with_frames(vec![1, 1, 0])),
        Err(AssetError::RepeatFirstFrame)
    ));
    assert!(matches!(
        Asset::from_bytes(&with_frames(vec![0])),
        Err(AssetError::NoFrames)
    ));
    assert!(matches!(
        Asset::from_bytes(&with_frames(vec![1, 1, 7])),
        Err(AssetError::FrameMode { frame: 0, mode: 7 })
    ));
    // A NaN error: bfloat16 0x7FC0, reached by a delta from 0 (exp-Golomb order 0
    // of zigzag 0xFF80 needs 33 bits: 16 zeros, then 17 bits).
    let mut bits: Vec<bool> = Vec::new();
    let push = |bits: &mut Vec<bool>, value: u64, count: u32| {
        for i in 0..count {
            bits.push(value >> i & 1 == 1);
        }
    };
    push(&mut bits, 3, 3); // u = 3 (width 3)
    push(&mut bits, 0b1, 1); // symbol 0 at order 0: the first neighbour of 3
    let v = 0x7FC0u64 * 2 + 1;
    let digits = 64 - v.leading_zeros();
    push(&mut bits, 1 << (digits - 1), digits); // zeros then the 1
    push(&mut bits, v, digits - 1);
    let mut frame = vec![1, 3, 0, 0, 1];
    frame.extend(bits.chunks(8).map(|c| {
        c.iter()
            .enumerate()
            .fold(0u8, |acc, (i, &b)| acc | (u8::from(b) << i))
    }));
    let mut frames = vec![1, frame.len() as u8];
    frames.extend_from_slice(&frame);
    assert!(matches!(
        Asset::from_bytes(&with_frames(frames)),
        Err(AssetError::BadError {
            frame: 0,
            step: 0,
            ..
        })
    ));
}

/// The sections of a file the library wrote, read back through its table.
fn sections_of(bytes: &[u8]) -> Vec<([u8; 4], Vec<u8>)> {
    let count = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let body = &bytes[HEADER_LEN..];
    (0..count)
        .map(|i| {
            let entry = &body[i * 24..(i + 1) * 24];
            let offset = u64::from_le_bytes(entry[8..16].try_into().unwrap()) as usize;
            let length = u64::from_le_bytes(entry[16..24].try_into().unwrap()) as usize;
            (
                entry[..4].try_into().unwrap(),
                body[offset..offset + length].to_vec(),
            )
        })
        .collect()
}

#[test]
fn animation_targets_round_trip_and_bad_target_sections_are_refused() {
    // The cube's asset comes from its weight animation: its targets travel in "TGTS".
    let (cube, bytes) = cube();
    let blend = cube
        .blend
        .as_ref()
        .expect("an animated asset keeps its targets");
    assert_eq!(blend.deltas.len(), 2);
    assert_eq!(inspect(bytes).unwrap().1.targets, 2);
    assert!(sections_of(bytes).iter().any(|(tag, _)| tag == b"TGTS"));
    assert!(!sections_of(&grid().1).iter().any(|(tag, _)| tag == b"TGTS"));

    // The tiny asset (4 vertices) with a hand-written "TGTS": LINEAR, one target, two keys.
    let base: Vec<([u8; 4], Vec<u8>)> = sections_of(&tiny_asset().to_bytes());
    let floats =
        |values: &[f32]| -> Vec<u8> { values.iter().flat_map(|v| v.to_le_bytes()).collect() };
    let section =
        |interpolation: u8, targets: u8, times: &[f32], values: &[f32], deltas: &[f32]| {
            let mut data = vec![interpolation, targets, times.len() as u8];
            data.extend(floats(times));
            data.extend(floats(values));
            data.extend(floats(deltas));
            data
        };
    let file = |targets: Vec<u8>| {
        let mut sections: Vec<(&[u8; 4], Vec<u8>)> =
            base.iter().map(|(tag, data)| (tag, data.clone())).collect();
        sections.push((b"TGTS", targets));
        file_with_sections(&sections)
    };
    let deltas = [0.0, 0.0, 1.0].repeat(4);
    let good = Asset::from_bytes(&file(section(1, 1, &[0.0, 2.0], &[0.0, 1.0], &deltas))).unwrap();
    let blend = good.blend.unwrap();
    assert_eq!(blend.deltas, vec![vec![[0.0, 0.0, 1.0]; 4]]);
    assert_eq!(blend.track.keyframes(), 2);

    let err = |data: Vec<u8>| Asset::from_bytes(&file(data)).unwrap_err();
    assert!(matches!(
        err(section(7, 1, &[0.0, 2.0], &[0.0, 1.0], &deltas)),
        AssetError::TargetInterpolation { code: 7 }
    ));
    assert!(matches!(
        err(section(1, 0, &[0.0, 2.0], &[0.0, 1.0], &[])),
        AssetError::TargetCount { targets: 0 }
    ));
    assert!(matches!(
        err(section(1, 65, &[0.0, 2.0], &[0.0, 1.0], &deltas)),
        AssetError::CountTooLarge { .. }
    ));
    assert!(matches!(
        err(section(1, 1, &[0.0, 2.0], &[0.0, 1.0], &deltas[..11])),
        AssetError::TargetSize {
            targets: 1,
            keyframes: 2,
            vertices: 4,
            ..
        }
    ));
    assert!(matches!(
        err(section(1, 1, &[2.0, 0.0], &[0.0, 1.0], &deltas)),
        AssetError::TargetTrack { .. }
    ));
    assert!(matches!(
        err(section(1, 1, &[0.0, 2.0], &[0.0, f32::NAN], &deltas)),
        AssetError::TargetTrack { .. }
    ));
    let mut bad_delta = deltas.clone();
    bad_delta[7] = f32::INFINITY;
    assert!(matches!(
        err(section(1, 1, &[0.0, 2.0], &[0.0, 1.0], &bad_delta)),
        AssetError::NonFiniteDelta {
            target: 0,
            vertex: 2,
            ..
        }
    ));
}

#[test]
fn surfaces_round_trip_and_old_files_have_none() {
    let (asset, bytes) = seamed();
    let tags: Vec<[u8; 4]> = sections_of(bytes).iter().map(|(t, _)| *t).collect();
    assert!(tags.contains(b"SURF") && tags.contains(b"TEXR"));
    let back = Asset::from_bytes(bytes).unwrap();
    assert_eq!(&back, asset);
    assert_eq!(back.to_bytes(), *bytes);
    assert!(inspect(bytes).is_ok());
    // A surface without a texture writes no "TEXR".
    let mut plain = asset.clone();
    plain.surface.as_mut().unwrap().material.texture = None;
    let plain_bytes = plain.to_bytes();
    assert!(!sections_of(&plain_bytes).iter().any(|(t, _)| t == b"TEXR"));
    assert_eq!(Asset::from_bytes(&plain_bytes).unwrap(), plain);
    // Assets without attributes write neither section.
    assert!(grid().0.surface.is_none());
    assert!(!sections_of(&grid().1)
        .iter()
        .any(|(t, _)| t == b"SURF" || t == b"TEXR"));
    // A surface makes the file version 2, which a version-1 reader refuses (it would show
    // the attribute-level LODs between step boundaries, seams torn open); without one the
    // file stays version 1, readable by every earlier build.
    let version = |b: &[u8]| u16::from_le_bytes([b[8], b[9]]);
    assert_eq!(version(bytes), 2);
    assert_eq!(version(&grid().1), 1);
    assert_eq!(inspect(bytes).unwrap().1.version, 2);
}

#[test]
fn damaged_surface_sections_are_refused() {
    let (asset, bytes) = seamed();
    let n = asset.v0.len();
    assert!(n < 128, "one-byte topology entries below");
    let original = sections_of(bytes);
    // The file with section `tag` edited (and the file's header repaired).
    let edited = |tag: &[u8; 4], edit: &dyn Fn(&mut Vec<u8>)| {
        let sections: Vec<([u8; 4], Vec<u8>)> = original
            .iter()
            .map(|(t, d)| {
                let mut d = d.clone();
                if t == tag {
                    edit(&mut d);
                }
                (*t, d)
            })
            .collect();
        let refs: Vec<(&[u8; 4], Vec<u8>)> = sections.iter().map(|(t, d)| (t, d.clone())).collect();
        Asset::from_bytes(&file_with_sections(&refs))
    };
    let err = |tag: &[u8; 4], edit: &dyn Fn(&mut Vec<u8>)| edited(tag, edit).unwrap_err();
    // Unchanged, the hand-written file loads.
    assert_eq!(&edited(b"SURF", &|_| {}).unwrap(), asset);

    // A flipped byte: that section's own checksum names it.
    for tag in [b"SURF", b"TEXR"] {
        assert!(matches!(
            err(tag, &|d| d[5] ^= 0x10),
            AssetError::SectionChecksum { tag: t, .. } if t.as_bytes() == tag
        ));
    }
    // Truncated (resealed): the reader says what it was reading, or that a length is past
    // the data.
    for tag in [b"SURF", b"TEXR"] {
        let e = err(tag, &|d| {
            d.truncate(d.len() / 2);
            reseal(d);
        });
        assert!(
            matches!(
                e,
                AssetError::Truncated { .. } | AssetError::CountTooLarge { .. }
            ),
            "{e}"
        );
    }
    assert!(matches!(
        err(b"SURF", &|d| d.truncate(3)),
        AssetError::Truncated { tag: "SURF", .. }
    ));
    // A version from the future, and one that never existed.
    for version in [0u8, 2] {
        assert!(matches!(
            err(b"SURF", &|d| {
                d[0] = version;
                reseal(d);
            }),
            AssetError::SectionVersion { tag: "SURF", found, .. } if found == version
        ));
    }
    assert!(matches!(
        err(b"SURF", &|d| {
            d[1] |= 0x80;
            reseal(d);
        }),
        AssetError::SurfaceFlags { .. }
    ));
    // Vertex 0's topology vertex past the count (entries start at byte 3).
    assert!(matches!(
        err(b"SURF", &|d| {
            d[3] = d[2];
            reseal(d);
        }),
        AssetError::SurfaceTopology { vertex: 0, .. }
    ));
    // Two vertices that do not coincide welded into one.
    assert!(matches!(
        err(b"SURF", &|d| {
            d[4] = d[3];
            reseal(d);
        }),
        AssetError::SurfaceWeld {
            vertex: 1,
            first: 0
        }
    ));
    // A NaN normal (n0 of vertex 2, x).
    assert!(matches!(
        err(b"SURF", &|d| {
            let at = 3 + n + 2 * 12;
            d[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
            reseal(d);
        }),
        AssetError::NonFiniteAttribute {
            attribute: "n0",
            vertex: 2
        }
    ));
    // Normal deltas for a target the asset does not blend.
    assert!(matches!(
        err(b"SURF", &|d| {
            let at = 3 + n + 24 * n;
            d[at] = 1;
            reseal(d);
        }),
        AssetError::NormalDeltaCount {
            found: 1,
            targets: 0
        }
    ));
    assert!(matches!(
        err(b"TEXR", &|d| {
            d[1] = 9;
            reseal(d);
        }),
        AssetError::TextureFormat { code: 9 }
    ));
    // A texture with nothing to map it.
    let without_surface: Vec<(&[u8; 4], Vec<u8>)> = original
        .iter()
        .filter(|(t, _)| t != b"SURF")
        .map(|(t, d)| (t, d.clone()))
        .collect();
    assert!(matches!(
        Asset::from_bytes(&file_with_sections(&without_surface)),
        Err(AssetError::TextureWithoutSurface)
    ));
}

/// The load budget counts the surface: the smallest budget that loads the asset without
/// its surface refuses it with its surface, and a budget of the plain need plus four times the
/// surface's section bytes plus 8 bytes per vertex loads it.
#[test]
fn the_load_budget_counts_the_surface() {
    let (asset, bytes) = seamed();
    let mut plain = asset.clone();
    plain.surface = None;
    let plain_bytes = plain.to_bytes();
    let loads = |bytes: &[u8], max_bytes: u64| {
        Asset::from_bytes_with(bytes, &AssetLoadOptions { max_bytes }).is_ok()
    };
    let (mut lo, mut hi) = (0u64, 1 << 30);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if loads(&plain_bytes, mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    assert!(matches!(
        Asset::from_bytes_with(bytes, &AssetLoadOptions { max_bytes: lo }),
        Err(AssetError::OverBudget { .. })
    ));
    let sections = sections_of(bytes);
    let length = |tag: &[u8; 4]| sections.iter().find(|(t, _)| t == tag).unwrap().1.len() as u64;
    let surface = 4 * length(b"SURF") + length(b"TEXR") + 8 * asset.v0.len() as u64;
    let file_growth = (bytes.len() - plain_bytes.len()) as u64;
    assert!(loads(bytes, lo + surface + file_growth));
}

/// A frame that moves only some copies of a seam vertex in a step is refused on load.
#[test]
fn frames_that_split_a_seam_are_refused() {
    let (asset, _) = seamed();
    let topology = &asset.surface.as_ref().unwrap().topology;
    // A collapse of a step of more than one collapse, moved to the front (the first such
    // move that leaves a valid sequence).
    let c = &asset.frames[1].collapses;
    let frame = (1..c.len())
        .filter(|&i| topology[c[i].u as usize] == topology[c[i - 1].u as usize])
        .map(|i| {
            let mut f = (*asset.frames[1]).clone();
            let moved = f.collapses.remove(i);
            f.collapses.insert(0, moved);
            f
        })
        .find(|f| f.validate().is_ok())
        .expect("some step's collapse can go first");
    let mut broken = asset.clone();
    broken.frames[1] = Arc::new(frame);
    assert!(matches!(
        Asset::from_bytes(&broken.to_bytes()),
        Err(AssetError::SurfaceSteps { frame: 1, .. })
    ));
}

#[derive(Clone, Debug)]
enum Mutation {
    Flip { at: usize, bit: u8 },
    Truncate { len: usize },
    Insert { at: usize, byte: u8 },
    Remove { at: usize },
    Overwrite { at: usize, value: u64 },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0..8u8).prop_map(|(at, bit)| Mutation::Flip { at, bit }),
        any::<usize>().prop_map(|len| Mutation::Truncate { len }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Mutation::Insert { at, byte }),
        any::<usize>().prop_map(|at| Mutation::Remove { at }),
        (
            any::<usize>(),
            prop_oneof![
                Just(u64::MAX),
                Just(u64::from(u32::MAX)),
                Just(1u64 << 40),
                any::<u64>()
            ]
        )
            .prop_map(|(at, value)| Mutation::Overwrite { at, value }),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let len = bytes.len().max(1);
    match *m {
        Mutation::Flip { at, bit } => {
            if let Some(b) = bytes.get_mut(at % len) {
                *b ^= 1 << bit;
            }
        }
        Mutation::Truncate { len: keep } => bytes.truncate(keep % len),
        Mutation::Insert { at, byte } => bytes.insert(at % (bytes.len() + 1), byte),
        Mutation::Remove { at } => {
            if !bytes.is_empty() {
                bytes.remove(at % len);
            }
        }
        Mutation::Overwrite { at, value } => {
            let at = at % len;
            for (i, b) in value.to_le_bytes().iter().enumerate() {
                if let Some(x) = bytes.get_mut(at + i) {
                    *x = *b;
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// No byte string panics the decoder. With the header repaired the
    /// mutation reaches the section and frame decoders; a file that still
    /// decodes must re-encode to something that decodes to the same asset.
    #[test]
    fn mutated_files_never_panic(
        which in 0..3usize,
        mutations in prop::collection::vec(mutation(), 1..4),
        repair in any::<bool>(),
    ) {
        let bytes = match which {
            0 => &cube().1,
            1 => &grid().1,
            _ => &seamed().1,
        };
        let mut bytes = bytes.clone();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        if repair {
            fix_header(&mut bytes);
        }
        if let Ok(asset) = Asset::from_bytes(&bytes) {
            let again = Asset::from_bytes(&asset.to_bytes());
            prop_assert_eq!(again.ok(), Some(asset));
        }
    }
}
