//! The animations: each source animation's weight track on every LOD node and its node
//! channels, or the morph's own weight track where the source has none.

use super::compress::{Buffers, Codec};
use super::mesh::flat_accessor;
use crate::io::gltf::write::{f32_bytes, quote, FLOAT};
use crate::io::gltf::NodeTrack;
use crate::morph::{Interpolation, Morph, WeightTrack, Weights};

/// The morph's own weight animation: its track, or 0 → 1 → 0 for two poses.
pub(super) fn animation(morph: &Morph) -> Option<WeightTrack> {
    match morph.weights() {
        Weights::Animated(track) => Some(track.clone()),
        Weights::TwoPose { w0, w1 } => {
            let values = [w0.as_slice(), w1, w0].concat();
            WeightTrack::new(Interpolation::Linear, vec![0.0, 1.0, 2.0], values, w0.len()).ok()
        }
    }
}

/// One animation to write: its name, its weight track (driving every LOD node) and its node
/// tracks, each with the written nodes it drives.
pub(super) struct WrittenAnimation<'a> {
    pub(super) name: String,
    pub(super) weights: Option<WeightTrack>,
    pub(super) channels: Vec<(Vec<usize>, &'a NodeTrack)>,
}

/// The animations JSON member (empty when there is nothing to play): per animation the
/// weight track's sampler with one `weights` channel per LOD node, and one sampler per node
/// track with a channel on each of the nodes it drives.
pub(super) fn animations_json(
    animations: &[WrittenAnimation],
    lods: usize,
    buffers: &mut Buffers,
) -> String {
    let written: Vec<String> = animations
        .iter()
        .filter_map(|a| animation_json(a, lods, buffers))
        .collect();
    if written.is_empty() {
        return String::new();
    }
    format!(r#","animations":[{}]"#, written.join(","))
}

/// One animation's JSON object; `None` when it has nothing to play.
fn animation_json(
    animation: &WrittenAnimation,
    lods: usize,
    buffers: &mut Buffers,
) -> Option<String> {
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    // Key times compressed without a filter: read back exactly, as the extension advises.
    let input = |buffers: &mut Buffers, times: &[f32]| {
        let view = buffers.view(f32_bytes(times.iter()), 4, false, None, Codec::Attributes);
        let (t0, t1) = (times[0], times[times.len() - 1]);
        buffers.json.accessor(
            view,
            FLOAT,
            times.len(),
            "SCALAR",
            Some((vec![t0], vec![t1])),
        )
    };
    if let Some(track) = &animation.weights {
        let input = input(buffers, track.times());
        let output = flat_accessor(buffers, track.values(), 1, "SCALAR", None);
        samplers.push(format!(
            r#"{{"input":{input},"output":{output},"interpolation":"{}"}}"#,
            track.interpolation().name()
        ));
        channels.extend(
            (0..lods).map(|node| {
                format!(r#"{{"sampler":0,"target":{{"node":{node},"path":"weights"}}}}"#)
            }),
        );
    }
    for (nodes, track) in &animation.channels {
        let input = input(buffers, &track.times);
        let width = track.property.components();
        let kind = if width == 4 { "VEC4" } else { "VEC3" };
        let output = flat_accessor(buffers, &track.values, width, kind, None);
        let sampler = samplers.len();
        samplers.push(format!(
            r#"{{"input":{input},"output":{output},"interpolation":"{}"}}"#,
            track.interpolation.name()
        ));
        channels.extend(nodes.iter().map(|node| {
            format!(
                r#"{{"sampler":{sampler},"target":{{"node":{node},"path":"{}"}}}}"#,
                track.property.name()
            )
        }));
    }
    (!samplers.is_empty()).then(|| {
        format!(
            r#"{{"name":{},"samplers":[{}],"channels":[{}]}}"#,
            quote(&animation.name),
            samplers.join(","),
            channels.join(",")
        )
    })
}
