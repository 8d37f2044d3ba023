//! glTF 2.0 binary (GLB) output of one morphing mesh: positions, `u32` indices, morph
//! targets as POSITION deltas, default weights and an optional weight animation, so any
//! glTF viewer plays the morph. Written by hand (a few accessors do not need a JSON
//! library): every accessor that the specification requires bounds for (POSITION,
//! animation input) carries `min`/`max`, every buffer view is 4-byte aligned, vertex and
//! index views carry their `target`, and the container follows the GLB framing (12-byte
//! header, JSON chunk padded with spaces, BIN chunk padded with zeros).
//!
//! The reader is [`crate::io::gltf::load_morph`]; [`exact_deltas`] chooses deltas so that
//! `base + delta` (what the reader and the GPU compute, in `f32`) gives each second pose
//! back bit for bit.

use std::fmt::Write as _;

/// A mesh with morph targets, ready to be written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GltfMorph {
    /// The base positions (all weights 0).
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// (name, POSITION deltas) per target; each has one delta per position.
    pub targets: Vec<(String, Vec<[f32; 3]>)>,
    /// The mesh's default weights (`mesh.weights`), one per target.
    pub weights: Vec<f32>,
    /// An optional weight animation (LINEAR): key times in seconds, and per key one
    /// weight per target.
    pub animation: Option<WeightAnimation>,
    /// The mesh's (and node's) name.
    pub name: String,
}

/// Key times and weights of a weight animation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WeightAnimation {
    pub name: String,
    /// Strictly increasing, in seconds.
    pub times: Vec<f32>,
    /// `times.len()` rows, one weight per target each.
    pub weights: Vec<Vec<f32>>,
}

/// Why a [`GltfMorph`] cannot be written.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum WriteError {
    #[error("glTF output: {0}")]
    Invalid(String),
}

impl GltfMorph {
    /// The two-pose morph `v0` → `v1` as one target named `name_target`, default weight 0,
    /// with a weight animation 0 → 1 → 0 over `seconds` (one way) so a viewer plays it.
    pub fn two_pose(
        name: &str,
        triangles: Vec<[u32; 3]>,
        v0: &[[f32; 3]],
        v1: &[[f32; 3]],
        seconds: f32,
    ) -> GltfMorph {
        GltfMorph {
            positions: v0.to_vec(),
            triangles,
            targets: vec![("V(1)".to_string(), exact_deltas(v0, v1))],
            weights: vec![0.0],
            animation: Some(WeightAnimation {
                name: format!("{name} 0-1-0"),
                times: vec![0.0, seconds, 2.0 * seconds],
                weights: vec![vec![0.0], vec![1.0], vec![0.0]],
            }),
            name: name.to_string(),
        }
    }

    fn check(&self) -> Result<(), WriteError> {
        let n = self.positions.len();
        let bad = |m: String| Err(WriteError::Invalid(m));
        if n == 0 || self.triangles.is_empty() {
            return bad("the mesh has no vertices or no triangles".into());
        }
        if let Some(t) = self.triangles.iter().flatten().find(|&&i| i as usize >= n) {
            return bad(format!("index {t} is out of range ({n} vertices)"));
        }
        if self.weights.len() != self.targets.len() {
            return bad(format!(
                "{} default weights for {} targets",
                self.weights.len(),
                self.targets.len()
            ));
        }
        for (name, deltas) in &self.targets {
            if deltas.len() != n {
                return bad(format!(
                    "target '{name}' has {} deltas for {n} vertices",
                    deltas.len()
                ));
            }
        }
        let all = self
            .positions
            .iter()
            .chain(self.targets.iter().flat_map(|(_, d)| d.iter()))
            .flatten();
        if all.clone().any(|x| !x.is_finite()) {
            return bad("a position or delta is not finite".into());
        }
        if let Some(a) = &self.animation {
            if self.targets.is_empty() {
                return bad("a weight animation needs morph targets".into());
            }
            if a.times.is_empty() || a.times.windows(2).any(|w| w[0] >= w[1]) {
                return bad("animation key times must be non-empty and increasing".into());
            }
            if a.times.iter().any(|t| !t.is_finite() || *t < 0.0) {
                return bad("animation key times must be finite and non-negative".into());
            }
            if a.weights.len() != a.times.len()
                || a.weights.iter().any(|w| w.len() != self.targets.len())
            {
                return bad("the animation needs one weight per target at every key".into());
            }
        }
        Ok(())
    }

    /// The file's bytes: a GLB container.
    pub fn to_glb(&self) -> Result<Vec<u8>, WriteError> {
        self.check()?;
        let mut bin = Bin::default();
        let mut json = Json::default();

        let pos_acc = vec3_accessor(&mut bin, &mut json, &self.positions, true);
        let target_accs: Vec<usize> = self
            .targets
            .iter()
            .map(|(_, deltas)| vec3_accessor(&mut bin, &mut json, deltas, true))
            .collect();

        let index_acc = index_accessor(&mut bin, &mut json, &self.triangles);

        let mut animation = String::new();
        if let Some(a) = &self.animation {
            let times = bin.push(f32_bytes(a.times.iter()));
            let times_view = json.view(times, None);
            let (t0, t1) = (a.times[0], a.times[a.times.len() - 1]);
            let times_acc = json.accessor(
                times_view,
                FLOAT,
                a.times.len(),
                "SCALAR",
                Some((vec![t0], vec![t1])),
            );
            let weights = bin.push(f32_bytes(a.weights.iter().flatten()));
            let weights_view = json.view(weights, None);
            let weights_acc = json.accessor(
                weights_view,
                FLOAT,
                a.times.len() * self.targets.len(),
                "SCALAR",
                None,
            );
            animation = format!(
                r#","animations":[{{"name":{},"samplers":[{{"input":{times_acc},"output":{weights_acc},"interpolation":"LINEAR"}}],"channels":[{{"sampler":0,"target":{{"node":0,"path":"weights"}}}}]}}]"#,
                quote(&a.name)
            );
        }

        let targets: Vec<String> = target_accs
            .iter()
            .map(|a| format!(r#"{{"POSITION":{a}}}"#))
            .collect();
        let names: Vec<String> = self.targets.iter().map(|(n, _)| quote(n)).collect();
        let weights: Vec<String> = self.weights.iter().map(|w| number(*w)).collect();
        let morph = if self.targets.is_empty() {
            String::new()
        } else {
            format!(r#","targets":[{}]"#, targets.join(","))
        };
        let mesh_extras = if self.targets.is_empty() {
            String::new()
        } else {
            format!(
                r#","weights":[{}],"extras":{{"targetNames":[{}]}}"#,
                weights.join(","),
                names.join(",")
            )
        };
        let mut text = String::new();
        let _ = write!(
            text,
            r#"{{"asset":{{"version":"2.0","generator":"morphlod"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"name":{name}}}],"meshes":[{{"name":{name},"primitives":[{{"attributes":{{"POSITION":{pos_acc}}},"indices":{index_acc},"mode":4{morph}}}]{mesh_extras}}}]{animation},"buffers":[{{"byteLength":{len}}}],"bufferViews":[{views}],"accessors":[{accessors}]}}"#,
            name = quote(&self.name),
            len = bin.bytes.len(),
            views = json.views.join(","),
            accessors = json.accessors.join(","),
        );
        Ok(glb(text.into_bytes(), bin.bytes))
    }
}

/// Deltas `d` with `v0 + d == v1` in `f32` (what a reader computes) wherever such a `d`
/// exists; `v1 − v0` rounded is usually it, and otherwise a neighbouring value is. Where
/// none exists the nearest result is kept (1 ulp of `v0` away): `v0 + d` lies on the grid
/// of the coarser of `v0`'s and `d`'s steps, so a `v1` with finer steps and an odd last bit
/// (0.96 → 0.4005698) cannot be reached by any `f32` delta; on the supermesh of two test
/// meshes about a fifth of the coordinates are such.
pub fn exact_deltas(v0: &[[f32; 3]], v1: &[[f32; 3]]) -> Vec<[f32; 3]> {
    v0.iter()
        .zip(v1)
        .map(|(a, b)| std::array::from_fn(|k| exact_delta(a[k], b[k])))
        .collect()
}

fn exact_delta(a: f32, b: f32) -> f32 {
    let d = b - a;
    if a + d == b {
        return d;
    }
    let mut best = d;
    for direction in [f32::INFINITY, f32::NEG_INFINITY] {
        let mut c = d;
        for _ in 0..4 {
            c = next_toward(c, direction);
            if a + c == b {
                return c;
            }
            if ((a + c) - b).abs() < ((a + best) - b).abs() {
                best = c;
            }
        }
    }
    best
}

/// The next `f32` after `x` toward `direction` (±∞); `x` finite.
fn next_toward(x: f32, direction: f32) -> f32 {
    if x == 0.0 {
        let tiny = f32::from_bits(1);
        return if direction > 0.0 { tiny } else { -tiny };
    }
    let bits = x.to_bits();
    let away_from_zero = (direction > 0.0) == (x > 0.0);
    f32::from_bits(if away_from_zero { bits + 1 } else { bits - 1 })
}

pub(crate) const ARRAY_BUFFER: u32 = 34962;
pub(crate) const ELEMENT_ARRAY_BUFFER: u32 = 34963;
pub(crate) const FLOAT: u32 = 5126;
pub(crate) const UNSIGNED_INT: u32 = 5125;

/// The binary chunk being filled: each push starts at a multiple of 4.
#[derive(Default)]
pub(crate) struct Bin {
    pub(crate) bytes: Vec<u8>,
}

impl Bin {
    pub(crate) fn push(&mut self, data: Vec<u8>) -> (usize, usize) {
        pad(&mut self.bytes, 0);
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(&data);
        (offset, data.len())
    }
}

#[derive(Default)]
pub(crate) struct Json {
    pub(crate) views: Vec<String>,
    pub(crate) accessors: Vec<String>,
}

impl Json {
    pub(crate) fn view(&mut self, at: (usize, usize), target: Option<u32>) -> usize {
        self.strided_view(at, None, target)
    }

    /// A buffer view whose elements start `stride` bytes apart (`None`: tightly packed).
    pub(crate) fn strided_view(
        &mut self,
        (offset, length): (usize, usize),
        stride: Option<usize>,
        target: Option<u32>,
    ) -> usize {
        let stride = stride.map_or(String::new(), |s| format!(r#","byteStride":{s}"#));
        let target = target.map_or(String::new(), |t| format!(r#","target":{t}"#));
        self.views.push(format!(
            r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{length}{stride}{target}}}"#
        ));
        self.views.len() - 1
    }

    pub(crate) fn accessor(
        &mut self,
        view: usize,
        component: u32,
        count: usize,
        kind: &str,
        bounds: Option<(Vec<f32>, Vec<f32>)>,
    ) -> usize {
        self.normalized_accessor(view, component, false, count, kind, bounds)
    }

    /// An accessor whose integer components are read as normalized when `normalized`.
    pub(crate) fn normalized_accessor(
        &mut self,
        view: usize,
        component: u32,
        normalized: bool,
        count: usize,
        kind: &str,
        bounds: Option<(Vec<f32>, Vec<f32>)>,
    ) -> usize {
        let normalized = if normalized {
            r#","normalized":true"#
        } else {
            ""
        };
        let bounds = bounds.map_or(String::new(), |(lo, hi)| {
            let list = |v: Vec<f32>| v.into_iter().map(number).collect::<Vec<_>>().join(",");
            format!(r#","min":[{}],"max":[{}]"#, list(lo), list(hi))
        });
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"componentType":{component},"count":{count}{normalized},"type":"{kind}"{bounds}}}"#
        ));
        self.accessors.len() - 1
    }
}

/// `data` as a VEC3 float buffer view and its accessor, with `min`/`max` when `with_bounds`
/// (POSITION needs them, glTF's morph targets should have them); returns the accessor.
pub(crate) fn vec3_accessor(
    bin: &mut Bin,
    json: &mut Json,
    data: &[[f32; 3]],
    with_bounds: bool,
) -> usize {
    let view = json.view(
        bin.push(f32_bytes(data.iter().flatten())),
        Some(ARRAY_BUFFER),
    );
    json.accessor(
        view,
        FLOAT,
        data.len(),
        "VEC3",
        with_bounds.then(|| bounds(data)),
    )
}

/// The triangles as a `u32` index buffer view and its SCALAR accessor; returns the accessor.
pub(crate) fn index_accessor(bin: &mut Bin, json: &mut Json, triangles: &[[u32; 3]]) -> usize {
    let bytes = triangles.iter().flatten().flat_map(|i| i.to_le_bytes());
    let view = json.view(bin.push(bytes.collect()), Some(ELEMENT_ARRAY_BUFFER));
    json.accessor(view, UNSIGNED_INT, triangles.len() * 3, "SCALAR", None)
}

pub(crate) fn bounds(points: &[[f32; 3]]) -> (Vec<f32>, Vec<f32>) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo.to_vec(), hi.to_vec())
}

pub(crate) fn f32_bytes<'a>(values: impl Iterator<Item = &'a f32>) -> Vec<u8> {
    values.flat_map(|v| v.to_le_bytes()).collect()
}

/// A finite `f32` as JSON: Rust's shortest representation that reads back to the same
/// `f32` (so `min`/`max` equal the data exactly), `-0` written as `0`.
pub(crate) fn number(x: f32) -> String {
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x:?}")
    }
}

/// A JSON string literal.
pub(crate) fn quote(s: &str) -> String {
    serde_json::Value::from(s).to_string()
}

fn pad(bytes: &mut Vec<u8>, with: u8) {
    while !bytes.len().is_multiple_of(4) {
        bytes.push(with);
    }
}

/// The GLB container: header, JSON chunk (space-padded), BIN chunk (zero-padded).
pub(crate) fn glb(mut json: Vec<u8>, mut bin: Vec<u8>) -> Vec<u8> {
    pad(&mut json, b' ');
    pad(&mut bin, 0);
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deltas_give_the_second_pose_back_exactly_where_any_delta_does() {
        // Pseudo-random pairs over a few magnitudes: wherever some delta near `b − a`
        // reaches `b`, ours does; elsewhere ours is within 1 ulp.
        let mut x = 0x1234_5678u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32 - 0.5) * [0.01f32, 1.0, 300.0][(x % 3) as usize]
        };
        let mut exact = 0;
        for _ in 0..20_000 {
            let (a, b) = (next(), next());
            let d = exact_delta(a, b);
            let reachable = (-64i32..=64).any(|k| {
                let c = f32::from_bits(((b - a).to_bits() as i32 + k) as u32);
                c.is_finite() && a + c == b
            });
            if reachable {
                assert_eq!((a + d).to_bits(), b.to_bits(), "{a} -> {b}");
                exact += 1;
            } else {
                assert!(((a + d) - b).abs() <= f32::EPSILON * a.abs().max(b.abs()));
            }
        }
        assert!(exact > 10_000, "{exact}");
    }

    #[test]
    fn an_unreachable_second_pose_is_one_ulp_away() {
        let (a, b) = (0.96f32, f32::from_bits(1_053_628_285));
        let d = exact_deltas(&[[a; 3]], &[[b; 3]])[0][0];
        assert!(((a + d) - b).abs() <= f32::EPSILON * a);
    }

    #[test]
    fn framing_is_aligned_and_json_parses() {
        let v0 = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let v1 = vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
        let morph = GltfMorph::two_pose("t\"ri", vec![[0, 1, 2]], &v0, &v1, 1.0);
        let bytes = morph.to_glb().unwrap();
        assert_eq!(&bytes[0..4], b"glTF");
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
            bytes.len()
        );
        assert_eq!(bytes.len() % 4, 0);
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        assert_eq!(json_len % 4, 0);
        let glb = gltf::Gltf::from_slice(&bytes).unwrap();
        assert_eq!(glb.meshes().count(), 1);
        assert_eq!(glb.animations().count(), 1);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let v = vec![[0.0f32; 3]; 3];
        let mut m = GltfMorph::two_pose("x", vec![[0, 1, 3]], &v, &v, 1.0);
        assert!(m.to_glb().is_err());
        m.triangles = vec![];
        assert!(m.to_glb().is_err());
    }
}
