//! A clip: the channels of one glTF animation on a skeleton's translations, rotations and
//! scales, sampled at any time with the interpolation rules of glTF 2.0 (§3.11, Appendix C).

use super::skeleton::{Skeleton, TRS, UNIT_TOLERANCE};
use super::SkinError;
use crate::keyframes::Interpolation;
use crate::keyframes::{hermite, segment, Segment};
use glam::Quat;

/// A node property an animation channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeProperty {
    Translation,
    Rotation,
    Scale,
}

impl NodeProperty {
    /// The glTF `path`.
    pub fn name(self) -> &'static str {
        match self {
            NodeProperty::Translation => "translation",
            NodeProperty::Rotation => "rotation",
            NodeProperty::Scale => "scale",
        }
    }

    /// Components per value: 4 for a rotation (a quaternion x, y, z, w), else 3.
    pub fn components(self) -> usize {
        match self {
            NodeProperty::Rotation => 4,
            _ => 3,
        }
    }

    /// Where its value sits in a local transform of [`TRS`] floats.
    fn offset(self) -> usize {
        match self {
            NodeProperty::Translation => 0,
            NodeProperty::Rotation => 3,
            NodeProperty::Scale => 7,
        }
    }
}

/// One animation channel on a node's transform, as its sampler has it: key times in seconds
/// (finite, strictly increasing) and per key [`NodeProperty::components`] values (for
/// `CubicSpline` an in-tangent, the value and an out-tangent, the glTF layout), read as `f32`
/// (normalized integer rotations converted as the glTF specification says).
#[derive(Clone, Debug, PartialEq)]
pub struct NodeTrack {
    pub property: NodeProperty,
    pub interpolation: Interpolation,
    pub times: Vec<f32>,
    pub values: Vec<f32>,
}

impl NodeTrack {
    /// Why the track cannot be sampled, if it cannot: no key, key times that are not finite
    /// and strictly increasing, a value count other than the keys ask for, a value that is
    /// not finite.
    pub fn problem(&self) -> Option<String> {
        let per_key = self.property.components() * self.values_per_key();
        let times = &self.times;
        if times.is_empty() {
            Some("has no keyframe".to_string())
        } else if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[0] >= w[1]) {
            Some("has key times that are not finite and strictly increasing".to_string())
        } else if self.values.len() != times.len() * per_key {
            Some(format!(
                "has {} output values for {} keys, expected {}",
                self.values.len(),
                times.len(),
                times.len() * per_key
            ))
        } else if self.values.iter().any(|v| !v.is_finite()) {
            Some("has a value that is not finite".to_string())
        } else {
            None
        }
    }

    /// 3 for `CubicSpline` (in-tangent, value, out-tangent), else 1.
    fn values_per_key(&self) -> usize {
        match self.interpolation {
            Interpolation::CubicSpline => 3,
            _ => 1,
        }
    }

    /// Key `k`'s value (not its tangents).
    fn value(&self, k: usize) -> &[f32] {
        let c = self.property.components();
        let at = (k * self.values_per_key() + usize::from(self.values_per_key() == 3)) * c;
        &self.values[at..at + c]
    }

    /// The value at `time` (seconds) into `out` ([`NodeProperty::components`] floats):
    /// held before the first key and after the last; STEP holds a key; LINEAR blends
    /// translations and scales linearly and rotations by glTF's spherical linear
    /// interpolation (the shorter way round); CUBICSPLINE is glTF's Hermite spline on every
    /// component, a rotation normalised afterwards.
    pub fn sample(&self, time: f32, out: &mut [f32]) {
        let c = self.property.components();
        match segment(&self.times, time) {
            Segment::Hold(k) => out.copy_from_slice(self.value(k)),
            Segment::Between { k, s, dt } => match self.interpolation {
                Interpolation::Step => out.copy_from_slice(self.value(k)),
                Interpolation::Linear if self.property == NodeProperty::Rotation => {
                    out.copy_from_slice(&slerp(self.value(k), self.value(k + 1), s));
                }
                Interpolation::Linear => {
                    let (a, b) = (self.value(k), self.value(k + 1));
                    for i in 0..c {
                        out[i] = a[i] + (b[i] - a[i]) * s;
                    }
                }
                Interpolation::CubicSpline => {
                    let key0 = &self.values[k * 3 * c..(k + 1) * 3 * c];
                    let key1 = &self.values[(k + 1) * 3 * c..(k + 2) * 3 * c];
                    for i in 0..c {
                        out[i] = hermite(s, dt, key0[c + i], key0[2 * c + i], key1[c + i], key1[i]);
                    }
                    if self.property == NodeProperty::Rotation {
                        let q = Quat::from_slice(out).normalize();
                        out.copy_from_slice(&q.to_array());
                    }
                }
            },
        }
    }
}

/// glTF's spherical linear interpolation (Appendix C): `a = arccos |a·b|`, the sign of `a·b`
/// taking the shorter way, `sin(a(1−s))/sin a · q0 + sign · sin(a s)/sin a · q1`; where the
/// keys are (nearly) one rotation, the linear blend (the spec's fallback), normalised.
fn slerp(q0: &[f32], q1: &[f32], s: f32) -> [f32; 4] {
    let dot: f32 = q0.iter().zip(q1).map(|(a, b)| a * b).sum();
    let sign = if dot < 0.0 { -1.0 } else { 1.0 };
    let cos = (dot * sign).min(1.0);
    let (w0, w1) = if cos > 1.0 - 1e-6 {
        (1.0 - s, s)
    } else {
        let angle = cos.acos();
        let sin = angle.sin();
        (((1.0 - s) * angle).sin() / sin, (s * angle).sin() / sin)
    };
    let q: [f32; 4] = std::array::from_fn(|i| w0 * q0[i] + sign * w1 * q1[i]);
    if cos > 1.0 - 1e-6 {
        Quat::from_array(q).normalize().to_array()
    } else {
        q
    }
}

/// One channel of a clip: the skeleton node it drives and its track.
#[derive(Clone, Debug, PartialEq)]
pub struct JointChannel {
    /// A node of the skin's [`Skeleton`].
    pub node: u32,
    pub track: NodeTrack,
}

/// One animation played on a skeleton.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clip {
    /// The animation's name in the source (empty when it has none).
    pub name: String,
    /// Seconds: the last key time over the animation's channels, its weight channel included
    /// (glTF's length of an animation). A morph plays it over `t ∈ [0, 1]` as time
    /// `t · duration`.
    pub duration: f32,
    /// Whether the clip ends in the pose it starts in, so that it plays as a loop: then the
    /// builder samples frames at `t_k = k / |r|` and the runtime shows frame
    /// `round(t |r|) mod |r|` (`DeformingModel::frame_at`), the last frame followed by the first.
    pub looping: bool,
    pub channels: Vec<JointChannel>,
}

impl Clip {
    /// Checks what sampling relies on: every channel on a node of `skeleton` and sampleable
    /// ([`NodeTrack::problem`]), rotation values of unit length within [`UNIT_TOLERANCE`], a
    /// finite duration not before the last key.
    pub fn validate(&self, skeleton: &Skeleton) -> Result<(), SkinError> {
        let nodes = skeleton.node_count();
        for (channel, c) in self.channels.iter().enumerate() {
            if c.node as usize >= nodes {
                return Err(SkinError::ChannelNode {
                    channel,
                    node: c.node,
                    nodes,
                });
            }
            let rotation = c.track.property == NodeProperty::Rotation;
            let problem = c.track.problem().or_else(|| {
                (0..c.track.times.len())
                    .filter(|_| rotation)
                    .map(|k| Quat::from_slice(c.track.value(k)).length())
                    .find(|&l| (l - 1.0).abs() > UNIT_TOLERANCE)
                    .map(|l| format!("has a rotation of length {l}, not 1"))
            });
            if let Some(problem) = problem {
                return Err(SkinError::Channel {
                    channel,
                    node: skeleton.display(c.node as usize),
                    problem,
                });
            }
        }
        let last = self
            .channels
            .iter()
            .filter_map(|c| c.track.times.last())
            .fold(0.0f32, |a, &b| a.max(b));
        if !self.duration.is_finite() || self.duration < last {
            return Err(SkinError::Duration {
                duration: self.duration,
                last,
            });
        }
        Ok(())
    }

    /// Every node's local transform at `time` (seconds) into `out` ([`TRS`] floats per node):
    /// the rest transform, each property a channel drives replaced by the channel's value.
    pub fn locals_at(&self, skeleton: &Skeleton, time: f32, out: &mut Vec<f32>) {
        out.clear();
        out.extend_from_slice(&skeleton.rest);
        for c in &self.channels {
            let at = c.node as usize * TRS + c.track.property.offset();
            let width = c.track.property.components();
            c.track.sample(time, &mut out[at..at + width]);
        }
    }

    /// Every key time of its channels in `[0, duration]`, sorted, each once, with 0 and the
    /// duration: the times at which baked joint matrices reproduce a LINEAR or STEP clip's
    /// keys.
    pub fn key_times(&self) -> Vec<f32> {
        let mut times: Vec<f32> = self
            .channels
            .iter()
            .flat_map(|c| c.track.times.iter().copied())
            .filter(|&t| (0.0..=self.duration).contains(&t))
            .chain([0.0, self.duration])
            .collect();
        times.sort_by(f32::total_cmp);
        times.dedup();
        times
    }

    /// Whether the local transforms at the clip's end equal those at its start, each
    /// component within `1e-5` of the larger magnitude (at least 1), a rotation also as its
    /// negation (the same turn): whether the joints loop.
    pub fn returns_to_start(&self, skeleton: &Skeleton) -> bool {
        let (mut start, mut end) = (Vec::new(), Vec::new());
        self.locals_at(skeleton, 0.0, &mut start);
        self.locals_at(skeleton, self.duration, &mut end);
        let close = |a: &[f32], b: &[f32]| {
            a.iter()
                .zip(b)
                .all(|(x, y)| (x - y).abs() <= 1e-5 * x.abs().max(y.abs()).max(1.0))
        };
        start
            .chunks_exact(TRS)
            .zip(end.chunks_exact(TRS))
            .all(|(a, b)| {
                let negated: Vec<f32> = b[3..7].iter().map(|v| -v).collect();
                close(&a[..3], &b[..3])
                    && close(&a[7..], &b[7..])
                    && (close(&a[3..7], &b[3..7]) || close(&a[3..7], &negated))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(property: NodeProperty, interpolation: Interpolation, values: Vec<f32>) -> NodeTrack {
        NodeTrack {
            property,
            interpolation,
            times: vec![1.0, 3.0],
            values,
        }
    }

    /// A quarter turn about z to a half turn (LINEAR): at a quarter of the way, 112.5°; and
    /// from the identity to a negated identity (the same rotation) nothing turns.
    #[test]
    fn rotations_slerp_the_shorter_way() {
        let (s, c) = (45f32.to_radians().sin(), 45f32.to_radians().cos());
        let t = track(
            NodeProperty::Rotation,
            Interpolation::Linear,
            vec![0.0, 0.0, s, c, 0.0, 0.0, 1.0, 0.0],
        );
        let mut out = [0.0; 4];
        t.sample(1.5, &mut out);
        let half = 112.5f32.to_radians() / 2.0;
        let want = [0.0, 0.0, half.sin(), half.cos()];
        for i in 0..4 {
            assert!((out[i] - want[i]).abs() < 1e-6, "{out:?} vs {want:?}");
        }
        let flipped = track(
            NodeProperty::Rotation,
            Interpolation::Linear,
            vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0],
        );
        flipped.sample(2.0, &mut out);
        assert!((out[3].abs() - 1.0).abs() < 1e-6, "{out:?}");
        // Before and after the keys the end values hold.
        t.sample(0.0, &mut out);
        assert_eq!(out, [0.0, 0.0, s, c]);
        t.sample(9.0, &mut out);
        assert_eq!(out, [0.0, 0.0, 1.0, 0.0]);
    }

    /// STEP holds the earlier key; CUBICSPLINE follows the Hermite spline per component, here
    /// a translation from 0 (out-tangent 2) to 1 (in-tangent −1) over 2 s: at s = ½,
    /// 0.5 · 0 + 0.125 · 2 · 2 + 0.5 · 1 − 0.125 · 2 · (−1) = 1.25.
    #[test]
    fn step_holds_and_cubic_follows_hermite() {
        let step = track(
            NodeProperty::Scale,
            Interpolation::Step,
            vec![1.0, 1.0, 1.0, 2.0, 2.0, 2.0],
        );
        let mut out = [0.0; 3];
        step.sample(2.999, &mut out);
        assert_eq!(out, [1.0; 3]);
        step.sample(3.0, &mut out);
        assert_eq!(out, [2.0; 3]);
        let cubic = track(
            NodeProperty::Translation,
            Interpolation::CubicSpline,
            vec![
                9.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, // key 0: in, value, out
                -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 7.0, 0.0, 0.0, // key 1
            ],
        );
        assert_eq!(cubic.problem(), None);
        cubic.sample(2.0, &mut out);
        assert!((out[0] - 1.25).abs() < 1e-6, "{out:?}");
        cubic.sample(3.0, &mut out);
        assert_eq!(out[0], 1.0, "a key gives its value, not a tangent");
    }

    #[test]
    fn problems_are_named() {
        let mut t = track(
            NodeProperty::Translation,
            Interpolation::Linear,
            vec![0.0; 6],
        );
        assert_eq!(t.problem(), None);
        t.values.pop();
        assert!(t.problem().unwrap().contains("5 output values"));
        t.values.push(f32::NAN);
        assert!(t.problem().unwrap().contains("not finite"));
        t.times = vec![1.0, 1.0];
        assert!(t.problem().unwrap().contains("strictly increasing"));
    }
}
