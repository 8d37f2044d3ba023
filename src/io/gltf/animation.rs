//! Animation channels: the weight track of a mesh, and node translation, rotation and scale
//! tracks, checked as they are read.

use super::document::Document;
use super::{display_name, interpolation};
use crate::io::LoadError;
use crate::morph::WeightTrack;
use gltf::accessor::Dimensions;

impl Document {
    /// The weight track of the first channel of `animation` that drives the
    /// weights of a node instancing `mesh`; `None` when there is none.
    pub(super) fn weight_track(
        &self,
        animation: &gltf::Animation,
        mesh: &gltf::Mesh,
        targets: usize,
    ) -> Result<Option<WeightTrack>, LoadError> {
        let channel = animation.channels().find(|c| {
            c.target().property() == gltf::animation::Property::MorphTargetWeights
                && c.target().node().mesh().map(|m| m.index()) == Some(mesh.index())
        });
        let Some(channel) = channel else {
            return Ok(None);
        };
        let sampler = channel.sampler();
        let (element, times, values) =
            self.sampler_keys(animation, &sampler, Dimensions::Scalar)?;
        WeightTrack::new(
            interpolation(sampler.interpolation()),
            times,
            values,
            targets,
        )
        .map(Some)
        .map_err(|e| self.data_error(&element, e.to_string()))
    }

    /// How messages name `sampler` of `animation`, its key times and its output values (of
    /// `dimensions` each), as floats.
    fn sampler_keys(
        &self,
        animation: &gltf::Animation,
        sampler: &gltf::animation::Sampler,
        dimensions: Dimensions,
    ) -> Result<(String, Vec<f32>, Vec<f32>), LoadError> {
        let element = format!(
            "animation {} sampler {}",
            display_name(animation.name(), animation.index()),
            sampler.index()
        );
        let times = self.read_floats(
            &sampler.input(),
            &format!("{element} input"),
            Dimensions::Scalar,
        )?;
        let values =
            self.read_floats(&sampler.output(), &format!("{element} output"), dimensions)?;
        Ok((element, times, values))
    }

    /// The channels of `animation` on node `node`'s translation, rotation and scale, checked
    /// as [`WeightTrack::new`] checks a weight track ([`super::NodeTrack::problem`]): finite,
    /// strictly increasing times, and finite values, as many as the keys ask for.
    pub(super) fn node_tracks(
        &self,
        animation: &gltf::Animation,
        node: usize,
    ) -> Result<Vec<super::NodeTrack>, LoadError> {
        let mut tracks = Vec::new();
        for channel in animation.channels() {
            if channel.target().node().index() != node {
                continue;
            }
            let Some(property) = node_property(channel.target().property()) else {
                continue;
            };
            let dimensions = match property {
                super::NodeProperty::Rotation => Dimensions::Vec4,
                _ => Dimensions::Vec3,
            };
            let sampler = channel.sampler();
            let (element, times, values) = self.sampler_keys(animation, &sampler, dimensions)?;
            let track = super::NodeTrack {
                property,
                interpolation: interpolation(sampler.interpolation()),
                times,
                values,
            };
            if let Some(problem) = track.problem() {
                return Err(self.data_error(&element, problem));
            }
            tracks.push(track);
        }
        Ok(tracks)
    }
}

/// The property of a channel on a node's transform (`None` for weights).
fn node_property(property: gltf::animation::Property) -> Option<super::NodeProperty> {
    use gltf::animation::Property;
    match property {
        Property::Translation => Some(super::NodeProperty::Translation),
        Property::Rotation => Some(super::NodeProperty::Rotation),
        Property::Scale => Some(super::NodeProperty::Scale),
        Property::MorphTargetWeights => None,
    }
}
