//! The crowd bench's report as a table and as JSON.

use super::{CrowdBenchReport, ModeFigures, Stat};

impl CrowdBenchReport {
    /// A table: one row per mode, mean and p95 of every time and byte figure, means of the
    /// counts, and the screen error drawn (mean over the frames of each frame's mean, and the
    /// largest).
    pub fn summary(&self) -> String {
        let mut out = format!(
            "crowd of {} x {} vertices ({} sampled frames), scene {}, on {}; path {}; GPU time: {}\n\
             per instance: {:.2} KB host, {:.2} KB GPU; shared asset: {:.1} MB GPU\n\
             spawning: adding every instance {:.2} ms, the first frame's set + prepare {:.2} ms and {:.1} KB uploaded\n\
             mode      set ms (p95)    prepare ms (p95)  record ms (p95)   GPU ms (p95)      pass ms (p95)     wait ms (p95)     upload KB (p95)   writes  triangles  switches  LOD steps  draws  indices  regions copies  tails culled  GPU MB  error px (max)\n",
            self.instances,
            self.vertices,
            self.frames_sampled,
            self.scene,
            self.adapter,
            self.path,
            self.gpu_timing,
            self.host_bytes_per_instance / 1e3,
            self.gpu_bytes_per_instance / 1e3,
            self.shared_gpu_bytes as f64 / 1e6,
            self.spawn_ms,
            self.first_frame_ms,
            self.first_frame_bytes as f64 / 1e3,
        );
        for m in &self.modes {
            let pair = |s: Stat| format!("{:7.2} ({:6.2})", s.mean, s.p95);
            out += &format!(
                "{:9} {}  {}  {}  {}  {}  {}  {:8.1} ({:7.1}) {:6.1} {:10.0} {:9.1} {:10.1} {:6.1} {:8.0} {:7.1} {:6.1} {:6.1} {:6.1} {:7.1}  {:5.2} ({:5.2})\n",
                m.mode,
                pair(m.set_ms),
                pair(m.prepare_ms),
                pair(m.record_ms),
                pair(m.gpu_ms),
                pair(m.pass_ms),
                pair(m.wait_ms),
                m.uploaded_bytes.mean / 1e3,
                m.uploaded_bytes.p95 / 1e3,
                m.writes.mean,
                m.triangles.mean,
                m.frame_switches.mean,
                m.lod_steps.mean,
                m.draws.mean,
                m.indices.mean,
                m.from_regions.mean,
                m.from_copies.mean,
                m.from_tails.mean,
                m.culled.mean,
                m.gpu_bytes.mean / 1e6,
                m.error_px.mean,
                m.max_error_px,
            );
        }
        for (l, level) in self.levels.iter().enumerate() {
            out += &format!(
                "discrete level {l}: {:.4} of the triangles, {} triangles, error {:.3e}, {:.1} instances\n",
                level.fraction, level.triangles, level.error, level.instances
            );
        }
        out
    }

    /// The report as one JSON object: every mode's figures (mean and p95) and frames, the
    /// discrete levels.
    pub fn to_json(&self) -> String {
        let modes: Vec<serde_json::Value> = self.modes.iter().map(mode_json).collect();
        serde_json::json!({
            "adapter": self.adapter,
            "instances": self.instances,
            "scene": self.scene,
            "vertices": self.vertices,
            "frames_sampled": self.frames_sampled,
            "gpu_timing": self.gpu_timing,
            "path": self.path,
            "host_bytes_per_instance": self.host_bytes_per_instance,
            "gpu_bytes_per_instance": self.gpu_bytes_per_instance,
            "shared_gpu_bytes": self.shared_gpu_bytes,
            "spawn_ms": self.spawn_ms,
            "first_frame_ms": self.first_frame_ms,
            "first_frame_bytes": self.first_frame_bytes,
            "frame_columns": [
                "cpu_ms", "gpu_ms", "triangles", "uploaded_bytes", "error_px", "max_error_px"
            ],
            "modes": modes,
            "levels": self
                .levels
                .iter()
                .map(|l| serde_json::json!({
                    "fraction": l.fraction,
                    "triangles": l.triangles,
                    "error": l.error,
                    "instances": l.instances,
                }))
                .collect::<Vec<_>>(),
        })
        .to_string()
    }
}

/// One mode's figures as JSON.
fn mode_json(m: &ModeFigures) -> serde_json::Value {
    let stat = |s: Stat| serde_json::json!({ "mean": s.mean, "p95": s.p95 });
    serde_json::json!({
        "mode": m.mode,
        "set_ms": stat(m.set_ms),
        "prepare_ms": stat(m.prepare_ms),
        "record_ms": stat(m.record_ms),
        "gpu_ms": stat(m.gpu_ms),
        "pass_ms": stat(m.pass_ms),
        "wait_ms": stat(m.wait_ms),
        "uploaded_bytes": stat(m.uploaded_bytes),
        "writes": stat(m.writes),
        "triangles": stat(m.triangles),
        "indices": stat(m.indices),
        "frame_switches": stat(m.frame_switches),
        "lod_steps": stat(m.lod_steps),
        "draws": stat(m.draws),
        "culled": stat(m.culled),
        "from_regions": stat(m.from_regions),
        "from_copies": stat(m.from_copies),
        "from_tails": stat(m.from_tails),
        "gpu_bytes": stat(m.gpu_bytes),
        "error_px": stat(m.error_px),
        "max_error_px": m.max_error_px,
        "frames": m
            .frames
            .iter()
            .map(|f| {
                serde_json::json!([
                    f.cpu_ms,
                    f.gpu_ms,
                    f.triangles,
                    f.uploaded_bytes,
                    f.error_px,
                    f.max_error_px
                ])
            })
            .collect::<Vec<_>>(),
    })
}
