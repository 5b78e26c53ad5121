use selfmanip_core::{ContactMode, FlatGround, RobotDescription};
use selfmanip_hybrid::{simulate, HybridOptions, ZeroTorque};

#[test]
fn scratch() {
    for fr in [
        "{ kind = \"sticking\", mu = 0.8 }",
        "{ kind = \"sliding\" }",
    ] {
        for shape in [
            "{ kind = \"box\", size_m = [0.4, 0.1] }",
            "{ kind = \"stadium\", length_m = 0.4, radius_m = 0.05 }",
            "{ kind = \"circle\", radius_m = 0.05 }",
        ] {
            let text = format!("name = \"b\"\n[body]\nmass_kg = 2.0\ninertia_kg_m2 = 0.03\ncollision = [{{ shape = {shape}, friction = {fr} }}]\n");
            let model = RobotDescription::from_toml_str(&text)
                .unwrap()
                .build()
                .unwrap();
            for c in &model.contacts {
                println!("{} {:?}", c.name, c.shape);
            }
            let q0 = [0.0, -0.2, 0.0];
            let qd0 = [0.3, 0.0, 0.0];
            let e = simulate(
                &model,
                &FlatGround,
                &ZeroTorque,
                ContactMode::FLIGHT,
                &q0,
                &qd0,
                1.0,
                HybridOptions::default(),
            )
            .unwrap();
            println!("{shape} {fr}: {} q={:?}", e.termination, e.q);
            for ev in &e.events {
                println!(
                    "  {:.6} {:?} {:b}->{:b} {:?}",
                    ev.t,
                    ev.kind,
                    ev.mode_before.normal_bits(),
                    ev.mode_after.normal_bits(),
                    ev.triggered
                );
            }
            let q0 = [0.0, -0.2, 0.3];
            let e = simulate(
                &model,
                &FlatGround,
                &ZeroTorque,
                ContactMode::FLIGHT,
                &q0,
                &qd0,
                1.0,
                HybridOptions::default(),
            )
            .unwrap();
            println!("tilted: {} q={:?}", e.termination, e.q);
            for ev in &e.events {
                println!(
                    "  {:.6} {:?} {:b}->{:b} {:?}",
                    ev.t,
                    ev.kind,
                    ev.mode_before.normal_bits(),
                    ev.mode_after.normal_bits(),
                    ev.triggered
                );
            }
        }
    }
}
