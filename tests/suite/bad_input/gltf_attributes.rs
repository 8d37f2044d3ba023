//! glTF vertex attributes, morph-target NORMAL deltas and base-colour textures: what the
//! specification allows loads with the values it defines (zero-initialised accessors with and
//! without `sparse`, normalized integer UVs and colours, every image source); what it does
//! not gives a typed error naming the element. Each file is built here by [`Gltf`], one
//! accessor at a time.

use morphlod::io::{load_morph, LoadError, LoadOptions, MorphSource};
use morphlod::morph::{ImageFormat, Morph};
use std::path::{Path, PathBuf};

/// A one-triangle glTF document under construction: buffer views are appended to one BIN
/// chunk (4-byte aligned), accessors and the primitive's attributes are JSON snippets.
#[derive(Default)]
struct Gltf {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
    attributes: Vec<String>,
    target: Vec<String>,
    extra: Vec<String>,
    material: bool,
    /// Appended to the primitive list after the triangle's primitive.
    more_primitives: String,
    /// The node's properties besides `mesh` (a leading comma each).
    node: String,
}

fn floats(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

const POSITIONS: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

impl Gltf {
    /// The triangle (positions, no indices) with one morph target whose attributes are
    /// added by the caller (none: a target without POSITION).
    fn triangle() -> Gltf {
        let mut doc = Gltf::default();
        let view = doc.view(&floats(&POSITIONS));
        let position = doc.accessor(&format!(
            r#"{{"bufferView": {view}, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}"#
        ));
        doc.attribute("POSITION", position);
        doc
    }

    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}}}"#,
            self.bin.len(),
            bytes.len()
        ));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn accessor(&mut self, json: &str) -> usize {
        self.accessors.push(json.to_string());
        self.accessors.len() - 1
    }

    /// A dense accessor over a new view of `bytes`.
    fn dense(&mut self, bytes: &[u8], component_type: u32, kind: &str, more: &str) -> usize {
        let view = self.view(bytes);
        self.accessor(&format!(
            r#"{{"bufferView": {view}, "componentType": {component_type}, "count": 3, "type": "{kind}"{more}}}"#
        ))
    }

    fn attribute(&mut self, semantic: &str, accessor: usize) {
        self.attributes.push(format!(r#""{semantic}": {accessor}"#));
    }

    fn target_attribute(&mut self, semantic: &str, accessor: usize) {
        self.target.push(format!(r#""{semantic}": {accessor}"#));
    }

    /// Material 0 with base colour texture 0 from image `image` (a JSON object).
    fn textured(&mut self, image: &str) {
        self.material = true;
        self.extra.push(format!(
            r#""materials": [{{"name": "skin", "pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.25, 1, 1], "baseColorTexture": {{"index": 0}}}}}}],
               "textures": [{{"source": 0}}], "images": [{image}]"#
        ));
    }

    fn glb(&self) -> Vec<u8> {
        let material = if self.material {
            r#", "material": 0"#
        } else {
            ""
        };
        let mut extra = self.extra.join(",\n");
        if !extra.is_empty() {
            extra.insert_str(0, ",\n");
        }
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}},
  "buffers": [{{"byteLength": {}}}],
  "bufferViews": [{}],
  "accessors": [{}],
  "meshes": [{{"primitives": [{{"attributes": {{{}}}, "targets": [{{{}}}]{material}}}{}]}}],
  "nodes": [{{"mesh": 0{}}}]{extra}
}}"#,
            self.bin.len(),
            self.views.join(", "),
            self.accessors.join(",\n  "),
            self.attributes.join(", "),
            self.target.join(", "),
            self.more_primitives,
            self.node,
        );
        super::gltf::glb(&json, &self.bin)
    }

    /// Writes the GLB into a fresh directory (beside which external images may be put) and
    /// loads target 0 as a morph.
    fn load(&self, test: &str) -> Result<Morph, LoadError> {
        load(&self.write(test))
    }

    fn write(&self, test: &str) -> PathBuf {
        super::gltf::write(&format!("attributes-{test}"), "file.glb", &self.glb())
    }
}

fn load(path: &Path) -> Result<Morph, LoadError> {
    load_morph(
        path,
        &LoadOptions::default(),
        &MorphSource::Target("0".to_string()),
    )
}

/// The smallest valid PNG header (signature and IHDR of a 2 x 1 image): what the loader
/// checks; the pixels are the renderer's to decode.
fn png() -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR".to_vec();
    png.extend(2u32.to_be_bytes());
    png.extend(1u32.to_be_bytes());
    png.extend([8, 6, 0, 0, 0]);
    png
}

#[test]
fn the_triangle_alone_has_no_attributes() {
    // The baseline: without attributes nothing is invented.
    let morph = Gltf::triangle().load("baseline").unwrap();
    assert_eq!(morph.vertex_count(), 3);
    assert!(!morph.attributes().has_vertex_attributes());
    assert!(morph.attributes().material.texture.is_none());
    assert!(morph.targets()[0].normal_deltas.is_none());
}

/// glTF: "When [bufferView is] undefined, the accessor MUST be initialized with zeros;
/// sparse property or extensions MAY override zeros with actual values." The `gltf` crate's
/// validator refuses the first form (gltf-rs/gltf#346).
#[test]
fn zero_initialised_accessors_with_and_without_sparse() {
    let mut doc = Gltf::triangle();
    let zeros = doc.accessor(r#"{"componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0]}"#);
    doc.target_attribute("POSITION", zeros);
    let indices = doc.view(&[2u8]);
    let values = doc.view(&floats(&[0.0, 0.0, -2.0]));
    let sparse = doc.accessor(&format!(
        r#"{{"componentType": 5126, "count": 3, "type": "VEC3",
             "sparse": {{"count": 1, "indices": {{"bufferView": {indices}, "componentType": 5121}}, "values": {{"bufferView": {values}}}}}}}"#
    ));
    doc.target_attribute("NORMAL", sparse);
    let normals = doc.dense(&floats(&[0.0, 0.0, 1.0].repeat(3)), 5126, "VEC3", "");
    doc.attribute("NORMAL", normals);
    let morph = doc.load("zeros").unwrap();
    assert_eq!(morph.targets()[0].deltas, vec![[0.0; 3]; 3]);
    assert_eq!(morph.v1(), morph.v0());
    assert_eq!(
        morph.targets()[0].normal_deltas.as_deref(),
        Some(&[[0.0; 3], [0.0; 3], [0.0, 0.0, -2.0]][..])
    );
    assert_eq!(
        morph.attributes().normals.as_deref(),
        Some(&[[0.0, 0.0, 1.0]; 3][..])
    );

    // An accessor without bufferView still names real data where it is sparse:
    // an out-of-range sparse index is an error, not a silent zero.
    let mut bad = Gltf::triangle();
    let indices = bad.view(&[3u8]);
    let values = bad.view(&floats(&[1.0, 0.0, 0.0]));
    let sparse = bad.accessor(&format!(
        r#"{{"componentType": 5126, "count": 3, "type": "VEC3",
             "sparse": {{"count": 1, "indices": {{"bufferView": {indices}, "componentType": 5121}}, "values": {{"bufferView": {values}}}}}}}"#
    ));
    bad.target_attribute("NORMAL", sparse);
    let err = bad.load("zeros-bad").unwrap_err();
    assert!(matches!(err, LoadError::GltfData { .. }), "{err:?}");
    assert!(err.to_string().contains("target 0 NORMAL"), "{err}");
    assert!(err.to_string().contains("replaces element 3"), "{err}");
}

/// TEXCOORD_0 may be float, or normalized unsigned byte or short (glTF 2.0, "Meshes"):
/// `c / 255` and `c / 65535`. COLOR_0 likewise, VEC3 (alpha 1) or VEC4.
#[test]
fn normalized_integer_uvs_and_colours_decode_per_spec() {
    let mut doc = Gltf::triangle();
    let uvs = doc.dense(
        &[0u8, 255, 51, 0, 255, 255],
        5121,
        "VEC2",
        r#", "normalized": true"#,
    );
    doc.attribute("TEXCOORD_0", uvs);
    let colors = doc.dense(
        &[0u8, 0, 255, 0, 255, 0, 255, 0, 0],
        5121,
        "VEC3",
        r#", "normalized": true"#,
    );
    doc.attribute("COLOR_0", colors);
    let morph = doc.load("u8").unwrap();
    let a = morph.attributes();
    assert_eq!(
        a.uvs.as_deref(),
        Some(&[[0.0, 1.0], [0.2, 0.0], [1.0, 1.0]][..])
    );
    assert_eq!(
        a.colors.as_deref(),
        Some(
            &[
                [0.0, 0.0, 1.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [1.0, 0.0, 0.0, 1.0]
            ][..]
        )
    );

    let mut doc = Gltf::triangle();
    let shorts: Vec<u8> = [0u16, 65535, 13107, 0, 65535, 32768]
        .iter()
        .flat_map(|s| s.to_le_bytes())
        .collect();
    let uvs = doc.dense(&shorts, 5123, "VEC2", r#", "normalized": true"#);
    doc.attribute("TEXCOORD_0", uvs);
    let rgba: Vec<u8> = [0u16, 0, 0, 65535]
        .repeat(3)
        .iter()
        .flat_map(|s| s.to_le_bytes())
        .collect();
    let colors = doc.dense(&rgba, 5123, "VEC4", r#", "normalized": true"#);
    doc.attribute("COLOR_0", colors);
    let morph = doc.load("u16").unwrap();
    let a = morph.attributes();
    assert_eq!(
        a.uvs.as_deref(),
        Some(&[[0.0, 1.0], [0.2, 0.0], [1.0, 32768.0 / 65535.0]][..])
    );
    assert_eq!(a.colors.as_deref(), Some(&[[0.0, 0.0, 0.0, 1.0]; 3][..]));

    // Integers that are not normalized are not texture coordinates in core glTF.
    let mut doc = Gltf::triangle();
    let uvs = doc.dense(&[0u8, 1, 1, 0, 1, 1], 5121, "VEC2", "");
    doc.attribute("TEXCOORD_0", uvs);
    let err = doc.load("u8-raw").unwrap_err();
    assert!(matches!(err, LoadError::GltfUnsupported { .. }), "{err:?}");
    assert!(err.to_string().contains("TEXCOORD_0"), "{err}");
}

#[test]
fn attributes_of_the_wrong_count_type_or_value_are_refused() {
    type Edit = fn(&mut Gltf);
    // Every one is a data error naming the accessor's role.
    let cases: [(&str, Edit, &[&str]); 6] = [
        (
            "UVs short of the vertices",
            |doc| {
                let view = doc.view(&floats(&[0.0; 4]));
                let uvs = doc.accessor(&format!(
                    r#"{{"bufferView": {view}, "componentType": 5126, "count": 2, "type": "VEC2"}}"#
                ));
                doc.attribute("TEXCOORD_0", uvs);
            },
            &["TEXCOORD_0", "2 elements", "POSITION has 3"],
        ),
        (
            "normals as VEC2",
            |doc| {
                let normals = doc.dense(&floats(&[0.0; 6]), 5126, "VEC2", "");
                doc.attribute("NORMAL", normals);
            },
            &["NORMAL", "Vec2", "expected Vec3"],
        ),
        (
            "a NaN normal",
            |doc| {
                let normals = doc.dense(
                    &floats(&[0.0, 0.0, 1.0, 0.0, f32::NAN, 1.0, 0.0, 0.0, 1.0]),
                    5126,
                    "VEC3",
                    "",
                );
                doc.attribute("NORMAL", normals);
            },
            &["NORMAL", "element 1 component 1 is NaN"],
        ),
        (
            "target normals of the wrong count",
            |doc| {
                let view = doc.view(&floats(&[0.0; 6]));
                let normals = doc.accessor(&format!(
                    r#"{{"bufferView": {view}, "componentType": 5126, "count": 2, "type": "VEC3"}}"#
                ));
                doc.target_attribute("NORMAL", normals);
            },
            &["target 0 NORMAL", "2 elements"],
        ),
        (
            "an infinite target normal delta",
            |doc| {
                let mut deltas = [0.0f32; 9];
                deltas[8] = f32::INFINITY;
                let normals = doc.dense(&floats(&deltas), 5126, "VEC3", "");
                doc.target_attribute("NORMAL", normals);
            },
            &["target 0 NORMAL", "element 2 component 2 is inf"],
        ),
        (
            "colours as SCALAR",
            |doc| {
                let colors = doc.dense(&floats(&[1.0; 3]), 5126, "SCALAR", "");
                doc.attribute("COLOR_0", colors);
            },
            &["COLOR_0", "expected Vec3 or Vec4"],
        ),
    ];
    let mut failures = Vec::new();
    for (name, edit, says) in cases {
        let mut doc = Gltf::triangle();
        edit(&mut doc);
        match doc.load(&name.replace(' ', "-")) {
            Ok(_) => failures.push(format!("{name}: accepted")),
            Err(err) if !matches!(err, LoadError::GltfData { .. }) => {
                failures.push(format!("{name}: {err:?}"))
            }
            Err(err) => {
                let message = err.to_string();
                if let Some(missing) = says.iter().find(|s| !message.contains(*s)) {
                    failures.push(format!("{name}: {message:?} should mention {missing:?}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn uv_triangle() -> Gltf {
    let mut doc = Gltf::triangle();
    let uvs = doc.dense(&floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]), 5126, "VEC2", "");
    doc.attribute("TEXCOORD_0", uvs);
    doc
}

#[test]
fn textures_load_from_every_image_source() {
    // Embedded in a buffer view, the format taken from the bytes.
    let mut doc = uv_triangle();
    let jpeg_bytes = {
        // SOI, then a baseline frame header of 4 x 3 pixels.
        let mut j = vec![0xFF, 0xD8, 0xFF, 0xC0, 0, 17, 8, 0, 3, 0, 4];
        j.extend([0; 12]);
        j
    };
    let view = doc.view(&jpeg_bytes);
    doc.textured(&format!(
        r#"{{"bufferView": {view}, "mimeType": "image/jpeg"}}"#
    ));
    let morph = doc.load("embedded").unwrap();
    let material = &morph.attributes().material;
    assert_eq!(material.name.as_deref(), Some("skin"));
    assert_eq!(material.base_color, [0.5, 0.25, 1.0, 1.0]);
    let texture = material.texture.as_ref().unwrap();
    assert_eq!(
        (texture.format, &texture.bytes),
        (ImageFormat::Jpeg, &jpeg_bytes)
    );
    assert_eq!(texture.sampler, Default::default());
    assert_eq!(
        morphlod::io::image_size(&texture.bytes).unwrap(),
        (ImageFormat::Jpeg, 4, 3)
    );

    // A data URI.
    let mut doc = uv_triangle();
    use base64::Engine;
    let data = base64::engine::general_purpose::STANDARD.encode(png());
    doc.textured(&format!(r#"{{"uri": "data:image/png;base64,{data}"}}"#));
    let morph = doc.load("data-uri").unwrap();
    let texture = morph.attributes().material.texture.clone().unwrap();
    assert_eq!((texture.format, texture.bytes), (ImageFormat::Png, png()));

    // An external file beside the glTF (percent-encoded name).
    let mut doc = uv_triangle();
    doc.textured(r#"{"uri": "my%20skin.png"}"#);
    let path = doc.write("external");
    std::fs::write(path.with_file_name("my skin.png"), png()).unwrap();
    let texture = load(&path).unwrap().attributes().material.texture.clone();
    assert_eq!(texture.map(|t| t.bytes), Some(png()));

    // Without the file: a typed error naming it.
    std::fs::remove_file(path.with_file_name("my skin.png")).unwrap();
    let err = load(&path).unwrap_err();
    assert!(
        matches!(&err, LoadError::GltfImageExternal { image: 0, file, .. } if file.ends_with("my skin.png")),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("keep the texture images beside"),
        "{err}"
    );
}

#[test]
fn a_texture_that_is_not_an_image_is_refused() {
    let mut doc = uv_triangle();
    let view = doc.view(b"GIF89a\x01\0\x01\0");
    doc.textured(&format!(
        r#"{{"bufferView": {view}, "mimeType": "image/png"}}"#
    ));
    let err = doc.load("gif").unwrap_err();
    assert!(
        matches!(err, LoadError::GltfImage { image: 0, .. }),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("neither a PNG nor a JPEG"),
        "{err}"
    );

    // A PNG signature over a corrupt header is no better.
    let mut doc = uv_triangle();
    let view = doc.view(&png()[..14]);
    doc.textured(&format!(
        r#"{{"bufferView": {view}, "mimeType": "image/png"}}"#
    ));
    let err = doc.load("cut-png").unwrap_err();
    assert!(matches!(err, LoadError::GltfImage { .. }), "{err:?}");
    assert!(err.to_string().contains("cut short"), "{err}");
}

/// glTF allows a texture without `source` (an extension supplies the image) and a
/// primitive without POSITION (skipped); the `gltf` crate's validator refuses both.
#[test]
fn spec_allowed_omissions_load() {
    let mut doc = uv_triangle();
    doc.textured(r#"{"uri": "unused.png"}"#);
    doc.extra[0] = doc.extra[0].replace(r#""textures": [{"source": 0}]"#, r#""textures": [{}]"#);
    let morph = doc.load("no-source").unwrap();
    assert_eq!(
        morph.attributes().material.base_color,
        [0.5, 0.25, 1.0, 1.0]
    );
    assert!(morph.attributes().material.texture.is_none());

    // A second primitive without POSITION draws nothing: skipped, with its NORMAL
    // (which would otherwise be one value short of nothing).
    let mut doc = Gltf::triangle();
    let normals = doc.dense(&floats(&[0.0, 0.0, 1.0].repeat(3)), 5126, "VEC3", "");
    doc.more_primitives =
        format!(r#", {{"attributes": {{"NORMAL": {normals}}}, "targets": [{{}}]}}"#);
    let morph = doc.load("no-position").unwrap();
    assert_eq!((morph.vertex_count(), morph.triangle_count()), (3, 1));
    assert!(morph.attributes().normals.is_none());
}

/// With `apply_transforms`, normals turn with the inverse transpose of the node's matrix
/// (so they stay perpendicular to the scaled surface), rescaled to unit length, and each
/// vertex's normal deltas by the same factor, so `normalize(n + w d)` turns exactly as the
/// surface does.
#[test]
fn node_transforms_turn_normals_and_their_deltas() {
    let mut doc = Gltf::triangle();
    let normals = doc.dense(&floats(&[1.0, 1.0, 0.0].repeat(3)), 5126, "VEC3", "");
    doc.attribute("NORMAL", normals);
    let deltas = doc.dense(&floats(&[0.0, 0.0, 1.0].repeat(3)), 5126, "VEC3", "");
    doc.target_attribute("NORMAL", deltas);
    doc.node = r#", "scale": [2, 1, 1]"#.to_string();
    let path = doc.write("scaled");
    let placed = LoadOptions {
        apply_transforms: true,
        ..LoadOptions::default()
    };
    let morph = load_morph(&path, &placed, &MorphSource::Target("0".to_string())).unwrap();
    // The face x = y stretched by 2 in x has normal (1/2, 1, 0), unit (1, 2, 0) / √5.
    let s = 1.0 / 5f32.sqrt();
    let close = |a: [f32; 3], b: [f32; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-6);
    let n = morph.attributes().normals.as_ref().unwrap();
    assert!(close(n[0], [s, 2.0 * s, 0.0]), "{n:?}");
    // The delta gets the factor 1 / |(1/2, 1, 0)| = 2 / √5 that made the normal unit.
    let d = morph.targets()[0].normal_deltas.as_ref().unwrap();
    assert!(close(d[0], [0.0, 0.0, 2.0 * s]), "{d:?}");
    // Untransformed, as the file has them.
    let morph = load(&path).unwrap();
    assert_eq!(
        morph.attributes().normals.as_ref().unwrap()[0],
        [1.0, 1.0, 0.0]
    );

    // A mirror flips the normal with the surface.
    doc.node = r#", "scale": [-1, 1, 1]"#.to_string();
    let path = doc.write("mirrored");
    let morph = load_morph(&path, &placed, &MorphSource::Target("0".to_string())).unwrap();
    let n = morph.attributes().normals.as_ref().unwrap();
    let h = 1.0 / 2f32.sqrt();
    assert!(close(n[0], [-h, h, 0.0]), "{n:?}");
}
