//! The track plot of the `nav` report: east against north [m] from the first GNSS fix, equal
//! scales; the GNSS fixes (used and withheld), the solution, and the solution during the
//! outages drawn thick.

use super::NavRun;
use crate::nav_io::outages::north_east;
use crate::nav_io::GnssFix;
use anyhow::{anyhow, Result};
use plotters::prelude::*;

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("track plot: {e:?}")
}

/// The track: east against north [m] from the first GNSS fix, equal scales.
pub fn track_svg(run: &NavRun) -> Result<String> {
    let Some(f0) = run.fixes.first() else {
        return Err(anyhow!("nav report: no GNSS fix"));
    };
    let en = |lat: f64, lon: f64| {
        let ne = north_east(f0.lat_deg, f0.lon_deg, f0.h, lat, lon);
        (ne[1], ne[0])
    };
    let withheld = |t: f64| {
        let k = run.epochs.partition_point(|e| e.t < t);
        run.epochs.get(k).is_some_and(|e| e.t == t && e.withheld)
    };
    let (used, held): (Vec<&GnssFix>, Vec<&GnssFix>) =
        run.fixes.iter().partition(|f| !withheld(f.t));
    let used: Vec<(f64, f64)> = used.iter().map(|f| en(f.lat_deg, f.lon_deg)).collect();
    let held: Vec<(f64, f64)> = held.iter().map(|f| en(f.lat_deg, f.lon_deg)).collect();
    let sol: Vec<(f64, f64, bool)> = run
        .epochs
        .iter()
        .filter(|e| e.lat_deg.is_finite() && e.lon_deg.is_finite())
        .map(|e| {
            let p = en(e.lat_deg, e.lon_deg);
            (p.0, p.1, e.withheld)
        })
        .collect();
    let (w, h) = (860u32, 600u32);
    let all = used
        .iter()
        .chain(held.iter())
        .copied()
        .chain(sol.iter().map(|p| (p.0, p.1)));
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in all.filter(|p| p.0.is_finite() && p.1.is_finite()) {
        (x0, x1, y0, y1) = (x0.min(p.0), x1.max(p.0), y0.min(p.1), y1.max(p.1));
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
    }
    // Equal metres per pixel on both axes (plot area about (w - 100) x (h - 85) pixels).
    let (pw, ph) = (f64::from(w - 100), f64::from(h - 85));
    let m_per_px = ((x1 - x0) / pw).max((y1 - y0) / ph).max(1e-3) * 1.05;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (x0, x1) = (cx - 0.5 * pw * m_per_px, cx + 0.5 * pw * m_per_px);
    let (y0, y1) = (cy - 0.5 * ph * m_per_px, cy + 0.5 * ph * m_per_px);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut c = ChartBuilder::on(&root)
            .caption(
                "Track: GNSS fixes and the solution (outages highlighted)",
                ("sans-serif", 18),
            )
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        c.configure_mesh()
            .x_desc("east [m]")
            .y_desc("north [m]")
            .draw()
            .map_err(err)?;
        let blue = RGBColor(30, 100, 200);
        let orange = RGBColor(240, 150, 30);
        let red = RGBColor(200, 40, 40);
        c.draw_series(used.iter().map(|p| Circle::new(*p, 2, blue.filled())))
            .map_err(err)?
            .label("GNSS fixes (used)")
            .legend(move |(x, y)| Circle::new((x + 9, y), 3, blue.filled()));
        if !held.is_empty() {
            c.draw_series(held.iter().map(|p| Circle::new(*p, 2, orange.filled())))
                .map_err(err)?
                .label("GNSS fixes withheld (outages)")
                .legend(move |(x, y)| Circle::new((x + 9, y), 3, orange.filled()));
        }
        c.draw_series(LineSeries::new(sol.iter().map(|p| (p.0, p.1)), BLACK))
            .map_err(err)?
            .label("solution")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK));
        // Each outage's solution as one thick red segment run.
        let mut runs: Vec<Vec<(f64, f64)>> = vec![];
        let mut prev = false;
        for p in &sol {
            if p.2 {
                if !prev {
                    runs.push(vec![]);
                }
                if let Some(r) = runs.last_mut() {
                    r.push((p.0, p.1));
                }
            }
            prev = p.2;
        }
        for (i, r) in runs.into_iter().enumerate() {
            let s = c
                .draw_series(LineSeries::new(r, red.stroke_width(3)))
                .map_err(err)?;
            if i == 0 {
                s.label("solution during outages").legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], red.stroke_width(3))
                });
            }
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
