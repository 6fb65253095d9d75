use colony_sim::{SceneConfig, SimError, World};

fn config_error(text: &str) -> colony_sim::ConfigError {
    match SceneConfig::from_toml_str(text) {
        Err(SimError::Config(e)) => e,
        other => panic!("expected a configuration error, got {other:?}"),
    }
}

#[test]
fn an_empty_file_is_the_standard_configuration() {
    let cfg = SceneConfig::from_toml_str("").unwrap();
    assert_eq!(cfg, SceneConfig::default());
    assert_eq!(cfg.robots.count, 4);
    assert_eq!(cfg.pucks.count, 40);
    assert_eq!(cfg.pucks.kinds, 2);
    assert_eq!(cfg.arena.width, 187.0);
    assert_eq!(cfg.arena.corner_radius, 15.0);
    assert!((cfg.control_step_seconds() - 3.0 / 14.0).abs() < 1e-12);
    // 180 degrees in 10 control steps.
    assert!(
        (cfg.robots.full_turn_rate * 10.0 * cfg.control_step_seconds() - std::f64::consts::PI)
            .abs()
            < 1e-9
    );
}

#[test]
fn the_shipped_scene_file_is_the_standard_configuration_written_out() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/scene.toml");
    let cfg = SceneConfig::from_file(path).unwrap();
    assert_eq!(cfg, SceneConfig::default());
}

#[test]
fn a_config_round_trips_through_toml() {
    let mut cfg = SceneConfig::scaled(16);
    cfg.robots.command_duration = Some(0.075);
    let back = SceneConfig::from_toml_str(&cfg.to_toml_string()).unwrap();
    assert_eq!(back, cfg);
}

#[test]
fn zero_robots_is_refused_naming_the_line_and_field() {
    let e = config_error("# a scene\n[robots]\ncount = 0\n");
    assert_eq!(e.line, Some(3));
    assert_eq!(e.field.as_deref(), Some("robots.count"));
    let text = e.to_string();
    assert!(
        text.starts_with("<string>:3: field `robots.count`:"),
        "{text}"
    );
    assert!(text.contains("at least 1"), "{text}");
}

#[test]
fn zero_pucks_is_refused() {
    let e = config_error("[pucks]\ncount = 0\n");
    assert_eq!(e.field.as_deref(), Some("pucks.count"));
    assert_eq!(e.line, Some(2));
}

#[test]
fn more_types_than_pucks_is_refused() {
    let e = config_error("[pucks]\ncount = 3\nkinds = 4\n");
    assert_eq!(e.field.as_deref(), Some("pucks.kinds"));
    assert_eq!(e.line, Some(3));
    assert!(
        e.message.contains("4 puck types") && e.message.contains("3 pucks"),
        "{}",
        e.message
    );
}

#[test]
fn more_than_255_types_is_refused() {
    let e = config_error("[pucks]\ncount = 1000\nkinds = 256\n");
    assert_eq!(e.field.as_deref(), Some("pucks.kinds"));
    assert!(e.message.contains("255"), "{}", e.message);
}

#[test]
fn non_positive_sizes_are_refused() {
    for (text, field) in [
        ("[arena]\nwidth = 0.0\n", "arena.width"),
        ("[arena]\nheight = -5.0\n", "arena.height"),
        ("[pucks]\ndiameter = 0.0\n", "pucks.diameter"),
        ("[robots]\nlength = -1.0\n", "robots.length"),
        ("[robots]\nwidth = 0.0\n", "robots.width"),
        ("[robots]\ngripper_radius = 0.0\n", "robots.gripper_radius"),
        ("[physics]\ndt = 0.0\n", "physics.dt"),
        ("[physics]\nsubsteps = 0\n", "physics.substeps"),
        ("[camera]\nfar = 1.0\n", "camera.far"),
        ("[robots]\nfull_speed = nan\n", "robots.full_speed"),
    ] {
        let e = config_error(text);
        assert_eq!(e.field.as_deref(), Some(field), "{text}: {e}");
        assert_eq!(e.line, Some(2), "{text}: {e}");
    }
}

#[test]
fn a_gripper_too_small_for_a_puck_is_refused() {
    let e = config_error("[pucks]\ndiameter = 8.0\n");
    assert_eq!(e.field.as_deref(), Some("robots.gripper_radius"));
}

#[test]
fn a_misspelt_field_is_refused_with_its_line() {
    let e = config_error("[robots]\ncount = 4\ncuont = 5\n");
    assert_eq!(e.line, Some(3));
    assert_eq!(e.field.as_deref(), Some("robots.cuont"));
    assert!(e.message.contains("unknown field"), "{}", e.message);
}

#[test]
fn a_wrong_type_is_refused_with_its_line_and_field() {
    let e = config_error("[arena]\nwidth = 187.0\n\n[pucks]\ncount = \"forty\"\n");
    assert_eq!(e.line, Some(5));
    assert_eq!(e.field.as_deref(), Some("pucks.count"));
    assert!(e.message.contains("invalid type"), "{}", e.message);
}

#[test]
fn a_syntax_error_gives_its_line() {
    let e = config_error("[robots]\ncount = = 4\n");
    assert_eq!(e.line, Some(2));
}

#[test]
fn errors_from_a_file_name_the_file() {
    let dir = std::env::temp_dir().join(format!("colony-sim-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, "[pucks]\ncount = 10\nkinds = 11\n").unwrap();
    let text = SceneConfig::from_file(&path).unwrap_err().to_string();
    assert!(
        text.starts_with(&format!("{}:3: field `pucks.kinds`", path.display())),
        "{text}"
    );
    let missing = dir.join("missing.toml");
    let text = SceneConfig::from_file(&missing).unwrap_err().to_string();
    assert!(text.contains("missing.toml"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn world_new_refuses_a_bad_config_and_an_impossible_layout() {
    let mut cfg = SceneConfig::default();
    cfg.robots.count = 0;
    assert!(matches!(World::new(&cfg, 1), Err(SimError::Config(_))));
    let mut crowded = SceneConfig::default();
    crowded.pucks.count = 2000;
    let e = World::new(&crowded, 1).unwrap_err();
    assert!(matches!(e, SimError::Layout(_)), "{e}");
    assert!(e.to_string().contains("too crowded"), "{e}");
}

#[test]
fn layouts_outside_the_arena_are_refused() {
    use colony_sim::{Pose, PuckKind, Vec2};
    let cfg = SceneConfig::default();
    let far = Pose {
        x: 200.0,
        y: 0.0,
        theta: 0.0,
    };
    assert!(matches!(
        World::with_layout(&cfg, &[far], &[]),
        Err(SimError::Layout(_))
    ));
    let bad_kind = [(PuckKind(5), Vec2::ZERO)];
    assert!(matches!(
        World::with_layout(&cfg, &[], &bad_kind),
        Err(SimError::Layout(_))
    ));
    let nan = [(PuckKind(0), Vec2::new(f64::NAN, 0.0))];
    assert!(matches!(
        World::with_layout(&cfg, &[], &nan),
        Err(SimError::Layout(_))
    ));
}

#[test]
fn non_finite_numbers_are_refused_in_every_float_field() {
    // TOML writes them `nan`, `inf` and `-inf`; each must be refused naming its field.
    let fields = [
        ("arena", "width"),
        ("arena", "height"),
        ("arena", "corner_radius"),
        ("robots", "length"),
        ("robots", "width"),
        ("robots", "mass"),
        ("robots", "full_speed"),
        ("robots", "full_turn_rate"),
        ("robots", "command_duration"),
        ("robots", "gripper_radius"),
        ("robots", "gripper_mouth_deg"),
        ("robots", "friction"),
        ("pucks", "diameter"),
        ("pucks", "mass"),
        ("pucks", "linear_damping"),
        ("pucks", "angular_damping"),
        ("pucks", "friction"),
        ("camera", "offset"),
        ("camera", "near"),
        ("camera", "far"),
        ("camera", "half_width"),
        ("camera", "max_range"),
        ("camera", "half_angle_deg"),
        ("camera", "obstacle_spacing"),
        ("physics", "dt"),
        ("carrying", "start_fraction"),
        ("carrying", "keep_fraction"),
    ];
    for (table, key) in fields {
        for value in ["nan", "inf", "-inf", "+inf", "-nan"] {
            let text = format!("[{table}]\n{key} = {value}\n");
            let e = config_error(&text);
            assert_eq!(
                e.field.as_deref(),
                Some(format!("{table}.{key}").as_str()),
                "{text}: {e}"
            );
            assert_eq!(e.line, Some(2), "{text}: {e}");
        }
    }
    // Every float field of the standard configuration is in the list above.
    let written = SceneConfig::default().to_toml_string();
    let floats = written
        .lines()
        .filter(|l| l.contains('.') && l.contains(" = "))
        .count();
    // (command_duration is absent by default, so not written.)
    assert_eq!(floats, fields.len() - 1, "{written}");
}
