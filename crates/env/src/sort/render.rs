//! A picture of the arena for `render_mode="rgb_array"`, drawn on
//! colony-sim's [`Canvas`]: the floor with its rounded corners, robots as
//! dark bodies with a nose line showing the heading (in the carried puck's
//! colour while they carry one), pucks in the colours by kind that colony's
//! monitor draws them in ([`KIND_COLOURS`]), so a frame and the live view of the
//! same run agree. A pure function of the state.

use colony_sim::canvas::{Canvas, View};
use colony_sim::{Vec2, World};

use super::EnvError;

/// The largest picture side accepted, pixels.
pub const MAX_RENDER_SIDE: usize = 8192;

const OUTSIDE: [u8; 3] = [64, 64, 64];
const FLOOR: [u8; 3] = [236, 236, 226];
const ROBOT: [u8; 3] = [40, 48, 72];
const NOSE: [u8; 3] = [255, 255, 255];

/// The pucks' colours by kind, those of the monitor's `KIND_COLOURS`
/// (`crates/monitor/web/app.js`; a test holds them equal).
const KIND_COLOURS: [[u8; 3]; 8] = [
    [0xe0, 0x45, 0x2b],
    [0x2b, 0x6f, 0xe0],
    [0x23, 0xa4, 0x46],
    [0xe0, 0xa2, 0x1b],
    [0x8e, 0x44, 0xd6],
    [0xe0, 0x70, 0x2b],
    [0x1f, 0xb5, 0xb5],
    [0xd6, 0x33, 0x84],
];

fn kind_colour(kind: u8) -> [u8; 3] {
    KIND_COLOURS[usize::from(kind) % KIND_COLOURS.len()]
}

/// `world` as RGB8, `width` × `height`, row-major, top row first (y up in the picture).
pub(crate) fn render(world: &World, width: usize, height: usize) -> Result<Vec<u8>, EnvError> {
    if width > MAX_RENDER_SIDE || height > MAX_RENDER_SIDE {
        return Err(EnvError::Config(format!(
            "a picture of {width} x {height} pixels: each side must be at most {MAX_RENDER_SIDE}"
        )));
    }
    let scene = world.config();
    let (hw, hh) = (scene.arena.width / 2.0, scene.arena.height / 2.0);
    let view = View::fit(Vec2::new(-hw, -hh), Vec2::new(hw, hh), width, height);
    let mut canvas = Canvas::new(width, height, OUTSIDE);
    let px = |p: Vec2| view.to_pixel(p);

    // The floor: two rectangles crossing, and a disc in each corner.
    let r = scene.arena.corner_radius.min(hw).min(hh);
    let (a0, a1) = (px(Vec2::new(-hw + r, -hh)), px(Vec2::new(hw - r, hh)));
    canvas.fill_rect(a0.0, a0.1, a1.0, a1.1, FLOOR);
    let (b0, b1) = (px(Vec2::new(-hw, -hh + r)), px(Vec2::new(hw, hh - r)));
    canvas.fill_rect(b0.0, b0.1, b1.0, b1.1, FLOOR);
    for (sx, sy) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
        let c = px(Vec2::new(sx * (hw - r), sy * (hh - r)));
        canvas.fill_disc(c.0, c.1, view.length(r), FLOOR);
    }

    let pucks = world.pucks();
    let length = scene.robots.length;
    let body_width = view.length(scene.robots.width);
    let gripper = world.robot_shape().gripper_centre.x + scene.robots.gripper_radius;
    for rb in world.robots() {
        let (sin, cos) = rb.pose.theta.sin_cos();
        let at = |forward: f64| {
            px(Vec2::new(
                rb.pose.x + cos * forward,
                rb.pose.y + sin * forward,
            ))
        };
        // A capsule as long as the body with its rounded ends inside it.
        let inset = (length - scene.robots.width).max(0.0) / 2.0;
        let (back, front) = (at(-inset), at(inset));
        canvas.line(back.0, back.1, front.0, front.1, body_width, ROBOT);
        let nose = rb
            .carrying
            .and_then(|c| pucks.get(c.0))
            .map_or(NOSE, |p| kind_colour(p.kind.0));
        let (centre, tip) = (at(0.0), at(gripper));
        canvas.line(
            centre.0,
            centre.1,
            tip.0,
            tip.1,
            (body_width / 4.0).max(1.0),
            nose,
        );
    }
    let puck_radius = view.length(scene.puck_radius()).max(1.0);
    for p in &pucks {
        let c = px(p.pos);
        canvas.fill_disc(c.0, c.1, puck_radius, kind_colour(p.kind.0));
    }
    Ok(canvas.into_rgb())
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_sim::SceneConfig;

    #[test]
    fn env_render_draws_the_floor_pucks_and_robots_and_is_deterministic() {
        let world = World::new(&SceneConfig::default(), 5).unwrap();
        let picture = render(&world, 120, 90).unwrap();
        assert_eq!(picture.len(), 120 * 90 * 3);
        assert_eq!(picture, render(&world, 120, 90).unwrap());
        let count = |colour: [u8; 3]| picture.chunks(3).filter(|p| *p == colour).count();
        // The arena is square: the picture's sides are outside it.
        assert_eq!(&picture[..3], &OUTSIDE);
        assert!(count(FLOOR) > 120 * 90 / 2);
        assert!(count(ROBOT) > 0);
        assert!(count(kind_colour(0)) > 0 && count(kind_colour(1)) > 0);
    }

    #[test]
    fn env_render_colours_pucks_as_the_monitor_does() {
        let app = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../monitor/web/app.js"
        ))
        .unwrap();
        let line = app
            .lines()
            .find(|l| l.starts_with("const KIND_COLOURS"))
            .expect("the monitor's KIND_COLOURS");
        let monitor: Vec<[u8; 3]> = line
            .split('\'')
            .skip(1)
            .step_by(2)
            .map(|hex| {
                let v = u32::from_str_radix(hex.trim_start_matches('#'), 16).unwrap();
                [(v >> 16) as u8, (v >> 8) as u8, v as u8]
            })
            .collect();
        assert_eq!(monitor, KIND_COLOURS);
    }

    #[test]
    fn env_render_of_no_pixels_or_too_many_is_no_panic() {
        let world = World::new(&SceneConfig::default(), 5).unwrap();
        assert!(render(&world, 0, 10).unwrap().is_empty());
        assert!(render(&world, MAX_RENDER_SIDE + 1, 1).is_err());
    }
}
