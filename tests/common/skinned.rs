//! A small skinned glTF file generated here, for the skin's oracle against three.js
//! (tests/suite/skin_oracle.rs) and its malformed variants (tests/suite/bad_input/gltf_skin.rs):
//! a square bar 8 units tall (9 rings of 4 vertices, 68 triangles) bound to a chain of three
//! joints, with every interpolation on the joints and a weight channel in the same animation.
//!
//! * Nodes: 0 `bar` (the mesh, its skin, a translation the specification says to ignore),
//!   1 `rig` (a matrix: turned 30° about y, scaled by 1.5, moved; never animated), 2 `root`
//!   (TRS) under it, 3 `j1` at (0, 3, 0) under `root`, 4 `j2` at (0, 3, 0) under `j1`. The
//!   scene holds `bar` and `rig`; the skin's joints are `root`, `j1`, `j2`, their inverse bind
//!   matrices the inverses of their rest world matrices.
//! * Per vertex JOINTS_0 and WEIGHTS_0 by ring: the root alone below, blends up the bar, `j2`
//!   alone at the top ([`Layout`] says which types); one morph target `bend` that leans the bar
//!   along x with its height.
//! * Animation `bend`, 1.2 s: `root` rotation LINEAR (its middle key negated, the same turn,
//!   so the spherical blend must take the shorter way), `j1` rotation CUBICSPLINE, `j1`
//!   translation LINEAR over two keys, `j2` rotation STEP, `j2` scale CUBICSPLINE, the mesh's
//!   weight CUBICSPLINE.

use serde_json::{json, Value};

/// Vertices of the bar.
pub const VERTICES: usize = 36;

/// How the vertex skin attributes are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// JOINTS_0 UNSIGNED_SHORT, WEIGHTS_0 FLOAT.
    Float,
    /// JOINTS_0 UNSIGNED_BYTE, WEIGHTS_0 normalized UNSIGNED_SHORT (sums exactly 65535).
    Normalized,
    /// As `Float`, plus JOINTS_1 / WEIGHTS_1: a tenth of every vertex's weight on a joint its
    /// first set does not use (`j2` below ring 6, the root above).
    TwoSets,
}

/// Accessors of the document, by what they hold.
pub mod accessor {
    pub const POSITION: usize = 0;
    pub const INDICES: usize = 1;
    pub const TARGET: usize = 2;
    pub const JOINTS: usize = 3;
    pub const WEIGHTS: usize = 4;
    pub const INVERSE_BINDS: usize = 5;
}

/// The document and its binary buffer, to write as it is or changed.
pub struct SkinnedBar {
    pub json: Value,
    pub bin: Vec<u8>,
}

/// Joint weights of ring `r` over (root, j1, j2).
fn ring_weights(r: usize) -> [f32; 3] {
    match r {
        0 | 1 => [1.0, 0.0, 0.0],
        2 => [0.75, 0.25, 0.0],
        3 => [0.5, 0.5, 0.0],
        4 => [0.25, 0.75, 0.0],
        5 => [0.0, 1.0, 0.0],
        6 => [0.0, 0.5, 0.5],
        7 => [0.0, 0.25, 0.75],
        _ => [0.0, 0.0, 1.0],
    }
}

fn quat(axis: glam::Vec3, degrees: f32) -> [f32; 4] {
    glam::Quat::from_axis_angle(axis, degrees.to_radians()).to_array()
}

impl SkinnedBar {
    pub fn new(layout: Layout) -> SkinnedBar {
        let mut bar = SkinnedBar {
            json: json!({
                "asset": {"version": "2.0"},
                "buffers": [{"byteLength": 0}],
                "bufferViews": [], "accessors": [],
                "scene": 0, "scenes": [{"nodes": [0, 1]}],
            }),
            bin: Vec::new(),
        };
        let positions: Vec<f32> = (0..9)
            .flat_map(|r| {
                [[-0.25, -0.25], [0.25, -0.25], [0.25, 0.25], [-0.25, 0.25]]
                    .into_iter()
                    .flat_map(move |[x, z]| [x, r as f32, z])
            })
            .collect();
        let mut indices: Vec<u16> = Vec::new();
        for r in 0..8u16 {
            for c in 0..4u16 {
                let (a, b) = (4 * r + c, 4 * r + (c + 1) % 4);
                indices.extend([a, b, b + 4, a, b + 4, a + 4]);
            }
        }
        indices.extend([0, 2, 1, 0, 3, 2, 32, 33, 34, 32, 34, 35]);
        let deltas: Vec<f32> = (0..VERTICES)
            .flat_map(|v| [0.05 * (v / 4) as f32, 0.0, 0.0])
            .collect();
        let weights: Vec<[f32; 3]> = (0..VERTICES).map(|v| ring_weights(v / 4)).collect();
        // Joints of zero weight are 0: the validator warns about a joint used with none.
        let joints: Vec<[u16; 4]> = weights
            .iter()
            .map(|w| [0, 1, 2, 0].map(|j: u16| if j > 0 && w[j as usize] == 0.0 { 0 } else { j }))
            .collect();
        let share = if layout == Layout::TwoSets { 0.9 } else { 1.0 };
        let floats = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|f| f.to_le_bytes()).collect() };
        let position = bar.accessor(floats(&positions), 5126, "VEC3", VERTICES, false, true);
        bar.json["accessors"][position]["min"] = json!([-0.25, 0.0, -0.25]);
        bar.json["accessors"][position]["max"] = json!([0.25, 8.0, 0.25]);
        let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        bar.accessor(index_bytes, 5123, "SCALAR", indices.len(), false, false);
        let target = bar.accessor(floats(&deltas), 5126, "VEC3", VERTICES, false, true);
        bar.json["accessors"][target]["min"] = json!([0.0, 0.0, 0.0]);
        bar.json["accessors"][target]["max"] = json!([0.4, 0.0, 0.0]);
        match layout {
            Layout::Normalized => {
                let bytes = joints.iter().flat_map(|j| j.map(|x| x as u8)).collect();
                bar.accessor(bytes, 5121, "VEC4", VERTICES, false, true);
                let bytes = weights
                    .iter()
                    .flat_map(|w| {
                        // Rounded, the remainder on the largest: every sum is 65535 exactly.
                        let mut q = w.map(|x| (x * 65535.0).round() as i32);
                        let largest = (0..3).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap();
                        q[largest] += 65535 - q.iter().sum::<i32>();
                        [q[0], q[1], q[2], 0]
                            .into_iter()
                            .flat_map(|x| (x as u16).to_le_bytes())
                    })
                    .collect();
                bar.accessor(bytes, 5123, "VEC4", VERTICES, true, true);
            }
            _ => {
                let bytes = joints
                    .iter()
                    .flatten()
                    .flat_map(|j| j.to_le_bytes())
                    .collect();
                bar.accessor(bytes, 5123, "VEC4", VERTICES, false, true);
                let values: Vec<f32> = weights
                    .iter()
                    .flat_map(|w| [w[0] * share, w[1] * share, w[2] * share, 0.0])
                    .collect();
                bar.accessor(floats(&values), 5126, "VEC4", VERTICES, false, true);
            }
        }
        // Rest transforms and their world matrices, for the inverse binds.
        let rig = glam::Affine3A::from_scale_rotation_translation(
            glam::Vec3::splat(1.5),
            glam::Quat::from_rotation_y(30f32.to_radians()),
            glam::Vec3::new(0.5, 0.0, -1.0),
        );
        let up = glam::Affine3A::from_translation(glam::Vec3::new(0.0, 3.0, 0.0));
        let worlds = [rig, rig * up, rig * up * up];
        let inverse: Vec<f32> = worlds
            .iter()
            .flat_map(|w| glam::Mat4::from(w.inverse()).to_cols_array())
            .collect();
        bar.accessor(floats(&inverse), 5126, "MAT4", 3, false, false);
        let mut attributes = json!({"POSITION": 0, "JOINTS_0": 3, "WEIGHTS_0": 4});
        if layout == Layout::TwoSets {
            // A joint the vertex's first set does not use: j2 below ring 6, the root above.
            let other = |v: usize| if v / 4 >= 6 { 0u16 } else { 2 };
            let bytes = (0..VERTICES)
                .flat_map(|v| [other(v), 0, 0, 0])
                .flat_map(u16::to_le_bytes);
            let j = bar.accessor(bytes.collect(), 5123, "VEC4", VERTICES, false, true);
            let w: Vec<f32> = (0..VERTICES).flat_map(|_| [0.1, 0.0, 0.0, 0.0]).collect();
            let w = bar.accessor(floats(&w), 5126, "VEC4", VERTICES, false, true);
            attributes["JOINTS_1"] = json!(j);
            attributes["WEIGHTS_1"] = json!(w);
        }
        bar.json["meshes"] = json!([{"name": "bar", "weights": [0.0],
            "extras": {"targetNames": ["bend"]},
            "primitives": [{"attributes": attributes, "indices": 1, "targets": [{"POSITION": 2}]}]}]);
        bar.json["nodes"] = json!([
            {"name": "bar", "mesh": 0, "skin": 0, "translation": [5.0, 5.0, 5.0]},
            {"name": "rig", "matrix": glam::Mat4::from(rig).to_cols_array(), "children": [2]},
            {"name": "root", "children": [3]},
            {"name": "j1", "translation": [0.0, 3.0, 0.0], "children": [4]},
            {"name": "j2", "translation": [0.0, 3.0, 0.0]},
        ]);
        bar.json["skins"] = json!([{"name": "chain", "joints": [2, 3, 4], "skeleton": 2,
            "inverseBindMatrices": accessor::INVERSE_BINDS}]);
        bar.animation();
        bar
    }

    /// Animation `bend` (module docs).
    fn animation(&mut self) {
        let floats = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|f| f.to_le_bytes()).collect() };
        let time = |s: &mut SkinnedBar, times: &[f32]| {
            let a = s.accessor(floats(times), 5126, "SCALAR", times.len(), false, false);
            s.json["accessors"][a]["min"] = json!([times[0]]);
            s.json["accessors"][a]["max"] = json!([times[times.len() - 1]]);
            a
        };
        let three = time(self, &[0.0, 0.6, 1.2]);
        let two = time(self, &[0.0, 1.2]);
        let step = time(self, &[0.0, 0.4, 0.9]);
        let (y, z, x) = (glam::Vec3::Y, glam::Vec3::Z, glam::Vec3::X);
        let negated = quat(y, 60.0).map(|c| -c);
        let root = [quat(y, 0.0), negated, quat(y, 30.0)].concat();
        let tangent = [0.0, 0.0, 0.3, 0.0];
        let j1 = [
            [0.0; 4],
            quat(z, 0.0),
            tangent,
            [0.0, 0.0, -0.2, 0.1],
            quat(z, 40.0),
            [0.0, 0.0, 0.1, -0.1],
            tangent,
            quat(z, 10.0),
            [0.0; 4],
        ]
        .concat();
        let moved: Vec<f32> = vec![0.0, 3.0, 0.0, 0.3, 3.0, 0.0];
        let j2 = [quat(x, 0.0), quat(x, 30.0), quat(x, -20.0)].concat();
        let scale: Vec<f32> = [
            [0.0; 3], [1.0; 3], [0.5; 3], [0.2; 3], [1.3; 3], [-0.4; 3], [-0.5; 3], [1.0; 3],
            [0.0; 3],
        ]
        .concat();
        let weight: Vec<f32> = vec![0.0, 0.0, 1.5, 0.5, 1.0, -1.0, -1.0, 0.25, 0.0];
        let outputs: Vec<(usize, Vec<f32>, &str)> = vec![
            (three, root, "VEC4"),
            (three, j1, "VEC4"),
            (two, moved, "VEC3"),
            (step, j2, "VEC4"),
            (three, scale, "VEC3"),
            (three, weight, "SCALAR"),
        ];
        let widths = [4, 4, 3, 4, 3, 1];
        let mut samplers = Vec::new();
        for ((input, values, kind), width) in outputs.into_iter().zip(widths) {
            let count = values.len() / width;
            let output = self.accessor(floats(&values), 5126, kind, count, false, false);
            samplers.push((input, output));
        }
        let interpolation = [
            "LINEAR",
            "CUBICSPLINE",
            "LINEAR",
            "STEP",
            "CUBICSPLINE",
            "CUBICSPLINE",
        ];
        let targets = [
            (2, "rotation"),
            (3, "rotation"),
            (3, "translation"),
            (4, "rotation"),
            (4, "scale"),
            (0, "weights"),
        ];
        self.json["animations"] = json!([{
            "name": "bend",
            "samplers": samplers.iter().zip(interpolation).map(|(&(input, output), i)|
                json!({"input": input, "output": output, "interpolation": i})).collect::<Vec<_>>(),
            "channels": targets.iter().enumerate().map(|(s, &(node, path))|
                json!({"sampler": s, "target": {"node": node, "path": path}})).collect::<Vec<_>>(),
        }]);
    }

    /// Appends `bytes` as a buffer view (4-byte aligned) with one accessor over it; returns
    /// the accessor's index.
    fn accessor(
        &mut self,
        bytes: Vec<u8>,
        component: u32,
        kind: &str,
        count: usize,
        normalized: bool,
        vertex: bool,
    ) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut view =
            json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if vertex {
            view["target"] = json!(34962);
        }
        self.bin.extend(bytes);
        self.json["buffers"][0]["byteLength"] = json!(self.bin.len());
        let views = self.json["bufferViews"].as_array_mut().unwrap();
        views.push(view);
        let mut accessor = json!({"bufferView": views.len() - 1, "componentType": component,
            "count": count, "type": kind});
        if normalized {
            accessor["normalized"] = json!(true);
        }
        let accessors = self.json["accessors"].as_array_mut().unwrap();
        accessors.push(accessor);
        accessors.len() - 1
    }

    /// The byte offset in `bin` of component `component` of element `element` of accessor
    /// `index` (tightly packed views, as [`SkinnedBar::new`] writes them).
    pub fn offset(&self, index: usize, element: usize, component: usize) -> usize {
        let a = &self.json["accessors"][index];
        let view = &self.json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let size = match a["componentType"].as_u64().unwrap() {
            5120 | 5121 => 1,
            5122 | 5123 => 2,
            _ => 4,
        };
        let width = match a["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 16,
        };
        view["byteOffset"].as_u64().unwrap() as usize + (element * width + component) * size
    }

    /// Overwrites one FLOAT component.
    pub fn set_f32(&mut self, index: usize, element: usize, component: usize, value: f32) {
        let at = self.offset(index, element, component);
        self.bin[at..at + 4].copy_from_slice(&value.to_le_bytes());
    }

    /// Overwrites one UNSIGNED_SHORT component.
    pub fn set_u16(&mut self, index: usize, element: usize, component: usize, value: u16) {
        let at = self.offset(index, element, component);
        self.bin[at..at + 2].copy_from_slice(&value.to_le_bytes());
    }

    /// The GLB file (JSON chunk padded with spaces, BIN chunk with zeros).
    pub fn glb(&self) -> Vec<u8> {
        let mut json = serde_json::to_vec(&self.json).unwrap();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let mut out = Vec::new();
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
        out.extend((json.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(&json);
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(&bin);
        out
    }

    /// Writes the GLB file to `dir/name` and returns its path.
    pub fn write(&self, dir: &std::path::Path, name: &str) -> std::path::PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, self.glb()).unwrap();
        path
    }
}
