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
    /// as [`WeightTrack::new`] checks a weight track: finite, strictly increasing times, and
    /// finite values, as many as the keys ask for.
    pub(super) fn node_tracks(
        &self,
        animation: &gltf::Animation,
        node: usize,
    ) -> Result<Vec<super::NodeTrack>, LoadError> {
        use gltf::animation::Property;
        let mut tracks = Vec::new();
        for channel in animation.channels() {
            if channel.target().node().index() != node {
                continue;
            }
            let (property, dimensions) = match channel.target().property() {
                Property::Translation => (super::NodeProperty::Translation, Dimensions::Vec3),
                Property::Rotation => (super::NodeProperty::Rotation, Dimensions::Vec4),
                Property::Scale => (super::NodeProperty::Scale, Dimensions::Vec3),
                Property::MorphTargetWeights => continue,
            };
            let sampler = channel.sampler();
            let (element, times, values) = self.sampler_keys(animation, &sampler, dimensions)?;
            let interpolation = interpolation(sampler.interpolation());
            let per_key = property.components()
                * if interpolation == crate::morph::Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
            let problem = if times.is_empty() {
                Some("has no keyframe".to_string())
            } else if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[0] >= w[1])
            {
                Some("has key times that are not finite and strictly increasing".to_string())
            } else if values.len() != times.len() * per_key {
                Some(format!(
                    "has {} output values for {} keys, expected {}",
                    values.len(),
                    times.len(),
                    times.len() * per_key
                ))
            } else if values.iter().any(|v| !v.is_finite()) {
                Some("has a value that is not finite".to_string())
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(self.data_error(&element, problem));
            }
            tracks.push(super::NodeTrack {
                property,
                interpolation,
                times,
                values,
            });
        }
        Ok(tracks)
    }
}
