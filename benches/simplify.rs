//! Our full simplification (the whole collapse sequence, down to the minimum)
//! against `meshopt::simplify` to 1% of the triangles, on man.off, same run.
//!
//! `cargo bench --bench simplify`

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use morphlod::simplify::{simplify, SimplifyOptions};

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/man.off");
    let mesh = match morphlod::io::off::load(&path) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    };
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&mesh.positions), 12, 0)
        .expect("tightly packed positions");
    let target = indices.len() / 100;

    let mut group = c.benchmark_group("simplify man.off");
    group.sample_size(20);
    group.bench_function("morphlod full sequence", |b| {
        b.iter(|| {
            simplify(
                black_box(&mesh.positions),
                black_box(&mesh.triangles),
                &SimplifyOptions::default(),
            )
        })
    });
    group.bench_function("meshopt to 1%", |b| {
        b.iter(|| {
            meshopt::simplify(
                black_box(&indices),
                &adapter,
                target,
                1.0,
                meshopt::SimplifyOptions::None,
                None,
            )
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
