//! A tiny SVG plot writer for measurement reports: line and scatter series on linear or log10 axes, with ticks,
//! tick labels, axis labels, a legend and a title. Pure Rust, no dependencies.
//!
//! ```
//! let svg = plot::Plot::new("error against λ")
//!     .x_axis("λ", plot::Scale::Log10)
//!     .y_axis("max error", plot::Scale::Log10)
//!     .line("paper", vec![(0.01, 0.1), (1.0, 0.02), (1e4, 0.05)])
//!     .scatter("ours", vec![(0.01, 0.004), (1.0, 0.002), (1e4, 0.003)])
//!     .to_svg();
//! assert!(svg.starts_with("<svg"));
//! ```
//!
//! Points that cannot be drawn (NaN, ±inf, or ≤ 0 on a log axis) are skipped; a line breaks at them rather than
//! joining across the gap, so a missing measurement is visible as a gap and never as a made-up segment.

use std::fmt::Write as _;
use std::path::Path;

/// How an axis maps data to pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    /// Base-10 logarithmic; ticks at decades (and at 2 and 5 when the range spans less than two decades).
    Log10,
}

/// Where the legend box sits inside the plot area.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    TopRight,
    TopLeft,
    BottomRight,
    BottomLeft,
    Hidden,
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    Line,
    Scatter,
    /// A line with a marker at each point.
    LineMarkers,
}

/// One named series of (x, y) points.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
    /// Any SVG colour; `None` takes the next colour of the palette.
    pub color: Option<String>,
    pub dashed: bool,
}

impl Series {
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Self { name: name.into(), points, style, color: None, dashed: false }
    }
    pub fn color(mut self, c: impl Into<String>) -> Self {
        self.color = Some(c.into());
        self
    }
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
}

#[derive(Clone, Debug)]
struct Axis {
    label: String,
    scale: Scale,
    range: Option<(f64, f64)>,
}

/// Colour-blind-safe palette (Okabe–Ito).
const PALETTE: [&str; 8] = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442"];

/// Margins of the plot area inside the picture, in pixels.
const LEFT: f64 = 78.0;
const RIGHT: f64 = 24.0;
const TOP: f64 = 44.0;
const BOTTOM: f64 = 58.0;

/// A plot under construction; `to_svg` renders it.
#[derive(Clone, Debug)]
pub struct Plot {
    title: String,
    x: Axis,
    y: Axis,
    series: Vec<Series>,
    width: f64,
    height: f64,
    legend: Legend,
}

/// A tick: data value and its label.
#[derive(Clone, Debug, PartialEq)]
pub struct Tick {
    pub value: f64,
    pub label: String,
}

/// The resolved mapping of one axis: data range after padding/rounding, and the pixel interval it fills.
#[derive(Clone, Copy, Debug)]
pub struct AxisMap {
    pub scale: Scale,
    pub lo: f64,
    pub hi: f64,
    pub px_lo: f64,
    pub px_hi: f64,
}

impl AxisMap {
    fn t(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => v,
            Scale::Log10 => v.log10(),
        }
    }
    /// Pixel coordinate of data value `v` (None when `v` cannot be drawn on this axis).
    pub fn to_px(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.scale == Scale::Log10 && v <= 0.0) {
            return None;
        }
        let (a, b) = (self.t(self.lo), self.t(self.hi));
        let u = (self.t(v) - a) / (b - a);
        Some(self.px_lo + u * (self.px_hi - self.px_lo))
    }
}

impl Plot {
    pub fn new(title: impl Into<String>) -> Self {
        let axis = |l: &str| Axis { label: l.into(), scale: Scale::Linear, range: None };
        Self {
            title: title.into(),
            x: axis("x"),
            y: axis("y"),
            series: Vec::new(),
            width: 720.0,
            height: 450.0,
            legend: Legend::TopRight,
        }
    }
    pub fn size(mut self, width: f64, height: f64) -> Self {
        self.width = width.max(LEFT + RIGHT + 50.0);
        self.height = height.max(TOP + BOTTOM + 50.0);
        self
    }
    pub fn x_axis(mut self, label: impl Into<String>, scale: Scale) -> Self {
        self.x.label = label.into();
        self.x.scale = scale;
        self
    }
    pub fn y_axis(mut self, label: impl Into<String>, scale: Scale) -> Self {
        self.y.label = label.into();
        self.y.scale = scale;
        self
    }
    pub fn legend(mut self, at: Legend) -> Self {
        self.legend = at;
        self
    }
    /// Fix the x range instead of fitting it to the data.
    pub fn x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x.range = Some((lo, hi));
        self
    }
    /// Fix the y range instead of fitting it to the data.
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y.range = Some((lo, hi));
        self
    }
    pub fn series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }
    pub fn line(self, name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        self.series(Series::new(name, points, Style::Line))
    }
    pub fn scatter(self, name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        self.series(Series::new(name, points, Style::Scatter))
    }

    fn drawable(&self, p: (f64, f64)) -> bool {
        let ok = |v: f64, s: Scale| v.is_finite() && (s == Scale::Linear || v > 0.0);
        ok(p.0, self.x.scale) && ok(p.1, self.y.scale)
    }

    fn resolve(&self, axis: &Axis, pick: impl Fn((f64, f64)) -> f64, px_lo: f64, px_hi: f64) -> AxisMap {
        let (lo, hi) = match axis.range {
            Some((lo, hi)) if lo < hi && (axis.scale == Scale::Linear || lo > 0.0) => (lo, hi),
            _ => {
                let mut lo = f64::INFINITY;
                let mut hi = f64::NEG_INFINITY;
                for s in &self.series {
                    for &p in s.points.iter().filter(|&&p| self.drawable(p)) {
                        lo = lo.min(pick(p));
                        hi = hi.max(pick(p));
                    }
                }
                nice_range(lo, hi, axis.scale)
            }
        };
        AxisMap { scale: axis.scale, lo, hi, px_lo, px_hi }
    }

    /// The pixel mapping of the x and y axes as `to_svg` draws them.
    pub fn layout(&self) -> (AxisMap, AxisMap) {
        let x = self.resolve(&self.x, |p| p.0, LEFT, self.width - RIGHT);
        let y = self.resolve(&self.y, |p| p.1, self.height - BOTTOM, TOP);
        (x, y)
    }

    /// Render to an SVG document.
    pub fn to_svg(&self) -> String {
        let (xm, ym) = self.layout();
        let (w, h) = (self.width, self.height);
        let (x0, x1, y0, y1) = (xm.px_lo, xm.px_hi, ym.px_hi, ym.px_lo);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect x="0" y="0" width="{w}" height="{h}" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{}" y="24" text-anchor="middle" font-size="15" font-weight="bold">{}</text>"#,
            w / 2.0,
            escape(&self.title)
        );

        // Grid and ticks.
        for t in ticks(xm.lo, xm.hi, xm.scale) {
            let Some(px) = xm.to_px(t.value) else { continue };
            let _ = writeln!(s, r##"<line x1="{px:.2}" y1="{y0}" x2="{px:.2}" y2="{y1}" stroke="#e0e0e0"/>"##);
            let _ = writeln!(s, r#"<line x1="{px:.2}" y1="{y1}" x2="{px:.2}" y2="{}" stroke="black"/>"#, y1 + 5.0);
            let _ = writeln!(
                s,
                r#"<text class="xtick" x="{px:.2}" y="{}" text-anchor="middle">{}</text>"#,
                y1 + 19.0,
                escape(&t.label)
            );
        }
        for t in ticks(ym.lo, ym.hi, ym.scale) {
            let Some(py) = ym.to_px(t.value) else { continue };
            let _ = writeln!(s, r##"<line x1="{x0}" y1="{py:.2}" x2="{x1}" y2="{py:.2}" stroke="#e0e0e0"/>"##);
            let _ = writeln!(s, r#"<line x1="{}" y1="{py:.2}" x2="{x0}" y2="{py:.2}" stroke="black"/>"#, x0 - 5.0);
            let _ = writeln!(
                s,
                r#"<text class="ytick" x="{}" y="{:.2}" text-anchor="end">{}</text>"#,
                x0 - 8.0,
                py + 4.0,
                escape(&t.label)
            );
        }
        let _ = writeln!(
            s,
            r#"<rect x="{x0}" y="{y0}" width="{}" height="{}" fill="none" stroke="black"/>"#,
            x1 - x0,
            y1 - y0
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            (x0 + x1) / 2.0,
            h - 14.0,
            escape(&self.x.label)
        );
        let (ly, lx) = ((y0 + y1) / 2.0, 18.0);
        let _ = writeln!(
            s,
            r#"<text x="{lx}" y="{ly}" text-anchor="middle" transform="rotate(-90 {lx} {ly})">{}</text>"#,
            escape(&self.y.label)
        );

        // Series, clipped here rather than with an SVG clipPath, which some renderers ignore.
        let _ = writeln!(s, "<g>");
        for (i, se) in self.series.iter().enumerate() {
            let color = se.color.clone().unwrap_or_else(|| PALETTE[i % PALETTE.len()].to_string());
            let color = escape(&color);
            let dash = if se.dashed { r#" stroke-dasharray="6 4""# } else { "" };
            if matches!(se.style, Style::Line | Style::LineMarkers) {
                for seg in segments(&se.points, |p| self.drawable(p)) {
                    let px: Vec<(f64, f64)> =
                        seg.iter().filter_map(|&(x, y)| Some((xm.to_px(x)?, ym.to_px(y)?))).collect();
                    for run in clip_polyline(&px, (x0, y0, x1, y1)) {
                        let pts: Vec<String> = run.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
                        let _ = writeln!(
                            s,
                            r#"<polyline fill="none" stroke="{color}" stroke-width="1.8"{dash} points="{}"/>"#,
                            pts.join(" ")
                        );
                    }
                }
            }
            if matches!(se.style, Style::Scatter | Style::LineMarkers)
                || (se.style == Style::Line && se.points.iter().filter(|&&p| self.drawable(p)).count() == 1)
            {
                let r = if se.style == Style::Scatter { 2.6 } else { 3.0 };
                for &(x, y) in &se.points {
                    let inside =
                        |px: f64, py: f64| px >= x0 - 0.01 && px <= x1 + 0.01 && py >= y0 - 0.01 && py <= y1 + 0.01;
                    if let (Some(px), Some(py)) = (xm.to_px(x), ym.to_px(y)) {
                        if !inside(px, py) {
                            continue;
                        }
                        let _ = writeln!(s, r#"<circle cx="{px:.2}" cy="{py:.2}" r="{r}" fill="{color}"/>"#);
                    }
                }
            }
        }
        let _ = writeln!(s, "</g>");

        // Legend inside the plot area.
        if !self.series.is_empty() && self.legend != Legend::Hidden {
            let longest = self.series.iter().map(|se| se.name.chars().count()).max().unwrap_or(0) as f64;
            let lw = 40.0 + 7.0 * longest;
            let lh = 8.0 + 18.0 * self.series.len() as f64;
            let lx = match self.legend {
                Legend::TopLeft | Legend::BottomLeft => x0 + 8.0,
                _ => x1 - lw - 8.0,
            };
            let ly = match self.legend {
                Legend::BottomLeft | Legend::BottomRight => y1 - lh - 8.0,
                _ => y0 + 8.0,
            };
            let _ = writeln!(
                s,
                r##"<rect x="{lx}" y="{ly}" width="{lw}" height="{lh}" fill="white" fill-opacity="0.85" stroke="#888"/>"##
            );
            for (i, se) in self.series.iter().enumerate() {
                let color = se.color.clone().unwrap_or_else(|| PALETTE[i % PALETTE.len()].to_string());
                let color = escape(&color);
                let cy = ly + 14.0 + 18.0 * i as f64;
                if se.style == Style::Scatter {
                    let _ = writeln!(s, r#"<circle cx="{}" cy="{cy}" r="3" fill="{color}"/>"#, lx + 17.0);
                } else {
                    let dash = if se.dashed { r#" stroke-dasharray="6 4""# } else { "" };
                    let _ = writeln!(
                        s,
                        r#"<line x1="{}" y1="{cy}" x2="{}" y2="{cy}" stroke="{color}" stroke-width="1.8"{dash}/>"#,
                        lx + 6.0,
                        lx + 28.0
                    );
                }
                let _ = writeln!(s, r#"<text x="{}" y="{}">{}</text>"#, lx + 34.0, cy + 4.0, escape(&se.name));
            }
        }
        s.push_str("</svg>\n");
        s
    }

    /// Render and write to `path`.
    pub fn write(&self, path: impl AsRef<Path>) -> std::io::Result<()> {
        std::fs::write(path, self.to_svg())
    }
}

/// Split into runs of drawable points.
fn segments(points: &[(f64, f64)], ok: impl Fn((f64, f64)) -> bool) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for &p in points {
        if ok(p) {
            out.last_mut().unwrap().push(p);
        } else if !out.last().unwrap().is_empty() {
            out.push(Vec::new());
        }
    }
    out.retain(|v| !v.is_empty());
    out
}

/// Clip a pixel-space polyline to the rectangle (x0, y0, x1, y1) (Liang–Barsky per segment); returns the visible
/// runs of two or more points.
fn clip_polyline(pts: &[(f64, f64)], r: (f64, f64, f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut visible = true;
        for (p, q) in [(-dx, a.0 - r.0), (dx, r.2 - a.0), (-dy, a.1 - r.1), (dy, r.3 - a.1)] {
            if p == 0.0 {
                if q < 0.0 {
                    visible = false;
                }
            } else if p < 0.0 {
                t0 = t0.max(q / p);
            } else {
                t1 = t1.min(q / p);
            }
        }
        if !visible || t0 > t1 {
            open = false;
            continue;
        }
        let pa = (a.0 + t0 * dx, a.1 + t0 * dy);
        let pb = (a.0 + t1 * dx, a.1 + t1 * dy);
        if !(open && t0 == 0.0) {
            runs.push(vec![pa]);
        }
        runs.last_mut().unwrap().push(pb);
        open = t1 == 1.0;
    }
    runs
}

/// Data range rounded outwards: to whole decades on a log axis, to the tick step on a linear one.
fn nice_range(lo: f64, hi: f64, scale: Scale) -> (f64, f64) {
    match scale {
        Scale::Log10 => {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0) {
                return (1.0, 10.0);
            }
            let (a, mut b) = (lo.log10().floor(), hi.log10().ceil());
            if b <= a {
                b = a + 1.0;
            }
            (10f64.powf(a), 10f64.powf(b))
        }
        Scale::Linear => {
            if !(lo.is_finite() && hi.is_finite()) {
                return (0.0, 1.0);
            }
            let (lo, hi) = if hi > lo {
                (lo, hi)
            } else {
                let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
                (lo - d, hi + d)
            };
            let step = nice_step((hi - lo) / 6.0);
            ((lo / step).floor() * step, (hi / step).ceil() * step)
        }
    }
}

/// 1, 2 or 5 × 10^k, at least `raw`.
fn nice_step(raw: f64) -> f64 {
    let e = raw.log10().floor();
    let base = 10f64.powf(e);
    let m = raw / base;
    let f = if m <= 1.0 {
        1.0
    } else if m <= 2.0 {
        2.0
    } else if m <= 5.0 {
        5.0
    } else {
        10.0
    };
    f * base
}

/// Ticks of an axis over [lo, hi].
pub fn ticks(lo: f64, hi: f64, scale: Scale) -> Vec<Tick> {
    let mut out = Vec::new();
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return out;
    }
    match scale {
        Scale::Log10 => {
            if lo <= 0.0 {
                return out;
            }
            let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
            let decades = b - a;
            // Label every k-th decade so that at most ~10 labels show.
            let every = (decades as f64 / 10.0).ceil().max(1.0) as i32;
            let mults: &[f64] = if hi / lo < 100.0 { &[1.0, 2.0, 5.0] } else { &[1.0] };
            for e in a..=b {
                for &m in mults {
                    let v = m * 10f64.powi(e);
                    if v < lo * (1.0 - 1e-9) || v > hi * (1.0 + 1e-9) {
                        continue;
                    }
                    if m == 1.0 && e.rem_euclid(every) != 0 {
                        continue;
                    }
                    out.push(Tick { value: v, label: log_label(m, e) });
                }
            }
        }
        Scale::Linear => {
            let step = nice_step((hi - lo) / 6.0);
            let k0 = (lo / step - 1e-9).ceil() as i64;
            let k1 = (hi / step + 1e-9).floor() as i64;
            for k in k0..=k1 {
                let v = k as f64 * step;
                out.push(Tick { value: v, label: lin_label(v, step) });
            }
        }
    }
    out
}

fn log_label(m: f64, e: i32) -> String {
    match (m as i32, e) {
        (1, 0) => "1".into(),
        (1, 1) => "10".into(),
        (1, _) => format!("1e{e}"),
        (m, 0) => format!("{m}"),
        (m, _) => format!("{m}e{e}"),
    }
}

fn lin_label(v: f64, step: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let mag = v.abs().max(step);
    if !(1e-3..1e5).contains(&mag) {
        return format!("{v:.1e}");
    }
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// Escape text for SVG content and attribute values.
pub fn escape(t: &str) -> String {
    let mut o = String::with_capacity(t.len());
    for c in t.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            c => o.push(c),
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal XML well-formedness check: balanced, properly nested tags, quoted attributes, no raw `<`/`&` in
    /// text, one root element.
    fn check_xml(s: &str) -> Result<(), String> {
        let b = s.as_bytes();
        let mut stack: Vec<String> = Vec::new();
        let mut i = 0;
        let mut roots = 0;
        while i < b.len() {
            match b[i] {
                b'<' => {
                    let end = s[i..].find('>').ok_or("unterminated tag")? + i;
                    let inner = &s[i + 1..end];
                    if let Some(name) = inner.strip_prefix('/') {
                        let top = stack.pop().ok_or(format!("close </{name}> without open"))?;
                        if top != name.trim() {
                            return Err(format!("</{name}> closes <{top}>"));
                        }
                    } else {
                        let self_close = inner.ends_with('/');
                        let body = inner.trim_end_matches('/');
                        let name: String = body.chars().take_while(|c| !c.is_whitespace()).collect();
                        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == ':') {
                            return Err(format!("bad tag name in <{inner}>"));
                        }
                        check_attrs(&body[name.len()..])?;
                        if stack.is_empty() {
                            roots += 1;
                        }
                        if !self_close {
                            stack.push(name);
                        }
                    }
                    i = end + 1;
                }
                b'&' => {
                    let end = s[i..].find(';').ok_or("bare &")? + i;
                    let ent = &s[i + 1..end];
                    if !["amp", "lt", "gt", "quot", "apos"].contains(&ent) {
                        return Err(format!("unknown entity &{ent};"));
                    }
                    i = end + 1;
                }
                b'>' => return Err("raw > in text".into()),
                c => {
                    if stack.is_empty() && !c.is_ascii_whitespace() {
                        return Err("text outside the root".into());
                    }
                    i += 1;
                }
            }
        }
        if !stack.is_empty() {
            return Err(format!("unclosed {stack:?}"));
        }
        if roots != 1 {
            return Err(format!("{roots} root elements"));
        }
        Ok(())
    }

    fn check_attrs(mut a: &str) -> Result<(), String> {
        loop {
            a = a.trim_start();
            if a.is_empty() {
                return Ok(());
            }
            let eq = a.find('=').ok_or(format!("attribute without value: {a}"))?;
            let name = &a[..eq];
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == ':') {
                return Err(format!("bad attribute name '{name}'"));
            }
            let rest = &a[eq + 1..];
            let q = rest.chars().next().ok_or("missing value")?;
            if q != '"' && q != '\'' {
                return Err(format!("unquoted attribute {name}"));
            }
            let close = rest[1..].find(q).ok_or("unterminated attribute")? + 1;
            if rest[1..close].contains('<') {
                return Err(format!("< inside attribute {name}"));
            }
            a = &rest[close + 1..];
        }
    }

    #[test]
    fn checker_rejects_malformed() {
        assert!(check_xml("<a><b></a></b>").is_err());
        assert!(check_xml("<a x=1/>").is_err());
        assert!(check_xml("<a>x & y</a>").is_err());
        assert!(check_xml("<a/><b/>").is_err());
        assert!(check_xml("<a>").is_err());
        assert!(check_xml(r#"<a x="1"><b/>t</a>"#).is_ok());
    }

    fn sample() -> Plot {
        Plot::new("ISG error <max & rms>")
            .x_axis("λ \"sharpness\"", Scale::Log10)
            .y_axis("error", Scale::Log10)
            .line(
                "paper's fit",
                (0..50).map(|i| (10f64.powf(-2.0 + i as f64 * 0.12), 0.02 + i as f64 * 1e-3)).collect(),
            )
            .series(
                Series::new(
                    "ours",
                    vec![
                        (0.01, 1e-3),
                        (0.1, 1.5e-3),
                        (f64::NAN, 1.0),
                        (1.0, 2e-3),
                        (2.0, 2.5e-3),
                        (10.0, -1.0),
                        (1e4, 3e-3),
                    ],
                    Style::LineMarkers,
                )
                .dashed(),
            )
            .scatter("samples", vec![(0.5, 0.004), (50.0, 0.01)])
    }

    #[test]
    fn svg_is_well_formed() {
        let svg = sample().to_svg();
        check_xml(&svg).unwrap_or_else(|e| panic!("{e}\n{svg}"));
        assert!(svg.contains("&lt;max &amp; rms&gt;"), "title escaped");
        assert!(svg.contains("&quot;sharpness&quot;"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "no non-finite coordinates");
        // Three legend entries, each name once in the legend.
        for name in ["paper&apos;s fit", "ours", "samples"] {
            assert_eq!(svg.matches(&format!(">{name}</text>")).count(), 1, "{name}");
        }
        // The dashed line breaks at NaN and at the negative y: two polylines of two points; the lone last point
        // is a marker only. Markers: 5 drawable points, 2 scatter points.
        assert_eq!(svg.matches("stroke-dasharray=\"6 4\" points=").count(), 2);
        assert_eq!(svg.matches("<circle").count(), 5 + 2 + 1, "5 markers, 2 scatter points, 1 legend dot");
        // Linear axes, empty plot, single point: still well formed.
        for p in [
            Plot::new("empty"),
            Plot::new("one").line("p", vec![(1.0, 1.0)]),
            Plot::new("lin").line("a", vec![(-3.0, 0.0), (7.0, 1e-4)]).x_range(-5.0, 10.0),
            Plot::new("bl").line("a", vec![(1.0, 2.0), (3.0, 4.0)]).legend(Legend::BottomLeft),
        ] {
            let svg = p.to_svg();
            check_xml(&svg).unwrap_or_else(|e| panic!("{e}\n{svg}"));
        }
    }

    #[test]
    fn log_axis_places_decades_evenly() {
        let p = Plot::new("t")
            .x_axis("x", Scale::Log10)
            .y_axis("y", Scale::Log10)
            .line("a", vec![(0.013, 2e-5), (9000.0, 0.7)]);
        let (xm, ym) = p.layout();
        // Data rounds out to whole decades.
        assert_eq!((xm.lo, xm.hi), (1e-2, 1e4));
        assert!((ym.lo - 1e-5).abs() < 1e-20 && (ym.hi - 1.0).abs() < 1e-12, "{ym:?}");
        // Six decades across the width: 10^k lands at k+2 sixths.
        let w = xm.px_hi - xm.px_lo;
        for k in -2..=4 {
            let px = xm.to_px(10f64.powi(k)).unwrap();
            let want = xm.px_lo + w * (k + 2) as f64 / 6.0;
            assert!((px - want).abs() < 1e-9, "10^{k}: {px} vs {want}");
        }
        // sqrt(10) halfway between 1 and 10; y grows upwards (pixel y falls).
        let mid = xm.to_px(10f64.sqrt()).unwrap();
        assert!((mid - (xm.to_px(1.0).unwrap() + xm.to_px(10.0).unwrap()) / 2.0).abs() < 1e-9);
        assert!(ym.to_px(1e-1).unwrap() < ym.to_px(1e-4).unwrap());
        assert_eq!(xm.to_px(0.0), None);
        assert_eq!(xm.to_px(-1.0), None);
        // Tick labels are at those positions in the SVG.
        let svg = p.to_svg();
        let t: Vec<_> = ticks(xm.lo, xm.hi, Scale::Log10).into_iter().map(|t| t.label).collect();
        assert_eq!(t, ["1e-2", "1e-1", "1", "10", "1e2", "1e3", "1e4"]);
        let px = xm.to_px(100.0).unwrap();
        assert!(svg.contains(&format!(
            r#"class="xtick" x="{px:.2}" y="{}" text-anchor="middle">1e2</text>"#,
            450.0 - 58.0 + 19.0
        )));
    }

    #[test]
    fn log_ticks_narrow_and_wide() {
        let narrow: Vec<_> = ticks(1.0, 10.0, Scale::Log10).into_iter().map(|t| t.value).collect();
        assert_eq!(narrow, [1.0, 2.0, 5.0, 10.0]);
        // 30 decades: at most ~10 labels.
        let wide = ticks(1e-15, 1e15, Scale::Log10);
        assert!(wide.len() <= 11 && wide.len() >= 6, "{}", wide.len());
    }

    #[test]
    fn lines_are_clipped_to_the_plot_area() {
        let r = (0.0, 0.0, 10.0, 10.0);
        // Inside: one run, unchanged.
        assert_eq!(
            clip_polyline(&[(1.0, 1.0), (2.0, 2.0), (3.0, 1.0)], r),
            vec![vec![(1.0, 1.0), (2.0, 2.0), (3.0, 1.0)]]
        );
        // Leaves and comes back: two runs, cut at the border.
        let runs = clip_polyline(&[(5.0, 5.0), (5.0, 15.0), (7.0, 15.0), (7.0, 5.0)], r);
        assert_eq!(runs, vec![vec![(5.0, 5.0), (5.0, 10.0)], vec![(7.0, 10.0), (7.0, 5.0)]]);
        // Entirely outside: nothing.
        assert!(clip_polyline(&[(-5.0, -5.0), (-1.0, 20.0)], r).is_empty());
        // A fixed y range cuts the drawn line; no coordinate leaves the plot area.
        let p =
            Plot::new("c").y_range(0.0, 1.0).line("s", (0..20).map(|i| (i as f64, (i as f64 - 10.0) * 0.2)).collect());
        let (_, ym) = p.layout();
        let svg = p.to_svg();
        for pl in svg.lines().filter(|l| l.starts_with("<polyline")) {
            let pts = pl.split("points=\"").nth(1).unwrap().trim_end_matches("\"/>");
            for xy in pts.split(' ') {
                let y: f64 = xy.split(',').nth(1).unwrap().parse().unwrap();
                assert!(y >= ym.px_hi - 0.01 && y <= ym.px_lo + 0.01, "{y}");
            }
        }
    }

    #[test]
    fn linear_ticks_are_nice() {
        let t: Vec<_> = ticks(0.0, 1.0, Scale::Linear).into_iter().map(|t| t.label).collect();
        assert_eq!(t, ["0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        let (lo, hi) = nice_range(0.013, 0.97, Scale::Linear);
        assert!(lo <= 0.013 && hi >= 0.97 && lo >= 0.0 && hi <= 1.0, "{lo} {hi}");
    }
}
