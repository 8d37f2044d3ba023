//! Keyframed morph-target weights: a glTF animation sampler whose channel
//! targets `weights`, evaluated at any time with the interpolation rules of
//! glTF 2.0 (§3.11 and Appendix C).

use super::MorphError;
pub use crate::keyframes::Interpolation;
use crate::keyframes::{hermite, segment, Segment};
use std::cmp::Ordering;

/// Weights of `targets` morph targets over time. Immutable after [`WeightTrack::new`]
/// so the sampling code can index without checks failing.
#[derive(Clone, Debug, PartialEq)]
pub struct WeightTrack {
    interpolation: Interpolation,
    times: Vec<f32>,
    /// Per keyframe: `targets` values, or for CUBICSPLINE `targets` in-tangents,
    /// `targets` values, `targets` out-tangents (the glTF output layout).
    values: Vec<f32>,
    targets: usize,
}

impl WeightTrack {
    /// Checks what sampling relies on: at least one keyframe, finite strictly
    /// increasing times (glTF requires strictly increasing input), finite values,
    /// and exactly `keyframes × targets` values (× 3 for CUBICSPLINE).
    pub fn new(
        interpolation: Interpolation,
        times: Vec<f32>,
        values: Vec<f32>,
        targets: usize,
    ) -> Result<WeightTrack, MorphError> {
        if times.is_empty() || targets == 0 {
            return Err(MorphError::TrackEmpty {
                keyframes: times.len(),
                targets,
            });
        }
        for (k, pair) in times.windows(2).enumerate() {
            if pair[0].partial_cmp(&pair[1]) != Some(Ordering::Less) {
                return Err(MorphError::TrackTimes {
                    keyframe: k + 1,
                    previous: pair[0],
                    time: pair[1],
                });
            }
        }
        if let Some(k) = times.iter().position(|t| !t.is_finite()) {
            return Err(MorphError::TrackTimes {
                keyframe: k,
                previous: if k == 0 { f32::NAN } else { times[k - 1] },
                time: times[k],
            });
        }
        let per_key = if interpolation == Interpolation::CubicSpline {
            3 * targets
        } else {
            targets
        };
        let expected = times.len().checked_mul(per_key);
        if expected != Some(values.len()) {
            return Err(MorphError::TrackValueCount {
                interpolation: interpolation.name(),
                keyframes: times.len(),
                targets,
                expected: times.len().saturating_mul(per_key),
                values: values.len(),
            });
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(MorphError::TrackValue { index: i });
        }
        Ok(WeightTrack {
            interpolation,
            times,
            values,
            targets,
        })
    }

    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    pub fn keyframes(&self) -> usize {
        self.times.len()
    }

    pub fn targets(&self) -> usize {
        self.targets
    }

    /// Time of the last keyframe: glTF animations play from time 0, so this is
    /// the length of the animation.
    pub fn duration(&self) -> f32 {
        self.times.last().copied().unwrap_or(0.0)
    }

    /// The weights at `time` (seconds) into `out` (resized to `targets`).
    /// Before the first keyframe and after the last the end values hold (the
    /// glTF clamping rule); a NaN time reads as before the first keyframe.
    pub fn sample_into(&self, time: f32, out: &mut Vec<f32>) {
        out.clear();
        let n = self.targets;
        match segment(&self.times, time) {
            Segment::Hold(k) => out.extend_from_slice(self.value(k)),
            Segment::Between { k, s, dt } => match self.interpolation {
                Interpolation::Step => out.extend_from_slice(self.value(k)),
                Interpolation::Linear => {
                    let (a, b) = (self.value(k), self.value(k + 1));
                    out.extend(a.iter().zip(b).map(|(&a, &b)| a + (b - a) * s));
                }
                Interpolation::CubicSpline => {
                    let key0 = &self.values[k * 3 * n..(k + 1) * 3 * n];
                    let key1 = &self.values[(k + 1) * 3 * n..(k + 2) * 3 * n];
                    out.extend((0..n).map(|i| {
                        hermite(s, dt, key0[n + i], key0[2 * n + i], key1[n + i], key1[i])
                    }));
                }
            },
        }
    }

    /// The weights played over `t ∈ [0, 1]` (time `t · duration`, as [`super::Morph`] plays
    /// an animation) minus the weights at `t = 0`, into `out`: what the GPU adds to `V(0)`
    /// (see [`super::TargetBlend`]). `t` is clamped to `[0, 1]`; NaN reads as 0.
    pub fn offsets_at(&self, t: f32, out: &mut Vec<f32>) {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let mut at_zero = Vec::with_capacity(self.targets);
        self.sample_into(0.0, &mut at_zero);
        self.sample_into(t * self.duration(), out);
        for (c, w0) in out.iter_mut().zip(&at_zero) {
            *c -= w0;
        }
    }

    /// The same track lasting until `duration` (seconds, after its last key): a key there
    /// holds the last key's values, so the track plays as before and the glTF animation it
    /// belongs to, longer than its own keys, keeps its length when the track is played over
    /// `t ∈ [0, 1]`. (For CUBICSPLINE the last key's out-tangent and the new key's tangents
    /// are 0: the old out-tangent was never used, and the new segment stays constant.)
    /// Unchanged when `duration` is not after the last key.
    pub fn held_until(&self, duration: f32) -> WeightTrack {
        let mut track = self.clone();
        if !duration.is_finite() || duration <= self.duration() {
            return track;
        }
        let n = self.targets;
        let last = self.value(self.keyframes() - 1).to_vec();
        if self.interpolation == Interpolation::CubicSpline {
            let end = track.values.len();
            track.values[end - n..].fill(0.0);
            track.values.extend(std::iter::repeat_n(0.0, n));
            track.values.extend(&last);
            track.values.extend(std::iter::repeat_n(0.0, n));
        } else {
            track.values.extend(&last);
        }
        track.times.push(duration);
        track
    }

    /// Whether the weights at the end equal those at the start (within `1e-5` of the larger
    /// magnitude, at least 1): the weights loop.
    pub fn returns_to_start(&self) -> bool {
        let (first, last) = (self.value(0), self.value(self.keyframes() - 1));
        first
            .iter()
            .zip(last)
            .all(|(a, b)| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1.0))
    }

    /// Keyframe times, seconds, strictly increasing.
    pub fn times(&self) -> &[f32] {
        &self.times
    }

    /// Per keyframe `targets` values, or for CUBICSPLINE in-tangents, values and out-tangents
    /// (the glTF output layout).
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// True when some keyframe gives target `target` a nonzero value or tangent, i.e. the
    /// target can move the mesh at some time.
    pub fn drives(&self, target: usize) -> bool {
        target < self.targets
            && self
                .values
                .iter()
                .skip(target)
                .step_by(self.targets)
                .any(|&v| v != 0.0)
    }

    /// The same track restricted to the targets `keep` (in that order). Indices past
    /// [`targets`](Self::targets) are skipped.
    pub fn select(&self, keep: &[usize]) -> WeightTrack {
        let keep: Vec<usize> = keep.iter().copied().filter(|&k| k < self.targets).collect();
        let values = self
            .values
            .chunks_exact(self.targets)
            .flat_map(|row| keep.iter().map(move |&k| row[k]))
            .collect();
        WeightTrack {
            interpolation: self.interpolation,
            times: self.times.clone(),
            values,
            targets: keep.len(),
        }
    }

    /// The keyframe's values (not its tangents).
    fn value(&self, k: usize) -> &[f32] {
        let n = self.targets;
        match self.interpolation {
            Interpolation::CubicSpline => &self.values[k * 3 * n + n..k * 3 * n + 2 * n],
            _ => &self.values[k * n..(k + 1) * n],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(track: &WeightTrack, time: f32) -> Vec<f32> {
        let mut out = Vec::new();
        track.sample_into(time, &mut out);
        out
    }

    fn close(a: &[f32], b: &[f32]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5)
    }

    /// Two targets, keyframes at 1 s, 2 s, 4 s.
    fn times() -> Vec<f32> {
        vec![1.0, 2.0, 4.0]
    }

    #[test]
    fn linear_interpolates_and_clamps() {
        let values = vec![0.0, 1.0, 1.0, 0.0, 0.5, 0.5];
        let track = WeightTrack::new(Interpolation::Linear, times(), values, 2).unwrap();
        assert_eq!(sample(&track, 0.0), vec![0.0, 1.0], "before the first key");
        assert_eq!(sample(&track, 1.0), vec![0.0, 1.0]);
        assert!(close(&sample(&track, 1.25), &[0.25, 0.75]));
        assert_eq!(sample(&track, 2.0), vec![1.0, 0.0]);
        // 3 s is halfway between (1, 0) and (0.5, 0.5).
        assert!(close(&sample(&track, 3.0), &[0.75, 0.25]));
        assert_eq!(sample(&track, 4.0), vec![0.5, 0.5]);
        assert_eq!(sample(&track, 9.0), vec![0.5, 0.5], "after the last key");
        assert_eq!(track.duration(), 4.0);
    }

    #[test]
    fn select_keeps_the_chosen_targets_and_their_curves() {
        // Three targets; target 1 is zero at every key, in values and tangents.
        let values = vec![
            0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 2.0, 0.0, 1.0, // key 0: in, value, out
            0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, // key 1
            1.0, 0.0, 0.0, 0.5, 0.0, 0.5, 0.0, 0.0, 3.0, // key 2
        ];
        let track = WeightTrack::new(Interpolation::CubicSpline, times(), values, 3).unwrap();
        assert!(track.drives(0) && !track.drives(1) && track.drives(2));
        assert!(!track.drives(3));
        let kept = track.select(&[0, 2]);
        assert_eq!(kept.targets(), 2);
        for time in [0.5, 1.0, 1.7, 2.0, 3.3, 4.0, 5.0] {
            let (all, some) = (sample(&track, time), sample(&kept, time));
            assert_eq!(some, vec![all[0], all[2]], "at {time} s");
        }
    }

    #[test]
    fn step_holds_the_previous_key() {
        let values = vec![0.0, 1.0, 1.0, 0.0, 0.5, 0.5];
        let track = WeightTrack::new(Interpolation::Step, times(), values, 2).unwrap();
        assert_eq!(sample(&track, -1.0), vec![0.0, 1.0]);
        assert_eq!(sample(&track, 1.999), vec![0.0, 1.0]);
        assert_eq!(sample(&track, 2.0), vec![1.0, 0.0]);
        assert_eq!(sample(&track, 3.9), vec![1.0, 0.0]);
        assert_eq!(sample(&track, 5.0), vec![0.5, 0.5]);
    }

    #[test]
    fn cubic_spline_matches_hand_computed_hermite() {
        // One target; keys at 1 s and 2 s and 4 s: (in, value, out) per key.
        let values = vec![
            9.0, 0.0, 2.0, // key 0: value 0, out-tangent 2 (in-tangent unused)
            -1.0, 1.0, 4.0, // key 1: value 1, in-tangent -1, out-tangent 4
            3.0, 0.0, 7.0, // key 2: value 0, in-tangent 3 (out-tangent unused)
        ];
        let track = WeightTrack::new(Interpolation::CubicSpline, times(), values, 1).unwrap();
        // Segment 0, dt = 1, s = 0.5: h00 = 0.5, h10 = 0.125, h01 = 0.5, h11 = -0.125.
        // p = 0.5*0 + 0.125*1*2 + 0.5*1 + (-0.125)*1*(-1) = 0.25 + 0.5 + 0.125 = 0.875
        assert!(close(&sample(&track, 1.5), &[0.875]));
        // Segment 1, dt = 2, time 2.5 → s = 0.25: h00 = 0.84375, h10 = 0.140625*2,
        // h01 = 0.15625, h11 = -0.046875*2.
        // p = 0.84375*1 + 0.28125*4 + 0.15625*0 + (-0.09375)*3 = 0.84375 + 1.125 - 0.28125 = 1.6875
        assert!(close(&sample(&track, 2.5), &[1.6875]));
        // At keys and outside: the key values, never a tangent.
        assert_eq!(sample(&track, 2.0), vec![1.0]);
        assert_eq!(sample(&track, 0.0), vec![0.0]);
        assert_eq!(sample(&track, 10.0), vec![0.0]);
    }

    /// Held until 6 s, each interpolation plays as before up to its last key and holds the
    /// last values after it.
    #[test]
    fn held_until_keeps_the_curve_and_holds_the_end() {
        let values = vec![
            9.0, 0.0, 2.0, -1.0, 1.0, 4.0, 3.0, 0.5, 7.0, // CUBICSPLINE: in, value, out
        ];
        let cubic = WeightTrack::new(Interpolation::CubicSpline, times(), values, 1).unwrap();
        let linear =
            WeightTrack::new(Interpolation::Linear, times(), vec![0.0, 1.0, 0.5], 1).unwrap();
        for track in [cubic, linear] {
            let held = track.held_until(6.0);
            assert_eq!(held.duration(), 6.0);
            for time in [0.0, 1.3, 2.0, 3.7, 4.0] {
                assert_eq!(sample(&held, time), sample(&track, time), "at {time} s");
            }
            for time in [4.5, 5.99, 6.0, 8.0] {
                assert!(close(&sample(&held, time), &[0.5]), "at {time} s");
            }
            assert_eq!(track.held_until(3.0), track, "not after the last key");
            assert!(!track.returns_to_start());
        }
    }

    #[test]
    fn single_keyframe_is_constant() {
        let track = WeightTrack::new(Interpolation::Linear, vec![0.5], vec![0.3], 1).unwrap();
        assert_eq!(sample(&track, 0.0), vec![0.3]);
        assert_eq!(sample(&track, 7.0), vec![0.3]);
    }

    #[test]
    fn rejects_inconsistent_tracks() {
        let bad_count = WeightTrack::new(Interpolation::CubicSpline, times(), vec![0.0; 6], 2);
        assert!(matches!(
            bad_count,
            Err(MorphError::TrackValueCount {
                keyframes: 3,
                values: 6,
                ..
            })
        ));
        let unordered =
            WeightTrack::new(Interpolation::Linear, vec![0.0, 2.0, 1.0], vec![0.0; 3], 1);
        assert!(matches!(
            unordered,
            Err(MorphError::TrackTimes { keyframe: 2, .. })
        ));
        let nan_time = WeightTrack::new(Interpolation::Linear, vec![f32::NAN], vec![0.0], 1);
        assert!(matches!(
            nan_time,
            Err(MorphError::TrackTimes { keyframe: 0, .. })
        ));
        let empty = WeightTrack::new(Interpolation::Step, vec![], vec![], 1);
        assert!(matches!(empty, Err(MorphError::TrackEmpty { .. })));
    }
}
