//! The report's charts (plotters): error against run time per kernel, log–log, and the
//! stability sweeps; each as SVG and PNG.

use super::{stability, Method, Report, Row};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Errors below this are drawn at it (log axes): exact results, the reference itself.
const FLOOR: f64 = 1e-9;
/// NaN and errors above this are drawn at it.
const CEIL: f64 = 10.0;

fn clampf(x: f64) -> f64 {
    if x.is_nan() {
        CEIL
    } else {
        x.clamp(FLOOR, CEIL)
    }
}

fn colour(m: Method) -> RGBColor {
    match m {
        Method::AccurateX8 => RGBColor(31, 119, 180),
        Method::FastX8 => RGBColor(23, 190, 207),
        Method::Scalar => RGBColor(44, 160, 44),
        Method::Reference => RGBColor(0, 0, 0),
        Method::Seed => RGBColor(214, 39, 40),
        Method::March(_) => RGBColor(255, 127, 14),
    }
}

fn err<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> String + '_ {
    move |e| format!("{what}: {e:?}")
}

fn fmt_log(v: &f64) -> String {
    let e = v.log10().round() as i32;
    if (v.log10() - e as f64).abs() < 1e-6 {
        format!("1e{e}")
    } else {
        String::new()
    }
}

fn error_time<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    r: &Report,
    set: &str,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err("fill"))?;
    let mut kernels: Vec<&str> = r.rows.iter().map(|x| x.kernel.as_str()).collect();
    kernels.dedup();
    let cols = 3;
    let rows_n = kernels.len().div_ceil(cols);
    let (title, body) = root.split_vertically(40);
    title
        .titled(
            &format!(
                "max |T - T_ref| against ns/ray (one thread), {set} rays ({}; orange: ray marching 4..1024 steps)",
                r.simd
            ),
            ("sans-serif", 18),
        )
        .map_err(err("title"))?;
    let areas = body.split_evenly((rows_n, cols));
    for (k, area) in kernels.iter().zip(areas) {
        let rows: Vec<&Row> = r
            .rows
            .iter()
            .filter(|x| x.kernel == *k && x.set == set)
            .collect();
        let (tmin, tmax) = rows.iter().fold((f64::MAX, 0.0f64), |(a, b), x| {
            (a.min(x.ns_1t), b.max(x.ns_1t))
        });
        let x0 = 10f64.powf(tmin.max(1e-3).log10().floor());
        let x1 = 10f64.powf(tmax.max(x0 * 10.0).log10().ceil());
        let mut ch = ChartBuilder::on(&area)
            .caption(*k, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(44)
            .build_cartesian_2d((x0..x1).log_scale(), (FLOOR..CEIL).log_scale())
            .map_err(err("chart"))?;
        ch.configure_mesh()
            .x_desc("ns/ray")
            .x_label_formatter(&fmt_log)
            .y_label_formatter(&fmt_log)
            .light_line_style(WHITE)
            .label_style(("sans-serif", 11))
            .draw()
            .map_err(err("mesh"))?;
        // Half a step of 8-bit output.
        ch.draw_series(LineSeries::new(
            [(x0, 0.5 / 255.0), (x1, 0.5 / 255.0)],
            RGBColor(180, 180, 180).stroke_width(1),
        ))
        .map_err(err("line"))?;
        let march: Vec<(f64, f64)> = rows
            .iter()
            .filter(|x| matches!(x.method, Method::March(_)))
            .map(|x| (x.ns_1t, clampf(x.t_abs.max)))
            .collect();
        ch.draw_series(LineSeries::new(
            march.clone(),
            colour(Method::March(0)).stroke_width(2),
        ))
        .map_err(err("march"))?;
        ch.draw_series(
            march
                .iter()
                .map(|&p| Circle::new(p, 3, colour(Method::March(0)).filled())),
        )
        .map_err(err("march points"))?;
        for x in rows
            .iter()
            .filter(|x| !matches!(x.method, Method::March(_)))
        {
            let c = colour(x.method);
            let p = (x.ns_1t, clampf(x.t_abs.max));
            ch.draw_series([Circle::new(p, 5, c.filled())])
                .map_err(err("point"))?
                .label(x.method.name())
                .legend(move |(a, b)| Circle::new((a, b), 4, c.filled()));
        }
        // The marching step count at the Accurate tier's max |ΔT|, and the speedup.
        if let Some(m) = r.matches.iter().find(|m| m.kernel == *k && m.set == set) {
            let text = match (m.steps, m.speedup) {
                (Some(n), Some(x)) => format!(
                    "march {}{n:.0} steps for accurate's error: {x:.0}x its time",
                    if m.extrapolated { "~" } else { "" }
                ),
                _ => "march: accurate's error not reached".to_string(),
            };
            ch.draw_series([Text::new(
                text,
                (x0 * 1.3, FLOOR * 4.0),
                ("sans-serif", 11).into_font().color(&BLACK),
            )])
            .map_err(err("march label"))?;
            ch.draw_series(LineSeries::new(
                [(x0, clampf(m.accurate_err)), (x1, clampf(m.accurate_err))],
                colour(Method::AccurateX8).mix(0.4).stroke_width(1),
            ))
            .map_err(err("accurate line"))?;
        }
        ch.configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 10))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(err("legend"))?;
    }
    root.present().map_err(err("present"))
}

fn stability_chart<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    s: &stability::Stability,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err("fill"))?;
    let (title, body) = root.split_vertically(40);
    title
        .titled(
            "relative error of tau (f32) against f64: this crate's stable form and the usual forms",
            ("sans-serif", 18),
        )
        .map_err(err("title"))?;
    let areas = body.split_evenly((1, s.sweeps.len()));
    let palette = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
    ];
    for (sw, area) in s.sweeps.iter().zip(areas) {
        let logx = sw.x.iter().all(|x| *x > 0.0);
        let caption = format!("{} ({})", sw.name, sw.setup);
        let (x0, x1) =
            sw.x.iter()
                .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(*x), b.max(*x)));
        let series = |k: usize| -> Vec<(f64, f64)> {
            sw.x.iter()
                .zip(&sw.err)
                .map(|(x, e)| (*x, clampf(e[k])))
                .collect()
        };
        macro_rules! draw {
            ($ch:expr, $xfmt:expr) => {{
                let mut ch = $ch;
                ch.configure_mesh()
                    .x_desc(sw.x_label)
                    .x_label_formatter($xfmt)
                    .y_desc("relative error of tau")
                    .y_label_formatter(&fmt_log)
                    .light_line_style(WHITE)
                    .label_style(("sans-serif", 11))
                    .draw()
                    .map_err(err("mesh"))?;
                for (k, name) in stability::FORMS.iter().enumerate() {
                    let c = palette[k];
                    ch.draw_series(LineSeries::new(series(k), c.stroke_width(2)))
                        .map_err(err("series"))?
                        .label(*name)
                        .legend(move |(a, b)| {
                            PathElement::new(vec![(a, b), (a + 16, b)], c.stroke_width(2))
                        });
                }
                ch.configure_series_labels()
                    .position(SeriesLabelPosition::UpperRight)
                    .label_font(("sans-serif", 11))
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .draw()
                    .map_err(err("legend"))?;
            }};
        }
        let mut b = ChartBuilder::on(&area);
        b.caption(caption, ("sans-serif", 13))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(50);
        if logx {
            let ch = b
                .build_cartesian_2d((x0..x1).log_scale(), (FLOOR..CEIL).log_scale())
                .map_err(err("chart"))?;
            draw!(ch, &fmt_log);
        } else {
            let ch = b
                .build_cartesian_2d(x0..x1, (FLOOR..CEIL).log_scale())
                .map_err(err("chart"))?;
            draw!(ch, &|v: &f64| format!("{v:.0}"));
        }
    }
    root.present().map_err(err("present"))
}

/// Draws every chart as SVG and PNG into `dir`; returns the files written.
pub fn draw_all(r: &Report, dir: &Path) -> Result<Vec<PathBuf>, String> {
    let mut files = vec![];
    let nk = {
        let mut k: Vec<&str> = r.rows.iter().map(|x| x.kernel.as_str()).collect();
        k.dedup();
        k.len()
    };
    let size = (1500, 40 + 380 * nk.div_ceil(3) as u32);
    for set in ["typical", "extreme"] {
        let name = format!("error_vs_time_{set}");
        let svg = dir.join(format!("{name}.svg"));
        error_time(SVGBackend::new(&svg, size).into_drawing_area(), r, set)
            .map_err(|e| format!("{}: {e}", svg.display()))?;
        let png = dir.join(format!("{name}.png"));
        error_time(BitMapBackend::new(&png, size).into_drawing_area(), r, set)
            .map_err(|e| format!("{}: {e}", png.display()))?;
        files.extend([svg, png]);
    }
    let size = (1800, 520);
    let svg = dir.join("stability.svg");
    stability_chart(
        SVGBackend::new(&svg, size).into_drawing_area(),
        &r.stability,
    )
    .map_err(|e| format!("{}: {e}", svg.display()))?;
    let png = dir.join("stability.png");
    stability_chart(
        BitMapBackend::new(&png, size).into_drawing_area(),
        &r.stability,
    )
    .map_err(|e| format!("{}: {e}", png.display()))?;
    files.extend([svg, png]);
    Ok(files)
}
