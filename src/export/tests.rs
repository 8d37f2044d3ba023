use super::mesh::written_names;
use super::*;
use crate::io::gltf::write::FLOAT;
use crate::io::gltf::{NodeTransform, RawAttribute};
use crate::morph::{MorphTarget, Weights};

/// Two triangles per cell of an `n × n` vertex grid, row by row.
fn grid_triangles(n: u32) -> Vec<[u32; 3]> {
    let mut triangles = Vec::new();
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let v = y * n + x;
            triangles.push([v, v + 1, v + n]);
            triangles.push([v + 1, v + n + 1, v + n]);
        }
    }
    triangles
}

/// A 5 × 5 grid with a target that moves two vertices (one by `-0.0` only) and one that
/// moves nothing: both are written sparse and read back bit for bit at every LOD.
#[test]
fn sparse_deltas_read_back_bit_for_bit() {
    let n = 5u32;
    let base: Vec<[f32; 3]> = (0..n * n)
        .map(|v| [(v % n) as f32, (v / n) as f32, ((v * 7) % 3) as f32 * 0.1])
        .collect();
    let triangles = grid_triangles(n);
    let mut moving = vec![[0.0f32; 3]; base.len()];
    moving[3] = [-0.0, 0.0, 0.0];
    moving[12] = [0.0, 0.0, 1.5];
    let targets = vec![
        MorphTarget {
            name: "moving".into(),
            deltas: moving,
            normal_deltas: None,
        },
        MorphTarget {
            name: "still".into(),
            deltas: vec![[0.0; 3]; base.len()],
            normal_deltas: None,
        },
    ];
    let weights = Weights::TwoPose {
        w0: vec![0.0, 0.0],
        w1: vec![1.0, 0.0],
    };
    let morph = Morph::from_parts(triangles, base, targets, weights).unwrap();
    let export = export_glb(
        &morph,
        &ExportOptions {
            lods: LodSteps::Fractions(vec![0.5]),
            ..ExportOptions::default()
        },
    )
    .unwrap();
    let gltf = gltf::Gltf::from_slice(&export.glb).unwrap();
    let blob = gltf.blob.clone().unwrap();
    for (mesh, lod) in gltf.meshes().zip(&export.lods) {
        let primitive = mesh.primitives().next().unwrap();
        for accessor in primitive.morph_targets().filter_map(|t| t.positions()) {
            assert!(accessor.sparse().is_some() && accessor.view().is_none());
        }
        let reader = primitive.reader(|_| Some(&blob[..]));
        for (read, source) in reader.read_morph_targets().zip(morph.targets()) {
            let read: Vec<[u32; 3]> = read.0.unwrap().map(|d| d.map(f32::to_bits)).collect();
            let expected: Vec<[u32; 3]> = lod
                .source_vertex
                .iter()
                .map(|&v| source.deltas[v as usize].map(f32::to_bits))
                .collect();
            assert_eq!(read, expected, "{}", source.name);
        }
    }
}

/// A bumpy `n × n` grid whose one target raises a ridge: collapse errors spread over
/// several orders of magnitude.
fn bumpy_grid(n: u32) -> Morph {
    let height = |x: u32, y: u32| ((x as f32 * 0.9).sin() * (y as f32 * 0.6).cos()) * 0.3;
    let base: Vec<[f32; 3]> = (0..n * n)
        .map(|v| [(v % n) as f32, (v / n) as f32, height(v % n, v / n)])
        .collect();
    let triangles = grid_triangles(n);
    let ridge = (0..n * n)
        .map(|v| [0.0, 0.0, if v % n == n / 2 { 1.0 } else { 0.0 }])
        .collect();
    let targets = vec![MorphTarget {
        name: "ridge".into(),
        deltas: ridge,
        normal_deltas: None,
    }];
    let weights = Weights::TwoPose {
        w0: vec![0.0],
        w1: vec![1.0],
    };
    Morph::from_parts(triangles, base, targets, weights).unwrap()
}

/// Each error step is the coarsest step boundary of the shared sequence within its bound:
/// its error (relative to the diagonal) is at most the bound, the next boundary's is
/// above it, and the LODs get coarser as the bounds grow.
#[test]
fn error_steps_are_the_coarsest_boundaries_within_each_bound() {
    let morph = bumpy_grid(16);
    let bounds = vec![0.002, 0.01, 0.03, 0.1];
    let options = ExportOptions {
        lods: LodSteps::Errors(bounds.clone()),
        ..ExportOptions::default()
    };
    let export = export_glb(&morph, &options).unwrap();
    let (asset, _) = Builder::new(&morph)
        .frames(DEFAULT_POSES)
        .sequences(Sequences::Shared(PoseError::Max))
        .simplify_options(options.simplify.clone())
        .build()
        .unwrap();
    let sequence = &asset.frames[0];
    let errors = sequence.errors();
    let boundaries = StepBoundaries::new(sequence, &morph.topology().of_vertex);
    // sqrt(2 · 15²) plus the bumps' height: the grid's diagonal.
    let diagonal = diagonal(morph.base());
    assert!((diagonal - 15.0 * 2f32.sqrt()).abs() < 0.1, "{diagonal}");
    assert_eq!(export.lods.len(), bounds.len() + 1);
    let mut steps = vec![0];
    for (lod, &bound) in export.lods[1..].iter().zip(&bounds) {
        assert!(boundaries.is_boundary(lod.step), "{lod:?}");
        let error = errors[lod.step].sqrt() / diagonal;
        assert_eq!(lod.error, error);
        assert!(error <= bound, "{bound}: {lod:?}");
        if lod.step < sequence.len() {
            let next = boundaries.ceil(lod.step + 1);
            assert!(
                errors[next].sqrt() / diagonal > bound,
                "{bound}: step {next}"
            );
        }
        steps.push(lod.step);
    }
    assert!(steps.windows(2).all(|w| w[0] <= w[1]), "{steps:?}");
    // The bounds span the sequence: the LODs are not all the same.
    assert!(steps[1] > 0 && steps[bounds.len()] > steps[1], "{steps:?}");
    let counts: Vec<usize> = export.lods.iter().map(|l| l.triangles.len()).collect();
    assert!(counts.windows(2).all(|w| w[0] >= w[1]), "{counts:?}");
}

#[test]
fn error_bounds_must_be_positive_finite_and_increase() {
    for bad in [
        vec![],
        vec![0.0],
        vec![-0.01],
        vec![f32::NAN],
        vec![f32::INFINITY],
        vec![0.01, 0.01],
        vec![0.02, 0.01],
    ] {
        let options = ExportOptions {
            lods: LodSteps::Errors(bad.clone()),
            ..ExportOptions::default()
        };
        let err = export_glb(&bumpy_grid(4), &options).unwrap_err();
        assert!(matches!(err, ExportError::Errors { .. }), "{bad:?}");
        assert!(err.to_string().contains("--error"), "{err}");
    }
    assert!(check_errors(&[0.001, 0.5, 2.0]).is_ok());
}

/// A raw attribute of `semantic`: one FLOAT SCALAR per vertex.
fn raw(semantic: &str, vertices: usize) -> RawAttribute {
    RawAttribute {
        semantic: semantic.into(),
        kind: "SCALAR",
        component_type: FLOAT,
        normalized: false,
        data: vec![0; 4 * vertices],
    }
}

/// Carried TEXCOORD and COLOR sets are numbered on after the morph's own, in order and
/// without gaps; JOINTS and WEIGHTS from 0; other names are kept.
#[test]
fn carried_sets_are_numbered_after_the_morphs_own() {
    let plain = bumpy_grid(3);
    let vertices = plain.vertex_count();
    let with_uvs = plain
        .clone()
        .with_attributes(crate::morph::Attributes {
            uvs: Some(vec![[0.0; 2]; vertices]),
            ..Default::default()
        })
        .unwrap();
    let carried: Vec<RawAttribute> = [
        "TEXCOORD_3",
        "TANGENT",
        "TEXCOORD_1",
        "COLOR_2",
        "JOINTS_1",
        "WEIGHTS_1",
        "_ID",
    ]
    .iter()
    .map(|s| raw(s, vertices))
    .collect();
    assert_eq!(
        written_names(&with_uvs, &carried),
        [
            "TEXCOORD_2",
            "TANGENT",
            "TEXCOORD_1",
            "COLOR_0",
            "JOINTS_0",
            "WEIGHTS_0",
            "_ID"
        ]
    );
    assert_eq!(
        written_names(&plain, &carried),
        [
            "TEXCOORD_1",
            "TANGENT",
            "TEXCOORD_0",
            "COLOR_0",
            "JOINTS_0",
            "WEIGHTS_0",
            "_ID"
        ]
    );
}

/// A source scene that does not describe the morph is refused before anything is built.
#[test]
fn a_source_scene_that_does_not_fit_is_refused() {
    use crate::io::gltf::{SourceNode, SourceSkin};
    let morph = bumpy_grid(4);
    let vertices = morph.vertex_count();
    let node = |parent| SourceNode {
        name: None,
        transform: NodeTransform::IDENTITY,
        parent,
    };
    let skin = SourceSkin {
        name: None,
        joints: vec![1],
        skeleton: None,
        inverse_bind_matrices: None,
    };
    let skinned = SourceScene {
        nodes: vec![node(None), node(None)],
        mesh_node: Some(0),
        skin: Some(skin.clone()),
        attributes: vec![raw("JOINTS_0", vertices), raw("WEIGHTS_0", vertices)],
        ..SourceScene::default()
    };
    let export = |source: SourceScene| {
        export_glb(
            &morph,
            &ExportOptions {
                source,
                ..ExportOptions::default()
            },
        )
    };
    assert!(export(skinned.clone()).is_ok());
    let bad = [
        SourceScene {
            attributes: vec![raw("_ID", vertices - 1)],
            ..SourceScene::default()
        },
        SourceScene {
            target_attributes: vec![vec![], vec![]],
            ..SourceScene::default()
        },
        SourceScene {
            attributes: vec![raw("_ID", vertices)],
            target_attributes: vec![vec![raw("TANGENT", vertices)]],
            ..SourceScene::default()
        },
        SourceScene {
            nodes: vec![node(Some(1)), node(None)],
            ..skinned.clone()
        },
        SourceScene {
            mesh_node: Some(2),
            ..skinned.clone()
        },
        SourceScene {
            skin: Some(SourceSkin {
                joints: vec![2],
                ..skin.clone()
            }),
            ..skinned.clone()
        },
        SourceScene {
            attributes: vec![raw("JOINTS_0", vertices)],
            ..skinned.clone()
        },
        SourceScene {
            skin: None,
            ..skinned.clone()
        },
    ];
    for source in bad {
        let err = export(source.clone()).unwrap_err();
        assert!(matches!(err, ExportError::Source(_)), "{source:?}: {err}");
    }
}

#[test]
fn fractions_must_lie_in_0_1_and_decrease() {
    for bad in [
        vec![],
        vec![0.0],
        vec![1.5],
        vec![0.5, 0.5],
        vec![0.2, 0.4],
        vec![f32::NAN],
    ] {
        assert!(check_fractions(&bad).is_err(), "{bad:?}");
    }
    assert!(check_fractions(&[1.0, 0.5, 0.01]).is_ok());
}

#[test]
fn quantization_bits_out_of_range_are_refused() {
    let good = QuantizeOptions::default();
    for bad in [
        QuantizeOptions {
            position_bits: 16,
            ..good
        },
        QuantizeOptions {
            position_bits: 0,
            ..good
        },
        QuantizeOptions {
            normal_bits: 3,
            ..good
        },
        QuantizeOptions {
            uv_bits: 17,
            ..good
        },
    ] {
        let options = ExportOptions {
            quantize: Some(bad),
            ..ExportOptions::default()
        };
        let err = export_glb(&bumpy_grid(4), &options).unwrap_err();
        assert!(matches!(err, ExportError::Bits { .. }), "{bad:?}: {err}");
        assert!(err.to_string().contains("-bits"), "{err}");
    }
}

/// Every stored position and target pose is the nearest grid point, within half a step per
/// component; the grid spans the base and the target poses.
#[test]
fn grid_points_are_the_nearest_within_half_a_step() {
    let morph = bumpy_grid(6);
    let grid = Grid::new(&morph, 10);
    assert_eq!(grid.max, 1023);
    let ridge = &morph.targets()[0].deltas;
    for (v, &p) in morph.base().iter().enumerate() {
        let read = grid.dequantize(grid.quantize(p).map(i32::from));
        let pose: [f32; 3] = std::array::from_fn(|k| p[k] + ridge[v][k]);
        let q: [i32; 3] =
            std::array::from_fn(|k| grid.quantize(p)[k] as i32 + grid.delta(p, ridge[v])[k] as i32);
        let moved = grid.dequantize(q);
        for k in 0..3 {
            assert!((read[k] - p[k]).abs() <= 0.5001 * grid.step, "{v} {k}");
            assert!((moved[k] - pose[k]).abs() <= 0.5001 * grid.step, "{v} {k}");
        }
    }
}

/// `export_glb` is `levels` written by `export_glb_levels`: the same file byte for byte; and
/// `export_glb_levels` refuses a level that is not over the mesh's vertices.
#[test]
fn levels_written_are_export_glb() {
    let n = 6u32;
    let base: Vec<[f32; 3]> = (0..n * n)
        .map(|v| [(v % n) as f32, (v / n) as f32, ((v * 5) % 4) as f32 * 0.2])
        .collect();
    let lift: Vec<[f32; 3]> = (0..n * n).map(|v| [0.0, 0.0, (v % 3) as f32]).collect();
    let targets = vec![MorphTarget {
        name: "lift".into(),
        deltas: lift,
        normal_deltas: None,
    }];
    let weights = Weights::TwoPose {
        w0: vec![0.0],
        w1: vec![1.0],
    };
    let morph = Morph::from_parts(grid_triangles(n), base, targets, weights).unwrap();
    let options = ExportOptions {
        lods: LodSteps::Fractions(vec![0.5, 0.2]),
        poses: 4,
        ..ExportOptions::default()
    };
    let whole = export_glb(&morph, &options).unwrap();
    let chosen = levels(&morph, &options).unwrap();
    assert_eq!(chosen.len(), 3);
    let written = export_glb_levels(&morph, chosen.clone(), &options).unwrap();
    assert_eq!(written.glb, whole.glb);
    assert_eq!(written.lods, whole.lods);

    let mut outside = chosen.clone();
    outside[2].source_vertex[0] = n * n;
    assert_eq!(
        export_glb_levels(&morph, outside, &options),
        Err(ExportError::Level {
            level: 2,
            vertices: (n * n) as usize
        })
    );
    let mut dangling = chosen;
    dangling[1].triangles[0][1] = dangling[1].source_vertex.len() as u32;
    assert!(matches!(
        export_glb_levels(&morph, dangling, &options),
        Err(ExportError::Level { level: 1, .. })
    ));
    assert!(matches!(
        export_glb_levels(&morph, Vec::new(), &options),
        Err(ExportError::Level { level: 0, .. })
    ));
}
