//! `morphlod export` and `morphlod::export::export_glb`: the file read back with the `gltf`
//! crate (one mesh and node per LOD, triangle counts falling, every kept vertex's position,
//! attributes and target deltas equal to the source's bit for bit, one animation channel per
//! LOD node, the MSFT_lod chain), checked by the Khronos validator, and bad input refused with
//! a message and exit code 1.

use crate::common;

use common::validator::validate;
use gltf::animation::{util::ReadOutputs, Interpolation, Property};
use gltf::json::Value;
use morphlod::build::{Builder, Sequences};
use morphlod::collapse::canonical_multiset;
use morphlod::export::{export_glb, Export, ExportOptions, LodSteps, DEFAULT_POSES};
use morphlod::io::{
    load_attributed, load_mesh, load_morph, morph_from_pair, LoadOptions, MorphSource,
};
use morphlod::morph::Morph;
use morphlod::seams::StepBoundaries;
use morphlod::simplify::{PoseError, SimplifyOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name)
}

fn temp_dir(name: &str) -> PathBuf {
    common::scratch_dir("export", name)
}

fn morphlod(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .arg("export")
        .args(args)
        .output()
        .expect("the morphlod binary runs")
}

/// `morphlod export INPUTS --lods LODS --distance-weight 0 -o OUT`, which must succeed; the
/// GLB it wrote. The tests here check what the file holds, which the distance term does not
/// change (it picks other collapses, for a build ~100 times longer: most of CI's time when it
/// was on); its default reaches the CLI in tests/suite/cli.rs and its quality is checked in
/// tests/suite/shared_sequence.rs.
fn export_lods(inputs: &[PathBuf], lods: &str, out: &Path) -> Vec<u8> {
    let mut args: Vec<&std::ffi::OsStr> = inputs.iter().map(|p| p.as_os_str()).collect();
    args.extend([
        "--lods".as_ref(),
        lods.as_ref(),
        "--distance-weight".as_ref(),
        "0".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let output = morphlod(&args);
    assert!(
        output.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    std::fs::read(out).unwrap()
}

/// [`ExportOptions::default`] without the distance term, as [`export_lods`] runs the CLI.
fn structural() -> ExportOptions {
    let defaults = ExportOptions::default();
    ExportOptions {
        simplify: SimplifyOptions {
            distance_weight: 0.0,
            ..defaults.simplify
        },
        ..defaults
    }
}

fn bits<const N: usize>(v: [f32; N]) -> [u32; N] {
    v.map(f32::to_bits)
}

/// Every LOD of `export` as read back from its bytes equals the source at the kept vertices,
/// bit for bit: positions, normals, UVs, colours, each target's POSITION and NORMAL deltas;
/// indices are the LOD's; triangle counts fall from LOD to LOD.
fn check_against_source(morph: &Morph, export: &Export) {
    let gltf = gltf::Gltf::from_slice(&export.glb).expect("the GLB parses");
    let blob = gltf.blob.clone().expect("a BIN chunk");
    let meshes: Vec<gltf::Mesh> = gltf.meshes().collect();
    assert_eq!(meshes.len(), export.lods.len(), "one mesh per LOD");
    let attributes = morph.attributes();
    let mut previous = usize::MAX;
    for (mesh, lod) in meshes.iter().zip(&export.lods) {
        let primitives: Vec<_> = mesh.primitives().collect();
        assert_eq!(primitives.len(), 1);
        let reader = primitives[0].reader(|_| Some(&blob[..]));
        let kept = |v: usize| lod.source_vertex[v] as usize;

        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        let flat: Vec<u32> = lod.triangles.iter().flatten().copied().collect();
        assert_eq!(indices, flat);
        assert!(lod.triangles.len() < previous, "triangle counts fall");
        previous = lod.triangles.len();

        let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        assert_eq!(positions.len(), lod.source_vertex.len());
        for (v, p) in positions.iter().enumerate() {
            assert_eq!(bits(*p), bits(morph.base()[kept(v)]));
        }
        if let Some(normals) = &attributes.normals {
            for (v, n) in reader.read_normals().unwrap().enumerate() {
                assert_eq!(bits(n), bits(normals[kept(v)]));
            }
        }
        if let Some(uvs) = &attributes.uvs {
            let read = reader.read_tex_coords(0).unwrap().into_f32();
            for (v, uv) in read.enumerate() {
                assert_eq!(bits(uv), bits(uvs[kept(v)]));
            }
        }
        if let Some(colors) = &attributes.colors {
            let read = reader.read_colors(0).unwrap().into_rgba_f32();
            for (v, c) in read.enumerate() {
                assert_eq!(bits(c), bits(colors[kept(v)]));
            }
        }
        let targets: Vec<_> = reader.read_morph_targets().collect();
        assert_eq!(targets.len(), morph.targets().len(), "every target kept");
        for ((deltas, normal_deltas, _), source) in targets.into_iter().zip(morph.targets()) {
            for (v, d) in deltas.unwrap().enumerate() {
                assert_eq!(bits(d), bits(source.deltas[kept(v)]), "{}", source.name);
            }
            match (normal_deltas, &source.normal_deltas) {
                (Some(read), Some(nd)) => {
                    for (v, d) in read.enumerate() {
                        assert_eq!(bits(d), bits(nd[kept(v)]), "{}", source.name);
                    }
                }
                (None, None) => {}
                _ => panic!("target {}: NORMAL deltas lost or invented", source.name),
            }
        }
    }
}

/// The JSON chunk of a GLB.
fn json(glb: &[u8]) -> Value {
    let glb = gltf::Glb::from_slice(glb).unwrap();
    gltf::json::deserialize::from_slice(&glb.json).unwrap()
}

/// One node per LOD named `<name>_LOD<i>`, LOD0 in the scene declaring the others with
/// MSFT_lod and one screen coverage per LOD, one animation channel per LOD node.
fn check_structure(glb: &[u8], name: &str, lods: usize, animated: bool) {
    let json = json(glb);
    assert_eq!(json["extensionsUsed"][0], "MSFT_lod");
    let nodes = json["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), lods);
    for (i, node) in nodes.iter().enumerate() {
        assert_eq!(node["name"], format!("{name}_LOD{i}").as_str());
        assert_eq!(node["mesh"], i);
    }
    let ids: Vec<u64> = nodes[0]["extensions"]["MSFT_lod"]["ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(ids, (1..lods as u64).collect::<Vec<_>>());
    let coverage = nodes[0]["extras"]["MSFT_screencoverage"]
        .as_array()
        .unwrap();
    assert_eq!(coverage.len(), lods);
    assert_eq!(json["scenes"][0]["nodes"].as_array().unwrap().len(), 1);
    if animated {
        let channels = json["animations"][0]["channels"].as_array().unwrap();
        let driven: Vec<u64> = channels
            .iter()
            .map(|c| {
                assert_eq!(c["target"]["path"], "weights");
                assert_eq!(c["sampler"], 0);
                c["target"]["node"].as_u64().unwrap()
            })
            .collect();
        assert_eq!(driven, (0..lods as u64).collect::<Vec<_>>());
    }
}

fn validate_clean(file: &Path) {
    let Some((ok, report)) = validate(&[file]) else {
        return;
    };
    assert!(ok, "{report}");
    assert!(report.contains("\"errors\":0,\"warnings\":0"), "{report}");
}

/// The binary buffer of a glTF file: its BIN chunk, or (a `.gltf`) its one external buffer.
fn blob_of(path: &Path, doc: &gltf::Gltf) -> Vec<u8> {
    if let Some(blob) = &doc.blob {
        return blob.clone();
    }
    match doc.buffers().next().expect("a buffer").source() {
        gltf::buffer::Source::Uri(uri) => std::fs::read(path.with_file_name(uri)).unwrap(),
        gltf::buffer::Source::Bin => panic!("{path:?}: no BIN chunk"),
    }
}

/// The morph-weight animation of a document, read with the `gltf` crate: its sampler's
/// interpolation, key times and values as bits. Every `weights` channel uses that one sampler.
fn weight_track(doc: &gltf::Gltf, blob: &[u8]) -> (Interpolation, Vec<u32>, Vec<u32>) {
    let channels: Vec<gltf::animation::Channel> = doc
        .animations()
        .take(1)
        .flat_map(|a| a.channels())
        .filter(|c| c.target().property() == Property::MorphTargetWeights)
        .collect();
    assert!(!channels.is_empty(), "no weights channel");
    let sampler = channels[0].sampler().index();
    assert!(channels.iter().all(|c| c.sampler().index() == sampler));
    let reader = channels[0].reader(|_| Some(blob));
    let times = reader.read_inputs().unwrap().map(f32::to_bits).collect();
    let values = match reader.read_outputs().unwrap() {
        ReadOutputs::MorphTargetWeights(w) => w.into_f32().map(f32::to_bits).collect(),
        _ => panic!("not a weights sampler"),
    };
    (channels[0].sampler().interpolation(), times, values)
}

/// The exported weight animation is the source file's first animation's weight track: the
/// interpolation, every key and every value, bit for bit.
fn check_weights_against_source(glb: &[u8], source: &Path) {
    let exported = gltf::Gltf::from_slice(glb).unwrap();
    // Without validation: the face's file has accessors without a buffer view (zeros), which
    // the gltf crate's validation refuses and glTF allows.
    let original =
        gltf::Gltf::from_slice_without_validation(&std::fs::read(source).unwrap()).unwrap();
    let (interpolation, times, values) = weight_track(&exported, exported.blob.as_deref().unwrap());
    let (source_interpolation, source_times, source_values) =
        weight_track(&original, &blob_of(source, &original));
    assert_eq!(interpolation, source_interpolation, "{source:?}");
    let first_difference =
        |a: &[u32], b: &[u32]| (a.len(), b.len(), a.iter().zip(b).position(|(x, y)| x != y));
    assert!(
        times == source_times,
        "{source:?}: key times differ (lengths and first difference: {:?})",
        first_difference(&times, &source_times)
    );
    assert!(
        values == source_values,
        "{source:?}: weights differ (lengths and first difference: {:?})",
        first_difference(&values, &source_values)
    );
}

/// makehuman_face.glb (52 targets with NORMAL deltas, normals, UVs, a JPEG texture, seams and
/// a weight animation): every LOD keeps every target and attribute bit for bit.
#[test]
fn face_lods_keep_targets_and_attributes_bit_for_bit() {
    let path = asset("makehuman_face.glb");
    let morph = load_morph(
        &path,
        &LoadOptions::default(),
        &MorphSource::Animation("0".into()),
    )
    .unwrap();
    assert!(morph.attributes().material.texture.is_some());
    assert!(morph.targets().iter().all(|t| t.normal_deltas.is_some()));
    let export = export_glb(
        &morph,
        &ExportOptions {
            name: "face".into(),
            ..structural()
        },
    )
    .unwrap();
    assert_eq!(export.lods.len(), 4);
    for lod in &export.lods[1..] {
        let goal = lod.fraction * morph.triangle_count() as f32;
        assert!(lod.triangles.len() as f32 <= goal, "{lod:?}");
    }
    // LOD0 is the original: the same triangles, over the same vertices.
    let lod0 = &export.lods[0];
    let back = lod0
        .triangles
        .iter()
        .map(|t| t.map(|v| lod0.source_vertex[v as usize]));
    assert_eq!(
        canonical_multiset(back),
        canonical_multiset(morph.triangles().iter().copied())
    );
    check_against_source(&morph, &export);
    check_structure(&export.glb, "face", 4, true);
    check_weights_against_source(&export.glb, &path);
    let gltf = gltf::Gltf::from_slice(&export.glb).unwrap();
    assert_eq!(gltf.textures().count(), 1);
    assert_eq!(gltf.animations().count(), 1);
}

/// `--error` steps on the face: each LOD's error (the shared sequence's, relative to the
/// bounding-box diagonal) is within its bound, the LODs get coarser as the bounds grow, and
/// every LOD keeps targets and attributes bit for bit.
#[test]
fn face_error_steps_stay_within_their_bounds() {
    let morph = load_morph(
        &asset("makehuman_face.glb"),
        &LoadOptions::default(),
        &MorphSource::Animation("0".into()),
    )
    .unwrap();
    let bounds = [0.001, 0.004, 0.02];
    let export = export_glb(
        &morph,
        &ExportOptions {
            lods: LodSteps::Errors(bounds.to_vec()),
            name: "face".into(),
            ..structural()
        },
    )
    .unwrap();
    assert_eq!(export.lods.len(), bounds.len() + 1);
    for (lod, bound) in export.lods[1..].iter().zip(bounds) {
        assert!(lod.error <= bound, "{bound}: {lod:?}");
        assert!(lod.step > 0, "{bound}: the bound allows some collapses");
    }
    let steps: Vec<usize> = export.lods.iter().map(|l| l.step).collect();
    assert!(steps.windows(2).all(|w| w[0] < w[1]), "{steps:?}");
    check_against_source(&morph, &export);
    check_structure(&export.glb, "face", bounds.len() + 1, true);
}

/// The CLI on the face, on the AnimatedMorphCube sample (.gltf with an external buffer) and on
/// a supermesh pair (bunny.obj, cow.off): the Khronos validator reports 0 errors and 0
/// warnings, the structure is as declared.
#[test]
fn exported_files_pass_the_khronos_validator() {
    let dir = temp_dir("validator");
    let cases = [
        (
            vec![asset("makehuman_face.glb")],
            "makehuman_face",
            "0.5,0.25,0.1",
        ),
        (
            vec![asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf")],
            "AnimatedMorphCube",
            "0.6,0.3",
        ),
        (
            vec![asset("bunny.obj"), asset("cow.off")],
            "bunny",
            "0.5,0.1",
        ),
    ];
    for (inputs, name, lods) in cases {
        let out = dir.join(format!("{name}.glb"));
        let glb = export_lods(&inputs, lods, &out);
        check_structure(&glb, name, lods.split(',').count() + 1, true);
        validate_clean(&out);
    }
}

/// The source node's placement travels: the AnimatedMorphCube sample's node (a rotation and
/// a scale of 100) is every exported LOD node's matrix, so the cube stands where it stood;
/// the face's node has no transform and its LOD nodes get none.
#[test]
fn lod_nodes_carry_the_source_node_placement() {
    let dir = temp_dir("placement");
    let cube = asset("AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
    let source = gltf::Gltf::open(&cube).unwrap();
    let placed = source.nodes().next().unwrap().transform().matrix();
    assert_ne!(
        placed,
        gltf::scene::Transform::Matrix { matrix: IDENTITY }.matrix()
    );
    for (input, expected) in [(cube, placed), (asset("makehuman_face.glb"), IDENTITY)] {
        let glb = export_lods(std::slice::from_ref(&input), "0.5", &dir.join("out.glb"));
        let exported = gltf::Gltf::from_slice(&glb).unwrap();
        for node in exported.nodes() {
            let matrix = node.transform().matrix();
            assert_eq!(matrix.map(bits), expected.map(bits), "{input:?}");
        }
    }
}

/// The source's place in its scene travels: the AnimatedMorphCube sample re-parented under a
/// named TRS node ("rig": translation, rotation, scale) under a named matrix node ("root"). The
/// export keeps both ancestors (names and transforms, same form, bit for bit), LOD0 under
/// "rig" with the cube node's own transform, the scene rooted at "root", every lower LOD with
/// LOD0's local transform, so LOD0's world matrix is the source node's, bit for bit; the
/// animation's channels on "rig" and on the cube node drive "rig" and every LOD node, keys and
/// values bit for bit; the Khronos validator reports no error and no warning.
#[test]
fn lods_keep_the_source_node_hierarchy() {
    let dir = temp_dir("hierarchy");
    let input = common::rigged_cube(&dir);
    let out = dir.join("rigged_lods.glb");
    let glb = export_lods(std::slice::from_ref(&input), "0.5,0.25", &out);
    let source = gltf::Gltf::open(&input).unwrap();
    let exported = gltf::Gltf::from_slice(&glb).unwrap();
    let same = |a: gltf::scene::Transform, b: gltf::scene::Transform| {
        let kind = |t: &gltf::scene::Transform| matches!(t, gltf::scene::Transform::Matrix { .. });
        kind(&a) == kind(&b) && a.matrix().map(bits) == b.matrix().map(bits)
    };
    for name in ["rig", "root"] {
        let (a, b) = (named(&source, name), named(&exported, name));
        assert!(same(a.transform(), b.transform()), "{name}");
    }
    let (root, rig, lod0) = (
        named(&exported, "root"),
        named(&exported, "rig"),
        named(&exported, "rigged_LOD0"),
    );
    let scene: Vec<usize> = exported
        .scenes()
        .next()
        .unwrap()
        .nodes()
        .map(|n| n.index())
        .collect();
    assert_eq!(scene, [root.index()]);
    assert_eq!(
        root.children().map(|n| n.index()).collect::<Vec<_>>(),
        [rig.index()]
    );
    assert_eq!(
        rig.children().map(|n| n.index()).collect::<Vec<_>>(),
        [lod0.index()]
    );
    let cube_node = source.nodes().next().unwrap();
    let (rig_index, cube_index) = (rig.index(), cube_node.index());
    assert!(same(cube_node.transform(), lod0.transform()));
    for i in 1..3 {
        let lod = named(&exported, &format!("rigged_LOD{i}"));
        assert!(same(lod0.transform(), lod.transform()), "LOD{i}");
    }
    let world = |chain: [gltf::Node; 3]| {
        chain.iter().fold(glam::Mat4::IDENTITY, |m, n| {
            m * glam::Mat4::from_cols_array_2d(&n.transform().matrix())
        })
    };
    assert_eq!(
        world([named(&source, "root"), named(&source, "rig"), cube_node])
            .to_cols_array_2d()
            .map(bits),
        world([root, rig, lod0]).to_cols_array_2d().map(bits)
    );
    // The animation's channels on the chain travel with their nodes, keys and values bit for
    // bit: "rig"'s translation drives "rig", the cube node's rotation every LOD node.
    let source_blob = std::fs::read(dir.join("AnimatedMorphCube.bin")).unwrap();
    let exported_blob = exported.blob.clone().unwrap();
    let channel = |doc: &gltf::Gltf, blob: &[u8], node: usize, path: gltf::animation::Property| {
        let found = doc
            .animations()
            .flat_map(|a| a.channels())
            .find(|c| c.target().node().index() == node && c.target().property() == path)
            .unwrap_or_else(|| panic!("no {path:?} channel on node {node}"));
        let reader = found.reader(|_| Some(blob));
        let times: Vec<u32> = reader.read_inputs().unwrap().map(f32::to_bits).collect();
        let values: Vec<u32> = match reader.read_outputs().unwrap() {
            ReadOutputs::Translations(t) => t.flat_map(bits).collect(),
            ReadOutputs::Rotations(r) => r.into_f32().flat_map(bits).collect(),
            ReadOutputs::Scales(s) => s.flat_map(bits).collect(),
            ReadOutputs::MorphTargetWeights(_) => panic!("a weights channel"),
        };
        (times, values, found.sampler().interpolation())
    };
    use gltf::animation::{
        util::ReadOutputs,
        Property::{Rotation, Translation},
    };
    assert_eq!(
        channel(&exported, &exported_blob, rig_index, Translation),
        channel(
            &source,
            &source_blob,
            named(&source, "rig").index(),
            Translation
        )
    );
    for i in 0..3 {
        let lod = named(&exported, &format!("rigged_LOD{i}"));
        assert_eq!(
            channel(&exported, &exported_blob, lod.index(), Rotation),
            channel(&source, &source_blob, cube_index, Rotation),
            "LOD{i}"
        );
    }
    validate_clean(&out);
}

/// A skinned character keeps its skin and every vertex attribute: the face bound to two joints
/// with JOINTS_0, WEIGHTS_0, a second TEXCOORD set of 2-byte elements, TANGENT, an
/// application-specific `_ID` and target TANGENT deltas ([`common::skinned_face`]). Nothing is left out;
/// every LOD has each attribute with the source's bytes at its kept vertices and the targets'
/// TANGENT deltas bit for bit; the skin keeps its name, joints (written with their names,
/// transforms and hierarchy), skeleton and inverse bind matrices bit for bit, and binds every
/// LOD; the joint's rotation channel travels; `morphlod export` writes the same bytes as the
/// library; the Khronos validator reports no error and no warning on source and export.
#[test]
fn a_skinned_character_keeps_its_skin_and_every_attribute() {
    let dir = temp_dir("skinned");
    let (input, written) = common::skinned_face(&dir);
    validate_clean(&input);
    let options = LoadOptions::default();
    let morph = load_morph(&input, &options, &MorphSource::Animation("0".into())).unwrap();
    let source = morphlod::io::gltf::source_scene(&input, &options).unwrap();
    assert!(source.left_out.is_empty(), "{:?}", source.left_out);
    let export = export_glb(
        &morph,
        &ExportOptions {
            lods: LodSteps::Fractions(vec![0.5, 0.1]),
            name: "skinned".into(),
            source,
            ..structural()
        },
    )
    .unwrap();
    let out = dir.join("skinned_lods.glb");
    assert_eq!(
        export_lods(std::slice::from_ref(&input), "0.5,0.1", &out),
        export.glb,
        "the CLI carries the source scene as the library does"
    );
    check_against_source(&morph, &export);

    let exported = gltf::Gltf::from_slice(&export.glb).unwrap();
    let blob = exported.blob.clone().unwrap();
    for (mesh, lod) in exported.meshes().zip(&export.lods) {
        let primitive = mesh.primitives().next().unwrap();
        for (semantic, values) in &written.attributes {
            let read = raw_elements(&attribute(&primitive, semantic), &blob);
            let expected: Vec<&Vec<u8>> = lod
                .source_vertex
                .iter()
                .map(|&v| &values[v as usize])
                .collect();
            assert_eq!(read.iter().collect::<Vec<_>>(), expected, "{semantic}");
        }
        let reader = primitive.reader(|_| Some(&blob[..]));
        for (k, (_, _, tangents)) in reader.read_morph_targets().enumerate() {
            let read: Option<Vec<[u32; 3]>> = tangents.map(|t| t.map(bits).collect());
            let expected: Option<Vec<[u32; 3]>> = written.tangent_deltas.get(k).map(|d| {
                lod.source_vertex
                    .iter()
                    .map(|&v| bits(d[v as usize]))
                    .collect()
            });
            assert_eq!(read, expected, "target {k} TANGENT deltas");
        }
    }
    // The skin, its joints and their hierarchy.
    let skin = exported.skins().next().expect("a skin");
    assert_eq!(skin.name(), Some("armature"));
    let joints: Vec<&str> = skin.joints().map(|j| j.name().unwrap()).collect();
    assert_eq!(joints, ["hips", "spine"]);
    assert_eq!(skin.skeleton().and_then(|s| s.name()), Some("hips"));
    let matrices: Vec<[u32; 16]> = skin
        .reader(|_| Some(&blob[..]))
        .read_inverse_bind_matrices()
        .unwrap()
        .map(|m| bits(glam::Mat4::from_cols_array_2d(&m).to_cols_array()))
        .collect();
    let expected: Vec<[u32; 16]> = written
        .inverse_bind_matrices
        .iter()
        .map(|m| bits(*m))
        .collect();
    assert_eq!(matrices, expected);
    for i in 0..3 {
        let node = named(&exported, &format!("skinned_LOD{i}"));
        assert_eq!(node.skin().map(|s| s.index()), Some(0), "LOD{i}");
    }
    let (hips, spine) = (named(&exported, "hips"), named(&exported, "spine"));
    assert_eq!(hips.transform().decomposed().0, [0.0, 0.5, 0.0]);
    assert_eq!(spine.transform().decomposed().0, [0.0, 0.25, 0.0]);
    assert_eq!(
        hips.children().map(|c| c.index()).collect::<Vec<_>>(),
        [spine.index()]
    );
    let roots: Vec<&str> = exported
        .scenes()
        .next()
        .unwrap()
        .nodes()
        .map(|n| n.name().unwrap())
        .collect();
    assert_eq!(roots, ["skinned_LOD0", "hips"]);
    let channel = exported
        .animations()
        .flat_map(|a| a.channels())
        .find(|c| c.target().node().index() == spine.index())
        .expect("a channel on spine");
    let reader = channel.reader(|_| Some(&blob[..]));
    let times: Vec<u32> = reader.read_inputs().unwrap().map(f32::to_bits).collect();
    let values: Vec<[u32; 4]> = match reader.read_outputs().unwrap() {
        gltf::animation::util::ReadOutputs::Rotations(r) => r.into_f32().map(bits).collect(),
        _ => panic!("not a rotation"),
    };
    // The material whole: every member as the source has it, its extensions declared, the
    // image the source's bytes.
    let source_json: Value = serde_json::from_slice(&std::fs::read(&input).unwrap()).unwrap();
    let exported_json = json(&export.glb);
    assert_eq!(exported_json["materials"], source_json["materials"]);
    assert_eq!(exported_json["samplers"], source_json["samplers"]);
    for extension in ["KHR_texture_transform", "KHR_materials_emissive_strength"] {
        let used = exported_json["extensionsUsed"].as_array().unwrap();
        assert!(used.iter().any(|e| e == extension), "{extension}: {used:?}");
    }
    let image = |doc: &gltf::Gltf, blob: &[u8]| match doc.images().next().unwrap().source() {
        gltf::image::Source::View { view, .. } => {
            blob[view.offset()..view.offset() + view.length()].to_vec()
        }
        gltf::image::Source::Uri { .. } => panic!("an external image"),
    };
    let texture = morph.attributes().material.texture.as_ref().unwrap();
    assert_eq!(image(&exported, &blob), texture.bytes);
    let (key_times, rotations) = &written.spine_rotation;
    assert_eq!(
        times,
        key_times.iter().map(|t| t.to_bits()).collect::<Vec<_>>()
    );
    assert_eq!(
        values,
        rotations.iter().map(|q| bits(*q)).collect::<Vec<_>>()
    );
    validate_clean(&out);
}

/// What cannot be carried is left out with a note, and the file stays valid: the skinned face
/// with its node's skin removed exports without JOINTS_0 and WEIGHTS_0 (they would bind to
/// nothing) and says so; its other attributes are still written.
#[test]
fn skinning_without_a_skin_is_left_out_with_a_note() {
    let dir = temp_dir("unskinned");
    let (input, _) = common::skinned_face(&dir);
    let mut gltf: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&input).unwrap()).unwrap();
    gltf["nodes"][0].as_object_mut().unwrap().remove("skin");
    gltf.as_object_mut().unwrap().remove("skins");
    std::fs::write(&input, serde_json::to_vec(&gltf).unwrap()).unwrap();
    let out = dir.join("unskinned.glb");
    let output = morphlod(&[
        input.as_os_str(),
        "--lods".as_ref(),
        "0.25".as_ref(),
        // A note about what is left out, not the LOD's quality (see `export_lods`).
        "--distance-weight".as_ref(),
        "0".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    for semantic in ["JOINTS_0", "WEIGHTS_0"] {
        let note = format!("warning: not exported: {semantic}: its node has no skin");
        assert!(stderr.contains(&note), "{note}: {stderr}");
    }
    let exported = gltf::Gltf::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(exported.skins().count(), 0);
    for mesh in exported.meshes() {
        let names: Vec<String> = mesh
            .primitives()
            .next()
            .unwrap()
            .attributes()
            .map(|(s, _)| s.to_string())
            .collect();
        assert!(!names
            .iter()
            .any(|n| n.starts_with("JOINTS") || n.starts_with("WEIGHTS")));
        for kept in ["TANGENT", "TEXCOORD_1", "_ID"] {
            assert!(names.iter().any(|n| n == kept), "{kept}: {names:?}");
        }
    }
    validate_clean(&out);
}

/// A skin whose inverse bind matrices hold a NaN is refused with a data error naming them,
/// before anything is built.
#[test]
fn a_non_finite_inverse_bind_matrix_is_refused() {
    let dir = temp_dir("skinned_nan");
    let (input, _) = common::skinned_face(&dir);
    let gltf: serde_json::Value = serde_json::from_slice(&std::fs::read(&input).unwrap()).unwrap();
    let accessor =
        &gltf["accessors"][gltf["skins"][0]["inverseBindMatrices"].as_u64().unwrap() as usize];
    let view = &gltf["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap() as usize + 5 * 4;
    let bin = dir.join("skinned.bin");
    let mut bytes = std::fs::read(&bin).unwrap();
    bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(&bin, bytes).unwrap();
    let err = morphlod::io::gltf::source_scene(&input, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("inverseBindMatrices") && err.contains("NaN"),
        "{err}"
    );
}

/// The accessor of `primitive`'s attribute `semantic`.
fn attribute<'a>(primitive: &gltf::Primitive<'a>, semantic: &str) -> gltf::Accessor<'a> {
    primitive
        .attributes()
        .find(|(s, _)| s.to_string() == semantic)
        .map(|(_, a)| a)
        .unwrap_or_else(|| panic!("{semantic} missing"))
}

/// An accessor's elements as stored (view offset, accessor offset and stride applied).
fn raw_elements(accessor: &gltf::Accessor, blob: &[u8]) -> Vec<Vec<u8>> {
    let view = accessor.view().expect("a buffer view");
    let size = accessor.size();
    let stride = view.stride().unwrap_or(size);
    let start = view.offset() + accessor.offset();
    (0..accessor.count())
        .map(|i| blob[start + i * stride..start + i * stride + size].to_vec())
        .collect()
}

/// A node track whose output does not fit its keys (the rigged cube's rotation sampler with 2
/// of its 3 values) is refused with a message naming the sampler, and nothing is written.
#[test]
fn a_broken_node_track_is_refused() {
    let dir = temp_dir("broken_track");
    let input = common::rigged_cube(&dir);
    let mut gltf: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&input).unwrap()).unwrap();
    let last = gltf["accessors"].as_array().unwrap().len() - 1;
    gltf["accessors"][last]["count"] = serde_json::json!(2);
    std::fs::write(&input, serde_json::to_vec(&gltf).unwrap()).unwrap();
    let out = dir.join("broken.glb");
    let output = morphlod(&[input.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{stderr}");
    assert!(
        stderr.contains("has 8 output values for 3 keys, expected 12"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing is written");
}

/// The node of `doc` named `name`.
fn named<'a>(doc: &'a gltf::Gltf, name: &str) -> gltf::Node<'a> {
    doc.nodes()
        .find(|n| n.name() == Some(name))
        .unwrap_or_else(|| panic!("no node {name}"))
}

const IDENTITY: [[f32; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// Two OFF meshes with the same connectivity in `dir`: a bumpy 12 × 12 grid (`a.off`) and the
/// same grid tilted (`b.off`: every vertex but the first column moves).
fn off_pair(dir: &Path) -> (PathBuf, PathBuf) {
    let n = 12;
    let write = |file: &str, lift: f32| {
        let mut text = format!("OFF\n{} {} 0\n", n * n, 2 * (n - 1) * (n - 1));
        for y in 0..n {
            for x in 0..n {
                let z = ((x * 7 + y * 3) % 5) as f32 * 0.1 + lift * x as f32 * 0.2;
                text += &format!("{x} {y} {z}\n");
            }
        }
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let v = y * n + x;
                text += &format!(
                    "3 {} {} {}\n3 {} {} {}\n",
                    v,
                    v + 1,
                    v + n,
                    v + 1,
                    v + n + 1,
                    v + n
                );
            }
        }
        let path = dir.join(file);
        std::fs::write(&path, text).unwrap();
        path
    };
    (write("a.off", 0.0), write("b.off", 1.0))
}

/// Two OFF meshes with the same connectivity: one target, LODs with falling triangle counts,
/// every written vertex one of A's (position bit for bit) with B's position minus A's as its
/// delta (so A and B swapped, or a delta of another vertex, fail), and the two-pose animation
/// `[w0, w1, w0] = [0, 1, 0]` at 0, 1, 2 s, LINEAR.
#[test]
fn an_off_pair_exports_with_its_one_target() {
    let dir = temp_dir("off_pair");
    let (a, b) = off_pair(&dir);
    let out = dir.join("pair.glb");
    let output = morphlod(&[a.as_os_str(), b.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let glb = std::fs::read(&out).unwrap();
    check_structure(&glb, "a", 4, true);
    let gltf = gltf::Gltf::from_slice(&glb).unwrap();
    let blob = gltf.blob.clone().unwrap();
    let (va, vb) = (
        load_mesh(&a, &LoadOptions::default()).unwrap(),
        load_mesh(&b, &LoadOptions::default()).unwrap(),
    );
    let of_position: HashMap<[u32; 3], usize> = va
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| (bits(*p), i))
        .collect();
    assert_eq!(
        of_position.len(),
        va.positions.len(),
        "A's positions differ"
    );
    let mut counts = Vec::new();
    for mesh in gltf.meshes() {
        let p = mesh.primitives().next().unwrap();
        assert_eq!(p.morph_targets().count(), 1);
        counts.push(p.indices().unwrap().count() / 3);
        let reader = p.reader(|_| Some(&blob[..]));
        let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        let (deltas, _, _) = reader.read_morph_targets().next().unwrap();
        let deltas: Vec<[f32; 3]> = deltas.expect("POSITION deltas").collect();
        assert_eq!(deltas.len(), positions.len());
        let moved = deltas.iter().filter(|d| **d != [0.0; 3]).count();
        assert!(moved > 0, "no vertex moves");
        for (p, d) in positions.iter().zip(&deltas) {
            let i = *of_position
                .get(&bits(*p))
                .unwrap_or_else(|| panic!("{p:?} is not a vertex of A"));
            let expected: [f32; 3] =
                std::array::from_fn(|k| vb.positions[i][k] - va.positions[i][k]);
            assert_eq!(bits(*d), bits(expected), "vertex {i}");
        }
    }
    assert!(counts.windows(2).all(|w| w[0] > w[1]), "{counts:?}");
    let (one, zero) = (1f32.to_bits(), 0f32.to_bits());
    assert_eq!(
        weight_track(&gltf, &blob),
        (
            Interpolation::Linear,
            vec![zero, one, 2f32.to_bits()],
            vec![zero, one, zero]
        )
    );
    validate_clean(&out);
}

/// `--poses` reaches the shared sequence: the CLI with `--poses 1` writes what the library
/// writes for one pose, without it what the library writes for `DEFAULT_POSES`, and on this
/// pair the two differ (the rest pose alone simplifies otherwise than the whole tilt).
#[test]
fn poses_reach_the_shared_sequence() {
    let dir = temp_dir("poses");
    let (a, b) = off_pair(&dir);
    let options = LoadOptions::default();
    let morph = morph_from_pair(
        &load_attributed(&a, &options).unwrap(),
        &load_attributed(&b, &options).unwrap(),
    )
    .unwrap();
    let library = |poses: usize| {
        let options = ExportOptions {
            poses,
            name: "a".into(),
            ..ExportOptions::default()
        };
        export_glb(&morph, &options).unwrap().glb
    };
    let cli = |poses: &[&str]| {
        let out = dir.join("poses.glb");
        let mut args = vec![a.as_os_str(), b.as_os_str(), "-o".as_ref(), out.as_os_str()];
        args.extend(poses.iter().map(std::ffi::OsStr::new));
        let output = morphlod(&args);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        std::fs::read(&out).unwrap()
    };
    let one = library(1);
    assert!(
        one != library(DEFAULT_POSES),
        "the fixture must tell poses apart"
    );
    assert!(cli(&["--poses", "1"]) == one, "--poses 1");
    assert!(cli(&[]) == library(DEFAULT_POSES), "the default");
}

/// The weight animation written is the source's, bit for bit (interpolation, keys, values):
/// the AnimatedMorphCube sample (LINEAR, 127 keys of 2 weights), and the same file with its
/// sampler made STEP (an exporter that writes LINEAR whatever the source says fails).
#[test]
fn the_weight_animation_is_the_sources_bit_for_bit() {
    let dir = temp_dir("weights");
    let sample = asset("AnimatedMorphCube-glTF");
    for file in ["AnimatedMorphCube.gltf", "AnimatedMorphCube.bin"] {
        std::fs::copy(sample.join(file), dir.join(file)).unwrap();
    }
    let linear = dir.join("AnimatedMorphCube.gltf");
    let mut json: Value = serde_json::from_slice(&std::fs::read(&linear).unwrap()).unwrap();
    json["animations"][0]["samplers"][0]["interpolation"] = Value::from("STEP");
    let step = dir.join("step.gltf");
    std::fs::write(&step, serde_json::to_vec(&json).unwrap()).unwrap();
    for (input, interpolation) in [(linear, Interpolation::Linear), (step, Interpolation::Step)] {
        let glb = export_lods(std::slice::from_ref(&input), "0.5", &dir.join("out.glb"));
        let exported = gltf::Gltf::from_slice(&glb).unwrap();
        let (written, _, _) = weight_track(&exported, exported.blob.as_deref().unwrap());
        assert_eq!(written, interpolation, "{input:?}");
        check_weights_against_source(&glb, &input);
    }
}

/// Every LOD is the reference mesh (docs/DESIGN.md: `CollapseSequence::reference_mesh`) of the
/// one shared sequence at its step, rebuilt here with the builder the way the module docs say
/// the export makes it, on a seamed sphere (seams: steps must be boundaries), for `--lods`
/// fractions and for `--error` bounds: the LOD's triangles mapped back to source vertices are
/// that mesh, and the step is a boundary. A fraction's LOD is the finest boundary within the
/// goal: at most `floor(f · triangles)` triangles, the boundary before it more.
#[test]
fn lods_are_the_shared_sequences_reference_meshes() {
    let morph = common::seamed_sphere(10, 16);
    let triangles = morph.triangles();
    let poses = 4;
    let fractions = vec![0.5, 0.25, 0.1];
    for lods in [
        LodSteps::Fractions(fractions.clone()),
        LodSteps::Errors(vec![0.02, 0.05, 0.15]),
    ] {
        let options = ExportOptions {
            lods: lods.clone(),
            poses,
            ..ExportOptions::default()
        };
        let export = export_glb(&morph, &options).unwrap();
        let (asset, _) = Builder::new(&morph)
            .frames(poses)
            .sequences(Sequences::Shared(PoseError::Max))
            .simplify_options(options.simplify.clone())
            .build()
            .unwrap();
        let sequence = &asset.frames[0];
        let boundaries = StepBoundaries::new(sequence, &morph.topology().of_vertex);
        let reference = |step: usize| sequence.reference_mesh(triangles, step);
        assert_eq!(export.lods.len(), 4);
        assert_eq!(export.lods[0].step, 0);
        let mut steps = Vec::new();
        for (i, lod) in export.lods.iter().enumerate() {
            let back = lod
                .triangles
                .iter()
                .map(|t| t.map(|v| lod.source_vertex[v as usize]));
            let (written, expected) = (
                canonical_multiset(back),
                canonical_multiset(reference(lod.step)),
            );
            assert!(
                written == expected,
                "{lods:?}: LOD{i} ({} triangles) is not the reference mesh at step {} ({})",
                written.len(),
                lod.step,
                expected.len()
            );
            assert!(boundaries.is_boundary(lod.step), "{lods:?}: LOD{i}");
            steps.push(lod.step);
            if i == 0 {
                continue;
            }
            if let LodSteps::Fractions(_) = lods {
                let goal = (f64::from(fractions[i - 1]) * triangles.len() as f64).floor() as usize;
                assert!(lod.triangles.len() <= goal, "LOD{i}: {lod:?}");
                let previous = boundaries.floor(lod.step - 1);
                assert!(
                    reference(previous).len() > goal,
                    "LOD{i} (step {}) is not the finest within {goal} triangles: step {previous} is",
                    lod.step
                );
            }
        }
        assert!(steps.windows(2).all(|w| w[0] < w[1]), "{lods:?}: {steps:?}");
        check_against_source(&morph, &export);
    }
}

/// Bad input: a message on stderr and exit code 1, no panic.
#[test]
fn bad_input_is_refused_with_exit_code_1() {
    let dir = temp_dir("bad");
    let face = asset("makehuman_face.glb");
    let out = dir.join("out.glb");
    let not_gltf = dir.join("not.glb");
    std::fs::write(&not_gltf, "this is not glTF").unwrap();
    let off = asset("cow.off");
    let missing = dir.join("missing.glb");
    let cases: Vec<(Vec<&std::ffi::OsStr>, &str)> = vec![
        (vec![missing.as_os_str()], "missing"),
        (vec![not_gltf.as_os_str()], "not.glb"),
        (vec![off.as_os_str()], "two meshes"),
        (
            vec![face.as_os_str(), "--lods".as_ref(), "1.5".as_ref()],
            "--lods",
        ),
        (
            vec![face.as_os_str(), "--lods".as_ref(), "0".as_ref()],
            "--lods",
        ),
        (
            vec![face.as_os_str(), "--lods".as_ref(), "0.25,0.5".as_ref()],
            "decreasing",
        ),
        (
            vec![face.as_os_str(), "--poses".as_ref(), "0".as_ref()],
            "--poses 0",
        ),
        (
            vec![face.as_os_str(), "--error".as_ref(), "-0.01".as_ref()],
            "--error [-0.01]",
        ),
        (
            vec![face.as_os_str(), "--error".as_ref(), "NaN".as_ref()],
            "--error [NaN]",
        ),
        (
            vec![face.as_os_str(), "--error".as_ref(), "0.01,0.002".as_ref()],
            "strictly increasing",
        ),
    ];
    for (args, expected) in cases {
        let mut args = args;
        args.extend(["-o".as_ref(), out.as_os_str()]);
        let output = morphlod(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains("error:"), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    // --lods and --error exclude each other (clap's usage error, exit code 2).
    let output = morphlod(&[
        face.as_os_str(),
        "--lods".as_ref(),
        "0.5".as_ref(),
        "--error".as_ref(),
        "0.01".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("cannot be used with"), "{stderr}");
    let wrong_extension = dir.join("out.mlod");
    let output = morphlod(&[face.as_os_str(), "-o".as_ref(), wrong_extension.as_os_str()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&output.stderr).contains(".glb"));
}
