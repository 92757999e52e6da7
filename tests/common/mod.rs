//! Shared by the scene tests: opening a shipped preset in a temporary cache.
use codimfx::sim::{RunOptions, Sim};
use tempfile::TempDir;

/// Opens `presets/NAME.yaml`, its text passed through `edit`, in a fresh
/// temporary cache folder (returned with the run: it lives as long as the
/// caller keeps it) to run to frame `frames` at resolution scale `scale`
/// (`None`: the preset's own).
pub fn open_preset(
    name: &str,
    frames: u32,
    scale: Option<f64>,
    edit: impl FnOnce(String) -> String,
) -> (Sim, TempDir) {
    let tmp = tempfile::tempdir().unwrap();
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("presets")
        .join(format!("{name}.yaml"));
    let text = edit(std::fs::read_to_string(&scene).unwrap());
    let sim = Sim::open_text(
        &text,
        &scene,
        &RunOptions {
            out_root: Some(tmp.path().to_path_buf()),
            frames: Some(frames),
            resume: false,
            scale,
            verbose: false,
        },
    )
    .unwrap();
    (sim, tmp)
}
