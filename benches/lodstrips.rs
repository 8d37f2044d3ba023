//! Figures for the stripifier and the LodStrips model on the real meshes,
//! printed as a table (run with `cargo bench --bench lodstrips`):
//!
//! * indices per triangle of `S0` against meshopt (vertex-cache strip order,
//!   then `meshopt::stripify` with restart indices, counted), and average strip length;
//! * indices per triangle of the live strips at 0, 25, 50, 75 and 90% of the collapses;
//! * change-list bytes per collapse, model bytes / indexed-mesh bytes;
//! * CPU time per collapse of `set_lod`, amortized over a linear sweep
//!   (0 → max → 0 one step at a time) and an exponential sweep (jumps that
//!   halve, alternating direction), fastest of 9 rounds (the machine is shared).

use std::time::Instant;

use morphlod::collapse::CollapseSequence;
use morphlod::lodstrips::{LodStrips, StripsState};
use morphlod::strip::stripify;
use morphlod::IndexedMesh;

fn load(name: &str) -> Option<IndexedMesh> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name);
    let mesh = if name.ends_with(".obj") {
        morphlod::io::obj::load(&path)
    } else {
        morphlod::io::off::load(&path)
    };
    match mesh {
        Ok(m) => Some(m),
        Err(e) => {
            eprintln!("skipping {name}: {e}");
            None
        }
    }
}

fn sequence(mesh: &IndexedMesh) -> CollapseSequence {
    morphlod::simplify::simplify(
        &mesh.positions,
        &mesh.triangles,
        &morphlod::simplify::SimplifyOptions::default(),
    )
}

fn meshopt_indices_per_triangle(mesh: &IndexedMesh) -> f64 {
    let flat: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let ordered = meshopt::optimize_vertex_cache_strip(&flat, mesh.positions.len());
    let strip = meshopt::stripify(&ordered, mesh.positions.len(), 0xFFFF_FFFF).unwrap_or_default();
    strip.len() as f64 / mesh.triangles.len() as f64
}

fn main() {
    println!(
        "{:<10} {:>7} {:>8} {:>8} {:>8} {:>7} | {:>6} {:>6} {:>6} {:>6} {:>6} | {:>6} {:>6} | {:>8} {:>8}",
        "mesh", "tris", "ipt", "ipt+rs", "meshopt", "avglen", "L0", "L25", "L50", "L75", "L90",
        "B/coll", "size", "lin ns", "exp ns"
    );
    for name in ["cow.off", "bunny.obj", "man.off", "bull.off", "camel.off"] {
        let Some(mesh) = load(name) else { continue };
        let n = mesh.positions.len();
        let tris = mesh.triangles.len();
        let strips = stripify(&mesh.triangles, n);
        let ipt = strips.indices.len() as f64 / tris as f64;
        // Counted as meshopt counts a single index buffer: one restart between strips.
        let ipt_restart =
            (strips.indices.len() + strips.len().saturating_sub(1)) as f64 / tris as f64;
        let avg_len = strips.indices.len() as f64 / strips.len().max(1) as f64;
        let seq = sequence(&mesh);
        let model = match LodStrips::build(&strips, &seq) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        let max = model.max_lod();
        let mut state = StripsState::new(&model);
        let mut lod_ipt = Vec::new();
        for pct in [0usize, 25, 50, 75, 90] {
            state.set_lod(&model, max * pct / 100).expect("same model");
            lod_ipt.push(state.index_count() as f64 / state.triangle_count().max(1) as f64);
        }
        let bytes_per_collapse = model.change_bytes() as f64 / max.max(1) as f64;
        let indexed = tris * 12;
        let size_ratio = model.byte_size() as f64 / indexed as f64;

        // Linear sweep: every step up, then every step down.
        state.set_lod(&model, 0).expect("same model");
        state.take_dirty();
        // The machine is shared: report the fastest of several rounds.
        let rounds = 9;
        let mut linear = f64::MAX;
        for _ in 0..rounds {
            let t = Instant::now();
            for l in 1..=max {
                state.set_lod(&model, l).expect("same model");
            }
            for l in (0..max).rev() {
                state.set_lod(&model, l).expect("same model");
            }
            linear = linear.min(t.elapsed().as_nanos() as f64 / (2 * max.max(1)) as f64);
        }
        state.take_dirty();
        // Exponential sweep: jumps of max, max/2, max/4, ... alternating
        // up and down, then back to 0.
        let mut targets = Vec::new();
        let mut span = max;
        let mut at = 0usize;
        let mut up = true;
        while span > 0 {
            at = if up {
                (at + span).min(max)
            } else {
                at.saturating_sub(span)
            };
            targets.push(at);
            up = !up;
            span /= 2;
        }
        targets.push(0);
        let mut exponential = f64::MAX;
        for _ in 0..rounds {
            let mut moved = 0usize;
            let mut cur = state.lod();
            let t = Instant::now();
            for &g in &targets {
                moved += cur.abs_diff(g);
                state.set_lod(&model, g).expect("same model");
                cur = g;
            }
            exponential = exponential.min(t.elapsed().as_nanos() as f64 / moved.max(1) as f64);
        }
        println!(
            "{:<10} {:>7} {:>8.3} {:>8.3} {:>8.3} {:>7.1} | {:>6.2} {:>6.2} {:>6.2} {:>6.2} {:>6.2} | {:>6.1} {:>6.2} | {:>8.1} {:>8.1}",
            name,
            tris,
            ipt,
            ipt_restart,
            meshopt_indices_per_triangle(&mesh),
            avg_len,
            lod_ipt[0],
            lod_ipt[1],
            lod_ipt[2],
            lod_ipt[3],
            lod_ipt[4],
            bytes_per_collapse,
            size_ratio,
            linear,
            exponential,
        );
    }
}
