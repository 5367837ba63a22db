//! Simulator throughput: one view × 81 lights of a 64² tile (1/81 of a full UBO2003 measurement).
use btfpt::btf::DirectionSet;
use btfpt::btf::synth::{MaterialKind, SynthSettings, measure};
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("synth_64x64_1view_81lights");
    g.sample_size(10);
    for m in [MaterialKind::Wool, MaterialKind::Foil] {
        let surf = match m.build(64, 64, 4, 1) {
            Ok(s) => s,
            Err(e) => panic!("bench material: {e}"),
        };
        let s = SynthSettings {
            views: DirectionSet::from_angles_deg(vec![(45.0, 60.0)]),
            ..SynthSettings::ubo2003(1)
        };
        g.bench_function(m.name(), |b| b.iter(|| measure(&surf, &s)));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
