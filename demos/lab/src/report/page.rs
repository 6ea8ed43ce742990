//! The results page of a sweep with a `site` (`cargo xtask report --sweep readme` → docs/results/):
//!
//! - `index.html`: one self-contained file (images as data URIs, plots as inline SVG, no external script, style
//!   or font), per scene every technique next to both references with their error heat maps, an in-place
//!   comparison of two images (a slider and a swap button), exposure and zoom controls, the speed-against-error
//!   plot and the tables;
//! - `README.md`: the same tables in Markdown;
//! - `summary.md`: the summary table (scene × technique at its defaults: error and speed), which the report also
//!   copies into the block of the project's README.md between [`BEGIN`] and [`END`];
//! - `summary.svg` (speed against error of those techniques, every scene) and `hero.png` (the first-screen
//!   picture: one scene rendered by the hero techniques and the reference, side by side).
//!
//! Every page names the commit, the sweep and the command that produced it. A test (demos/tests/results_page.rs)
//! checks by text that what README.md shows from the sweep is what docs/results/ holds.

use super::results::{PageImage, Results, Row};
use super::sweep::{Site, Sweep};
use anyhow::{bail, Context, Result};
use base64::Engine as _;
use std::fmt::Write as _;
use std::path::Path;

/// The first line of the generated block in README.md (the rest of that line says where it comes from).
pub const BEGIN: &str = "<!-- results:summary begin";
/// The last line of the generated block.
pub const END: &str = "<!-- results:summary end -->";

/// Write every file of the page into `out` (and the summary into `site.readme`).
pub fn write(out: &Path, sweep: &Sweep, site: &Site, res: &Results, adapter: &str, command: &str) -> Result<()> {
    let commit = crate::bench::COMMIT;
    let stamp = Stamp { commit, command, adapter, sweep };
    let summary = summary_block(&stamp, site, &res.rows)?;
    let file = |name: &str, text: &str| -> Result<()> {
        let p = out.join(name);
        std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))
    };
    file("summary.md", &summary)?;
    summary_plot(site, &res.rows).write(out.join("summary.svg")).context("writing summary.svg")?;
    write_hero(&out.join("hero.png"), site, res)?;
    file("README.md", &markdown(&stamp, &summary, res))?;
    file("index.html", &html(out, &stamp, &summary, res)?)?;
    if let Some(readme) = &site.readme {
        let path = super::sweep::workspace_root().join(readme);
        let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
        let spliced = splice(&text, &summary).with_context(|| format!("{}", path.display()))?;
        std::fs::write(&path, spliced).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("copied the summary table into {}", path.display());
    }
    Ok(())
}

/// What every page says about where it comes from.
struct Stamp<'a> {
    commit: &'a str,
    command: &'a str,
    adapter: &'a str,
    sweep: &'a Sweep,
}

impl Stamp<'_> {
    fn line(&self) -> String {
        format!(
            "Generated at commit `{}` by `{}` on {} ({}×{}, references ≤ {} spp; times are ratios on this device, \
             not real-GPU milliseconds).",
            self.commit, self.command, self.adapter, self.sweep.width, self.sweep.height, self.sweep.max_spp
        )
    }
}

/// `text` with its block between [`BEGIN`] and [`END`] (both lines included) replaced by `block`, which holds
/// both markers itself.
pub fn splice(text: &str, block: &str) -> Result<String> {
    let Some(start) = text.find(BEGIN) else { bail!("no line starting with '{BEGIN}'") };
    let Some(end) = text[start..].find(END).map(|e| start + e + END.len()) else { bail!("no '{END}' after '{BEGIN}'") };
    Ok(format!("{}{}{}", &text[..start], block.trim_end(), &text[end..]))
}

/// The block between the markers of `text` (both marker lines included), as [`splice`] writes it.
pub fn block_of(text: &str) -> Option<&str> {
    let start = text.find(BEGIN)?;
    let end = start + text[start..].find(END)? + END.len();
    Some(&text[start..end])
}

fn pct(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.1}")
    } else {
        "–".into()
    }
}

fn ms(v: f64) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v < 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.0}")
    }
}

fn scenes(rows: &[Row]) -> Vec<&str> {
    let mut out: Vec<&str> = Vec::new();
    for r in rows {
        if !out.contains(&r.scene.as_str()) {
            out.push(&r.scene);
        }
    }
    out
}

/// One cell of the summary table: relative RMSE % net of noise vs the sphere proxy / vs the triangles, and the
/// shade ms (`–` where a value does not exist: a scene without blocker spheres has no sphere-proxy reference).
pub fn summary_cell(vs_spheres: f64, vs_triangles: f64, shade_ms: f64) -> String {
    format!("{} / {} % · {} ms", pct(vs_spheres), pct(vs_triangles), ms(shade_ms))
}

/// The summary table: per scene (rows) and summary technique (columns), per pixel: relative RMSE % net of the
/// reference's noise against the sphere proxy / against the triangles, and the shade ms.
fn summary_block(stamp: &Stamp, site: &Site, rows: &[Row]) -> Result<String> {
    let mut s = String::new();
    let _ =
        writeln!(s, "{BEGIN}: generated by `{}` at commit {}; do not edit by hand -->", stamp.command, stamp.commit);
    let _ = write!(s, "| scene |");
    for t in &site.summary_techniques {
        let _ = write!(s, " `{t}` |");
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "|---|{}", "---:|".repeat(site.summary_techniques.len()));
    for scene in scenes(rows) {
        let _ = write!(s, "| {scene} |");
        for t in &site.summary_techniques {
            let Some(r) = rows.iter().find(|r| r.scene == scene && r.shading == "pixel" && &r.technique == t) else {
                bail!("summary technique '{t}' was not measured per pixel on '{scene}': add it to the sweep");
            };
            let cell = summary_cell(
                r.vs_spheres.map_or(f64::NAN, |e| e.debiased),
                r.vs_triangles.map_or(f64::NAN, |e| e.debiased),
                r.shade_ms,
            );
            let _ = write!(s, " {cell} |");
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(
        s,
        "\nPer pixel at {}×{}: relative RMSE % net of the reference's noise against the sphere-proxy / the triangle \
         reference · shade ms (median GPU time of the shading passes on {}: compare within a row or a column, not \
         with a real GPU). Generated by `{}` at commit {}; every technique, variant and image: \
         [docs/results](docs/results/README.md).",
        stamp.sweep.width, stamp.sweep.height, stamp.adapter, stamp.command, stamp.commit
    );
    let _ = writeln!(s, "{END}");
    Ok(s)
}

/// Speed against error of the summary techniques per pixel: one series per technique, one point per scene.
fn summary_plot(site: &Site, rows: &[Row]) -> plot::Plot {
    let mut p = plot::Plot::new("speed against error, per pixel (each point a scene)")
        .size(760.0, 440.0)
        .x_axis("shade ms (median GPU time, lavapipe)", plot::Scale::Log10)
        .y_axis("relative RMSE % vs triangles, net of noise", plot::Scale::Log10)
        .legend(plot::Legend::TopRight);
    for t in &site.summary_techniques {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.shading == "pixel" && &r.technique == t)
            .filter_map(|r| r.vs_triangles.map(|e| (r.shade_ms, e.debiased)))
            .filter(|(x, y)| x.is_finite() && *x > 0.0 && y.is_finite() && *y > 0.0)
            .collect();
        if !pts.is_empty() {
            p = p.series(plot::Series::new(t.clone(), pts, plot::Style::Scatter));
        }
    }
    p
}

/// The hero techniques of the hero scene (per pixel) and the triangle reference, side by side, each scaled 3× by
/// pixel repetition, 4 white pixels apart.
fn write_hero(path: &Path, site: &Site, res: &Results) -> Result<()> {
    let Some(scene) = res.images.iter().find(|s| s.scene == site.hero_scene) else {
        bail!("hero scene '{}' is not in the sweep", site.hero_scene)
    };
    let mut tiles: Vec<&PageImage> = Vec::new();
    for t in &site.hero_techniques {
        let Some(img) = scene.images.iter().find(|i| &i.spec == t && i.group == "pixel") else {
            bail!("hero technique '{t}' was not measured per pixel on '{}'", site.hero_scene)
        };
        tiles.push(img);
    }
    tiles.push(scene.images.iter().find(|i| i.spec == "reference/triangles").context("no triangle reference")?);
    let (k, gap) = (3usize, 4usize);
    let (w, h) = (scene.width as usize, scene.height as usize);
    let width = tiles.len() * w * k + (tiles.len() - 1) * gap;
    let mut rgba = vec![255u8; width * h * k * 4];
    for (n, tile) in tiles.iter().enumerate() {
        let x0 = n * (w * k + gap);
        for y in 0..h * k {
            for x in 0..w * k {
                let src = ((y / k) * w + x / k) * 4;
                let dst = (y * width + x0 + x) * 4;
                rgba[dst..dst + 4].copy_from_slice(&tile.ldr[src..src + 4]);
            }
        }
    }
    engine::output::write_png(path, width as u32, (h * k) as u32, &rgba)?;
    Ok(())
}

/// A scene's table rows: technique, shading, errors vs both references (raw / net), FLIP, times.
fn scene_table(rows: &[&Row], html: bool) -> String {
    let mut s = String::new();
    let head = [
        "technique",
        "shading",
        "vs sphere proxy % (net)",
        "vs triangles % (net)",
        "FLIP vs triangles",
        "shade ms",
        "frame ms",
    ];
    if html {
        s.push_str("<table><tr>");
        for h in head {
            let _ = write!(s, "<th>{h}</th>");
        }
        s.push_str("</tr>\n");
    } else {
        let _ = writeln!(s, "| {} |\n|---|---|---:|---:|---:|---:|---:|", head.join(" | "));
    }
    let pair = |e: Option<crate::measure::Errors>| {
        e.map_or("–".into(), |e| format!("{} ({})", pct(e.rmse), pct(e.debiased)))
    };
    for r in rows {
        let cells = [
            r.technique.clone(),
            r.shading.clone(),
            pair(r.vs_spheres),
            pair(r.vs_triangles),
            r.vs_triangles.map_or("–".into(), |e| format!("{:.3}", e.flip)),
            ms(r.shade_ms),
            ms(r.frame_ms),
        ];
        if html {
            s.push_str("<tr>");
            for c in cells {
                let _ = write!(s, "<td>{}</td>", plot::escape(&c));
            }
            s.push_str("</tr>\n");
        } else {
            let _ = writeln!(s, "| `{}` | {} |", cells[0], cells[1..].join(" | "));
        }
    }
    if html {
        s.push_str("</table>\n");
    }
    s
}

fn markdown(stamp: &Stamp, summary: &str, res: &Results) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Results: speed against error\n");
    let _ = writeln!(
        s,
        "{} Re-run it to rewrite every file here (and the summary in the project's README). The same tables \
         with every image, heat maps and an image comparison: [index.html](index.html) (one file, works offline). \
         Data: [results.csv](results.csv), by region [regions.csv](regions.csv).\n",
        stamp.line()
    );
    let _ = writeln!(s, "![the hero scene: techniques and the reference side by side](hero.png)\n");
    // The block as README.md shows it, its link made relative to this folder.
    let here = summary.replace("[docs/results](docs/results/README.md)", "[this page](README.md)");
    let _ = writeln!(s, "## Summary\n\n{here}\n![speed against error](summary.svg)\n");
    let _ = writeln!(s, "## References\n");
    let _ = writeln!(s, "| scene | visibility | spp | rel. std. error % |\n|---|---|---:|---:|");
    for r in &res.references {
        for (vis, x) in [("triangles", Some(&r.triangles)), ("spheres", r.spheres.as_ref())] {
            if let Some(x) = x {
                let _ = writeln!(s, "| {} | {vis} | {} | {:.2} |", r.scene, x.spp, 100.0 * x.relative_stderr);
            }
        }
    }
    for scene in scenes(&res.rows) {
        let rows: Vec<&Row> =
            res.rows.iter().filter(|r| r.scene == scene && !r.technique.starts_with("reference")).collect();
        let _ = writeln!(s, "\n## {scene}\n");
        let _ = writeln!(s, "![{scene}: speed against error](pareto-{}.svg)\n", crate::measure::file_stem(scene));
        s.push_str(&scene_table(&rows, false));
    }
    s
}

fn data_uri(png: &[u8]) -> String {
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png))
}

/// An inline copy of an SVG file written by the report (its XML declaration dropped).
fn inline_svg(path: &Path) -> Result<String> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let start = text.find("<svg").with_context(|| format!("{}: not an SVG file", path.display()))?;
    Ok(text[start..].to_string())
}

const STYLE: &str = r#"
body { font-family: sans-serif; margin: 1.5em; color: #222; max-width: 1400px; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 13px; }
td, th { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
td:first-child, th:first-child { text-align: left; }
#controls { position: sticky; top: 0; background: #f4f4f4; padding: 6px 10px; border: 1px solid #ccc; z-index: 2; }
.gallery { display: flex; flex-wrap: wrap; gap: 10px; }
.cell { border: 1px solid #ddd; padding: 4px; font-size: 12px; }
.cell img { display: block; width: calc(var(--w) * var(--zoom)); height: calc(var(--h) * var(--zoom));
  image-rendering: pixelated; cursor: pointer; }
.row { display: flex; gap: 3px; }
.render { filter: brightness(var(--exposure)); }
.compare { position: relative; width: calc(var(--w) * var(--zoom) * 2); height: calc(var(--h) * var(--zoom) * 2); }
.compare img { position: absolute; left: 0; top: 0; width: 100%; height: 100%; image-rendering: pixelated; }
.split { position: absolute; top: 0; bottom: 0; width: 1px; background: #fff; pointer-events: none; }
svg { max-width: 100%; height: auto; }
"#;

const SCRIPT: &str = r#"
"use strict";
function setExposure(stops) {
  document.documentElement.style.setProperty("--exposure", String(Math.pow(2, stops)));
  document.getElementById("exposure-value").textContent = (stops >= 0 ? "+" : "") + stops + " stops";
}
function setZoom(z) {
  document.documentElement.style.setProperty("--zoom", String(z));
  document.getElementById("zoom-value").textContent = z + "×";
}
function showCompare(scene) {
  const a = document.getElementById("cmp-" + scene + "-a"), b = document.getElementById("cmp-" + scene + "-b");
  const pa = document.getElementById("cmp-" + scene + "-pick-a"), pb = document.getElementById("cmp-" + scene + "-pick-b");
  a.src = document.getElementById(pa.value).src;
  b.src = document.getElementById(pb.value).src;
  const x = document.getElementById("cmp-" + scene + "-slider").value;
  b.style.clipPath = "inset(0 0 0 " + x + "%)";
  document.getElementById("cmp-" + scene + "-split").style.left = x + "%";
  document.getElementById("cmp-" + scene + "-caption").textContent =
    "left: " + pa.options[pa.selectedIndex].text + " | right: " + pb.options[pb.selectedIndex].text;
}
function swapCompare(scene) {
  const pa = document.getElementById("cmp-" + scene + "-pick-a"), pb = document.getElementById("cmp-" + scene + "-pick-b");
  const t = pa.value; pa.value = pb.value; pb.value = t;
  showCompare(scene);
}
function pick(scene, id, side) {
  document.getElementById("cmp-" + scene + "-pick-" + side).value = id;
  showCompare(scene);
}
document.addEventListener("DOMContentLoaded", function () {
  document.getElementById("exposure").addEventListener("input", function (e) { setExposure(Number(e.target.value)); });
  document.getElementById("zoom").addEventListener("input", function (e) { setZoom(Number(e.target.value)); });
  for (const box of document.querySelectorAll(".compare-box")) {
    const scene = box.dataset.scene;
    for (const part of ["pick-a", "pick-b", "slider"]) {
      document.getElementById("cmp-" + scene + "-" + part).addEventListener("input", function () { showCompare(scene); });
    }
    document.getElementById("cmp-" + scene + "-swap").addEventListener("click", function () { swapCompare(scene); });
    showCompare(scene);
  }
  for (const img of document.querySelectorAll(".gallery img")) {
    img.addEventListener("click", function (e) { pick(img.dataset.scene, img.id, e.shiftKey ? "a" : "b"); });
  }
  setExposure(0);
  setZoom(2);
});
"#;

fn html(out: &Path, stamp: &Stamp, summary: &str, res: &Results) -> Result<String> {
    let e = plot::escape;
    let mut s = String::new();
    let _ = writeln!(s, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">");
    let _ = writeln!(s, "<title>softshadows results: speed against error</title>");
    let _ = writeln!(s, "<style>{STYLE}</style>\n<script>{SCRIPT}</script></head><body>");
    let _ = writeln!(s, "<h1>Speed against error</h1>");
    let _ = writeln!(s, "<p id=\"stamp\">{}</p>", e(&stamp.line()));
    let _ = writeln!(
        s,
        "<div id=\"controls\">exposure <input id=\"exposure\" type=\"range\" min=\"-4\" max=\"4\" step=\"0.5\" \
         value=\"0\"> <span id=\"exposure-value\"></span> (brightness of the tone-mapped renders, ×2<sup>stops</sup>) \
         &nbsp; zoom <input id=\"zoom\" type=\"range\" min=\"1\" max=\"8\" step=\"1\" value=\"2\"> \
         <span id=\"zoom-value\"></span> &nbsp; Click an image to show it on the right of its scene's comparison, \
         shift-click for the left.</div>"
    );
    let _ = writeln!(s, "<h2>Summary</h2>");
    // The summary table, from its Markdown (the same numbers README.md shows).
    s.push_str(&summary_html(summary));
    let _ = writeln!(s, "{}", inline_svg(&out.join("summary.svg"))?);
    let _ = writeln!(s, "<p>Scenes: {}</p>", {
        let links: Vec<String> = res.images.iter().map(|i| format!("<a href=\"#{0}\">{0}</a>", e(&i.scene))).collect();
        links.join(" · ")
    });
    for scene in &res.images {
        let stem = crate::measure::file_stem(&scene.scene);
        let id = |n: usize, kind: &str| format!("img-{stem}-{n}-{kind}");
        let _ = writeln!(
            s,
            "<section id=\"{}\" style=\"--w: {}px; --h: {}px\"><h2>{}</h2>",
            e(&scene.scene),
            scene.width,
            scene.height,
            e(&scene.scene)
        );
        // The comparison: A under B, B clipped from the left at the slider.
        let mut options = String::new();
        for (n, img) in scene.images.iter().enumerate() {
            let _ = write!(options, "<option value=\"{}\">{}</option>", id(n, "render"), e(&img.label));
            for (kind, heat, what) in
                [("tri", &img.heat_triangles, "triangles"), ("sph", &img.heat_spheres, "sphere proxy")]
            {
                if heat.is_some() {
                    let _ =
                        write!(options, "<option value=\"{}\">{} error vs {what}</option>", id(n, kind), e(&img.label));
                }
            }
        }
        let first_technique = scene.images.iter().position(|i| i.group != "reference").unwrap_or(0);
        let _ = writeln!(
            s,
            "<div class=\"compare-box\" data-scene=\"{stem}\"><p>Compare: left <select id=\"cmp-{stem}-pick-a\">{options}</select> \
             right <select id=\"cmp-{stem}-pick-b\">{options}</select> \
             <button id=\"cmp-{stem}-swap\" type=\"button\">swap left and right</button> \
             split <input id=\"cmp-{stem}-slider\" type=\"range\" min=\"0\" max=\"100\" value=\"50\"></p>\
             <div class=\"compare\" id=\"cmp-{stem}\"><img id=\"cmp-{stem}-a\" class=\"render\" alt=\"left image\">\
             <img id=\"cmp-{stem}-b\" class=\"render\" alt=\"right image\"><div class=\"split\" id=\"cmp-{stem}-split\"></div></div>\
             <p id=\"cmp-{stem}-caption\"></p></div>"
        );
        // Preselect: the triangle reference on the left, the first technique on the right.
        let _ = writeln!(
            s,
            "<script>document.addEventListener(\"DOMContentLoaded\", function () {{ \
             document.getElementById(\"cmp-{stem}-pick-a\").value = \"{}\"; \
             document.getElementById(\"cmp-{stem}-pick-b\").value = \"{}\"; showCompare(\"{stem}\"); }});</script>",
            id(0, "render"),
            id(first_technique, "render")
        );
        let _ = writeln!(s, "<div class=\"gallery\">");
        for (n, img) in scene.images.iter().enumerate() {
            let _ = write!(s, "<div class=\"cell\"><div class=\"row\">");
            let _ = write!(
                s,
                "<img id=\"{}\" class=\"render\" data-scene=\"{stem}\" src=\"{}\" alt=\"{}\" title=\"{}\">",
                id(n, "render"),
                data_uri(&img.png),
                e(&img.label),
                e(&img.label)
            );
            for (kind, heat, what) in
                [("tri", &img.heat_triangles, "triangles"), ("sph", &img.heat_spheres, "sphere proxy")]
            {
                if let Some(h) = heat {
                    let t = format!("{} error vs {what}", img.label);
                    let _ = write!(
                        s,
                        "<img id=\"{}\" data-scene=\"{stem}\" src=\"{}\" alt=\"{}\" title=\"{}\">",
                        id(n, kind),
                        data_uri(h),
                        e(&t),
                        e(&t)
                    );
                }
            }
            let _ = writeln!(s, "</div>{}</div>", e(&img.label));
        }
        let _ = writeln!(s, "</div>");
        let _ = writeln!(
            s,
            "<p>Each image, then |image − triangle reference| and |image − sphere-proxy reference| (a tenth of the \
             reference's maximum is white).</p>"
        );
        let _ = writeln!(s, "{}", inline_svg(&out.join(format!("pareto-{stem}.svg")))?);
        let rows: Vec<&Row> =
            res.rows.iter().filter(|r| r.scene == scene.scene && !r.technique.starts_with("reference")).collect();
        s.push_str(&scene_table(&rows, true));
        let _ = writeln!(s, "</section>");
    }
    let _ = writeln!(s, "</body></html>");
    Ok(s)
}

/// The summary block's Markdown table as an HTML table (its caption line as a paragraph).
fn summary_html(summary: &str) -> String {
    let mut s = String::from("<table>\n");
    let mut text = String::new();
    for line in summary.lines().filter(|l| !l.starts_with("<!--")) {
        if line.starts_with("|---") {
            continue;
        }
        if let Some(cells) = line.strip_prefix('|') {
            let tag = if s == "<table>\n" { "th" } else { "td" };
            s.push_str("<tr>");
            for c in cells.trim_end_matches('|').split('|') {
                let _ = write!(s, "<{tag}>{}</{tag}>", plot::escape(c.trim().trim_matches('`')));
            }
            s.push_str("</tr>\n");
        } else if !line.trim().is_empty() {
            text.push_str(line);
        }
    }
    let cut = text.find("; every technique, variant").unwrap_or(text.len());
    let _ = write!(s, "</table>\n<p>{}</p>\n", plot::escape(&text[..cut]));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block between the markers is replaced whole, the text around it kept; a file without the markers is
    /// an error, not a silent append.
    #[test]
    fn splice_replaces_the_marked_block() {
        let text = format!("# T\n\n{BEGIN}: old -->\n| a |\n{END}\n\nafter\n");
        let block = format!("{BEGIN}: new -->\n| b |\n{END}\n");
        let out = splice(&text, &block).unwrap();
        assert_eq!(out, format!("# T\n\n{BEGIN}: new -->\n| b |\n{END}\n\nafter\n"));
        assert_eq!(block_of(&out), Some(block.trim_end()));
        assert!(splice("# no markers\n", &block).is_err());
        assert!(splice(&format!("{BEGIN} -->\nno end\n"), &block).is_err());
    }
}
