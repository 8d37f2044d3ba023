//! glTF's keyframe sampling (glTF 2.0 §3.11 and Appendix C), shared by the samplers that
//! read it: morph-target weights (`morph::WeightTrack`) and joint channels (`skin::Clip`).
//! Below both, so neither imports the other for it.

/// How values between two keyframes are computed (glTF `sampler.interpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The value of the last keyframe at or before the time.
    Step,
    /// Linear blend of the two surrounding keyframes.
    Linear,
    /// Cubic Hermite spline; every keyframe stores an in-tangent, a value and an out-tangent.
    CubicSpline,
}

impl Interpolation {
    /// The glTF spelling, for messages and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Step => "STEP",
            Interpolation::Linear => "LINEAR",
            Interpolation::CubicSpline => "CUBICSPLINE",
        }
    }
}

/// Where a time falls among strictly increasing key times (glTF 2.0 §3.11): on one key's value
/// (before the first key, after the last, or a single key: the end values hold), or inside
/// the segment from key `k` to `k + 1` at `s ∈ [0, 1)` of its length `dt`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Segment {
    Hold(usize),
    Between { k: usize, s: f32, dt: f32 },
}

/// The [`Segment`] `time` (seconds) falls in; a NaN time reads as before the first key.
pub(crate) fn segment(times: &[f32], time: f32) -> Segment {
    // Number of keys at or before `time`: 0 = before the first one.
    let after = times.partition_point(|&k| k <= time);
    if after == 0 || after == times.len() {
        return Segment::Hold(after.saturating_sub(1));
    }
    let k = after - 1;
    let dt = times[k + 1] - times[k];
    Segment::Between {
        k,
        s: (time - times[k]) / dt,
        dt,
    }
}

/// glTF's cubic Hermite spline (Appendix C) on one component at `s` of a segment of length
/// `dt`: `v0` and its out-tangent `b0` at the start, `v1` and its in-tangent `a1` at the end.
pub(crate) fn hermite(s: f32, dt: f32, v0: f32, b0: f32, v1: f32, a1: f32) -> f32 {
    let (s2, s3) = (s * s, s * s * s);
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = (s3 - 2.0 * s2 + s) * dt;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = (s3 - s2) * dt;
    h00 * v0 + h10 * b0 + h01 * v1 + h11 * a1
}
