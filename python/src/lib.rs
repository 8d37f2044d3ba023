//! `morphlod._morphlod`: the Rust side of the Python package (python/morphlod/__init__.py is
//! the public API, with the docstrings; it converts and checks arrays before calling here).
//!
//! Every entry point runs the library code the command line runs, with its defaults:
//! `simplify` builds a [`Morph`] from the arrays and calls [`morphlod::export::levels`] (what
//! `morphlod export` writes, without the file); `export` and `build` load files as the
//! command line does and call [`export_glb`] and [`Builder`]; `supermesh` is
//! [`Supermesh::build`]; `info` is [`morphlod::asset::inspect_with`]. The GIL is released
//! while Rust works ([`Python::detach`]); a progress callback is called back with the GIL
//! taken again, from whichever thread reports, and an exception it raises is raised by the
//! call once the work is done. Errors are `morphlod.MorphlodError` (a `ValueError`) carrying
//! the Rust error's text.

use morphlod::asset::{inspect_with, save_bytes, AssetInfo, AssetLoadOptions};
use morphlod::build::{Builder, Progress, Sequences};
use morphlod::export::{
    export_glb, export_glb_levels, levels, ExportOptions, Lod, LodSteps, QuantizeOptions,
    DEFAULT_POSES,
};
use morphlod::io::gltf::SourceScene;
use morphlod::io::{load_attributed, morph_from_pair, Format, LoadError, LoadOptions, MorphSource};
use morphlod::mesh::clean::CleanOptions;
use morphlod::mesh::IndexedMesh;
use morphlod::morph::supermesh::{parse_landmarks, Landmarks, Origin, Supermesh, SupermeshOptions};
use morphlod::morph::{
    Attributes, Interpolation, Morph, MorphError, MorphTarget, WeightTrack, Weights,
};
use morphlod::simplify::{PoseError, SimplifyOptions, DISTANCE_WEIGHT, NORMAL_WEIGHT, UV_WEIGHT};
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

create_exception!(
    _morphlod,
    MorphlodError,
    PyValueError,
    "An error of morphlod's Rust core: bad input (its text says what and where), a file that \
     does not load, or a mesh the operation cannot take."
);

/// `Err(MorphlodError(text))`.
fn fail<T>(text: impl std::fmt::Display) -> PyResult<T> {
    Err(MorphlodError::new_err(text.to_string()))
}

// ---------------------------------------------------------------------------------------------
// Arrays in and out

/// A C-contiguous `(n, N)` array as `n` rows of `N` (the wrapper makes arrays contiguous;
/// the shape is checked again here for direct callers of `_morphlod`).
fn rows<const N: usize, T: numpy::Element + Copy + Default>(
    name: &str,
    array: &PyReadonlyArray2<'_, T>,
) -> PyResult<Vec<[T; N]>> {
    let shape = array.shape();
    if shape[1] != N {
        return fail(format!("{name}: shape {shape:?}, expected (n, {N})"));
    }
    let flat = array
        .as_slice()
        .or_else(|_| fail(format!("{name}: the array must be C-contiguous")))?;
    Ok(flat
        .chunks_exact(N)
        .map(|c| {
            let mut row = [T::default(); N];
            row.copy_from_slice(c);
            row
        })
        .collect())
}

fn array1<'py, T: numpy::Element>(py: Python<'py>, values: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, values)
}

fn array2<'py, T: numpy::Element + Copy, const N: usize>(
    py: Python<'py>,
    values: &[[T; N]],
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let flat: Vec<T> = values.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat).reshape([values.len(), N])
}

/// Marks a returned array read-only: it is a value of the result, shared by every access.
fn frozen<'py, A>(array: Bound<'py, A>) -> PyResult<Py<A>> {
    let kwargs = PyDict::new(array.py());
    kwargs.set_item("write", false)?;
    array.as_any().call_method("setflags", (), Some(&kwargs))?;
    Ok(array.unbind())
}

// ---------------------------------------------------------------------------------------------
// Progress

/// A Python progress callback `progress(stage, fraction)`, callable from any thread while
/// the GIL is released; the first exception it raises is kept for the caller to raise.
struct Reporter<'a> {
    callback: Option<&'a Py<PyAny>>,
    error: Mutex<Option<PyErr>>,
}

impl<'a> Reporter<'a> {
    fn new(callback: Option<&'a Py<PyAny>>) -> Self {
        Reporter {
            callback,
            error: Mutex::new(None),
        }
    }

    fn report(&self, stage: &str, fraction: f32) {
        let Some(callback) = self.callback else {
            return;
        };
        let mut error = self.error.lock().unwrap_or_else(|e| e.into_inner());
        if error.is_some() {
            return;
        }
        if let Err(e) = Python::attach(|py| callback.call1(py, (stage, fraction)).map(drop)) {
            *error = Some(e);
        }
    }

    /// `result`, or the callback's exception if it raised one.
    fn finish<T>(self, result: PyResult<T>) -> PyResult<T> {
        match self.error.into_inner().unwrap_or_else(|e| e.into_inner()) {
            Some(e) => Err(e),
            None => result,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Levels

/// One level of detail: which source vertices it keeps and its triangles over them.
#[pyclass(frozen, module = "morphlod")]
struct Level {
    /// The fraction asked for (fractions), or the fraction of the triangles kept (error
    /// bounds); 1 for the original.
    #[pyo3(get)]
    fraction: f32,
    /// The simplification error at this level relative to the base pose's bounding-box
    /// diagonal (`morphlod export`'s `error/diagonal` column).
    #[pyo3(get)]
    error: f32,
    /// Collapses of the shared sequence applied.
    #[pyo3(get)]
    step: usize,
    /// Bytes of the level's mesh data in the written file (`export` only; 0 otherwise).
    #[pyo3(get)]
    bytes: usize,
    /// With quantization: the largest position error as written, relative to the diagonal.
    #[pyo3(get)]
    quantization_error: f32,
    vertices: Py<PyArray1<u32>>,
    triangles: Py<PyArray2<u32>>,
}

#[pymethods]
impl Level {
    /// `vertices[i]`: the source vertex that is the level's vertex `i` (uint32, read-only).
    #[getter]
    fn vertices(&self, py: Python<'_>) -> Py<PyArray1<u32>> {
        self.vertices.clone_ref(py)
    }

    /// `(m, 3)` uint32 triangles over the level's vertices (`vertices[triangles]` gives them
    /// over the source's), in vertex-cache order (read-only).
    #[getter]
    fn triangles(&self, py: Python<'_>) -> Py<PyArray2<u32>> {
        self.triangles.clone_ref(py)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Level(fraction={}, triangles={}, vertices={}, error={:.3e}, step={})",
            self.fraction,
            self.triangles.bind(py).shape()[0],
            self.vertices.bind(py).shape()[0],
            self.error,
            self.step
        )
    }
}

fn level(py: Python<'_>, lod: &Lod) -> PyResult<Level> {
    Ok(Level {
        fraction: lod.fraction,
        error: lod.error,
        step: lod.step,
        bytes: lod.bytes,
        quantization_error: lod.quantization_error,
        vertices: frozen(array1(py, lod.source_vertex.clone()))?,
        triangles: frozen(array2(py, &lod.triangles)?)?,
    })
}

/// `fractions` or `errors` (not both; neither: the exporter's default fractions).
fn lod_steps(fractions: Option<Vec<f32>>, errors: Option<Vec<f32>>) -> PyResult<LodSteps> {
    match (fractions, errors) {
        (Some(_), Some(_)) => fail("give fractions or errors, not both"),
        (None, Some(e)) => Ok(LodSteps::Errors(e)),
        (Some(f), None) => Ok(LodSteps::Fractions(f)),
        (None, None) => Ok(ExportOptions::default().lods),
    }
}

/// The simplifier's options as `morphlod export` makes them from `--uv-weight`,
/// `--normal-weight` and `--distance-weight` (each finite and >= 0).
fn simplify_options(uv: f32, normal: f32, distance: f32) -> PyResult<SimplifyOptions> {
    for (name, w) in [
        ("uv_weight", uv),
        ("normal_weight", normal),
        ("distance_weight", distance),
    ] {
        if !(w.is_finite() && w >= 0.0) {
            return fail(format!(
                "{name} {w}: give a finite number >= 0 (0 turns the term off)"
            ));
        }
    }
    Ok(SimplifyOptions {
        uv_weight: uv,
        normal_weight: normal,
        distance_weight: distance,
        ..SimplifyOptions::default()
    })
}

/// The morph of the arrays: `poses` (p × t weights) become a STEP weight track with its keys
/// at `k / (p − 1)`, exactly the times at which the exporter samples `p` poses, so the
/// shared sequence is simplified over exactly these weight sets.
#[allow(clippy::too_many_arguments)]
fn morph_of_arrays(
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    targets: Option<PyReadonlyArray3<'_, f32>>,
    target_names: Option<Vec<String>>,
    poses: Option<PyReadonlyArray2<'_, f32>>,
    uvs: Option<Vec<[f32; 2]>>,
    normals: Option<Vec<[f32; 3]>>,
) -> PyResult<(Morph, usize)> {
    let n = positions.len();
    let targets: Vec<MorphTarget> = match targets {
        None => Vec::new(),
        Some(t) => {
            let shape = t.shape();
            if shape[1] != n || shape[2] != 3 {
                return fail(format!(
                    "targets: shape {shape:?}, expected (t, {n}, 3): one delta per vertex"
                ));
            }
            let names = target_names.unwrap_or_default();
            if !names.is_empty() && names.len() != shape[0] {
                return fail(format!(
                    "{} target names for {} targets",
                    names.len(),
                    shape[0]
                ));
            }
            let flat = t
                .as_slice()
                .or_else(|_| fail("targets: the array must be C-contiguous"))?;
            flat.chunks_exact(3 * n.max(1))
                .take(shape[0])
                .enumerate()
                .map(|(i, deltas)| MorphTarget {
                    name: names
                        .get(i)
                        .cloned()
                        .unwrap_or_else(|| format!("target {i}")),
                    deltas: deltas.chunks_exact(3).map(|d| [d[0], d[1], d[2]]).collect(),
                    normal_deltas: None,
                })
                .collect()
        }
    };
    let t = targets.len();
    let (weights, count) = match poses {
        None if t == 0 => (
            Weights::TwoPose {
                w0: vec![],
                w1: vec![],
            },
            1,
        ),
        None => {
            // The basis and every target alone at weight 1.
            let mut values = vec![0.0; t];
            for k in 0..t {
                values.extend((0..t).map(|j| if j == k { 1.0 } else { 0.0 }));
            }
            (step_track(values, t + 1, t).or_else(fail)?, t + 1)
        }
        Some(p) => {
            let shape = p.shape();
            if shape[1] != t {
                return fail(format!(
                    "poses: shape {shape:?}, expected (p, {t}): one weight per target in each pose"
                ));
            }
            if shape[0] == 0 {
                return fail("poses: give at least one pose");
            }
            let values = p
                .as_slice()
                .or_else(|_| fail("poses: the array must be C-contiguous"))?
                .to_vec();
            if t == 0 {
                (
                    Weights::TwoPose {
                        w0: vec![],
                        w1: vec![],
                    },
                    shape[0],
                )
            } else {
                (step_track(values, shape[0], t).or_else(fail)?, shape[0])
            }
        }
    };
    let attributes = Attributes {
        normals,
        uvs,
        ..Attributes::default()
    };
    let morph = Morph::from_parts(triangles, positions, targets, weights)
        .and_then(|m| m.with_attributes(attributes))
        .or_else(fail)?;
    Ok((morph, count))
}

/// A STEP track of `poses` keys of `targets` weights each, keyed at `k / (poses − 1)`.
fn step_track(values: Vec<f32>, poses: usize, targets: usize) -> Result<Weights, MorphError> {
    let times: Vec<f32> = if poses == 1 {
        vec![0.0]
    } else {
        (0..poses).map(|k| k as f32 / (poses - 1) as f32).collect()
    };
    WeightTrack::new(Interpolation::Step, times, values, targets).map(Weights::Animated)
}

/// `morph` with its weights replaced by the STEP track of `count` weight sets of `targets`
/// weights ([`step_track`]), for choosing levels over those poses.
fn with_pose_track(
    morph: &Morph,
    values: Vec<f32>,
    count: usize,
    targets: usize,
) -> Result<Morph, String> {
    if count == 0 || targets != morph.targets().len() {
        return Err(format!(
            "pose_weights: shape ({count}, {targets}), expected (p, {}) with p >= 1: one weight per morph target of the file in each pose",
            morph.targets().len()
        ));
    }
    let weights = match targets {
        0 => Weights::TwoPose {
            w0: vec![],
            w1: vec![],
        },
        _ => step_track(values, count, targets).map_err(|e| e.to_string())?,
    };
    Morph::from_parts(
        morph.triangles().to_vec(),
        morph.base().to_vec(),
        morph.targets().to_vec(),
        weights,
    )
    .and_then(|m| m.with_attributes(morph.attributes().clone()))
    .map_err(|e| e.to_string())
}

/// Checks that `seams` (a label per vertex: equal labels for copies of one surface vertex)
/// groups the vertices as morphlod welds them ([`Morph::topology`]).
fn check_seams(morph: &Morph, seams: &[u32]) -> PyResult<()> {
    let n = morph.vertex_count();
    if seams.len() != n {
        return fail(format!("seams: {} entries for {n} vertices", seams.len()));
    }
    let topology = morph.topology();
    // The first vertex of each label and of each welded vertex: two vertices must share a
    // label exactly when they share a welded vertex.
    let mut first_of_label = std::collections::HashMap::new();
    let mut first_of_weld = vec![u32::MAX; topology.topology_count];
    for (v, (&label, &weld)) in seams.iter().zip(&topology.of_vertex).enumerate() {
        let by_label = *first_of_label.entry(label).or_insert(v as u32);
        let by_weld = &mut first_of_weld[weld as usize];
        if *by_weld == u32::MAX {
            *by_weld = v as u32;
        }
        if by_label == *by_weld {
            continue;
        }
        // Either v shares its label with a vertex welded elsewhere, or it is welded to a
        // vertex of another label.
        let differ = topology.of_vertex[by_label as usize] != weld;
        let attributes = morph.attributes().has_vertex_attributes();
        return fail(if differ && attributes {
            format!(
                "seams: vertices {by_label} and {v} have one label, but they differ in position or in a target's delta: copies at a seam must coincide in every pose"
            )
        } else if differ {
            format!(
                "seams: vertices {by_label} and {v} have one label, but copies are welded only on a mesh with uvs or normals (without them a split is an open border)"
            )
        } else {
            format!(
                "seams: vertices {} and {v} have different labels, but they coincide in every pose (position and every target's delta), and morphlod welds such vertices on a mesh with uvs or normals: merge them or move one",
                *by_weld
            )
        });
    }
    Ok(())
}

#[pyfunction]
#[pyo3(signature = (positions, triangles, targets=None, target_names=None, poses=None, uvs=None, normals=None, seams=None, fractions=None, errors=None, uv_weight=UV_WEIGHT, normal_weight=NORMAL_WEIGHT, distance_weight=DISTANCE_WEIGHT, progress=None))]
#[allow(clippy::too_many_arguments)]
fn simplify(
    py: Python<'_>,
    positions: PyReadonlyArray2<'_, f32>,
    triangles: PyReadonlyArray2<'_, u32>,
    targets: Option<PyReadonlyArray3<'_, f32>>,
    target_names: Option<Vec<String>>,
    poses: Option<PyReadonlyArray2<'_, f32>>,
    uvs: Option<PyReadonlyArray2<'_, f32>>,
    normals: Option<PyReadonlyArray2<'_, f32>>,
    seams: Option<PyReadonlyArray1<'_, u32>>,
    fractions: Option<Vec<f32>>,
    errors: Option<Vec<f32>>,
    uv_weight: f32,
    normal_weight: f32,
    distance_weight: f32,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<Level>> {
    let positions = rows::<3, f32>("positions", &positions)?;
    let triangles = rows::<3, u32>("triangles", &triangles)?;
    let uvs = uvs.map(|a| rows::<2, f32>("uvs", &a)).transpose()?;
    let normals = normals.map(|a| rows::<3, f32>("normals", &a)).transpose()?;
    let (morph, pose_count) = morph_of_arrays(
        positions,
        triangles,
        targets,
        target_names,
        poses,
        uvs,
        normals,
    )?;
    if let Some(seams) = seams {
        let seams = seams
            .as_slice()
            .or_else(|_| fail("seams: the array must be C-contiguous"))?
            .to_vec();
        check_seams(&morph, &seams)?;
    }
    let options = ExportOptions {
        lods: lod_steps(fractions, errors)?,
        poses: pose_count,
        simplify: simplify_options(uv_weight, normal_weight, distance_weight)?,
        ..ExportOptions::default()
    };
    let reporter = Reporter::new(progress.as_ref());
    let result = py.detach(|| {
        reporter.report("simplify", 0.0);
        let lods = levels(&morph, &options);
        reporter.report("simplify", 1.0);
        lods
    });
    let lods = reporter.finish(result.or_else(fail))?;
    // LOD0 is the original: the caller has it.
    lods[1..].iter().map(|lod| level(py, lod)).collect()
}

// ---------------------------------------------------------------------------------------------
// Files

/// A mesh as morphlod reads it from a file (`load`).
#[pyclass(frozen, module = "morphlod")]
struct Mesh {
    morph: Morph,
    /// The mesh's default weights (glTF `mesh.weights`), one per target.
    #[pyo3(get)]
    default_weights: Vec<f32>,
}

#[pymethods]
impl Mesh {
    /// `(n, 3)` float32 base positions.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        array2(py, self.morph.base())
    }

    /// `(m, 3)` uint32 triangles.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u32>>> {
        array2(py, self.morph.triangles())
    }

    /// `(t, n, 3)` float32 morph-target position deltas.
    #[getter]
    fn targets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let t = self.morph.targets();
        let flat: Vec<f32> = t
            .iter()
            .flat_map(|t| t.deltas.iter().flatten().copied())
            .collect();
        PyArray1::from_vec(py, flat).reshape([t.len(), self.morph.vertex_count(), 3])
    }

    /// The targets' names.
    #[getter]
    fn target_names(&self) -> Vec<String> {
        self.morph
            .targets()
            .iter()
            .map(|t| t.name.clone())
            .collect()
    }

    /// `(n, 2)` float32 texture coordinates, or None.
    #[getter]
    fn uvs<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f32>>>> {
        self.morph
            .attributes()
            .uvs
            .as_deref()
            .map(|uvs| array2(py, uvs))
            .transpose()
    }

    /// `(n, 3)` float32 normals as the file gives them, or None.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f32>>>> {
        self.morph
            .attributes()
            .normals
            .as_deref()
            .map(|n| array2(py, n))
            .transpose()
    }

    /// `(n,)` uint32: the surface vertex each vertex is a copy of (vertices split at a seam
    /// share one), numbered by first appearance; the identity without uvs or normals.
    #[getter]
    fn seams<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        array1(py, self.morph.topology().of_vertex)
    }

    /// `(count, t)` float32: the weights of the `count` poses `export` samples evenly over
    /// the mesh's animation (or from the basis to the default weights without one).
    fn pose_weights<'py>(
        &self,
        py: Python<'py>,
        count: usize,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        if count == 0 {
            return fail("count: sample at least one pose");
        }
        let rows: Vec<Vec<f32>> = (0..count)
            .map(|k| {
                let t = if count == 1 {
                    0.0
                } else {
                    k as f32 / (count - 1) as f32
                };
                self.morph.weights_at(t)
            })
            .collect();
        let t = self.morph.targets().len();
        PyArray1::from_vec(py, rows.concat()).reshape([count, t])
    }

    fn __repr__(&self) -> String {
        format!(
            "Mesh(vertices={}, triangles={}, targets={})",
            self.morph.vertex_count(),
            self.morph.triangle_count(),
            self.morph.targets().len()
        )
    }
}

fn load_options(mesh: Option<String>) -> LoadOptions {
    LoadOptions {
        gltf_mesh: mesh,
        ..LoadOptions::default()
    }
}

/// As `morphlod export` reads one glTF file (src/bin/morphlod/export.rs, `load_gltf`): every
/// target, driven by the chosen (or first) weight animation, or from the basis to the default
/// weights without one; and the default weights.
fn load_gltf(
    path: &Path,
    animation: Option<&str>,
    options: &LoadOptions,
) -> Result<(Morph, Option<Vec<f32>>), String> {
    if Format::from_path(path) != Some(Format::Gltf) {
        return Err(format!(
            "{}: a single input must be a glTF file (.gltf, .glb); to export a {} mesh, give two meshes V(0) V(1)",
            path.display(),
            Format::from_path(path).map_or("mesh", Format::name)
        ));
    }
    let by_default = match morphlod::io::load_morph(path, options, &MorphSource::DefaultWeights) {
        Err(LoadError::NoTargets { .. }) => load_attributed(path, options)
            .map_err(|e| e.to_string())?
            .to_static_morph()
            .map_err(|e| format!("{}: {e}", path.display()))?,
        other => other.map_err(|e| e.to_string())?,
    };
    let default_weights = match by_default.weights() {
        Weights::TwoPose { w1, .. } if !by_default.targets().is_empty() => Some(w1.clone()),
        _ => return Ok((by_default, None)),
    };
    let source = MorphSource::Animation(animation.unwrap_or("0").to_string());
    match morphlod::io::load_morph(path, options, &source) {
        Ok(morph) => Ok((morph, default_weights)),
        Err(LoadError::NoSuchAnimation { .. } | LoadError::NoWeightChannel { .. })
            if animation.is_none() =>
        {
            Ok((by_default, default_weights))
        }
        Err(e) => Err(e.to_string()),
    }
}

/// Two meshes as a morph from the first to the second, as the command line makes it
/// (src/bin/morphlod/main.rs, `load_pair`): directly when they share their connectivity,
/// else over their supermesh with the landmark pairs.
fn load_pair(
    a_path: &Path,
    b_path: &Path,
    landmarks: Option<&Path>,
    options: &LoadOptions,
    reporter: &Reporter<'_>,
) -> Result<Morph, String> {
    let a = load_attributed(a_path, options).map_err(|e| e.to_string())?;
    let b = load_attributed(b_path, options).map_err(|e| e.to_string())?;
    match morph_from_pair(&a, &b) {
        Ok(morph) => Ok(morph),
        Err(
            MorphError::PoseSizeMismatch { .. }
            | MorphError::TriangleCountMismatch { .. }
            | MorphError::TriangleMismatch { .. },
        ) => {
            let landmarks = read_landmarks(landmarks)?;
            let (supermesh, _) =
                build_supermesh(&a.positions, &b.positions, &landmarks, true, reporter)?;
            supermesh.to_morph().map_err(|e| e.to_string())
        }
        Err(e) => Err(e.to_string()),
    }
}

fn read_landmarks(path: Option<&Path>) -> Result<Landmarks, String> {
    let Some(path) = path else {
        return Ok(Landmarks::default());
    };
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse_landmarks(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn build_supermesh(
    a: &IndexedMesh,
    b: &IndexedMesh,
    landmarks: &Landmarks,
    tips: bool,
    reporter: &Reporter<'_>,
) -> Result<(Supermesh, morphlod::morph::supermesh::SupermeshReport), String> {
    let progress = |stage: morphlod::morph::supermesh::Stage, fraction: f32| {
        reporter.report(&format!("supermesh: {}", stage.name()), fraction)
    };
    let options = SupermeshOptions {
        landmarks: landmarks.pairs.clone(),
        progress: Some(&progress),
        tips,
        ..SupermeshOptions::default()
    };
    Supermesh::build(a, b, &options).map_err(|e| landmarks.explain(&e))
}

/// Refuses an output that is one of the inputs or lacks the extension of what is written
/// (the command line's rule, src/bin/morphlod/output.rs), before any work.
fn check_output(output: &Path, extension: &str, inputs: &[&Path]) -> Result<(), String> {
    let ext = output.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !ext.eq_ignore_ascii_case(extension) {
        return Err(format!(
            "{}: the output must be a .{extension} file: give a path ending in .{extension}",
            output.display()
        ));
    }
    if let Ok(out) = std::fs::canonicalize(output) {
        if let Some(input) = inputs
            .iter()
            .find(|i| std::fs::canonicalize(i).is_ok_and(|i| i == out))
        {
            return Err(format!(
                "{}: the output is one of the inputs ({}); writing it would destroy that input: choose another output file",
                output.display(),
                input.display()
            ));
        }
    }
    Ok(())
}

#[pyfunction]
#[pyo3(signature = (path, mesh=None, animation=None))]
fn load(
    py: Python<'_>,
    path: PathBuf,
    mesh: Option<String>,
    animation: Option<String>,
) -> PyResult<Mesh> {
    let options = load_options(mesh);
    let (morph, default_weights) = py
        .detach(|| {
            if Format::from_path(&path) == Some(Format::Gltf) {
                return load_gltf(&path, animation.as_deref(), &options);
            }
            // OBJ, OFF, PLY: one mesh with its attributes and no targets.
            let morph = load_attributed(&path, &options)
                .map_err(|e| e.to_string())?
                .to_static_morph()
                .map_err(|e| format!("{}: {e}", path.display()))?;
            Ok((morph, None))
        })
        .or_else(fail)?;
    let default_weights = default_weights.unwrap_or_else(|| morph.weights_at(0.0));
    Ok(Mesh {
        morph,
        default_weights,
    })
}

#[pyfunction]
#[pyo3(signature = (inputs, output, fractions=None, errors=None, poses=DEFAULT_POSES, uv_weight=UV_WEIGHT, normal_weight=NORMAL_WEIGHT, distance_weight=DISTANCE_WEIGHT, animation=None, mesh=None, landmarks=None, quantize=false, compress=false, position_bits=None, normal_bits=None, uv_bits=None, pose_weights=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn export(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    fractions: Option<Vec<f32>>,
    errors: Option<Vec<f32>>,
    poses: usize,
    uv_weight: f32,
    normal_weight: f32,
    distance_weight: f32,
    animation: Option<String>,
    mesh: Option<String>,
    landmarks: Option<PathBuf>,
    quantize: bool,
    compress: bool,
    position_bits: Option<u32>,
    normal_bits: Option<u32>,
    uv_bits: Option<u32>,
    pose_weights: Option<PyReadonlyArray2<'_, f32>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<Level>> {
    let lods = lod_steps(fractions, errors)?;
    let pose_weights = match &pose_weights {
        Some(w) => {
            let shape = w.shape();
            let flat = w
                .as_slice()
                .or_else(|_| fail("pose_weights: the array must be C-contiguous"))?;
            Some((flat.to_vec(), shape[0], shape[1]))
        }
        None => None,
    };
    let simplify = simplify_options(uv_weight, normal_weight, distance_weight)?;
    let defaults = QuantizeOptions::default();
    let quantize = (quantize || compress).then_some(QuantizeOptions {
        position_bits: position_bits.unwrap_or(defaults.position_bits),
        normal_bits: normal_bits.unwrap_or(defaults.normal_bits),
        uv_bits: uv_bits.unwrap_or(defaults.uv_bits),
    });
    let reporter = Reporter::new(progress.as_ref());
    let result = py.detach(|| -> Result<Vec<Lod>, String> {
        let mut read: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        read.extend(landmarks.as_deref());
        check_output(&output, "glb", &read)?;
        let options = load_options(mesh);
        reporter.report("load", 0.0);
        let (morph, default_weights, source) = match inputs.as_slice() {
            [a, b] => (
                load_pair(a, b, landmarks.as_deref(), &options, &reporter)?,
                None,
                SourceScene::default(),
            ),
            [path] => {
                let (morph, weights) = load_gltf(path, animation.as_deref(), &options)?;
                // Every animation of the file is written.
                let source =
                    morphlod::io::gltf::source_scene(path, &options).map_err(|e| e.to_string())?;
                (morph, weights, source)
            }
            _ => return Err("give one glTF file or two meshes".into()),
        };
        reporter.report("load", 1.0);
        let name = inputs[0]
            .file_stem()
            .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
        reporter.report("simplify", 0.0);
        let options = ExportOptions {
            lods,
            poses,
            simplify,
            default_weights,
            name,
            source,
            quantize,
            compress,
        };
        let export = match pose_weights {
            None => export_glb(&morph, &options),
            // The levels over the given weight sets, written with the file's animation.
            Some((values, count, targets)) => {
                let over = with_pose_track(&morph, values, count, targets)?;
                let poses = ExportOptions {
                    poses: count,
                    ..options.clone()
                };
                levels(&over, &poses).and_then(|lods| export_glb_levels(&morph, lods, &options))
            }
        }
        .map_err(|e| e.to_string())?;
        reporter.report("simplify", 1.0);
        std::fs::write(&output, &export.glb)
            .map_err(|e| format!("{}: cannot write: {e}", output.display()))?;
        reporter.report("write", 1.0);
        Ok(export.lods)
    });
    let lods = reporter.finish(result.or_else(fail))?;
    lods.iter().map(|lod| level(py, lod)).collect()
}

/// As the command line loads a build's inputs (src/bin/morphlod/main.rs, `load_morph`).
fn build_input(
    inputs: &[PathBuf],
    target: Option<&str>,
    animation: Option<&str>,
    landmarks: Option<&Path>,
    options: &LoadOptions,
    reporter: &Reporter<'_>,
) -> Result<Morph, String> {
    match inputs {
        [a, b] => {
            if target.is_some() || animation.is_some() {
                return Err("target and animation choose a glTF morph; with two input meshes the morph runs from the first to the second".into());
            }
            load_pair(a, b, landmarks, options, reporter)
        }
        [path] => {
            let source = match (target, animation) {
                (Some(_), Some(_)) => return Err("give target or animation, not both".into()),
                (Some(t), None) => MorphSource::Target(t.to_string()),
                (None, Some(a)) => MorphSource::Animation(a.to_string()),
                (None, None) => {
                    return Err(format!(
                        "{}: one input needs target=NAME or animation=NAME (`morphlod.load` and `morphlod info` list them), or give two meshes",
                        path.display()
                    ))
                }
            };
            morphlod::io::load_morph(path, options, &source).map_err(|e| e.to_string())
        }
        _ => Err("give one glTF file or two meshes".into()),
    }
}

#[pyfunction]
#[pyo3(signature = (inputs, output, target=None, animation=None, mesh=None, frames=morphlod::build::DEFAULT_FRAMES, sequence="per-frame", pose_error="max", uv_weight=UV_WEIGHT, normal_weight=NORMAL_WEIGHT, distance_weight=None, landmarks=None, weld=false, no_weld=false, progress=None))]
#[allow(clippy::too_many_arguments)]
fn build<'py>(
    py: Python<'py>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    target: Option<String>,
    animation: Option<String>,
    mesh: Option<String>,
    frames: usize,
    sequence: &str,
    pose_error: &str,
    uv_weight: f32,
    normal_weight: f32,
    distance_weight: Option<f32>,
    landmarks: Option<PathBuf>,
    weld: bool,
    no_weld: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let sequences = match (sequence, pose_error) {
        ("per-frame", _) => Sequences::PerFrame,
        ("shared", "max") => Sequences::Shared(PoseError::Max),
        ("shared", "mean") => Sequences::Shared(PoseError::Mean),
        ("shared", other) => {
            return fail(format!("pose_error {other:?}: give \"max\" or \"mean\""))
        }
        (other, _) => {
            return fail(format!(
                "sequence {other:?}: give \"per-frame\" or \"shared\""
            ))
        }
    };
    if weld && no_weld {
        return fail("give weld or no_weld, not both");
    }
    // Per-frame sequences default to no distance term, a shared one to the exporter's.
    let shared = matches!(sequences, Sequences::Shared(_));
    let distance = distance_weight.unwrap_or(if shared { DISTANCE_WEIGHT } else { 0.0 });
    let simplify = simplify_options(uv_weight, normal_weight, distance)?;
    let reporter = Reporter::new(progress.as_ref());
    let result = py.detach(|| -> Result<(AssetInfo, f64), String> {
        let mut read: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        read.extend(landmarks.as_deref());
        check_output(&output, "mlod", &read)?;
        let options = load_options(mesh);
        reporter.report("load", 0.0);
        let morph = build_input(
            &inputs,
            target.as_deref(),
            animation.as_deref(),
            landmarks.as_deref(),
            &options,
            &reporter,
        )?;
        let (morph, _) = morph
            .clean(&CleanOptions {
                weld,
                weld_soup: !no_weld,
            })
            .map_err(|e| e.to_string())?;
        reporter.report("load", 1.0);
        let on_frame =
            |p: Progress| reporter.report("frames", p.frames_done as f32 / p.frames.max(1) as f32);
        let (asset, report) = Builder::new(&morph)
            .frames(frames)
            .sequences(sequences)
            .simplify_options(simplify)
            .progress(&on_frame)
            .build()
            .map_err(|e| e.to_string())?;
        let bytes = asset.to_bytes();
        save_bytes(&output, &bytes).map_err(|e| e.to_string())?;
        reporter.report("write", 1.0);
        let (_, info) =
            inspect_with(&bytes, &AssetLoadOptions::default()).map_err(|e| e.to_string())?;
        Ok((info, report.wall.as_secs_f64()))
    });
    let (info, seconds) = reporter.finish(result.or_else(fail))?;
    let dict = info_dict(py, &info)?;
    dict.set_item("build_seconds", seconds)?;
    Ok(dict)
}

fn info_dict<'py>(py: Python<'py>, info: &AssetInfo) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("version", info.version)?;
    dict.set_item("file_bytes", info.file_bytes)?;
    dict.set_item("vertices", info.vertices)?;
    dict.set_item("triangles", info.triangles)?;
    dict.set_item("strips", info.strips)?;
    dict.set_item("strip_indices", info.strip_indices)?;
    dict.set_item(
        "frames",
        PyList::new(py, info.frames.iter().map(|f| f.collapses + 1))?,
    )?;
    dict.set_item("targets", info.targets)?;
    let sections = PyDict::new(py);
    for s in &info.sections {
        sections.set_item(s.tag.trim_end(), s.bytes)?;
    }
    dict.set_item("sections", sections)?;
    dict.set_item("text", info.to_string())?;
    Ok(dict)
}

#[pyfunction]
#[pyo3(signature = (path, memory_budget_mb=morphlod::asset::DEFAULT_MAX_BYTES >> 20))]
fn info<'py>(
    py: Python<'py>,
    path: PathBuf,
    memory_budget_mb: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let options = AssetLoadOptions {
        max_bytes: memory_budget_mb.saturating_mul(1 << 20),
    };
    let info = py
        .detach(|| -> Result<AssetInfo, String> {
            let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            inspect_with(&bytes, &options)
                .map(|(_, info)| info)
                .map_err(|e| format!("{}: {e}", path.display()))
        })
        .or_else(fail)?;
    info_dict(py, &info)
}

// ---------------------------------------------------------------------------------------------
// Supermesh

/// The supermesh of two meshes: one triangulation with a pose on each.
#[pyclass(frozen, module = "morphlod")]
struct SupermeshResult {
    /// `(m, 3)` uint32 triangles.
    #[pyo3(get)]
    triangles: Py<PyArray2<u32>>,
    /// `(n, 3)` float32 positions on A (t = 0); A's vertices bit for bit.
    #[pyo3(get)]
    v0: Py<PyArray2<f32>>,
    /// `(n, 3)` float32 positions on B (t = 1); B's vertices bit for bit.
    #[pyo3(get)]
    v1: Py<PyArray2<f32>>,
    /// `(n,)` int64: the vertex of A each vertex is, or -1 (a vertex of B or a crossing).
    #[pyo3(get)]
    a_vertex: Py<PyArray1<i64>>,
    /// `(n,)` int64: the vertex of B each vertex is, or -1.
    #[pyo3(get)]
    b_vertex: Py<PyArray1<i64>>,
    /// The command line's report (sizes, crossings, fold-overs, alignment, time per stage).
    #[pyo3(get)]
    report: String,
    /// Supermesh triangles that fold over on the sphere (0 for a correct supermesh).
    #[pyo3(get)]
    fold_overs: usize,
}

#[pyfunction]
#[pyo3(signature = (a_positions, a_triangles, b_positions, b_triangles, landmarks=None, tips=true, progress=None))]
#[allow(clippy::too_many_arguments)]
fn supermesh(
    py: Python<'_>,
    a_positions: PyReadonlyArray2<'_, f32>,
    a_triangles: PyReadonlyArray2<'_, u32>,
    b_positions: PyReadonlyArray2<'_, f32>,
    b_triangles: PyReadonlyArray2<'_, u32>,
    landmarks: Option<PyReadonlyArray2<'_, u32>>,
    tips: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<SupermeshResult> {
    let a = IndexedMesh::new(
        rows("a_positions", &a_positions)?,
        rows("a_triangles", &a_triangles)?,
    );
    let b = IndexedMesh::new(
        rows("b_positions", &b_positions)?,
        rows("b_triangles", &b_triangles)?,
    );
    let pairs: Vec<[u32; 2]> = landmarks
        .map(|l| rows::<2, u32>("landmarks", &l))
        .transpose()?
        .unwrap_or_default();
    let landmarks = Landmarks {
        lines: (1..=pairs.len()).collect(),
        pairs: pairs.iter().map(|p| (p[0], p[1])).collect(),
    };
    let reporter = Reporter::new(progress.as_ref());
    let result = py.detach(|| build_supermesh(&a, &b, &landmarks, tips, &reporter));
    let (mesh, report) = reporter.finish(result.or_else(fail))?;
    let side = |pick: fn(&Origin) -> Option<u32>| -> Vec<i64> {
        mesh.origins
            .iter()
            .map(|o| pick(o).map_or(-1, i64::from))
            .collect()
    };
    let a_vertex = side(|o| match *o {
        Origin::A(a) | Origin::Both { a, .. } => Some(a),
        _ => None,
    });
    let b_vertex = side(|o| match *o {
        Origin::B(b) | Origin::Both { b, .. } => Some(b),
        _ => None,
    });
    Ok(SupermeshResult {
        triangles: frozen(array2(py, &mesh.triangles)?)?,
        v0: frozen(array2(py, &mesh.v0)?)?,
        v1: frozen(array2(py, &mesh.v1)?)?,
        a_vertex: frozen(array1(py, a_vertex))?,
        b_vertex: frozen(array1(py, b_vertex))?,
        report: report.to_string(),
        fold_overs: report.fold_overs,
    })
}

#[pymodule]
fn _morphlod(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MorphlodError", m.py().get_type::<MorphlodError>())?;
    m.add("UV_WEIGHT", UV_WEIGHT)?;
    m.add("NORMAL_WEIGHT", NORMAL_WEIGHT)?;
    m.add("DISTANCE_WEIGHT", DISTANCE_WEIGHT)?;
    m.add("DEFAULT_POSES", DEFAULT_POSES)?;
    m.add("DEFAULT_FRAMES", morphlod::build::DEFAULT_FRAMES)?;
    m.add("MAX_POSES", morphlod::build::MAX_FRAMES)?;
    m.add_class::<Level>()?;
    m.add_class::<Mesh>()?;
    m.add_class::<SupermeshResult>()?;
    m.add_function(wrap_pyfunction!(simplify, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(export, m)?)?;
    m.add_function(wrap_pyfunction!(build, m)?)?;
    m.add_function(wrap_pyfunction!(info, m)?)?;
    m.add_function(wrap_pyfunction!(supermesh, m)?)?;
    Ok(())
}
