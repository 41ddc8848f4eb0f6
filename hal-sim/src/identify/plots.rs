//! The two SVG plots of `identify`: log-log ADEV with intervals, component curves and their
//! sum; and the ACF with its exponential and exponential-cosine fits.

use anyhow::{anyhow, Result};
use plotters::coord::CoordTranslate;
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

/// The legend box, upper right, shared by both plots.
fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)
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
        // The measured 95 % interval as one shaded area (upper edge out, lower edge back),
        // drawn under the curves, with its own legend entry.
        let band: Vec<(f64, f64)> = measured
            .iter()
            .filter(|m| ok(m.0) && ok(m.2) && ok(m.3))
            .map(|&(t, _, _, hi)| (t, hi))
            .chain(
                measured
                    .iter()
                    .rev()
                    .filter(|m| ok(m.0) && ok(m.2) && ok(m.3))
                    .map(|&(t, _, lo, _)| (t, lo.max(y_floor))),
            )
            .collect();
        let shade = RGBColor(0, 0, 0).mix(0.15);
        chart
            .draw_series(std::iter::once(Polygon::new(band, shade.filled())))
            .map_err(err)?
            .label("measured 95 % CI")
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], shade.filled()));
        chart
            .draw_series(
                measured
                    .iter()
                    .filter(|m| ok(m.0) && ok(m.1))
                    .map(|&(t, a, _, _)| Circle::new((t, a), 3, BLACK.filled())),
            )
            .map_err(err)?
            .label("measured ADEV")
            .legend(|(x, y)| Circle::new((x + 9, y), 3, BLACK.filled()));
        draw_legend(&mut chart)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// ACF against lag time, with fits and the ±`band` interval of a white series shaded (one
/// legend entry for the band, not one per edge).
pub fn acf_svg(title: &str, rho: &[(f64, f64)], fits: &[Curve], band: f64) -> Result<String> {
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let all = || {
        rho.iter()
            .chain(fits.iter().flat_map(|c| c.1.iter()))
            .filter(finite)
    };
    let x1 = all().map(|p| p.0).fold(f64::MIN, f64::max);
    let x0 = all().map(|p| p.0).fold(f64::MAX, f64::min).min(0.0);
    let y0 = all().map(|p| p.1).fold(-band, f64::min);
    let y1 = all().map(|p| p.1).fold(band, f64::max);
    if x0 >= x1 || y0.partial_cmp(&y1) != Some(std::cmp::Ordering::Less) {
        return Err(anyhow!("plot: no ACF points"));
    }
    let pad = 0.05 * (y1 - y0);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (860, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("lag [s]")
            .y_desc("rho")
            .draw()
            .map_err(err)?;
        let shade = RGBColor(0, 0, 0).mix(0.12);
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(x0, -band), (x1, band)],
                shade.filled(),
            )))
            .map_err(err)?
            .label(format!("white-noise 95 % band, +/-{band:.3e}"))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], shade.filled()));
        chart
            .draw_series(LineSeries::new(
                rho.iter().copied().filter(|p| finite(&p)),
                BLACK.stroke_width(1),
            ))
            .map_err(err)?
            .label("sample ACF")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK));
        for (i, (name, p)) in fits.iter().enumerate() {
            let c = COLORS[i % COLORS.len()];
            chart
                .draw_series(LineSeries::new(
                    p.iter().copied().filter(|q| finite(&q)),
                    c.stroke_width(2),
                ))
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c));
        }
        draw_legend(&mut chart)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The band is one shaded area with one legend entry (it was two coloured lines sharing a
    /// "99 % band" entry), and the ADEV interval is a filled polygon.
    #[test]
    fn bands_are_shaded_with_one_legend_entry() {
        let rho: Vec<(f64, f64)> = (1..50).map(|i| (i as f64 * 0.01, 0.9f64.powi(i))).collect();
        let svg = acf_svg("t", &rho, &[], 0.02).expect("acf");
        assert_eq!(svg.matches("white-noise 95 % band").count(), 1, "{svg}");
        assert!(!svg.contains("99 % band"));
        assert!(svg.contains("opacity=\"0.12\""), "no shaded area: {svg}");
        let m: Vec<(f64, f64, f64, f64)> = (0..10)
            .map(|i| {
                let t = 2f64.powi(i) * 0.01;
                let a = 1.0 / t.sqrt();
                (t, a, 0.9 * a, 1.1 * a)
            })
            .collect();
        let svg = adev_svg("t", "u", &m, &[], &[]).expect("adev");
        assert_eq!(svg.matches("measured 95 % CI").count(), 1);
        assert!(svg.contains("<polygon"), "no CI polygon");
    }
}
