//! The two SVG plots of `identify`: log-log ADEV with intervals, component curves and their
//! sum; and the ACF with its exponential and exponential-cosine fits.

use anyhow::{anyhow, Result};
use plotters::prelude::*;

const COLORS: [RGBColor; 6] = [
    RGBColor(30, 100, 200),
    RGBColor(20, 150, 60),
    RGBColor(150, 60, 170),
    RGBColor(230, 130, 0),
    RGBColor(0, 160, 160),
    RGBColor(120, 120, 120),
];

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plot: {e:?}")
}

/// A named curve.
pub type Curve = (String, Vec<(f64, f64)>);

/// Log-log ADEV: measured points with their interval as vertical bars, then `curves`
/// (each component) and `total` (their sum, drawn last in red).
pub fn adev_svg(
    title: &str,
    unit: &str,
    measured: &[(f64, f64, f64, f64)],
    curves: &[Curve],
    total: &[(f64, f64)],
) -> Result<String> {
    let ok = |v: f64| v.is_finite() && v > 0.0;
    let (mut x0, mut x1) = (f64::MAX, f64::MIN);
    let (mut y0, mut y1) = (f64::MAX, f64::MIN);
    for &(t, a, lo, hi) in measured {
        if ok(t) && ok(a) {
            (x0, x1) = (x0.min(t), x1.max(t));
            (y0, y1) = (y0.min(a).min(if ok(lo) { lo } else { a }), y1.max(a));
            if ok(hi) {
                y1 = y1.max(hi);
            }
        }
    }
    if x0 >= x1 || y0 >= y1 {
        return Err(anyhow!("plot: no positive ADEV points"));
    }
    // Component curves may dive far below the data: show at most two decades under it.
    let y_floor = y0 / 100.0;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (860, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (x0 / 1.5..x1 * 1.5).log_scale(),
                (y_floor..y1 * 1.5).log_scale(),
            )
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("tau [s]")
            .y_desc(format!("Allan deviation [{unit}]"))
            .draw()
            .map_err(err)?;
        let clip = |p: &[(f64, f64)]| -> Vec<(f64, f64)> {
            p.iter()
                .copied()
                .filter(|q| ok(q.0) && ok(q.1) && q.1 >= y_floor)
                .collect()
        };
        for (i, (name, p)) in curves.iter().enumerate() {
            let c = COLORS[i % COLORS.len()];
            chart
                .draw_series(LineSeries::new(clip(p), c.stroke_width(1)))
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c));
        }
        chart
            .draw_series(LineSeries::new(clip(total), RED.stroke_width(2)))
            .map_err(err)?
            .label("model (sum)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], RED));
        chart
            .draw_series(
                measured
                    .iter()
                    .filter(|m| ok(m.0) && ok(m.2) && ok(m.3))
                    .map(|&(t, _, lo, hi)| PathElement::new([(t, lo), (t, hi)], BLACK)),
            )
            .map_err(err)?;
        chart
            .draw_series(
                measured
                    .iter()
                    .filter(|m| ok(m.0) && ok(m.1))
                    .map(|&(t, a, _, _)| Circle::new((t, a), 3, BLACK.filled())),
            )
            .map_err(err)?
            .label("measured, 95 % CI")
            .legend(|(x, y)| Circle::new((x + 9, y), 3, BLACK.filled()));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// ACF against lag time, with fits and the ±`band` lines.
pub fn acf_svg(title: &str, rho: &[(f64, f64)], fits: &[Curve], band: f64) -> Result<String> {
    let mut series: Vec<Curve> = vec![("sample ACF".into(), rho.to_vec())];
    series.extend(fits.iter().cloned());
    crate::report::line_chart(title, "lag [s]", "rho", &series, &[band, -band])
}
