//! Static plots for experiment reports (ARCHITECTURE.md section 7): box plots per condition and
//! method side by side, line plots of a statistic against a parameter, grouped bar charts.
//!
//! Every plot is written twice, `STEM.png` and `STEM.svg`, from the same drawing code
//! (plotters' bitmap and SVG backends). Text uses an embedded DejaVu Sans (its licence is
//! `viz/assets/DejaVuSans.LICENSE`) through plotters' `ab_glyph` backend, so nothing here
//! needs fontconfig or any system font library. The PNG is encoded with the workspace's
//! `image` crate.
//!
//! The plots are pure functions of their input structs: the same data gives the same bytes
//! (no clock, no random colours, series drawn in input order).
//!
//! # Box plots
//! Tukey's convention (J. W. Tukey, *Exploratory Data Analysis*, 1977): the box spans the
//! first to the third quartile (linear interpolation between order statistics, the same
//! definition as numpy's default `percentile`), the bar inside it is the median, the whiskers
//! reach the most extreme samples within 1.5 IQR of the box, and samples beyond them are drawn
//! as open circles. Non-finite samples are ignored (count them yourself, e.g. as refusals).
//!
//! # Example
//! ```no_run
//! use viz::plots::{BoxPlot, write_box_plot};
//! let plot = BoxPlot {
//!     title: "rotation error".into(),
//!     x_label: "noise sigma".into(),
//!     y_label: "e_R (deg)".into(),
//!     conditions: vec!["0.05".into(), "0.1".into()],
//!     methods: vec!["ours".into(), "zhi".into()],
//!     // samples[condition][method]
//!     samples: vec![vec![vec![0.1, 0.2, 0.15], vec![0.3, 0.5]], vec![vec![0.2], vec![0.6, 0.7]]],
//!     log_y: false,
//! };
//! let files = write_box_plot(&plot, std::path::Path::new("out/rot_err"))?;
//! # Ok::<(), viz::plots::PlotError>(())
//! ```

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// The embedded font (DejaVu Sans, Bitstream Vera licence).
static FONT_TTF: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// The family name plots ask plotters for; registered to [`FONT_TTF`].
const FONT: &str = "sans-serif";
/// Size of every plot in pixels (PNG) and user units (SVG).
pub const PLOT_SIZE: (u32, u32) = (1000, 620);
/// Height of one legend entry and the legend box's padding (pixels, at label font 15).
const LEGEND_LINE_PX: f64 = 19.0;
const LEGEND_PAD_PX: f64 = 26.0;
/// A lower bound on the data area's height in a [`PLOT_SIZE`] chart (pixels): the caption,
/// margins and the tallest category labels take the rest.
const DATA_AREA_PX: f64 = 440.0;
/// Light mesh lines between two labelled ones.
const LIGHT_LINES: usize = 1;
/// Whisker reach in interquartile ranges (Tukey).
pub const WHISKER_IQR: f64 = 1.5;

/// Qualitative colour cycle for methods/series (Tableau 10), in input order.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Errors of the plot writers.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The input structs disagree with themselves (e.g. a row of the wrong length).
    #[error("bad plot input: {0}")]
    BadInput(String),
    /// plotters failed while drawing.
    #[error("drawing {path} failed: {message}")]
    Draw {
        /// The file being drawn.
        path: PathBuf,
        /// plotters' message.
        message: String,
    },
    /// The PNG could not be encoded or written.
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The encoder's or the file system's message.
        message: String,
    },
    /// The embedded font was rejected (never expected).
    #[error("the embedded font could not be registered")]
    Font,
}

/// The two files a plot writer made.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlotFiles {
    /// `STEM.png`.
    pub png: PathBuf,
    /// `STEM.svg`.
    pub svg: PathBuf,
}

/// Box plots of samples per condition (x axis groups) and method (side by side in a group).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoxPlot {
    /// Caption above the chart.
    pub title: String,
    /// What the conditions are (x axis description).
    pub x_label: String,
    /// What the samples are, with unit (y axis description).
    pub y_label: String,
    /// Condition names, left to right.
    pub conditions: Vec<String>,
    /// Method names (legend), one colour each.
    pub methods: Vec<String>,
    /// `samples[condition][method]`: the samples (any order; non-finite ones ignored).
    pub samples: Vec<Vec<Vec<f64>>>,
    /// A logarithmic y axis (for errors that span orders of magnitude: one diverged estimate
    /// would flatten every other box on a linear axis); samples <= 0 are then ignored.
    pub log_y: bool,
}

/// One line of a [`LinePlot`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Line {
    /// Legend name.
    pub name: String,
    /// `(x, y)` points, drawn in the given order with a marker each.
    pub points: Vec<(f64, f64)>,
    /// Optional shaded band `(x, low, high)` (e.g. quartiles), same x order as `points`.
    pub band: Vec<(f64, f64, f64)>,
}

/// A line plot of a statistic (e.g. the median) against a parameter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinePlot {
    /// Caption above the chart.
    pub title: String,
    /// The parameter, with unit.
    pub x_label: String,
    /// The statistic, with unit.
    pub y_label: String,
    /// The lines, one colour each in order.
    pub series: Vec<Line>,
    /// A logarithmic y axis (one method orders of magnitude off flattens the others on a
    /// linear one); values <= 0 are then ignored.
    pub log_y: bool,
}

/// A grouped bar chart: one group per category, one bar per series inside it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BarChart {
    /// Caption above the chart.
    pub title: String,
    /// What the categories are.
    pub x_label: String,
    /// The value, with unit.
    pub y_label: String,
    /// Category names, left to right.
    pub categories: Vec<String>,
    /// `(series name, values[category])`; a non-finite value draws no bar.
    pub series: Vec<(String, Vec<f64>)>,
}

/// Tukey box statistics of one sample set (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxStats {
    /// Lower whisker end (smallest sample >= q1 - 1.5 IQR).
    pub whisker_low: f64,
    /// First quartile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub q3: f64,
    /// Upper whisker end (largest sample <= q3 + 1.5 IQR).
    pub whisker_high: f64,
}

/// Quantile `p` in `[0, 1]` of ascending `sorted` by linear interpolation between order
/// statistics (numpy's default, Hyndman & Fan 1996 definition 7): position `p (n - 1)`.
/// `None` when `sorted` is empty.
pub fn quantile_sorted(sorted: &[f64], p: f64) -> Option<f64> {
    let n = sorted.len();
    let last = *sorted.last()?;
    let pos = p.clamp(0.0, 1.0) * (n - 1) as f64;
    let lo = pos.floor() as usize;
    let frac = pos - lo as f64;
    let a = *sorted.get(lo)?;
    let b = sorted.get(lo + 1).copied().unwrap_or(last);
    Some(a + (b - a) * frac)
}

/// Finite samples sorted ascending (total order).
fn sorted_finite(samples: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = samples.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v
}

impl BoxStats {
    /// The Tukey statistics of the finite `samples`; `None` when there are none.
    pub fn of(samples: &[f64]) -> Option<Self> {
        let v = sorted_finite(samples);
        let q1 = quantile_sorted(&v, 0.25)?;
        let median = quantile_sorted(&v, 0.5)?;
        let q3 = quantile_sorted(&v, 0.75)?;
        let reach = WHISKER_IQR * (q3 - q1);
        let whisker_low = v.iter().copied().find(|&x| x >= q1 - reach).unwrap_or(q1);
        let whisker_high = v
            .iter()
            .rev()
            .copied()
            .find(|&x| x <= q3 + reach)
            .unwrap_or(q3);
        Some(Self {
            whisker_low,
            q1,
            median,
            q3,
            whisker_high,
        })
    }
}

/// Registers the embedded font once per process.
fn ensure_font() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE
        .get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, FONT_TTF).is_ok());
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// `[lo, hi]` padded by 5% (and widened when flat), always including 0 when `from_zero`.
fn padded(lo: f64, hi: f64, from_zero: bool) -> Range<f64> {
    let (mut lo, mut hi) = if lo.is_finite() && hi.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    };
    if from_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        hi = lo + lo.abs().max(1.0) * 0.1;
    }
    let pad = 0.05 * (hi - lo);
    let lo = if from_zero && lo >= 0.0 { lo } else { lo - pad };
    lo..hi + pad
}

/// A plot that can draw itself on any plotters backend.
trait Draw {
    /// Draws the whole plot on `root` (already sized, not yet filled).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Converts a plotters error to its message.
fn msg<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Writes `stem.svg` and `stem.png` (parent folders must exist).
fn write_plot<P: Draw>(plot: &P, stem: &Path) -> Result<PlotFiles, PlotError> {
    ensure_font()?;
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    {
        let root = SVGBackend::new(&svg, PLOT_SIZE).into_drawing_area();
        plot.draw(&root).map_err(|message| PlotError::Draw {
            path: svg.clone(),
            message,
        })?;
        root.present().map_err(|e| PlotError::Write {
            path: svg.clone(),
            message: e.to_string(),
        })?;
    }
    let (w, h) = PLOT_SIZE;
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, PLOT_SIZE).into_drawing_area();
        plot.draw(&root).map_err(|message| PlotError::Draw {
            path: png.clone(),
            message,
        })?;
        root.present().map_err(|e| PlotError::Draw {
            path: png.clone(),
            message: e.to_string(),
        })?;
    }
    let img = image::RgbImage::from_raw(w, h, buf).ok_or_else(|| PlotError::Write {
        path: png.clone(),
        message: "pixel buffer of the wrong size".into(),
    })?;
    img.save_with_format(&png, image::ImageFormat::Png)
        .map_err(|e| PlotError::Write {
            path: png.clone(),
            message: e.to_string(),
        })?;
    Ok(PlotFiles { png, svg })
}

/// Writes a [`BoxPlot`] as `stem.png` and `stem.svg`.
///
/// # Errors
/// [`PlotError::BadInput`] when `samples` is not `conditions x methods`; drawing and file
/// errors.
pub fn write_box_plot(plot: &BoxPlot, stem: &Path) -> Result<PlotFiles, PlotError> {
    if plot.samples.len() != plot.conditions.len()
        || plot
            .samples
            .iter()
            .any(|row| row.len() != plot.methods.len())
    {
        return Err(PlotError::BadInput(format!(
            "box plot {:?}: samples must be {} conditions x {} methods",
            plot.title,
            plot.conditions.len(),
            plot.methods.len()
        )));
    }
    write_plot(plot, stem)
}

/// Writes a [`LinePlot`] as `stem.png` and `stem.svg`.
///
/// # Errors
/// [`PlotError::BadInput`] when a band's length differs from its points'; drawing and file
/// errors.
pub fn write_line_plot(plot: &LinePlot, stem: &Path) -> Result<PlotFiles, PlotError> {
    if let Some(s) = plot
        .series
        .iter()
        .find(|s| !s.band.is_empty() && s.band.len() != s.points.len())
    {
        return Err(PlotError::BadInput(format!(
            "line plot {:?}: series {:?} has {} points and {} band entries",
            plot.title,
            s.name,
            s.points.len(),
            s.band.len()
        )));
    }
    write_plot(plot, stem)
}

/// Writes a [`BarChart`] as `stem.png` and `stem.svg`.
///
/// # Errors
/// [`PlotError::BadInput`] when a series has not one value per category; drawing and file
/// errors.
pub fn write_bar_chart(plot: &BarChart, stem: &Path) -> Result<PlotFiles, PlotError> {
    if let Some((name, v)) = plot
        .series
        .iter()
        .find(|(_, v)| v.len() != plot.categories.len())
    {
        return Err(PlotError::BadInput(format!(
            "bar chart {:?}: series {name:?} has {} values for {} categories",
            plot.title,
            v.len(),
            plot.categories.len()
        )));
    }
    write_plot(plot, stem)
}

/// Colour of series `i`.
fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Centre x of member `j` of `m` side by side in group `i` (groups at integers, members
/// spread over 80% of the unit width) and the member's width.
fn slot(i: usize, j: usize, m: usize) -> (f64, f64) {
    let m = m.max(1) as f64;
    let width = 0.8 / m;
    (i as f64 - 0.4 + width * (j as f64 + 0.5), width)
}

/// The x range of `n` categories centred at the integers `0..n`.
fn category_axis(n: usize) -> Range<f64> {
    -0.5..(n.max(1) as f64 - 0.5)
}

/// `r` grown at the top so that a legend of `entries` lines (upper right) lies above the data
/// and covers none of the highest boxes, bars or line points (e.g. a success rate at 100 %):
/// the data keeps the lower `1 - f` of the axis, `f` being the legend's share of the data
/// area's height.
fn with_legend_room(r: Range<f64>, entries: usize) -> Range<f64> {
    let legend_px = LEGEND_PAD_PX + LEGEND_LINE_PX * entries as f64;
    let f = (legend_px / DATA_AREA_PX).min(0.6);
    let span = r.end - r.start;
    r.start..r.start + span / (1.0 - f)
}

/// How many y labels to ask plotters for on a log10 axis `r`: the number of whole decades in
/// it when there are at least two, so that its 1-2-5 tick search lands on the decades
/// (`10^0.5` would print as 3.162); otherwise plotters' default.
fn log_label_count(r: &Range<f64>) -> usize {
    let decades = (r.end.floor() - r.start.ceil() + 1.0).max(0.0) as usize;
    if decades >= 2 {
        decades
    } else {
        DEFAULT_LABELS
    }
}

/// plotters' default number of axis labels.
const DEFAULT_LABELS: usize = 10;

/// A tick label on a linear axis: at most six decimals, trailing zeros dropped (12, not 12.0;
/// 0.3, not 0.30000000000000004).
fn plain_tick(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

/// Margin around every chart (pixels).
const CHART_MARGIN: u32 = 14;
/// Width of the y label area (pixels).
const Y_LABEL_AREA: u32 = 72;
/// Category label font size and the height of one label line (pixels).
const CATEGORY_FONT: u32 = 15;
const CATEGORY_LINE: u32 = 18;

/// Category names broken into lines at spaces so that no line is wider than `max_width`
/// (as `width` measures it); a single word wider than that stays on its own line.
fn wrap_labels(names: &[String], max_width: f64, width: impl Fn(&str) -> f64) -> Vec<Vec<String>> {
    names
        .iter()
        .map(|name| {
            let mut lines: Vec<String> = Vec::new();
            for word in name.split_whitespace() {
                match lines.last_mut() {
                    Some(line) if width(&format!("{line} {word}")) <= max_width => {
                        line.push(' ');
                        line.push_str(word);
                    }
                    _ => lines.push(word.to_string()),
                }
            }
            if lines.is_empty() {
                lines.push(String::new());
            }
            lines
        })
        .collect()
}

/// The category labels of a plot with `names` on `root`, wrapped to the room each category
/// has along the x axis, and the label area height they need below the axis.
fn category_labels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    names: &[String],
) -> (Vec<Vec<String>>, u32) {
    let font = TextStyle::from((FONT, CATEGORY_FONT).into_font());
    let plot_width = root
        .dim_in_pixel()
        .0
        .saturating_sub(2 * CHART_MARGIN + Y_LABEL_AREA);
    // 90% of a category's width, so neighbours keep a gap.
    let room = 0.9 * f64::from(plot_width) / names.len().max(1) as f64;
    let width = |text: &str| {
        root.estimate_text_size(text, &font)
            .map_or(f64::INFINITY, |(w, _)| f64::from(w))
    };
    let lines = wrap_labels(names, room, width);
    let deepest = lines.iter().map(Vec::len).max().unwrap_or(1) as u32;
    // Room for the lines plus the axis description below them.
    (lines, 30 + CATEGORY_LINE * deepest)
}

/// Writes category `i`'s label lines under the x axis at `x = i` (plotters' numeric axes
/// cannot place labels at chosen positions, so the mesh draws none and these go on the root).
fn draw_category_labels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    labels: &[Vec<String>],
    y_axis: f64,
) -> Result<(), String> {
    let style = TextStyle::from((FONT, CATEGORY_FONT).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Top));
    for (i, lines) in labels.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(i as f64, y_axis));
        for (k, line) in lines.iter().enumerate() {
            let y = py + 6 + (CATEGORY_LINE as i32) * k as i32;
            root.draw(&Text::new(line.as_str(), (px, y), style.clone()))
                .map_err(msg)?;
        }
    }
    Ok(())
}

/// A y tick label in the samples' units for a log10 axis value: three significant digits
/// (a decade prints exactly: 1, 0.01, 1e9).
fn log_tick(v: f64) -> String {
    let x = 10f64.powf(v);
    let decade = (v - v.round()).abs() < 1e-9;
    if (1e-3..1e4).contains(&x) {
        let decimals = (2 - x.log10().floor() as i32).max(0) as usize;
        let s = format!("{x:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            s
        }
    } else if decade {
        format!("{x:.0e}")
    } else {
        format!("{x:.2e}")
    }
}

/// `y` as drawn on the y axis: log10 of it on a log axis (`None` for y <= 0 there).
fn axis_y(y: f64, log_y: bool) -> Option<f64> {
    match (log_y, y > 0.0) {
        (false, _) => Some(y),
        (true, true) => Some(y.log10()),
        (true, false) => None,
    }
}

impl Draw for BoxPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(msg)?;
        // On a log axis every coordinate is log10 of the sample.
        let samples: Vec<Vec<Vec<f64>>> = if self.log_y {
            self.samples
                .iter()
                .map(|row| {
                    row.iter()
                        .map(|s| s.iter().filter(|x| **x > 0.0).map(|x| x.log10()).collect())
                        .collect()
                })
                .collect()
        } else {
            self.samples.clone()
        };
        let stats: Vec<Vec<Option<BoxStats>>> = samples
            .iter()
            .map(|row| row.iter().map(|s| BoxStats::of(s)).collect())
            .collect();
        let (lo, hi) = samples
            .iter()
            .flatten()
            .flatten()
            .filter(|x| x.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        let xr = category_axis(self.conditions.len());
        let yr = with_legend_room(padded(lo, hi, lo >= 0.0 && !self.log_y), self.methods.len());
        let (labels, label_area) = category_labels(root, &self.conditions);
        let y_desc = if self.log_y {
            format!("{} (log scale)", self.y_label)
        } else {
            self.y_label.clone()
        };
        let y_tick = |v: &f64| {
            if self.log_y {
                log_tick(*v)
            } else {
                plain_tick(*v)
            }
        };
        let y_labels = if self.log_y {
            log_label_count(&yr)
        } else {
            DEFAULT_LABELS
        };
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, 24))
            .margin(CHART_MARGIN)
            .x_label_area_size(label_area)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(xr, yr.clone())
            .map_err(msg)?;
        chart
            .configure_mesh()
            .max_light_lines(LIGHT_LINES)
            .disable_x_mesh()
            .x_desc(&self.x_label)
            .y_desc(&y_desc)
            .y_label_formatter(&y_tick)
            .y_labels(y_labels)
            .x_labels(0)
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(msg)?;
        draw_category_labels(root, &chart, &labels, yr.start)?;
        let m = self.methods.len();
        for (j, name) in self.methods.iter().enumerate() {
            let c = colour(j);
            let mut elements: Vec<DynElement<'static, DB, (f64, f64)>> = Vec::new();
            for (i, row) in stats.iter().enumerate() {
                let Some(Some(s)) = row.get(j) else { continue };
                let (x, w) = slot(i, j, m);
                let (l, r) = (x - 0.4 * w, x + 0.4 * w);
                let cap = 0.2 * w;
                elements
                    .push(Rectangle::new([(l, s.q1), (r, s.q3)], c.mix(0.35).filled()).into_dyn());
                elements.push(Rectangle::new([(l, s.q1), (r, s.q3)], c.stroke_width(2)).into_dyn());
                elements.push(
                    PathElement::new(vec![(l, s.median), (r, s.median)], BLACK.stroke_width(3))
                        .into_dyn(),
                );
                for (from, to) in [(s.q1, s.whisker_low), (s.q3, s.whisker_high)] {
                    elements.push(
                        PathElement::new(vec![(x, from), (x, to)], c.stroke_width(2)).into_dyn(),
                    );
                    elements.push(
                        PathElement::new(vec![(x - cap, to), (x + cap, to)], c.stroke_width(2))
                            .into_dyn(),
                    );
                }
                let samples = samples
                    .get(i)
                    .and_then(|r| r.get(j))
                    .map(Vec::as_slice)
                    .unwrap_or_default();
                for &y in samples {
                    if y.is_finite() && (y < s.whisker_low || y > s.whisker_high) {
                        elements.push(Circle::new((x, y), 3, c.stroke_width(1)).into_dyn());
                    }
                }
            }
            chart
                .draw_series(elements)
                .map_err(msg)?
                .label(name.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], c.filled()));
        }
        if m > 0 {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 15))
                .draw()
                .map_err(msg)?;
        }
        Ok(())
    }
}

impl Draw for LinePlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(msg)?;
        let log_y = self.log_y;
        let xs = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0));
        let ys = self.series.iter().flat_map(|s| {
            s.points
                .iter()
                .map(|p| p.1)
                .chain(s.band.iter().flat_map(|b| [b.1, b.2]))
                .filter_map(|y| axis_y(y, log_y))
        });
        let range = |it: &mut dyn Iterator<Item = f64>| {
            it.filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                    (l.min(v), h.max(v))
                })
        };
        let (x0, x1) = range(&mut xs.into_iter());
        let (y0, y1) = range(&mut ys.into_iter());
        let yr = with_legend_room(padded(y0, y1, y0 >= 0.0 && !log_y), self.series.len());
        let (y_desc, y_labels) = if log_y {
            (
                format!("{} (log scale)", self.y_label),
                log_label_count(&yr),
            )
        } else {
            (self.y_label.clone(), DEFAULT_LABELS)
        };
        let y_tick = |v: &f64| if log_y { log_tick(*v) } else { plain_tick(*v) };
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, 24))
            .margin(CHART_MARGIN)
            .x_label_area_size(48)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(padded(x0, x1, false), yr)
            .map_err(msg)?;
        chart
            .configure_mesh()
            .max_light_lines(LIGHT_LINES)
            .x_desc(&self.x_label)
            .y_desc(&y_desc)
            .x_label_formatter(&|v| plain_tick(*v))
            .y_label_formatter(&y_tick)
            .y_labels(y_labels)
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(msg)?;
        for (j, s) in self.series.iter().enumerate() {
            let c = colour(j);
            if !s.band.is_empty() {
                let poly: Vec<(f64, f64)> = s
                    .band
                    .iter()
                    .map(|b| (b.0, b.2))
                    .chain(s.band.iter().rev().map(|b| (b.0, b.1)))
                    .filter_map(|(x, y)| Some((x, axis_y(y, log_y)?)))
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .collect();
                chart
                    .draw_series(std::iter::once(Polygon::new(poly, c.mix(0.18).filled())))
                    .map_err(msg)?;
            }
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter_map(|&(x, y)| Some((x, axis_y(y, log_y)?)))
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect();
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))
                .map_err(msg)?;
            chart
                .draw_series(plotters::series::LineSeries::new(pts, c.stroke_width(2)))
                .map_err(msg)?
                .label(s.name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(3))
                });
        }
        if !self.series.is_empty() {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 15))
                .draw()
                .map_err(msg)?;
        }
        Ok(())
    }
}

impl Draw for BarChart {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(msg)?;
        let (lo, hi) = self
            .series
            .iter()
            .flat_map(|(_, v)| v.iter())
            .filter(|v| v.is_finite())
            .fold((0.0f64, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        let xr = category_axis(self.categories.len());
        let yr = with_legend_room(padded(lo, hi, true), self.series.len());
        let (labels, label_area) = category_labels(root, &self.categories);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, 24))
            .margin(CHART_MARGIN)
            .x_label_area_size(label_area)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(xr, yr.clone())
            .map_err(msg)?;
        chart
            .configure_mesh()
            .max_light_lines(LIGHT_LINES)
            .disable_x_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .y_label_formatter(&|v| plain_tick(*v))
            .x_labels(0)
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(msg)?;
        draw_category_labels(root, &chart, &labels, yr.start)?;
        let m = self.series.len();
        for (j, (name, values)) in self.series.iter().enumerate() {
            let c = colour(j);
            let bars: Vec<Rectangle<(f64, f64)>> = values
                .iter()
                .enumerate()
                .filter(|(_, v)| v.is_finite())
                .map(|(i, &v)| {
                    let (x, w) = slot(i, j, m);
                    Rectangle::new([(x - 0.45 * w, 0.0), (x + 0.45 * w, v)], c.filled())
                })
                .collect();
            chart
                .draw_series(bars)
                .map_err(msg)?
                .label(name.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], c.filled()));
        }
        if m > 0 {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 15))
                .draw()
                .map_err(msg)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quartiles_match_numpy_linear() {
        // numpy.percentile([1, 2, 3, 4, 10], [25, 50, 75]) = [2, 3, 4]
        let s = BoxStats::of(&[10.0, 1.0, 3.0, 2.0, 4.0, f64::NAN]).expect("stats");
        assert_eq!((s.q1, s.median, s.q3), (2.0, 3.0, 4.0));
        // IQR 2 -> upper reach 7: 10 is an outlier, the whisker stops at 4.
        assert_eq!((s.whisker_low, s.whisker_high), (1.0, 4.0));
        assert_eq!(quantile_sorted(&[0.0, 1.0], 0.25), Some(0.25));
        assert!(BoxStats::of(&[f64::NAN]).is_none());
    }

    #[test]
    fn long_category_labels_wrap_at_spaces_to_fit_their_slot() {
        let names: Vec<String> = ["none", "0.5 deg + 3 mm", "trans 10 mm", "verylongword"]
            .map(String::from)
            .to_vec();
        // One unit per character: a slot 9 characters wide.
        let lines = wrap_labels(&names, 9.0, |t| t.chars().count() as f64);
        assert_eq!(lines[0], ["none"]);
        assert_eq!(lines[1], ["0.5 deg +", "3 mm"]);
        assert_eq!(lines[2], ["trans 10", "mm"]);
        assert_eq!(lines[3], ["verylongword"]);
        assert!(
            lines
                .iter()
                .flatten()
                .all(|l| l.len() <= 9 || !l.contains(' '))
        );
    }

    #[test]
    fn writes_png_and_svg_that_parse() {
        let dir = tempfile::tempdir().expect("tempdir");
        let plot = BoxPlot {
            title: "t".into(),
            x_label: "sigma".into(),
            y_label: "deg".into(),
            conditions: vec!["a".into(), "b".into()],
            methods: vec!["ours".into(), "zhi".into()],
            samples: vec![
                vec![vec![1.0, 2.0, 3.0, 9.0], vec![2.0]],
                vec![vec![], vec![0.5, 0.7]],
            ],
            log_y: false,
        };
        let f = write_box_plot(&plot, &dir.path().join("box")).expect("box");
        let img = image::open(&f.png).expect("png").to_rgb8();
        assert_eq!(img.dimensions(), PLOT_SIZE);
        // Something besides the white background and the black axes was drawn (the boxes).
        assert!(img.pixels().any(|p| p.0 == [31, 119, 180]));
        let svg = std::fs::read_to_string(&f.svg).expect("svg");
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("ours") && svg.contains("sigma"));

        let line = LinePlot {
            title: "l".into(),
            x_label: "motions".into(),
            y_label: "mm".into(),
            series: vec![Line {
                name: "ours".into(),
                points: vec![(12.0, 3.0), (14.0, 2.0)],
                band: vec![(12.0, 2.0, 4.0), (14.0, 1.0, 2.5)],
            }],
            log_y: false,
        };
        let f = write_line_plot(&line, &dir.path().join("line")).expect("line");
        assert!(image::open(&f.png).is_ok());
        let bars = BarChart {
            title: "b".into(),
            x_label: "pair set".into(),
            y_label: "rate".into(),
            categories: vec!["sim".into()],
            series: vec![
                ("orb-gms".into(), vec![0.9]),
                ("orb-bf".into(), vec![f64::NAN]),
            ],
        };
        let f = write_bar_chart(&bars, &dir.path().join("bars")).expect("bars");
        assert!(image::open(&f.png).is_ok());
        // Same input, same bytes.
        let again = write_bar_chart(&bars, &dir.path().join("bars2")).expect("bars");
        assert_eq!(
            std::fs::read(&f.png).expect("read"),
            std::fs::read(&again.png).expect("read")
        );
    }

    #[test]
    fn log_axis_keeps_small_boxes_visible_beside_a_diverged_sample() {
        let dir = tempfile::tempdir().expect("tempdir");
        let plot = BoxPlot {
            title: "e_t".into(),
            x_label: "sigma".into(),
            y_label: "mm".into(),
            conditions: vec!["a".into()],
            methods: vec!["ours".into(), "diverged".into()],
            samples: vec![vec![vec![0.5, 0.6, 0.7, 0.8], vec![1e9, 2e9, 0.0]]],
            log_y: true,
        };
        let f = write_box_plot(&plot, &dir.path().join("log")).expect("box");
        let svg = std::fs::read_to_string(&f.svg).expect("svg");
        assert!(
            svg.contains("(log scale)"),
            "the axis says it is logarithmic"
        );
        // Ticks are in the samples' units: the small box's range and the diverged one's.
        let texts: Vec<&str> = svg.lines().map(str::trim).collect();
        assert!(texts.contains(&"1") && texts.contains(&"1e8"), "{texts:?}");
        assert_eq!(log_tick(0.0), "1");
        assert_eq!(log_tick(-2.0), "0.01");
        assert_eq!(log_tick(9.0), "1e9");
        // Only decades are labelled when the axis spans two or more.
        let ticks: Vec<f64> = texts.iter().filter_map(|t| t.parse::<f64>().ok()).collect();
        assert!(ticks.len() >= 5, "{ticks:?}");
        for t in ticks {
            let e = t.log10();
            assert!((e - e.round()).abs() < 1e-9, "tick {t} is no decade");
        }
    }

    #[test]
    fn log_ticks_are_decades_or_three_digits() {
        assert_eq!(log_label_count(&(-3.6..1.7)), 5);
        assert_eq!(log_label_count(&(0.2..1.5)), DEFAULT_LABELS);
        // Between decades (an axis under two decades wide): three significant digits.
        assert_eq!(log_tick(3.5), "3162");
        assert_eq!(log_tick(0.1), "1.26");
        assert_eq!(log_tick(-1.5), "0.0316");
        assert_eq!(log_tick(-3.5), "3.16e-4");
        assert_eq!(plain_tick(12.0), "12");
        assert_eq!(plain_tick(0.1 + 0.2), "0.3");
        assert_eq!(plain_tick(-0.0000001), "0");
    }

    #[test]
    fn the_legend_covers_no_bar() {
        // The matchers' chart: six series with long names, three sets, every bar at the
        // same height, so the last set's bars stand under the legend. Its background is white
        // at 85 %: a bar behind it would show as a pale tint of its colour.
        let dir = tempfile::tempdir().expect("tempdir");
        let names = [
            "orb-gms",
            "orb-bf",
            "sift",
            "akaze",
            "orb-gms-retain-best",
            "opencv-orb-gms",
        ];
        let bars = BarChart {
            title: "b".into(),
            x_label: "set".into(),
            y_label: "rate".into(),
            categories: vec!["sim".into(), "shecar".into(), "warp".into()],
            series: names.iter().map(|n| ((*n).into(), vec![1.0; 3])).collect(),
        };
        let f = write_bar_chart(&bars, &dir.path().join("bars")).expect("bars");
        let img = image::open(&f.png).expect("png").to_rgb8();
        let tint = |c: RGBColor| {
            [c.0, c.1, c.2].map(|v| (0.85 * 255.0 + 0.15 * f64::from(v)).round() as i32)
        };
        for c in &PALETTE[..names.len()] {
            let t = tint(*c);
            let seen = img.pixels().filter(|p| {
                p.0.iter()
                    .zip(t)
                    .all(|(&v, w)| (i32::from(v) - w).abs() <= 2)
            });
            assert_eq!(seen.count(), 0, "a bar of {c:?} shows through the legend");
        }
    }

    #[test]
    fn rejects_ragged_input() {
        let plot = BoxPlot {
            conditions: vec!["a".into()],
            methods: vec!["x".into(), "y".into()],
            samples: vec![vec![vec![1.0]]],
            ..BoxPlot::default()
        };
        assert!(matches!(
            write_box_plot(&plot, Path::new("/nonexistent/x")),
            Err(PlotError::BadInput(_))
        ));
    }
}
