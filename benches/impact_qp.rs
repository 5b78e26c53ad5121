//! Complementarity beyond the enumeration limit: one frictionless impact QP (clarabel) on a
//! body landing flat on 16 collinear points (ambiguous: the impulse distribution is not
//! unique) and pivoting on them (unique).
use criterion::{criterion_group, criterion_main, Criterion};
use selfmanip::core::{Data, FlatGround, RobotDescription};
use selfmanip::hybrid::impact_qp::frictionless_impact;
use std::hint::black_box;

/// A 3 kg, 0.05 kg m² body with `n` sliding points on its flat bottom (depth 4 cm, ±0.4 m).
fn flat_bottom(n: usize) -> selfmanip::core::Model {
    let mut s = String::from(
        "name = \"flat bottom\"\ngravity_m_s2 = 9.81\nlegs = []\n\
         [body]\nmass_kg = 3.0\ninertia_kg_m2 = 0.05\n",
    );
    for i in 0..n {
        let x = -0.4 + 0.8 * i as f64 / (n - 1) as f64;
        s += &format!(
            "[[contacts]]\nname = \"p{i}\"\nshape = {{ kind = \"point\", position_m = [{x}, 0.04] }}\n\
             friction = {{ kind = \"sliding\" }}\n"
        );
    }
    RobotDescription::from_toml_str(&s)
        .unwrap()
        .build()
        .unwrap()
}

fn impact_qp(c: &mut Criterion) {
    let model = flat_bottom(16);
    let candidates: Vec<usize> = (0..16).collect();
    let q = [0.0, -0.04, 0.0];
    let mut data = Data::new(&model);
    let mut g = c.benchmark_group("impact_qp_16_contacts");
    for (label, qd) in [
        ("flat_landing_ambiguous", [0.7, 1.2, -2.0]),
        ("pivot_unique", [0.2, 0.5, -20.0]),
    ] {
        g.bench_function(label, |b| {
            b.iter(|| {
                frictionless_impact(
                    &model,
                    &mut data,
                    &FlatGround,
                    &candidates,
                    &q,
                    black_box(&qd),
                    None,
                )
                .unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, impact_qp);
criterion_main!(benches);
