//! VFH+ on hand-placed obstacles, and the steering law.

use colony_sim::Vec2;
use colony_sort::params::SortParams;
use colony_sort::vfh::{
    binary_histogram, candidate_sectors, choose_direction, masked_histogram, nearest_sector,
    primary_histogram, sector_angle, steer, steer_toward, turning_limits, Obstacle, Vfh,
};

fn wall(x: f64, ys: impl Iterator<Item = f64>) -> Vec<Obstacle> {
    ys.map(|y| Obstacle::point(Vec2::new(x, y))).collect()
}

fn span(from: f64, to: f64) -> impl Iterator<Item = f64> {
    let n = (to - from).round() as i64;
    (0..=n).map(move |i| from + i as f64)
}

fn vfh() -> Vfh {
    let p = SortParams::default();
    Vfh::new(&p.vfh, &p.robot)
}

#[test]
fn sectors_are_two_and_a_half_degrees_with_one_straight_ahead() {
    let p = SortParams::default().vfh;
    assert_eq!(nearest_sector(&p, 0.0), 36);
    assert!(sector_angle(&p, 36).abs() < 1e-12);
    assert!((sector_angle(&p, 37).to_degrees() - 2.5).abs() < 1e-9);
    assert!((sector_angle(&p, 72).to_degrees() - 90.0).abs() < 1e-9);
    assert_eq!(nearest_sector(&p, 3.0), 72, "angles beyond the range clamp");
}

#[test]
fn free_space_goes_straight_to_the_goal() {
    let mut v = vfh();
    assert_eq!(v.direction(&[], 0.0), Some(0.0));
    let d = v.direction(&[], 0.5).unwrap();
    assert!((d - 0.5).abs() < 0.03, "{d}");
}

#[test]
fn steers_around_an_obstacle_straight_ahead_toward_the_goal_beyond_it() {
    let block = wall(25.0, span(-8.0, 8.0));
    let mut v = vfh();
    let d = v.direction(&block, 0.0).unwrap();
    // The block covers about +-30 degrees from the camera; VFH+ takes the border of the
    // opening plus s_max / 2 sectors.
    assert!(
        d.abs().to_degrees() > 30.0 && d.abs().to_degrees() < 50.0,
        "{}",
        d.to_degrees()
    );
    // The chosen direction's sector is free in the primary histogram.
    let p = SortParams::default();
    let h = primary_histogram(&p.vfh, &p.robot, &block);
    assert!(h[nearest_sector(&p.vfh, d)] < p.vfh.tau_low);
    // A goal slightly to the left makes it pass on the left, slightly right on the right.
    assert!(vfh().direction(&block, 0.2).unwrap() > 0.0);
    assert!(vfh().direction(&block, -0.2).unwrap() < 0.0);
}

#[test]
fn goes_through_a_gap_wide_enough_for_the_robot() {
    // Two walls 20 cm ahead with a 30 cm gap straight ahead.
    let mut walls = wall(20.0, span(-60.0, -15.0));
    walls.extend(wall(20.0, span(15.0, 60.0)));
    let mut v = vfh();
    assert_eq!(v.direction(&walls, 0.0), Some(0.0));
    // A goal a little to the right inside the gap is taken as it is.
    let d = vfh().direction(&walls, -0.3).unwrap();
    assert!((d + 0.3).abs() < 0.03, "{}", d.to_degrees());
    // Directions into the near wall ends are blocked.
    let p = SortParams::default();
    let h = primary_histogram(&p.vfh, &p.robot, &walls);
    assert!(h[nearest_sector(&p.vfh, 50f64.to_radians())] > p.vfh.tau_high);
    assert!(h[nearest_sector(&p.vfh, -50f64.to_radians())] > p.vfh.tau_high);
}

#[test]
fn reports_blocked_when_boxed_in() {
    let ring: Vec<Obstacle> = (0..180)
        .map(|i| {
            let a = i as f64 * 2.0_f64.to_radians();
            Obstacle::point(Vec2::new(15.0 * a.cos(), 15.0 * a.sin()))
        })
        .collect();
    assert_eq!(vfh().direction(&ring, 0.0), None);
    // Blocked: creep (PuckSwarm: 0.5 scaled by the law at pi/2) and turn hard toward the freer side.
    let s = SortParams::default().steering;
    let c = steer(None, -1.0, &s);
    assert_eq!((c.forward, c.turn), (0.125, -1.0));
}

#[test]
fn binary_histogram_keeps_its_value_between_the_thresholds() {
    let p = SortParams::default().vfh;
    let primary = [0.9, 0.8, 0.8, 0.5];
    let before = [false, false, true, true];
    assert_eq!(
        binary_histogram(&p, &primary, &before),
        vec![true, false, true, false]
    );
}

#[test]
fn hysteresis_holds_a_sector_blocked_until_the_obstacle_is_clearly_far() {
    let p = SortParams::default();
    let ahead = |d: f64| [Obstacle::point(Vec2::new(p.robot.camera_x_cm + d, 0.0))];
    let straight = nearest_sector(&p.vfh, 0.0);
    let mut v = vfh();
    // Magnitude 1 - 27^2 / 3333 = 0.78: between the thresholds, starts free.
    v.direction(&ahead(27.0), 0.0);
    assert!(!v.binary()[straight]);
    v.direction(&ahead(15.0), 0.0); // 0.93: blocked
    assert!(v.binary()[straight]);
    v.direction(&ahead(27.0), 0.0); // back between the thresholds: still blocked
    assert!(v.binary()[straight]);
    v.direction(&ahead(40.0), 0.0); // 0.52: free again
    assert!(!v.binary()[straight]);
    v.direction(&ahead(15.0), 0.0);
    v.reset();
    assert!(!v.binary()[straight]);
    assert_eq!(v.previous(), 0.0);
}

#[test]
fn obstacle_inside_a_turning_circle_masks_the_directions_beyond_it() {
    let p = SortParams::default();
    // 10 cm ahead and 10 cm left of the centre: inside the left circle (+ safety margin),
    // at about 71 degrees from the camera.
    let o = [Obstacle::point(Vec2::new(10.0, 10.0))];
    let (right, left) = turning_limits(&p.vfh, &p.robot, &o);
    assert!(
        (left.to_degrees() - 70.7).abs() < 0.2,
        "{}",
        left.to_degrees()
    );
    assert_eq!(right, -std::f64::consts::FRAC_PI_2);
    let masked = masked_histogram(&p.vfh, &[false; 73], (right, left));
    assert!(masked[nearest_sector(&p.vfh, 80f64.to_radians())]);
    assert!(!masked[nearest_sector(&p.vfh, 60f64.to_radians())]);
    assert!(!masked[nearest_sector(&p.vfh, -80f64.to_radians())]);
    // A goal far left is refused beyond the limit.
    let d = vfh().direction(&o, 85f64.to_radians()).unwrap();
    assert!(d < left, "{}", d.to_degrees());
}

#[test]
fn narrow_openings_offer_their_centre_and_wide_ones_their_borders_and_the_goal() {
    let p = SortParams::default().vfh;
    let mut masked = vec![true; 73];
    // Narrow: sectors 10..=14 (5 < s_max = 8).
    masked[10..=14].iter_mut().for_each(|m| *m = false);
    // Wide: sectors 30..=50.
    masked[30..=50].iter_mut().for_each(|m| *m = false);
    assert_eq!(candidate_sectors(&p, &masked, 40), vec![12, 34, 46, 40]);
    assert_eq!(candidate_sectors(&p, &masked, 0), vec![12, 34, 46]);
    // The goal sector 40 costs least when it is free.
    assert_eq!(
        choose_direction(&p, &masked, sector_angle(&p, 40), 0.0),
        Some(sector_angle(&p, 40))
    );
    assert_eq!(choose_direction(&p, &[true; 73], 0.0, 0.0), None);
}

#[test]
fn steering_law_turns_fully_from_45_degrees_and_slows_down() {
    let s = SortParams::default().steering;
    let c = steer_toward(0.0, &s);
    assert_eq!((c.forward, c.turn), (1.0, 0.0));
    let c = steer_toward(std::f64::consts::FRAC_PI_8, &s);
    assert!((c.forward - 0.5).abs() < 1e-12 && (c.turn - 0.5).abs() < 1e-12);
    let c = steer_toward(-std::f64::consts::FRAC_PI_2, &s);
    assert_eq!((c.forward, c.turn), (0.25, -1.0));
    let c = steer(Some(0.0), 1.0, &s);
    assert_eq!((c.forward, c.turn), (1.0, 0.0));
}
