//! `morphlod export --quantize` (KHR_mesh_quantization) and `--compress`
//! (EXT_meshopt_compression): the Khronos validator passes both, a quantized export read back
//! with the `gltf` crate gives every position and target delta within the stated error (and
//! exactly the grid the exporter reports), three.js (GLTFLoader with the MeshoptDecoder three
//! ships) decodes every LOD of a compressed export to exactly the integers meant, our reader
//! decodes every attribute of both within its quantisation and gives back the reported
//! quantisation error, the LOD choice does not depend on quantization, and a corrupt compressed
//! view is refused by our reader with a typed error. The face is exported once per mode (without the distance term, as the other
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
/// translation and scale are the grid's, its indices the LOD's triangles (in order and winding,
/// corners rotated where the codec did), its positions the grid points of the kept vertices,
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
        let index = &got["index"];
        let indices: Vec<u32> = match index["type"].as_str() {
            Some("Uint16Array") => bytes(index, "Uint16Array")
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]) as u32)
                .collect(),
            _ => bytes(index, "Uint32Array")
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes(b.try_into().unwrap()))
                .collect(),
        };
        let triangles: Vec<[u32; 3]> = indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        assert_same_triangles(&triangles, &lod.triangles, name);
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

/// `decoded` are `expected`'s triangles in the same order, each with its corners in the same
/// cyclic order (the winding): EXT_meshopt_compression's TRIANGLES codec may start a triangle at
/// another corner to reuse an edge it has seen, and nothing else.
fn assert_same_triangles(decoded: &[[u32; 3]], expected: &[[u32; 3]], what: &str) {
    assert_eq!(decoded.len(), expected.len(), "{what}: triangle count");
    let rotations = |t: [u32; 3]| [t, [t[1], t[2], t[0]], [t[2], t[0], t[1]]];
    for (i, (&got, &want)) in decoded.iter().zip(expected).enumerate() {
        assert!(
            rotations(want).contains(&got),
            "{what}: triangle {i} decodes as {got:?}, the LOD has {want:?}"
        );
    }
}

/// The LOD node's dequantising transform as the file states it: (translation, uniform scale).
fn node_grid(json: &Value, node: usize) -> ([f64; 3], f64) {
    // The numbers are f32s written in their shortest form: read back as the f32 they name.
    let number = |v: &Value| v.as_f64().unwrap() as f32 as f64;
    let node = &json["nodes"][node];
    let scale: Vec<f64> = node["scale"]
        .as_array()
        .unwrap()
        .iter()
        .map(number)
        .collect();
    assert!(scale.iter().all(|&s| s == scale[0]), "{node}");
    let t = node["translation"].as_array().unwrap();
    (std::array::from_fn(|k| number(&t[k])), scale[0])
}

/// Every LOD of `export` as our reader decodes it, quantized values as stored (the node
/// transform not applied).
fn read_lods(export: &Export, name: &str) -> Vec<Morph> {
    let file = write(&format!("read_{name}"), &export.glb);
    (0..export.lods.len())
        .map(|i| {
            let options = LoadOptions {
                gltf_mesh: Some(format!("face_LOD{i}")),
                apply_transforms: false,
            };
            load_morph(&file, &options, &MorphSource::Animation("0".into()))
                .unwrap_or_else(|e| panic!("{name}: LOD{i} loads: {e}"))
        })
        .collect()
}

/// The largest component difference between `read` and `source`.
fn worst<const N: usize>(read: &[[f32; N]], source: impl Iterator<Item = [f32; N]>) -> f32 {
    read.iter()
        .zip(source)
        .flat_map(|(a, b)| (0..N).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0, f32::max)
}

/// Our reader's decode of the quantized and of the compressed face, every LOD, against the
/// source, each attribute within what its quantisation allows: the triangles are the LOD's
/// (corners rotated at most, compressed); every position and every target's pose at weight 1,
/// dequantised with the node's transform, within half a grid step per component of the source;
/// every normal within half a step of its bits per component (quantized) or within the
/// octahedral encoding's bound (compressed: half a step per octahedral coordinate moves a unit
/// normal by at most √18 half-steps, and the decoded bytes round once more, √3 half-steps);
/// every normal delta within half a step of the source clamped to ±1; every UV within half a
/// step of its bits plus the rounding to 16 bits.
#[test]
fn our_reader_decodes_every_attribute_within_its_quantisation() {
    let morph = face();
    let source = morph.attributes();
    let (source_normals, source_uvs) = (source.normals.as_ref(), source.uvs.as_ref());
    let bits = QuantizeOptions::default();
    let normal_step = 0.5 / ((1 << (bits.normal_bits - 1)) - 1) as f32;
    let uv_step = 0.5 / ((1 << bits.uv_bits) - 1) as f32 + 0.5 / 65535.0;
    for (name, export, compressed) in [
        ("quantized", exported(true, false), false),
        ("compressed", exported(true, true), true),
    ] {
        let json = json(&export.glb);
        for (i, (lod, read)) in export.lods.iter().zip(read_lods(export, name)).enumerate() {
            let what = format!("{name} LOD{i}");
            if compressed {
                assert_same_triangles(read.triangles(), &lod.triangles, &what);
            } else {
                assert_eq!(read.triangles(), &lod.triangles[..], "{what}");
            }
            let kept = || lod.source_vertex.iter().map(|&v| v as usize);
            let (offset, step) = node_grid(&json, i);
            let place = |q: [f32; 3]| -> [f32; 3] {
                std::array::from_fn(|k| (offset[k] + step * q[k] as f64) as f32)
            };
            // Half a step per component, and f32 rounding of a coordinate of up to ~1.
            let half_step = (step / 2.0) as f32 + 1e-6;
            let positions: Vec<[f32; 3]> = read.base().iter().map(|&q| place(q)).collect();
            assert_eq!(positions.len(), lod.source_vertex.len(), "{what}");
            let error = worst(&positions, kept().map(|v| morph.base()[v]));
            assert!(error <= half_step, "{what}: positions off by {error}");
            assert_eq!(read.targets().len(), morph.targets().len(), "{what}");
            for (got, target) in read.targets().iter().zip(morph.targets()) {
                let poses: Vec<[f32; 3]> = read
                    .base()
                    .iter()
                    .zip(&got.deltas)
                    .map(|(q, d)| place(std::array::from_fn(|k| q[k] + d[k])))
                    .collect();
                let exact = kept()
                    .map(|v| std::array::from_fn(|k| morph.base()[v][k] + target.deltas[v][k]));
                let error = worst(&poses, exact);
                assert!(error <= half_step, "{what}: {} off by {error}", target.name);
                let normal_deltas = got.normal_deltas.as_ref().expect("normal deltas");
                let source = target.normal_deltas.as_ref().unwrap();
                let clamped = kept().map(|v| source[v].map(|d| d.clamp(-1.0, 1.0)));
                let error = worst(normal_deltas, clamped);
                assert!(
                    error <= normal_step + 1e-6,
                    "{what}: {} normal deltas off by {error}",
                    target.name
                );
            }
            let normals = read.attributes().normals.as_ref().expect("normals");
            let source = source_normals.unwrap();
            let error = if compressed {
                normals
                    .iter()
                    .zip(kept())
                    .map(|(n, v)| distance(*n, source[v]))
                    .fold(0.0, f32::max)
            } else {
                worst(normals, kept().map(|v| source[v]))
            };
            let bound = match compressed {
                true => (18f32.sqrt() + 3f32.sqrt()) * normal_step,
                false => normal_step + 1e-6,
            };
            assert!(error <= bound, "{what}: normals off by {error} > {bound}");
            let uvs = read.attributes().uvs.as_ref().expect("UVs");
            let error = worst(uvs, kept().map(|v| source_uvs.unwrap()[v]));
            assert!(error <= uv_step + 1e-7, "{what}: UVs off by {error}");
        }
    }
}

/// Each LOD's `quantization_error` is what the decoded file gives: per kept vertex, the largest
/// distance over the measured poses (32 weight sets evenly over the animation, the default
/// weights, each target alone at weight 1) between the pose read from the file's integers and
/// its transform (`offset + step · (q + Σ w·d)`) and the source's (`base + Σ w·delta`), the
/// largest over the LOD's vertices, relative to the base's diagonal; computed here in `f64`,
/// equal to the reported `f32` to its rounding.
#[test]
fn the_reported_quantization_error_is_the_decoded_files() {
    let morph = face();
    let n = morph.targets().len();
    let samples = morphlod::export::DEFAULT_POSES;
    let mut poses: Vec<Vec<f32>> = (0..samples)
        .map(|i| morph.weights_at(i as f32 / (samples - 1) as f32))
        .collect();
    poses.push(morph.weights_at(0.0));
    poses.extend((0..n).map(|k| (0..n).map(|j| (j == k) as u8 as f32).collect()));
    let diagonal = common::diagonal(morph.base());
    for (name, export) in [
        ("quantized", exported(true, false)),
        ("compressed", exported(true, true)),
    ] {
        let json = json(&export.glb);
        for (i, (lod, read)) in export.lods.iter().zip(read_lods(export, name)).enumerate() {
            let (offset, step) = node_grid(&json, i);
            let mut largest = 0.0f64;
            for (r, &v) in lod.source_vertex.iter().enumerate() {
                let v = v as usize;
                for weights in &poses {
                    let mut exact = morph.base()[v].map(f64::from);
                    let mut stored = read.base()[r].map(f64::from);
                    for ((source, got), &w) in
                        morph.targets().iter().zip(read.targets()).zip(weights)
                    {
                        for k in 0..3 {
                            exact[k] += w as f64 * source.deltas[v][k] as f64;
                            stored[k] += w as f64 * got.deltas[r][k] as f64;
                        }
                    }
                    let d2: f64 = (0..3)
                        .map(|k| (offset[k] + step * stored[k] - exact[k]).powi(2))
                        .sum();
                    largest = largest.max(d2.sqrt());
                }
            }
            let recomputed = largest / diagonal;
            let reported = lod.quantization_error as f64;
            assert!(
                (reported - recomputed).abs() <= 1e-5 * recomputed,
                "{name} LOD{i}: reported {reported}, the file gives {recomputed}"
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
    let output = cli_export(&rigged, "--quantize", &dir.join("rigged.glb"));
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("without --quantize"), "{stderr}");
}
