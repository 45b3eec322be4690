//! Criterion benches of the kernels `g1tess bench` measures, kept quick: the patch-table
//! build, the CPU f32 grid kernel (`evaluate_f32`), the f64 CPU reference, and the GPU with and without
//! readback (when a Vulkan adapter is present), for G1 and the flat baseline on spot.obj
//! at level 16. `cargo bench --bench kernels`.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

use g1tess::{
    CpuEvaluator, Evaluator, GpuContext, GpuEvaluator, LoadOptions, Mesh, PatchTable, Pattern,
    Precision, Scheme,
};

const LEVEL: u32 = 16;

fn kernels(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/spot.obj");
    let mesh = Mesh::load(path, &LoadOptions::default()).expect("spot.obj");
    let gpu = match GpuContext::new()
        .map(std::sync::Arc::new)
        .and_then(|ctx| GpuEvaluator::new(ctx, Precision::F32))
    {
        Ok(g) => Some(g),
        Err(e) => {
            eprintln!("no GPU benches: {e}");
            None
        }
    };
    let cpu = CpuEvaluator::default();
    for scheme in [Scheme::G1, Scheme::Flat] {
        let mut g = c.benchmark_group(format!("{scheme}"));
        g.sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
        g.bench_function("build", |b| {
            b.iter(|| PatchTable::build(&mesh, scheme, &Default::default()).unwrap())
        });
        let table = PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
        let pattern = Pattern::Grid { level: LEVEL };
        g.throughput(Throughput::Elements(pattern.len(table.len()) as u64));
        g.bench_function(format!("cpu_f32_level{LEVEL}"), |b| {
            b.iter(|| {
                cpu.evaluate_f32(&table, &pattern, &mut |c| {
                    std::hint::black_box(c.positions.last());
                    Ok(())
                })
                .unwrap()
            })
        });
        g.bench_function(format!("cpu_f64_level{LEVEL}"), |b| {
            b.iter(|| {
                cpu.evaluate(&table, &pattern, &mut |c| {
                    std::hint::black_box(c.positions.last());
                    Ok(())
                })
                .unwrap()
            })
        });
        if let Some(gpu) = &gpu {
            g.bench_function(format!("gpu_dispatch_level{LEVEL}"), |b| {
                b.iter(|| gpu.time_grid(&table, LEVEL).unwrap())
            });
            g.bench_function(format!("gpu_readback_level{LEVEL}"), |b| {
                b.iter(|| {
                    gpu.evaluate(&table, &pattern, &mut |c| {
                        std::hint::black_box(c.positions.last());
                        Ok(())
                    })
                    .unwrap()
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, kernels);
criterion_main!(benches);
