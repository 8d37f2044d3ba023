//! Skinned assets in the `.mlod` file: the "SKIN" section round trips (the skin and clip,
//! not the poses), the asset's drawn pose (`Asset::pose_at`) is the morph's skinned pose, a
//! looping asset's frames wrap, and a damaged or inconsistent section is refused with the
//! error that names it (CRC, version, flags, truncation, joints out of range, weights, inverse
//! binds, channels).

use crate::common;

use common::fix_header;
use common::skinned::{Layout, SkinnedBar};
use morphlod::asset::{AssetError, SKIN_VERSION};
use morphlod::build::Sequences;
use morphlod::io::{load_morph, LoadOptions, MorphSource};
use morphlod::morph::Morph;
use morphlod::simplify::PoseError;
use morphlod::skin::SkinError;
use morphlod::{Asset, Builder, DeformingModel};
use std::path::Path;

fn walker() -> Morph {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_walker.glb");
    load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("walk".into()),
    )
    .unwrap()
}

/// The generated bar (1.2 s, not a loop; its weight in the same animation), written to a
/// directory of the test's own (tests run in parallel).
fn bar(test: &str) -> Morph {
    let dir = common::scratch_dir("asset_skin", test);
    let path = SkinnedBar::new(Layout::Float).write(&dir, "bar.glb");
    load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("bend".into()),
    )
    .unwrap()
}

/// Largest distance between two poses.
fn farthest(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(&p, &q)| glam::Vec3::from(p).distance(glam::Vec3::from(q)))
        .fold(0.0, f32::max)
}

#[test]
fn skinned_assets_round_trip_and_pose_as_their_morphs() {
    for (name, morph, frames) in [("walker", walker(), 8), ("bar", bar("round_trip"), 4)] {
        let (asset, _) = Builder::new(&morph).frames(frames).build().unwrap();
        let bytes = asset.to_bytes();
        let back = Asset::from_bytes(&bytes).unwrap();
        assert_eq!(back, asset, "{name}: read back equal");
        assert_eq!(
            back.skin.as_ref(),
            morph.skinning(),
            "{name}: the skin and clip"
        );
        assert_eq!(back.v0, morph.v0(), "{name}: V(0) in bind space");
        for t in [0.0, 0.1, 0.37, 0.5, 0.81, 1.0] {
            let d = farthest(&back.pose_at(t), &morph.positions_at(t));
            let diagonal = common::diagonal(&morph.positions_at(t)) as f32;
            assert!(d <= 1e-6 * diagonal, "{name} t = {t}: drawn pose {d} away");
        }
        let model = DeformingModel::new(&back).unwrap();
        assert_eq!(model.looping(), name == "walker");
    }
    // `--sequence shared`: one pose-aware sequence over the clip's poses, one frame, the skin.
    let (shared, _) = Builder::new(&walker())
        .frames(8)
        .sequences(Sequences::Shared(PoseError::Max))
        .build()
        .unwrap();
    assert_eq!((shared.frames.len(), shared.skin.is_some()), (1, true));
    let back = Asset::from_bytes(&shared.to_bytes()).unwrap();
    assert_eq!(back, shared);
    let (bar_asset, _) = Builder::new(&bar("frames")).frames(4).build().unwrap();
    let model = DeformingModel::new(&bar_asset).unwrap();
    let frames: Vec<usize> = [0.0, 0.16, 0.17, 0.99, 1.0]
        .map(|t| model.frame_at(t).unwrap())
        .to_vec();
    assert_eq!(frames, [0, 0, 1, 3, 3], "not a loop: round(3 t)");
    let (walker_asset, _) = Builder::new(&walker()).frames(8).build().unwrap();
    let model = DeformingModel::new(&walker_asset).unwrap();
    let frames: Vec<usize> = [0.0, 0.06, 0.07, 0.93, 0.94, 1.0]
        .map(|t| model.frame_at(t).unwrap())
        .to_vec();
    assert_eq!(frames, [0, 0, 1, 7, 0, 0], "a loop: round(8 t) mod 8");
}

/// The section table of a file image: (tag, start, end) in the body.
fn sections(bytes: &[u8]) -> Vec<([u8; 4], usize, usize)> {
    let count = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let body = &bytes[32..];
    (0..count)
        .map(|i| {
            let e = &body[24 * i..24 * i + 24];
            let at = u64::from_le_bytes(e[8..16].try_into().unwrap()) as usize;
            let len = u64::from_le_bytes(e[16..24].try_into().unwrap()) as usize;
            (e[..4].try_into().unwrap(), at, at + len)
        })
        .collect()
}

/// The file with its "SKIN" section replaced by `change(content)` (the bytes before the
/// section's CRC), the section's CRC and the file's header recomputed when `reseal`.
fn with_skin(bytes: &[u8], reseal: bool, change: impl Fn(&mut Vec<u8>)) -> Vec<u8> {
    let table = sections(bytes);
    let body = &bytes[32..];
    let mut parts: Vec<([u8; 4], Vec<u8>)> = table
        .iter()
        .map(|&(tag, a, b)| (tag, body[a..b].to_vec()))
        .collect();
    let skin = parts.iter_mut().find(|(tag, _)| tag == b"SKIN").unwrap();
    let mut content = skin.1[..skin.1.len() - 4].to_vec();
    let crc = skin.1[skin.1.len() - 4..].to_vec();
    change(&mut content);
    let crc = match reseal {
        true => crc32fast::hash(&content).to_le_bytes().to_vec(),
        false => crc,
    };
    skin.1 = [content, crc].concat();
    let mut out = bytes[..32].to_vec();
    let mut offset = (parts.len() * 24) as u64;
    for (tag, data) in &parts {
        out.extend_from_slice(tag);
        out.extend_from_slice(&[0; 4]);
        out.extend_from_slice(&offset.to_le_bytes());
        out.extend_from_slice(&(data.len() as u64).to_le_bytes());
        offset += data.len() as u64;
    }
    for (_, data) in &parts {
        out.extend_from_slice(data);
    }
    fix_header(&mut out);
    out
}

#[test]
fn damaged_skin_sections_are_refused() {
    let (asset, _) = Builder::new(&bar("damaged")).frames(2).build().unwrap();
    let bytes = asset.to_bytes();
    let damaged = with_skin(&bytes, false, |c| c[40] ^= 1);
    assert!(matches!(
        Asset::from_bytes(&damaged),
        Err(AssetError::SectionChecksum { tag: "SKIN", .. })
    ));
    let newer = with_skin(&bytes, true, |c| c[0] = SKIN_VERSION + 1);
    let err = Asset::from_bytes(&newer).unwrap_err();
    assert!(
        matches!(
            err,
            AssetError::SectionVersion {
                tag: "SKIN",
                newest: SKIN_VERSION,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("upgrade morphlod"), "{err}");
    let flags = with_skin(&bytes, true, |c| c[1] = 0x80);
    assert!(matches!(
        Asset::from_bytes(&flags),
        Err(AssetError::SkinFlags { flags: 0x80 })
    ));
    let cut = with_skin(&bytes, true, |c| c.truncate(c.len() / 2));
    assert!(matches!(
        Asset::from_bytes(&cut),
        Err(AssetError::Truncated { tag: "SKIN", .. })
    ));
    let trailing = with_skin(&bytes, true, |c| c.push(0));
    assert!(matches!(
        Asset::from_bytes(&trailing),
        Err(AssetError::SectionTrailing { tag: "SKIN", .. })
    ));
}

fn skin(asset: &mut Asset) -> &mut morphlod::skin::Skinning {
    asset.skin.as_mut().unwrap()
}

/// A skin the writer stores as it is but the reader refuses: each inconsistency with the
/// error naming it.
#[test]
fn inconsistent_skins_are_refused_on_load() {
    let (asset, _) = Builder::new(&bar("inconsistent"))
        .frames(2)
        .build()
        .unwrap();
    let refused = |change: &dyn Fn(&mut Asset)| -> SkinError {
        let mut bad = asset.clone();
        change(&mut bad);
        match Asset::from_bytes(&bad.to_bytes()) {
            Err(AssetError::Skin { source }) => source,
            other => panic!("expected a skin error, got {other:?}"),
        }
    };
    assert!(matches!(
        refused(&|a| skin(a).skin.joints[9] = 3),
        SkinError::JointOutOfRange {
            vertex: 2,
            influence: 1,
            joint: 3,
            joints: 3
        }
    ));
    assert!(matches!(
        refused(&|a| skin(a).skin.weights[4] = f32::NAN),
        SkinError::BadWeight { vertex: 1, .. }
    ));
    assert!(matches!(
        refused(&|a| skin(a).skin.weights[4] = 0.5),
        SkinError::WeightSum { vertex: 1, .. }
    ));
    assert!(matches!(
        refused(&|a| skin(a).skin.inverse_binds[16..20].fill(0.0)),
        SkinError::InverseBind { joint: 1, .. }
    ));
    assert!(matches!(
        refused(&|a| skin(a).skin.joint_nodes[2] = 40),
        SkinError::JointNode {
            joint: 2,
            node: 40,
            ..
        }
    ));
    assert!(matches!(
        refused(&|a| skin(a).skin.skeleton.parents[1] = 3),
        SkinError::ParentOrder { node: 1, parent: 3 }
    ));
    assert!(matches!(
        refused(&|a| skin(a).clip.channels[0].node = 9),
        SkinError::ChannelNode { node: 9, .. }
    ));
    assert!(matches!(
        refused(&|a| skin(a).clip.channels[1].track.times.reverse()),
        SkinError::Channel { channel: 1, .. }
    ));
    assert!(matches!(
        refused(&|a| skin(a).clip.duration = 0.5),
        SkinError::Duration { .. }
    ));
}
