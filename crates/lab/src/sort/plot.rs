//! PNG figures for experiment reports: completion curves with confidence
//! bands (the paper's Fig. 7), box plots (Fig. 9), cache convergence
//! (Fig. 11) and arena snapshots (Figs. 8 and 10).

use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

/// Everything drawing can fail with, as one readable message.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {path}: {message}")]
pub struct PlotError {
    /// The file being drawn.
    pub path: String,
    /// What went wrong.
    pub message: String,
}

fn err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// The font is built in, so plots draw the same on a machine with no fonts installed.
fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/DejaVuSans.ttf");
        // The bytes are a valid TrueType font, checked by the tests that draw.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}

/// Colours for series and puck types, distinguishable in print.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// One curve: mean with a band of ±1.96 standard errors.
pub struct Band {
    /// The legend's text.
    pub label: String,
    /// (x, mean, half-width of the band).
    pub points: Vec<(f64, f64, f64)>,
}

fn canvas(
    path: &Path,
    size: (u32, u32),
) -> Result<DrawingArea<BitMapBackend<'_>, Shift>, PlotError> {
    register_font();
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(path, e))?;
    Ok(root)
}

/// Mean curves with shaded 95 % bands, as in the paper's Fig. 7 and 11.
pub fn bands(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Band],
    y_max: Option<f64>,
) -> Result<(), PlotError> {
    let root = canvas(path, (900, 600))?;
    let x_max = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .fold(1.0, f64::max);
    let y_top = y_max.unwrap_or_else(|| {
        series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1 + p.2))
            .fold(f64::MIN_POSITIVE, f64::max)
            * 1.05
    });
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 24))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(0.0..x_max, 0.0..y_top)
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(|e| err(path, e))?;
    for (i, s) in series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let mut outline: Vec<(f64, f64)> = s
            .points
            .iter()
            .map(|&(x, m, h)| (x, (m + h).min(y_top)))
            .collect();
        outline.extend(
            s.points
                .iter()
                .rev()
                .map(|&(x, m, h)| (x, (m - h).max(0.0))),
        );
        chart
            .draw_series(std::iter::once(Polygon::new(outline, colour.mix(0.2))))
            .map_err(|e| err(path, e))?;
        chart
            .draw_series(LineSeries::new(
                s.points.iter().map(|&(x, m, _)| (x, m)),
                colour.stroke_width(2),
            ))
            .map_err(|e| err(path, e))?
            .label(&s.label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(3))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))
}

/// Box-and-whisker plots, one box per group (the paper's Fig. 9): boxes from
/// the 25th to the 75th percentile, whiskers to the smallest and largest values.
pub fn boxes(
    path: &Path,
    title: &str,
    y_label: &str,
    groups: &[(String, Vec<f64>)],
) -> Result<(), PlotError> {
    let root = canvas(path, (700, 550))?;
    let all = groups.iter().flat_map(|g| g.1.iter().copied());
    let (lo, hi) = all.fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let (lo, hi) = if lo > hi { (0.0, 1.0) } else { (lo, hi) };
    let pad = ((hi - lo) * 0.1).max(1e-6);
    let labels: Vec<String> = groups.iter().map(|g| g.0.clone()).collect();
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            labels.as_slice().into_segmented(),
            (lo - pad) as f32..(hi + pad) as f32,
        )
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .y_desc(y_label)
        .label_style(("sans-serif", 15))
        .disable_x_mesh()
        .draw()
        .map_err(|e| err(path, e))?;
    chart
        .draw_series(groups.iter().enumerate().map(|(i, (label, values))| {
            let q = Quartiles::new(values);
            Boxplot::new_vertical(SegmentValue::CenterOf(label), &q)
                .width(40)
                .style(PALETTE[i % PALETTE.len()].stroke_width(2))
        }))
        .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))
}

/// What an arena snapshot shows.
pub struct ArenaView<'a> {
    /// The caption.
    pub title: String,
    /// The arena's side (cm).
    pub width: f64,
    /// The arena's corner radius (cm).
    pub corner_radius: f64,
    /// A puck's diameter (cm).
    pub puck_diameter: f64,
    /// (x, y, kind) in the world frame.
    pub pucks: &'a [(f64, f64, u8)],
    /// (x, y, heading) in the world frame.
    pub robots: &'a [(f64, f64, f64)],
    /// (x, y, kind): cache points, drawn as filled squares.
    pub caches: &'a [(f64, f64, u8)],
}

/// Draws the arena from above, as in the paper's Figs. 8 and 10.
pub fn arena(path: &Path, view: &ArenaView<'_>) -> Result<(), PlotError> {
    let root = canvas(path, (620, 660))?;
    let h = view.width / 2.0;
    let mut chart = ChartBuilder::on(&root)
        .caption(&view.title, ("sans-serif", 20))
        .margin(10)
        .build_cartesian_2d(-h..h, -h..h)
        .map_err(|e| err(path, e))?;
    // The rounded-square wall.
    let r = view.corner_radius.min(h);
    let mut wall = Vec::new();
    for (cx, cy, start) in [
        (h - r, h - r, 0.0),
        (-h + r, h - r, 90.0),
        (-h + r, -h + r, 180.0),
        (h - r, -h + r, 270.0),
    ] {
        for deg in 0..=18 {
            let a = (start + deg as f64 * 5.0f64).to_radians();
            wall.push((cx + r * a.cos(), cy + r * a.sin()));
        }
    }
    wall.push(wall[0]);
    chart
        .draw_series(std::iter::once(PathElement::new(
            wall,
            BLACK.stroke_width(3),
        )))
        .map_err(|e| err(path, e))?;
    let scale = 560.0 / view.width;
    let puck_px = ((view.puck_diameter / 2.0) * scale).max(2.0) as i32;
    chart
        .draw_series(
            view.pucks
                .iter()
                .map(|&(x, y, k)| Circle::new((x, y), puck_px, PALETTE[k as usize % 8].filled())),
        )
        .map_err(|e| err(path, e))?;
    for &(x, y, theta) in view.robots {
        let (s, c) = theta.sin_cos();
        let corner = |fx: f64, fy: f64| (x + c * fx - s * fy, y + s * fx + c * fy);
        let body = vec![
            corner(6.25, 5.4),
            corner(-6.25, 5.4),
            corner(-6.25, -5.4),
            corner(6.25, -5.4),
            corner(6.25, 5.4),
        ];
        chart
            .draw_series(std::iter::once(PathElement::new(
                body,
                BLUE.stroke_width(2),
            )))
            .map_err(|e| err(path, e))?;
        let nose = vec![(x, y), corner(11.0, 0.0)];
        chart
            .draw_series(std::iter::once(PathElement::new(
                nose,
                BLUE.stroke_width(2),
            )))
            .map_err(|e| err(path, e))?;
    }
    chart
        .draw_series(view.caches.iter().map(|&(x, y, k)| {
            let d = 2.5;
            Rectangle::new(
                [(x - d, y - d), (x + d, y + d)],
                PALETTE[k as usize % 8].mix(0.9).filled(),
            )
        }))
        .map_err(|e| err(path, e))?;
    chart
        .draw_series(view.caches.iter().map(|&(x, y, _)| {
            let d = 2.5;
            Rectangle::new([(x - d, y - d), (x + d, y + d)], BLACK.stroke_width(1))
        }))
        .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_written_as_png_files() {
        let dir = std::env::temp_dir().join(format!("colony-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let band = Band {
            label: "CACHECONS".into(),
            points: (0..10)
                .map(|i| (i as f64 * 100.0, i as f64 * 10.0, 3.0))
                .collect(),
        };
        bands(
            &dir.join("pc.png"),
            "Percentage completion",
            "step",
            "PC (%)",
            &[band],
            Some(100.0),
        )
        .unwrap();
        boxes(
            &dir.join("stc.png"),
            "STC",
            "steps",
            &[
                ("A".into(), vec![1.0, 2.0, 3.0, 4.0]),
                ("B".into(), vec![2.0, 5.0, 6.0]),
            ],
        )
        .unwrap();
        let view = ArenaView {
            title: "step 0".into(),
            width: 187.0,
            corner_radius: 15.0,
            puck_diameter: 6.3,
            pucks: &[(0.0, 0.0, 0), (10.0, 5.0, 1)],
            robots: &[(30.0, 30.0, 1.0)],
            caches: &[(-20.0, -20.0, 0)],
        };
        arena(&dir.join("arena.png"), &view).unwrap();
        for f in ["pc.png", "stc.png", "arena.png"] {
            let bytes = std::fs::read(dir.join(f)).unwrap();
            assert_eq!(&bytes[1..4], b"PNG", "{f}");
            assert!(bytes.len() > 2_000, "{f} is suspiciously small");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
