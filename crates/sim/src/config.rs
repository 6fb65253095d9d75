//! The scene configuration: arena, robots, pucks, camera, physics.
//!
//! Every field has a default, so an empty TOML file is the cache-consensus
//! paper's standard configuration (Vardy et al. 2014, Sect. 3-4.1), with the
//! gaps the paper leaves filled from the authors' own simulator (PuckSwarm).
//! `configs/scene.toml` lists every value with its source.

use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::types::Vec2;

/// Everything that fixes a world apart from the seed.
///
/// ```
/// let cfg = colony_sim::SceneConfig::from_toml_str("[robots]\ncount = 8\n").unwrap();
/// assert_eq!(cfg.robots.count, 8);
/// assert_eq!(cfg.pucks.count, 40); // the rest is the standard configuration
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct SceneConfig {
    /// The walled arena.
    pub arena: ArenaConfig,
    /// The robots and their grippers.
    pub robots: RobotConfig,
    /// The pucks to be sorted.
    pub pucks: PuckConfig,
    /// The forward camera's ground footprint.
    pub camera: CameraConfig,
    /// Time stepping.
    pub physics: PhysicsConfig,
    /// When a puck in the gripper counts as carried.
    pub carrying: CarryingConfig,
}

/// A rectangular arena with rounded corners, centred on the origin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArenaConfig {
    /// Inner width along x, cm (paper Sect. 3.1: 187).
    pub width: f64,
    /// Inner height along y, cm (paper Sect. 3.1: 187).
    pub height: f64,
    /// Radius of the rounded corners, cm (paper Sect. 3.1: 15; the authors' code uses 15.5).
    pub corner_radius: f64,
}

/// The robots: SRV-1 tracked vehicles with a passive C-shaped gripper.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotConfig {
    /// Number of robots (paper Sect. 4.1: 4).
    pub count: usize,
    /// Body length along the heading, cm, gripper excluded (paper Sect. 2.1: 12.5).
    pub length: f64,
    /// Body width, cm (paper Sect. 2.1: 10.8).
    pub width: f64,
    /// Mass, g. Not in the paper; an estimate for an SRV-1 with its printed body.
    /// Only the ratio to the puck mass matters: it sets how much pushed pucks slow a robot.
    pub mass: f64,
    /// Forward speed at `forward = 1`, cm/s (PuckSwarm: about 20, 4.3 cm per control step).
    pub full_speed: f64,
    /// Turn rate at `turn = 1`, rad/s. Default: 180 degrees in 10 control steps
    /// (PuckSwarm), i.e. pi / (10 * 3/14 s) = 1.466 rad/s.
    pub full_turn_rate: f64,
    /// How long each command acts, s, from the start of the control step; the robot
    /// stands still for the rest of the step. Absent: the whole control step (the
    /// simulator the paper's results come from). The physical robots held each
    /// command 75 ms (paper Sect. 3.1): `command_duration = 0.075`.
    pub command_duration: Option<f64>,
    /// Inner radius of the gripper's C-shaped arc, cm (PuckSwarm: 3.6). The arc's
    /// back touches the body's front; a puck whose centre is inside it is held.
    pub gripper_radius: f64,
    /// Full angle of the gripper's mouth, degrees, centred on the heading
    /// (PuckSwarm: the arc runs from 65 to 295 degrees, a 130-degree mouth about 6.5 cm wide).
    pub gripper_mouth_deg: f64,
    /// Coulomb friction of robot surfaces (JBox2D's default 0.2, as in PuckSwarm).
    pub friction: f64,
}

/// The pucks: wooden discs, 1 cm high.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PuckConfig {
    /// Number of pucks (paper Sect. 4.1: 40).
    pub count: usize,
    /// Number of puck types (colours), at most 255; pucks are divided evenly among
    /// them, puck `i` having type `i % kinds` (paper Sect. 4.1: 2, 20 red and 20 green).
    pub kinds: usize,
    /// Diameter, cm (paper Sect. 3.1: 6.3).
    pub diameter: f64,
    /// Mass, g. Not in the paper; an estimate for a wooden disc 6.3 cm across and 1 cm high.
    pub mass: f64,
    /// Linear damping, 1/s: floor friction that stops a pushed puck (PuckSwarm: 10).
    ///
    /// In Box2D's convention, as in the authors' JBox2D simulator: each physics step
    /// the speed is multiplied by `max(0, 1 - damping * dt)`, 0.286 at the defaults. It
    /// is converted to rapier's convention (`1 / (1 + d * dt)`, d = 35 here) so a puck
    /// loses the same share of its speed per step; a pushed puck coasts about 1 cm.
    pub linear_damping: f64,
    /// Angular damping, 1/s, in the same convention (PuckSwarm: 10).
    pub angular_damping: f64,
    /// Coulomb friction between pucks and anything they touch (JBox2D's default 0.2).
    pub friction: f64,
}

/// The forward camera's ground footprint, in the camera's frame (x forward, y left).
///
/// The paper gives the fisheye lens (187 degrees) but not the ground area; these
/// values come from the authors' simulator (PuckSwarm), where the area seen on the
/// ground is 2.5 to 35.6 cm ahead, +-30.5 cm to the sides, at most 46.8 cm away and
/// within +-79.4 degrees of the heading. A point is seen when it satisfies all four.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// Where the camera sits ahead of the robot's centre, cm. Default 3.75: 2.5 cm
    /// behind the body's front edge as in PuckSwarm, so the footprint starts at the front edge.
    pub offset: f64,
    /// Nearest ground distance seen ahead of the camera, cm (PuckSwarm: 2.5).
    pub near: f64,
    /// Farthest ground distance seen ahead of the camera, cm (PuckSwarm: 35.6).
    pub far: f64,
    /// Half-width of the footprint, cm (PuckSwarm: 30.5).
    pub half_width: f64,
    /// Maximum range from the camera, cm (PuckSwarm: 46.8).
    pub max_range: f64,
    /// Half of the footprint's angular extent, degrees (PuckSwarm: 79.4).
    pub half_angle_deg: f64,
    /// Spacing of the obstacle points reported on walls and robots, cm (PuckSwarm's
    /// occupancy grid cell: 1).
    pub obstacle_spacing: f64,
}

/// Time stepping of the physics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhysicsConfig {
    /// One physics step, s (PuckSwarm: 1/14).
    pub dt: f64,
    /// Physics steps per control step (PuckSwarm: 3, so a control step is 3/14 = 0.214 s).
    pub substeps: u32,
    /// Constraint-solver iterations per physics step (rapier's default: 4).
    pub solver_iterations: u32,
    /// The contact engine that steps the arena's bodies.
    pub engine: Engine,
}

/// A contact engine for the arena (a choice per run: `--engine NAME`, `engine = "NAME"`).
///
/// Both step the same scene, bodies and parameters; they differ in how contacts are
/// found and solved, and so in their last digits and their speed (BENCHMARKS.md,
/// "Choosing the contact engine").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Engine {
    /// rapier2d, the general-purpose engine: the reference.
    Rapier,
    /// colony's own engine for the arena's few shapes (discs, capsules, convex
    /// polygons against a rounded-rectangle wall): a uniform grid, resting pucks
    /// asleep, a soft-step solver. The default: it matches rapier on the gripper and
    /// sorting statistics (`tests/fidelity.rs`, `docs/engine-comparison.md`) at two to
    /// three times the speed.
    #[default]
    Disc,
}

impl Engine {
    /// Every engine, by name.
    pub const ALL: [Engine; 2] = [Engine::Rapier, Engine::Disc];

    /// The engine's name on the command line and in configuration files.
    pub fn name(self) -> &'static str {
        match self {
            Engine::Rapier => "rapier",
            Engine::Disc => "disc",
        }
    }
}

impl std::fmt::Display for Engine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Engine {
    type Err = String;

    fn from_str(s: &str) -> Result<Engine, String> {
        Engine::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Engine::ALL.iter().map(|e| e.name()).collect();
                format!(
                    "no contact engine named {s:?} (there are: {})",
                    names.join(", ")
                )
            })
    }
}

/// Carrying detection with hysteresis (PuckSwarm: the fraction of gripper pixels
/// showing puck colour must exceed 0.4 to start carrying and 0.1 to keep carrying).
///
/// Here the fraction is computed exactly: the area of the puck inside the
/// gripper's disc (radius `robots.gripper_radius`) over the disc's area. A seated
/// puck covers (3.15 / 3.6)^2 = 0.77 of it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CarryingConfig {
    /// Fraction above which a puck starts to count as carried (PuckSwarm: 0.4).
    pub start_fraction: f64,
    /// Fraction above which a carried puck stays carried (PuckSwarm: 0.1).
    pub keep_fraction: f64,
}

impl Default for ArenaConfig {
    fn default() -> Self {
        ArenaConfig {
            width: 187.0,
            height: 187.0,
            corner_radius: 15.0,
        }
    }
}

impl Default for RobotConfig {
    fn default() -> Self {
        RobotConfig {
            count: 4,
            length: 12.5,
            width: 10.8,
            mass: 350.0,
            full_speed: 20.0,
            full_turn_rate: std::f64::consts::PI / (10.0 * 3.0 / 14.0),
            command_duration: None,
            gripper_radius: 3.6,
            gripper_mouth_deg: 130.0,
            friction: 0.2,
        }
    }
}

impl Default for PuckConfig {
    fn default() -> Self {
        PuckConfig {
            count: 40,
            kinds: 2,
            diameter: 6.3,
            mass: 20.0,
            linear_damping: 10.0,
            angular_damping: 10.0,
            friction: 0.2,
        }
    }
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            offset: 3.75,
            near: 2.5,
            far: 35.6,
            half_width: 30.5,
            max_range: 46.8,
            half_angle_deg: 79.4,
            obstacle_spacing: 1.0,
        }
    }
}

impl Default for PhysicsConfig {
    fn default() -> Self {
        PhysicsConfig {
            dt: 1.0 / 14.0,
            substeps: 3,
            solver_iterations: 4,
            engine: Engine::default(),
        }
    }
}

impl Default for CarryingConfig {
    fn default() -> Self {
        CarryingConfig {
            start_fraction: 0.4,
            keep_fraction: 0.1,
        }
    }
}

/// The longest arena side accepted, cm (500 m: room for 100,000 robots at the standard
/// densities, 296 m; the standard arena is 1.87 m).
pub const MAX_ARENA_SIDE: f64 = 50_000.0;

impl SceneConfig {
    /// The standard configuration scaled to `robots` robots: 10 pucks per robot and
    /// the arena's sides scaled by sqrt(robots / 4), so densities stay those of the
    /// standard configuration (4 robots, 40 pucks, 187 cm).
    pub fn scaled(robots: usize) -> SceneConfig {
        let mut cfg = SceneConfig::default();
        let k = (robots as f64 / cfg.robots.count as f64).sqrt();
        cfg.robots.count = robots;
        cfg.pucks.count = 10 * robots;
        cfg.arena.width *= k;
        cfg.arena.height *= k;
        cfg
    }

    /// The configuration as TOML text (every field written out).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("a SceneConfig always serialises")
    }

    /// Simulated time of one control step, s (`physics.dt * physics.substeps`).
    pub fn control_step_seconds(&self) -> f64 {
        self.physics.dt * self.physics.substeps as f64
    }

    /// Puck radius, cm.
    pub fn puck_radius(&self) -> f64 {
        self.pucks.diameter / 2.0
    }

    /// The type of puck `index` (`index % kinds`).
    pub fn puck_kind(&self, index: usize) -> crate::PuckKind {
        crate::PuckKind((index % self.pucks.kinds.max(1)) as u8)
    }

    /// Checks every value; the error names the first bad field.
    pub fn validate(&self) -> Result<(), SimError> {
        self.validate_geometry()?;
        if self.robots.count == 0 {
            return Err(SimError::invalid(
                "robots.count",
                "must be at least 1 (a world needs a robot)",
            ));
        }
        if self.pucks.count == 0 {
            return Err(SimError::invalid(
                "pucks.count",
                "must be at least 1 (a world needs a puck)",
            ));
        }
        if self.pucks.kinds > self.pucks.count {
            return Err(SimError::invalid(
                "pucks.kinds",
                format!(
                    "{} puck types cannot be shared among {} pucks (at most one type per puck)",
                    self.pucks.kinds, self.pucks.count
                ),
            ));
        }
        Ok(())
    }

    /// Checks everything but the robot and puck counts (used by explicit layouts).
    pub(crate) fn validate_geometry(&self) -> Result<(), SimError> {
        let a = &self.arena;
        positive("arena.width", a.width)?;
        positive("arena.height", a.height)?;
        for (field, side) in [("arena.width", a.width), ("arena.height", a.height)] {
            if side > MAX_ARENA_SIDE {
                return Err(SimError::invalid(
                    field,
                    format!("{side} cm is more than the {MAX_ARENA_SIDE} cm (500 m) this simulator supports"),
                ));
            }
        }
        non_negative("arena.corner_radius", a.corner_radius)?;
        if a.corner_radius > a.width.min(a.height) / 2.0 {
            return Err(SimError::invalid(
                "arena.corner_radius",
                format!(
                    "{} cm is more than half the arena's smaller side",
                    a.corner_radius
                ),
            ));
        }
        let r = &self.robots;
        positive("robots.length", r.length)?;
        positive("robots.width", r.width)?;
        positive("robots.mass", r.mass)?;
        positive("robots.full_speed", r.full_speed)?;
        positive("robots.full_turn_rate", r.full_turn_rate)?;
        if let Some(d) = r.command_duration {
            positive("robots.command_duration", d)?;
        }
        positive("robots.gripper_radius", r.gripper_radius)?;
        if !(r.gripper_mouth_deg.is_finite()
            && r.gripper_mouth_deg > 0.0
            && r.gripper_mouth_deg < 180.0)
        {
            return Err(SimError::invalid(
                "robots.gripper_mouth_deg",
                format!(
                    "must lie strictly between 0 and 180 degrees, not {}",
                    r.gripper_mouth_deg
                ),
            ));
        }
        non_negative("robots.friction", r.friction)?;
        let p = &self.pucks;
        if p.kinds == 0 {
            return Err(SimError::invalid("pucks.kinds", "must be at least 1"));
        }
        if p.kinds > 255 {
            return Err(SimError::invalid(
                "pucks.kinds",
                format!(
                    "{} puck types is more than the 255 a PuckKind can name",
                    p.kinds
                ),
            ));
        }
        positive("pucks.diameter", p.diameter)?;
        positive("pucks.mass", p.mass)?;
        non_negative("pucks.linear_damping", p.linear_damping)?;
        non_negative("pucks.angular_damping", p.angular_damping)?;
        non_negative("pucks.friction", p.friction)?;
        if p.diameter / 2.0 >= r.gripper_radius {
            return Err(SimError::invalid(
                "robots.gripper_radius",
                format!(
                    "{} cm cannot hold a puck of radius {} cm (the gripper must be wider than a puck)",
                    r.gripper_radius,
                    p.diameter / 2.0
                ),
            ));
        }
        let mouth = 2.0 * r.gripper_radius * (r.gripper_mouth_deg.to_radians() / 2.0).sin();
        if mouth <= p.diameter {
            return Err(SimError::invalid(
                "robots.gripper_mouth_deg",
                format!(
                    "a {mouth:.2} cm mouth is too narrow for a {} cm puck to pass",
                    p.diameter
                ),
            ));
        }
        let c = &self.camera;
        finite("camera.offset", c.offset)?;
        non_negative("camera.near", c.near)?;
        positive("camera.far", c.far)?;
        if c.far <= c.near {
            return Err(SimError::invalid(
                "camera.far",
                format!("{} must exceed camera.near ({})", c.far, c.near),
            ));
        }
        positive("camera.half_width", c.half_width)?;
        positive("camera.max_range", c.max_range)?;
        if !(c.half_angle_deg.is_finite() && c.half_angle_deg > 0.0 && c.half_angle_deg <= 180.0) {
            return Err(SimError::invalid(
                "camera.half_angle_deg",
                format!("must lie in (0, 180] degrees, not {}", c.half_angle_deg),
            ));
        }
        if !(c.obstacle_spacing.is_finite() && c.obstacle_spacing >= 0.1) {
            return Err(SimError::invalid(
                "camera.obstacle_spacing",
                format!("must be at least 0.1 cm, not {}", c.obstacle_spacing),
            ));
        }
        let ph = &self.physics;
        positive("physics.dt", ph.dt)?;
        if ph.substeps == 0 {
            return Err(SimError::invalid("physics.substeps", "must be at least 1"));
        }
        if ph.solver_iterations == 0 {
            return Err(SimError::invalid(
                "physics.solver_iterations",
                "must be at least 1",
            ));
        }
        let k = &self.carrying;
        let seated = (p.diameter / 2.0 / r.gripper_radius).powi(2);
        if !(k.start_fraction.is_finite() && k.start_fraction > 0.0 && k.start_fraction < seated) {
            return Err(SimError::invalid(
                "carrying.start_fraction",
                format!(
                    "{} must lie in (0, {seated:.3}), the fraction of the gripper a seated puck covers",
                    k.start_fraction
                ),
            ));
        }
        if !(k.keep_fraction.is_finite()
            && k.keep_fraction > 0.0
            && k.keep_fraction <= k.start_fraction)
        {
            return Err(SimError::invalid(
                "carrying.keep_fraction",
                format!(
                    "{} must lie in (0, start_fraction = {}]",
                    k.keep_fraction, k.start_fraction
                ),
            ));
        }
        Ok(())
    }
}

impl CameraConfig {
    /// The footprint as a fast point test.
    pub fn footprint(&self) -> Footprint {
        let half = self.half_angle_deg.to_radians();
        Footprint {
            offset: self.offset,
            near: self.near,
            far: self.far,
            half_width: self.half_width,
            max_range_sq: self.max_range * self.max_range,
            // Beyond 90 degrees the angular limit excludes nothing ahead of `near`.
            tan_half_angle: if half < std::f64::consts::FRAC_PI_2 {
                Some(libm::tan(half))
            } else {
                None
            },
        }
    }
}

/// The camera's ground footprint as a point test in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    offset: f64,
    near: f64,
    far: f64,
    half_width: f64,
    max_range_sq: f64,
    tan_half_angle: Option<f64>,
}

impl Footprint {
    /// Whether a robot-frame point (x forward from the robot's centre, y left) lies on
    /// the ground area the camera sees.
    pub fn contains(&self, p: Vec2) -> bool {
        let x = p.x - self.offset;
        let ay = p.y.abs();
        x >= self.near
            && x <= self.far
            && ay <= self.half_width
            && x * x + p.y * p.y <= self.max_range_sq
            && self.tan_half_angle.is_none_or(|t| ay <= t * x)
    }

    /// Radius around the robot's centre that contains the whole footprint, cm.
    pub fn reach(&self) -> f64 {
        self.offset.abs()
            + self
                .max_range_sq
                .sqrt()
                .min(self.far.hypot(self.half_width))
    }

    /// The footprint's corners in the robot frame (near-right, far-right, far-left, near-left):
    /// its bounding quadrilateral, before the range and angle limits cut it.
    pub fn corners(&self) -> [Vec2; 4] {
        let (n, f, w) = (
            self.near + self.offset,
            self.far + self.offset,
            self.half_width,
        );
        [
            Vec2::new(n, -w),
            Vec2::new(f, -w),
            Vec2::new(f, w),
            Vec2::new(n, w),
        ]
    }
}

fn finite(field: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SimError::invalid(
            field,
            format!("must be a finite number, not {v}"),
        ))
    }
}

fn positive(field: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SimError::invalid(
            field,
            format!("must be positive, not {v}"),
        ))
    }
}

fn non_negative(field: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(SimError::invalid(
            field,
            format!("must be zero or positive, not {v}"),
        ))
    }
}
