//! The arena and the battlefield as Foxglove scene entities (`foxglove.SceneUpdate`, JSON), so
//! a viewer's 3D panel draws the swarm and the game: built from the monitor's own views, with no
//! socket and no clock. Lengths go out in metres (colony's are centimetres), headings as
//! quaternions about z.
//!
//! The arena (frame [`ARENA_FRAME`]): the walls as a line loop with rounded corners, each robot
//! as a box along its heading with an arrow, each puck as a disc in its kind's colour (the
//! monitor page's palette), each cache point from `debug` as a flat square in its kind's colour.
//! The battlefield (frame [`BATTLEFIELD_FRAME`]): its terrain as boxes (walls and trees tall,
//! water and swamp flat), runs of equal cells in a row merged into one box, each robot in its
//! team's colour with its heading, each flag. Every part is one entity with a fixed id, so each
//! update replaces the last.

use colony_proto::swarm::{Arena, Sizes, VisionFrame};
use serde::Serialize;
use serde_json::{json, Value};

use colony_proto::game::{GameMap as Map, GameState};

/// The schema name of a scene update.
pub const SCENE_UPDATE: &str = "foxglove.SceneUpdate";
/// The frame the arena's entities are in.
pub const ARENA_FRAME: &str = "arena";
/// The frame the battlefield's entities are in.
pub const BATTLEFIELD_FRAME: &str = "battlefield";
/// The schema name of a list of frame transforms.
pub const FRAME_TRANSFORMS: &str = "foxglove.FrameTransforms";
/// The frame both views are placed in (each at its origin, unturned).
pub const WORLD_FRAME: &str = "world";
/// Terrain boxes at most (a larger map is drawn in part): a forged map of alternating cells
/// defeats merging runs, and would otherwise make a scene of many megabytes.
pub const MAX_TERRAIN_BOXES: usize = 20_000;

/// The monitor page's puck colours, by kind (kind modulo their number).
const KIND_COLOURS: [[f64; 3]; 8] = [
    [0.878, 0.271, 0.169],
    [0.169, 0.435, 0.878],
    [0.137, 0.643, 0.275],
    [0.878, 0.635, 0.106],
    [0.557, 0.267, 0.839],
    [0.878, 0.439, 0.169],
    [0.122, 0.710, 0.710],
    [0.839, 0.200, 0.518],
];
/// Team colours, by the team's place among the teams.
const TEAM_COLOURS: [[f64; 3]; 4] = [
    [0.85, 0.2, 0.2],
    [0.2, 0.4, 0.9],
    [0.2, 0.7, 0.3],
    [0.9, 0.7, 0.1],
];

const CM: f64 = 0.01;

// The message types, written with serde (a `serde_json::Value` per primitive cost 40 µs per
// robot). Fields colony does not use are written empty, as the schema has them.

#[derive(Serialize, Clone, Copy)]
struct Time {
    sec: u64,
    nsec: u64,
}

#[derive(Serialize, Clone, Copy)]
struct Vec3 {
    x: f64,
    y: f64,
    z: f64,
}

#[derive(Serialize, Clone, Copy)]
struct Quat {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

#[derive(Serialize, Clone, Copy)]
struct Pose {
    position: Vec3,
    orientation: Quat,
}

#[derive(Serialize, Clone, Copy)]
struct Color {
    r: f64,
    g: f64,
    b: f64,
    a: f64,
}

#[derive(Serialize)]
struct Cube {
    pose: Pose,
    size: Vec3,
    color: Color,
}

#[derive(Serialize)]
struct Cylinder {
    pose: Pose,
    size: Vec3,
    bottom_scale: f64,
    top_scale: f64,
    color: Color,
}

#[derive(Serialize)]
struct Arrow {
    pose: Pose,
    shaft_length: f64,
    shaft_diameter: f64,
    head_length: f64,
    head_diameter: f64,
    color: Color,
}

#[derive(Serialize)]
struct Line {
    #[serde(rename = "type")]
    kind: u8,
    pose: Pose,
    thickness: f64,
    scale_invariant: bool,
    points: Vec<Vec3>,
    color: Color,
    colors: [Color; 0],
    indices: [u32; 0],
}

#[derive(Serialize)]
struct Text {
    pose: Pose,
    billboard: bool,
    font_size: f64,
    scale_invariant: bool,
    color: Color,
    text: String,
}

#[derive(Serialize, Default)]
struct Entity {
    timestamp: Option<Time>,
    frame_id: &'static str,
    id: &'static str,
    lifetime: Option<Time>,
    frame_locked: bool,
    metadata: [u8; 0],
    arrows: Vec<Arrow>,
    cubes: Vec<Cube>,
    spheres: Vec<Cube>,
    cylinders: Vec<Cylinder>,
    lines: Vec<Line>,
    triangles: [u8; 0],
    texts: Vec<Text>,
    models: [u8; 0],
}

impl Entity {
    fn new(ns: u64, frame_id: &'static str, id: &'static str) -> Entity {
        Entity {
            timestamp: Some(stamp(ns)),
            frame_id,
            id,
            lifetime: Some(Time { sec: 0, nsec: 0 }),
            ..Default::default()
        }
    }
}

#[derive(Serialize)]
struct SceneUpdate {
    deletions: [u8; 0],
    entities: Vec<Entity>,
}

impl SceneUpdate {
    fn bytes(entities: Vec<Entity>) -> Vec<u8> {
        serde_json::to_vec(&SceneUpdate {
            deletions: [],
            entities,
        })
        .unwrap_or_default()
    }
}

fn stamp(ns: u64) -> Time {
    Time {
        sec: ns / 1_000_000_000,
        nsec: ns % 1_000_000_000,
    }
}

fn colour(rgb: [f64; 3], a: f64) -> Color {
    Color {
        r: rgb[0],
        g: rgb[1],
        b: rgb[2],
        a,
    }
}

/// A length in metres to a tenth of a millimetre (shorter JSON, and more than a viewer shows).
fn m(v: f64) -> f64 {
    if v.is_finite() {
        (v * 1e4).round() / 1e4
    } else {
        0.0
    }
}

/// A pose at (x, y, z) metres, turned `theta` about z.
fn pose(x: f64, y: f64, z: f64, theta: f64) -> Pose {
    let theta = if theta.is_finite() { theta } else { 0.0 };
    let r = |v: f64| (v * 1e6).round() / 1e6;
    Pose {
        position: v3(x, y, z),
        orientation: Quat {
            x: 0.0,
            y: 0.0,
            z: r((theta / 2.0).sin()),
            w: r((theta / 2.0).cos()),
        },
    }
}

fn v3(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3 {
        x: m(x),
        y: m(y),
        z: m(z),
    }
}

/// The arena's walls: a rectangle with rounded corners centred on the origin, as points (m).
fn wall_points(a: &Arena) -> Vec<Vec3> {
    let (hw, hh) = (a.width / 2.0 * CM, a.height / 2.0 * CM);
    let r = (a.corner * CM).clamp(0.0, hw.min(hh).max(0.0));
    let mut pts = Vec::new();
    // Corner centres, counter-clockwise from the top right, each with its arc's start angle.
    let corners = [
        (hw - r, hh - r, 0.0),
        (-hw + r, hh - r, 90.0f64),
        (-hw + r, -hh + r, 180.0),
        (hw - r, -hh + r, 270.0),
    ];
    for (cx, cy, start) in corners {
        for i in 0..=8 {
            let t = (start + 90.0 * f64::from(i) / 8.0).to_radians();
            pts.push(v3(cx + r * t.cos(), cy + r * t.sin(), 0.0));
        }
    }
    pts
}

/// The swarm's arena at the newest frame, with cache points (`(robot, kind, x, y)`, cm), as one
/// `foxglove.SceneUpdate`.
pub fn arena_scene(
    frame: &VisionFrame,
    arena: Option<Arena>,
    sizes: Option<Sizes>,
    caches: impl IntoIterator<Item = (u32, u8, f64, f64)>,
    ns: u64,
) -> Vec<u8> {
    let sizes = sizes.unwrap_or(Sizes {
        robot_length: 12.5,
        robot_width: 10.8,
        gripper_radius: 3.6,
        puck_diameter: 6.3,
    });
    let mut entities = Vec::new();
    if let Some(a) = arena {
        let mut walls = Entity::new(ns, ARENA_FRAME, "walls");
        walls.lines.push(Line {
            kind: 1,
            pose: pose(0.0, 0.0, 0.0, 0.0),
            thickness: 0.01,
            scale_invariant: false,
            points: wall_points(&a),
            color: colour([0.23, 0.25, 0.28], 1.0),
            colors: [],
            indices: [],
        });
        entities.push(walls);
    }
    let (len, wid) = (sizes.robot_length * CM, sizes.robot_width * CM);
    let mut robots = Entity::new(ns, ARENA_FRAME, "robots");
    for r in &frame.robots {
        let (x, y, theta) = (r.pose.x * CM, r.pose.y * CM, r.pose.theta);
        robots.cubes.push(Cube {
            pose: pose(x, y, 0.025, theta),
            size: v3(len, wid, 0.05),
            color: colour([0.11, 0.14, 0.17], 1.0),
        });
        robots.arrows.push(Arrow {
            pose: pose(x, y, 0.06, theta),
            shaft_length: m(len * 0.6),
            shaft_diameter: m(len * 0.1),
            head_length: m(len * 0.3),
            head_diameter: m(len * 0.25),
            color: colour([0.95, 0.72, 0.02], 1.0),
        });
        robots.texts.push(Text {
            pose: pose(x, y, 0.1, 0.0),
            billboard: true,
            font_size: 12.0,
            scale_invariant: true,
            color: colour([0.0, 0.0, 0.0], 1.0),
            text: r.id.to_string(),
        });
    }
    entities.push(robots);
    let d = sizes.puck_diameter * CM;
    let kind_colour = |k: u8| KIND_COLOURS[usize::from(k) % KIND_COLOURS.len()];
    let mut pucks = Entity::new(ns, ARENA_FRAME, "pucks");
    pucks.cylinders = frame
        .pucks
        .iter()
        .map(|p| Cylinder {
            pose: pose(p.pos.x * CM, p.pos.y * CM, 0.01, 0.0),
            size: v3(d, d, 0.02),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: colour(kind_colour(p.kind.0), 1.0),
        })
        .collect();
    entities.push(pucks);
    let mut cache = Entity::new(ns, ARENA_FRAME, "caches");
    cache.cubes = caches
        .into_iter()
        .map(|(_, kind, x, y)| Cube {
            pose: pose(x * CM, y * CM, 0.001, 0.0),
            size: v3(d * 1.5, d * 1.5, 0.002),
            color: colour(kind_colour(kind), 0.45),
        })
        .collect();
    entities.push(cache);
    SceneUpdate::bytes(entities)
}

/// How tall a battlefield cell's box is, and its colour; `None`: open ground, not drawn.
fn terrain(c: char) -> Option<(f64, [f64; 3])> {
    match c {
        '@' | 'O' => Some((0.3, [0.23, 0.25, 0.27])),
        'T' => Some((0.2, [0.13, 0.45, 0.2])),
        'W' => Some((0.005, [0.29, 0.53, 0.78])),
        'S' => Some((0.005, [0.42, 0.48, 0.3])),
        _ => None,
    }
}

/// The battlefield's terrain, as one `foxglove.SceneUpdate` (sent when the map changes).
pub fn terrain_scene(map: &Map, ns: u64) -> Vec<u8> {
    let cell = map.cell * CM;
    let mut terrain_entity = Entity::new(ns, BATTLEFIELD_FRAME, "terrain");
    'rows: for (row, text) in map.rows.iter().enumerate() {
        // The top row first: its y is the highest.
        let y = (f64::from(map.height) - 1.0 - row as f64 + 0.5) * cell;
        let chars: Vec<char> = text.chars().collect();
        let mut x = 0;
        while x < chars.len() {
            let c = chars[x];
            let run = chars[x..].iter().take_while(|&&d| d == c).count();
            if let Some((h, rgb)) = terrain(c) {
                if terrain_entity.cubes.len() >= MAX_TERRAIN_BOXES {
                    break 'rows;
                }
                let cx = (x as f64 + run as f64 / 2.0) * cell;
                terrain_entity.cubes.push(Cube {
                    pose: pose(cx, y, h / 2.0, 0.0),
                    size: v3(run as f64 * cell, cell, h),
                    color: colour(rgb, 1.0),
                });
            }
            x += run;
        }
    }
    SceneUpdate::bytes(vec![terrain_entity])
}

/// The game's robots and flags, as one `foxglove.SceneUpdate`.
pub fn battlefield_scene(state: &GameState, ns: u64) -> Vec<u8> {
    let team_colour = |team: &str| {
        let i = state.teams.iter().position(|t| t.name == team).unwrap_or(0);
        TEAM_COLOURS[i % TEAM_COLOURS.len()]
    };
    let mut robots = Entity::new(ns, BATTLEFIELD_FRAME, "robots");
    for r in state.robots.iter().filter(|r| r.alive) {
        let (x, y) = (r.pose.x * CM, r.pose.y * CM);
        robots.cylinders.push(Cylinder {
            pose: pose(x, y, 0.05, r.pose.theta),
            size: v3(0.3, 0.3, 0.1),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: colour(team_colour(&r.team), 1.0),
        });
        robots.arrows.push(Arrow {
            pose: pose(x, y, 0.12, r.pose.theta),
            shaft_length: 0.2,
            shaft_diameter: 0.04,
            head_length: 0.1,
            head_diameter: 0.1,
            color: colour([0.95, 0.95, 0.95], 1.0),
        });
    }
    let mut flags = Entity::new(ns, BATTLEFIELD_FRAME, "flags");
    flags.spheres = state
        .flags
        .iter()
        .map(|f| Cube {
            pose: pose(f.at.x * CM, f.at.y * CM, 0.3, 0.0),
            size: v3(0.2, 0.2, 0.2),
            color: colour(team_colour(&f.team), 1.0),
        })
        .collect();
    SceneUpdate::bytes(vec![robots, flags])
}

/// The arena's and the battlefield's frames, each placed at the origin of [`WORLD_FRAME`], at
/// time `ns`, as one `foxglove.FrameTransforms`: the 3D panel then has a tree to choose a
/// display frame from.
pub fn frame_transforms(ns: u64) -> Vec<u8> {
    let transforms: Vec<Value> = [ARENA_FRAME, BATTLEFIELD_FRAME]
        .into_iter()
        .map(|child| {
            let t = stamp(ns);
            json!({
                "timestamp": { "sec": t.sec, "nsec": t.nsec },
                "parent_frame_id": WORLD_FRAME,
                "child_frame_id": child,
                "translation": { "x": 0.0, "y": 0.0, "z": 0.0 },
                "rotation": { "x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0 },
            })
        })
        .collect();
    serde_json::to_vec(&json!({ "transforms": transforms })).unwrap_or_default()
}

/// A JSON Schema for `foxglove.FrameTransforms` as [`frame_transforms`] writes it.
pub fn frame_transforms_schema() -> String {
    let num = json!({ "type": "number" });
    let vec3 = json!({ "type": "object", "properties": { "x": num, "y": num, "z": num } });
    let quat =
        json!({ "type": "object", "properties": { "x": num, "y": num, "z": num, "w": num } });
    let time = json!({ "type": "object", "properties": {
        "sec": { "type": "integer" }, "nsec": { "type": "integer" } } });
    let transform = json!({ "type": "object", "title": "foxglove.FrameTransform", "properties": {
        "timestamp": time, "parent_frame_id": { "type": "string" },
        "child_frame_id": { "type": "string" }, "translation": vec3, "rotation": quat } });
    json!({
        "title": FRAME_TRANSFORMS,
        "type": "object",
        "properties": { "transforms": { "type": "array", "items": transform } },
    })
    .to_string()
}

/// A JSON Schema for `foxglove.SceneUpdate` as colony writes it (the fields above; the viewer
/// knows the type by its name).
pub fn scene_update_schema() -> String {
    let num = json!({ "type": "number" });
    let vec3 = json!({ "type": "object", "properties": { "x": num, "y": num, "z": num } });
    let quat =
        json!({ "type": "object", "properties": { "x": num, "y": num, "z": num, "w": num } });
    let pose = json!({ "type": "object", "properties": { "position": vec3, "orientation": quat } });
    let color =
        json!({ "type": "object", "properties": { "r": num, "g": num, "b": num, "a": num } });
    let time = json!({ "type": "object", "properties": {
        "sec": { "type": "integer" }, "nsec": { "type": "integer" } } });
    let sized =
        json!({ "type": "object", "properties": { "pose": pose, "size": vec3, "color": color } });
    let cylinder = json!({ "type": "object", "properties": {
        "pose": pose, "size": vec3, "bottom_scale": num, "top_scale": num, "color": color } });
    let arrow = json!({ "type": "object", "properties": {
        "pose": pose, "shaft_length": num, "shaft_diameter": num, "head_length": num,
        "head_diameter": num, "color": color } });
    let line = json!({ "type": "object", "properties": {
        "type": { "type": "integer" }, "pose": pose, "thickness": num,
        "scale_invariant": { "type": "boolean" },
        "points": { "type": "array", "items": vec3 },
        "color": color, "colors": { "type": "array", "items": color },
        "indices": { "type": "array", "items": { "type": "integer" } } } });
    let text = json!({ "type": "object", "properties": {
        "pose": pose, "billboard": { "type": "boolean" }, "font_size": num,
        "scale_invariant": { "type": "boolean" }, "color": color, "text": { "type": "string" } } });
    let list = |items: &Value| json!({ "type": "array", "items": items });
    let entity = json!({ "type": "object", "title": "foxglove.SceneEntity", "properties": {
        "timestamp": time, "frame_id": { "type": "string" }, "id": { "type": "string" },
        "lifetime": time, "frame_locked": { "type": "boolean" },
        "metadata": list(&json!({ "type": "object", "properties": {
            "key": { "type": "string" }, "value": { "type": "string" } } })),
        "arrows": list(&arrow), "cubes": list(&sized), "spheres": list(&sized),
        "cylinders": list(&cylinder), "lines": list(&line), "texts": list(&text),
        "triangles": list(&json!({ "type": "object" })), "models": list(&json!({ "type": "object" })),
    } });
    let deletion = json!({ "type": "object", "properties": {
        "timestamp": time, "type": { "type": "integer" }, "id": { "type": "string" } } });
    json!({
        "title": SCENE_UPDATE,
        "description": "colony's arena or battlefield as Foxglove scene entities",
        "type": "object",
        "properties": { "deletions": list(&deletion), "entities": list(&entity) },
    })
    .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_proto::swarm::{PuckKind, VisionPuck, VisionRobot};
    use colony_proto::{Pose, Vec2};

    fn frame() -> VisionFrame {
        VisionFrame {
            step: 7,
            robots: vec![VisionRobot {
                id: 3,
                pose: Pose {
                    x: 100.0,
                    y: -50.0,
                    theta: std::f64::consts::FRAC_PI_2,
                },
                carrying: None,
            }],
            pucks: vec![
                VisionPuck {
                    id: 0,
                    kind: PuckKind(0),
                    pos: Vec2 { x: 10.0, y: 0.0 },
                },
                VisionPuck {
                    id: 1,
                    kind: PuckKind(1),
                    pos: Vec2 { x: 20.0, y: 0.0 },
                },
            ],
            ..Default::default()
        }
    }

    fn entity<'a>(scene: &'a Value, id: &str) -> &'a Value {
        scene["entities"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["id"] == id)
            .unwrap_or_else(|| panic!("no entity {id}: {scene}"))
    }

    #[test]
    fn the_arena_has_walls_robots_with_heading_pucks_by_colour_and_caches() {
        let arena = Arena {
            width: 200.0,
            height: 100.0,
            corner: 10.0,
        };
        let bytes = arena_scene(
            &frame(),
            Some(arena),
            None,
            [(3, 1, 30.0, 40.0)],
            1_500_000_000,
        );
        let scene: Value = serde_json::from_slice(&bytes).unwrap();
        let walls = entity(&scene, "walls");
        assert_eq!(walls["frame_id"], ARENA_FRAME);
        let pts = walls["lines"][0]["points"].as_array().unwrap();
        let max_x = pts
            .iter()
            .map(|p| p["x"].as_f64().unwrap())
            .fold(f64::MIN, f64::max);
        assert!((max_x - 1.0).abs() < 1e-9, "walls in metres: {max_x}");
        let robots = entity(&scene, "robots");
        assert_eq!(robots["timestamp"]["sec"], 1);
        assert_eq!(robots["timestamp"]["nsec"], 500_000_000);
        let p = &robots["cubes"][0]["pose"];
        assert!((p["position"]["x"].as_f64().unwrap() - 1.0).abs() < 1e-9);
        // A quarter turn about z.
        let (z, w) = (
            p["orientation"]["z"].as_f64().unwrap(),
            p["orientation"]["w"].as_f64().unwrap(),
        );
        assert!((z - w).abs() < 1e-9 && z > 0.7, "{p}");
        assert_eq!(robots["texts"][0]["text"], "3");
        let pucks = entity(&scene, "pucks")["cylinders"].as_array().unwrap();
        assert_eq!(pucks.len(), 2);
        assert_ne!(pucks[0]["color"], pucks[1]["color"]);
        let caches = entity(&scene, "caches")["cubes"].as_array().unwrap();
        assert_eq!(caches[0]["color"]["r"], pucks[1]["color"]["r"]);
    }

    #[test]
    fn a_forged_map_of_alternating_cells_is_drawn_in_part() {
        let row: String = "TW".repeat(128);
        let map = Map {
            width: 256,
            height: 256,
            cell: 10.0,
            rows: vec![row; 256],
            sites: Vec::new(),
        };
        let scene: Value = serde_json::from_slice(&terrain_scene(&map, 0)).unwrap();
        let cubes = entity(&scene, "terrain")["cubes"].as_array().unwrap();
        assert_eq!(cubes.len(), MAX_TERRAIN_BOXES);
    }

    #[test]
    fn terrain_runs_become_one_box_each() {
        let map = Map {
            width: 4,
            height: 2,
            cell: 100.0,
            rows: vec!["@@..".into(), "WW.@".into()],
            sites: Vec::new(),
        };
        let scene: Value = serde_json::from_slice(&terrain_scene(&map, 0)).unwrap();
        let cubes = entity(&scene, "terrain")["cubes"].as_array().unwrap();
        assert_eq!(cubes.len(), 3);
        // The top row's wall run: two cells wide, centred at x 1 m, y 1.5 m.
        assert_eq!(cubes[0]["size"]["x"], 2.0);
        assert_eq!(cubes[0]["pose"]["position"]["x"], 1.0);
        assert_eq!(cubes[0]["pose"]["position"]["y"], 1.5);
    }

    #[test]
    fn both_views_are_placed_in_the_world_frame() {
        let t: Value = serde_json::from_slice(&frame_transforms(7)).unwrap();
        let list = t["transforms"].as_array().unwrap();
        assert_eq!(list.len(), 2);
        assert!(list.iter().all(|t| t["parent_frame_id"] == WORLD_FRAME));
        assert_eq!(list[0]["child_frame_id"], ARENA_FRAME);
        assert_eq!(list[0]["rotation"]["w"], 1.0);
        let s: Value = serde_json::from_str(&frame_transforms_schema()).unwrap();
        assert_eq!(s["title"], FRAME_TRANSFORMS);
    }

    #[test]
    fn the_schema_is_json_and_names_the_type() {
        let s: Value = serde_json::from_str(&scene_update_schema()).unwrap();
        assert_eq!(s["title"], SCENE_UPDATE);
        assert!(s["properties"]["entities"]["items"]["properties"]["cubes"].is_object());
    }
}
