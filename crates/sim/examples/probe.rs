use colony_sim::*;
fn trial(cfg: &SceneConfig, turn: f64, fwd: f64, off: f64) -> String {
    let mut w = World::with_layout(
        cfg,
        &[Pose {
            x: -40.0,
            y: 0.0,
            theta: 0.0,
        }],
        &[(PuckKind(0), Vec2::new(0.0, off))],
    )
    .unwrap();
    for _ in 0..12 {
        w.step(&[WheelCommand {
            forward: 1.0,
            turn: 0.0,
        }]);
    }
    if w.robots()[0].carrying.is_none() {
        return "no-capture".into();
    }
    let local = w.robots()[0].pose.to_local(w.pucks()[0].pos);
    for i in 0..30 {
        w.step(&[WheelCommand { forward: fwd, turn }]);
        if w.robots()[0].carrying.is_none() {
            return format!("{i}");
        }
    }
    format!("kept(seated {:.2},{:.2})", local.x, local.y)
}
fn main() {
    for mouth in [126.0, 130.0, 140.0] {
        let mut cfg = SceneConfig::default();
        cfg.robots.gripper_mouth_deg = mouth;
        println!("mouth {mouth}: turn {} turn-half {} fwd+turn {} fwd-half+turn {} back+turn {} back {} | off1.5 {} off2.5 {} off3.5 {}",
            trial(&cfg, 1.0, 0.0, 0.0), trial(&cfg, 0.5, 0.0, 0.0), trial(&cfg, 1.0, 1.0, 0.0), trial(&cfg, 1.0, 0.5, 0.0), trial(&cfg, 1.0, -0.3, 0.0), trial(&cfg, 0.0, -1.0, 0.0),
            trial(&cfg, 1.0, 0.0, 1.5), trial(&cfg, 1.0, 0.0, 2.5), trial(&cfg, 1.0, 0.0, 3.5));
    }
}
