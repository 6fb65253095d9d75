//! Every value the cache-consensus paper leaves open, in one place.
//!
//! [`SortParams`] holds the constants of perception, VFH+, the Deneubourg
//! rules, the state machines' durations and the cache-consensus memory.
//! `Default` gives the standard configuration; `configs/sort.toml` writes the
//! same values down with where each one comes from. Loading checks every
//! field and names the file and the field that is wrong.
//!
//! Units are in the field names: `_cm`, `_deg`, `_rad`, `_steps` (control
//! steps), or none for pure numbers.
//!
//! ```
//! let p = colony_sort::SortParams::from_toml_str("[deneubourg]\nk2 = 4.0\n", "inline").unwrap();
//! assert_eq!(p.deneubourg.k2, 4.0);
//! assert_eq!(p.deneubourg.k1, 1.0); // untouched fields keep their defaults
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

/// Why a parameter file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ParamsError {
    /// The file could not be read.
    #[error("{path}: cannot read")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The text is not valid TOML, or a field is unknown or of the wrong type.
    /// `message` comes from the TOML parser and names the line, column and key.
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    /// A field parsed but its value cannot work.
    #[error("{path}: field `{field}` = {value}: {reason}")]
    Invalid {
        path: String,
        field: &'static str,
        value: String,
        reason: &'static str,
    },
}

/// All tunable values of the sorting methods (see `configs/sort.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct SortParams {
    pub robot: RobotParams,
    pub perception: PerceptionParams,
    pub deneubourg: DeneubourgParams,
    pub timing: TimingParams,
    pub seek: SeekParams,
    pub cache: CacheParams,
    pub informed: InformedParams,
    pub vfh: VfhParams,
    pub steering: SteeringParams,
}

/// The robot's geometry as the controllers assume it (robot frame: x forward, y left).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotParams {
    /// Where the camera (the origin of the authors' local map and of VFH+'s
    /// polar histogram) sits ahead of the robot's centre.
    pub camera_x_cm: f64,
    /// Radius of the two turning circles.
    pub turning_radius_cm: f64,
    /// x of both turning-circle centres in the robot frame (their y is
    /// +-`turning_radius_cm`).
    pub turning_centre_x_cm: f64,
    /// Obstacle points within this distance of another robot's centre are
    /// taken to be that robot's body (for the robot-proximity rule).
    pub body_radius_cm: f64,
}

impl Default for RobotParams {
    fn default() -> Self {
        RobotParams {
            camera_x_cm: 6.5,
            turning_radius_cm: 12.5,
            turning_centre_x_cm: 0.0,
            body_radius_cm: 12.0,
        }
    }
}

/// The local map: pucks, clusters and what is ignored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PerceptionParams {
    /// Two same-type pucks closer than this are joined in a cluster (Sect. 2.2).
    pub cluster_threshold_cm: f64,
    /// A puck's radius, used to enlarge pucks as VFH+ obstacles.
    pub puck_radius_cm: f64,
    /// Clusters with a puck closer than this to another robot's body are not
    /// targeted.
    pub robot_proximity_cm: f64,
}

impl Default for PerceptionParams {
    fn default() -> Self {
        PerceptionParams {
            cluster_threshold_cm: 9.45,
            puck_radius_cm: 3.15,
            robot_proximity_cm: 10.0,
        }
    }
}

/// The constants of Deneubourg et al.'s pick-up and deposit probabilities (Fig. 3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeneubourgParams {
    pub k1: f64,
    pub k2: f64,
}

impl Default for DeneubourgParams {
    fn default() -> Self {
        DeneubourgParams { k1: 1.0, k2: 8.0 }
    }
}

/// How long the timed states last, in control steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TimingParams {
    pub push_steps: u32,
    pub backup_steps: u32,
    /// Control steps for a 180-degree turn at full turn rate; a random turn of
    /// angle a in [pi/2, pi] lasts round(a / pi * half_turn_steps) steps.
    pub half_turn_steps: u32,
    /// PU_TARGET gives up after this many steps.
    pub pick_up_timeout_steps: u32,
    /// DE_TARGET gives up after this many steps.
    pub placement_timeout_steps: u32,
    pub exile_steps: u32,
    pub spit_out_steps: u32,
}

impl Default for TimingParams {
    fn default() -> Self {
        TimingParams {
            push_steps: 1,
            backup_steps: 5,
            half_turn_steps: 10,
            pick_up_timeout_steps: 20,
            placement_timeout_steps: 40,
            exile_steps: 20,
            spit_out_steps: 10,
        }
    }
}

/// Wandering and target tracking (PROBSEEK and CACHECONS).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SeekParams {
    /// A target is lost when the nearest candidate is farther than this from
    /// where the target was last seen.
    pub target_lost_cm: f64,
    /// Standard deviation of the Gaussian goal angle fed to VFH+ when wandering.
    pub wander_sigma_rad: f64,
}

impl Default for SeekParams {
    fn default() -> Self {
        SeekParams {
            target_lost_cm: 10.0,
            wander_sigma_rad: 0.5,
        }
    }
}

/// Which visible clusters are candidates for a new cache point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CacheCandidates {
    /// Only L, the largest visible cluster of any type (the paper, Sect. 2.6.1).
    LargestOverall,
    /// L_j for every type j (the authors' simulator).
    LargestPerType,
}

/// Cache-consensus memory (Sect. 2.6.1, 2.6.2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CacheParams {
    /// Minimum distance between cache points of different types.
    pub separation_cm: f64,
    /// C_j, the visible cache cluster, is the cluster of type j with a puck
    /// nearest the cache point, if that puck is closer than this.
    pub match_cm: f64,
    pub candidates: CacheCandidates,
    /// Per-step probability of wiping all caches (`cachecons-erase`).
    pub erase_probability: f64,
}

impl Default for CacheParams {
    fn default() -> Self {
        CacheParams {
            separation_cm: 50.0,
            match_cm: 9.45,
            candidates: CacheCandidates::LargestOverall,
            erase_probability: 0.001,
        }
    }
}

/// The preset caches of CACHECONS_INFORMED.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InformedParams {
    /// Circle diameter as a fraction of the arena width.
    pub diameter_fraction: f64,
    /// Angle of type 0's cache; type k is at this plus k * 360 / n degrees.
    pub first_angle_deg: f64,
    /// Remembered size of each preset cache.
    pub remembered_size: f64,
}

impl Default for InformedParams {
    fn default() -> Self {
        InformedParams {
            diameter_fraction: 0.75,
            first_angle_deg: 45.0,
            remembered_size: 1000.0,
        }
    }
}

/// VFH+ (Ulrich and Borenstein 1998) as the authors configured it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VfhParams {
    /// Number of sectors over [-half_range, +half_range]; odd so one is centred on 0.
    pub sectors: usize,
    pub half_range_deg: f64,
    /// Cell magnitude is 1 - d^2 / magnitude_zero^2 (zero from this distance on).
    pub magnitude_zero_cm: f64,
    /// Enlargement angle asin(r / d) uses this r.
    pub enlargement_cm: f64,
    /// Added to the turning radius when masking blocked turning circles.
    pub safety_margin_cm: f64,
    /// Binary histogram hysteresis: free below `tau_low`, blocked above `tau_high`.
    pub tau_low: f64,
    pub tau_high: f64,
    /// Openings at least this many sectors wide are wide valleys.
    pub s_max: usize,
    /// Cost weight of the difference from the goal direction.
    pub mu_target: f64,
    /// Cost weight of the difference from straight ahead.
    pub mu_heading: f64,
    /// Cost weight of the difference from the previous choice.
    pub mu_previous: f64,
    /// BHD: an obstacle is ahead if VFH+ finds no direction or one more than
    /// this far off straight.
    pub obstacle_ahead_deg: f64,
}

impl Default for VfhParams {
    fn default() -> Self {
        VfhParams {
            sectors: 73,
            half_range_deg: 90.0,
            magnitude_zero_cm: 57.735_026_918_962_58,
            enlargement_cm: 2.0,
            safety_margin_cm: 5.0,
            tau_low: 0.7,
            tau_high: 0.85,
            s_max: 8,
            mu_target: 5.0,
            mu_heading: 2.0,
            mu_previous: 3.0,
            obstacle_ahead_deg: 45.0,
        }
    }
}

/// From a chosen direction theta to wheel commands.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SteeringParams {
    /// turn = sat(theta / full_turn_angle, -1, 1).
    pub full_turn_angle_deg: f64,
    /// forward = sat((slow_angle - |theta|) / slow_angle, min_forward, 1).
    pub slow_angle_deg: f64,
    pub min_forward: f64,
    /// Forward speed when VFH+ finds no free direction (turn is then hard
    /// toward the freer side).
    pub blocked_forward: f64,
    /// While VFH+ stays blocked, keep turning toward the side chosen on the
    /// first blocked step (instead of re-deciding every step).
    pub hold_blocked_side: bool,
}

impl Default for SteeringParams {
    fn default() -> Self {
        SteeringParams {
            full_turn_angle_deg: 45.0,
            slow_angle_deg: 45.0,
            min_forward: 0.25,
            blocked_forward: 0.125,
            hold_blocked_side: true,
        }
    }
}

impl SortParams {
    /// Reads and checks a TOML file; missing fields keep their defaults.
    pub fn load(path: impl AsRef<Path>) -> Result<SortParams, ParamsError> {
        let path = path.as_ref();
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ParamsError::Io {
            path: shown.clone(),
            source,
        })?;
        SortParams::from_toml_str(&text, &shown)
    }

    /// Parses and checks TOML text; `origin` names it in errors (a path, or "inline").
    pub fn from_toml_str(text: &str, origin: &str) -> Result<SortParams, ParamsError> {
        let params: SortParams = toml::from_str(text).map_err(|e| ParamsError::Parse {
            path: origin.to_string(),
            message: e.to_string().trim_end().to_string(),
        })?;
        params.validate(origin)?;
        Ok(params)
    }

    /// The TOML text of these parameters (no comments).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Checks that every value can work; `origin` names the source in errors.
    pub fn validate(&self, origin: &str) -> Result<(), ParamsError> {
        let bad = |field: &'static str, value: String, reason: &'static str| {
            Err(ParamsError::Invalid {
                path: origin.to_string(),
                field,
                value,
                reason,
            })
        };
        let positive: [(&'static str, f64); 17] = [
            ("robot.turning_radius_cm", self.robot.turning_radius_cm),
            ("robot.body_radius_cm", self.robot.body_radius_cm),
            (
                "perception.cluster_threshold_cm",
                self.perception.cluster_threshold_cm,
            ),
            ("perception.puck_radius_cm", self.perception.puck_radius_cm),
            (
                "perception.robot_proximity_cm",
                self.perception.robot_proximity_cm,
            ),
            ("deneubourg.k1", self.deneubourg.k1),
            ("deneubourg.k2", self.deneubourg.k2),
            ("seek.target_lost_cm", self.seek.target_lost_cm),
            ("cache.match_cm", self.cache.match_cm),
            (
                "informed.diameter_fraction",
                self.informed.diameter_fraction,
            ),
            ("informed.remembered_size", self.informed.remembered_size),
            ("vfh.half_range_deg", self.vfh.half_range_deg),
            ("vfh.magnitude_zero_cm", self.vfh.magnitude_zero_cm),
            ("vfh.obstacle_ahead_deg", self.vfh.obstacle_ahead_deg),
            (
                "steering.full_turn_angle_deg",
                self.steering.full_turn_angle_deg,
            ),
            ("steering.slow_angle_deg", self.steering.slow_angle_deg),
            ("vfh.tau_high", self.vfh.tau_high),
        ];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(field, v.to_string(), "must be a finite number above 0");
            }
        }
        for (field, v) in [
            ("robot.camera_x_cm", self.robot.camera_x_cm),
            ("robot.turning_centre_x_cm", self.robot.turning_centre_x_cm),
        ] {
            if !v.is_finite() {
                return bad(field, v.to_string(), "must be a finite number");
            }
        }
        let non_negative: [(&'static str, f64); 7] = [
            ("seek.wander_sigma_rad", self.seek.wander_sigma_rad),
            ("cache.separation_cm", self.cache.separation_cm),
            ("vfh.enlargement_cm", self.vfh.enlargement_cm),
            ("vfh.safety_margin_cm", self.vfh.safety_margin_cm),
            ("vfh.mu_target", self.vfh.mu_target),
            ("vfh.mu_heading", self.vfh.mu_heading),
            ("vfh.mu_previous", self.vfh.mu_previous),
        ];
        for (field, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return bad(field, v.to_string(), "must be a finite number, 0 or more");
            }
        }
        let unit: [(&'static str, f64); 4] = [
            ("cache.erase_probability", self.cache.erase_probability),
            ("vfh.tau_low", self.vfh.tau_low),
            ("steering.min_forward", self.steering.min_forward),
            ("steering.blocked_forward", self.steering.blocked_forward),
        ];
        for (field, v) in unit {
            if !(0.0..=1.0).contains(&v) {
                return bad(field, v.to_string(), "must lie in [0, 1]");
            }
        }
        if self.vfh.tau_low > self.vfh.tau_high {
            return bad(
                "vfh.tau_low",
                self.vfh.tau_low.to_string(),
                "must not exceed vfh.tau_high",
            );
        }
        if self.vfh.half_range_deg > 180.0 {
            return bad(
                "vfh.half_range_deg",
                self.vfh.half_range_deg.to_string(),
                "must not exceed 180",
            );
        }
        if self.vfh.sectors < 3 || self.vfh.sectors % 2 == 0 || self.vfh.sectors > 10_000 {
            return bad(
                "vfh.sectors",
                self.vfh.sectors.to_string(),
                "must be odd, from 3 to 9999, so that one sector is centred straight ahead",
            );
        }
        if self.vfh.s_max == 0 {
            return bad("vfh.s_max", "0".into(), "must be at least 1");
        }
        if self.timing.half_turn_steps == 0 {
            return bad("timing.half_turn_steps", "0".into(), "must be at least 1");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_text_gives_the_defaults() {
        assert_eq!(
            SortParams::from_toml_str("", "x").unwrap(),
            SortParams::default()
        );
    }

    #[test]
    fn unknown_field_is_named_with_the_file() {
        let e = SortParams::from_toml_str("[deneubourg]\nk3 = 1.0\n", "my.toml").unwrap_err();
        let s = e.to_string();
        assert!(s.starts_with("my.toml:"), "{s}");
        assert!(s.contains("k3"), "{s}");
    }

    #[test]
    fn wrong_type_is_named() {
        let e =
            SortParams::from_toml_str("[timing]\nbackup_steps = \"five\"\n", "f.toml").unwrap_err();
        let s = e.to_string();
        assert!(s.contains("backup_steps"), "{s}");
        assert!(s.contains("line 2"), "{s}");
    }

    #[test]
    fn impossible_value_names_the_field() {
        let e = SortParams::from_toml_str("[vfh]\ntau_low = 0.9\n", "f.toml").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.toml: field `vfh.tau_low` = 0.9: must not exceed vfh.tau_high"
        );
        let e = SortParams::from_toml_str("[vfh]\nsectors = 72\n", "f.toml").unwrap_err();
        assert!(e.to_string().contains("vfh.sectors"));
        let e = SortParams::from_toml_str("[deneubourg]\nk1 = -1.0\n", "f.toml").unwrap_err();
        assert!(e.to_string().contains("deneubourg.k1"));
    }

    #[test]
    fn missing_file_is_named() {
        let e = SortParams::load("/nonexistent/sort.toml").unwrap_err();
        assert!(e
            .to_string()
            .starts_with("/nonexistent/sort.toml: cannot read"));
    }

    #[test]
    fn defaults_survive_a_round_trip() {
        let p = SortParams::default();
        let text = p.to_toml_string();
        assert_eq!(SortParams::from_toml_str(&text, "rt").unwrap(), p);
    }

    #[test]
    fn repository_config_holds_exactly_the_defaults() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs/sort.toml");
        assert_eq!(SortParams::load(path).unwrap(), SortParams::default());
    }
}
