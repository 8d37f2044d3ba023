//! `morphlod bench --plot`: the bench rows as a picture for the README — per sweep, GPU frame
//! time of the LOD strips, the same LOD as a list and full detail (left axis), and the
//! triangles the strips draw (right axis), over the sweep's frames. With `--crowd`, the crowd
//! bench's modes (LOD, full detail, discrete LODs) per measured frame: CPU time, GPU time and
//! triangles, one panel each on a log scale (the modes differ by orders of magnitude).
//!
//! With `--baselines`, the LodStrips paper's Fig. 1: vertices and strips sent per frame of the
//! linear test by every model.
//!
//! plotters draws into an RGB buffer and `image` writes the PNG, so the two crates share one
//! encoder; labels use the embedded font because CI machines have no system fonts.

use std::path::Path;

use crate::bench::{BenchReport, FrameRow, Sweep};
use crate::bench_baselines::BaselinesReport;
use morphlod::gpu::{CrowdBenchReport, FrameFigures};
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

const FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSansMono.ttf");
const FAMILY: &str = "morphlod-mono";
const WIDTH: u32 = 1200;
const PANEL_HEIGHT: u32 = 420;

/// One drawn quantity: its colour, legend and how to read it off a row.
struct Series {
    colour: RGBColor,
    label: &'static str,
    value: fn(&FrameRow) -> f64,
}

const TIMES: [Series; 5] = [
    Series {
        colour: RGBColor(31, 119, 180),
        label: "LOD strips",
        value: |row| row.strips_ms,
    },
    Series {
        colour: RGBColor(255, 127, 14),
        label: "same LOD, triangle list",
        value: |row| row.list_ms,
    },
    Series {
        colour: RGBColor(44, 160, 44),
        label: "full detail, strips S0 (grouped)",
        value: |row| row.full_strips_ms,
    },
    Series {
        colour: RGBColor(214, 39, 40),
        label: "full detail, triangle list",
        value: |row| row.full_list_ms,
    },
    Series {
        colour: RGBColor(140, 86, 75),
        label: "full detail, one draw per strip",
        value: |row| row.full_per_strip_ms,
    },
];

const TRIANGLES: RGBColor = RGBColor(148, 103, 189);

/// Draws one panel per sweep present in `report` and writes them as one PNG at `path`.
pub fn write_plot(report: &BenchReport, path: &Path) -> Result<(), String> {
    let sweeps: Vec<Sweep> = [Sweep::Linear, Sweep::Exponential]
        .into_iter()
        .filter(|&sweep| report.rows.iter().any(|row| row.sweep == sweep))
        .collect();
    if sweeps.is_empty() {
        return Err("the bench report has no rows to plot".into());
    }
    write_panels(path, sweeps.len(), |panel, i| {
        let rows: Vec<&FrameRow> = report
            .rows
            .iter()
            .filter(|r| r.sweep == sweeps[i])
            .collect();
        draw_panel(panel, report, sweeps[i], &rows)
    })
}

/// Draws `count` panels, one above the other, with `draw(panel, i)` and writes them as one
/// PNG at `path`.
fn write_panels(
    path: &Path,
    count: usize,
    mut draw: impl FnMut(&Panel<'_>, usize) -> Result<(), Box<dyn std::error::Error>>,
) -> Result<(), String> {
    // Registering twice only replaces the same face, so repeated calls are harmless.
    register_font(FAMILY, FontStyle::Normal, FONT)
        .map_err(|_| "the embedded plot font could not be parsed".to_string())?;
    let height = PANEL_HEIGHT * count as u32;
    let mut pixels = vec![255u8; (WIDTH * height * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (WIDTH, height)).into_drawing_area();
        for (i, panel) in root.split_evenly((count, 1)).iter().enumerate() {
            draw(panel, i).map_err(|e| format!("plot: {e}"))?;
        }
        root.present().map_err(|e| format!("plot: {e}"))?;
    }
    let image = image::RgbImage::from_raw(WIDTH, height, pixels)
        .ok_or("plot: the pixel buffer does not match the image size")?;
    image
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// One panel of a figure.
type Panel<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// The legend every chart here has: top right, on a light box.
fn draw_legend<'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, BitMapBackend<'a>, CT>,
) -> Result<(), Box<dyn std::error::Error>> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FAMILY, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

fn draw_panel(
    area: &Panel<'_>,
    report: &BenchReport,
    sweep: Sweep,
    rows: &[&FrameRow],
) -> Result<(), Box<dyn std::error::Error>> {
    let frames = rows.len().max(2) as f64 - 1.0;
    let max_ms = rows
        .iter()
        .flat_map(|row| TIMES.iter().map(move |s| (s.value)(row)))
        .fold(0.0f64, f64::max)
        .max(1e-3)
        * 1.1;
    let max_triangles = report.full_triangles.max(1) as f64 * 1.05;
    let caption = format!(
        "{} sweep: {} ({}), {} vertices, {} triangles at full detail",
        sweep.name(),
        report.adapter,
        report.device_type,
        report.vertices,
        report.full_triangles
    );
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FAMILY, 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .right_y_label_area_size(80)
        .build_cartesian_2d(0.0..frames, 0.0..max_ms)?
        .set_secondary_coord(0.0..frames, 0.0..max_triangles);
    chart
        .configure_mesh()
        .x_desc("frame of the sweep (t from 0 to 1, LOD coarsening)")
        .y_desc("GPU frame time, ms")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y:.1}"))
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    chart
        .configure_secondary_axes()
        .y_desc("triangles drawn (LOD strips)")
        .y_label_formatter(&|y| format!("{y:.0}"))
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .draw()?;
    for series in &TIMES {
        let points = rows
            .iter()
            .enumerate()
            .map(|(i, row)| (i as f64, (series.value)(row)));
        let style = series.colour.stroke_width(2);
        chart
            .draw_series(LineSeries::new(points, style))?
            .label(series.label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
    }
    let triangles = rows
        .iter()
        .enumerate()
        .map(|(i, row)| (i as f64, row.triangles as f64));
    let style = TRIANGLES.stroke_width(1);
    chart
        .draw_secondary_series(LineSeries::new(triangles, style))?
        .label("triangles (right axis)")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
    draw_legend(&mut chart)
}

/// Colours of the crowd bench's modes, by name; others grey.
fn mode_colour(mode: &str) -> RGBColor {
    match mode {
        "lod" => RGBColor(31, 119, 180),
        "full" => RGBColor(214, 39, 40),
        "discrete" => RGBColor(44, 160, 44),
        _ => RGBColor(127, 127, 127),
    }
}

/// A figure of a crowd frame.
type Figure = fn(&FrameFigures) -> f64;

/// The crowd bench's panels: what each plots of a frame.
const CROWD_PANELS: [(&str, Figure); 3] = [
    ("CPU set + prepare + record, ms", |f| f.cpu_ms),
    ("GPU time, ms", |f| f.gpu_ms),
    ("triangles drawn", |f| f.triangles),
];

/// The crowd bench's modes per frame, one panel per figure, written as one PNG at `path`.
pub fn write_crowd_plot(report: &CrowdBenchReport, path: &Path) -> Result<(), String> {
    if report.modes.iter().all(|m| m.frames.is_empty()) {
        return Err("the crowd report has no frames to plot".into());
    }
    write_panels(path, CROWD_PANELS.len(), |panel, i| {
        let (label, value) = CROWD_PANELS[i];
        let label = label.replace("GPU time", &format!("GPU time ({})", report.gpu_timing));
        draw_crowd_panel(panel, report, &label, value)
    })
}

fn draw_crowd_panel(
    area: &Panel<'_>,
    report: &CrowdBenchReport,
    label: &str,
    value: Figure,
) -> Result<(), Box<dyn std::error::Error>> {
    let frames = report
        .modes
        .iter()
        .map(|m| m.frames.len())
        .max()
        .unwrap_or(0);
    let values = || report.modes.iter().flat_map(|m| m.frames.iter().map(value));
    // A log axis needs positive bounds (a zero is drawn at the bottom); whole decades, so
    // the axis has labels however narrow the figures' range.
    let low = values().filter(|&v| v > 0.0).fold(f64::MAX, f64::min);
    let low = if low == f64::MAX { 1e-3 } else { low };
    let high = values().fold(low, f64::max);
    let (low, high) = (
        10f64.powf(low.log10().floor()),
        10f64.powf((high.log10() + 1e-9).ceil()),
    );
    let caption = format!(
        "crowd of {} x {} vertices on {}: {label}",
        report.instances, report.vertices, report.adapter
    );
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FAMILY, 16))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..(frames.max(2) - 1) as f64, (low..high).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("measured frame")
        .y_desc(label)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|&y| match y {
            y if y >= 1e6 => format!("{:.0}M", y / 1e6),
            y if y >= 1e3 => format!("{:.0}k", y / 1e3),
            y if y >= 1.0 => format!("{y:.0}"),
            y => format!("{y:.3}"),
        })
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for mode in &report.modes {
        let points = mode
            .frames
            .iter()
            .enumerate()
            .map(|(i, f)| (i as f64, value(f).max(low)));
        let style = mode_colour(mode.mode).stroke_width(2);
        chart
            .draw_series(LineSeries::new(points, style))?
            .label(mode.mode)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
    }
    draw_legend(&mut chart)
}

/// Colours of the baselines' models, by name.
fn model_colour(model: &str) -> RGBColor {
    match model {
        "LodStrips" => RGBColor(31, 119, 180),
        "MTS" => RGBColor(255, 127, 14),
        "PM" => RGBColor(214, 39, 40),
        _ => RGBColor(44, 160, 44),
    }
}

/// The LodStrips paper's Fig. 1 for `report`: (a) vertices and (b) strips sent over the
/// linear test's LOD fraction, one line per model (PM sends no strips), written at `path`.
pub fn write_baselines_plot(report: &BaselinesReport, path: &Path) -> Result<(), String> {
    let linear: Vec<_> = report
        .rows
        .iter()
        .filter(|r| r.test == Sweep::Linear)
        .collect();
    if linear.is_empty() {
        return Err("the baselines report has no rows to plot".into());
    }
    type Value = fn(&crate::bench_baselines::BaselineRow) -> f64;
    let panels: [(&str, Value, bool); 2] = [
        ("(a) vertices sent", |r| r.vertices as f64, true),
        ("(b) strips sent", |r| r.strips as f64, false),
    ];
    write_panels(path, panels.len(), |area, i| {
        let (label, value, with_pm) = panels[i];
        let rows: Vec<_> = linear
            .iter()
            .filter(|r| with_pm || r.model != "PM")
            .collect();
        let top = rows
            .iter()
            .map(|r| value(r))
            .fold(0.0f64, f64::max)
            .max(1.0)
            * 1.05;
        // MTS and Skip Strips build the same display strips, so their lines coincide.
        let caption = format!(
            "{label} by {} in the linear test ({} triangles; MTS under Skip Strips)",
            report.mesh, report.triangles
        );
        let mut chart = ChartBuilder::on(area)
            .caption(caption, (FAMILY, 18))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..1.0, 0.0..top)?;
        chart
            .configure_mesh()
            .x_desc("LOD (0 full detail, 1 the coarsest)")
            .y_desc(label)
            .x_label_formatter(&|x| format!("{x:.1}"))
            .y_label_formatter(&|y| format!("{y:.0}"))
            .label_style((FAMILY, 13))
            .axis_desc_style((FAMILY, 14))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        for s in &report.sizes {
            if !with_pm && s.model == "PM" {
                continue;
            }
            let points = rows
                .iter()
                .filter(|r| r.model == s.model)
                .map(|r| (r.lod as f64 / report.max_lod.max(1) as f64, value(r)));
            let style = model_colour(s.model).stroke_width(2);
            chart
                .draw_series(LineSeries::new(points, style))?
                .label(s.model)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
        }
        draw_legend(&mut chart)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(sweep: Sweep, frame: usize) -> FrameRow {
        let x = frame as f64;
        FrameRow {
            sweep,
            frame,
            t: frame as f32 / 9.0,
            lod: frame as f32 / 9.0,
            asset_frame: frame / 3,
            steps: frame * 10,
            triangles: 1000 - frame * 100,
            indices: 1200 - frame * 110,
            set_us: 1.0,
            prepare_us: 1.0,
            built_ahead: false,
            upload_bytes: 64,
            draws: 1,
            strips_ms: 3.0 - 0.2 * x,
            list_triangles: 1000 - frame * 100,
            list_build_us: 1.0,
            list_upload_bytes: 128,
            list_ms: 2.5 - 0.2 * x,
            full_strips_ms: 3.0,
            full_per_strip_ms: 3.4,
            faceted_ms: 1.0,
            full_list_ms: 2.8,
            records: 1,
            upload_writes: 2,
        }
    }

    fn report(rows: Vec<FrameRow>) -> BenchReport {
        BenchReport {
            adapter: "test adapter".into(),
            backend: "Vulkan".into(),
            device_type: "Cpu".into(),
            vertices: 500,
            full_triangles: 1000,
            full_index_bytes: 4800,
            rows,
        }
    }

    #[test]
    fn plot_has_one_panel_per_sweep_with_every_series_drawn() {
        let rows = (0..10)
            .map(|i| row(Sweep::Linear, i))
            .chain((0..10).map(|i| row(Sweep::Exponential, i)))
            .collect();
        let dir = std::env::temp_dir().join(format!("morphlod-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("plot.png");
        write_plot(&report(rows), &path).unwrap();
        let image = image::open(&path).unwrap().to_rgb8();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(image.dimensions(), (WIDTH, 2 * PANEL_HEIGHT));
        // Every series' colour appears in both panels left of the legend (upper right), so
        // the lines were drawn, not only their legend samples.
        for half in 0..2 {
            let rows = half * PANEL_HEIGHT..(half + 1) * PANEL_HEIGHT;
            let colours: Vec<RGBColor> =
                TIMES.iter().map(|s| s.colour).chain([TRIANGLES]).collect();
            for colour in colours {
                let found = rows.clone().any(|y| {
                    (0..WIDTH * 2 / 3)
                        .any(|x| image.get_pixel(x, y).0 == [colour.0, colour.1, colour.2])
                });
                assert!(found, "colour {colour:?} missing in panel {half}");
            }
        }
    }

    #[test]
    fn crowd_plot_draws_every_mode_in_every_panel() {
        // Each mode apart from the others in every figure, so no line hides another.
        let modes = [("lod", 1.0), ("full", 30.0), ("discrete", 3.0)].map(|(mode, scale)| {
            morphlod::gpu::ModeFigures {
                mode,
                frames: (0..8)
                    .map(|i| FrameFigures {
                        cpu_ms: scale * (1.0 + 0.1 * i as f64),
                        gpu_ms: scale * 20.0,
                        triangles: scale * 1e4,
                        ..Default::default()
                    })
                    .collect(),
                ..Default::default()
            }
        });
        let report = CrowdBenchReport {
            adapter: "test adapter".into(),
            instances: 9,
            modes: modes.to_vec(),
            ..Default::default()
        };
        let path = std::env::temp_dir().join(format!("morphlod-crowd-{}.png", std::process::id()));
        write_crowd_plot(&report, &path).unwrap();
        let image = image::open(&path).unwrap().to_rgb8();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(image.dimensions(), (WIDTH, 3 * PANEL_HEIGHT));
        for panel in 0..3 {
            for mode in ["lod", "full", "discrete"] {
                let c = mode_colour(mode);
                let found = (panel * PANEL_HEIGHT..(panel + 1) * PANEL_HEIGHT).any(|y| {
                    (0..WIDTH * 2 / 3).any(|x| image.get_pixel(x, y).0 == [c.0, c.1, c.2])
                });
                assert!(found, "mode {mode} missing in panel {panel}");
            }
        }
    }

    #[test]
    fn a_report_without_rows_is_an_error_not_an_empty_picture() {
        let path = std::env::temp_dir().join("morphlod-never-written.png");
        let error = write_plot(&report(Vec::new()), &path).unwrap_err();
        assert!(error.contains("no rows"), "{error}");
        assert!(!path.exists());
    }
}
