//! Headless: a frame sequence rendered offscreen ([`RenderTarget`]) into numbered PNGs.

use std::path::{Path, PathBuf};
use std::time::Instant;

use morphlod::gpu::{save_png, Context, RenderTarget};

use super::cache::Library;
use super::scene::{LodControl, Scene};
use super::{CommonArgs, Demo, DemoError, CLEAR};

/// The coarsest LOD fraction the headless sweep reaches: at 1.0 a mesh simplified "to the end"
/// has almost nothing left to look at.
const HEADLESS_COARSEST: f32 = 0.97;

pub fn run_headless(
    demo: &Demo,
    args: &CommonArgs,
    library: &Library,
    out: &Path,
) -> Result<(), DemoError> {
    let context = Context::headless().map_err(DemoError::lib)?;
    let info = context.adapter_info();
    let (width, height) = args.size;
    let device = &context.device;
    let queue = &context.queue;
    let target = RenderTarget::new(device, width, height, CLEAR).map_err(DemoError::lib)?;
    let mut scene = Scene::new(
        device,
        queue,
        &info,
        RenderTarget::COLOR_FORMAT,
        library,
        args,
    )?;
    for &command in &args.keys {
        scene.apply(device, command)?;
    }
    scene.view.playing = false;
    scene.show_keys = false;
    let frames = args.frames;
    println!(
        "{}: rendering {frames} frames of '{}' headless on {} ({:?}), {width}x{height}",
        demo.name,
        library.label(scene.current),
        info.name,
        info.backend
    );
    remove_old_frames(out)?;
    let mut first = None;
    let mut last = PathBuf::new();
    // The resident set after the warm-up frames (pipelines, caches, staging pools fill up) and
    // at the end: the loop must not grow with the number of frames.
    let warm_up = (frames / 10).max(1);
    let mut warm_resident = None;
    for i in 0..frames {
        // The bench's linear sweep: t runs 0 → 1 while the LOD coarsens with it.
        let x = if frames > 1 {
            i as f32 / (frames - 1) as f32
        } else {
            0.0
        };
        scene.view.t = x;
        scene.view.lod = LodControl::Fraction(HEADLESS_COARSEST * x);
        let status = format!("{}  headless frame {}/{frames}", demo.name, i + 1);
        let start = Instant::now();
        let mut encoder = device.create_command_encoder(&Default::default());
        scene.update(device, queue, &mut encoder, (width, height), &status)?;
        {
            let mut pass = target.begin_pass(&mut encoder);
            scene.draw(&mut pass)?;
        }
        queue.submit([encoder.finish()]);
        let image = target.read_image(device, queue).map_err(DemoError::lib)?;
        let path = out.join(format!("frame_{i:04}.png"));
        save_png(&image, &path).map_err(DemoError::lib)?;
        let state = scene.object.object.state();
        println!(
            "  {} t {:.3} k {:2} lod {:5} triangles {:6} indices {:6} uploaded {:7} B  {:.1} ms",
            path.display(),
            x,
            state.frame(),
            state.lod(),
            state.triangle_count(),
            state.index_count(),
            scene.last.upload.bytes(),
            start.elapsed().as_secs_f64() * 1e3
        );
        first.get_or_insert_with(|| path.clone());
        last = path;
        if i + 1 == warm_up {
            warm_resident = resident_mb();
        }
    }
    check_growth(
        demo.name,
        warm_resident,
        warm_up,
        frames,
        args.max_growth_mb,
    )?;
    if let Some(first) = first {
        println!(
            "{}: {frames} frames written: {} .. {}",
            demo.name,
            first.display(),
            last.display()
        );
    }
    Ok(())
}

/// Deletes the `frame_NNNN.png` files of an earlier run, so a shorter sequence does not leave
/// a longer one's tail behind it. Nothing else in `out` is touched.
pub fn remove_old_frames(out: &Path) -> Result<(), DemoError> {
    let io = |source| DemoError::Io {
        path: out.to_path_buf(),
        source,
    };
    for entry in std::fs::read_dir(out).map_err(io)? {
        let path = entry.map_err(io)?.path();
        let is_frame = path
            .file_name()
            .and_then(|name| name.to_str())
            .and_then(|name| name.strip_prefix("frame_")?.strip_suffix(".png"))
            .is_some_and(|number| number.len() == 4 && number.bytes().all(|b| b.is_ascii_digit()));
        if is_frame {
            std::fs::remove_file(&path).map_err(|source| DemoError::Io { path, source })?;
        }
    }
    Ok(())
}

/// Prints the resident set at the end of a headless run against `warm_resident` (taken after
/// frame `warm_up`) and fails with [`DemoError::MemoryGrowth`] when it grew by more than
/// `bound_mb`. Nothing is checked where the resident set cannot be read (not Linux).
pub fn check_growth(
    name: &str,
    warm_resident: Option<f64>,
    warm_up: u32,
    frames: u32,
    bound_mb: Option<f64>,
) -> Result<(), DemoError> {
    let (Some(before), Some(after)) = (warm_resident, resident_mb()) else {
        return Ok(());
    };
    let growth_mb = after - before;
    println!(
        "{name}: resident set {before:.1} MB after frame {warm_up}, {after:.1} MB after frame {frames}"
    );
    match bound_mb.filter(|&bound| growth_mb > bound) {
        Some(bound_mb) => Err(DemoError::MemoryGrowth {
            growth_mb,
            bound_mb,
            from: warm_up,
            to: frames,
        }),
        None => Ok(()),
    }
}

/// The process's resident set in MB (`/proc/self/statm`, 4 KiB pages), or `None` off Linux.
pub fn resident_mb() -> Option<f64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: f64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096.0 / 1e6)
}
