//! `morphlod bench --baselines MESH`: the LodStrips paper's comparison (seed 001 §4) run here.
//! Progressive Meshes, MTS and Skip Strips ([`crate::baselines`]) beside our LodStrips, all
//! built from one QEM collapse sequence and one set of strips `S0` of the mesh, on the same
//! adapter in one run:
//!
//! * **Table 1**, the spatial cost of each model (its shared data plus 12 bytes per vertex
//!   position) against the triangle mesh (12 bytes per vertex and per triangle), in MB of
//!   2^20 bytes as the paper's Cow row (0.100 MB for 2904 vertices, 5804 triangles) implies;
//! * **Table 2**, the linear and exponential tests (Ribelles et al. 1999, as seed 001 cites
//!   them) over `frames` frames from full detail to the coarsest, with the LOD fractions of
//!   [`Sweep`]: `x`, and `(1024^x − 1) / 1023`, which dwells near full detail (the paper's
//!   exponential render times are above its linear ones for every model and mesh, so its
//!   exponential test spends more frames at fine LODs). Per frame and model: the extraction's
//!   CPU time (`set_lod`), the GPU time of one draw (submit + wait, the fastest of `repeats`;
//!   the first carries the frame's uploads), vertices and strips sent, bytes uploaded.
//!   Render time = extraction + draw, and "% rec" its extraction share, as in the paper.
//!
//! * **Table 3**, Skip Strips' view-dependent mode (seed 003 §4.2.1, no other model has one):
//!   the eye flies in along the camera's axis from 3 to 0.25 mesh diagonals from the centre
//!   over `frames` frames, one [`SkipStrips::adapt_to_view`] pass a frame (merges, splits, the
//!   modified display strips regenerated); per frame its CPU time, the operations done and
//!   refused by the dependencies, the display vertices and what the strips send. Extraction
//!   only: nothing is drawn.
//!
//! Every model draws through the same [`Object`] path (regions, one multi-draw), faceted:
//! a strip model's changed regions are written with `write_region` (which uploads only the
//! words that changed), PM's one triangle-list region likewise.

use std::fmt::Write as _;
use std::time::Instant;

use crate::baselines::mts::Mts;
use crate::baselines::pm::ProgressiveMesh;
use crate::baselines::skip_strips::SkipStrips;
use crate::baselines::{
    strips_and_vertices, Baseline, BaselineError, Primitive, POSITION_BYTES, RESTART,
};
use crate::bench::{gpu_frame, micros, Sweep};
use morphlod::collapse::CollapseSequence;
use morphlod::gpu::camera::{fit_to_bounds, Projection};
use morphlod::gpu::{Context, MorphPipeline, Object, RenderTarget, ShadeMode, Topology};
use morphlod::lodstrips::{Indices, LodStrips, StripsState};
use morphlod::strip::Strips;
use morphlod::IndexedMesh;

/// Settings of a baselines run.
#[derive(Clone, Copy, Debug)]
pub struct BaselineOptions {
    /// Frames per test (at least 2).
    pub frames: usize,
    /// Width and height of the offscreen target.
    pub size: u32,
    /// Draws per model and frame; the fastest counts.
    pub repeats: usize,
}

/// Our LodStrips (the library's model and runtime) behind the baselines' interface.
struct OurLodStrips {
    model: LodStrips,
    state: StripsState,
}

impl Baseline for OurLodStrips {
    fn name(&self) -> &'static str {
        "LodStrips"
    }
    fn primitive(&self) -> Primitive {
        Primitive::Strips
    }
    fn max_lod(&self) -> usize {
        self.model.max_lod()
    }
    fn lod(&self) -> usize {
        self.state.lod()
    }
    fn set_lod(&mut self, lod: usize) -> Result<(), BaselineError> {
        let max = self.max_lod();
        if lod > max {
            return Err(BaselineError::LodOutOfRange { lod, max });
        }
        self.state
            .set_lod(&self.model, lod)
            .map_err(|_| BaselineError::LodOutOfRange { lod, max })
    }
    fn region_count(&self) -> usize {
        self.model.strip_count()
    }
    fn region_capacity(&self, r: usize) -> usize {
        let offsets = self.model.region_offsets();
        (offsets[r + 1] - offsets[r]) as usize
    }
    fn region(&self, r: usize) -> Indices<'_> {
        self.state.strip(r).unwrap_or_default()
    }
    fn take_changed(&mut self) -> Vec<u32> {
        let dirty = self.state.take_dirty();
        let mut changed = dirty.lengths;
        changed.extend(dirty.ranges.iter().map(|range| range.strip));
        changed.sort_unstable();
        changed.dedup();
        changed
    }
    fn model_bytes(&self) -> usize {
        self.model.byte_size()
    }
    fn state_bytes(&self) -> usize {
        self.state.heap_bytes()
    }
}

/// Spatial cost of one model (Table 1).
#[derive(Clone, Debug)]
pub struct SizeRow {
    pub model: &'static str,
    /// The model's shared data plus the vertex positions.
    pub bytes: usize,
    /// Per-instance runtime state, not in `bytes` (the paper does not count it).
    pub state_bytes: usize,
    /// Build time, milliseconds.
    pub build_ms: f64,
}

/// One frame of one test for one model (Table 2, Fig. 1).
#[derive(Clone, Debug)]
pub struct BaselineRow {
    pub test: Sweep,
    pub model: &'static str,
    pub frame: usize,
    pub lod: usize,
    pub extract_us: f64,
    pub draw_ms: f64,
    /// Indices sent other than restarts, and strips (0 for PM's triangle list).
    pub vertices: usize,
    pub strips: usize,
    pub upload_bytes: u64,
}

/// One frame of the view-dependent fly-in (Table 3).
#[derive(Clone, Debug)]
pub struct ViewRow {
    pub frame: usize,
    /// Eye distance from the mesh's centre, in mesh diagonals.
    pub distance: f32,
    pub extract_us: f64,
    pub merges: usize,
    pub splits: usize,
    pub refused: usize,
    /// Display vertices (the active nodes list).
    pub displayed: usize,
    /// Indices sent other than restarts, and strips.
    pub vertices: usize,
    pub strips: usize,
}

/// A whole baselines run over one mesh.
#[derive(Clone, Debug)]
pub struct BaselinesReport {
    pub mesh: String,
    pub adapter: String,
    pub backend: String,
    pub device_type: String,
    pub vertices: usize,
    pub triangles: usize,
    pub max_lod: usize,
    pub sizes: Vec<SizeRow>,
    pub rows: Vec<BaselineRow>,
    pub view_rows: Vec<ViewRow>,
}

/// A model and the milliseconds its build took.
type Built = (Box<dyn Baseline>, f64);

/// The four models of `mesh` (PM, MTS, Skip Strips, LodStrips), each timed as it builds.
fn build_models(
    mesh: &IndexedMesh,
    strips: &Strips,
    seq: &CollapseSequence,
) -> Result<Vec<Built>, String> {
    type Build<'a> = Box<dyn Fn() -> Result<Box<dyn Baseline>, String> + 'a>;
    let builds: [Build; 4] = [
        Box::new(|| {
            ProgressiveMesh::build(&mesh.triangles, seq)
                .map(|m| Box::new(m) as Box<dyn Baseline>)
                .map_err(|e| format!("PM: {e}"))
        }),
        Box::new(|| {
            Mts::build(strips, seq)
                .map(|m| Box::new(m) as Box<dyn Baseline>)
                .map_err(|e| format!("MTS: {e}"))
        }),
        Box::new(|| {
            SkipStrips::build(strips, seq)
                .map(|m| Box::new(m) as Box<dyn Baseline>)
                .map_err(|e| format!("Skip Strips: {e}"))
        }),
        Box::new(|| {
            let model = LodStrips::build(strips, seq).map_err(|e| format!("LodStrips: {e}"))?;
            let state = StripsState::new(&model);
            Ok(Box::new(OurLodStrips { model, state }) as Box<dyn Baseline>)
        }),
    ];
    builds
        .iter()
        .map(|build| {
            let start = Instant::now();
            let model = build()?;
            Ok((model, micros(start) / 1e3))
        })
        .collect()
}

/// Runs Table 1 and both tests of Table 2 over `mesh` with its collapse sequence `seq`.
pub fn run_baselines(
    context: &Context,
    name: &str,
    mesh: &IndexedMesh,
    seq: &CollapseSequence,
    options: &BaselineOptions,
) -> Result<BaselinesReport, String> {
    let (device, queue) = (&context.device, &context.queue);
    let positions = &mesh.positions;
    let strips = morphlod::strip::stripify(&mesh.triangles, positions.len());
    let mut models = build_models(mesh, &strips, seq)?;
    let sizes = models
        .iter()
        .map(|(model, build_ms)| SizeRow {
            model: model.name(),
            bytes: model.model_bytes() + POSITION_BYTES * positions.len(),
            state_bytes: model.state_bytes(),
            build_ms: *build_ms,
        })
        .collect();

    let gpu = |e: morphlod::gpu::GpuError| e.to_string();
    let target =
        RenderTarget::new(device, options.size, options.size, wgpu::Color::BLACK).map_err(gpu)?;
    let pipeline = MorphPipeline::new(
        device,
        RenderTarget::COLOR_FORMAT,
        Some(RenderTarget::DEPTH_FORMAT),
    );
    let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in positions {
        for k in 0..3 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    let camera = fit_to_bounds(
        min,
        max,
        glam::Vec3::new(-0.35, -0.15, -1.0),
        1.0,
        Projection::Perspective {
            vertical_fov: 40f32.to_radians(),
        },
    )
    .map_err(gpu)?
    .view_proj();

    let frames = options.frames.max(2);
    let repeats = options.repeats.max(1);
    let mut rows = Vec::new();
    for test in [Sweep::Linear, Sweep::Exponential] {
        let mut objects = Vec::with_capacity(models.len());
        for (model, _) in &mut models {
            model.set_lod(0).map_err(|e| e.to_string())?;
            model.take_changed();
            let object = object_for(device, queue, &pipeline, positions, camera, model.as_ref())?;
            gpu_frame(device, queue, &target, &object).map_err(gpu)?;
            objects.push(object);
        }
        // Frame by frame, every model in turn: load from other processes on a shared machine
        // then falls on all four alike instead of on whichever model ran during it.
        for frame in 0..frames {
            let x = frame as f32 / (frames - 1) as f32;
            for ((model, _), object) in models.iter_mut().zip(&mut objects) {
                let max_lod = model.max_lod();
                let lod = (f64::from(test.fraction(x)) * max_lod as f64).round() as usize;
                let start = Instant::now();
                model.set_lod(lod.min(max_lod)).map_err(|e| e.to_string())?;
                let extract_us = micros(start);
                for r in model.take_changed() {
                    object
                        .write_region(r as usize, model.region(r as usize))
                        .map_err(gpu)?;
                }
                let upload = object.prepare(queue);
                let mut draw_ms = f64::INFINITY;
                for _ in 0..repeats {
                    draw_ms =
                        draw_ms.min(gpu_frame(device, queue, &target, object).map_err(gpu)?.0);
                }
                let (mut strips_sent, mut vertices) = (0, 0);
                for r in 0..model.region_count() {
                    let live = model.region(r);
                    match model.primitive() {
                        Primitive::Strips => {
                            let (s, v) = strips_and_vertices(live);
                            strips_sent += s;
                            vertices += v;
                        }
                        Primitive::Triangles => vertices += live.len(),
                    }
                }
                rows.push(BaselineRow {
                    test,
                    model: model.name(),
                    frame,
                    lod: model.lod(),
                    extract_us,
                    draw_ms,
                    vertices,
                    strips: strips_sent,
                    upload_bytes: upload.geometry_bytes(),
                });
            }
        }
    }
    let view_rows = view_dependent(&strips, seq, positions, (min, max), frames)?;
    let info = context.adapter_info();
    Ok(BaselinesReport {
        mesh: name.to_string(),
        adapter: info.name,
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        vertices: positions.len(),
        triangles: mesh.triangles.len(),
        max_lod: seq.len(),
        sizes,
        rows,
        view_rows,
    })
}

/// Table 3: Skip Strips' view-dependent fly-in over the mesh with bounds `(min, max)`. The
/// tolerance wants half the merges (by switch value) at one diagonal's distance.
fn view_dependent(
    strips: &Strips,
    seq: &CollapseSequence,
    positions: &[[f32; 3]],
    (min, max): ([f32; 3], [f32; 3]),
    frames: usize,
) -> Result<Vec<ViewRow>, String> {
    let mut model = SkipStrips::build(strips, seq).map_err(|e| format!("Skip Strips: {e}"))?;
    let centre = glam::Vec3::from(min).lerp(glam::Vec3::from(max), 0.5);
    let diag = (glam::Vec3::from(max) - glam::Vec3::from(min))
        .length()
        .max(f32::MIN_POSITIVE);
    let mut errors: Vec<f32> = seq
        .collapses
        .iter()
        .map(|c| c.error.max(0.0).sqrt())
        .collect();
    errors.sort_by(f32::total_cmp);
    let tolerance = errors.get(errors.len() / 2).copied().unwrap_or(0.0) / diag;
    let axis = glam::Vec3::new(-0.35, -0.15, -1.0).normalize();
    let mut rows = Vec::with_capacity(frames);
    for frame in 0..frames {
        let x = frame as f32 / (frames - 1).max(1) as f32;
        let distance = 3.0 + (0.25 - 3.0) * x;
        let eye = centre - axis * distance * diag;
        let start = Instant::now();
        let done = model
            .adapt_to_view(positions, eye.into(), tolerance)
            .map_err(|e| format!("Skip Strips: {e}"))?;
        let extract_us = micros(start);
        let (mut strips_sent, mut vertices) = (0, 0);
        for r in 0..model.region_count() {
            let (s, v) = strips_and_vertices(model.region(r));
            strips_sent += s;
            vertices += v;
        }
        rows.push(ViewRow {
            frame,
            distance,
            extract_us,
            merges: done.merges,
            splits: done.splits,
            refused: done.refused,
            displayed: model.displayed().len(),
            vertices,
            strips: strips_sent,
        });
    }
    Ok(rows)
}

/// A GPU object over `model`'s regions at its current LOD, seen through `camera`, uploaded: each region sized to its
/// capacity (restarts or degenerate triangles past the live part), then given its live
/// contents, as the model's extractions will write it later.
fn object_for(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &MorphPipeline,
    positions: &[[f32; 3]],
    camera: glam::Mat4,
    model: &dyn Baseline,
) -> Result<Object, String> {
    let gpu = |e: morphlod::gpu::GpuError| e.to_string();
    let (topology, filler) = match model.primitive() {
        Primitive::Strips => (Topology::Strip, RESTART),
        Primitive::Triangles => (Topology::List, 0),
    };
    let regions: Vec<Vec<u32>> = (0..model.region_count())
        .map(|r| {
            let mut region = model.region(r).to_vec();
            region.resize(model.region_capacity(r), filler);
            region
        })
        .collect();
    let mut object =
        Object::new(device, pipeline, topology, positions, positions, &regions).map_err(gpu)?;
    for r in 0..model.region_count() {
        object.write_region(r, model.region(r)).map_err(gpu)?;
    }
    object.set_view_proj(camera);
    object.set_shade_mode(ShadeMode::Faceted);
    object.prepare(queue);
    Ok(object)
}

const MB: f64 = (1 << 20) as f64;

/// The seed's figures for a mesh of the same name (Table 1: MB of the triangle mesh, PM, MTS,
/// LodStrips; Table 2: render ms and % rec, linear then exponential, PM, MTS, LodStrips).
type PaperRow = (&'static str, [f64; 4], [[f64; 2]; 6]);
const PAPER: [PaperRow; 3] = [
    (
        "cow",
        [0.100, 0.272, 0.252, 0.186],
        [
            [0.917916, 6.43],
            [0.934682, 24.36],
            [0.231398, 24.36],
            [1.234464, 5.88],
            [0.53519, 37.6],
            [0.298161, 20.73],
        ],
    ),
    (
        "bunny",
        [1.193, 3.282, 2.963, 2.111],
        [
            [10.792452, 0.59],
            [6.304261, 21.85],
            [3.077063, 2.57],
            [16.164691, 0.49],
            [6.998482, 17.54],
            [4.129842, 1.89],
        ],
    ),
    (
        "phone",
        [2.850, 7.863, 6.765, 4.844],
        [
            [32.983562, 0.24],
            [14.812924, 16.29],
            [8.301228, 1.65],
            [48.922801, 0.17],
            [16.735283, 12.81],
            [11.756625, 1.15],
        ],
    ),
];

impl BaselinesReport {
    /// Bytes of the plain triangle mesh: 12 per vertex and 12 per triangle.
    pub fn triangle_mesh_bytes(&self) -> usize {
        POSITION_BYTES * self.vertices + 12 * self.triangles
    }

    fn rows_of<'a>(&'a self, test: Sweep, model: &'a str) -> impl Iterator<Item = &'a BaselineRow> {
        self.rows
            .iter()
            .filter(move |r| r.test == test && r.model == model)
    }

    /// Per-frame means of one model in one test: render ms, extraction ms, draw ms,
    /// vertices, strips, upload bytes.
    fn means(&self, test: Sweep, model: &str) -> [f64; 6] {
        let mut sum = [0.0; 6];
        let mut n = 0usize;
        for r in self.rows_of(test, model) {
            let extract = r.extract_us / 1e3;
            let row = [
                extract + r.draw_ms,
                extract,
                r.draw_ms,
                r.vertices as f64,
                r.strips as f64,
                r.upload_bytes as f64,
            ];
            for (s, v) in sum.iter_mut().zip(row) {
                *s += v;
            }
            n += 1;
        }
        sum.map(|s| s / n.max(1) as f64)
    }

    fn models(&self) -> Vec<&'static str> {
        self.sizes.iter().map(|s| s.model).collect()
    }

    /// Table 1 and Table 2 as Markdown, each with the paper's row for a mesh of that name.
    pub fn markdown(&self) -> String {
        let mut out = String::new();
        let tri = self.triangle_mesh_bytes() as f64;
        let _ = writeln!(
            out,
            "{}: {} vertices, {} triangles, {} LODs; {} ({}, {})\n",
            self.mesh,
            self.vertices,
            self.triangles,
            self.max_lod,
            self.adapter,
            self.backend,
            self.device_type
        );
        let models = self.models();
        let _ = writeln!(
            out,
            "Table 1. Spatial cost in MB (2^20 bytes), ratio to the triangle mesh.\n"
        );
        let mut header = String::from("| Mesh | Tr. Mesh |");
        let mut rule = String::from("|---|---:|");
        for m in &models {
            let _ = write!(header, " {m} |");
            rule.push_str("---:|");
        }
        for m in &models {
            let _ = write!(header, " Ratio {m} |");
            rule.push_str("---:|");
        }
        let _ = writeln!(out, "{header}\n{rule}");
        let mut line = format!("| {} (here) | {:.3} |", self.mesh, tri / MB);
        for s in &self.sizes {
            let _ = write!(line, " {:.3} |", s.bytes as f64 / MB);
        }
        for s in &self.sizes {
            let _ = write!(line, " {:.2} |", s.bytes as f64 / tri);
        }
        let _ = writeln!(out, "{line}");
        let paper = self.paper_row();
        if let Some((name, sizes, _)) = paper {
            // The paper has no Skip Strips column.
            let cell = |m: &str| match m {
                "PM" => Some(sizes[1]),
                "MTS" => Some(sizes[2]),
                "LodStrips" => Some(sizes[3]),
                _ => None,
            };
            let mut line = format!("| {name} (paper) | {:.3} |", sizes[0]);
            for m in &models {
                let _ = match cell(m) {
                    Some(v) => write!(line, " {v:.3} |"),
                    None => write!(line, " – |"),
                };
            }
            for m in &models {
                let _ = match cell(m) {
                    Some(v) => write!(line, " {:.1} |", v / sizes[0]),
                    None => write!(line, " – |"),
                };
            }
            let _ = writeln!(out, "{line}");
        }
        let _ = writeln!(
            out,
            "\nTable 2. Linear and exponential tests: mean render time per frame (extraction + \
             draw), its extraction (% rec) and draw (% drw) shares; vertices, strips and bytes \
             uploaded per frame.\n"
        );
        let _ = writeln!(
            out,
            "| Test | Model | Render (ms) | % rec | % drw | Extract (ms) | Draw (ms) | Vertices | Strips | Upload (B) | Paper render (ms) | Paper % rec |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
        for (t, test) in [Sweep::Linear, Sweep::Exponential].into_iter().enumerate() {
            for m in &models {
                let [render, extract, draw, vertices, strips, upload] = self.means(test, m);
                let share = 100.0 * extract / render.max(1e-12);
                let column = match *m {
                    "PM" => Some(0),
                    "MTS" => Some(1),
                    "LodStrips" => Some(2),
                    _ => None,
                };
                let (paper_ms, paper_rec) = match (paper, column) {
                    (Some((_, _, table)), Some(c)) => {
                        let [ms, rec] = table[3 * t + c];
                        (format!("{ms:.3}"), format!("{rec:.2}"))
                    }
                    _ => ("–".into(), "–".into()),
                };
                let _ = writeln!(
                    out,
                    "| {} | {m} | {render:.3} | {share:.2} | {:.2} | {extract:.4} | {draw:.3} | {vertices:.0} | {strips:.0} | {upload:.0} | {paper_ms} | {paper_rec} |",
                    test.name(),
                    100.0 - share
                );
            }
        }
        let _ = writeln!(
            out,
            "\nTable 3. Skip Strips, view-dependent: the eye flies in from 3 to 0.25 diagonals, \
             one adapt pass a frame (extraction only, nothing drawn); every {}th frame.\n",
            self.view_rows.len().div_ceil(8).max(1)
        );
        let _ = writeln!(
            out,
            "| Frame | Distance (diag.) | Extract (ms) | Merges | Splits | Refused | Display vertices | Vertices sent | Strips |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
        let stride = self.view_rows.len().div_ceil(8).max(1);
        for r in self
            .view_rows
            .iter()
            .filter(|r| r.frame % stride == 0 || r.frame + 1 == self.view_rows.len())
        {
            let _ = writeln!(
                out,
                "| {} | {:.2} | {:.4} | {} | {} | {} | {} | {} | {} |",
                r.frame,
                r.distance,
                r.extract_us / 1e3,
                r.merges,
                r.splits,
                r.refused,
                r.displayed,
                r.vertices,
                r.strips
            );
        }
        let n = self.view_rows.len().max(1) as f64;
        let mean = self.view_rows.iter().map(|r| r.extract_us).sum::<f64>() / n / 1e3;
        let worst = self
            .view_rows
            .iter()
            .map(|r| r.extract_us)
            .fold(0.0, f64::max)
            / 1e3;
        let _ = writeln!(
            out,
            "\nView-dependent extraction: mean {mean:.4} ms, worst {worst:.4} ms per frame."
        );
        out
    }

    /// The paper's figures for this mesh: by name (cow, bunny), and the phone row for any
    /// other mesh (the largest of the paper's three; say which mesh stood in for it).
    fn paper_row(&self) -> Option<PaperRow> {
        let lower = self.mesh.to_lowercase();
        PAPER
            .iter()
            .find(|(name, _, _)| lower.contains(name))
            .or_else(|| PAPER.iter().find(|(name, _, _)| *name == "phone"))
            .copied()
    }

    /// Everything as JSON: the sizes, the means and every frame.
    pub fn to_json(&self) -> String {
        let sizes: Vec<serde_json::Value> = self
            .sizes
            .iter()
            .map(|s| {
                serde_json::json!({
                    "model": s.model,
                    "bytes": s.bytes,
                    "ratio": s.bytes as f64 / self.triangle_mesh_bytes() as f64,
                    "state_bytes": s.state_bytes,
                    "build_ms": s.build_ms,
                })
            })
            .collect();
        let rows: Vec<serde_json::Value> = self
            .rows
            .iter()
            .map(|r| {
                serde_json::json!({
                    "test": r.test.name(),
                    "model": r.model,
                    "frame": r.frame,
                    "lod": r.lod,
                    "extract_us": r.extract_us,
                    "draw_ms": r.draw_ms,
                    "vertices": r.vertices,
                    "strips": r.strips,
                    "upload_bytes": r.upload_bytes,
                })
            })
            .collect();
        let mut means = Vec::new();
        for test in [Sweep::Linear, Sweep::Exponential] {
            for m in self.models() {
                let [render, extract, draw, vertices, strips, upload] = self.means(test, m);
                means.push(serde_json::json!({
                    "test": test.name(), "model": m, "render_ms": render, "extract_ms": extract,
                    "draw_ms": draw, "rec_percent": 100.0 * extract / render.max(1e-12),
                    "vertices": vertices, "strips": strips, "upload_bytes": upload,
                }));
            }
        }
        let view_rows: Vec<serde_json::Value> = self
            .view_rows
            .iter()
            .map(|r| {
                serde_json::json!({
                    "frame": r.frame,
                    "distance": r.distance,
                    "extract_us": r.extract_us,
                    "merges": r.merges,
                    "splits": r.splits,
                    "refused": r.refused,
                    "displayed": r.displayed,
                    "vertices": r.vertices,
                    "strips": r.strips,
                })
            })
            .collect();
        serde_json::json!({
            "mesh": self.mesh,
            "adapter": self.adapter,
            "backend": self.backend,
            "device_type": self.device_type,
            "vertices": self.vertices,
            "triangles": self.triangles,
            "max_lod": self.max_lod,
            "triangle_mesh_bytes": self.triangle_mesh_bytes(),
            "sizes": sizes,
            "means": means,
            "rows": rows,
            "view_dependent": view_rows,
        })
        .to_string()
    }
}
