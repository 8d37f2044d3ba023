//! `morphlod export --quantize` (KHR_mesh_quantization) and `--compress`
//! (EXT_meshopt_compression): the Khronos validator passes both, a quantized export read back
//! with the `gltf` crate gives every position and target delta within the stated error (and
//! exactly the grid the exporter reports), three.js (GLTFLoader with the MeshoptDecoder three
//! ships) decodes every LOD of a compressed export to exactly the integers meant, the LOD choice
//! does not depend on quantization, and a corrupt compressed view is refused by our reader with a
//! typed error. The face is exported once per mode (without the distance term, as the other
//! export tests do) and shared by the tests.

use crate::common;

use base64::Engine;
use common::validator::{run_node, validate};
use gltf::json::Value;
use morphlod::export::{export_glb, Export, ExportOptions, QuantizeOptions};
use morphlod::io::{load_morph, LoadError, LoadOptions, MorphSource};
use morphlod::morph::Morph;
use morphlod::simplify::SimplifyOptions;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The error the issue allows: 1e-4 of the diagonal at 14-bit positions.
const MAX_ERROR: f32 = 1e-4;
const FRACTIONS: [f32; 3] = [0.1, 0.05, 0.02];

fn face() -> &'static Morph {
    static FACE: OnceLock<Morph> = OnceLock::new();
    FACE.get_or_init(|| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_face.glb");
        load_morph(
            &path,
            &LoadOptions::default(),
            &MorphSource::Animation("0".into()),
        )
        .expect("the face loads")
    })
}

/// The face exported with `--lods 0.1,0.05,0.02` plain, `--quantize` or `--compress`, without
/// the distance term (which only picks other collapses, for a much longer build).
fn exported(quantize: bool, compress: bool) -> &'static Export {
    static EXPORTS: [OnceLock<Export>; 3] = [OnceLock::new(), OnceLock::new(), OnceLock::new()];
    let slot = &EXPORTS[quantize as usize + compress as usize];
    slot.get_or_init(|| {
        let defaults = ExportOptions::default();
        let options = ExportOptions {
            lods: morphlod::export::LodSteps::Fractions(FRACTIONS.to_vec()),
            simplify: SimplifyOptions {
                distance_weight: 0.0,
                ..defaults.simplify
            },
            name: "face".into(),
            quantize: quantize.then(QuantizeOptions::default),
            compress,
            ..defaults
        };
        export_glb(face(), &options).expect("the face exports")
    })
}

fn write(name: &str, glb: &[u8]) -> PathBuf {
    let path = common::scratch_dir("export_compressed", name).join(format!("{name}.glb"));
    std::fs::write(&path, glb).unwrap();
    path
}

fn json(glb: &[u8]) -> Value {
    let length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&glb[20..20 + length]).unwrap()
}

fn validate_clean(file: &Path) {
    let Some((ok, report)) = validate(&[file]) else {
        return;
    };
    assert!(ok, "{report}");
    assert!(report.contains("\"errors\":0,\"warnings\":0"), "{report}");
}

/// Both files pass the validator with neither errors nor warnings, require the extensions they
/// use, keep MSFT_lod and every LOD's targets; the LODs are the plain export's (the choice does
/// not depend on quantization) and each LOD's quantisation error is within the bound.
#[test]
fn quantized_and_compressed_exports_validate_and_keep_the_lods() {
    let plain = exported(false, false);
    for (name, export, required) in [
        (
            "quantized",
            exported(true, false),
            vec!["KHR_mesh_quantization"],
        ),
        (
            "compressed",
            exported(true, true),
            vec!["KHR_mesh_quantization", "EXT_meshopt_compression"],
        ),
    ] {
        validate_clean(&write(name, &export.glb));
        let json = json(&export.glb);
        let listed = |key: &str| -> Vec<String> {
            json[key]
                .as_array()
                .into_iter()
                .flatten()
                .map(|v| v.as_str().unwrap().to_string())
                .collect()
        };
        assert_eq!(listed("extensionsRequired"), required, "{name}");
        assert!(listed("extensionsUsed").contains(&"MSFT_lod".to_string()));
        assert_eq!(
            json["nodes"][0]["extensions"]["MSFT_lod"]["ids"],
            serde_json::json!([1, 2, 3])
        );
        for mesh in json["meshes"].as_array().unwrap() {
            let targets = mesh["primitives"][0]["targets"].as_array().unwrap();
            assert_eq!(targets.len(), face().targets().len(), "{name}");
        }
        assert_eq!(export.lods.len(), plain.lods.len());
        for (lod, same) in export.lods.iter().zip(&plain.lods) {
            assert_eq!(
                (lod.step, &lod.source_vertex, &lod.triangles),
                (same.step, &same.source_vertex, &same.triangles),
                "{name}: the LOD choice changed"
            );
            assert!(
                lod.quantization_error > 0.0 && lod.quantization_error <= MAX_ERROR,
                "{name}: {}",
                lod.quantization_error
            );
            assert!(lod.bytes > 0 && lod.bytes < same.bytes, "{name}: {lod:?}");
        }
    }
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt()
}

/// A quantized export read with the `gltf` crate (parsed without its validation, which refuses
/// every required extension it does not implement, KHR_mesh_quantization included): every LOD
/// node carries the grid's dequantising transform, the positions are the grid points the
/// exporter reports, and every vertex of the base and of every target's pose at weight 1
/// dequantises to within the stated error of the source.
#[test]
fn a_quantized_export_round_trips_through_the_gltf_crate() {
    let export = exported(true, false);
    let grid = export.grid.expect("a quantized export reports its grid");
    let gltf = gltf::Gltf::from_slice_without_validation(&export.glb).unwrap();
    let blob = gltf.blob.clone().unwrap();
    let morph = face();
    let bound = MAX_ERROR * common::diagonal(morph.base()) as f32;
    for (node, lod) in gltf.nodes().zip(&export.lods) {
        let (translation, _, scale) = node.transform().decomposed();
        assert_eq!(translation, grid.offset);
        assert_eq!(scale, [grid.step; 3]);
        let primitive = node.mesh().unwrap().primitives().next().unwrap();
        let positions = primitive.get(&gltf::Semantic::Positions).unwrap();
        assert_eq!(positions.data_type(), gltf::accessor::DataType::U16);
        let base: Vec<[u16; 3]> = gltf::accessor::Iter::new(positions, |_| Some(&blob[..]))
            .unwrap()
            .collect();
        assert_eq!(base.len(), lod.source_vertex.len());
        let read = |q: [i32; 3]| grid.dequantize(q);
        for (&q, &v) in base.iter().zip(&lod.source_vertex) {
            let source = morph.base()[v as usize];
            assert_eq!(q, grid.quantize(source));
            assert!(distance(read(q.map(i32::from)), source) <= bound);
        }
        for (target, source) in primitive.morph_targets().zip(morph.targets()) {
            let accessor = target.positions().unwrap();
            assert_eq!(accessor.data_type(), gltf::accessor::DataType::I16);
            let deltas: Vec<[i16; 3]> = gltf::accessor::Iter::new(accessor, |_| Some(&blob[..]))
                .unwrap()
                .collect();
            for ((&q, &d), &v) in base.iter().zip(&deltas).zip(&lod.source_vertex) {
                let v = v as usize;
                let pose: [f32; 3] =
                    std::array::from_fn(|k| morph.base()[v][k] + source.deltas[v][k]);
                let stored = std::array::from_fn(|k| q[k] as i32 + d[k] as i32);
                assert!(
                    distance(read(stored), pose) <= bound,
                    "{}: vertex {v}",
                    source.name
                );
            }
        }
    }
}

/// three.js's GLTFLoader with the MeshoptDecoder three ships loads every LOD of the compressed
/// face, and what it decoded is what the exporter meant, bit for bit: every LOD node's
/// translation and scale are the grid's, its positions the grid points of the kept vertices,
/// every target's POSITION deltas the grid deltas and its NORMAL deltas the normalized bytes.
#[test]
fn three_js_decodes_every_lod_bit_for_bit() {
    let export = exported(true, true);
    let grid = export.grid.unwrap();
    let file = write("three", &export.glb);
    let lods = export.lods.len().to_string();
    let Some((ok, report)) = run_node(
        "gltf-loader",
        "three",
        "decode.mjs",
        &[file.as_os_str(), "face".as_ref(), lods.as_ref()],
    ) else {
        return;
    };
    assert!(ok, "{report}");
    let decoded: Value = serde_json::from_str(report.trim()).expect("one JSON line");
    let bytes = |dump: &Value, ty: &str| -> Vec<u8> {
        assert_eq!(dump["type"], ty);
        base64::engine::general_purpose::STANDARD
            .decode(dump["base64"].as_str().unwrap())
            .unwrap()
    };
    let morph = face();
    let le16 = |values: Vec<[i32; 3]>| -> Vec<u8> {
        values
            .iter()
            .flatten()
            .flat_map(|&c| (c as i16).to_le_bytes())
            .collect()
    };
    for (lod, got) in export.lods.iter().zip(decoded["lods"].as_array().unwrap()) {
        let name = got["name"].as_str().unwrap();
        let vector = |key: &str| -> Vec<u32> {
            got[key]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| (x.as_f64().unwrap() as f32).to_bits())
                .collect()
        };
        assert_eq!(
            vector("translation"),
            grid.offset.map(f32::to_bits),
            "{name}"
        );
        assert_eq!(vector("scale"), [grid.step.to_bits(); 3], "{name}");
        assert_eq!(got["indices"], lod.triangles.len() * 3, "{name}");
        let kept = || lod.source_vertex.iter().map(|&v| v as usize);
        let positions: Vec<[i32; 3]> = kept()
            .map(|v| grid.quantize(morph.base()[v]).map(i32::from))
            .collect();
        assert_eq!(
            bytes(&got["position"], "Uint16Array"),
            le16(positions),
            "{name}"
        );
        let targets = morph.targets();
        let morph_positions = got["morphPosition"].as_array().unwrap();
        let morph_normals = got["morphNormal"].as_array().unwrap();
        assert_eq!(morph_positions.len(), targets.len(), "{name}");
        assert_eq!(morph_normals.len(), targets.len(), "{name}");
        for (k, target) in targets.iter().enumerate() {
            let deltas: Vec<[i32; 3]> = kept()
                .map(|v| grid.delta(morph.base()[v], target.deltas[v]).map(i32::from))
                .collect();
            assert_eq!(
                bytes(&morph_positions[k], "Int16Array"),
                le16(deltas),
                "{name}: {}",
                target.name
            );
            // Normalized bytes at 8 bits: round(127 · d), clamped to ±1.
            let normal_deltas = target.normal_deltas.as_ref().unwrap();
            let expected: Vec<u8> = kept()
                .flat_map(|v| {
                    normal_deltas[v].map(|d| (d.clamp(-1.0, 1.0) * 127.0).round() as i8 as u8)
                })
                .collect();
            assert_eq!(
                bytes(&morph_normals[k], "Int8Array"),
                expected,
                "{name}: {} normals",
                target.name
            );
        }
    }
}

/// Our reader loads the compressed face (decoding every view), and refuses it with a typed
/// error that names the view when a compressed stream's header is broken or its data cut short.
#[test]
fn a_corrupt_compressed_buffer_is_refused_with_a_typed_error() {
    let export = exported(true, true);
    let file = write("intact", &export.glb);
    let options = LoadOptions::default();
    let source = MorphSource::Animation("0".into());
    let read = load_morph(&file, &options, &source).expect("the compressed face loads");
    assert_eq!(read.targets().len(), face().targets().len());
    assert_eq!(read.vertex_count(), face().vertex_count());

    let json = json(&export.glb);
    let (view, ext) = json["bufferViews"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .find_map(|(i, v)| Some((i, v["extensions"].get("EXT_meshopt_compression")?.clone())))
        .expect("a compressed view");
    let json_length = u32::from_le_bytes(export.glb[12..16].try_into().unwrap()) as usize;
    let bin = 20 + json_length + 8;
    let at = bin + ext["byteOffset"].as_u64().unwrap() as usize;

    let mut broken = export.glb.clone();
    broken[at] ^= 0xff;
    let err = load_morph(&write("header", &broken), &options, &source).unwrap_err();
    assert!(
        matches!(&err, LoadError::GltfCompressed { view: v, .. } if *v == view),
        "{err:?}"
    );
    assert!(err.to_string().contains("corrupt"), "{err}");

    // The stream cut to its header: the codec's own check refuses it.
    let cut = export.glb.clone();
    let text = String::from_utf8(cut[20..20 + json_length].to_vec()).unwrap();
    let length = format!(r#""byteLength":{}"#, ext["byteLength"]);
    let offset = format!(r#""byteOffset":{},{length}"#, ext["byteOffset"]);
    let short = format!(r#""byteOffset":{},"byteLength":1"#, ext["byteOffset"]);
    assert!(text.contains(&offset), "{offset}");
    // Same length after the edit, so the GLB framing holds: pad the number with spaces.
    let padded = format!("{short}{}", " ".repeat(offset.len() - short.len()));
    let text = text.replacen(&offset, &padded, 1);
    let mut cut = cut;
    cut[20..20 + json_length].copy_from_slice(text.as_bytes());
    let err = load_morph(&write("cut", &cut), &options, &source).unwrap_err();
    assert!(matches!(err, LoadError::GltfCompressed { .. }), "{err:?}");
    assert!(err.to_string().contains("EXT_meshopt_compression"), "{err}");
}

/// `morphlod export IN --lods 0.5,0.1 --distance-weight 0 MODE -o OUT`: its output.
fn cli_export(input: &Path, mode: &str, out: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .arg("export")
        .arg(input)
        .args(["--lods", "0.5,0.1", "--distance-weight", "0", mode, "-o"])
        .arg(out)
        .output()
        .expect("the morphlod binary runs")
}

/// A skinned character compressed: glTF ignores a skinned node's transform, so the grid's
/// dequantising transform is in every inverse bind matrix (`IBM · D`) and the LOD nodes keep
/// the source's; the file passes the validator. A mesh node with an animated transform (not
/// skinned) is refused with a message, since its channels would replace the transform.
#[test]
fn a_skinned_face_carries_the_grid_in_its_inverse_bind_matrices() {
    let dir = common::scratch_dir("export_compressed", "skinned");
    let (input, face) = common::skinned_face(&dir);
    let out = dir.join("skinned.glb");
    let output = cli_export(&input, "--compress", &out);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    validate_clean(&out);
    let glb = std::fs::read(&out).unwrap();
    let json = json(&glb);
    let lod0 = &json["nodes"][0];
    assert!(
        lod0.get("scale").is_none() && lod0.get("translation").is_none(),
        "{lod0}"
    );
    // The grid as the un-skinned export of the same mesh writes it on its nodes.
    let plain = exported(true, false);
    let grid = plain.grid.unwrap();
    let d = glam::Mat4::from_scale_rotation_translation(
        glam::Vec3::splat(grid.step),
        glam::Quat::IDENTITY,
        glam::Vec3::from_array(grid.offset),
    );
    // The matrices' view is compressed (ATTRIBUTES, 4-byte elements): decoded here with the
    // meshopt crate directly, apart from the exporter's and our reader's code.
    let accessor =
        &json["accessors"][json["skins"][0]["inverseBindMatrices"].as_u64().unwrap() as usize];
    let view = &json["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
    let ext = &view["extensions"]["EXT_meshopt_compression"];
    assert_eq!(
        (ext["mode"].as_str(), ext["byteStride"].as_u64()),
        (Some("ATTRIBUTES"), Some(4))
    );
    let json_length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let at = 20 + json_length + 8 + ext["byteOffset"].as_u64().unwrap() as usize;
    let data = &glb[at..at + ext["byteLength"].as_u64().unwrap() as usize];
    let words: Vec<[u8; 4]> =
        meshopt::decode_vertex_buffer(data, ext["count"].as_u64().unwrap() as usize).unwrap();
    let floats: Vec<f32> = words.into_iter().map(f32::from_le_bytes).collect();
    let matrices: Vec<[[f32; 4]; 4]> = floats
        .chunks_exact(16)
        .map(|m| std::array::from_fn(|c| std::array::from_fn(|r| m[4 * c + r])))
        .collect();
    assert_eq!(matrices.len(), face.inverse_bind_matrices.len());
    for (read, source) in matrices.iter().zip(&face.inverse_bind_matrices) {
        let expected = (glam::Mat4::from_cols_array(source) * d).to_cols_array_2d();
        assert_eq!(*read, expected);
    }

    let rigged = common::rigged_cube(&dir);
    if rigged.exists() {
        let output = cli_export(&rigged, "--quantize", &dir.join("rigged.glb"));
        assert_eq!(output.status.code(), Some(1));
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains("without --quantize"), "{stderr}");
    }
}
