//! The time-series chart of the `nav` report: [`crate::report::chart`]'s look (lines over
//! shaded bands, one legend entry each), but lines and bands are broken where the data are:
//! a point with a non-finite value ends a segment, so that a stretch without GNSS epochs is
//! left blank instead of bridged by a straight line or a band triangle.

use anyhow::{anyhow, Result};
use plotters::prelude::*;

const COLORS: [RGBColor; 4] = [
    RGBColor(200, 40, 40),
    RGBColor(30, 100, 200),
    RGBColor(20, 150, 60),
    RGBColor(150, 60, 170),
];

/// Shading of the bands, as in [`crate::report`].
const BAND_FILL: RGBColor = RGBColor(120, 150, 220);

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plot: {e:?}")
}

/// A named line: `(x, y)`, a non-finite `y` breaks it.
pub type Line = (String, Vec<(f64, f64)>);

/// A named band: `(x, lo, hi)`, a non-finite `lo` or `hi` breaks it.
pub type Shade = (String, Vec<(f64, f64, f64)>);

/// The runs of consecutive points that satisfy `ok`.
fn segments<P: Copy>(pts: &[P], ok: impl Fn(&P) -> bool) -> Vec<Vec<P>> {
    let mut out: Vec<Vec<P>> = vec![];
    let mut open = false;
    for p in pts {
        if ok(p) {
            if !open {
                out.push(vec![]);
                open = true;
            }
            if let Some(s) = out.last_mut() {
                s.push(*p);
            }
        } else {
            open = false;
        }
    }
    out
}

/// Inserts a break (`NaN`) wherever `x` jumps by more than `max_dx`; `value` builds the break.
pub fn break_gaps<P: Copy>(pts: &[P], x: impl Fn(&P) -> f64, max_dx: f64, gap: P) -> Vec<P> {
    let mut out = Vec::with_capacity(pts.len());
    for (i, p) in pts.iter().enumerate() {
        if i > 0 && x(p) - x(&pts[i - 1]) > max_dx {
            out.push(gap);
        }
        out.push(*p);
    }
    out
}

/// A line chart of `lines` over the shaded `bands`, with a grey line at `y = 0` when `zero`.
pub fn chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    lines: &[Line],
    bands: &[Shade],
    zero: bool,
) -> Result<String> {
    let fin = |x: f64, y: f64| x.is_finite() && y.is_finite();
    let pts = lines
        .iter()
        .flat_map(|l| l.1.iter().copied())
        .chain(
            bands
                .iter()
                .flat_map(|b| b.1.iter().flat_map(|p| [(p.0, p.1), (p.0, p.2)])),
        )
        .filter(|p| fin(p.0, p.1));
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in pts {
        (x0, x1, y0, y1) = (x0.min(p.0), x1.max(p.0), y0.min(p.1), y1.max(p.1));
    }
    if zero {
        (y0, y1) = (y0.min(0.0), y1.max(0.0));
    }
    if x0 >= x1 {
        (x0, x1) = (x0.min(0.0), x0.max(0.0) + 1.0);
    }
    if y0 >= y1 {
        (y0, y1) = (y0.min(0.0), y0.max(0.0) + 1.0);
    }
    let pad = 0.05 * (y1 - y0);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (860, 320)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut c = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
            .map_err(err)?;
        c.configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .y_label_formatter(&|v| crate::report::axis_label(*v))
            .draw()
            .map_err(err)?;
        let fill = BAND_FILL.mix(0.3).filled();
        for (name, b) in bands {
            let polys = segments(b, |p| fin(p.0, p.1) && p.2.is_finite());
            let outlines = polys.into_iter().map(|s| {
                let o: Vec<(f64, f64)> = s
                    .iter()
                    .map(|p| (p.0, p.2))
                    .chain(s.iter().rev().map(|p| (p.0, p.1)))
                    .collect();
                Polygon::new(o, fill)
            });
            c.draw_series(outlines)
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], fill));
        }
        if zero {
            c.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], BLACK.mix(0.5)))
                .map_err(err)?;
        }
        for (i, (name, l)) in lines.iter().enumerate() {
            let col = COLORS[i % COLORS.len()];
            let segs = segments(l, |p| fin(p.0, p.1));
            let paths = segs.into_iter().map(|s| PathElement::new(s, col));
            c.draw_series(paths)
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], col));
        }
        c.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_break_lines_and_bands() {
        let pts = [(0.0, 1.0), (1.0, 2.0), (5.0, 1.0), (6.0, 0.0)];
        let broken = break_gaps(&pts, |p| p.0, 1.5, (f64::NAN, f64::NAN));
        assert_eq!(broken.len(), 5);
        assert_eq!(segments(&broken, |p| p.0.is_finite()).len(), 2);
        let band: Vec<(f64, f64, f64)> = broken.iter().map(|p| (p.0, -p.1, p.1)).collect();
        let svg = chart(
            "t",
            "x",
            "y",
            &[("a".into(), broken)],
            &[("band".into(), band)],
            true,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            svg.matches("<polygon").count(),
            2,
            "one polygon per segment"
        );
    }
}
