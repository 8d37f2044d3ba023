//! The animation: the weight track on every LOD node, and the source's node channels.

use super::compress::{Buffers, Codec};
use super::mesh::flat_accessor;
use crate::io::gltf::write::{f32_bytes, FLOAT};
use crate::io::gltf::NodeTrack;
use crate::morph::{Interpolation, Morph, WeightTrack, Weights};

/// The weight animation to write: the morph's own track, or 0 → 1 → 0 for two poses.
pub(super) fn animation(morph: &Morph) -> Option<WeightTrack> {
    match morph.weights() {
        Weights::Animated(track) => Some(track.clone()),
        Weights::TwoPose { w0, w1 } => {
            let values = [w0.as_slice(), w1, w0].concat();
            WeightTrack::new(Interpolation::Linear, vec![0.0, 1.0, 2.0], values, w0.len()).ok()
        }
    }
}

/// The animation JSON member (empty when there is nothing to play): the weight track's
/// sampler with one `weights` channel per LOD node, and one sampler per node track with a
/// channel on each of the nodes it drives.
pub(super) fn animation_json(
    weights: Option<&WeightTrack>,
    node_tracks: &[(Vec<usize>, &NodeTrack)],
    lods: usize,
    buffers: &mut Buffers,
) -> String {
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
    if let Some(track) = weights {
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
    for (nodes, track) in node_tracks {
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
    if samplers.is_empty() {
        return String::new();
    }
    format!(
        r#","animations":[{{"name":"weights","samplers":[{}],"channels":[{}]}}]"#,
        samplers.join(","),
        channels.join(",")
    )
}
