//! SVG charts for the measurements (`irt tradeoff`, `irt stability`, the interactive study):
//! log–log, and linear for quantities over time, written atomically.

use plotters::coord::combinators::LogCoord;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// A chart that could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[error("plotting {}: {message}", path.display())]
pub struct PlotError {
    pub path: PathBuf,
    pub message: String,
}

/// What a `draw` callback may fail with (plotters' errors, or a message).
pub type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// The chart a `draw` callback of [`log_log_svg`] gets: both axes logarithmic.
pub type LogLogChart<'a> = ChartContext<'a, SVGBackend<'a>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// The chart a `draw` callback of [`linear_svg`] gets.
pub type LinearChart<'a> = ChartContext<'a, SVGBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws a titled log–log chart with axis labels (`x_desc`, `y_desc`) over `x` × `y`, lets `draw`
/// add the data, and writes the SVG to `path` atomically.
pub fn log_log_svg(
    path: &Path,
    title: &str,
    (x, y): (Range<f64>, Range<f64>),
    axes: (&str, &str),
    draw: impl FnOnce(&mut LogLogChart<'_>) -> DrawResult,
) -> Result<(), PlotError> {
    svg(path, title, (x.log_scale(), y.log_scale()), axes, true, draw)
}

/// [`log_log_svg`] with linear axes.
pub fn linear_svg(
    path: &Path,
    title: &str,
    (x, y): (Range<f64>, Range<f64>),
    axes: (&str, &str),
    draw: impl FnOnce(&mut LinearChart<'_>) -> DrawResult,
) -> Result<(), PlotError> {
    svg(path, title, (x, y), axes, false, draw)
}

/// The one chart writer: `short_ticks` shortens the labels (log axes put ticks at values such
/// as 0.006000000000000001).
fn svg<X, Y>(
    path: &Path,
    title: &str,
    (x, y): (X, Y),
    (x_desc, y_desc): (&str, &str),
    short_ticks: bool,
    draw: impl for<'a> FnOnce(
        &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X::CoordDescType, Y::CoordDescType>>,
    ) -> DrawResult,
) -> Result<(), PlotError>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| PlotError { path: path.to_path_buf(), message: e.to_string() };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(20)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x, y)
            .map_err(|e| err(&e))?;
        let label = |v: &f64| if short_ticks { tick(*v) } else { format!("{v}") };
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(x_desc).y_desc(y_desc);
        if short_ticks {
            mesh.x_label_formatter(&label).y_label_formatter(&label);
        }
        mesh.draw().map_err(|e| err(&e))?;
        draw(&mut chart).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    crate::image::write_atomic(path, svg.as_bytes()).map_err(|e| err(&e))
}

/// A tick label with three significant digits at most.
fn tick(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn ticks_are_short() {
        assert_eq!(super::tick(0.006000000000000001), "0.006");
        assert_eq!(super::tick(1000.0), "1000");
        assert_eq!(super::tick(2.5), "2.5");
        assert_eq!(super::tick(0.00105), "0.00105");
        assert_eq!(super::tick(30.0), "30");
    }
}
